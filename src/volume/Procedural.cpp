// Procedural.cpp: the "cloud", "sphere" and "box" generators (Procedural.h, docs/volumes.md).
//
// Cloud and sphere describe density as a function of position plus a conservative test that
// classifies each 8^3 block of voxels (the size of a VDB leaf) as empty, full or mixed. Only
// mixed blocks, the ones that straddle the edge, are evaluated voxel by voxel (in parallel with
// TBB); full blocks become active tiles, the way a modelling package stores a uniform interior.
// The box is filled as tiles plus boundary voxels by OpenVDB itself. Either way the result is
// an ordinary sparse FloatGrid and goes through the same conversion as a file (VdbLoad.cpp).
#include "Procedural.h"

#include "../core/Error.h"
#include "../core/StopFlag.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/Prune.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <sstream>
#include <type_traits>
#include <vector>

namespace nimbus {

namespace {

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;
using openvdb::FloatTree;
using openvdb::Vec3d;
using LeafT = FloatTree::LeafNodeType;
static_assert(std::is_same<VdbFloatGrid, FloatGrid>::value, "Procedural.h spells out openvdb::FloatGrid");

// The index box's voxel count is limited to a 1024^3 box, the largest scale nimbus is measured
// at (docs/benchmarks.md "Scale", issue 18 item 7). Generators allocate only the blocks their
// shape touches (a cloud fills about a fifth of its box), but a box filled throughout would take
// ~6 GB as bricks (4 bytes x 729/512 per voxel), so beyond it a scene almost certainly has a unit
// error. The render's own memory check (render.memory_limit) comes after the volume is built.
constexpr double kMaxVoxels = 1.1e9;
// Lengths (metres) a generator accepts: at most 1e30, so that they and the voxel edge fit a
// float; a voxel edge of at least 2e-5 m, because below about 1.5e-5 m OpenVDB's transform
// refuses the scale as zero ("Non-zero scale values required", a render failure before issue
// 18's sweep). Millimetre-sized volumes stay renderable (WkbStability's scale invariance renders
// a 1 mm sphere with 6.25e-5 m voxels).
constexpr double kMaxLength = 1e30;
constexpr double kMinVoxelEdge = 2e-5;

std::string formatNumber(double v)
{
    std::ostringstream s;
    s << v;
    return s.str();
}

// ---- parameters ------------------------------------------------------------------------------

// The numeric parameters of one generator: unknown names are an error (Mitsuba's rule: a typo
// must not silently fall back to a default), and each value is checked where it is read.
class Params {
public:
    Params(const VolumeSource& source, const std::string& keyPath, std::initializer_list<const char*> known)
        : mSource(source), mKeyPath(keyPath)
    {
        for (const auto& [name, value] : source.params) {
            // An init-capture: C++17 cannot capture a structured binding (clang refuses it).
            bool ok = std::find_if(known.begin(), known.end(), [&n = name](const char* k) { return n == k; }) !=
                      known.end();
            if (!ok) {
                std::string list;
                for (const char* k : known)
                    list += (list.empty() ? "" : ", ") + std::string(k);
                throw InputError(key(name) + ": unknown parameter of generator '" + source.generator + "' (expected " +
                                 list + ")");
            }
            if (!std::isfinite(value))
                throw InputError(key(name) + ": must be finite, got " + formatNumber(value));
        }
    }

    std::string key(const std::string& name) const { return mKeyPath + "." + name; }
    bool has(const char* name) const { return mSource.params.count(name) != 0; }

    double number(const char* name, double fallback, double lo, double hi) const
    {
        auto it = mSource.params.find(name);
        double v = it == mSource.params.end() ? fallback : it->second;
        if (!(v >= lo && v <= hi))
            throw InputError(key(name) + ": must be in [" + formatNumber(lo) + ", " + formatNumber(hi) + "], got " +
                             formatNumber(v));
        return v;
    }

    // A length in metres: (0, kMaxLength].
    double length(const char* name, double fallback) const
    {
        double v = positive(name, fallback);
        if (!(v <= kMaxLength))
            throw InputError(key(name) + ": must be at most " + formatNumber(kMaxLength) + " m, got " +
                             formatNumber(v));
        return v;
    }

