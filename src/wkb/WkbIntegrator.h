// WkbIntegrator.h: the L2+ term of method "wkb" (Tessendorf eqs. 88-89; DESIGN "L2+, WKB
// multiple scattering"). Built once per render from a RenderContext: the plan (WkbPlanner), the
// light volumes and their pyramids (LightVolumes); then `march` adds L2+ to one camera ray.
//
// The camera ray's L0 and L1 come from marchSingle, unchanged; marchRays calls `march` after it
// with the same random stream, so wkb's L0 + L1 are exactly single's.
#pragma once

#include "../render/Integrator.h"
#include "../single/EmissionScatter.h"
#include "../single/SingleScatter.h"
#include "LightVolumes.h"
#include "RadianceGrid.h"
#include "SourcePlacement.h"
#include "TracedOrder2.h"
#include "WkbPlanner.h"

#include <memory>
#include <vector>

namespace nimbus::wkb {

// What wkb produces: single's L0 and L1 and the L2+ term, over deep shadow maps (engine registry).
inline IntegratorTraits wkbTraits()
{
    IntegratorTraits t;
    t.method = Method::Wkb;
    t.terms = {"L0", "L1", "L2plus"};
    t.shadowMaps = true;
    return t;
}

class WkbIntegrator final : public Integrator {
public:
    // Builds the light volumes and their pyramids for the plan's WkbSetup (plan.integrator, made
    // by planWkb in the planning pass); sizes and stage times go to stats.
    // orders3: with render.wkb_orders3 "traced", the radiance cache of the lights' orders 3 and up
    // (vrl::traceOrders3, built by the engine above this layer); it then replaces the kernel's
    // orders 3+ of every light (emission keeps the kernel; with render.wkb_order2 "kernel" the
    // lights' kernel keeps its order-2 term alone). Null: the kernel's.
    WkbIntegrator(const RenderContext& ctx, const RenderPlan& plan, RenderStats& stats,
                  std::shared_ptr<const RadianceGrid> orders3 = nullptr);

    Drive drive() const override { return Drive::CameraRays; }
    // L0 + L1 by marchSingle, then L2+ by march, ray by ray on one random stream each.
    void marchRays(int n, const float3* o, const float3* d, const float* tFar, const float* time, NbRng* rng,
                   CameraSample* out,
                   float* perLight) const override;

    bool active() const { return mSetup.active; }
    const WkbSetup& setup() const { return mSetup; }
    const LightVolumes& lightVolumes() const { return mLights; }

    // Adds L2+ along the camera ray o + t d (d unit, t >= 0) to out.L2plus and each light's part
    // to perLight[3 i + c] (emission's part goes to L2plus only): the l-march, and with
    // setup().tracedOrder2 the lights' order 2 by TracedOrder2. Draws its numbers from rng.
    // tFar: where a holdout stops the ray (the l-march ends there), INFINITY for none.
    // seconds: the ray's shutter time, at which moving volumes are read (VolumeSet::sampleAt).
    // orders3Read: the radiance cache's term along this ray, one per layer, where single's march
    // has read it already (marchSingleRays' grid), else null.
    void march(float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight, float tFar = INFINITY,
               float seconds = 0.0f, const float3* orders3Read = nullptr) const;

private:
    // A stretch of the ray with constant coefficients (one medium sample).
    struct Piece;
    struct Scratch;
    struct Cursor;

    bool nextPiece(Cursor& cur, Scratch& sc, float3 o, float3 d, double maxLen, double sigmaMarch) const;
    void evaluateNode(Scratch& sc, float3 o, float3 d, const TableEntry& e0, const TableEntry& e1, double* L,
                      double& remaining) const;
    // Density-weighted source channels at world point x blurred by sigma (metres); false if no
    // medium is near. out: setup.channels floats, channel 0 the weight.
    bool readSources(float3 x, double sigma, float* out) const;

    const RenderContext* mCtx;
    WkbSetup mSetup;
    LightVolumes mLights;
    std::unique_ptr<TracedOrder2> mOrder2;  // set with setup().tracedOrder2
    bool mOrder2Outside = false;  // the lights' order 2 outside the kernel: traced, or in the cache
    std::unique_ptr<EmissionScatter> mEmission;  // emission's L1, as single's
    std::shared_ptr<const RadianceGrid> mOrders3;  // traced orders 3+ of the lights, or null
    bool mKernelSources = true;  // some source the l-march still evaluates (with both traced: emission)
    PlacementModel mModel = PlacementModel::Straight;
    float mMinLightVoxel = 1.0f;
    std::vector<Rgb> mSigmaS, mSigmaA;  // per volume, 1/m at density 1 (density scale included)
    std::vector<NbPhase> mPhase;        // per volume
    int mMaxShOrder = -1;
};

}  // namespace nimbus::wkb
