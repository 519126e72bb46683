/* pathtrace.cl: nimbus's reference integrator, an unbiased volumetric path tracer.
 *
 * One work item renders one pixel of the data window: `samples` camera paths per launch, each
 * folded into per-pixel running means (Skanberg eq. 39) in `acc` (layout in ptscene.h). The
 * random numbers of a path are a hash of (seed, pixel, sample index, dimension) (rng.h), so the
 * image does not depend on the work-group size, the launch split or the device's thread count.
 *
 * Estimators (docs/pathtracer.md derives each):
 *  - Free flights: delta tracking against the local majorant mu (majorant.h), with the
 *    "spectral tracking" choice of events of Kutz et al. 2017 (SIGGRAPH, "Spectral and
 *    decomposition tracking for rendering heterogeneous volumes", sec. 5) for RGB media. At a
 *    tentative collision the null-collision form of the RTE (Galtier et al. 2013; Novak et al.
 *    2018 sec. 4) reads, per channel c,
 *        L_c = [ j_c + sigma_s,c L^s_c + sigma_n,c L_c ] / mu,   sigma_n = mu - sigma_t >= 0,
 *    averaged over tentative collisions drawn with pdf mu exp(-mu t) (one scalar mu for all
 *    channels: the largest channel's majorant). The emission term j/mu is added at every
 *    tentative collision. Of the other two we pick one: scattering with probability
 *        P_s = avg(w sigma_s) / (avg(w sigma_s) + avg(w sigma_n)),  P_n = 1 - P_s,
 *    and weight w *= sigma_s / (mu P_s) or sigma_n / (mu P_n), w the RGB path throughput. The
 *    expectation is exactly the bracket above in every channel whenever P_x > 0 wherever
 *    w sigma_x != 0, which the averages guarantee: the scheme is unbiased for any RGB
 *    coefficients. Absorption is never sampled as an event; its share of the collision term
 *    (sigma_a L_a with L_a = 0, emission being separate) contributes zero, so dropping it only
 *    rescales the weights. For grey media this is delta tracking with absorption by weighting:
 *    P_s = sigma_s / (sigma_s + sigma_n) and w *= 1 - sigma_a / mu.
 *  - Transmittance to lights: ratio tracking (Cramer 1978; Novak et al. 2014) over the same
 *    majorant walk, T_c *= 1 - sigma_t,c / mu per tentative collision, with Russian roulette
 *    once every channel is below 0.1.
 *  - Next-event estimation at every scattering vertex for every light (nbLightSample; the
 *    uniform environment draws its direction from the phase function instead). An environment
 *    light with an HDR map (envmap.h) takes two samples combined by multiple importance
 *    sampling (Veach 1997, sec. 9.2, the power heuristic with beta = 2): one direction from the
 *    map's piecewise-constant distribution, weighted pdf_map^2 / (pdf_map^2 + p^2), and one
 *    from the phase function p, weighted p^2 / (pdf_map^2 + p^2); each with its own
 *    transmittance estimate. The weights sum to 1 for every direction either can draw, so the
 *    pair is unbiased; each covers where the other's pdf is small (a peaked phase function
 *    against a broad sky, a small bright sun texel against a broad lobe). Camera
 *    rays that escape see the background (L0); scattered rays that escape add nothing, since
 *    NEE already accounts for every light: nothing is counted twice.
 *  - Equi-angular sampling towards point and spot lights (NB_EQUIANGULAR; Kulla and Fajardo
 *    2012, equiangular.h): each flight segment [0, tEnd) of a path that may still scatter adds,
 *    per point or spot light, one extra next-event estimate of that light's single scattering
 *    anywhere on the segment, at a point t drawn with pdf_e(t) ~ 1 / r(t)^2:
 *        w sigma_s(t) T(0, t) phase I / r^2 T(t, light) m_e(t) / pdf_e(t),
 *    both transmittances by ratio tracking. The NEE of the same light at the free flight's
 *    scattering vertex (which estimates the same integral) is multiplied by 1 - m_e(t_c).
 *    m_e = pdf_e^2 / (pdf_e^2 + p_d^2), p_d(t) = mu(t) exp(-int_0^t mu) the pdf of the first
 *    tentative collision: a deterministic function of t on the segment, computable at both
 *    techniques' points (the true density of the vertex, sigma_t(t) T(0, t), is not), so the
 *    weights sum to 1 at every t and the pair is unbiased for any such function; p_d equals
 *    the true density in a homogeneous medium. Near the light pdf_e dominates and the vertex's
 *    NEE, whose second moment diverges like int r^-4 r^2 dr at a point light, is weighted out.
 *    A flight takes it only where pdf_e's peak reaches half the flight's largest majorant
 *    (nbEquiWorthwhile; m = 0 elsewhere): decided once per flight and light (equiMask) and
 *    read by both techniques. Lights past the 32nd never take it.
 *  - Directions from the phase function (nbPhaseSample, pdf = phase, weight 1).
 *  - Russian roulette from rrDepth scattering events on, survival probability min(1, max_c w_c),
 *    weight w / q for survivors: E[w'] = q (w / q) = w, unbiased. It is what ends paths in an
 *    unbounded render: in a grey medium every tentative collision multiplies w by
 *    1 - sigma_a / mu, so with w reset to 1 by each roulette a path survives a scattering event
 *    with probability about the albedo (mean depth ~ 1 / (1 - albedo) for a path that never
 *    escapes: 10^4 at albedo 0.9999).
 *  - maxDepth bounds the number of scattering events; emission met after the last allowed
 *    event still counts (those paths have maxDepth events). An unbounded render passes a safety
 *    cap far beyond any plausible depth with countDepthCap set, and paths reaching it are counted
 *    (the host warns: each one is energy lost).
 *
 *  - Scene geometry (docs/geometry.md, geometry.h): opaque, absorbing, unshaded. The camera ray
 *    ends at the first holdout (or the depth-map holdout's depth): the pixel keeps the volume
 *    in front and sees no background there. Holdouts affect camera visibility only: path
 *    segments after a scattering event and shadow rays pass holdout-only surfaces. Shadow
 *    casters end every path segment after the first scattering event that reaches them (the
 *    path is absorbed) and block every light sample (an any-hit ray before ratio tracking);
 *    the camera ray passes a caster that is not a holdout (invisible to the camera).
 *
 * Specialisation (the host's defines): NB_NUM_VOLUMES, NB_NUM_LIGHTS, NB_HAS_LIGHT_<TYPE>,
 * NB_HAS_EMISSION, NB_TWO_LOBE, NB_CHROMATIC, NB_GLOBAL_MAJORANT, NB_GEOM_HOLDOUTS,
 * NB_GEOM_SHADOW_CASTERS, NB_HOLDOUT_DEPTH, NB_HAS_VELOCITY, NB_HAS_MOTION (volume transforms
 * moving within the shutter), NB_HAS_LIGHT_MOTION (lights moving within it), NB_EQUIANGULAR.
 * Code for what a scene lacks is not compiled.
 */
