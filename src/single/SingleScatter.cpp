#include "SingleScatter.h"

#include "../render/BrickWalk.h"
#include "MarchEightRays.h"
#include "SkyTail.h"

#include "../core/ExpNeg.h"
#include "../core/StepCount.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace nimbus {

namespace {

// Transmittance of one step and the integral over the step of exp(-sigma_t s) ds,
// (1 - e^{-sigma_t dt}) / sigma_t, per channel. (stepOpacity: a step's share of the ray's
// opacity, T (1 - e^{-sigma_t dt}), is T sigma_t w, so the depth AOV, sum of opacity t over sum
// of opacity, does not suffer the cancellation of T - T e^{-sigma_t dt} on thin steps, where
// 1 - T of a nearly clear ray is all rounding.) One exp per channel; for optically thin steps
// (sigma_t dt < 1e-3) the series 1 - x/2 + x^2/6 keeps full float precision where 1 - e^{-x}
// would cancel, and stiff steps (sigma_t dt ~ 1e4) give 1/sigma_t without overflow.
[[gnu::always_inline]] inline void stepTerms(float sigma, float dt, float& transmit, float& weight)
{
    float x = sigma * dt;
    if (x < 1e-3f) {
        transmit = 1.0f - x * (1.0f - 0.5f * x);
        weight = dt * (1.0f - x * (0.5f - x * (1.0f / 6.0f)));
    } else {
        transmit = expNeg(x);
        weight = (1.0f - transmit) / sigma;
    }
}

// E1 = int_0^L e^{-a u} du and E2 = int_0^L u e^{-a u} du, for either sign of a: by their
// series where |a L| < 0.1 (1 - e^{-x} (1 + x) cancels to x^2 / 2 there), else in closed form.
[[gnu::always_inline]] inline void secantWeights(float a, float L, float& e1, float& e2)
{
    const float x = std::max(a * L, -40.0f);
    if (std::fabs(x) < 0.1f) {
        e1 = L * (1.0f - x * (0.5f - x * (1.0f / 6.0f - x * (1.0f / 24.0f))));
        e2 = L * L * (0.5f - x * (1.0f / 3.0f - x * (1.0f / 8.0f - x * (1.0f / 30.0f))));
    } else {
        const float e = std::exp(-x);
        e1 = (1.0f - e) / a;
        e2 = (1.0f - e * (1.0f + x)) / (a * a);
    }
}

// A light as the stiff sub-steps read it: its baked optical depth and, for a point or spot
// light, its position (distant lights: direction toward the light, distance unbounded).
struct StiffLight {
    size_t index;  // in ctx.lights
    const BrickGrid* cache;
    bool distant;
};

// One camera step [ta, tb] through a stiff brick (StiffVoxels.h) in n equal sub-steps. At
// both ends of a sub-step the density rho and each light's optical depth tau_L (marched back
// toward the light where a cell is not flat, stiffOpticalDepth) are taken, and both optical
// depths, the camera's and the light's, are held linear across the sub-step (the secant
// rule): with a = sigma_t (rho0 + rho1) / 2 + (tau1 - tau0) / L,
//   int_0^L T e^{-sigma_t rho_avg u} rho(u) e^{-tau_L(u)} du = T e^{-tau0} (rho0 E1 + (rho1 - rho0) / L E2),
// exact in a homogeneous medium at any step (light entering through any face), second order
// where the density ramps (a voxelised surface). L1[l] gets that, per channel, times sigma_s
// / rho for the caller to apply, and times L_i p for point and spot lights (distant lights'
// L_i p is constant along the ray: the caller applies it). Returns false once every channel's
// transmittance is below the cut-off.
bool marchStiffStep(const RenderContext& ctx, const VolumeData& vol, float3 o, float3 d, float ta, float tb, int n,
                    const StiffLight* lights, size_t nLights, Rgb& T, Rgb* L1, float& opacitySum, float& depthSum)
{
    const float3 oi = vol.indexFromWorld.point(o), di = vol.indexFromWorld.vector(d);
    const Rgb kT = vol.sigmaT();
    const NbPhase phase = vol.medium.phase;
    const float cutoff = ctx.scene->render.tolerance;
    const float L = (tb - ta) / float(n);
    constexpr size_t kMaxLights = 16;
    struct End {
        float rho;
        Rgb tau[kMaxLights];
    };
    // The lights toward which the sub-steps march back (at most kMaxLights; the rest read the
    // lattice, as outside stiff bricks).
    const size_t nl = std::min(nLights, kMaxLights);
    auto evaluate = [&](float t, End& e) {
        const float3 q = oi + di * t;
        const BrickGrid::Stencil st = vol.density.stencil(q);
        e.rho = st.brick < 0 ? 0.0f : std::max(vol.density.interpolate(st), 0.0f);
        for (size_t l = 0; l < nl; ++l) {
            if (st.brick < 0) {
                e.tau[l] = splat(-1.0f);  // no lattice here: the other end's value stands in
                continue;
            }
            const LightEntry& le = ctx.lights[lights[l].index];
            float3 wi;
            float distance = 1e30f;
            if (lights[l].distant) {
                wi = -nbLoad3(le.light.direction);
            } else {
                const float3 toLight = nbLoad3(le.light.position) - (o + d * t);
                distance = length(toLight);
                wi = toLight / std::max(distance, 1e-30f);
            }
            e.tau[l] = stiffOpticalDepth(vol, *lights[l].cache, q, vol.indexFromWorld.vector(wi), distance);
        }
    };
    End e0, e1;
    evaluate(ta, e0);
    for (int j = 0; j < n; ++j) {
        const float t0 = ta + float(j) * L;
        evaluate(j + 1 == n ? tb : t0 + L, e1);
        if (e0.rho > 0.0f || e1.rho > 0.0f) {
            const float rhoAvg = 0.5f * (e0.rho + e1.rho), slope = (e1.rho - e0.rho) / L;
            const Rgb camera = kT * (rhoAvg * L);  // the sub-step's optical depth
            for (size_t l = 0; l < nl; ++l) {
                Rgb tau0 = e0.tau[l], tau1 = e1.tau[l];
                if (tau0.x < 0.0f)
                    tau0 = tau1;
                if (tau1.x < 0.0f)
                    tau1 = tau0;
                if (tau0.x < 0.0f)
                    continue;
                Rgb c;
                float w1, w2;
                secantWeights(camera.x / L + (tau1.x - tau0.x) / L, L, w1, w2);
                c.x = std::exp(-tau0.x) * (e0.rho * w1 + slope * w2);
                if (kT.y == kT.x && kT.z == kT.x && tau0.y == tau0.x && tau1.y == tau1.x && tau0.z == tau0.x &&
                    tau1.z == tau1.x) {
                    c.y = c.z = c.x;
                } else {
                    secantWeights(camera.y / L + (tau1.y - tau0.y) / L, L, w1, w2);
                    c.y = std::exp(-tau0.y) * (e0.rho * w1 + slope * w2);
                    secantWeights(camera.z / L + (tau1.z - tau0.z) / L, L, w1, w2);
                    c.z = std::exp(-tau0.z) * (e0.rho * w1 + slope * w2);
                }
                c = T * c;
                if (!lights[l].distant) {
                    float3 wi;
                    const Rgb weight = ctx.deltaWeight(lights[l].index, o + d * t0, wi);
                    c = c * weight * nbPhaseEval(phase, dot(wi, d));  // travel -wi, then -d
                }
                L1[l] += c;
            }
            const Rgb stepT = make_float3(std::exp(-camera.x), std::exp(-camera.y), std::exp(-camera.z));
            const float opacity = nbAverage(T * (splat(1.0f) - stepT));  // stepOpacity, no thin steps here
            opacitySum += opacity;
            // At the sub-step's opacity-weighted mean distance, t0 + L (1/x - 1/(e^x - 1)), x
            // its optical depth (L/2 where thin): the partial first step is not jittered.
            const float x = nbAverage(camera);
            depthSum += opacity * (t0 + (x > 1e-3f ? L * (1.0f / x - 1.0f / std::expm1(x)) : 0.5f * L));
            T = T * stepT;
            if (nbMaxComponent(T) < cutoff) {
                T = splat(0.0f);
                return false;
            }
        }
        e0 = e1;
    }
    return true;
}

// Where a stiff step starting at sample t begins (marchStiffStep's ta): at t where the step
// before was integrated, else back to the sample before (its step read no density, or lay in
// an empty brick, and density may begin inside it) but not before the lattice's start, so that
// the first sample also covers the partial step from the entry into the occupied bricks.
inline float stiffStepStart(float t, float dt, float tStart, float coveredTo)
{
    return std::max(std::max(coveredTo, t - dt), tStart);
}

// The stretch [ta, tb] a stiff step at lattice sample k (t = tStart + (k + jitter) dt) integrates,
// and its sub-step count: `subSteps` per whole step, in proportion for a longer first step.
// Records the stretch as covered.
struct StiffStep {
    float ta, tb;
    int n;
};
inline StiffStep stiffStepAt(int k, float t, float dt, float jitter, int subSteps, float& coveredTo)
{
    StiffStep st;
    st.ta = stiffStepStart(t, dt, t - (float(k) + jitter) * dt, coveredTo);
    st.tb = t + dt;
    st.n = int(std::ceil(float(subSteps) * (st.tb - st.ta) / dt));
    coveredTo = st.tb;
    return st;
}
// A held-out ray's last stiff step ends at the holdout.
inline StiffStep clippedStep(StiffStep st, float tMax)
{
    st.tb = std::min(st.tb, tMax);
    return st;
}

// How far a camera ray marches: to its first holdout (geometry or the depth map, found by the
// tile driver), else unbounded, as 1e30 (the bound every march here used before holdouts, so that
// a scene without them marches exactly as before). A held-out ray sees no background.
struct Reach {
    float tMax = 1e30f;
    bool heldOut = false;
};
inline Reach reachOf(float tFar)
{
    return tFar < INFINITY ? Reach{std::min(tFar, 1e30f), true} : Reach{};
}
// The background seen along d through the medium's transmittance T, unless a holdout hides it.
inline Rgb backgroundSeen(const RenderContext& ctx, float3 d, Rgb T, const Reach& reach)
{
    return reach.heldOut ? splat(0.0f) : T * ctx.backgroundAlong(d);
}

// An environment light's sky grid as one camera ray reads it (SkyLight.h): the ray's contraction
// a_jm = p_j y_jm(-d) per volume and a cursor per volume.
struct SkyRay {
    size_t index;  // in ctx.lights
    const SkyLight* sky;
    float a[SkyLight::kCountMax];
    SkyLight::Cursor cursor;
};

// The sky lights of ctx with their contractions for one volume's phase function along -d.
void skyRaysOf(const RenderContext& ctx, float3 d, NbPhase phase, std::vector<SkyRay>& rays)
{
    rays.clear();
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        if (!e.used || !e.sky)
            continue;
        SkyRay r;
        r.index = i;
        r.sky = &*e.sky;
        e.sky->contraction(phase, -d, r.a);  // light scatters toward the camera, along -d
        rays.push_back(r);
    }
}