    // The voxel edge `edge` that parameter `name` led to must be representable (kMinVoxelEdge).
    void voxelEdge(const char* name, double edge) const
    {
        if (!(edge >= kMinVoxelEdge))
            throw InputError(key(name) + ": the voxel edge would be " + formatNumber(edge) + " m, below the " +
                             formatNumber(kMinVoxelEdge) + " m nimbus grids can hold");
    }

    double positive(const char* name, double fallback) const
    {
        auto it = mSource.params.find(name);
        double v = it == mSource.params.end() ? fallback : it->second;
        if (!(v > 0.0))
            throw InputError(key(name) + ": must be > 0, got " + formatNumber(v));
        return v;
    }

    int integer(const char* name, int fallback, int lo, int hi) const
    {
        double v = number(name, fallback, lo, hi);
        if (v != std::floor(v))
            throw InputError(key(name) + ": must be an integer, got " + formatNumber(v));
        return int(v);
    }

private:
    const VolumeSource& mSource;
    std::string mKeyPath;
};

// `extent` names the parameters that set the grid's size, for the message.
void checkVoxelCount(const Params& p, const CoordBBox& voxels, const std::string& extent)
{
    double n = double(voxels.dim().x()) * voxels.dim().y() * voxels.dim().z();
    if (n > kMaxVoxels)
        throw InputError(p.key("voxel_size") + ": the grid would have " + formatNumber(n) +
                         " voxels, more than the limit of " + formatNumber(kMaxVoxels) +
                         "; use a larger voxel size or a smaller " + extent);
}

// ---- noise -----------------------------------------------------------------------------------

// MurmurHash3's 32-bit finaliser: a cheap integer hash with full avalanche.
inline uint32_t mix32(uint32_t h)
{
    h ^= h >> 16;
    h *= 0x85ebca6bu;
    h ^= h >> 13;
    h *= 0xc2b2ae35u;
    h ^= h >> 16;
    return h;
}

inline uint32_t hashLattice(int x, int y, int z, uint32_t seed)
{
    return mix32(seed ^ mix32(uint32_t(x) + mix32(uint32_t(y) + mix32(uint32_t(z)))));
}

// A uniform number in [0, 1) from (seed, index): shape parameters that do not depend on how
// many threads or in which order they were drawn.
inline double uniform(uint32_t seed, uint32_t index)
{
    return mix32(mix32(seed * 0x9e3779b9u) ^ (index * 0x632be5abu)) * (1.0 / 4294967296.0);
}

// Perlin's improved gradient noise (Perlin 2002, "Improving Noise"; quintic fade, 12 edge
// gradients), with the permutation table replaced by a hash of lattice point and seed so that
// every seed gives an independent unbounded field. Values lie in about [-1, 1].
class GradientNoise {
public:
    explicit GradientNoise(uint32_t seed) : mSeed(seed) {}

    float operator()(double x, double y, double z) const
    {
        double fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
        int ix = int(fx), iy = int(fy), iz = int(fz);
        float u = float(x - fx), v = float(y - fy), w = float(z - fz);
        float su = fade(u), sv = fade(v), sw = fade(w);
        float n[8];
        for (int c = 0; c < 8; ++c) {
            int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
            n[c] = grad(hashLattice(ix + dx, iy + dy, iz + dz, mSeed), u - dx, v - dy, w - dz);
        }
        float x00 = lerp(n[0], n[1], su), x10 = lerp(n[2], n[3], su);
        float x01 = lerp(n[4], n[5], su), x11 = lerp(n[6], n[7], su);
        return lerp(lerp(x00, x10, sv), lerp(x01, x11, sv), sw);
    }

private:
    static float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
    static float lerp(float a, float b, float t) { return a + t * (b - a); }
    static float grad(uint32_t h, float x, float y, float z)
    {
        // Perlin's 12 cube-edge directions (16 entries, four repeated), as in his reference code.
        uint32_t k = h & 15u;
        float a = k < 8 ? x : y;
        float b = k < 4 ? y : (k == 12 || k == 14 ? x : z);
        return ((k & 1u) ? -a : a) + ((k & 2u) ? -b : b);
    }

