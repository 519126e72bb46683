// SingleIntegrator.h: "method": "single", L0 + L1 (Tessendorf eqs. 26-33) by the camera-ray
// march of SingleScatter.h over the context's deep shadow maps, and emission's L1 by
// EmissionScatter.h. The engine's tile driver feeds
// it tile rows of camera rays.
#pragma once

#include "../render/Integrator.h"
#include "EmissionScatter.h"
#include "SingleScatter.h"

#include <vector>

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
    explicit SingleIntegrator(const RenderContext& ctx) : mCtx(&ctx), mEmission(ctx) {}

    Drive drive() const override { return Drive::CameraRays; }
    void marchRays(int n, const float3* o, const float3* d, const float* tFar, const float* time, NbRng* rng,
                   CameraSample* out, float* perLight) const override
    {
        // Velocity blur: each ray's shutter fraction as seconds after the frame's time.
        thread_local std::vector<float> seconds;
        const bool moving = mCtx->moving() && time;
        if (moving) {
            seconds.resize(size_t(n));
            for (int i = 0; i < n; ++i)
                seconds[size_t(i)] = mCtx->volumes.shutterSeconds(time[i]);
        }
        marchSingleRays(*mCtx, n, o, d, rng, out, perLight, tFar, moving ? seconds.data() : nullptr);
        if (mEmission.active())
            for (int i = 0; i < n; ++i)
                mEmission.add(o[i], d[i], rng[i], out[i], tFar ? tFar[i] : INFINITY,
                              moving ? seconds[size_t(i)] : 0.0f);
    }

private:
    const RenderContext* mCtx;
    EmissionScatter mEmission;  // emission lights the medium (L1)
};

}  // namespace nimbus
