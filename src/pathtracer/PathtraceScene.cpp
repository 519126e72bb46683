#include "PathtraceScene.h"

#include "../core/Error.h"
#include "NanoDensity.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

namespace nimbus {

static_assert(sizeof(NbGridDesc) == 48, "NbGridDesc layout is shared with OpenCL");
static_assert(sizeof(NbVolumeDesc) == 352, "NbVolumeDesc layout is shared with OpenCL");
static_assert(sizeof(NbPtParams) == 324, "NbPtParams layout is shared with OpenCL");
static_assert(sizeof(NbLight) == 112, "NbLight layout is shared with OpenCL");

namespace {

// The slot majorants of sigma_t are inflated by this relative margin: trilinear interpolation
// never exceeds the largest corner mathematically, but float rounding can overshoot it by an
// ulp or two, and a majorant below sigma_t would make null-collision weights negative.
constexpr float kMajorantMargin = 1.0f + 1e-5f;

// Collisions per metre in emitting slots whose density majorant is lower: emission is gathered
// at tentative collisions (pathtrace.cl), so an emitting slot needs a positive rate even where
// the density is zero. Half a collision per voxel: about four per brick crossed.
constexpr float kEmissionCollisionsPerVoxel = 0.5f;

NbGridDesc appendGrid(const BrickGrid& g, PathtraceScene& s)
{
    NbGridDesc d{};
    if (g.empty())
        return d;  // channels 0: absent
    d.brickLo[0] = g.brickLo().x, d.brickLo[1] = g.brickLo().y, d.brickLo[2] = g.brickLo().z;
    d.dims[0] = g.dims().x, d.dims[1] = g.dims().y, d.dims[2] = g.dims().z;
    d.dims[3] = g.channels();
    d.tableOffset = nb_uint(s.tables.size());
    d.poolOffset = nb_uint(s.pools.size());
    d.majorantOffset = nb_uint(s.majorants.size());
    d.maxValue = g.maxValue();
    s.tables.insert(s.tables.end(), g.table().begin(), g.table().end());
    s.pools.insert(s.pools.end(), g.pool().begin(), g.pool().end());
    s.majorants.insert(s.majorants.end(), g.majorants().begin(), g.majorants().end());
    if (s.pools.size() > size_t(0xffffffffu))
        throw Error("path tracer: the volumes hold more than 2^32 values (16 GiB); not supported");
    return d;
}

// A density grid as a NanoVDB grid in the pool buffer, 32-byte aligned (kernels/shared/nanogrid.h):
// poolOffset is its first word; no table; the slot majorants as appendGrid's.
NbGridDesc appendNanoDensity(const BrickGrid& g, PathtraceScene& s)
{
    NbGridDesc d{};
    if (g.empty())
        return d;
    d.brickLo[0] = g.brickLo().x, d.brickLo[1] = g.brickLo().y, d.brickLo[2] = g.brickLo().z;
    d.dims[0] = g.dims().x, d.dims[1] = g.dims().y, d.dims[2] = g.dims().z;
    d.dims[3] = g.channels();
    d.majorantOffset = nb_uint(s.majorants.size());
    d.maxValue = g.maxValue();
    const std::vector<uint32_t> words = buildNanoDensity(g);
    s.pools.resize((s.pools.size() + 7) / 8 * 8, 0.0f);
    d.poolOffset = nb_uint(s.pools.size());
    s.pools.resize(s.pools.size() + words.size());
    std::memcpy(s.pools.data() + d.poolOffset, words.data(), words.size() * sizeof(uint32_t));
    s.majorants.insert(s.majorants.end(), g.majorants().begin(), g.majorants().end());
    if (s.pools.size() > size_t(0xffffffffu))
        throw Error("path tracer: the volumes hold more than 2^32 values (16 GiB); not supported");
    return d;
}

// The slot majorant of grid g at brick (bx, by, bz): 0 outside its table (brickgrid.h).
float slotMajorant(const BrickGrid& g, int bx, int by, int bz)
{
    if (g.empty())
        return 0.0f;
    const int x = bx - g.brickLo().x, y = by - g.brickLo().y, z = bz - g.brickLo().z;
    if (x < 0 || y < 0 || z < 0 || x >= g.dims().x || y >= g.dims().y || z >= g.dims().z)
        return 0.0f;
    return g.majorants()[(size_t(z) * size_t(g.dims().y) + size_t(y)) * size_t(g.dims().x) + size_t(x)];
}

// Velocity blur (ptscene.h): the volume's box grown by its largest displacement over the shutter
// (plus a voxel), brick aligned, and over its slots the extinction majorant that bounds every
// point at every shutter time: a lookup from slot b lands at most ceil(grow / 8) slots away per
// axis, so the static slot majorants (nbSlotMajorant's, emission's collision rate included) are
// max-filtered over that many slots, one axis at a time.
NbGridDesc appendMotionMajorant(const VolumeData& v, const NbVolumeDesc& d, float grow, PathtraceScene& s)
{
    NbGridDesc g{};
    const float B = float(BrickGrid::kBrick);
    int lo[3], hi[3], dims[3];
    for (int a = 0; a < 3; ++a) {
        lo[a] = int(std::floor(d.boundsLo[a] / B));
        hi[a] = int(std::ceil(d.boundsHi[a] / B)) - 1;
        dims[a] = std::max(1, hi[a] - lo[a] + 1);
        g.brickLo[a] = lo[a];
        g.dims[a] = dims[a];
    }
    g.dims[3] = 1;
    const int r = int(std::ceil(grow / B)) + 1;
    const size_t n = size_t(dims[0]) * size_t(dims[1]) * size_t(dims[2]);
    if (n > (size_t(1) << 30))
        throw Error("path tracer: volume '" + v.name + "' moves across more than 2^30 brick slots over the shutter; "
                    "lower velocity_scale or the shutter");
    std::vector<float> m(n), tmp(n);
    auto at = [&](int x, int y, int z) { return (size_t(z) * size_t(dims[1]) + size_t(y)) * size_t(dims[0]) + size_t(x); };
    for (int z = 0; z < dims[2]; ++z)
        for (int y = 0; y < dims[1]; ++y)
            for (int x = 0; x < dims[0]; ++x) {
                const int bx = lo[0] + x, by = lo[1] + y, bz = lo[2] + z;
                float value = d.sigma_t[3] * slotMajorant(v.density, bx, by, bz);
                if (v.hasEmission() && slotMajorant(v.emission, bx, by, bz) > 0.0f)
                    value = std::max(value, d.boundsLo[3]);
                m[at(x, y, z)] = value;
            }
    for (int axis = 0; axis < 3; ++axis) {
        tmp = m;
        for (int z = 0; z < dims[2]; ++z)
            for (int y = 0; y < dims[1]; ++y)
                for (int x = 0; x < dims[0]; ++x) {
                    const int c[3] = {x, y, z};
                    float best = 0.0f;
                    for (int k = std::max(0, c[axis] - r); k <= std::min(dims[axis] - 1, c[axis] + r); ++k) {
                        int e[3] = {x, y, z};
                        e[axis] = k;
                        best = std::max(best, tmp[at(e[0], e[1], e[2])]);
                    }
                    m[at(x, y, z)] = best;
                }
    }
    g.majorantOffset = nb_uint(s.majorants.size());
    g.maxValue = *std::max_element(m.begin(), m.end());
    s.majorants.insert(s.majorants.end(), m.begin(), m.end());
    return g;
}

bool isGrey(Rgb c)
{
    return c.x == c.y && c.y == c.z;
}

}  // namespace

PathtraceScene buildPathtraceScene(const RenderContext& ctx, bool pnanovdbDensity)
{
    PathtraceScene s;
    s.pnanovdb = pnanovdbDensity;
    const auto& vols = ctx.volumes.volumes();
    if (int(vols.size()) > kMaxPathtraceVolumes)
        throw Error("path tracer: " + std::to_string(vols.size()) + " volumes; at most " +
                    std::to_string(kMaxPathtraceVolumes) + " are supported (merge grids into one volume)");
    for (size_t vi = 0; vi < vols.size(); ++vi) {
        const VolumeData& v = *vols[vi];
        NbVolumeDesc d{};
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                d.indexFromWorld[4 * r + c] = float(v.indexFromWorld.at(r, c));
        Rgb ss = v.sigmaS(), st = v.sigmaT();
        d.sigma_s[0] = ss.x, d.sigma_s[1] = ss.y, d.sigma_s[2] = ss.z;
        d.sigma_t[0] = st.x, d.sigma_t[1] = st.y, d.sigma_t[2] = st.z;
        d.sigma_t[3] = nbMaxComponent(st) * kMajorantMargin;
        d.phase = v.medium.phase;
        if (!(d.phase.blend > 0.0f))
            d.phase.blend = 0.0f;
        s.twoLobe |= d.phase.blend > 0.0f;
        s.chromatic |= !isGrey(ss) || !isGrey(st);

        // With velocity blur, the box the volume sweeps over the shutter (VolumeSet::setShutter).
        const float grow = ctx.volumes.maxDisplacement(vi);
        const Bbox b = ctx.volumes.movingIndexBounds(vi);
        d.boundsLo[0] = b.lo.x, d.boundsLo[1] = b.lo.y, d.boundsLo[2] = b.lo.z;
        d.boundsHi[0] = b.hi.x, d.boundsHi[1] = b.hi.y, d.boundsHi[2] = b.hi.z;
        d.boundsLo[3] = kEmissionCollisionsPerVoxel / std::max(v.voxelSize, 1e-12f);
        d.boundsHi[3] = v.medium.emissionScale;
        d.density = pnanovdbDensity ? appendNanoDensity(v.density, s) : appendGrid(v.density, s);
        if (v.hasEmission()) {
            d.emission = appendGrid(v.emission, s);
            s.emission = true;
        }
        if (grow > 0.0f) {
            d.velocity = appendGrid(v.velocity, s);
            d.motionMajorant = appendMotionMajorant(v, d, grow, s);
            s.velocity = true;
        }
        d.shutter[0] = ctx.volumes.shutterSeconds(0.0f);
        d.shutter[1] = ctx.volumes.shutterSeconds(1.0f);
        // A transform moving within the shutter: its block (motion.h) after the slot majorants.
        if (const std::vector<float>& block = ctx.volumes.transformMotion(vi); !block.empty()) {
            d.motion[0] = int(s.majorants.size());
            d.motion[1] = ctx.volumes.transformKnots(vi);
            s.majorants.insert(s.majorants.end(), block.begin(), block.end());
            s.motion = true;
        }
        s.volumes.push_back(d);
    }
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        if (!e.used)
            continue;
        if (e.map) {  // SceneValidate allows one map per scene
            s.envLight = int(s.lights.size());
            s.envMap = e.map->header();
            s.envData = e.map->data();
        }
        NbLight l = e.light;
        if (!e.motion.empty()) {  // a light moving within the shutter: its knots (motion.h)
            l.motion[0] = int(s.majorants.size());
            l.motion[1] = int(e.motion.size() / NB_MOTION_KNOT);
            s.majorants.insert(s.majorants.end(), e.motion.begin(), e.motion.end());
            s.lightMotion = true;
        }
        s.lights.push_back(l);
        s.lightEntry.push_back(int(i));
        s.lightTypes |= 1u << e.light.type;
    }
    // Equi-angular sampling aims at point and spot lights only (pathtrace.cl).
    s.equiangular = ctx.scene && ctx.scene->render.equiangular &&
                    (s.lightTypes & ((1u << NB_LIGHT_POINT) | (1u << NB_LIGHT_SPOT))) != 0;
    if (ctx.geometry) {
        // The planning pass built it for a render (Renderer.cpp); contexts made otherwise build it here.
        s.geometry = ctx.kernelBvh ? *ctx.kernelBvh : buildKernelBvh(ctx.geometry->geometry());
        s.holdouts = ctx.geometry->hasHoldouts();
        s.shadowCasters = ctx.geometry->hasShadowCasters();
    }
    if (ctx.holdoutDepth) {
        s.holdoutDepth = ctx.holdoutDepth->depths();
        s.holdoutDepthWidth = ctx.holdoutDepth->width();
        s.holdoutDepthHeight = ctx.holdoutDepth->height();
        s.holdoutDepthScale[0] = ctx.holdoutDepth->scaleX();
        s.holdoutDepthScale[1] = ctx.holdoutDepth->scaleY();
    }
    return s;
}