#include "shared/brickgrid.h"
#include "shared/camera.h"
#include "shared/compat.h"
#include "shared/geometry.h"
#include "shared/holdoutdepth.h"
#include "shared/envmap.h"
#include "shared/equiangular.h"
#include "shared/light.h"
#include "shared/majorant.h"
#include "shared/phase.h"
#include "shared/ptscene.h"
#include "shared/rng.h"

#ifndef NB_NUM_LIGHTS
#define NB_NUM_LIGHTS 0
#endif
#ifndef NB_TWO_LOBE
#define NB_TWO_LOBE 1
#endif
#ifndef NB_CHROMATIC
#define NB_CHROMATIC 1
#endif
#ifndef NB_GEOM_HOLDOUTS
#define NB_GEOM_HOLDOUTS 0
#endif
#ifndef NB_GEOM_SHADOW_CASTERS
#define NB_GEOM_SHADOW_CASTERS 0
#endif
#ifndef NB_HOLDOUT_DEPTH
#define NB_HOLDOUT_DEPTH 0
#endif
#ifndef NB_HAS_ENV_MAP
#define NB_HAS_ENV_MAP 0
#endif
#ifndef NB_EQUIANGULAR
#define NB_EQUIANGULAR 0
#endif
#ifndef NB_HAS_LIGHT_MOTION
#define NB_HAS_LIGHT_MOTION 0
#endif

/* Uniform in (0, 1]: safe for -log. */
NB_FN float nbRngOpen(__private NbRng* rng)
{
    return 1.0f - nbRngNext(rng);
}

/* t + dt, but at least one ulp past t: a majorant so large that dt falls below t's precision
 * must not stall the walk (the shift is far below a voxel for any sane scene). */
NB_FN float nbAdvance(float t, float dt)
{
    float tn = t + dt;
    return tn > t ? tn : nextafter(t, NB_INF);
}

NB_FN float3 nbSigmaS(__global const NbVolumeDesc* vd)
{
    return make_float3(vd->sigma_s[0], vd->sigma_s[1], vd->sigma_s[2]);
}
NB_FN float3 nbSigmaT(__global const NbVolumeDesc* vd)
{
    return make_float3(vd->sigma_t[0], vd->sigma_t[1], vd->sigma_t[2]);
}

/* Channel average of w * v: the "history-aware" weights of spectral tracking. Grey media need
 * one channel only. */
NB_FN float nbWeighted(float3 w, float3 v)
{
#if NB_CHROMATIC
    return nbAverage(w * v);
#else
    return w.x * v.x;
#endif
}

/* One light sample. With the types a scene has known at compile time, each case calls
 * nbLightSample with a constant type, so the compiler drops the branches for the others. */
NB_FN NbLightSample nbSampleLight(NbLight l, float3 p, float u0, float u1)
{
    NbLightSample s;
    s.wi = make_float3(0.0f, 1.0f, 0.0f);
    s.distance = 0.0f;
    s.weight = make_float3(0.0f, 0.0f, 0.0f);
    switch (l.type) {
#if NB_HAS_LIGHT_DISTANT
    case NB_LIGHT_DISTANT:
        l.type = NB_LIGHT_DISTANT;
        s = nbLightSample(l, p, u0, u1);
        break;
#endif
#if NB_HAS_LIGHT_POINT
    case NB_LIGHT_POINT:
        l.type = NB_LIGHT_POINT;
        s = nbLightSample(l, p, u0, u1);
        break;
#endif
#if NB_HAS_LIGHT_SPOT
    case NB_LIGHT_SPOT:
        l.type = NB_LIGHT_SPOT;
        s = nbLightSample(l, p, u0, u1);
        break;
#endif
#if NB_HAS_LIGHT_RECT
    case NB_LIGHT_RECT:
        l.type = NB_LIGHT_RECT;
        s = nbLightSample(l, p, u0, u1);
        break;
#endif
#if NB_HAS_LIGHT_SPHERE
    case NB_LIGHT_SPHERE:
        l.type = NB_LIGHT_SPHERE;
        s = nbLightSample(l, p, u0, u1);
        break;
#endif
#if NB_HAS_LIGHT_ENVIRONMENT
    case NB_LIGHT_ENVIRONMENT:
        l.type = NB_LIGHT_ENVIRONMENT;
        s = nbLightSample(l, p, u0, u1);
        break;
#endif
    default: break;
    }
    return s;
}

