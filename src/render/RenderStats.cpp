#include "RenderStats.h"

#include "../core/FormatBytes.h"

#include <cstdio>
#include <sstream>

namespace nimbus {

double RenderStats::stage(const std::string& name) const
{
    for (const auto& st : stageSeconds)
        if (st.first == name)
            return st.second;
    return 0.0;
}

std::string RenderStats::describe(const RenderPlan& plan) const
{
    std::ostringstream s;
    s << "render statistics\n";
    for (size_t i = 0; i < lights.size() && i < plan.lights.size(); ++i) {
        const LightStats& l = lights[i];
        if (l.shadowMapBytes == 0 && l.l2plusShadowMapBytes == 0 && l.skyBytes == 0)
            continue;
        s << "  light " << plan.lights[i].name << ":";
        if (l.shadowMapBytes) {
            s << " deep shadow map " << l.resolution << "^2 texels, " << formatBytes(l.shadowMapBytes) << ", built in "
              << l.shadowMapSeconds << " s; baked on the voxels, " << formatBytes(l.cacheBytes) << ", "
              << l.cacheSeconds << " s";
            if (l.marchSampleBytes > 0)
                s << " (from the map's uncompressed march, " << formatBytes(l.marchSampleBytes) << ", freed after)";
        }
        if (l.l2plusShadowMapBytes)
            s << (l.shadowMapBytes ? ";" : "") << " L2+ shadow map of its own, " << formatBytes(l.l2plusShadowMapBytes);
        if (l.skyBytes)
            s << " sky grid " << formatBytes(l.skyBytes) << ", built in " << l.skySeconds << " s";
        s << "\n";
    }
    for (size_t v = 0; v < volumes.size() && v < plan.volumes.size(); ++v) {
        if (volumes[v].pyramidBytes)
            s << "  volume " << plan.volumes[v].name << ": L2+ light pyramid " << volumes[v].mipLevels
              << " mip levels, " << formatBytes(volumes[v].pyramidBytes) << "\n";
        // Any stiff brick sends every single-scattering ray of the frame to the one-ray march.
        if (volumes[v].bricks)
            s << "  volume " << plan.volumes[v].name << ": " << volumes[v].stiffBricks << " of " << volumes[v].bricks
              << " bricks stiff (optically thick voxels, sub-stepped)\n";
    }
    if (pyramidBytes)
        s << "  light pyramids in all: " << formatBytes(pyramidBytes) << "\n";
    if (orders3Cells) {
        s << "  orders " << orders3FirstOrder << "+ cache: " << orders3Cells << " cells, " << orders3SkinCells
          << " skin cells; light paths ";
        if (orders3FocusRadius > 0.0f) {
            char buf[96];
            std::snprintf(buf, sizeof buf, "aimed at the view (a sphere of radius %.3g m around the seen medium)",
                          double(orders3FocusRadius));
            s << buf;
        } else {
            s << "over the whole medium (the camera sees most of it)";
        }
        if (orders3Paths > 0) {
            s << "; " << orders3Paths << " of them";
            char buf[192];
            if (orders3MaxPaths > 0 && orders3NoisePaths > 0)
                std::snprintf(buf, sizeof buf,
                              " (adaptive, at most %lld; the cache's noise measured at relMSE %.2g in the image at %lld; %s)",
                              orders3MaxPaths, orders3Noise, orders3NoisePaths,
                              orders3Blurred ? "blurred" : "sharp: the noise target reached without the blur");
            else if (orders3MaxPaths > 0)
                std::snprintf(buf, sizeof buf, " (adaptive, at most %lld)", orders3MaxPaths);
            else
                buf[0] = 0;
            s << buf;
        }
        s << "\n";
    }
    if (marchedPixels > 0) {
        char buf[256];
        if (maxSpp > baseSpp)
            std::snprintf(buf, sizeof buf,
                          "  camera samples: %.2f per marched pixel (adaptive: %d to %d; %.1f%% of %lld pixels took "
                          "%d)\n",
                          double(cameraSamples) / double(marchedPixels), baseSpp, maxSpp,
                          100.0 * double(pixelsAtMostSpp) / double(marchedPixels), marchedPixels, maxSpp);
        else
            std::snprintf(buf, sizeof buf, "  camera samples: %d per pixel over %lld marched pixels\n", baseSpp,
                          marchedPixels);
        s << buf;
    }
    if (!stageSeconds.empty()) {
        s << "  stages:";
        for (auto& st : stageSeconds) {
            char buf[64];
            std::snprintf(buf, sizeof buf, " %s %.3f s;", st.first.c_str(), st.second);
            s << buf;
        }
        s << "\n";
    }
    return s.str();
}

}  // namespace nimbus
