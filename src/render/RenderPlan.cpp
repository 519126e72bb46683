#include "RenderPlan.h"

#include <cstdio>
#include <sstream>

namespace nimbus {

namespace {
std::string bytes(size_t b)
{
    char buf[64];
    if (b >= (size_t(1) << 20))
        std::snprintf(buf, sizeof buf, "%.1f MiB", double(b) / (1 << 20));
    else
        std::snprintf(buf, sizeof buf, "%.1f KiB", double(b) / 1024.0);
    return buf;
}
}  // namespace

std::string RenderPlan::describe() const
{
    std::ostringstream s;
    s << "render plan (method " << methodName(method) << ")\n";
    s << "  volumes:\n";
    if (volumes.empty())
        s << "    (none: only the background renders)\n";
    for (auto& v : volumes) {
        s << "    " << v.name << ": grids [";
        for (size_t i = 0; i < v.gridsRead.size(); ++i)
            s << (i ? ", " : "") << v.gridsRead[i];
        s << "], " << v.bricks << " bricks (" << bytes(v.memoryBytes) << "), voxel " << v.voxelSize << " m, bounds "
          << v.bounds << "\n";
        s << "      optical depth: up to " << v.maxOpticalDepthPerVoxel << " per voxel, up to "
          << v.opticalDepthAcross << " across; emission " << (v.emission ? "on" : "off (no emission grid)");
        if (v.clampedVoxels)
            s << "; " << v.clampedVoxels << " bad voxel values clamped";
        s << "\n";
    }
    s << "  lights:\n";
    if (lights.empty())
        s << "    (none)\n";
    for (auto& l : lights) {
        s << "    " << l.name << " (" << l.type << "): ";
        if (!l.used)
            s << "skipped: " << l.reason;
        else if (l.shadowMap) {
            s << "deep shadow map, " << l.projection << ", " << l.resolution << "^2 texels";
            if (l.shadowMapBytes)
                s << ", " << bytes(l.shadowMapBytes) << ", built in " << l.shadowMapSeconds << " s";
        } else if (l.sampled)
            s << "sampled with shadow rays (" << l.reason << ")";
        s << "\n";
    }
    for (auto& n : notes)
        s << "  " << n << "\n";
    if (!stageSeconds.empty()) {
        s << "  stages:";
        for (auto& st : stageSeconds) {
            char buf[64];
            std::snprintf(buf, sizeof buf, " %s %.2f s;", st.first.c_str(), st.second);
            s << buf;
        }
        s << "\n";
    }
    return s.str();
}

}  // namespace nimbus