/* Ratio-tracking transmittance along o + t d, t in [0, tMax] (Novak et al. 2014, eq. 6): an
 * unbiased estimate of exp(-int sigma_t) per channel. */
NB_FN float3 nbRatioTransmittance(float3 o, float3 d, float tMax, float seconds, __global const NbVolumeDesc* vols,
                                  int volumeCount, __global const int* tables, __global const float* pools,
                                  __global const float* majorants, __private NbRng* rng, __private int* budget)
{
    float3 T = make_float3(1.0f, 1.0f, 1.0f);
    NbMajorantIter it;
    nbMajorantInit(&it, vols, volumeCount, o, d, 0.0f, tMax, seconds, majorants);
    float tau = -log(nbRngOpen(rng));
    float segEnd, mu;
    float rho[NB_NUM_VOLUMES];
    while (nbMajorantNext(&it, vols, majorants, &segEnd, &mu)) {
        float span = mu * (segEnd - it.t);
        if (tau >= span) {
            tau -= span;
            it.t = segEnd;
            continue;
        }
        it.t = nbAdvance(it.t, tau / mu);
        --*budget;
        nbMajorantDensities(&it, vols, tables, pools, rho);
        float3 sigma_t = make_float3(0.0f, 0.0f, 0.0f);
        for (int v = 0; v < NB_NUM_VOLUMES; ++v)
            sigma_t = sigma_t + nbSigmaT(vols + v) * rho[v];
        T = T * fmax(make_float3(0.0f, 0.0f, 0.0f), make_float3(1.0f, 1.0f, 1.0f) - sigma_t / mu);
        float m = nbMaxComponent(T);
        if (m < 0.1f) {
            /* Russian roulette: survive with probability 10 m, then T has max 0.1. */
            if (nbRngNext(rng) >= m * 10.0f)
                return make_float3(0.0f, 0.0f, 0.0f);
            T = T / (m * 10.0f);
        }
        tau = -log(nbRngOpen(rng));
    }
    return T;
}

#if NB_EQUIANGULAR
/* A point or spot light: the lights equi-angular sampling aims at. */
NB_FN int nbEquiLight(NbLight l)
{
    return l.type == NB_LIGHT_POINT || l.type == NB_LIGHT_SPOT;
}

/* The ray-parameter hull [*a, *b] of the volumes' boxes that a freshly initialised walk will
 * visit, and *muMax, the sum of those volumes' largest majorants (a bound on the majorant along
 * the segment); 0 when it visits none. */
NB_FN int nbMajorantHull(__private const NbMajorantIter* it, __global const NbVolumeDesc* vols, float* a, float* b,
                         float* muMax)
{
    float lo = NB_INF, hi = -NB_INF, m = 0.0f;
    for (int v = 0; v < NB_NUM_VOLUMES; ++v)
        if (it->state[v] == 0) {
            lo = fmin(lo, it->tEvent[v]);
            hi = fmax(hi, it->tEnd[v]);
            m += nbVolumeMajorant(vols + v);
        }
    *a = lo;
    *b = hi;
    *muMax = m;
    return lo < hi;
}

/* What the equi-angular estimator needs at the point o + t d of a flight segment [0, tEnd): the
 * ratio-tracking transmittance from 0 to t (*T, RGB), the majorant's optical depth over [0, t]
 * (*tauMaj) and the majorant at t (*muAt), which give the distance sampling's proxy pdf, and the
 * densities at t (rho). The walk is the flight's own (same o, d, tEnd, shutter time), so the
 * majorant is the function the free flight sampled. Returns 0 where nothing can scatter at t (a
 * stretch of zero majorant, or past the volumes) or where the roulette ended the estimate. */
NB_FN int nbTrackToPoint(float3 o, float3 d, float t, float tEnd, float seconds, __global const NbVolumeDesc* vols,
                         int volumeCount, __global const int* tables, __global const float* pools,
                         __global const float* majorants, __private NbRng* rng, __private float3* T,
                         __private float* tauMaj, __private float* muAt, __private float* rho,
                         __private int* budget)
{
    float3 Tr = make_float3(1.0f, 1.0f, 1.0f);
    float tm = 0.0f;
    NbMajorantIter it;
    nbMajorantInit(&it, vols, volumeCount, o, d, 0.0f, tEnd, seconds, majorants);
    float tau = -log(nbRngOpen(rng));
    float segEnd, mu;
    while (nbMajorantNext(&it, vols, majorants, &segEnd, &mu)) {
        if (it.t > t)
            return 0; /* t lies where the majorant is 0 */
        const float stop = fmin(segEnd, t);
        const float span = mu * (stop - it.t);
        if (tau >= span) {
            tm += span;
            if (stop >= t) {
                it.t = t;
                nbMajorantDensities(&it, vols, tables, pools, rho);
                *T = Tr;
                *tauMaj = tm;
                *muAt = mu;
                return 1;
            }
            tau -= span;
            it.t = stop;
            continue;
        }
        tm += tau;
        it.t = nbAdvance(it.t, tau / mu);
        --*budget;
        float r[NB_NUM_VOLUMES];
        nbMajorantDensities(&it, vols, tables, pools, r);
        float3 sigma_t = make_float3(0.0f, 0.0f, 0.0f);
        for (int v = 0; v < NB_NUM_VOLUMES; ++v)
            sigma_t = sigma_t + nbSigmaT(vols + v) * r[v];
        Tr = Tr * fmax(make_float3(0.0f, 0.0f, 0.0f), make_float3(1.0f, 1.0f, 1.0f) - sigma_t / mu);
        float m = nbMaxComponent(Tr);
        if (m < 0.1f) {
            if (nbRngNext(rng) >= m * 10.0f)
                return 0;
            Tr = Tr / (m * 10.0f);
        }
        tau = -log(nbRngOpen(rng));
    }
    return 0;
}
#endif

