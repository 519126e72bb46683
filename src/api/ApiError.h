// ApiError.h: an error with its C ABI status code, thrown inside the API layer and turned into
// a NimbusStatus and the thread's last-error message at the entry point (CApi.cpp).
#pragma once

#include "nimbus.h"

#include <stdexcept>
#include <string>

namespace nimbus::api {

class ApiError : public std::runtime_error {
public:
    ApiError(NimbusStatus status, const std::string& message) : std::runtime_error(message), mStatus(status) {}
    NimbusStatus status() const { return mStatus; }

private:
    NimbusStatus mStatus;
};

// The status for a scene-format InputError message: the JSON reader's wording tells an unknown
// key ("unknown key") and a type error ("expected X, got Y") from every other bad value. The
// C ABI tests pin this mapping (tests/api/test_capi_misuse.c).
NimbusStatus classifyInputError(const std::string& message);

}  // namespace nimbus::api