    uint32_t mSeed;
};

inline float smoothstep01(float t)
{
    t = std::min(std::max(t, 0.0f), 1.0f);
    return t * t * (3.0f - 2.0f * t);
}

// ---- block-wise construction -----------------------------------------------------------------

enum class Block : uint8_t { Empty, Full, Mixed };

// Builds a fog volume over the voxels in `voxels` (index space of `xform`, uniform voxel size
// h). classify(centre, radius) must be conservative for every voxel centre within `radius` of
// the block centre (world units): Empty means density 0 at all of them, Full means `full` at
// all of them. density(p) is evaluated at world positions of voxel centres in mixed blocks.
// A raised `stop` ends the loop over the blocks early (each block is at most 512 density
// evaluations, ~0.1 ms for a cloud of 5 octaves) and throws Cancelled, freeing what was built.
template <class Classify, class Density>
FloatGrid::Ptr buildBlocks(const CoordBBox& voxels, openvdb::math::Transform::Ptr xform, double h, float full,
                           const Classify& classify, const Density& density, const StopFlag* stop)
{
    const int B = int(LeafT::DIM);
    Coord lo = voxels.min() & ~(B - 1), hi = voxels.max() & ~(B - 1);
    const int nx = (hi.x() - lo.x()) / B + 1, ny = (hi.y() - lo.y()) / B + 1, nz = (hi.z() - lo.z()) / B + 1;
    const size_t blocks = size_t(nx) * ny * nz;
    // Distance from a block's centre to its farthest voxel centre: 3.5 voxels along each axis.
    const double radius = 0.5 * (B - 1) * h * std::sqrt(3.0);

    auto blockOrigin = [&](size_t b) {
        return lo + Coord(int(b % nx) * B, int((b / nx) % ny) * B, int(b / (size_t(nx) * ny)) * B);
    };
    std::vector<Block> kinds(blocks, Block::Empty);
    std::vector<std::unique_ptr<LeafT>> leaves(blocks);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t b = r.begin(); b != r.end(); ++b) {
            if (stopRaised(stop))
                return;
            const Coord origin = blockOrigin(b);
            Vec3d centre = xform->indexToWorld(origin.asVec3d() + Vec3d(0.5 * (B - 1)));
            Block kind = classify(centre, radius);
            kinds[b] = kind;
            if (kind != Block::Mixed)
                continue;
            auto leaf = std::make_unique<LeafT>(origin, 0.0f, false);
            for (int x = 0; x < B; ++x)
                for (int y = 0; y < B; ++y)
                    for (int z = 0; z < B; ++z) {
                        Coord ijk = origin + Coord(x, y, z);
                        float v = density(xform->indexToWorld(ijk));
                        if (v > 0.0f)
                            leaf->setValueOn(ijk, v);
                    }
            if (!leaf->isEmpty())
                leaves[b] = std::move(leaf);
        }
    });
    throwIfStopped(stop);

    FloatGrid::Ptr grid = FloatGrid::create(0.0f);
    grid->setTransform(xform);
    FloatTree& tree = grid->tree();
    for (size_t b = 0; b < blocks; ++b) {
        if (leaves[b])
            tree.addLeaf(leaves[b].release());  // the tree takes ownership
        else if (kinds[b] == Block::Full)
            tree.addTile(1, blockOrigin(b), full, true);
    }
    // Merges full leaves and neighbouring tiles into larger tiles; exact (tolerance 0).
    openvdb::tools::prune(tree);
    return grid;
}

// Index box of the voxels whose centres (at ijk * h) cover the world box [lo, hi]. Clamped to
// +-5e8 so that an absurd voxel size reaches checkVoxelCount instead of overflowing an int.
CoordBBox voxelBox(const Vec3d& lo, const Vec3d& hi, double h)
{
    auto index = [h](double v, bool up) {
        double i = up ? std::ceil(v / h) : std::floor(v / h);
        return int(std::min(std::max(i, -5e8), 5e8));
    };
    return CoordBBox(Coord(index(lo.x(), false), index(lo.y(), false), index(lo.z(), false)),
                     Coord(index(hi.x(), true), index(hi.y(), true), index(hi.z(), true)));
}

