#include "Log.h"

#include <cstdio>
#include <mutex>

namespace nimbus {

namespace {
std::mutex gMutex;
LogSink gSink;
bool gQuiet = false;

void emit(LogLevel level, const std::string& message)
{
    std::lock_guard<std::mutex> lock(gMutex);
    if (level == LogLevel::Info && gQuiet)
        return;
    if (gSink) {
        gSink(level, message);
        return;
    }
    const char* prefix = level == LogLevel::Warning ? "nimbus: warning: " : "nimbus: ";
    std::fprintf(stderr, "%s%s\n", prefix, message.c_str());
}
}  // namespace

void setLogSink(LogSink sink)
{
    std::lock_guard<std::mutex> lock(gMutex);
    gSink = std::move(sink);
}
void setLogQuiet(bool quiet)
{
    gQuiet = quiet;
}
void logInfo(const std::string& message)
{
    emit(LogLevel::Info, message);
}
void logWarning(const std::string& message)
{
    emit(LogLevel::Warning, message);
}

}  // namespace nimbus