/* The contributions of one camera path, by scattering order. */
typedef struct {
    float3 L[3];         /* L0, L1, L2plus */
    float transmittance; /* camera-ray transmittance estimate (channel average) */
    float depth;         /* distance to the first scattering vertex; valid if hasDepth */
    float hasDepth;
#if NB_NUM_LIGHTS > 0
    float3 perLight[NB_NUM_LIGHTS];
#endif
} NbPathSample;

/* A flight's equi-angular state: the volumes' hull [segA, segB] along it and segMu, a bound on
 * its majorant there; equiMask, bit i: light i takes equi-angular sampling on this flight
 * (i < 32); and the majorant's optical depth so far and mu at the flight's vertex, which that
 * vertex's MIS weight needs. */
typedef struct {
    float segA, segB, segMu, tauMaj, muHit;
    nb_uint equiMask;
} NbEquiFlight;

/* Where a path stands: the flight from o along d (the next one, or with inFlight the one under
 * way), its throughput w and its scattering events so far. A camera path starts at the camera
 * with w 1, order 0 and no flight under way. A flight under way also keeps its walk over the
 * majorants (at its last tentative collision), where it ends, the optical depth drawn to its
 * next collision and its equi-angular state. */
typedef struct {
    NbMajorantIter it;
    float3 o, d, w;
    float tEnd, tau;
    NbEquiFlight equi;
    int order;
    int inFlight;
} NbPathCursor;

/* Follows the path at *cur, adding its contributions to *out. tCamera: where the camera ray ends
 * at a holdout (INFINITY: nowhere). seconds: the path's shutter time after the frame's; every
 * segment of the path reads moving volumes at it (ptscene.h). *budget: the work this launch may
 * still do, in steps: each flight's start, each tentative collision and each step of a shadow
 * ray's ratio tracking takes one. Where none is left at a flight's start or after a null
 * collision, the path stops with its state in *cur (and *rng, *out) and 0 is returned; a later
 * call from there continues it exactly as if it had not stopped. Returns 1 where the path ended. */