// ---- sphere ----------------------------------------------------------------------------------

// A ball of uniform density centred at the origin. The edge is a smoothstep of width
// w = max(falloff, voxel_size) centred on `radius`, so density is half its value exactly at
// `radius` and the ball's volume is 4/3 pi radius^3 to first order in w.
FloatGrid::Ptr makeSphere(const Params& p, const StopFlag* stop)
{
    const double r = p.length("radius", 1.0);
    const double h = p.length("voxel_size", r / 48.0);
    p.voxelEdge(p.has("voxel_size") ? "voxel_size" : "radius", h);
    const double d = p.number("density", 1.0, 0.0, 1e30);
    const double falloff = p.number("falloff", 0.0, 0.0, kMaxLength);
    const double w = std::max(falloff, h);
    const double outer = r + 0.5 * w, inner = r - 0.5 * w;
    const CoordBBox voxels = voxelBox(Vec3d(-outer), Vec3d(outer), h);
    checkVoxelCount(p, voxels, "radius or falloff");

    auto classify = [=](const Vec3d& c, double radius) {
        double dist = c.length();
        if (dist - radius >= outer)
            return Block::Empty;
        if (dist + radius <= inner)
            return Block::Full;
        return Block::Mixed;
    };
    auto density = [=](const Vec3d& x) {
        double t = (x.length() - inner) / w;
        return float(d * (1.0 - smoothstep01(float(t))));
    };
    return buildBlocks(voxels, openvdb::math::Transform::createLinearTransform(h), h, float(d), classify, density,
                       stop);
}

// ---- box -------------------------------------------------------------------------------------

// A homogeneous box [-size/2, size/2] per axis, exact for analytic tests. Each axis gets
// n = round(size / voxel_size) voxels of edge size / n (so the faces land exactly), with the
// voxel centres at -size/2 + (i + 1/2) size/n: the outermost centres lie half a voxel inside the
// faces. Trilinear sampling is therefore exactly `density` wherever the point is at least half
// a voxel inside, exactly density/2 on a face, and 0 from half a voxel outside.
FloatGrid::Ptr makeBox(const Params& p)
{
    const double size = p.length("size", 1.0);
    const double sx = p.length("size_x", size), sy = p.length("size_y", size), sz = p.length("size_z", size);
    const double h = p.length("voxel_size", std::min({sx, sy, sz}) / 32.0);
    const double d = p.number("density", 1.0, 0.0, 1e30);
    Coord n(std::max(1, int(std::lround(std::min(sx / h, 1e9)))), std::max(1, int(std::lround(std::min(sy / h, 1e9)))),
            std::max(1, int(std::lround(std::min(sz / h, 1e9)))));
    CoordBBox voxels(Coord(0), n - Coord(1));
    checkVoxelCount(p, voxels, "size (size_x, size_y, size_z)");

    Vec3d edge(sx / n.x(), sy / n.y(), sz / n.z());
    // An axis of one voxel has the axis's size as its edge: name the key that made it small.
    const char* axisKeys[3] = {"size_x", "size_y", "size_z"};
    for (int a = 0; a < 3; ++a) {
        const char* culprit = n[a] > 1 ? (p.has("voxel_size") ? "voxel_size" : "size")
                                        : (p.has(axisKeys[a]) ? axisKeys[a] : "size");
        p.voxelEdge(culprit, edge[a]);
    }
    auto xform = openvdb::math::Transform::createLinearTransform(1.0);
    xform->preScale(edge);
    xform->postTranslate(
        Vec3d(-0.5 * (n.x() - 1) * edge.x(), -0.5 * (n.y() - 1) * edge.y(), -0.5 * (n.z() - 1) * edge.z()));
    FloatGrid::Ptr grid = FloatGrid::create(0.0f);
    grid->setTransform(xform);
    if (d > 0.0)
        grid->tree().fill(voxels, float(d), true);  // tiles where whole nodes fit, voxels elsewhere
    return grid;
}

// ---- cloud -----------------------------------------------------------------------------------

