#include "VrlLightPass.h"

#include "ShadowCasters.h"

#include "../../kernels/shared/envmap.h"
#include "../../kernels/shared/geometry.h"
#include "../../kernels/shared/light.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

namespace {

// Russian roulette from this many scattering events on: the path tracer's (Pathtracer.cpp).
constexpr int kRussianRouletteDepth = 3;
// An unbounded render's light paths end by roulette; this only keeps one from running forever
// (the path tracer's safety cap).
constexpr int kSafetyMaxOrder = 1000000;
// A light path's random stream is keyed apart from the camera samples' (seed, pixel, sample).
constexpr uint32_t kLightStreamKey = 0x6c696768u;

float3 cosineDirection(float3 n, float u0, float u1)
{
    const float r = std::sqrt(u0), phi = 2.0f * NB_PI * u1;
    float3 t, b;
    nbBasis(n, &t, &b);
    return normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::fmax(0.0f, 1.0f - u0)));
}

// A uniform point on the disc of radius R centred at c across direction d.
float3 discPoint(float3 c, float3 d, float R, float u0, float u1)
{
    const float r = R * std::sqrt(u0), phi = 2.0f * NB_PI * u1;
    float3 t, b;
    nbBasis(d, &t, &b);
    return c + t * (r * std::cos(phi)) + b * (r * std::sin(phi));
}

// The pdf (per unit solid angle) of a direction drawn uniformly within the cone of axis `axis` and
// 1 - cos(half angle) = oneMinusCos; 0 outside it.
float conePdf(float3 dir, float3 axis, float oneMinusCos)
{
    // (A hair of slack: nbSampleCone draws within 1 - cos rounded to float, which may be wider.)
    return dot(dir, axis) >= 1.0f - oneMinusCos * 1.0001f ? 1.0f / (2.0f * NB_PI * oneMinusCos) : 0.0f;
}

// The pdf (per unit area across dir) of the line through p along dir drawn from the disc of radius
// R centred at c across dir; 0 where the line passes farther than R from c (a hair of slack for
// lines drawn at the disc's rim).
float discPdf(float3 p, float3 dir, float3 c, float R)
{
    float3 v = p - c;
    v = v - dir * dot(v, dir);
    return dot(v, v) <= R * R * 1.0001f ? 1.0f / (NB_PI * R * R) : 0.0f;
}

float area(const NbLight& l)
{
    return 4.0f * length(nbLoad3(l.axisU)) * length(nbLoad3(l.axisV));
}

}  // namespace

LightPass::LightPass(const RenderContext& ctx, const PathtraceScene& ps, const VrlMedium& medium, int maxDepth)
    : mPs(&ps), mMedium(&medium), mStop(&ctx.stop), mMaxDepth(maxDepth)
{
    const Bbox& b = ctx.volumes.movingBounds();  // with velocity blur, all the shutter sweeps
    mCentre = b.empty() ? make_float3(0, 0, 0) : b.center();
    mRadius = b.empty() ? 0.0f : 0.5f * length(b.extent()) * 1.001f + 1e-4f;
    mDefaultPhase = medium.dominantPhase();
    const float discArea = NB_PI * mRadius * mRadius;
    std::vector<double> power;
    for (size_t i = 0; i < ps.lights.size(); ++i) {
        const NbLight& l = ps.lights[i];
        const double c = std::max(0.0f, nbAverage(nbLoad3(l.color)));
        double p = 0;
        char inward = 0;
        switch (l.type) {
        case NB_LIGHT_POINT: p = 4 * NB_PI * c; break;
        case NB_LIGHT_SPOT: p = 2 * NB_PI * (1 - l.p0) * c; break;
        case NB_LIGHT_DISTANT: p = discArea * c; break;
        case NB_LIGHT_ENVIRONMENT: p = 4 * NB_PI * discArea * c; break;
        case NB_LIGHT_RECT: p = NB_PI * area(l) * c; break;
        case NB_LIGHT_SPHERE: {
            const float r = l.p0;
            const float3 q = fmin(fmax(nbLoad3(l.position), b.lo), b.hi);  // the box's nearest point
            // A sphere moving within the shutter (motion.h) may reach into the box at some time:
            // it emits inward too (unbiased either way; only the overlap needs it).
            inward = !b.empty() && (length(q - nbLoad3(l.position)) < r || l.motion[1] > 0);
            p = NB_PI * 4 * NB_PI * r * r * c * (inward ? 2 : 1);
            break;
        }
        default: break;
        }
        power.push_back(std::isfinite(p) ? p : 0.0);
        mInward.push_back(inward);
    }
    double total = 0;
    for (double p : power)
        total += p;
    if (!(total > 0))
        return;  // no light reaches a volume: no VRLs
    double acc = 0;
    for (double p : power) {
        mProb.push_back(p / total);
        acc += p / total;
        mCdf.push_back(acc);
    }
    mCdf.back() = 1.0;
}