std::string PathtraceScene::defines(bool globalMajorant) const
{
    std::ostringstream o;
    o << "-D NB_NUM_VOLUMES=" << std::max<size_t>(1, volumes.size()) << " -D NB_NUM_LIGHTS=" << lights.size();
    const char* names[] = {"DISTANT", "POINT", "SPOT", "RECT", "SPHERE", "ENVIRONMENT"};
    for (int t = 0; t < 6; ++t)
        o << " -D NB_HAS_LIGHT_" << names[t] << "=" << ((lightTypes >> t) & 1u);
    o << " -D NB_HAS_ENV_MAP=" << (envLight >= 0 ? 1 : 0);
    o << " -D NB_HAS_EMISSION=" << (emission ? 1 : 0) << " -D NB_TWO_LOBE=" << (twoLobe ? 1 : 0)
      << " -D NB_CHROMATIC=" << (chromatic ? 1 : 0) << " -D NB_GLOBAL_MAJORANT=" << (globalMajorant ? 1 : 0)
      << " -D NB_GEOM_HOLDOUTS=" << (holdouts ? 1 : 0) << " -D NB_GEOM_SHADOW_CASTERS=" << (shadowCasters ? 1 : 0)
      << " -D NB_HOLDOUT_DEPTH=" << (holdoutDepth.empty() ? 0 : 1) << " -D NB_HAS_VELOCITY=" << (velocity ? 1 : 0)
      << " -D NB_EQUIANGULAR=" << (equiangular ? 1 : 0) << " -D NB_GRID_PNANOVDB=" << (pnanovdb ? 1 : 0)
      << " -D NB_HAS_MOTION=" << (motion ? 1 : 0) << " -D NB_HAS_LIGHT_MOTION=" << (lightMotion ? 1 : 0);
    return o.str();
}

}  // namespace nimbus
