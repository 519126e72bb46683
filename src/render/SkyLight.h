// SkyLight.h: an environment light's transmittance-weighted radiance, precomputed once per render
// on a grid per volume and read by single's and wkb's camera marches instead of shadow rays at
// every step (issue 17; docs/single-scattering.md "environment light").
//
// At each grid node y, in the real SH basis of SphericalHarmonics.h (order J, polar axis +z),
//     L^jm(y) = int y_jm(n') T(y, -n') L_env(-n') dOmega'          (Tessendorf eq. 87)
// with n' the direction light travels (toward y), L_env(w) the sky's radiance seen looking along
// w and T the transmittance from y out of the volumes along w, RGB. The light the medium at y
// scatters toward the camera, along w_o = -d, is then (the addition theorem closes the sum over
// m; p_j the phase function's Legendre moments, phase.h)
//     int p(n' . w_o) L0(y, n') dOmega' = sum_j p_j sum_m y_jm(w_o) L^jm(y),
// exact where L0 has no order above J, and for a uniform sky seen unshadowed at any J.
//
// The sphere is split into cells of the map's texels (kCellRows x kCellColumns in latitude and
// longitude, or one per texel of a smaller map). A cell's part of L^jm is its texels' exact sum
// of y_jm L_env dOmega times the transmittance along one direction, the cell's radiance-weighted
// mean direction: exact wherever T is constant across a cell, and a one-texel sun is shadowed
// along its own direction. The map's own SH projection is exact (no sampling noise); what the
// grid approximates is T within a cell and between nodes (trilinear).
//
// The transmittance is weighted over each node's cell by what the camera sees there (eight
// octant sub-points, each taking every eighth sky cell's shadow ray, weighted rho T_cam / mean:
// the density times the transmittance to the camera's eye): the march reads the light where the
// medium is, not T = 1 from a node just outside a surface, and where the camera sees it, the
// first mean free path under a surface. Shadow rays march the full-resolution density near their
// start, until the coarse density (the mean over each node's cell) is smooth around them, and the
// coarse density's optical depth from there: one sweep per sky cell with one volume and no
// shadow casters, else rays at settings.shadowStep nodes per step.
//
// Grid: nodes every `spacing` density voxels over the density's active index bounds, in the
// volume's index space; nodes whose neighbourhood holds no occupied brick are left at zero (no
// sample of the march reads them with weight). docs/single-scattering.md has the measurements.
#pragma once

#include "EnvironmentMap.h"
#include "RenderControl.h"

#include <algorithm>
#include <memory>
#include <vector>

namespace nimbus {

struct RenderContext;
class VolumeSet;
class EmbreeScene;

// Grid nodes along a volume's largest extent: render.light_volume_resolution, else 32.
inline int skyNodesAcross(const Scene& scene)
{
    return scene.render.lightVolumeResolution > 0 ? scene.render.lightVolumeResolution : 32;
}

class SkyLight {
public:
    static constexpr int kCellRows = 8, kCellColumns = 16;
    static constexpr int kOrderMax = 8;  // render.wkb_sh_order_max's cap
    static constexpr int kCountMax = (kOrderMax + 1) * (kOrderMax + 1);

    struct Settings {
        int order = 2;            // SH order J (render.wkb_sh_order_max)
        int nodesAcross = 32;     // grid nodes along a volume's largest extent
        float shadowStep = 1.0f;  // shadow-ray step in node spacings (render.shadow_step)
        // The camera's eye (world), where the grid is read by camera rays: each node's light is
        // weighted within its cell by what the camera sees there (build(), "Phase 2").
        bool hasViewer = false;
        float3 viewer = make_float3(0, 0, 0);
    };

    // The sky's radiance is colour * map(w) (map null: uniform, colour alone). stop: the render's
    // (RenderControl.h), polled per row of nodes and inside the shadow rays; a raised one throws
    // Cancelled.
    static SkyLight build(const VolumeSet& volumes, const EmbreeScene* casters, const EnvironmentMap* map, Rgb colour,
                          const Settings& settings, const StopFlag* stop = nullptr);

    int order() const { return mOrder; }
    int count() const { return (mOrder + 1) * (mOrder + 1); }
    double buildSeconds() const { return mSeconds; }
    size_t memoryBytes() const;

    // Per camera ray and volume: a_jm = (p_j - f) y_jm(w_o) for the outgoing direction w_o
    // (toward the camera, -d), the volume's phase function and its forward peak f (tailAlong);
    // count() floats.
    void contraction(NbPhase phase, float3 wo, float* a) const;

