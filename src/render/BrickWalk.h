// BrickWalk.h: the samples of a ray march that land in the occupied bricks of one grid.
//
// A march samples o + t d at t_k = tStart + (k + jitter) dt, k = 0, 1, ...; jitter in [0, 1)
// drawn once per ray makes it a stratified estimator (the camera march), jitter 0.5 is the
// midpoint rule (shadow maps). Only bricks with a positive majorant can hold density
// (BrickGrid.h), so a 3D DDA over the brick table (Amanatides & Woo 1987) visits the ray's
// occupied bricks in order and hands the visitor the samples inside each, as stencils (brick,
// cell corner, trilinear weights) that every grid sharing the topology reads alike: density
// and the baked light. An empty brick costs one table read; no sample is placed in it, and
// skipping it moves no other sample (the lattice t_k is fixed by tStart, not by the bricks).
//
// o and d are in the grid's index space; t keeps the caller's units (world metres when d is
// the index-space image of a unit world direction), so dt is the caller's step.
#pragma once

#include "../../kernels/shared/brickdda.h"
#include "../volume/BrickGrid.h"
#include "../volume/VolumeData.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nimbus {

// The 3D DDA over the 8^3 brick cells crossed by an index-space ray o + t d: kernels/shared/
// brickdda.h, the path tracer's majorant walk's too. `cell` is the current brick (index / 8),
// `exit()` the t where the ray leaves it.
struct BrickDda : NbBrickDda {
    // Starts at o + d tIn; false where that point is not finite (nothing to walk).
    bool start(float3 o, float3 d, float tIn)
    {
        static_assert(BrickGrid::kBrick == NB_BRICK, "brickdda.h walks BrickGrid's bricks");
        constexpr float B = float(BrickGrid::kBrick);
        const float3 p = o + d * tIn;
        if (!(std::fabs(p.x) < 1e9f && std::fabs(p.y) < 1e9f && std::fabs(p.z) < 1e9f))
            return false;
        nbBrickDdaAxis(this, 0, floorToInt(p.x / B), o.x, d.x);
        nbBrickDdaAxis(this, 1, floorToInt(p.y / B), o.y, d.y);
        nbBrickDdaAxis(this, 2, floorToInt(p.z / B), o.z, d.z);
        return true;
    }
    int exitAxis() const { return nbBrickDdaExitAxis(this); }
    float exit() const { return tNext[exitAxis()]; }
    // Moves into the next brick along the ray.
    void advance() { nbBrickDdaAdvance(this, exitAxis()); }
};

// visit(int k, float t, const BrickGrid::Stencil& s) returns false to stop the walk.
// Samples are visited in increasing k; each lattice sample in [tIn, tOut) inside an occupied
// brick exactly once.
template <class Visit>
void walkOccupiedBricks(const BrickGrid& grid, float3 o, float3 d, float tIn, float tOut, float tStart, float dt,
                        float jitter, Visit&& visit)
{
    constexpr float B = float(BrickGrid::kBrick);
    // Comparisons, not fmin/fmax (whose NaN rules cost a branchy sequence); NaN reads as 0.
    auto clampLocal = [](float v) {
        constexpr float kLastInside = B * (1.0f - 1.0f / 16777216.0f);  // largest float below 8
        v = v > 0.0f ? v : 0.0f;
        return v < kLastInside ? v : kLastInside;
    };
    BrickDda dda;
    if (!(tOut > tIn) || !(dt > 0.0f) || !dda.start(o, d, tIn))
        return;
    const int* cell = dda.cell;
    const float invDt = 1.0f / dt;
    const Int3 dims = grid.dims();
    const int maxSteps = dims.x + dims.y + dims.z + 8;
    float t = tIn;
    int kNext = 0;
    BrickGrid::Stencil s;
    for (int i = 0; i < maxSteps && t < tOut; ++i) {
        const int axis = dda.exitAxis();
        const float tExit = std::min(dda.tNext[axis], tOut);
        const int brick = grid.occupiedBrick(cell[0], cell[1], cell[2]);
        if (brick >= 0 && tExit > t) {
            s.brick = brick;
            const float3 origin = make_float3(cell[0] * B, cell[1] * B, cell[2] * B);
            int k = std::max(kNext, int(std::ceil((t - tStart) * invDt - jitter)));
            for (;; ++k) {
                const float tk = tStart + (float(k) + jitter) * dt;
                if (tk >= tExit)
                    break;
                // Local position in [0, 8) up to rounding; clamped, so truncation is the floor.
                const float3 q = o + d * tk - origin;
                const float qx = clampLocal(q.x), qy = clampLocal(q.y), qz = clampLocal(q.z);
                const int cx = int(qx), cy = int(qy), cz = int(qz);
                s.corner = (cz * BrickGrid::kStored + cy) * BrickGrid::kStored + cx;
                s.tx = qx - float(cx), s.ty = qy - float(cy), s.tz = qz - float(cz);
                if (!visit(k, tk, s))
                    return;
            }
            kNext = k;
        }
        t = tExit;
        nbBrickDdaAdvance(&dda, axis);  // dda.advance(), its exit axis known
    }
}

// The march of a world ray o + t d (d unit) through one volume's density: its index-space
// image, clipped to the volume's world bounds and to the occupied bricks. The lattice starts
// where the ray enters them (t_k = t_in + (k + jitter) dt, t in metres), or with
// Lattice::FromOrigin at the ray's origin (t_k = (k + jitter) dt: rays that start on one plane
// then share their sample depths, as a shadow map's do). visit as walkOccupiedBricks.
enum class Lattice { FromEntry, FromOrigin };
template <class Visit>
void walkVolume(const VolumeData& vol, float3 o, float3 d, float dt, float jitter, Visit&& visit,
                Lattice lattice = Lattice::FromEntry)
{
    float t0, t1, s0, s1;
    const float3 oi = vol.indexFromWorld.point(o), di = vol.indexFromWorld.vector(d);
    if (vol.worldBounds.intersect(o, safeInverse(d), 0.0f, 1e30f, t0, t1) &&
        vol.density.activeIndexBounds().intersect(oi, safeInverse(di), t0, t1, s0, s1))
        walkOccupiedBricks(vol.density, oi, di, s0, s1, lattice == Lattice::FromEntry ? s0 : 0.0f, dt, jitter, visit);
}

// walkVolume up to tMax (a camera ray held out by geometry, docs/geometry.md): the same lattice,
// no sample at or past tMax. Apart from walkVolume, so that rays without a holdout compile to
// exactly the code they did before holdouts (the same images, bit for bit).
template <class Visit>
void walkVolumeTo(const VolumeData& vol, float3 o, float3 d, float dt, float jitter, float tMax, Visit&& visit)
{
    float t0, t1, s0, s1;
    const float3 oi = vol.indexFromWorld.point(o), di = vol.indexFromWorld.vector(d);
    if (vol.worldBounds.intersect(o, safeInverse(d), 0.0f, tMax, t0, t1) &&
        vol.density.activeIndexBounds().intersect(oi, safeInverse(di), t0, t1, s0, s1))
        walkOccupiedBricks(vol.density, oi, di, s0, s1, s0, dt, jitter, visit);
}

}  // namespace nimbus
