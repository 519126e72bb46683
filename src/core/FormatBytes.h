// FormatBytes.h: a byte count for people ("12.3 KiB", "4.5 MiB"), as the plan and stats print it.
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>

namespace nimbus {

inline std::string formatBytes(size_t b)
{
    char buf[64];
    if (b >= (size_t(1) << 20))
        std::snprintf(buf, sizeof buf, "%.1f MiB", double(b) / (1 << 20));
    else
        std::snprintf(buf, sizeof buf, "%.1f KiB", double(b) / 1024.0);
    return buf;
}

}  // namespace nimbus