// The walk's per-sample step, ending the walk once the render is stopped (RenderControl.h: a
// cancel is obeyed within a second however long one ray's march is), polled every
// kStopPollInterval samples. The samples marched so far are left as they are: the tile driver
// discards a stopped render's film.
template <class Step>
auto stoppable(const RenderContext& ctx, Step& step)
{
    return [&ctx, &step, n = 0u](int k, float t, const BrickGrid::Stencil& st) mutable {
        if (++n % kStopPollInterval == 0 && ctx.stop.raised())
            return false;
        return step(k, t, st);
    };
}

// The common case in a tight loop: one volume without emission, every used light shadow-mapped
// and baked on its voxels. The march walks the density grid's occupied bricks in index space
// (BrickWalk.h: no spans, no matrix per step); one stencil reads the density and every light's
// optical depth; a distant light's phase and weight are constant along the ray. Same estimator
// as the general loop below: samples at t_k = t_in + (k + jitter) dt.
// OneDistant: the only used light is distant (a key light), so its weight and cache pointer
// live in registers for the whole ray.
// HeldOut: the ray stops at tMax (a holdout) and sees no background; rays without one take the
// HeldOut = false instance, the march exactly as it was before holdouts.
template <bool Grey, bool OneDistant, bool HeldOut>
void marchOneVolume(const RenderContext& ctx, const VolumeData& vol, float3 o, float3 d, float jitter, float tMax,
                    CameraSample& out, float* perLight)
{
    const size_t nLights = ctx.lights.size();
    const BrickGrid& density = vol.density;
    const Rgb kS = vol.sigmaS(), kT = vol.sigmaT();
    const NbPhase phase = vol.medium.phase;
    const float cutoff = ctx.scene->render.tolerance;
    const float dt = ctx.scene->render.step * vol.voxelSize;

    struct Active {
        int index;
        const BrickGrid* cache;
        bool distant;
        Rgb weight;  // distant lights: L_i * phase, constant along the ray
    };
    thread_local std::vector<Active> activeList;
    activeList.clear();
    for (size_t i = 0; i < nLights; ++i) {
        const LightEntry& e = ctx.lights[i];
        if (!e.used || e.sky)
            continue;
        Active a{int(i), &e.cache->grid(0), e.light.type == NB_LIGHT_DISTANT, splat(0.0f)};
        if (a.distant)  // light travels along its direction, then toward the camera (along -d)
            a.weight = nbLoad3(e.light.color) * nbPhaseEval(phase, -dot(nbLoad3(e.light.direction), d));
        activeList.push_back(a);
    }
    const Active* active = activeList.data();
    const size_t nActive = OneDistant ? 1 : activeList.size();
    constexpr int C = Grey ? 1 : 3;  // channels of the density's light caches
    // Copied out of the list: a local the loop's stores cannot alias stays in registers.
    const Active first = activeList.empty() ? Active{0, nullptr, false, splat(0.0f)} : activeList[0];
    Rgb T = splat(1.0f), L1 = splat(0.0f), L1Sky = splat(0.0f);
    float depthSum = 0.0f, opacitySum = 0.0f;
    const StiffVoxels& stiff = ctx.stiff[0];
    thread_local std::vector<StiffLight> stiffLights;
    thread_local std::vector<Rgb> stiffL1;
    stiffLights.clear();
    for (size_t ai = 0; ai < nActive; ++ai)
        stiffLights.push_back({size_t(active[ai].index), active[ai].cache, active[ai].distant});
    stiffL1.resize(nActive);
    // Environment lights: their sky grids (SkyLight.h), read at the sample's index-space point.
    thread_local std::vector<SkyRay> skyRays;
    skyRaysOf(ctx, d, phase, skyRays);
    const float3 oi = vol.indexFromWorld.point(o), di = vol.indexFromWorld.vector(d);
    auto addSky = [&](float t, Rgb TwS) {
        for (SkyRay& r : skyRays) {
            const Rgb c = TwS * r.sky->radiance(0, oi + di * t, r.a, r.cursor);
            L1Sky += c;
            float* pl = perLight + 3 * r.index;
            pl[0] += c.x, pl[1] += c.y, pl[2] += c.z;
        }
    };
    float coveredTo = -1e30f;  // stiffStepStart
    auto step = [&](int k, float t, const BrickGrid::Stencil& st) {
        if (stiff.any) {
            if (const int n = stiff.subStepsOf(st.brick)) {
                StiffStep ss = stiffStepAt(k, t, dt, jitter, n, coveredTo);
                if constexpr (HeldOut)
                    ss = clippedStep(ss, tMax);
                std::fill(stiffL1.begin(), stiffL1.end(), splat(0.0f));
                const Rgb Tbefore = T;
                const bool go = marchStiffStep(ctx, vol, o, d, ss.ta, ss.tb, ss.n, stiffLights.data(), nActive, T,
                                               stiffL1.data(), opacitySum, depthSum);
                // The sky over the stiff step: int T sigma_s ds = (T_a - T_b) sigma_s / sigma_t,
                // read at the step's middle (the grid is coarser than the step).
                if (!skyRays.empty())
                    addSky(0.5f * (ss.ta + ss.tb), (Tbefore - T) * kS / fmax(kT, splat(1e-30f)));
                for (size_t ai = 0; ai < nActive; ++ai) {
                    const Active& a = OneDistant ? first : active[ai];
                    const Rgb c = kS * stiffL1[ai] * (a.distant ? a.weight : splat(1.0f));
                    L1 += c;
                    if (!OneDistant) {
                        float* pl = perLight + 3 * a.index;
                        pl[0] += c.x, pl[1] += c.y, pl[2] += c.z;
                    }
                }
                return go;
            }
        }
        const float rho = BrickGrid::trilinear<1>(density.brickData(st.brick) + st.corner, st.tx, st.ty, st.tz);
        if (!(rho > 0.0f))
            return true;
        coveredTo = t + dt;
        Rgb stepT, w;
        stepTerms(kT.x * rho, dt, stepT.x, w.x);
        if (Grey) {
            stepT.y = stepT.z = stepT.x;
            w.y = w.z = w.x;
        } else {
            stepTerms(kT.y * rho, dt, stepT.y, w.y);
            stepTerms(kT.z * rho, dt, stepT.z, w.z);
        }
        const Rgb TwS = T * w * kS * rho;  // int over the step of T sigma_s (eq. 31 per step)
        if (!skyRays.empty())
            addSky(t, TwS);
        for (size_t ai = 0; ai < nActive; ++ai) {
            const Active& a = OneDistant ? first : active[ai];
            Rgb Li;
            if (OneDistant || a.distant) {
                Li = a.weight;
            } else {
                float3 wi;
                Rgb weight = ctx.deltaWeight(size_t(a.index), o + d * t, wi);  // sets wi first
                Li = weight * nbPhaseEval(phase, dot(wi, d));                  // travel -wi, then -d
            }
            const float* tau = a.cache->brickData(st.brick) + st.corner * C;
            Rgb Tl;
            if (Grey) {
                Tl = splat(expNeg(BrickGrid::trilinear<1>(tau, st.tx, st.ty, st.tz)));
            } else {
                Tl = make_float3(expNeg(BrickGrid::trilinear<3>(tau, st.tx, st.ty, st.tz)),
                                 expNeg(BrickGrid::trilinear<3>(tau + 1, st.tx, st.ty, st.tz)),
                                 expNeg(BrickGrid::trilinear<3>(tau + 2, st.tx, st.ty, st.tz)));
            }
            const Rgb c = TwS * Li * Tl;
            L1 += c;
            if (!OneDistant) {
                float* pl = perLight + 3 * a.index;
                pl[0] += c.x, pl[1] += c.y, pl[2] += c.z;
            }
        }
        const float opacity = nbAverage(T * w * kT) * rho;  // stepOpacity
        opacitySum += opacity;
        depthSum += opacity * t;
        T = T * stepT;
        if (nbMaxComponent(T) < cutoff) {
            T = splat(0.0f);
            return false;
        }
        return true;
    };
    if constexpr (HeldOut)
        walkVolumeTo(vol, o, d, dt, jitter, tMax, stoppable(ctx, step));
    else
        walkVolume(vol, o, d, dt, jitter, stoppable(ctx, step));
    out.L1 += L1 + L1Sky;
    if (OneDistant) {
        float* pl = perLight + 3 * first.index;
        pl[0] += L1.x, pl[1] += L1.y, pl[2] += L1.z;
    }
    if (!skyRays.empty())
        addSkyTailsOneVolume(ctx, vol, o, d, T, HeldOut, out, perLight);
    if constexpr (!HeldOut)
        out.L0 += T * ctx.backgroundAlong(d);
    out.transmittance = T;
    out.depth = opacitySum > 0.0f ? depthSum / opacitySum : 0.0f;
    out.opacity = opacitySum;
}