float3 LightPass::ownDirection(const NbLight& l, float a, float b)
{
    return l.type == NB_LIGHT_SPOT ? nbSampleCone(nbLoad3(l.direction), l.p0, a, b) : nbSampleSphereUniform(a, b);
}

LightPass::AimCone LightPass::aimCone(int i) const
{
    const NbLight& l = mPs->lights[size_t(i)];
    AimCone c;
    if (!(mFocus.active || mAimAtVolumes))
        return c;
    // The view's focus, else (where asked) the volumes' bounding sphere: every direction that
    // can meet a volume is in the cone that subtends it.
    const EmissionFocus bounds{true, mCentre, mRadius};
    const EmissionFocus& aim = mFocus.active ? mFocus : bounds;
    const float3 toFocus = aim.centre - nbLoad3(l.position);
    const float dist = length(toFocus);
    // The cone subtending the aim: sin^2 = (R / dist)^2, 1 - cos = sin^2 / (1 + cos); aimed only
    // where the light is outside it, the cone is narrower than the light's own, and wide enough
    // for float directions to tell its rim (1 - cos over 1e-5: half a degree; a lamp farther
    // than about 200 radii of the aim is left as it is).
    const float s2 = dist > 0.0f ? (aim.radius / dist) * (aim.radius / dist) : 1.0f;
    const float cosMax = std::sqrt(std::fmax(0.0f, 1.0f - s2));
    const float oneMinusCos = s2 / (1.0f + cosMax);
    const float ownOneMinusCos = l.type == NB_LIGHT_SPOT ? 1.0f - l.p0 : 2.0f;
    if (s2 < 0.9998f && oneMinusCos < ownOneMinusCos && oneMinusCos > 1e-5f) {
        c.active = true;
        c.axis = toFocus * (1.0f / dist);
        c.cosMax = cosMax;
        c.oneMinusCos = oneMinusCos;
    }
    return c;
}

float LightPass::directionPdf(int i, float3 dir) const
{
    const NbLight& l = mPs->lights[size_t(i)];
    if (l.type != NB_LIGHT_POINT && l.type != NB_LIGHT_SPOT)
        return 0.0f;
    // The light's own distribution: uniform over the sphere, or over the spot's outer cone.
    const float own = l.type == NB_LIGHT_SPOT ? conePdf(dir, nbLoad3(l.direction), 1.0f - l.p0) : 1.0f / (4.0f * NB_PI);
    const AimCone aim = aimCone(i);
    if (!aim.active)
        return own;
    return kFocusDefensive * own + (1.0f - kFocusDefensive) * conePdf(dir, aim.axis, aim.oneMinusCos);
}

