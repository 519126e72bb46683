#include "DeepFilm.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nimbus {

namespace {

// `front` over `back`: both premultiplied (OpenEXR deep compositing).
DeepSample mergeSamples(const DeepSample& front, const DeepSample& back)
{
    DeepSample m;
    m.z = front.z;
    m.zBack = std::max(front.zBack, back.zBack);
    m.color = front.color + back.color * (1.0f - front.alpha);
    m.alpha = front.alpha + back.alpha * (1.0f - front.alpha);
    return m;
}

float mergedAlpha(const DeepSample& front, const DeepSample& back)
{
    return front.alpha + back.alpha * (1.0f - front.alpha);
}

}  // namespace

std::vector<DeepSample> deepSamplesOf(DeepCurve curve, int maxSamples)
{
    const size_t n = curve.edges.size() - 1;  // slices
    std::vector<Rgb>& L = curve.L;
    std::vector<float>& T = curve.T;
    for (size_t k = 0; k < L.size(); ++k) {
        if (!(std::isfinite(L[k].x) && std::isfinite(L[k].y) && std::isfinite(L[k].z)))
            L[k] = splat(0.0f);
        L[k] = make_float3(std::max(0.0f, L[k].x), std::max(0.0f, L[k].y), std::max(0.0f, L[k].z));
        T[k] = std::isfinite(T[k]) ? std::min(1.0f, std::max(0.0f, T[k])) : 1.0f;
    }
    L[0] = splat(0.0f), T[0] = 1.0f;
    // Monotone from the back: L(z) never falls and T(z) never rises toward the camera's far side.
    for (size_t k = n + 1; k-- > 1;) {
        L[k - 1] = make_float3(std::min(L[k - 1].x, L[k].x), std::min(L[k - 1].y, L[k].y), std::min(L[k - 1].z, L[k].z));
        T[k - 1] = std::max(T[k - 1], T[k]);
    }
    std::vector<DeepSample> samples;
    samples.reserve(n + 1);
    for (size_t k = 1; k <= n + 1; ++k) {
        DeepSample s;
        const bool background = k == n + 1;
        s.z = background ? std::numeric_limits<float>::max() : curve.edges[k - 1];
        s.zBack = background ? std::numeric_limits<float>::max() : curve.edges[k];
        const Rgb dL = L[k] - L[k - 1];
        if (!(T[k - 1] > 0.0f)) {
            // Nothing is seen past an opaque front; any rounding left over joins the last sample.
            if (!samples.empty())
                samples.back().color += dL;
            continue;
        }
        s.color = dL * (1.0f / T[k - 1]);
        s.alpha = std::min(1.0f, std::max(0.0f, 1.0f - T[k] / T[k - 1]));
        if (s.alpha == 0.0f && s.color.x == 0.0f && s.color.y == 0.0f && s.color.z == 0.0f)
            continue;  // an empty slice
        samples.push_back(s);
    }
    // Merge neighbours while the merge stays within the tolerance; a merged sample's [Z, ZBack]
    // spans both (and the empty slices between them). The background sample, at infinity, stays
    // apart while the count allows.
    std::vector<DeepSample> merged;
    for (const DeepSample& s : samples) {
        const bool background = s.z == std::numeric_limits<float>::max();
        if (!merged.empty() && !background && merged.back().z != std::numeric_limits<float>::max() &&
            mergedAlpha(merged.back(), s) <= kDeepMergeAlpha)
            merged.back() = mergeSamples(merged.back(), s);
        else
            merged.push_back(s);
    }
    while (maxSamples > 0 && merged.size() > size_t(maxSamples)) {
        size_t best = 0;
        float bestAlpha = INFINITY;
        for (size_t i = 0; i + 1 < merged.size(); ++i) {
            const float a = mergedAlpha(merged[i], merged[i + 1]);
            if (a < bestAlpha)
                bestAlpha = a, best = i;
        }
        merged[best] = mergeSamples(merged[best], merged[best + 1]);
        merged.erase(merged.begin() + std::ptrdiff_t(best) + 1);
    }
    return merged;
}

void flattenDeep(const std::vector<DeepSample>& samples, Rgb& color, float& alpha)
{
    color = splat(0.0f);
    alpha = 0.0f;
    for (const DeepSample& s : samples) {
        color += s.color * (1.0f - alpha);
        alpha += s.alpha * (1.0f - alpha);
    }
}

}  // namespace nimbus