// The commonest case of all, a grey medium (equal RGB extinction) lit by one distant light:
// marchOneVolume<true, true> with the transmittance, the weights and the sum in scalars (the
// constant RGB factors sigma_s / rho and L_i p are applied once, after the march).
// Sky: the sun and skies (SkyLight.h) of marchOneVolume<true, false> (a sun plus a sky is the
// commonest lighting of a cloud): each sky's grid read at every sample as there, its sum of
// T w rho times the grid's radiance (sigma_s / rho applied after the march).
template <bool HeldOut, bool Sky = false>
void marchGreyKeyLight(const RenderContext& ctx, const VolumeData& vol, const LightEntry& key, float3 o, float3 d,
                       float jitter, float tMax, CameraSample& out, float* perLight)
{
    const BrickGrid& density = vol.density;
    const BrickGrid& cache = key.cache->grid(0);
    const float kT = vol.sigmaT().x;
    const float cutoff = ctx.scene->render.tolerance;
    const float dt = ctx.scene->render.step * vol.voxelSize;
    float T = 1.0f, L1 = 0.0f, depthSum = 0.0f, opacitySum = 0.0f;
    const StiffVoxels& stiff = ctx.stiff[0];
    const StiffLight stiffKey{size_t(&key - ctx.lights.data()), &cache, true};
    float coveredTo = -1e30f;  // stiffStepStart
    // Skies: per sky the ray's contraction and cursor (SkyRay), and its sum over samples.
    thread_local std::vector<SkyRay> skyRays;
    thread_local std::vector<Rgb> skySums;
    float3 oi = splat(0.0f), di = splat(0.0f);
    if constexpr (Sky) {
        skyRaysOf(ctx, d, vol.medium.phase, skyRays);
        skySums.assign(skyRays.size(), splat(0.0f));
        oi = vol.indexFromWorld.point(o), di = vol.indexFromWorld.vector(d);
    }
    auto addSky = [&](float t, float weight) {  // weight: int over the step of T rho ds
        for (size_t s = 0; s < skyRays.size(); ++s) {
            SkyRay& r = skyRays[s];
            skySums[s] += r.sky->radiance(0, oi + di * t, r.a, r.cursor) * weight;
        }
    };
    auto step = [&](int k, float t, const BrickGrid::Stencil& st) {
        if (stiff.any) {
            if (const int n = stiff.subStepsOf(st.brick)) {
                StiffStep ss = stiffStepAt(k, t, dt, jitter, n, coveredTo);
                if constexpr (HeldOut)
                    ss = clippedStep(ss, tMax);
                Rgb Tr = splat(T), l1 = splat(0.0f);
                const bool go =
                    marchStiffStep(ctx, vol, o, d, ss.ta, ss.tb, ss.n, &stiffKey, 1, Tr, &l1, opacitySum, depthSum);
                // The sky over the stiff step as marchOneVolume reads it: int T rho ds =
                // (T_a - T_b) / (sigma_t / rho), at the step's middle.
                if constexpr (Sky)
                    addSky(0.5f * (ss.ta + ss.tb), (T - Tr.x) / std::max(kT, 1e-30f));
                T = Tr.x, L1 += l1.x;
                return go;
            }
        }
        const float rho = BrickGrid::trilinear<1>(density.brickData(st.brick) + st.corner, st.tx, st.ty, st.tz);
        if (!(rho > 0.0f))
            return true;
        coveredTo = t + dt;
        float stepT, w;
        stepTerms(kT * rho, dt, stepT, w);
        if constexpr (Sky)
            addSky(t, T * w * rho);
        const float tauLight = BrickGrid::trilinear<1>(cache.brickData(st.brick) + st.corner, st.tx, st.ty, st.tz);
        L1 += T * w * rho * expNeg(tauLight);    // eq. 31 per step, over sigma_s / rho and L_i p
        const float opacity = T * w * kT * rho;  // stepOpacity
        opacitySum += opacity;
        depthSum += opacity * t;
        T *= stepT;
        if (T < cutoff) {
            T = 0.0f;
            return false;
        }
        return true;
    };
    if constexpr (HeldOut)
        walkVolumeTo(vol, o, d, dt, jitter, tMax, stoppable(ctx, step));
    else
        walkVolume(vol, o, d, dt, jitter, stoppable(ctx, step));
    // Light travels along its direction, then toward the camera (along -d).
    const Rgb weight = nbLoad3(key.light.color) * nbPhaseEval(vol.medium.phase, -dot(nbLoad3(key.light.direction), d));
    const Rgb l1 = vol.sigmaS() * weight * L1;
    out.L1 += l1;
    float* pl = perLight + 3 * (&key - ctx.lights.data());
    pl[0] += l1.x, pl[1] += l1.y, pl[2] += l1.z;
    if constexpr (Sky) {
        for (size_t s = 0; s < skyRays.size(); ++s) {
            const Rgb c = vol.sigmaS() * skySums[s];
            out.L1 += c;
            float* ps = perLight + 3 * skyRays[s].index;
            ps[0] += c.x, ps[1] += c.y, ps[2] += c.z;
        }
        addSkyTailsOneVolume(ctx, vol, o, d, splat(T), HeldOut, out, perLight);
    }
    if constexpr (!HeldOut)
        out.L0 += T * ctx.backgroundAlong(d);
    out.transmittance = splat(T);
    out.depth = opacitySum > 0.0f ? depthSum / opacitySum : 0.0f;
    out.opacity = opacitySum;
}