float LightPass::linePdf(int i, float3 q, float3 dir) const
{
    const NbLight& l = mPs->lights[size_t(i)];
    if (l.type != NB_LIGHT_DISTANT || i == mPs->envLight)
        return 0.0f;
    if (!mFocus.active)
        return discPdf(q, dir, mCentre, mRadius);
    return kFocusDefensive * discPdf(q, dir, mCentre, mRadius) +
           (1.0f - kFocusDefensive) * discPdf(q, dir, mFocus.centre, mFocus.radius);
}

double LightPass::selectionProbability(int i) const
{
    return i >= 0 && size_t(i) < mProb.size() ? mProb[size_t(i)] : 0.0;
}

bool LightPass::emit(int i, NbRng& rng, float3& x, float3& dir, float3& W, float& tEnd) const
{
    const NbLight& l = mPs->lights[size_t(i)];
    const float3 colour = nbLoad3(l.color);
    const float u0 = nbRngNext(&rng), u1 = nbRngNext(&rng), u2 = nbRngNext(&rng), u3 = nbRngNext(&rng);
    tEnd = INFINITY;
    switch (l.type) {
    case NB_LIGHT_POINT:
    case NB_LIGHT_SPOT: {
        x = nbLoad3(l.position);
        const bool spot = l.type == NB_LIGHT_SPOT;
        const AimCone aim = aimCone(i);
        if (aim.active) {
            dir = nbRngNext(&rng) < kFocusDefensive ? ownDirection(l, u0, u1)
                                                    : nbSampleCone(aim.axis, aim.cosMax, u0, u1);
            const float pdf = directionPdf(i, dir);
            if (!(pdf > 0.0f))
                return false;
            W = colour * ((spot ? nbSpotFalloff(l, -dir) : 1.0f) / pdf);  // 0 outside a spot's cone
        } else {
            dir = ownDirection(l, u0, u1);
            W = colour * (spot ? 2.0f * NB_PI * (1.0f - l.p0) * nbSpotFalloff(l, -dir) : 4.0f * NB_PI);
        }
        return nbMaxComponent(W) > 0.0f;
    }
    case NB_LIGHT_DISTANT:
    case NB_LIGHT_ENVIRONMENT: {
        // L / pdf per direction (light.h's weight), then the disc across the direction.
        float3 toLight;
        float3 perDirection;
        if (i == mPs->envLight) {
            float pdf;
            toLight = nbEnvSample(mPs->envMap, mPs->envData.data(), u0, u1, &pdf);
            if (!(pdf > 0.0f))
                return false;
            perDirection = colour * nbEnvLookup(mPs->envMap, mPs->envData.data(), toLight) / pdf;
        } else {
            const NbLightSample s = nbLightSample(l, mCentre, u0, u1);
            toLight = s.wi;
            perDirection = s.weight;
        }
        dir = -toLight;
        if (mFocus.active) {
            const bool own = nbRngNext(&rng) < kFocusDefensive;
            const float3 p =
                own ? discPoint(mCentre, dir, mRadius, u2, u3) : discPoint(mFocus.centre, dir, mFocus.radius, u2, u3);
            const float pdf = kFocusDefensive * discPdf(p, dir, mCentre, mRadius) +
                              (1.0f - kFocusDefensive) * discPdf(p, dir, mFocus.centre, mFocus.radius);
            if (!(pdf > 0.0f))
                return false;
            x = p + dir * (dot(mCentre - p, dir) - mRadius);  // outside the volumes' sphere
            W = perDirection * (1.0f / pdf);
        } else {
            x = discPoint(mCentre, dir, mRadius, u2, u3) - dir * mRadius;
            W = perDirection * (NB_PI * mRadius * mRadius);
        }
        return nbMaxComponent(W) > 0.0f;
    }
    case NB_LIGHT_RECT: {
        const float3 n = nbLoad3(l.direction);
        x = nbLoad3(l.position) + nbLoad3(l.axisU) * (2.0f * u0 - 1.0f) + nbLoad3(l.axisV) * (2.0f * u1 - 1.0f);
        dir = cosineDirection(n, u2, u3);
        W = colour * (NB_PI * area(l));
        return true;
    }
    case NB_LIGHT_SPHERE: {
        const float r = l.p0;
        const float3 n = nbSampleSphereUniform(u0, u1);
        x = nbLoad3(l.position) + n * r;
        W = colour * (NB_PI * 4.0f * NB_PI * r * r);
        float v = nbRngNext(&rng);
        if (mInward[size_t(i)] && v < 0.5f) {
            dir = cosineDirection(-n, u2, u3);
            tEnd = -2.0f * r * dot(dir, n);  // the chord to the far side
            W = W * 2.0f;
        } else {
            dir = cosineDirection(n, u2, u3);
            if (mInward[size_t(i)])
                W = W * 2.0f;
        }
        return true;
    }
    default: return false;
    }
}