NB_FN int nbTracePath(__private NbPathCursor* cur, float tCamera, float seconds, __global const NbPtParams* P,
                      __global const NbLight* lights,
                      __global const NbVolumeDesc* vols, __global const int* tables, __global const float* pools,
                      __global const float* majorants, __global const float* envData,
                      __global const NbBvhNode* bvhNodes, __global const NbGeomPrim* geomPrims,
                      __global int* counters, __private NbRng* rng, __private NbPathSample* out,
                      __private int* budget)
{
    const int volumeCount = P->volumeCount;
    float3 o = cur->o, d = cur->d, w = cur->w;
    int order = cur->order; /* scattering events so far */
    int resumeFlight = cur->inFlight;
    float rho[NB_NUM_VOLUMES];

    for (;;) {
        NbMajorantIter it;
        float tEnd, tau;
#if NB_EQUIANGULAR
        NbEquiFlight ef = {0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0u};
#endif
        if (resumeFlight) { /* the flight a budget stopped, from its last null collision */
            resumeFlight = 0;
            it = cur->it;
            tEnd = cur->tEnd;
            tau = cur->tau;
#if NB_EQUIANGULAR
            ef = cur->equi;
#endif
        } else {
            if (*budget <= 0) {
                cur->o = o;
                cur->d = d;
                cur->w = w;
                cur->order = order;
                cur->inFlight = 0;
                return 0;
            }
            --*budget;
            /* Free flight from o along d, up to the first surface that ends this segment: a holdout
             * for the camera ray, a shadow caster after a scattering event. */
            tEnd = order == 0 ? tCamera : NB_INF;
#if NB_GEOM_SHADOW_CASTERS
            if (order > 0)
                tEnd = nbGeomTrace(bvhNodes, geomPrims, P->geom, o, d, 0.0f, NB_INF, NB_GEOM_SHADOWS, 0);
#endif
            nbMajorantInit(&it, vols, volumeCount, o, d, 0.0f, tEnd, seconds, majorants);
#if NB_EQUIANGULAR
            /* Equi-angular next-event estimation along this flight, one point per point or spot
             * light (docs/pathtracer.md, "Equi-angular sampling"): the single scattering of that
             * light anywhere on [0, tEnd), sigma_s(t) T(0, t) phase I / r^2 T(t, light) / pdf_equi(t),
             * weighted by the power heuristic against the proxy pdf mu(t) exp(-int_0^t mu) of the
             * free flight below; the NEE at the flight's scattering vertex takes the complementary
             * weight. Only where a vertex on this flight may still scatter (order < maxDepth). */
            const int equi = order < P->maxDepth && nbMajorantHull(&it, vols, &ef.segA, &ef.segB, &ef.segMu);
            if (equi) {
                const int next = order + 1 < 2 ? order + 1 : 2;
                for (int i = 0; i < P->lightCount && i < NB_NUM_LIGHTS && i < 32; ++i) {
                    NbLight l = lights[i];
#if NB_HAS_LIGHT_MOTION
                    if (l.motion[1] > 0) /* placed at the path's time (motion.h) */
                        l = nbLightAt(l, majorants + l.motion[0], l.motion[1], seconds);
#endif
                    if (!nbEquiLight(l))
                        continue;
                    if (nbEquiPeakBound(o, d, nbLoad3(l.position), ef.segA, ef.segB) < NB_EQUI_MIN_PEAK * ef.segMu)
                        continue; /* cheap: nbEquiWorthwhile would say no */
                    const NbEquiAngular e = nbEquiInit(o, d, nbLoad3(l.position), ef.segA, ef.segB);
                    if (!nbEquiWorthwhile(e, ef.segMu))
                        continue;
                    ef.equiMask |= 1u << i;
                    const float te = nbEquiSample(e, nbRngNext(rng));
                    const float pe = nbEquiPdf(e, te);
                    if (!(pe > 0.0f))
                        continue;
                    const float3 pe3 = o + d * te;
                    const NbLightSample s = nbSampleLight(l, pe3, 0.0f, 0.0f);
                    if (!(nbMaxComponent(s.weight) > 0.0f))
                        continue; /* outside a spot's cone */
#if NB_GEOM_SHADOW_CASTERS
                    if (nbGeomTrace(bvhNodes, geomPrims, P->geom, pe3, s.wi, 0.0f, s.distance, NB_GEOM_SHADOWS, 1) <
                        NB_INF)
                        continue;
#endif
                    float3 Tc;
                    float tm, muT;
                    if (!nbTrackToPoint(o, d, te, tEnd, seconds, vols, volumeCount, tables, pools, majorants, rng, &Tc,
                                        &tm, &muT, rho, budget))
                        continue;
                    /* In-scattering towards -d, summed over the volumes there (each its phase). */
                    const float cosTheta = dot(s.wi, d);
                    float3 f = make_float3(0.0f, 0.0f, 0.0f);
                    for (int v = 0; v < NB_NUM_VOLUMES; ++v) {
                        NbPhase ph = vols[v].phase;
#if !NB_TWO_LOBE
                        ph.blend = 0.0f;
#endif
                        if (rho[v] > 0.0f)
                            f = f + nbSigmaS(vols + v) * (rho[v] * nbPhaseEval(ph, cosTheta));
                    }
                    if (!(nbMaxComponent(f) > 0.0f))
                        continue;
                    const float wEq = nbEquiMisWeight(pe, muT * exp(-tm));
                    if (!(wEq > 0.0f))
                        continue;
                    const float3 Tl =
                        nbRatioTransmittance(pe3, s.wi, s.distance, seconds, vols, volumeCount, tables, pools,
                                             majorants, rng, budget);
                    const float3 c = w * Tc * f * s.weight * Tl * (wEq / pe);
                    out->L[next] += c;
                    out->perLight[i] += c;
                }
            }
#endif
            tau = -log(nbRngOpen(rng));
        }
        float segEnd, mu;
        int scatterVolume = -1;
        const int bucket = order < 2 ? order : 2;
        while (nbMajorantNext(&it, vols, majorants, &segEnd, &mu)) {
            float span = mu * (segEnd - it.t);
            if (tau >= span) {
                tau -= span;
                it.t = segEnd;
#if NB_EQUIANGULAR
                ef.tauMaj += span;
#endif
                continue;
            }
#if NB_EQUIANGULAR
            ef.tauMaj += tau;
            ef.muHit = mu;
#endif
            it.t = nbAdvance(it.t, tau / mu);
            nbMajorantDensities(&it, vols, tables, pools, rho);
#if NB_HAS_EMISSION
            /* Emission at every tentative collision: its term in the bracket is j / mu. */
            out->L[bucket] += w * nbMajorantEmission(&it, vols, tables, pools) / mu;
#endif
            float3 sigma_t = make_float3(0.0f, 0.0f, 0.0f), sigma_s = sigma_t;
            for (int v = 0; v < NB_NUM_VOLUMES; ++v) {
                sigma_t = sigma_t + nbSigmaT(vols + v) * rho[v];
                sigma_s = sigma_s + nbSigmaS(vols + v) * rho[v];
            }
            float3 sigma_n = fmax(make_float3(0.0f, 0.0f, 0.0f), make_float3(mu, mu, mu) - sigma_t);
            float ps = nbWeighted(w, sigma_s), pn = nbWeighted(w, sigma_n);
            float total = ps + pn;
            if (!(total > 0.0f)) { /* only absorption is left: the path ends */
                w = make_float3(0.0f, 0.0f, 0.0f);
                break;
            }
            float u = nbRngNext(rng) * total;
            if (u < ps) {
                /* A real scattering event; choose the volume that scatters in proportion to its
                 * share of avg(w sigma_s), which fixes the phase function. */
                int chosen = 0;
                float3 sigma_sv = nbSigmaS(vols) * rho[0];
#if NB_NUM_VOLUMES > 1
                float acc = 0.0f;
                for (int v = 0; v < NB_NUM_VOLUMES; ++v) {
                    float3 s = nbSigmaS(vols + v) * rho[v];
                    float sv = nbWeighted(w, s);
                    if (sv > 0.0f) { /* never a volume with no share, whatever the rounding */
                        chosen = v;
                        sigma_sv = s;
                    }
                    acc += sv;
                    if (u < acc)
                        break;
                }
#endif
                float pv = nbWeighted(w, sigma_sv) / total;
                w = w * sigma_sv / (mu * pv);
                scatterVolume = chosen;
                break;
            }
            w = w * sigma_n / (mu * (pn / total));
            tau = -log(nbRngOpen(rng));
            if (--*budget <= 0) { /* stop at this null collision; the next launch goes on from it */
                cur->it = it;
                cur->o = o;
                cur->d = d;
                cur->w = w;
                cur->tEnd = tEnd;
                cur->tau = tau;
#if NB_EQUIANGULAR
                cur->equi = ef;
#endif
                cur->order = order;
                cur->inFlight = 1;
                return 0;
            }
        }

        if (scatterVolume < 0) {
            if (order == 0) {
                /* The camera ray left the volumes, or reached a holdout: E[w] is its
                 * transmittance per channel up to there. A holdout is black with alpha 0 and
                 * hides the background: the pixel keeps the volume in front only. */
                float3 bg = make_float3(P->background[0], P->background[1], P->background[2]);
#if NB_HAS_ENV_MAP
                __global const NbLight* env = lights + P->envLight;
                bg += make_float3(env->color[0], env->color[1], env->color[2]) * nbEnvLookup(P->envMap, envData, d);
#endif
                if (!(tEnd < NB_INF))
                    out->L[0] += w * bg;
                out->transmittance = nbAverage(w);
            }
            return 1; /* escaped, or absorbed by a shadow caster */
        }
        if (order >= P->maxDepth)
            return 1; /* a path with one more event than allowed */
        ++order;
        const float3 p = o + d * it.t;
        if (order == 1) {
            out->depth = it.t;
            out->hasDepth = 1.0f;
        }
        NbPhase phase = vols[scatterVolume].phase;
#if !NB_TWO_LOBE
        phase.blend = 0.0f;
#endif
        const int nb = order < 2 ? order : 2;

#if NB_NUM_LIGHTS > 0
        /* Next-event estimation for every light. Light arrives travelling along -wi and leaves
         * along -d (toward the previous vertex): cos = dot(-wi, -d) (phase.h's convention). */
        for (int i = 0; i < P->lightCount && i < NB_NUM_LIGHTS; ++i) {
            NbLight l = lights[i];
#if NB_HAS_LIGHT_MOTION
            /* A light moving within the shutter, placed at the path's time (motion.h). */
            if (l.motion[1] > 0)
                l = nbLightAt(l, majorants + l.motion[0], l.motion[1], seconds);
#endif
            float u0 = nbRngNext(rng), u1 = nbRngNext(rng);
            NbLightSample s;
            float f;
#if NB_HAS_ENV_MAP
            if (i == P->envLight) {
                /* The map, by MIS of a map sample and a phase sample (the header comment). */
                const float3 colour = nbLoad3(l.color);
                float3 c = make_float3(0.0f, 0.0f, 0.0f);
                float pdfMap;
                float3 wi = nbEnvSample(P->envMap, envData, u0, u1, &pdfMap);
                float fp = nbPhaseEval(phase, dot(wi, d));
                if (pdfMap > 0.0f && fp > 0.0f) {
                    float3 L = colour * nbEnvLookup(P->envMap, envData, wi);
                    if (nbMaxComponent(L) > 0.0f) {
                        float mis = pdfMap * pdfMap / (pdfMap * pdfMap + fp * fp);
                        float3 T = nbRatioTransmittance(p, wi, NB_INF, seconds, vols, volumeCount, tables, pools,
                                                        majorants, rng, budget);
                        c += L * T * (fp * mis / pdfMap);
                    }
                }
                float v0 = nbRngNext(rng), v1 = nbRngNext(rng), v2 = nbRngNext(rng);
                wi = nbPhaseSample(phase, d, v0, v1, v2);
                fp = nbPhaseEval(phase, dot(wi, d));
                float3 L = colour * nbEnvLookup(P->envMap, envData, wi);
                if (fp > 0.0f && nbMaxComponent(L) > 0.0f) {
                    pdfMap = nbEnvPdf(P->envMap, envData, wi);
                    float mis = fp * fp / (pdfMap * pdfMap + fp * fp);
                    float3 T = nbRatioTransmittance(p, wi, NB_INF, seconds, vols, volumeCount, tables, pools,
                                                    majorants, rng, budget);
                    c += L * T * mis; /* p / pdf = 1 */
                }
                c = w * c;
                out->L[nb] += c;
                out->perLight[i] += c;
                continue;
            }
#endif
#if NB_HAS_LIGHT_ENVIRONMENT
            if (l.type == NB_LIGHT_ENVIRONMENT) {
                /* Uniform radiance L from every direction: draw wi from the phase function
                 * instead of uniformly (nbLightSample), so p / pdf = 1 and the estimate is L T.
                 * Unbiased either way; with a forward-peaked phase function uniform directions
                 * would mostly land where p is tiny. */
                s.wi = nbPhaseSample(phase, d, u0, u1, nbRngNext(rng));
                s.distance = NB_INF;
                s.weight = make_float3(l.color[0], l.color[1], l.color[2]);
                f = 1.0f;
            } else
#endif
            {
                s = nbSampleLight(l, p, u0, u1);
                f = nbPhaseEval(phase, dot(s.wi, d));
            }
            if (!(nbMaxComponent(s.weight) > 0.0f) || !(f > 0.0f))
                continue;
#if NB_EQUIANGULAR
            if (i < 32 && ((ef.equiMask >> i) & 1u)) {
                /* The complement of the equi-angular estimator's weight at this vertex. */
                const NbEquiAngular e = nbEquiInit(o, d, nbLoad3(l.position), ef.segA, ef.segB);
                f *= 1.0f - nbEquiMisWeight(nbEquiPdf(e, it.t), ef.muHit * exp(-ef.tauMaj));
                if (!(f > 0.0f))
                    continue;
            }
#endif
#if NB_GEOM_SHADOW_CASTERS
            /* Geometry first: one any-hit ray is cheaper than ratio tracking, and a blocked
             * sample needs neither. */
            if (nbGeomTrace(bvhNodes, geomPrims, P->geom, p, s.wi, 0.0f, s.distance, NB_GEOM_SHADOWS, 1) < NB_INF)
                continue;
#endif
            float3 T = nbRatioTransmittance(p, s.wi, s.distance, seconds, vols, volumeCount, tables, pools, majorants,
                                            rng, budget);
            float3 c = w * s.weight * T * f;
            out->L[nb] += c;
            out->perLight[i] += c;
        }
#endif

        if (order >= P->maxDepth) {
            if (P->countDepthCap)
                atomic_inc(counters + NB_COUNTER_DEPTH_CAP);
#if !NB_HAS_EMISSION
            return 1; /* nothing more to gather: a further flight could only meet emission */
#endif
        }
        if (order >= P->rrDepth) {
            float q = fmin(1.0f, nbMaxComponent(w));
            if (nbRngNext(rng) >= q)
                return 1;
            w = w / q;
        }
        float u0 = nbRngNext(rng), u1 = nbRngNext(rng), u2 = nbRngNext(rng);
        d = nbPhaseSample(phase, d, u0, u1, u2);
        o = p;
    }
}

