// DeepShadowMap.h: per-light transmittance from the light to any point (Tessendorf eq. 27;
// Lokovic & Veach 2000).
//
// Each texel holds the optical depth tau(z) (RGB, since extinction is chromatic) along its ray
// from the light as a piecewise-linear function of depth z, compressed so that the
// transmittance exp(-tau) it reconstructs is within `tolerance` of the marched one *relative
// to the transmittance* wherever T >= kRelativeFloor, and within tolerance * kRelativeFloor
// below: the single-scattered light is proportional to T, so a relative bound is a bound on the
// relative error of L1; darker regions, where nothing visible is lit, cost no vertices.
// Storing optical depth rather than transmittance keeps homogeneous stretches exact with two
// vertices and makes the bound direct: an optical-depth error delta changes T by the factor
// e^{+-delta}.
// Projections: orthographic for distant lights (depth along the direction of travel),
// perspective for spot lights and a cube of six perspective faces for point lights (depth =
// distance from the light, so optical depth is linear in depth in homogeneous media).
// Lookups interpolate bilinearly between the four nearest texels, each evaluated at the
// point's depth.
#pragma once

#include "../../kernels/shared/light.h"
#include "../core/BulkAllocator.h"
#include "../geometry/EmbreeScene.h"
#include "RenderControl.h"
#include "VolumeSet.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace nimbus {

class DeepShadowMap {
public:
    enum class Projection { Orthographic, Perspective, Cube };

    struct Settings {
        int resolution = 256;       // texels per side (per face for cube maps)
        float tolerance = 0.002f;   // max relative transmittance error of the compression
        float stepFraction = 1.0f;  // light-ray march step, voxels
        // Keep the march samples where they can be kept (see hasMarchSamples), for a bake that
        // follows; the caller releases them after.
        bool keepMarchSamples = false;
        // A distant light's disc (its half-angle's tangent; 0: a point on the sky): the lookups
        // average the transmittance over the penumbra (penumbraTexels below). Orthographic only.
        float penumbraSlope = 0.0f;
        // Opaque surfaces that stop the texel rays (docs/geometry.md): behind the first one a
        // texel's optical depth jumps by kOpaqueDepth. Null: none (the map is as without geometry).
        const EmbreeScene* shadowCasters = nullptr;
        // The render's stop flag (RenderControl.h; null: none): the build polls it inside the
        // texel marches and throws Cancelled once it is raised.
        const StopFlag* stop = nullptr;
    };

    // The optical depth added behind a shadow caster: e^-200 is 0 in float, and the camera
    // march's expNeg clamps it to e^-87 ~ 1.6e-38, the "opaque" of every cut-off. A lookup
    // between a lit texel and a shadowed one interpolates tau, so the shadow's edge is sharp to
    // within one texel (and, baked on the voxels, one voxel), never a soft ramp of T.
    static constexpr float kOpaqueDepth = 200.0f;

    DeepShadowMap() = default;
    // Move-only: the kept march samples are addressed by pointers into their rows.
    DeepShadowMap(DeepShadowMap&&) noexcept = default;
    DeepShadowMap& operator=(DeepShadowMap&&) noexcept = default;
    DeepShadowMap(const DeepShadowMap&) = delete;
    DeepShadowMap& operator=(const DeepShadowMap&) = delete;

    // Builds the map for a point, spot or distant light over the volumes (TBB-parallel).
    static DeepShadowMap build(const NbLight& light, const VolumeSet& volumes, const Settings& settings);

    // Where the last lookups in recently used texels ended: nearby lookups hit the same texels
    // at nearby depths, so a search can start there instead of bisecting.
    struct Cursor {
        // Direct-mapped by the texel's (x, y) modulo 32: a brick's 9^3 voxels touch a few
        // hundred texels inside a window narrower than 32 texels, each about a dozen times, so
        // no two of them share a slot and most searches become a step or two from the last
        // vertex. (Slots by texel index modulo 1024 would put rows 4 apart, with 256 texels per
        // row, in the same slots, and a brick's footprint spans ~15 rows.)
        static constexpr uint32_t kSlotBits = 5;
        static constexpr uint32_t kSlots = 1u << (2 * kSlotBits);
        static uint32_t slot(int x, int y)
        {
            constexpr uint32_t m = (1u << kSlotBits) - 1;
            return ((uint32_t(y) & m) << kSlotBits) | (uint32_t(x) & m);
        }
        uint32_t texel[kSlots];
        uint32_t vertex[kSlots];
        Cursor()
        {
            for (uint32_t i = 0; i < kSlots; ++i)
                texel[i] = ~0u, vertex[i] = 0;
        }
    };