// Which tight loop a scene's camera rays take: one volume without emission whose every used
// light is baked on its voxels (FastMarch::None otherwise: the general march).
// `allDistant`, when given, is set where every used light is distant (and one at least).
enum class FastMarch { None, GreyKeyLight, GreyKeySky, Grey, OneDistant, Chromatic };
FastMarch fastMarchOf(const RenderContext& ctx, const LightEntry** key, bool* allDistant = nullptr)
{
    const VolumeSet& vs = ctx.volumes;
    if (vs.volumes().size() != 1)
        return FastMarch::None;
    const VolumeData& vol = *vs.volumes()[0];
    if (vol.hasEmission() || vol.density.channels() != 1)
        return FastMarch::None;
    const Rgb kT = vol.sigmaT();
    const bool grey = kT.x == kT.y && kT.y == kT.z;
    for (const LightEntry& e : ctx.lights)
        if (e.used && !e.sky && (!e.cache || e.cache->grid(0).channels() != (grey ? 1 : 3)))
            return FastMarch::None;
    size_t used = 0, distant = 0, skies = 0;
    for (const LightEntry& e : ctx.lights) {
        used += e.used;  // a sky too: then no OneDistant loop, which reads one light
        distant += e.used && e.light.type == NB_LIGHT_DISTANT;
        skies += e.used && e.sky;
        if (e.used && !e.sky)
            *key = &e;
    }
    const bool oneDistant = used == 1 && distant == 1;
    const bool sunAndSkies = distant == 1 && skies > 0 && used == 1 + skies;  // a sun and its skies
    if (allDistant)  // the lanes' case: distant lights and skies, both at infinity
        *allDistant = used > 0 && distant + skies == used;
    return grey && oneDistant    ? FastMarch::GreyKeyLight
           : grey && sunAndSkies ? FastMarch::GreyKeySky
           : grey                ? FastMarch::Grey
           : oneDistant       ? FastMarch::OneDistant
                              : FastMarch::Chromatic;
}