void LightPass::tracePath(uint32_t seed, uint32_t iteration, int path, int paths, std::vector<Vrl>& out) const
{
    if (mCdf.empty())
        return;
    NbRng rng = nbRngStart(nbPcgHash(seed ^ kLightStreamKey), nb_uint(path), iteration);
    const double u = nbRngNext(&rng);
    const int light = std::min(int(std::upper_bound(mCdf.begin(), mCdf.end(), u) - mCdf.begin()), int(mCdf.size()) - 1);
    float3 x, dir, W;
    float tEnd;
    if (!emit(light, rng, x, dir, W, tEnd))
        return;
    const float3 flux = W / float(mProb[size_t(light)] * double(paths));
    const int maxOrder = mMaxDepth > 0 ? mMaxDepth - 2 : kSafetyMaxOrder;  // a VRL of order k: k + 2 events
    const PathtraceScene& ps = *mPs;
    float3 w = make_float3(1, 1, 1);
    NbPhase phase = mDefaultPhase;
    float3 inDir = make_float3(0, 0, 0);
    for (int order = 0; order <= maxOrder; ++order) {
        if (order % kStopPollInterval == kStopPollInterval - 1 && mStop->raised())
            return;
        tEnd = std::fmin(tEnd, casterDistance(ps, x, dir));
        float t0, t1;
        if (!mMedium->span(x, dir, 0.0f, tEnd, t0, t1))
            return;  // the ray misses every volume
        Vrl v;
        v.origin = x;
        v.dir = dir;
        v.t0 = t0;
        v.t1 = t1;
        v.flux = flux * w;
        v.phase = phase;
        v.inDir = inDir;
        v.order = order;
        v.light = light;
        out.push_back(v);
        if (order == maxOrder)
            return;
        const FlightResult f = mMedium->freeFlight(x, dir, tEnd, w, rng, nullptr);
        if (!f.scattered)
            return;
        if (order + 1 >= kRussianRouletteDepth) {
            const float q = std::fmin(1.0f, nbMaxComponent(w));
            if (nbRngNext(&rng) >= q)
                return;
            w = w / q;
        }
        x = x + dir * f.t;
        phase = mMedium->phase(f.volume);
        const float v0 = nbRngNext(&rng), v1 = nbRngNext(&rng), v2 = nbRngNext(&rng);
        inDir = dir;
        dir = nbPhaseSample(phase, dir, v0, v1, v2);
        tEnd = INFINITY;
    }
}

std::vector<Vrl> LightPass::trace(uint32_t seed, uint32_t iteration, int paths) const
{
    std::vector<std::vector<Vrl>> perPath(size_t(std::max(0, paths)));
    if (mCdf.empty())
        return {};
    tbb::parallel_for(0, paths, [&](int p) {
        if (!mStop->raised())
            tracePath(seed, iteration, p, paths, perPath[size_t(p)]);
    });
    std::vector<Vrl> out;
    for (const std::vector<Vrl>& v : perPath)
        out.insert(out.end(), v.begin(), v.end());
    return out;
}

}  // namespace nimbus::vrl
