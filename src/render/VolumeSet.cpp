#include "VolumeSet.h"

#include "../core/StepCount.h"

#include "BrickWalk.h"

#include "../scene/Scene.h"

#include <algorithm>
#include <atomic>
#include <cmath>

namespace nimbus {

VolumeSet::VolumeSet(std::vector<std::shared_ptr<VolumeData>> volumes, float)
{
    mMinVoxel = std::numeric_limits<float>::infinity();
    for (size_t i = 0; i < volumes.size(); ++i) {
        auto& v = volumes[i];
        if (!v || v->density.empty() || v->worldBounds.empty())
            continue;  // an empty grid renders as nothing
        mBounds.expand(v->worldBounds);
        mHasEmission |= v->hasEmission();
        mMinVoxel = std::min(mMinVoxel, v->voxelSize);
        mVolumes.push_back(std::move(v));
        mSceneIndex.push_back(i);
    }
    mMotion.assign(mVolumes.size(), {});
    if (mVolumes.empty())
        mMinVoxel = 1.0f;
    for (auto& v : mVolumes) {
        Hot h;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                h.m[r * 4 + c] = float(v->indexFromWorld.at(r, c));
        h.sigmaS = v->sigmaS();
        h.sigmaT = v->sigmaT();
        h.emissionScale = v->medium.emissionScale;
        mHot.push_back(h);
    }
}

namespace {

// Appends the spans of non-empty brick slots of one grid along an index-space ray (3D DDA,
// Amanatides & Woo 1987). tIn/tOut bound the ray inside the grid's active bounds. Adjacent slots
// merge into one span, only among this grid's own: `out` may hold another volume's spans, later
// along the ray, which a merge would cut short (VolumeSet::spans sorts and merges them after).
void gridSpans(const BrickGrid& grid, const BrickGrid* emission, float3 o, float3 d, float tIn, float tOut, float step,
               std::vector<Span>& out)
{
    const size_t first = out.size();
    const float B = float(BrickGrid::kBrick);
    BrickDda dda;
    if (!dda.start(o, d, tIn))
        return;
    const int* cell = dda.cell;
    float t = tIn;
    // Cap the walk: a ray crosses at most the sum of the table's dimensions plus a margin.
    Int3 dims = grid.dims();
    int maxSteps = dims.x + dims.y + dims.z + 8;
    for (int i = 0; i < maxSteps && t < tOut; ++i) {
        float tExit = std::min(dda.exit(), tOut);
        float3 centre = make_float3((cell[0] + 0.5f) * B, (cell[1] + 0.5f) * B, (cell[2] + 0.5f) * B);
        bool occupied = grid.majorantAt(centre) > 0.0f || (emission && emission->majorantAt(centre) > 0.0f);
        if (occupied && tExit > t) {
            if (out.size() > first && out.back().t1 >= t - 1e-6f * std::fabs(t) && out.back().step == step)
                out.back().t1 = tExit;
            else
                out.push_back({t, tExit, step});
        }
        t = tExit;
        dda.advance();
    }
}

}  // namespace

void VolumeSet::spans(float3 o, float3 d, float tmin, float tmax, float stepFraction, std::vector<Span>& out) const
{
    out.clear();
    if (mVolumes.empty() || !(tmax > tmin))
        return;
    std::vector<Span> local;
    for (auto& v : mVolumes) {
        float t0, t1;
        if (!v->worldBounds.intersect(o, safeInverse(d), tmin, tmax, t0, t1))
            continue;
        float3 oi = v->indexFromWorld.point(o), di = v->indexFromWorld.vector(d);
        Bbox ib = v->density.activeIndexBounds();
        if (v->hasEmission())
            ib.expand(v->emission.activeIndexBounds());
        float s0, s1;
        if (!ib.intersect(oi, safeInverse(di), t0, t1, s0, s1))
            continue;
        gridSpans(v->density, v->hasEmission() ? &v->emission : nullptr, oi, di, s0, s1, stepFraction * v->voxelSize,
                  local);
    }
    if (local.empty())
        return;
    std::sort(local.begin(), local.end(), [](const Span& a, const Span& b) { return a.t0 < b.t0; });
    // Merge overlaps; where volumes overlap, the finer step wins.
    out.push_back(local[0]);
    for (size_t i = 1; i < local.size(); ++i) {
        Span& last = out.back();
        if (local[i].t0 <= last.t1) {
            last.t1 = std::max(last.t1, local[i].t1);
            last.step = std::min(last.step, local[i].step);
        } else {
            out.push_back(local[i]);
        }
    }
}

MediumSample VolumeSet::sample(float3 p, float* phaseWeights, BrickGrid::Stencil* stencils) const
{
    MediumSample m;
    for (size_t i = 0; i < mVolumes.size(); ++i) {
        const VolumeData& v = *mVolumes[i];
        const Hot& h = mHot[i];
        float w = 0.0f;
        BrickGrid::Stencil st;
        if (v.worldBounds.contains(p)) {
            float3 ip = h.index(p);
            st = v.density.stencil(ip);
            float rho = v.density.interpolate(st);
            if (rho > 0.0f) {
                Rgb s = h.sigmaS * rho;
                m.sigma_s += s;
                m.sigma_t += h.sigmaT * rho;
                w = nbAverage(s);
            }
            if (v.hasEmission())
                m.emission += v.emission.sample3(ip) * h.emissionScale;
        }
        phaseWeights[i] = w;
        stencils[i] = st;
    }
    return m;
}

MediumSample VolumeSet::sample(float3 p, float* phaseWeights) const
{
    thread_local std::vector<float> weights;
    thread_local std::vector<BrickGrid::Stencil> stencils;
    weights.resize(mVolumes.size());
    stencils.resize(mVolumes.size());
    MediumSample m = sample(p, weights.data(), stencils.data());
    if (phaseWeights)
        std::copy(weights.begin(), weights.end(), phaseWeights);
    return m;
}

// ---- velocity motion blur ----------------------------------------------------------------------

void setShutterOf(VolumeSet& volumes, const Scene& scene)
{
    const double fps = double(scene.render.fps);
    volumes.setShutter(float(double(scene.camera.shutterOpen) / fps), float(double(scene.camera.shutterClose) / fps));
    for (size_t i = 0; i < volumes.volumes().size(); ++i) {
        const size_t si = volumes.sceneIndex(i);
        if (si < scene.volumes.size())
            volumes.setTransformMotion(i, transformMotionBlock(scene.volumes[si], *volumes.volumes()[i], scene.render.fps));
    }
}

std::vector<float> transformMotionBlock(const Volume& volume, const VolumeData& data, float fps)
{
    const Keys<Transform>& k = volume.shutterMotion;
    if (k.frames.size() < 2)
        return {};
    std::vector<float> block(NB_MOTION_KNOT * (k.frames.size() + 1), 0.0f);
    const Transform indexFromUser = data.indexFromWorld * volume.transform;
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
            block[size_t(4 * r + c)] = float(indexFromUser.at(r, c));
    for (size_t j = 0; j < k.frames.size(); ++j) {
        float* knot = block.data() + NB_MOTION_KNOT * (j + 1);
        const TrsParts p = splitTrs(k.values[j]);  // the keys were split alike when read (Animation.h)
        knot[0] = float(k.frames[j] / double(fps));
        for (int a = 0; a < 3; ++a)
            knot[1 + a] = float(p.translate[a]), knot[8 + a] = float(p.scale[a]);
        for (int a = 0; a < 4; ++a)
            knot[4 + a] = float(p.rotation[a]);
    }
    return block;
}

void VolumeSet::setShutter(float openSeconds, float closeSeconds)
{
    mShutterOpen = openSeconds, mShutterClose = closeSeconds;
    mMaxDisplacement.assign(mVolumes.size(), 0.0f);
    const float longest = std::max(std::fabs(openSeconds), std::fabs(closeSeconds));
    for (size_t i = 0; i < mVolumes.size(); ++i) {
        const VolumeData& v = *mVolumes[i];
        if (closeSeconds > openSeconds && v.hasVelocity())
            mMaxDisplacement[i] = v.maxSpeed * longest;
    }
    updateMotion();
}

void VolumeSet::setTransformMotion(size_t i, std::vector<float> block)
{
    mMotion[i] = std::move(block);
    updateMotion();
}

void VolumeSet::indexFromWorldAt(size_t i, float seconds, float* m) const
{
    if (mMotion[i].empty()) {
        std::copy(mHot[i].m, mHot[i].m + 12, m);
        return;
    }
    nbMotionIndexFromWorld(mMotion[i].data(), transformKnots(i), seconds, m);
}

float3 VolumeSet::indexAt(size_t i, float3 p, float seconds) const
{
    if (mMotion[i].empty())
        return mHot[i].index(p);
    // A march reads every step of a ray at one time: the matrices are kept per thread until the
    // time (or the set) changes.
    thread_local unsigned long long cachedId = 0;
    thread_local float cachedSeconds = 0.0f;
    thread_local std::vector<float> cached;
    if (cachedId != mMotionId || cachedSeconds != seconds || cached.size() != 12 * mVolumes.size()) {
        cached.resize(12 * mVolumes.size());
        for (size_t v = 0; v < mVolumes.size(); ++v)
            indexFromWorldAt(v, seconds, cached.data() + 12 * v);
        cachedId = mMotionId, cachedSeconds = seconds;
    }
    const float* m = cached.data() + 12 * i;
    return make_float3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                       m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
}

namespace {

Transform transformOf(const float* m)
{
    std::array<double, 16> a{};
    for (int k = 0; k < 12; ++k)
        a[size_t(k)] = double(m[k]);
    a[15] = 1.0;
    return Transform::fromRowMajor(a);
}

}  // namespace

void VolumeSet::updateMotion()
{
    static std::atomic<unsigned long long> ids{0};
    mMotionId = ++ids;
    mMovingBounds = Bbox();
    mMoving = false;
    for (size_t i = 0; i < mVolumes.size(); ++i) {
        mMoving |= mMaxDisplacement.size() > i && mMaxDisplacement[i] > 0.0f;
        mMoving |= !mMotion[i].empty();
        const Bbox ib = movingIndexBounds(i);
        if (mMotion[i].empty() || ib.empty()) {
            mMovingBounds.expand(mVolumes[i]->worldFromIndex.box(ib));
            continue;
        }
        // The box the transform sweeps: its placements at 64 times per knot interval, each grown
        // by half the largest move of a corner between neighbouring times (an arc between two
        // samples strays from its chord by less than that).
        const int knots = transformKnots(i);
        const float* k = mMotion[i].data() + NB_MOTION_KNOT;
        Bbox swept;
        float3 last[8];
        float pad = 0.0f;
        for (int j = 0; j + 1 < knots; ++j)
            for (int n = 0; n <= 64; ++n) {
                const float t0 = k[NB_MOTION_KNOT * j], t1 = k[NB_MOTION_KNOT * (j + 1)];
                float m[12];
                indexFromWorldAt(i, t0 + (t1 - t0) * float(n) / 64.0f, m);
                const Transform worldFromIndex = transformOf(m).inverse();
                for (int c = 0; c < 8; ++c) {
                    const float3 corner = make_float3(c & 1 ? ib.hi.x : ib.lo.x, c & 2 ? ib.hi.y : ib.lo.y,
                                                      c & 4 ? ib.hi.z : ib.lo.z);
                    const float3 w = worldFromIndex.point(corner);
                    if (j > 0 || n > 0)
                        pad = std::max(pad, 0.5f * length(w - last[c]));
                    last[c] = w;
                    swept.expand(w);
                }
            }
        const float grow = pad + 1e-4f * length(swept.extent());
        swept.lo = swept.lo - splat(grow);
        swept.hi = swept.hi + splat(grow);
        mMovingBounds.expand(swept);
    }
}

Bbox VolumeSet::movingIndexBounds(size_t i) const
{
    const VolumeData& v = *mVolumes[i];
    Bbox b = v.density.activeIndexBounds();
    if (v.hasEmission())
        b.expand(v.emission.activeIndexBounds());
    const float grow = maxDisplacement(i);
    if (grow > 0.0f && !b.empty()) {
        b.lo = b.lo - splat(grow + 1.0f);
        b.hi = b.hi + splat(grow + 1.0f);
    }
    return b;
}

float3 VolumeSet::movedIndex(size_t i, float3 q, float seconds) const
{
    if (!(maxDisplacement(i) > 0.0f))
        return q;
    return q - mVolumes[i]->velocity.sample3(q) * seconds;
}

void VolumeSet::spansAt(float seconds, float3 o, float3 d, float tmin, float tmax, float stepFraction,
                        std::vector<Span>& out) const
{
    if (!mMoving) {
        spans(o, d, tmin, tmax, stepFraction, out);
        return;
    }
    out.clear();
    if (!(tmax > tmin))
        return;
    std::vector<Span> local;
    for (size_t i = 0; i < mVolumes.size(); ++i) {
        const VolumeData& v = *mVolumes[i];
        const Bbox ib = movingIndexBounds(i);  // velocity: the grown box holds every time's matter
        float3 oi = v.indexFromWorld.point(o), di = v.indexFromWorld.vector(d);
        if (!mMotion[i].empty()) {  // a moving transform: the ray in index space at this time
            oi = indexAt(i, o, seconds);
            di = indexAt(i, o + d, seconds) - oi;
        }
        float s0, s1;
        if (!ib.intersect(oi, safeInverse(di), tmin, tmax, s0, s1))
            continue;
        const float step = stepFraction * v.voxelSize;
        if (maxDisplacement(i) > 0.0f)
            local.push_back({s0, s1, step});
        else
            gridSpans(v.density, v.hasEmission() ? &v.emission : nullptr, oi, di, s0, s1, step, local);
    }
    if (local.empty())
        return;
    std::sort(local.begin(), local.end(), [](const Span& a, const Span& b) { return a.t0 < b.t0; });
    out.push_back(local[0]);
    for (size_t i = 1; i < local.size(); ++i) {
        Span& last = out.back();
        if (local[i].t0 <= last.t1) {
            last.t1 = std::max(last.t1, local[i].t1);
            last.step = std::min(last.step, local[i].step);
        } else {
            out.push_back(local[i]);
        }
    }
}

MediumSample VolumeSet::sampleAt(float seconds, float3 p, float* phaseWeights, BrickGrid::Stencil* stencils,
                                 float3* lightPoint) const
{
    if (!mMoving) {
        *lightPoint = p;
        return sample(p, phaseWeights, stencils);
    }
    MediumSample m;
    float best = 0.0f;
    bool moved = false;
    *lightPoint = p;
    for (size_t i = 0; i < mVolumes.size(); ++i) {
        const VolumeData& v = *mVolumes[i];
        const Hot& h = mHot[i];
        float w = 0.0f;
        BrickGrid::Stencil st;
        const float3 q = indexAt(i, p, seconds);
        const float3 ip = movedIndex(i, q, seconds);
        st = v.density.stencil(ip);
        const float rho = v.density.interpolate(st);
        if (rho > 0.0f) {
            Rgb s = h.sigmaS * rho;
            m.sigma_s += s;
            m.sigma_t += h.sigmaT * rho;
            w = nbAverage(s);
        }
        if (v.hasEmission())
            m.emission += v.emission.sample3(ip) * h.emissionScale;
        // The volume that scatters most moves the light point; where none scatters, the
        // first that moves there (a uniform flow moves all of space alike). Its matter at p
        // was at index point ip when the maps were made (velocity: the grid's time; a moving
        // transform: the shutter centre's placement, worldFromIndex).
        const bool transformMoves = !mMotion[i].empty();
        if (w > best || (best == 0.0f && !moved && (transformMoves || ip.x != q.x || ip.y != q.y || ip.z != q.z))) {
            best = w;
            moved = true;
            *lightPoint = transformMoves ? v.worldFromIndex.point(ip) : p + v.worldFromIndex.vector(ip - q);
        }
        phaseWeights[i] = w;
        stencils[i] = st;
    }
    return m;
}

MediumSample VolumeSet::sampleAt(float seconds, float3 p, float* phaseWeights) const
{
    if (!mMoving)
        return sample(p, phaseWeights);
    thread_local std::vector<float> weights;
    thread_local std::vector<BrickGrid::Stencil> stencils;
    weights.resize(mVolumes.size());
    stencils.resize(mVolumes.size());
    float3 lightPoint;
    MediumSample m = sampleAt(seconds, p, weights.data(), stencils.data(), &lightPoint);
    if (phaseWeights)
        std::copy(weights.begin(), weights.end(), phaseWeights);
    return m;
}

float3 VolumeSet::lightPointAt(float seconds, float3 p) const
{
    if (!mMoving)
        return p;
    thread_local std::vector<float> weights;
    thread_local std::vector<BrickGrid::Stencil> stencils;
    weights.resize(mVolumes.size());
    stencils.resize(mVolumes.size());
    float3 lightPoint;
    sampleAt(seconds, p, weights.data(), stencils.data(), &lightPoint);
    return lightPoint;
}

Rgb VolumeSet::opticalDepth(float3 o, float3 d, float t0, float t1, float stepFraction, const StopFlag* stop) const
{
    thread_local std::vector<Span> spanList;
    spans(o, d, t0, t1, stepFraction, spanList);
    Rgb tau = splat(0.0f);
    unsigned polled = 0;
    for (const Span& s : spanList) {
        float len = s.t1 - s.t0;
        int n = stepCount(len, s.step);
        float dt = len / float(n);
        for (int k = 0; k < n; ++k) {
            tau += sample(o + d * (s.t0 + (k + 0.5f) * dt)).sigma_t * dt;
            if (++polled % kStopPollInterval == 0 && stopRaised(stop))
                return tau;
        }
    }
    return tau;
}

}  // namespace nimbus