/* Starts the camera path of sample sampleIndex of pixel (px, py): its random numbers, the camera
 * ray (with the pixel filter and the shutter time) as the cursor, where a holdout ends the ray,
 * the shutter time in seconds, and empty sums. */
NB_FN void nbStartCameraPath(__global const NbPtParams* P, int px, int py, nb_uint pixelIndex, nb_uint sampleIndex,
                             __global const NbVolumeDesc* vols, __global const NbBvhNode* bvhNodes,
                             __global const NbGeomPrim* geomPrims, __global const float* holdoutDepth,
                             __private NbRng* rng, __private NbPathCursor* cursor, __private NbPathSample* r,
                             __private float* tCamera, __private float* seconds)
{
    const NbCamera cam = P->camera;
    *rng = nbRngStart(P->seed, pixelIndex, sampleIndex);
    /* The pixel filter by importance sampling (filter.h): an offset from the pixel's centre. */
    float jx = nbFilterSample(P->filterType, P->filterWidth, nbRngNext(rng));
    float jy = nbFilterSample(P->filterType, P->filterWidth, nbRngNext(rng));
    float time = nbRngNext(rng);
    float3 o, d;
    const float sx = (float)px + 0.5f + jx, sy = (float)py + 0.5f + jy;
    nbCameraRay(cam, sx, sy, P->width, P->height, time, &o, &d);
    /* Holdouts: the camera ray ends at the nearer of the first holdout object and the
     * depth map's depth (Z along the view axis, so t = Z / cos to it). */
    *tCamera = NB_INF;
#if NB_GEOM_HOLDOUTS
    *tCamera = nbGeomTrace(bvhNodes, geomPrims, P->geom, o, d, 0.0f, NB_INF, NB_GEOM_HOLDOUT, 0);
#endif
#if NB_HOLDOUT_DEPTH
    {
        const float z = nbHoldoutDepthAt(holdoutDepth, P->holdoutDepthWidth, P->holdoutDepthHeight,
                                         P->holdoutDepthScale[0], P->holdoutDepthScale[1], sx, sy);
        const float cosAxis = dot(d, nbCameraViewAxis(cam, time));
        if (z < NB_INF && cosAxis > 0.0f)
            *tCamera = fmin(*tCamera, z / cosAxis);
    }
#endif

    r->L[0] = r->L[1] = r->L[2] = make_float3(0.0f, 0.0f, 0.0f);
    r->transmittance = 0.0f;
    r->depth = 0.0f;
    r->hasDepth = 0.0f;
#if NB_NUM_LIGHTS > 0
    for (int i = 0; i < NB_NUM_LIGHTS; ++i)
        r->perLight[i] = make_float3(0.0f, 0.0f, 0.0f);
#endif
    /* Velocity, transform and light motion blur: the camera's time sample as seconds after
     * the frame's (ptscene.h, motion.h). */
    *seconds = 0.0f;
#if NB_HAS_VELOCITY || NB_HAS_MOTION || NB_HAS_LIGHT_MOTION
    if (P->volumeCount > 0)
        *seconds = vols[0].shutter[0] + (vols[0].shutter[1] - vols[0].shutter[0]) * time;
#endif
    cursor->o = o;
    cursor->d = d;
    cursor->w = make_float3(1.0f, 1.0f, 1.0f);
    cursor->order = 0;
    cursor->inFlight = 0;
}