bool marchSingleFast(const RenderContext& ctx, float3 o, float3 d, float jitter, Reach reach, CameraSample& out,
                     float* perLight)
{
    const LightEntry* key = nullptr;
    const FastMarch fast = fastMarchOf(ctx, &key);
    if (fast == FastMarch::None)
        return false;
    const VolumeData& vol = *ctx.volumes.volumes()[0];
    const float tMax = reach.tMax;
    if (reach.heldOut) {
        if (fast == FastMarch::GreyKeyLight)
            marchGreyKeyLight<true>(ctx, vol, *key, o, d, jitter, tMax, out, perLight);
        else if (fast == FastMarch::GreyKeySky)
            marchGreyKeyLight<true, true>(ctx, vol, *key, o, d, jitter, tMax, out, perLight);
        else if (fast == FastMarch::Grey)
            marchOneVolume<true, false, true>(ctx, vol, o, d, jitter, tMax, out, perLight);
        else if (fast == FastMarch::OneDistant)
            marchOneVolume<false, true, true>(ctx, vol, o, d, jitter, tMax, out, perLight);
        else
            marchOneVolume<false, false, true>(ctx, vol, o, d, jitter, tMax, out, perLight);
    } else if (fast == FastMarch::GreyKeyLight)
        marchGreyKeyLight<false>(ctx, vol, *key, o, d, jitter, tMax, out, perLight);
    else if (fast == FastMarch::GreyKeySky)
        marchGreyKeyLight<false, true>(ctx, vol, *key, o, d, jitter, tMax, out, perLight);
    else if (fast == FastMarch::Grey)
        marchOneVolume<true, false, false>(ctx, vol, o, d, jitter, tMax, out, perLight);
    else if (fast == FastMarch::OneDistant)
        marchOneVolume<false, true, false>(ctx, vol, o, d, jitter, tMax, out, perLight);
    else
        marchOneVolume<false, false, false>(ctx, vol, o, d, jitter, tMax, out, perLight);
    return true;
}