    // Transmittance (RGB) from the light to world point p. Points outside the map's footprint
    // see no volume between them and the light and get 1. `cursor` is optional.
    Rgb transmittance(float3 p, Cursor* cursor = nullptr) const { return exp(-opticalDepth(p, cursor)); }
    // The optical depth from the light to p, bilinear over the four nearest texels (and over a
    // soft sun's penumbra, penumbraTexels).
    Rgb opticalDepth(float3 p, Cursor* cursor = nullptr) const;
    // Where p falls in the map: the face, (u, v) in [0,1] across it and the depth z. False
    // where no texel sees p (behind a perspective face). Orthographic maps are affine in p,
    // which lets a caller with a lattice of points project three and step the rest.
    bool project(float3 p, int& face, float& u, float& v, float& z) const;
    // The optical depth at a projected point, unfiltered (bilinear over four texels), and with a
    // soft sun's penumbra filter where it has one (opticalDepth = project + the filtered one).
    Rgb opticalDepthAt(int face, float u, float v, float z, Cursor* cursor = nullptr) const;
    Rgb filteredOpticalDepthAt(int face, float u, float v, float z, Cursor* cursor = nullptr) const;

    // Channel 0 of opticalDepthAt on face 0 of an orthographic map, addressed in texel units
    // (fx = u * resolution - 0.5, so texel centres sit at integers): the light cache bakes grey
    // media through this at every voxel, stepping (fx, fy, z) affinely, so it skips the
    // projection and the two other channels. Same bilinear interpolation and clamping.
    float greyOpticalDepthTexel(float fx, float fy, float z, Cursor& cursor) const;

    // The uncompressed optical depth along each texel's ray at the depths k dz of its march
    // (dz = marchSampleStep(), one lattice for all texels: their rays start on the map's
    // plane): build() keeps it, when asked (Settings::keepMarchSamples), for an orthographic
    // map over one grey volume (the march's uniform lattice) when it fits kMarchSamplesBudget.
    // A lookup is then one index computation per texel instead of a search among compressed
    // vertices, and exact to the march; the light cache bakes from it, then
    // releaseMarchSamples() frees it. greyMarchedDepthTexel: greyOpticalDepthTexel's
    // interpolation and clamping, with the depth in steps (zSteps = z / dz).
    static constexpr size_t kMarchSamplesBudget = size_t(256) << 20;  // bytes
    bool hasMarchSamples() const { return !mSamples.empty(); }
    size_t marchSampleBytes() const;
    float marchSampleStep() const { return mSampleDz; }
    float greyMarchedDepthTexel(float fx, float fy, float zSteps) const
    {
        float tau;
        greyMarchedDepthRow(fx, fy, zSteps, 0.0f, 0.0f, 0.0f, 1, &tau);
        return tau;
    }
    // greyMarchedDepthTexel at n points (fx + i dx, fy + i dy, zSteps + i dz), i = 0..n-1: a
    // row of the bake's voxels. Where the CPU has AVX2 and FMA, a row of eight runs as eight
    // lanes with gathers (greyMarchedDepthRow8); else, and for other n, one point at a time
    // (both inline, in ShadowMapMarchSamples.h).
    void greyMarchedDepthRow(float fx, float fy, float zSteps, float dx, float dy, float dz, int n, float* out) const;
    void releaseMarchSamples();

    Projection projection() const { return mProjection; }
    int resolution() const { return mRes; }

    // A soft sun's penumbra (Settings::penumbraSlope = tan of the disc's half-angle): a point at
    // depth z below the map's plane sees the disc's directions through rays tilted by up to the
    // slope; the map holds parallel rays only, so a lookup averages the transmittance of the
    // parallel rays offset across a disc of radius slope x z / 2 (the mean lateral offset, over
    // the depths between the plane and the point, of a tilted ray; exact for the average over a
    // uniform medium that starts at the plane, an approximation of the penumbra's width
    // elsewhere) with kPenumbraTaps taps, where that radius is at least kPenumbraMinTexels (below
    // it the bilinear lookup's own footprint is wider). T is averaged, not tau: tau = -ln(mean T).
    // penumbraTexels: that radius in texels at world depth z; 0 for a hard light.
    static constexpr int kPenumbraTaps = 7;
    static constexpr float kPenumbraMinTexels = 0.5f;
    // The taps: the centre and a hexagon at radius sqrt(7/12) = 0.764 (equal weights, so their
    // second moment is the disc's, r^2 / 2), unit disc.
    static constexpr float kPenumbraTapX[kPenumbraTaps] = {0.0f, 0.764f, 0.382f, -0.382f, -0.764f, -0.382f, 0.382f};
    static constexpr float kPenumbraTapY[kPenumbraTaps] = {0.0f, 0.0f, 0.6616f, 0.6616f, 0.0f, -0.6616f, -0.6616f};
    float penumbraTexels(float z) const { return mPenumbraTexelsPerMetre * std::max(z, 0.0f); }
    bool hasPenumbra() const { return mPenumbraTexelsPerMetre > 0.0f; }
    size_t vertexCount() const { return mVertices.size(); }
    size_t memoryBytes() const;
    double buildSeconds() const { return mBuildSeconds; }

    // The optical depth stored in texel (face, ix, iy) at depth z, and the texel's ray
    // (u, v in [0,1] across the face): for tests and debugging views.
    Rgb texelOpticalDepth(int face, int ix, int iy, float z) const;
    void texelRay(int face, float u, float v, float3& o, float3& d) const;
    int faceCount() const { return int(mFaces.size()); }