/* Launches of bounded length (src/pathtracer/LaunchSize.h): a launch gives each work item a
 * budget of steps (P->eventBudget; nbTracePath says what a step is), and an item whose budget
 * runs out saves the path it is following here, one slot per item of the launch's range; the
 * next launch over the same range (P->resume) continues it. The image does not depend on where paths stopped: a path
 * continues with its own random numbers and adds to its sample's sums as before. */
typedef struct {
    NbPathSample r;
    NbPathCursor cursor;
    NbRng rng;
    float tCamera, seconds;
    int sample; /* the launch's sample (0 .. P->samples - 1) the path belongs to; -1: none left */
} NbPathState;

/* sizeof(NbPathState) on this device, for the host's allocation. */
__kernel void nbPathStateBytes(__global int* bytes)
{
    if (get_global_id(0) == 0)
        bytes[0] = (int)sizeof(NbPathState);
}

__kernel void nbPathtrace(__global const NbPtParams* P, __global const NbLight* lights,
                          __global const NbVolumeDesc* vols, __global const int* tables, __global const float* pools,
                          __global const float* majorants, __global const float* envData, __global float* acc,
                          __global int* counters, __global const NbBvhNode* bvhNodes,
                          __global const NbGeomPrim* geomPrims, __global const float* holdoutDepth,
                          __global NbPathState* states)
{
    const int gid = (int)get_global_id(0);
    if (gid >= P->pixelCount)
        return;
    const int px = P->x0 + gid % P->cropWidth, py = P->y0 + gid / P->cropWidth;
    const nb_uint pixelIndex = (nb_uint)py * (nb_uint)P->width + (nb_uint)px;
    __global float* a = acc + (size_t)gid * NB_ACC_STRIDE(NB_NUM_LIGHTS);
    __global NbPathState* saved = states + (gid - P->rangeStart);
    int budget = P->eventBudget > 0 ? P->eventBudget : INT_MAX;

    int s = 0, resume = P->resume;
    if (resume) {
        s = saved->sample;
        if (s < 0)
            return; /* this item finished its samples in an earlier launch */
    }
    for (; s < P->samples; ++s) {
        const nb_uint sampleIndex = P->sampleStart + (nb_uint)s;
        NbRng rng;
        NbPathCursor cursor;
        NbPathSample r;
        float tCamera, seconds;
        if (resume) {
            resume = 0;
            rng = saved->rng;
            cursor = saved->cursor;
            r = saved->r;
            tCamera = saved->tCamera;
            seconds = saved->seconds;
        } else {
            nbStartCameraPath(P, px, py, pixelIndex, sampleIndex, vols, bvhNodes, geomPrims, holdoutDepth, &rng,
                              &cursor, &r, &tCamera, &seconds);
        }
        if (!nbTracePath(&cursor, tCamera, seconds, P, lights, vols, tables, pools, majorants, envData, bvhNodes,
                         geomPrims, counters, &rng, &r, &budget)) {
            saved->r = r;
            saved->cursor = cursor;
            saved->rng = rng;
            saved->tCamera = tCamera;
            saved->seconds = seconds;
            saved->sample = s;
            atomic_inc(counters + NB_COUNTER_SUSPENDED);
            return;
        }

        /* A non-finite sample (a bug or a float overflow) would poison the pixel for good:
         * count it and drop it. */
        float3 beauty = r.L[0] + r.L[1] + r.L[2];
        float y = nbAverage(beauty);
        if (!isfinite(y)) {
            atomic_inc(counters + NB_COUNTER_BAD_SAMPLES);
            r.L[0] = r.L[1] = r.L[2] = make_float3(0.0f, 0.0f, 0.0f);
#if NB_NUM_LIGHTS > 0
            for (int i = 0; i < NB_NUM_LIGHTS; ++i)
                r.perLight[i] = make_float3(0.0f, 0.0f, 0.0f);
#endif
            y = 0.0f;
        }

        /* Running means (Skanberg eq. 39) and Welford's M2: after n samples,
         * variance of the mean = M2 / (n (n - 1)). A sample split's means count from its
         * first sample (accStart). */
        const float inv = 1.0f / (float)(sampleIndex - P->accStart + 1u);
        for (int k = 0; k < 3; ++k) {
            float3 L = r.L[k];
            a[3 * k + 0] += (L.x - a[3 * k + 0]) * inv;
            a[3 * k + 1] += (L.y - a[3 * k + 1]) * inv;
            a[3 * k + 2] += (L.z - a[3 * k + 2]) * inv;
        }
        a[NB_ACC_TRANSMITTANCE] += (r.transmittance - a[NB_ACC_TRANSMITTANCE]) * inv;
        a[NB_ACC_DEPTH_SUM] += (r.depth * r.hasDepth - a[NB_ACC_DEPTH_SUM]) * inv;
        a[NB_ACC_DEPTH_HITS] += (r.hasDepth - a[NB_ACC_DEPTH_HITS]) * inv;
        float delta = y - a[NB_ACC_MEAN_Y];
        a[NB_ACC_MEAN_Y] += delta * inv;
        a[NB_ACC_M2_Y] += delta * (y - a[NB_ACC_MEAN_Y]);
#if NB_NUM_LIGHTS > 0
        for (int i = 0; i < NB_NUM_LIGHTS; ++i) {
            __global float* q = a + NB_ACC_LIGHTS + 3 * i;
            q[0] += (r.perLight[i].x - q[0]) * inv;
            q[1] += (r.perLight[i].y - q[1]) * inv;
            q[2] += (r.perLight[i].z - q[2]) * inv;
        }
#endif
    }
    saved->sample = -1;
}