// Any scene: several volumes, emission, sampled area and environment lights, chromatic media.
// Out of line, so that its frame does not weigh on the common cases above.
// `latticeStart`, where given, puts the samples on one lattice along the whole ray,
// t_k = *latticeStart + (k + jitter) step (one volume: the specialised loops' lattice, for
// marchSingleGeneralReference) instead of one per span.
[[gnu::noinline]] void marchSingleGeneral(const RenderContext& ctx, float3 o, float3 d, float jitter, Reach reach,
                                          NbRng& rng, CameraSample& out, float* perLight,
                                          const float* latticeStart = nullptr, float seconds = 0.0f)
{
    const Scene& scene = *ctx.scene;
    const VolumeSet& vs = ctx.volumes;
    const auto& volumes = vs.volumes();
    const size_t nVolumes = volumes.size();
    const size_t nLights = ctx.lights.size();
    thread_local std::vector<Span> spanList;
    thread_local std::vector<float> phaseWeights;
    // Phase values that are constant along the ray: a distant light's direction does not change,
    // nor does the camera ray's, so p(cos) per (light, volume) is evaluated once per ray.
    thread_local std::vector<float> rayPhase;
    thread_local std::vector<char> rayPhaseValid;
    thread_local std::vector<DeepShadowMap::Cursor> cursors;
    thread_local std::vector<BrickGrid::Stencil> stencils;
    cursors.assign(nLights, DeepShadowMap::Cursor());
    stencils.resize(nVolumes);
    phaseWeights.resize(nVolumes);
    rayPhase.assign(nLights * nVolumes, 0.0f);
    rayPhaseValid.assign(nLights, 0);
    for (size_t i = 0; i < nLights; ++i) {
        const LightEntry& e = ctx.lights[i];
        if (!e.used || !e.delta || e.light.type != NB_LIGHT_DISTANT)
            continue;
        // Light travels along its direction, then toward the camera, along -d (phase.h); a
        // light moving within the shutter, at the ray's time.
        float cosTheta = -dot(nbLoad3(e.lightAt(seconds).direction), d);
        for (size_t v = 0; v < nVolumes; ++v)
            rayPhase[i * nVolumes + v] = nbPhaseEval(volumes[v]->medium.phase, cosTheta);
        rayPhaseValid[i] = 1;
    }

    // Environment lights' sky grids (SkyLight.h): per (sky, volume) the ray's contraction with
    // that volume's phase function and a cursor.
    thread_local std::vector<int> skySlot;
    thread_local std::vector<float> skyA;
    thread_local std::vector<SkyLight::Cursor> skyCursors;
    skySlot.assign(nLights, -1);
    int nSky = 0;
    for (size_t i = 0; i < nLights; ++i)
        if (ctx.lights[i].used && ctx.lights[i].sky)
            skySlot[i] = nSky++;
    skyA.resize(size_t(nSky) * nVolumes * SkyLight::kCountMax);
    skyCursors.assign(size_t(nSky) * nVolumes, SkyLight::Cursor());
    for (size_t i = 0; i < nLights; ++i)
        if (skySlot[i] >= 0)
            for (size_t v = 0; v < nVolumes; ++v)  // light scatters toward the camera, along -d
                ctx.lights[i].sky->contraction(volumes[v]->medium.phase, -d,
                                               skyA.data() + (size_t(skySlot[i]) * nVolumes + v) * SkyLight::kCountMax);
    // Per sky and volume: the volume's int sigma_s dt along the ray, for the phase tails
    // (SkyTail.h, after the march).
    thread_local std::vector<Rgb> skyTailTau;
    skyTailTau.assign(size_t(nSky) * nVolumes, splat(0.0f));

    // Velocity blur: the spans of the volumes as they move, and each step read at the ray's time.
    vs.spansAt(seconds, o, d, 0.0f, reach.tMax, scene.render.step, spanList);
    const int lightSamples = std::max(1, scene.render.lightSamples);
    // Stop where every channel's transmittance is below the tolerance: what lies behind can
    // change the pixel by at most that fraction of the light it would send unattenuated
    // (DESIGN: term cut-offs follow render.tolerance; vdb_render stops at 0.005).
    const float cutoff = scene.render.tolerance;
    Rgb T = splat(1.0f);
    float depthSum = 0.0f, opacitySum = 0.0f;
    bool done = false;

    // One volume without emission whose every used light is baked: stiff bricks take
    // marchStiffStep's sub-steps, as in the specialised loops.
    thread_local std::vector<StiffLight> stiffLights;
    thread_local std::vector<Rgb> stiffL1;
    stiffLights.clear();
    bool stiffSteps = nVolumes == 1 && ctx.stiff[0].any && !volumes[0]->hasEmission() && !ctx.moving();
    for (size_t i = 0; i < nLights && stiffSteps; ++i) {
        const LightEntry& e = ctx.lights[i];
        if (!e.used)
            continue;
        stiffSteps = e.cache.has_value();
        if (stiffSteps)
            stiffLights.push_back({i, &e.cache->grid(0), e.light.type == NB_LIGHT_DISTANT});
    }
    stiffL1.resize(stiffLights.size());
    float coveredTo = -1e30f;  // stiffStepStart

    int kNext = 0;  // latticeStart: the first lattice sample not yet taken
    unsigned polled = 0;  // samples since the march began, for the stop poll (stoppable above)
    for (const Span& span : spanList) {
        float len = span.t1 - span.t0;
        int n = stepCount(len, span.step);
        float dt = len / float(n), t0 = span.t0;
        int k = 0;
        if (latticeStart) {  // as walkOccupiedBricks (BrickWalk.h) places them
            dt = span.step, t0 = *latticeStart, n = std::numeric_limits<int>::max();
            k = std::max(kNext, int(std::ceil((span.t0 - t0) * (1.0f / dt) - jitter)));
        }
        for (; k < n && !done; ++k) {
            if (++polled % kStopPollInterval == 0 && ctx.stop.raised()) {
                done = true;
                break;
            }
            float t = t0 + (float(k) + jitter) * dt;
            if (latticeStart && !(t < span.t1))
                break;
            kNext = k + 1;
            // p: where the step lies, where the light's direction and distance are taken (a
            // moving light placed at the ray's time); with moving volumes the shadow maps, baked
            // transmittance and sky grids are read at lp, where its matter was when they were
            // made (VolumeSet::sampleAt).
            const float3 p = o + d * t;
            float3 lp;
            MediumSample m = vs.sampleAt(seconds, p, phaseWeights.data(), stencils.data(), &lp);
            if (stiffSteps) {
                if (const int ns = ctx.stiff[0].subStepsOf(stencils[0].brick)) {
                    const VolumeData& vol = *volumes[0];
                    const StiffStep ss = clippedStep(stiffStepAt(k, t, dt, jitter, ns, coveredTo), reach.tMax);
                    std::fill(stiffL1.begin(), stiffL1.end(), splat(0.0f));
                    done = !marchStiffStep(ctx, vol, o, d, ss.ta, ss.tb, ss.n, stiffLights.data(), stiffLights.size(),
                                           T, stiffL1.data(), opacitySum, depthSum);
                    for (size_t l = 0; l < stiffLights.size(); ++l) {
                        const size_t i = stiffLights[l].index;
                        const Rgb c =
                            vol.sigmaS() * stiffL1[l] *
                            (stiffLights[l].distant ? nbLoad3(ctx.lights[i].light.color) * rayPhase[i] : splat(1.0f));
                        out.L1 += c;
                        perLight[3 * i + 0] += c.x;
                        perLight[3 * i + 1] += c.y;
                        perLight[3 * i + 2] += c.z;
                    }
                    continue;
                }
            }
            if (nbMaxComponent(m.sigma_t) <= 0.0f && nbMaxComponent(m.emission) <= 0.0f)
                continue;
            coveredTo = t + dt;
            Rgb stepT, w;
            stepTerms(m.sigma_t.x, dt, stepT.x, w.x);
            if (m.sigma_t.y == m.sigma_t.x && m.sigma_t.z == m.sigma_t.x) {  // grey medium
                stepT.y = stepT.z = stepT.x;
                w.y = w.z = w.x;
            } else {
                stepTerms(m.sigma_t.y, dt, stepT.y, w.y);
                stepTerms(m.sigma_t.z, dt, stepT.z, w.z);
            }
            Rgb Tw = T * w;  // int over the step of T(0, s) ds (Tessendorf eq. 31 per step)
            out.L0 += Tw * m.emission;
            if (nbMaxComponent(m.sigma_s) > 0.0f) {
                float weightSum = 0.0f;
                for (size_t v = 0; v < nVolumes; ++v)
                    weightSum += phaseWeights[v];
                const float invWeightSum = 1.0f / std::max(weightSum, 1e-30f);
                for (size_t i = 0; i < nLights; ++i) {
                    if (!ctx.lights[i].used)
                        continue;
                    if (const int slot = skySlot[i]; slot >= 0) {
                        // The sky grid's in-scattered radiance, the volumes' phases mixed by
                        // scattering coefficient as below.
                        Rgb sum = splat(0.0f);
                        for (size_t v = 0; v < nVolumes; ++v) {
                            if (!(phaseWeights[v] > 0.0f))
                                continue;
                            const size_t sv = size_t(slot) * nVolumes + v;
                            sum += ctx.lights[i].sky->radiance(v, volumes[v]->indexFromWorld.point(lp),
                                                               skyA.data() + sv * SkyLight::kCountMax, skyCursors[sv]) *
                                   phaseWeights[v];
                            skyTailTau[sv] += m.sigma_s * (dt * phaseWeights[v] * invWeightSum);
                        }
                        const Rgb contribution = Tw * m.sigma_s * sum * invWeightSum;
                        out.L1 += contribution;
                        perLight[3 * i + 0] += contribution.x;
                        perLight[3 * i + 1] += contribution.y;
                        perLight[3 * i + 2] += contribution.z;
                        continue;
                    }
                    const bool delta = ctx.lights[i].delta;
                    const int ns = delta ? 1 : lightSamples;
                    Rgb sum = splat(0.0f);
                    const LightEntry& light = ctx.lights[i];
                    for (int s = 0; s < ns; ++s) {
                        float3 wi;
                        Rgb Li;
                        if (light.cache) {
                            Li = ctx.deltaWeight(i, p, wi, seconds) * light.cache->transmittance(stencils.data());
                        } else {
                            float u0 = delta ? 0.5f : nbRngNext(&rng), u1 = delta ? 0.5f : nbRngNext(&rng);
                            Li = ctx.incident(i, p, u0, u1, wi, &cursors[i], seconds, &lp);
                        }
                        if (nbMaxComponent(Li) <= 0.0f)
                            continue;
                        // Light travels along -wi, then scatters toward the camera, along -d
                        // (Tessendorf eq. 31); with several volumes here, their phases mix by
                        // scattering coefficient.
                        float phase = 0.0f;
                        if (rayPhaseValid[i]) {
                            for (size_t v = 0; v < nVolumes; ++v)
                                phase += phaseWeights[v] * rayPhase[i * nVolumes + v];
                        } else {
                            float cosTheta = dot(wi, d);  // travel -wi before, -d after
                            for (size_t v = 0; v < nVolumes; ++v)
                                if (phaseWeights[v] > 0.0f)
                                    phase += phaseWeights[v] * nbPhaseEval(volumes[v]->medium.phase, cosTheta);
                        }
                        sum += Li * (phase * invWeightSum);
                    }
                    Rgb contribution = Tw * m.sigma_s * sum / float(ns);
                    out.L1 += contribution;
                    perLight[3 * i + 0] += contribution.x;
                    perLight[3 * i + 1] += contribution.y;
                    perLight[3 * i + 2] += contribution.z;
                }
            }
            const float opacity = nbAverage(Tw * m.sigma_t);  // stepOpacity
            opacitySum += opacity;
            depthSum += opacity * t;
            T = T * stepT;
            if (nbMaxComponent(T) < cutoff) {
                T = splat(0.0f);
                done = true;
            }
        }
        if (done)
            break;
    }
    if (nSky > 0 && !done && skyBehindOpen(ctx, o, d, reach.heldOut))
        addSkyTails(ctx, d, T, skyTailTau.data(), nVolumes, out, perLight);
    out.L0 += backgroundSeen(ctx, d, T, reach);
    out.transmittance = T;
    out.depth = opacitySum > 0.0f ? depthSum / opacitySum : 0.0f;
    out.opacity = opacitySum;
}

