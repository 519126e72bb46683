// SingleIntegrator.h: "method": "single", L0 + L1 (Tessendorf eqs. 26-33) by the camera-ray
// march of SingleScatter.h over the context's deep shadow maps. The engine's tile driver feeds
// it tile rows of camera rays.
#pragma once

#include "../render/Integrator.h"
#include "SingleScatter.h"

namespace nimbus {

// What single produces: L0 and L1, over deep shadow maps (engine registry).
inline IntegratorTraits singleTraits()
{
    IntegratorTraits t;
    t.method = Method::Single;
    t.terms = {"L0", "L1"};
    t.shadowMaps = true;
    return t;
}

class SingleIntegrator final : public Integrator {
public:
    explicit SingleIntegrator(const RenderContext& ctx) : mCtx(&ctx) {}

    Drive drive() const override { return Drive::CameraRays; }
    void marchRays(int n, const float3* o, const float3* d, const float* tFar, NbRng* rng, CameraSample* out,
                   float* perLight) const override
    {
        marchSingleRays(*mCtx, n, o, d, rng, out, perLight, tFar);
    }

private:
    const RenderContext* mCtx;
};

}  // namespace nimbus
