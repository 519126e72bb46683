// ShadowMapCompression.cpp: DeepShadowMap::compress (DeepShadowMap.h), the greedy
// piecewise-linear fit of a texel's marched optical depth within the transmittance bound. Its own
// file: the one place the map's accuracy is decided, read apart from how the rays are marched.
#include "DeepShadowMap.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

void DeepShadowMap::compress(const std::vector<Vertex>& raw, float tolerance, std::vector<Vertex>& out, int channels)
{
    out.clear();
    if (raw.empty())
        return;
    const Vertex& last = raw.back();
    if (std::max({last.tau[0], last.tau[1], last.tau[2]}) <= 0.0f)
        return;  // nothing along this ray: T = 1 everywhere

    // Greedy compression with a window of admissible slopes per channel (Lokovic & Veach sec.
    // 4.2): from the last kept vertex a, extend while some line through a passes within
    // tol_i of every raw vertex. tol_i is the optical-depth error delta that keeps the
    // transmittance error within the bound at that depth:
    // e^{-tau}(e^delta - 1) = tolerance * max(e^{-tau}, floor), so
    // delta = log(1 + tolerance * max(1, floor e^tau)). (The error toward lower T is smaller.)
    // Above the floor (tau < ln(1 / floor)) the bound is relative and delta is one constant.
    const float flatTol = std::log1p(tolerance), knee = std::log(1.0f / kRelativeFloor);
    auto tolAt = [&](const Vertex& v, int c) {
        if (v.tau[c] <= knee)
            return flatTol;
        float rel = kRelativeFloor * std::exp(std::min(v.tau[c], 80.0f));
        return std::log1p(tolerance * rel);
    };
    size_t a = 0;
    out.push_back(raw[0]);
    float lo[3], hi[3];
    auto resetWindow = [&]() {
        for (int c = 0; c < channels; ++c)
            lo[c] = -INFINITY, hi[c] = INFINITY;
    };
    resetWindow();
    for (size_t i = 1; i < raw.size(); ++i) {
        float dz = raw[i].z - raw[a].z;
        bool fits = dz > 0.0f;
        for (int c = 0; c < channels && fits; ++c) {
            float slope = (raw[i].tau[c] - raw[a].tau[c]) / dz;
            fits = slope >= lo[c] && slope <= hi[c];
        }
        if (!fits) {
            // Keep the previous vertex and restart the window from it.
            a = i - 1;
            out.push_back(raw[a]);
            resetWindow();
            dz = raw[i].z - raw[a].z;
            if (!(dz > 0.0f))
                continue;
        }
        for (int c = 0; c < channels; ++c) {
            float t = tolAt(raw[i], c);
            lo[c] = std::max(lo[c], (raw[i].tau[c] - t - raw[a].tau[c]) / dz);
            hi[c] = std::min(hi[c], (raw[i].tau[c] + t - raw[a].tau[c]) / dz);
        }
    }
    if (out.back().z != raw.back().z)
        out.push_back(raw.back());
}

}  // namespace nimbus