// Most camera rays of a typical frame miss every volume: the background, nothing else (and no
// further random numbers, as in the general march, which finds no span).
bool missesEveryVolume(const RenderContext& ctx, float3 o, float3 d, Reach reach, CameraSample& out)
{
    float tIn, tOut;
    if (ctx.volumes.movingBounds().intersect(o, safeInverse(d), 0.0f, reach.tMax, tIn, tOut))
        return false;
    out.L0 += backgroundSeen(ctx, d, splat(1.0f), reach);
    out.transmittance = splat(1.0f);
    out.depth = 0.0f;
    return true;
}

}  // namespace

void marchSingle(const RenderContext& ctx, float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight,
                 float tFar, float seconds)
{
    const float jitter = nbRngNext(&rng);
    const Reach reach = reachOf(tFar);
    if (missesEveryVolume(ctx, o, d, reach, out))
        return;
    if (ctx.moving()) {  // motion blur: only the general loop reads moving volumes and lights
        marchSingleGeneral(ctx, o, d, jitter, reach, rng, out, perLight, nullptr, seconds);
        return;
    }
    if (!marchSingleFast(ctx, o, d, jitter, reach, out, perLight))
        marchSingleGeneral(ctx, o, d, jitter, reach, rng, out, perLight);
}

namespace {

#if NIMBUS_EIGHT_RAY_MARCH
// A grey medium lit only by distant lights, at most kMaxEightRayLights: the lanes' case
// (MarchEightRays.h). Returns how many lights, written to `lights`; 0 where it is not the case.
int eightRayLightsOf(const RenderContext& ctx, const LightEntry** lights)
{
    const LightEntry* key = nullptr;
    bool allDistant = false;
    const FastMarch fast = fastMarchOf(ctx, &key, &allDistant);
    if (!allDistant || (fast != FastMarch::GreyKeyLight && fast != FastMarch::GreyKeySky && fast != FastMarch::Grey))
        return 0;
    if (ctx.stiff[0].any)  // stiff bricks take the one-ray march's sub-steps (marchStiffStep)
        return 0;
    int lightCount = 0;
    for (const LightEntry& e : ctx.lights) {
        if (!e.used)
            continue;
        if (lightCount == kMaxEightRayLights)  // too many for the lanes' accumulators
            return 0;
        lights[lightCount++] = &e;
    }
    return lightCount;
}
#endif

}  // namespace

