// ProbeRays.h: rays that probe the procedural cloud (SceneBuilders.h) from every side, and their
// march in batches.
#pragma once

#include "single/SingleScatter.h"

#include <random>
#include <vector>

namespace nimbus::test {

struct Ray {
    float3 o, d;
};

// Rays from all around the cloud toward points near it, a few from inside it, a few that miss,
// and some along the index axes (direction components exactly zero: the lanes' brick exits
// must never divide by them).
inline std::vector<Ray> probeRays(int count, unsigned seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> s(-1.0f, 1.0f);
    std::vector<Ray> rays;
    for (int i = 0; i < count; ++i) {
        float3 o, to;
        switch (i % 8) {
        case 0:  // from inside the cloud's bounds
            o = make_float3(0.3f * s(rng), 0.3f * s(rng), 0.3f * s(rng));
            to = make_float3(3 * s(rng), 3 * s(rng), 3 * s(rng));
            break;
        case 1: {  // along an index axis (the procedural grid is axis-aligned with the world)
            const int axis = i / 8 % 3;
            o = make_float3(0.8f * s(rng), 0.8f * s(rng), 0.8f * s(rng));
            to = o;
            (axis == 0 ? o.x : axis == 1 ? o.y : o.z) = -4.0f;
            break;
        }
        case 2:  // misses
            o = make_float3(6, 6, 6);
            to = make_float3(12 + s(rng), 6 + s(rng), 6 + s(rng));
            break;
        default:
            o = normalize(make_float3(s(rng), s(rng), s(rng))) * 5.0f;
            to = make_float3(0.7f * s(rng), 0.7f * s(rng), 0.7f * s(rng));
        }
        rays.push_back({o, normalize(to - o)});
    }
    return rays;
}

// Marches rays [first, first + n) as one batch (marchSingleRays), ray i with the random stream
// nbRngStart(seed, first + i, 0); out gets n samples, perLight n runs of 3 * lights floats.
inline void marchBatch(const RenderContext& ctx, const std::vector<Ray>& rays, size_t first, int n, nb_uint seed,
                       std::vector<CameraSample>& out, std::vector<float>& perLight)
{
    const size_t count = size_t(n);
    std::vector<float3> o(count), d(count);
    std::vector<NbRng> rng(count);
    for (size_t i = 0; i < count; ++i) {
        o[i] = rays[first + i].o, d[i] = rays[first + i].d;
        rng[i] = nbRngStart(seed, nb_uint(first + i), 0);
    }
    out.assign(count, CameraSample());
    perLight.assign(count * 3 * ctx.lights.size(), 0.0f);
    marchSingleRays(ctx, n, o.data(), d.data(), rng.data(), out.data(), perLight.data());
}

}  // namespace nimbus::test