    // One vertex of a texel's optical-depth function: depth z (metres) and tau per channel.
    struct Vertex {
        float z;
        float tau[3];
    };
    // The uncompressed march along a light ray: a vertex at the start of every span and at the
    // end of every step (midpoint rule), optical depth accumulated from the ray origin.
    // A raised `stop` ends the march early (what it leaves is to be discarded).
    static void marchRay(const VolumeSet& volumes, float3 o, float3 d, float stepFraction, std::vector<Vertex>& raw,
                         const StopFlag* stop = nullptr);
    // Greedy piecewise-linear compression of `raw` whose transmittance T' stays within
    // |T' - T| <= tolerance * max(T, kRelativeFloor) of raw's at every raw vertex (and so
    // everywhere between them, both being linear in between).
    static constexpr float kRelativeFloor = 0.01f;
    // channels 1: a grey medium, whose three optical depths are equal; only the first is fitted
    // (the others, equal at every raw vertex, follow exactly).
    static void compress(const std::vector<Vertex>& raw, float tolerance, std::vector<Vertex>& out, int channels = 3);

private:
    struct Face {
        float3 origin;  // orthographic: a corner of the footprint plane; perspective: apex
        float3 right, up, forward;
        float extent;  // orthographic: footprint side, metres; perspective: tan(half angle)
    };

#if defined(__AVX2__) && defined(__FMA__)
    // greyMarchedDepthRow for n = 8, one lane per point: the same arithmetic, with gathers.
    void greyMarchedDepthRow8(float fx, float fy, float zSteps, float dx, float dy, float dz, float* out) const;
#endif

    // Sets mProjection and mFaces for the light and, for orthographic maps, caps mRes at what
    // the density grid resolves (ShadowMapProjection.cpp).
    void placeFaces(const NbLight& light, const VolumeSet& volumes);
    Rgb lookup(uint32_t texel, uint32_t slot, float z, Cursor* cursor) const;
    float greyLookup(uint32_t texel, uint32_t slot, float z, Cursor& cursor) const;
    // Where one texel's march samples lie in its row's samples, while the rows are built.
    // No initialisers: buildTexel writes every field, from the parallel build, so the index is
    // first touched there (BulkVector).
    struct TexelSamples {
        int32_t k0;             // the first sample's depth, k0 dz
        uint32_t first, count;  // where in the row, how many (depths (k0 + i) dz)
    };
    static constexpr uint32_t kEmptyTexel = ~0u;  // TexelSamples::first of a ray that meets nothing
    // Orthographic maps: per texel, whether its ray can meet an occupied brick of some volume
    // (the others are empty without marching).
    std::vector<char> texelsMeetingBricks(const VolumeSet& volumes) const;
    void buildTexel(const VolumeSet& volumes, int face, int ix, int iy, std::vector<Vertex>& out,
                    std::vector<float>* samples, TexelSamples* where, float zStop) const;
    // Per texel, the depth where its ray first meets a shadow caster (0 where one lies between the
    // light and an orthographic map's plane), INFINITY where none.
    std::vector<float> texelStops(const EmbreeScene& casters) const;
    // marchRay for the texels (columns, iy) of an orthographic map over one grey volume, eight
    // rays at once where the build can (MarchParallelRays.h), else one by one: raw[ix] receives
    // texel ix's march.
    void marchTexelRow(const VolumeSet& volumes, int face, int iy, const std::vector<int>& columns,
                       std::vector<std::vector<Vertex>>& raw) const;
    // A texel from its march: the compressed function in `out`; the samples kept for the bake,
    // where asked (samples, where not null). zStop: where a shadow caster stops the ray (the
    // march is cut there and the optical depth jumps by kOpaqueDepth), INFINITY for none.
    void finishTexel(const std::vector<Vertex>& raw, std::vector<Vertex>& out, std::vector<float>* samples,
                     TexelSamples* where, float zStop = INFINITY) const;

    Projection mProjection = Projection::Orthographic;
    int mRes = 0;
    float mTolerance = 0.002f;
    float mStepFraction = 1.0f;
    bool mGrey = false;  // every volume's extinction is equal in R, G and B
    float mSampleDz = 0.0f, mInvSampleDz = 0.0f;
    float mPenumbraTexelsPerMetre = 0.0f;  // slope / 2 x texels per metre (penumbraTexels)
    const StopFlag* mStop = nullptr;       // while it is built: Settings::stop
    // The kept march samples, every row's end to end after two zeros (where texels whose ray
    // meets nothing point), each texel's run padded with a 0 before and a copy after; per texel
    // (structure of arrays, for gathers): lo, the padding 0's index; hi, the last sample's;
    // base = lo + 1 - k0, so the sample at depth k dz is at k + base.
    BulkVector<float> mSamples;
    BulkVector<int32_t> mSampleBase, mSampleLo, mSampleHi;
    std::vector<Face> mFaces;
    std::vector<uint32_t> mOffsets;  // per texel: first vertex; one past the last at the end
    BulkVector<Vertex> mVertices;
    double mBuildSeconds = 0.0;
};

}  // namespace nimbus

// The inline lookups in the kept march samples.
#include "ShadowMapMarchSamples.h"
