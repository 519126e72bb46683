// Error.h: the error types library code throws; the CLI and the C ABI turn them into one line
// and an exit or error code. Library code never terminates the process (STYLE rule 8).
#pragma once

#include <stdexcept>
#include <string>

namespace nimbus {

// A render failure: something went wrong that is not the user's input (exit code 1).
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Bad user input: a missing file or grid, bad JSON, an unknown key, a value out of range
// (exit code 2). The message names the file and the key path.
class InputError : public Error {
public:
    using Error::Error;
};

}  // namespace nimbus
