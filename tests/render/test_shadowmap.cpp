// Deep shadow maps on a heterogeneous medium: the compressed function of every texel keeps
// the transmittance within the stated tolerance of the uncompressed march along the same ray.
#include "HandMadeVolume.h"

#include "render/DeepShadowMap.h"
#include "scene/KernelScene.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace nimbus;
using namespace nimbus::test;

TEST(ShadowMap, CompressionStaysWithinTolerance)
{
    Medium m;
    m.sigma_s = make_float3(2.0f, 1.0f, 0.5f);
    m.sigma_a = make_float3(0.1f, 0.3f, 0.2f);
    auto vol = handMadeVolume(40, 0.05f, make_float3(-1, -1, -1), [](int i, int j, int k) {
        float v = 1.0f + std::sin(i * 0.4f) * std::cos(j * 0.3f) + 0.5f * std::sin(k * 0.7f + i * 0.1f);
        return std::max(0.0f, v) * 4.0f;
    }, m);
    VolumeSet volumes({vol}, 0.5f);

    for (LightType type : {LightType::Distant, LightType::Spot, LightType::Point}) {
        Light l;
        l.type = type;
        l.direction = normalize(make_float3(-0.4f, -1.0f, 0.3f));
        l.position = make_float3(0.8f, 3.0f, -0.6f);
        l.coneAngle = 60.0f;
        DeepShadowMap::Settings s;
        s.resolution = 32;
        s.tolerance = 0.003f;
        DeepShadowMap dsm = DeepShadowMap::build(makeNbLight(l, 0), volumes, s);
        double worst = 0;
        size_t rawVertices = 0;
        std::vector<DeepShadowMap::Vertex> raw;
        for (int face = 0; face < dsm.faceCount(); ++face)
            for (int iy = 0; iy < s.resolution; ++iy)
                for (int ix = 0; ix < s.resolution; ++ix) {
                    float3 o, d;
                    dsm.texelRay(face, (ix + 0.5f) / s.resolution, (iy + 0.5f) / s.resolution, o, d);
                    DeepShadowMap::marchRay(volumes, o, d, s.stepFraction, raw);
                    rawVertices += raw.size();
                    // At the raw vertices and halfway between them (both functions are linear
                    // between raw vertices, so these bound the error everywhere).
                    for (size_t i = 0; i < raw.size(); ++i)
                        for (float w : {0.0f, 0.5f}) {
                            if (w > 0 && i + 1 == raw.size())
                                continue;
                            float z = w == 0 ? raw[i].z : 0.5f * (raw[i].z + raw[i + 1].z);
                            Rgb stored = dsm.texelOpticalDepth(face, ix, iy, z);
                            for (int c = 0; c < 3; ++c) {
                                float exact = w == 0 ? raw[i].tau[c] : 0.5f * (raw[i].tau[c] + raw[i + 1].tau[c]);
                                float got = c == 0 ? stored.x : (c == 1 ? stored.y : stored.z);
                                // Relative error, with the floor below which it turns absolute.
                                double T = std::exp(-double(exact));
                                double err = std::fabs(T - std::exp(-double(got))) /
                                             std::max(T, double(DeepShadowMap::kRelativeFloor));
                                worst = std::max(worst, err);
                            }
                        }
                }
        // The stated tolerance plus float rounding of the interpolation: optical depths up to
        // ~10 carry ~1e-6 relative rounding, 1e-5 in T / floor.
        EXPECT_LE(worst, s.tolerance + 1e-3 * s.tolerance + 1e-4) << lightTypeName(type);
        EXPECT_LT(dsm.vertexCount(), rawVertices) << "compression never adds vertices";
        std::printf("%s: %zu of %zu vertices kept, worst |dT|/max(T, floor) %.5f (tolerance %.3f)\n", lightTypeName(type),
                    dsm.vertexCount(), rawVertices, worst, s.tolerance);
    }
}