SingleRoute singleRouteOf(const RenderContext& ctx, bool batch)
{
#if NIMBUS_EIGHT_RAY_MARCH
    const LightEntry* lights[kMaxEightRayLights];
    if (batch && eightRayLightsOf(ctx, lights) > 0)
        return SingleRoute::GreyDistantEight;
#else
    (void)batch;
#endif
    const LightEntry* key = nullptr;
    switch (fastMarchOf(ctx, &key)) {
    case FastMarch::GreyKeyLight: return SingleRoute::GreyKeyLight;
    case FastMarch::GreyKeySky: return SingleRoute::GreyKeySky;
    case FastMarch::Grey: return SingleRoute::Grey;
    case FastMarch::OneDistant: return SingleRoute::OneDistant;
    case FastMarch::Chromatic: return SingleRoute::Chromatic;
    case FastMarch::None: break;
    }
    return SingleRoute::General;
}

void marchSingleGeneralReference(const RenderContext& ctx, float3 o, float3 d, NbRng& rng, CameraSample& out,
                                 float* perLight)
{
    const float jitter = nbRngNext(&rng);  // as marchSingle draws it
    if (missesEveryVolume(ctx, o, d, Reach{}, out))
        return;
    // walkVolume's lattice start (BrickWalk.h): the entry into the occupied bricks' bounds.
    float start = 0.0f;
    const float* lattice = nullptr;
    if (ctx.volumes.volumes().size() == 1) {
        const VolumeData& vol = *ctx.volumes.volumes()[0];
        const float3 oi = vol.indexFromWorld.point(o), di = vol.indexFromWorld.vector(d);
        float t0, t1, s1;
        if (vol.worldBounds.intersect(o, safeInverse(d), 0.0f, 1e30f, t0, t1) &&
            vol.density.activeIndexBounds().intersect(oi, safeInverse(di), t0, t1, start, s1))
            lattice = &start;
    }
    marchSingleGeneral(ctx, o, d, jitter, Reach{}, rng, out, perLight, lattice);
}

void marchSingleRays(const RenderContext& ctx, int n, const float3* o, const float3* d, NbRng* rng, CameraSample* out,
                     float* perLight, const float* tFar, const float* seconds, const InScatterGrid* grid, float3* gridL,
                     unsigned char* gridRead)
{
    const size_t stride = 3 * ctx.lights.size();
    if (grid)
        std::fill(gridRead, gridRead + n, (unsigned char)0);
    if (ctx.moving() && seconds) {
        for (int i = 0; i < n; ++i)
            marchSingle(ctx, o[i], d[i], rng[i], out[i], perLight + stride * size_t(i), tFar ? tFar[i] : INFINITY,
                        seconds[i]);
        return;
    }
#if NIMBUS_EIGHT_RAY_MARCH
    // A grey medium lit only by distant lights: eight rays at once (MarchEightRays.h).
    const LightEntry* lights[kMaxEightRayLights];
    const int lightCount = n > 1 ? eightRayLightsOf(ctx, lights) : 0;
    if (lightCount > 0) {
        const VolumeData& vol = *ctx.volumes.volumes()[0];
        for (int first = 0; first < n; first += 8) {
            const int m = std::min(8, n - first);
            float jitter[8];
            NbRng start[8];
            for (int i = 0; i < m; ++i) {
                start[i] = rng[first + i];
                jitter[i] = nbRngNext(&rng[first + i]);  // as marchSingle draws it
            }
            if (marchGreyDistantEight(ctx, vol, lights, lightCount, m, o + first, d + first,
                                      tFar ? tFar + first : nullptr, jitter, out + first,
                                      perLight + stride * size_t(first), stride, grid,
                                      grid ? gridL + size_t(first) * size_t(grid->layers) : nullptr)) {
                if (grid)
                    std::fill(gridRead + first, gridRead + first + m, (unsigned char)1);
            } else {
                for (int i = 0; i < m; ++i) {
                    rng[first + i] = start[i];
                    marchSingle(ctx, o[first + i], d[first + i], rng[first + i], out[first + i],
                                perLight + stride * size_t(first + i), tFar ? tFar[first + i] : INFINITY);
                }
            }
        }
        return;
    }
#endif
    for (int i = 0; i < n; ++i)
        marchSingle(ctx, o[i], d[i], rng[i], out[i], perLight + stride * size_t(i), tFar ? tFar[i] : INFINITY);
}

}  // namespace nimbus