// A cumulus-like cloud: a smooth union of spheres (a body of three and `puffs` smaller ones on
// its upper half) cut by a flat base, its surface displaced outwards by fractal turbulence
// (sum of |noise| octaves, which gives the rounded bulges and sharp creases of cauliflower
// tops), with a smoothstep edge of width `softness` and a uniform interior of `density`.
class CloudShape {
public:
    explicit CloudShape(const Params& p)
        : mRadius(p.length("radius", 2.0)), mVoxel(p.length("voxel_size", mRadius / 64.0)),
          mDensity(float(p.number("density", 1.0, 0.0, 1e30))), mOctaves(p.integer("octaves", 5, 1, 12)),
          mFrequency(p.positive("frequency", 2.5) / mRadius), mAmplitude(p.number("detail", 0.5, 0.0, 2.0) * mRadius),
          mSoftness(p.positive("softness", 0.05) * mRadius), mBase(p.number("base", -0.35, -10.0, 1.0) * mRadius),
          mSeed(uint32_t(p.integer("seed", 1, 0, 2147483647))), mNoise(mix32(mSeed + 0x5bd1e995u))
    {
        const int puffs = p.integer("puffs", 6, 0, 64);
        // The body: a wide core and two shoulders, in units of the radius.
        mSpheres = {{Vec3d(0.0, 0.1, 0.0), 0.7}, {Vec3d(-0.6, -0.15, 0.05), 0.45}, {Vec3d(0.6, -0.15, -0.05), 0.45}};
        for (int k = 0; k < puffs; ++k) {
            double azimuth = 2.0 * M_PI * (k + uniform(mSeed, 4 * k)) / std::max(puffs, 1);
            double elevation = (20.0 + 50.0 * uniform(mSeed, 4 * k + 1)) * M_PI / 180.0;
            double dist = 0.45 + 0.2 * uniform(mSeed, 4 * k + 2);
            double r = 0.3 + 0.15 * uniform(mSeed, 4 * k + 3);
            Vec3d c(1.2 * std::cos(elevation) * std::cos(azimuth), std::sin(elevation),
                    0.8 * std::cos(elevation) * std::sin(azimuth));
            mSpheres.push_back({c * dist, r});
        }
        for (auto& s : mSpheres) {
            s.centre *= mRadius;
            s.radius *= mRadius;
        }
        mBlend = 0.25 * mRadius;
        for (int o = 0; o < mOctaves; ++o)
            mOffsets.push_back(
                Vec3d(uniform(mSeed, 1000 + 3 * o), uniform(mSeed, 1001 + 3 * o), uniform(mSeed, 1002 + 3 * o)) * 97.0);
    }

    double voxelSize() const { return mVoxel; }
    float density() const { return mDensity; }

    // World box holding every voxel centre where the density can be non-zero.
    CoordBBox voxels() const
    {
        Vec3d lo(1e300), hi(-1e300);
        for (const auto& s : mSpheres) {
            lo = openvdb::math::minComponent(lo, s.centre - Vec3d(s.radius));
            hi = openvdb::math::maxComponent(hi, s.centre + Vec3d(s.radius));
        }
        // The smooth union bulges at most blend/4 beyond the spheres; the displacement pushes
        // the surface out by at most kOut * amplitude.
        double margin = 0.25 * mBlend + kOut * mAmplitude + mVoxel;
        lo -= Vec3d(margin);
        hi += Vec3d(margin);
        lo.y() = std::max(lo.y(), mBase - mVoxel);
        return voxelBox(lo, hi, mVoxel);
    }

    Block classify(const Vec3d& c, double radius) const
    {
        // The undisplaced distance is 1-Lipschitz (a smooth minimum and a maximum of distances),
        // and the displacement lies in [-kIn, kOut] * amplitude.
        double s = undisplaced(c);
        if (s - radius >= kOut * mAmplitude)
            return Block::Empty;
        if (s + radius + kIn * mAmplitude <= -mSoftness)
            return Block::Full;
        return Block::Mixed;
    }

