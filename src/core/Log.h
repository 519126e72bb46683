// Log.h: warnings and info lines go to stderr through one sink so that embedding applications
// can redirect them (the C ABI installs its own sink).
#pragma once

#include <functional>
#include <string>

namespace nimbus {

enum class LogLevel { Info, Warning, Error };

using LogSink = std::function<void(LogLevel, const std::string&)>;

void setLogSink(LogSink sink);  // nullptr restores the default (stderr)
void setLogQuiet(bool quiet);   // drops Info lines
void logInfo(const std::string& message);
void logWarning(const std::string& message);

}  // namespace nimbus