    // Remembers the grid cell a march is in and its eight corners contracted with a: a march
    // reads the same cell for about spacing / step samples in a row.
    struct Cursor {
        long cell = -1;
        int ijk[3] = {0, 0, 0};  // the cell's node indices
        Rgb corner[8];
    };
    // sum_jm a_jm L^jm at index-space point q of volume v, trilinear between nodes (clamped to
    // the grid). W/(m^2 sr) per unit of sigma_s: the in-scattered radiance per unit phase.
    // Inline: the scalar marches read it at every sample.
    Rgb radiance(size_t volume, float3 q, const float* a, Cursor& cursor) const
    {
        const Grid& g = mGrids[volume];
        if (g.nx == 0)
            return splat(0.0f);
        const float3 f = (q - g.origin) * g.invSpacing;
        auto split = [](float x, int n, int& i) {
            if (n < 2) {
                i = 0;
                return 0.0f;
            }
            x = clamp(x, 0.0f, float(n - 1));
            i = std::min(int(x), n - 2);
            return x - float(i);
        };
        int i, j, k;
        const float tx = split(f.x, g.nx, i), ty = split(f.y, g.ny, j), tz = split(f.z, g.nz, k);
        const long cell = (long(k) * g.ny + j) * g.nx + i;
        if (cell != cursor.cell) {
            corners(volume, i, j, k, a, cursor.corner, cursor.cell >= 0 ? cursor.ijk : nullptr);
            cursor.cell = cell;
            cursor.ijk[0] = i, cursor.ijk[1] = j, cursor.ijk[2] = k;
        }
        const Rgb* c = cursor.corner;
        const Rgb x00 = c[0] + (c[1] - c[0]) * tx, x10 = c[2] + (c[3] - c[2]) * tx;
        const Rgb x01 = c[4] + (c[5] - c[4]) * tx, x11 = c[6] + (c[7] - c[6]) * tx;
        const Rgb y0 = x00 + (x10 - x00) * ty, y1 = x01 + (x11 - x01) * ty;
        return fmax(y0 + (y1 - y0) * tz, splat(0.0f));
    }

    // The grid of volume v as the eight-ray march reads it (MarchEightRays.cpp): nodes at
    // origin + spacing (i, j, k) in index space, n per axis; and the eight corners of cell
    // (i, j, k) contracted with a (corner c at (i + (c & 1), j + (c >> 1 & 1), k + (c >> 2 & 1))).
    struct Geometry {
        float3 origin;
        float invSpacing;
        int nx, ny, nz;
    };
    Geometry geometry(size_t volume) const
    {
        const Grid& g = mGrids[volume];
        return Geometry{g.origin, g.invSpacing, g.nx, g.ny, g.nz};
    }
    // `previous`: where non-null, the cell (i', j', k') whose corners `out` holds; a march
    // mostly steps into a cell sharing a face with it, and the face's four corners are kept
    // rather than contracted again.
    void corners(size_t volume, int i, int j, int k, const float* a, Rgb* out, const int* previous = nullptr) const;

    // The part of the phase function the grid leaves to the camera march (single/SkyTail.h).
    // A forward-peaked lobe (HG of large g) has moments g^j that an order-J grid cuts off. The
    // split, after delta-M (Wiscombe 1977): f = p_(J+1) where positive (forwardPeak), the grid
    // carries moments p_j - f for j <= J (contraction), and the rest,
    //     k(mu) = p(mu) - sum_(j<=J) (2j+1)/(4 pi) (p_j - f) P_j(mu)
    // (moments f for j <= J, p_j above: the HG tail plus f times the low bands of a forward
    // delta), is forward-peaked, so the light it scatters toward the camera at y comes through
    // the medium behind y along the ray: T(y, end) times, seen along the camera ray's direction d,
    //     L_tail(d) = int k(w . d) L_sky(w) dOmega_w
    // (w the direction a texel is seen along: light travels along -w, then toward the camera along
    // -d, so the scattering cosine is w . d). A uniform sky's L_tail is f L. Exact with an
    // unshadowed sky; shadowed, the grid's low bands of T L and the ray's T for the peak.
    // Zero where the moments above J are under kTailNegligible (f too).
    // Precomputed per volume on a 64 x 32 lat-long table of d, read bilinearly.
    Rgb tailAlong(size_t volume, float3 d) const;
    static constexpr double kTailNegligible = 1e-3;  // |p_j| bound above J under which there is no tail
    static float forwardPeak(NbPhase phase, int order);

    // Test hook: the grid's coefficients at the node nearest index-space point q, count() RGB.
    std::vector<Rgb> nodeCoefficients(size_t volume, float3 q) const;

private:
    struct Grid {
        float3 origin = splat(0.0f);  // index space of the volume
        float spacing = 1.0f, invSpacing = 1.0f;
        int nx = 0, ny = 0, nz = 0;
        // Per node `stride` floats: coefficient jm's RGB at 4 jm (the fourth float 0), count()
        // rounded up to even, so that a corner's contraction is whole 8-float vectors.
        int stride = 0;
        std::vector<float> L;
    };
    // L_tail on a lat-long table of d: row r at polar angle (r + 0.5) pi / H from +y, column c
    // at azimuth (c + 0.5) 2 pi / W from +x toward +z; RGB innermost. Empty: no tail.
    struct Tail {
        static constexpr int W = 64, H = 32;
        std::vector<float> rgb;
    };
    int mOrder = 2;
    double mSeconds = 0.0;
    std::vector<Grid> mGrids;
    std::vector<Tail> mTails;  // per volume
};

}  // namespace nimbus
