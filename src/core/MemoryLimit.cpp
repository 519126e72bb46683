#include "MemoryLimit.h"

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <string>
#include <unistd.h>

namespace nimbus {

namespace {

// A "Key: value kB" line of /proc/meminfo, in bytes; 0 where absent.
size_t fromFile(const char* path, const char* key)
{
    std::ifstream in(path);
    std::string word;
    while (in >> word)
        if (word == key) {
            double kib = 0;
            in >> kib;
            return size_t(kib * 1024.0);
        }
    return 0;
}

size_t cgroupLimit()
{
    for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
        std::ifstream in(path);
        std::string text;
        if (in >> text && !text.empty() && text != "max") {
            const double v = std::strtod(text.c_str(), nullptr);
            if (v > 0 && v < 1e18)  // cgroup v1 says "no limit" with a huge number
                return size_t(v);
        }
    }
    return 0;
}

}  // namespace

size_t defaultMemoryLimit()
{
    size_t physical = fromFile("/proc/meminfo", "MemTotal:");
    if (physical == 0)
        physical = size_t(::sysconf(_SC_PHYS_PAGES)) * size_t(::sysconf(_SC_PAGESIZE));
    const size_t cgroup = cgroupLimit();
    if (cgroup && cgroup < physical)
        physical = cgroup;
    return size_t(0.8 * double(physical));
}

size_t memoryLimitBytes(double configured)
{
    return configured > 0 ? size_t(std::min(configured, 1.8e19)) : defaultMemoryLimit();
}

}  // namespace nimbus