    float operator()(const Vec3d& x) const
    {
        double s = undisplaced(x);
        if (s >= kOut * mAmplitude)
            return 0.0f;
        // Displacement fades out towards the flat base so that the base stays flat.
        double fade = std::min(std::max((x.y() - mBase) / (0.25 * mRadius), 0.0), 1.0);
        if (fade > 0.0 && mAmplitude > 0.0)
            s -= mAmplitude * fade * (turbulence(x) - kIn);
        return mDensity * smoothstep01(float(-s / mSoftness));
    }

private:
    struct Sphere {
        Vec3d centre;
        double radius;
    };
    // Turbulence is normalised to [0, 1]; shifting it by kIn makes the mean displacement about
    // zero, so the cloud keeps roughly its nominal radius.
    static constexpr double kIn = 0.3, kOut = 0.7;

    // Polynomial smooth minimum (Quilez): the union blends spheres over a width mBlend.
    static double smoothMin(double a, double b, double k)
    {
        double t = std::max(k - std::fabs(a - b), 0.0) / k;
        return std::min(a, b) - 0.25 * t * t * k;
    }

    double undisplaced(const Vec3d& x) const
    {
        double d = 1e300;
        for (const auto& s : mSpheres)
            d = smoothMin(d, (x - s.centre).length() - s.radius, mBlend);
        return std::max(d, mBase - x.y());
    }

    double turbulence(const Vec3d& x) const
    {
        double sum = 0.0, norm = 0.0, amplitude = 1.0, f = mFrequency;
        for (int o = 0; o < mOctaves; ++o) {
            Vec3d q = x * f + mOffsets[o];
            sum += amplitude * std::fabs(mNoise(q.x(), q.y(), q.z()));
            norm += amplitude;
            amplitude *= 0.5;
            f *= 2.0;
        }
        return std::min(sum / norm, 1.0);
    }

    double mRadius, mVoxel;
    float mDensity;
    int mOctaves;
    double mFrequency, mAmplitude, mSoftness, mBase;
    uint32_t mSeed;
    GradientNoise mNoise;
    double mBlend = 0.0;
    std::vector<Sphere> mSpheres;
    std::vector<Vec3d> mOffsets;
};

FloatGrid::Ptr makeCloud(const Params& p, const StopFlag* stop)
{
    CloudShape cloud(p);
    p.voxelEdge(p.has("voxel_size") ? "voxel_size" : "radius", cloud.voxelSize());
    CoordBBox voxels = cloud.voxels();
    checkVoxelCount(p, voxels, "radius");
    return buildBlocks(
        voxels, openvdb::math::Transform::createLinearTransform(cloud.voxelSize()), cloud.voxelSize(), cloud.density(),
        [&](const Vec3d& c, double radius) { return cloud.classify(c, radius); },
        [&](const Vec3d& x) { return cloud(x); }, stop);
}

}  // namespace

std::shared_ptr<VdbFloatGrid> makeProceduralGrid(const VolumeSource& source, const std::string& keyPath,
                                                 const StopFlag* stop)
{
    FloatGrid::Ptr grid;
    if (source.generator == "cloud")
        grid = makeCloud(Params(source, keyPath,
                                {"radius", "voxel_size", "density", "seed", "octaves", "frequency", "detail",
                                 "softness", "puffs", "base"}),
                         stop);
    else if (source.generator == "sphere")
        grid = makeSphere(Params(source, keyPath, {"radius", "voxel_size", "density", "falloff"}), stop);
    else if (source.generator == "box")
        grid = makeBox(Params(source, keyPath, {"size", "size_x", "size_y", "size_z", "voxel_size", "density"}));
    else
        throw InputError(keyPath + ".generator: unknown generator '" + source.generator +
                         "' (expected cloud, sphere, box)");
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    return grid;
}

void writeProceduralVdb(const VolumeSource& source, const std::string& path)
{
    openvdb::initialize();
    openvdb::GridPtrVec grids{makeProceduralGrid(source, "source")};
    try {
        openvdb::io::File file(path);
        file.write(grids);
        file.close();
    } catch (const openvdb::Exception& e) {
        throw Error("cannot write '" + path + "': " + e.what());
    }
}

}  // namespace nimbus
