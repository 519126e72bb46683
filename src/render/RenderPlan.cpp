#include "RenderPlan.h"

#include "../core/FormatBytes.h"

#include <algorithm>
#include <cstdio>
#include <sstream>

namespace nimbus {

std::string RenderPlan::describe() const
{
    std::ostringstream s;
    s << "render plan (method " << methodName(method) << ")\n";
    s << "  AOVs:";
    for (size_t i = 0; i < aovs.size(); ++i)
        s << (i ? ", " : " ") << aovs[i];
    s << "\n";
    s << "  volumes:\n";
    if (volumes.empty())
        s << "    (none: only the background renders)\n";
    for (auto& v : volumes) {
        s << "    " << v.name << ": grids [";
        for (size_t i = 0; i < v.gridsRead.size(); ++i)
            s << (i ? ", " : "") << v.gridsRead[i];
        s << "], " << v.bricks << " bricks (" << formatBytes(v.memoryBytes) << "), voxel " << v.voxelSize
          << " m, bounds " << v.bounds << "\n";
        s << "      optical depth: up to " << v.maxOpticalDepthPerVoxel << " per voxel, up to " << v.opticalDepthAcross
          << " across; emission " << (v.emission ? "on" : "off (no emission grid)");
        if (v.clampedVoxels)
            s << "; " << v.clampedVoxels << " bad voxel values clamped";
        s << "\n";
        if (v.motionKnots > 0)
            s << "      transform motion blur: the transform moves within the shutter (" << v.motionKnots
              << " knots); bounds at the shutter's centre\n";
        if (v.velocity) {
            char buf[200];
            std::snprintf(buf, sizeof buf,
                          "      velocity blur: vel up to %.3g voxels/s; largest displacement %.3g voxels over the "
                          "shutter%s\n",
                          v.maxSpeed, v.maxDisplacement, v.maxDisplacement > 0.0f ? "" : " (closed or still: no blur)");
            s << buf;
        }
        if (wkb.enabled && wkb.l2plus && !wkb.lightGrid) {
            char buf[96];
            std::snprintf(buf, sizeof buf, "%.2g", v.l2plusBound);
            s << "      L2+: no light grid (every source traced); bound " << buf << " E/4pi\n";
        } else if (wkb.enabled && wkb.l2plus) {
            s << "      L2+ light grid: " << v.lightGrid << " (" << v.lightVoxelFactor << " density voxels each), "
              << v.mipLevels << " mip levels, " << formatBytes(v.pyramidBytes) << "; ";
            char buf[96];
            std::snprintf(buf, sizeof buf, "%.2g", v.l2plusBound);
            s << (v.l2plus ? "L2+ sources on" : "L2+ sources off") << " (bound " << buf << " E/4pi)\n";
        }
    }
    s << "  lights:\n";
    if (lights.empty())
        s << "    (none)\n";
    for (auto& l : lights) {
        s << "    " << l.name << " (" << l.type << "): ";
        if (!l.used)
            s << "skipped: " << l.reason;
        else if (l.shadowMap)
            s << "deep shadow map, " << l.projection << ", up to " << l.resolution << "^2 texels, baked on the voxels";
        else if (l.sampled)
            s << "sampled with shadow rays (" << l.reason << ")";
        else if (l.skyGrid)
            s << "transmittance-weighted SH radiance on a grid, built once (" << l.reason << ")";
        s << "\n";
        if (l.motionKnots > 0)
            s << "      moves within the shutter (" << l.motionKnots << " knots); shadow map at the shutter's centre\n";
        if (wkb.enabled && !l.l2plus.empty())
            s << "      L2+: " << l.l2plus << "\n";
    }
    if (wkb.enabled) {
        char buf[200];
        if (wkb.l2plus) {
            if (wkb.lightGrid) {
                std::snprintf(buf, sizeof buf, "K %.3g, l step %.3g, orders <= %d, %d channel%s per light voxel",
                              wkb.blurK, wkb.lStep, wkb.orderCap, wkb.channels, wkb.channels == 1 ? "" : "s");
                s << "  L2+ (wkb): kernel " << wkb.kernel << "; source " << wkb.source << "; " << buf << "\n";
                std::snprintf(buf, sizeof buf, " (estimated, %.2f x, budget %.2f x)",
                              double(wkb.pyramidBytes) / double(std::max<size_t>(wkb.densityBytes, 1)),
                              wkb.memoryBudget);
                s << "    light pyramids " << formatBytes(wkb.pyramidBytes) << " for density grids of "
                  << formatBytes(wkb.densityBytes) << buf << "\n";
            } else {
                s << "  L2+ (wkb): kernel " << wkb.kernel << "; no light volumes: every source is traced, and "
                  << "the kernel's march is not run\n";
            }
        } else {
            std::snprintf(buf, sizeof buf, "%.2g", wkb.l2plusBound);
            s << "  L2+ (wkb): not computed (bound " << buf << " E/4pi)\n";
        }
    }
    if (!geometry.empty()) {
        size_t triangles = 0, bytes = 0;
        for (auto& g : geometry)
            triangles += g.triangles, bytes += g.memoryBytes;
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.3f s", geometryBvhSeconds);
        s << "  geometry: " << geometry.size() << " object(s), " << triangles << " triangles ("
          << formatBytes(bytes) << "), Embree BVH built in " << buf << " (" << formatBytes(geometryBvhBytes)
          << ")\n";
        if (kernelBvh) {
            std::snprintf(buf, sizeof buf, "%.3f s", kernelBvhSeconds);
            s << "  path tracer's BVH (rtcBuildBVH): " << kernelBvhNodes << " nodes, " << kernelBvhPrims
              << " primitives, depth " << kernelBvhDepth << ", " << formatBytes(kernelBvhBytes) << ", built in " << buf
              << "\n";
        }
        for (auto& g : geometry) {
            s << "    " << g.name << " (" << g.type << "): ";
            if (g.triangles)
                s << g.triangles << " triangles, ";
            else
                s << "analytic, ";
            s << "bounds " << g.bounds << ", " << formatBytes(g.memoryBytes) << "; "
              << (g.holdout && g.shadows ? "holdout and shadow caster"
                  : g.holdout            ? "holdout only (casts no shadow)"
                  : g.shadows            ? "shadow caster only (not seen by the camera)"
                                         : "neither holdout nor shadow caster: changes nothing")
              << "\n";
        }
    }
    if (!holdoutDepth.empty())
        s << "  depth-map holdout: " << holdoutDepth << "\n";
    for (auto& n : notes)
        s << "  " << n << "\n";
    if (memory.estimateBytes) {
        s << "  memory: estimated peak " << formatBytes(memory.estimateBytes) << " of the limit "
          << formatBytes(memory.limitBytes)
          << (memory.limitDefault ? " (80% of physical memory; render.memory_limit)" : " (render.memory_limit)")
          << ": resident " << formatBytes(memory.residentBytes) << " (code, libraries, the volumes)";
        for (const auto& item : memory.items)
            if (item.bytes)
                s << ", " << item.name << " " << formatBytes(item.bytes);
        if (memory.peakSoFar > memory.residentBytes)
            s << "; loading peaked at " << formatBytes(memory.peakSoFar);
        s << "\n";
    }
    return s.str();
}

}  // namespace nimbus
