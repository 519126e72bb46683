#include "StiffVoxels.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {

constexpr int kB = BrickGrid::kBrick, kS = BrickGrid::kStored;
// The eight corners of a cell among a brick's 9^3 values, from its lower corner.
constexpr int kCorner[8] = {0, 1, kS, kS + 1, kS* kS, kS* kS + 1, kS* kS + kS, kS* kS + kS + 1};

// The most any cell of brick `values` (9^3, one channel) changes across its corners.
float cellContrast(const float* values)
{
    float worst = 0.0f;
    for (int z = 0; z < kB; ++z)
        for (int y = 0; y < kB; ++y)
            for (int x = 0; x < kB; ++x) {
                const float* q = values + (z * kS + y) * kS + x;
                float lo = q[0], hi = q[0];
                for (int c = 1; c < 8; ++c)
                    lo = std::min(lo, q[kCorner[c]]), hi = std::max(hi, q[kCorner[c]]);
                worst = std::max(worst, hi - lo);
            }
    return worst;
}

float maxComponent(Rgb v)
{
    return std::max(v.x, std::max(v.y, v.z));
}

}  // namespace

StiffVoxels StiffVoxels::find(const VolumeData& vol, float step)
{
    StiffVoxels s;
    const BrickGrid& g = vol.density;
    if (g.channels() != 1 || g.brickCount() == 0)
        return s;
    const float kT = maxComponent(vol.sigmaT()), h = vol.voxelSize;
    s.subSteps.assign(g.brickCount(), 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, g.brickCount(), 16), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t b = r.begin(); b != r.end(); ++b) {
            const float* values = g.brickData(int(b));
            const float rhoMax = *std::max_element(values, values + BrickGrid::kBrickValues);
            // A cell's contrast is at most the brick's maximum: most bricks stop here.
            if (!(kT * h * rhoMax >= kStiffCell) && !(kT * rhoMax * step > kStiffStep))
                continue;
            const float thick = kT * rhoMax * step;  // a camera step's largest optical depth
            if (thick <= kStiffStep && kT * h * cellContrast(values) < kStiffCell)
                continue;
            s.subSteps[b] = uint16_t(std::clamp(int(std::ceil(thick / kSubStepDepth)), 1, kMaxSubSteps));
        }
    });
    s.any = std::any_of(s.subSteps.begin(), s.subSteps.end(), [](uint16_t n) { return n > 0; });
    if (!s.any)
        s.subSteps.clear();
    return s;
}

Rgb stiffOpticalDepth(const VolumeData& vol, const BrickGrid& cache, float3 p, float3 toLight, float maxDistance)
{
    const BrickGrid& density = vol.density;
    const Rgb kT = vol.sigmaT();
    const float kTmax = maxComponent(kT), kTmin = std::min(kT.x, std::min(kT.y, kT.z));
    const float flat = kFlatCell / (kTmax * vol.voxelSize);  // largest flat contrast in density units
    const int C = cache.channels();
    constexpr int kMaxCells = 32;

    // Amanatides & Woo over unit cells [i, i + 1)^3, parameter s in world metres.
    int cell[3] = {int(std::floor(p.x)), int(std::floor(p.y)), int(std::floor(p.z))};
    const float pc[3] = {p.x, p.y, p.z}, dc[3] = {toLight.x, toLight.y, toLight.z};
    int stepDir[3];
    float sNext[3], sDelta[3];
    for (int a = 0; a < 3; ++a) {
        if (dc[a] > 0.0f) {
            stepDir[a] = 1, sDelta[a] = 1.0f / dc[a], sNext[a] = (float(cell[a] + 1) - pc[a]) / dc[a];
        } else if (dc[a] < 0.0f) {
            stepDir[a] = -1, sDelta[a] = -1.0f / dc[a], sNext[a] = (float(cell[a]) - pc[a]) / dc[a];
        } else {
            stepDir[a] = 0, sDelta[a] = sNext[a] = 1e30f;
        }
    }
    // The lattice's optical depth at index point q, read in cell (brick, corner) at `origin`.
    auto latticeDepth = [&](int brick, int corner, float3 origin, float3 q) {
        const float tx = std::clamp(q.x - origin.x, 0.0f, 1.0f), ty = std::clamp(q.y - origin.y, 0.0f, 1.0f),
                    tz = std::clamp(q.z - origin.z, 0.0f, 1.0f);
        const float* t = cache.brickData(brick) + size_t(corner) * C;
        if (C == 1)
            return splat(BrickGrid::trilinear<1>(t, tx, ty, tz));
        return make_float3(BrickGrid::trilinear<3>(t, tx, ty, tz), BrickGrid::trilinear<3>(t + 1, tx, ty, tz),
                           BrickGrid::trilinear<3>(t + 2, tx, ty, tz));
    };

    // A trilinear cell is linear exactly when its four diagonals' corner sums agree; their
    // spread bounds the interpolation's departure from the plane through the corners.
    auto latticeIsLinear = [&](int brick, int corner) {
        const float* t = cache.brickData(brick) + size_t(corner) * C;
        float lo = 1e30f, hi = -1e30f;
        for (int c = 0; c < 4; ++c) {
            const float sum = t[size_t(kCorner[c]) * C] + t[size_t(kCorner[7 - c]) * C];
            lo = std::min(lo, sum), hi = std::max(hi, sum);
        }
        return 0.5f * (hi - lo) < kFlatCell;
    };

    Bbox bounds = density.activeIndexBounds();
    float integral = 0.0f;  // int rho ds from p, metres
    float s = 0.0f;
    int lastBrick = -1, lastCorner = 0;
    float3 lastOrigin = splat(0.0f);
    for (int n = 0; n < kMaxCells; ++n) {
        const int brick = density.allocatedBrick(cell[0] >> 3, cell[1] >> 3, cell[2] >> 3);
        const float3 q = p + toLight * s;
        // Past the occupied bricks' bounds toward the light there is no medium at all.
        if (!bounds.contains(q))
            return kT * integral;
        const int corner = ((cell[2] & (kB - 1)) * kS + (cell[1] & (kB - 1))) * kS + (cell[0] & (kB - 1));
        const float3 origin = make_float3(float(cell[0]), float(cell[1]), float(cell[2]));
        const float* r = brick >= 0 ? density.brickData(brick) + corner : nullptr;
        float lo = r ? r[0] : 0.0f, hi = lo;
        for (int c = 1; c < 8 && r; ++c)
            lo = std::min(lo, r[kCorner[c]]), hi = std::max(hi, r[kCorner[c]]);
        const int axis = sNext[0] < sNext[1] ? (sNext[0] < sNext[2] ? 0 : 2) : (sNext[1] < sNext[2] ? 1 : 2);
        // An empty cell adds nothing, and its lattice value can be blurred by the shadow map's
        // texels reaching into the dense cells next to it: walk on through it toward the light.
        if (hi <= 0.0f) {
            if (brick >= 0)
                lastBrick = brick, lastCorner = corner, lastOrigin = origin;
            s = sNext[axis];
            if (s >= maxDistance)
                return kT * integral;
            cell[axis] += stepDir[axis];
            sNext[axis] += sDelta[axis];
            continue;
        }
        // Density flat across the cell, and the lattice's tau linear across it (near a shadow's
        // terminator tau_L bends sharply even where the density is flat): the lattice is exact.
        if (hi - lo < flat && latticeIsLinear(brick, corner))
            return kT * integral + latticeDepth(brick, corner, origin, q);
        const float sEnd = std::min(sNext[axis], maxDistance);
        auto rho = [&](float sAt) {
            const float3 x = p + toLight * sAt - origin;
            return BrickGrid::trilinear<1>(r, std::clamp(x.x, 0.0f, 1.0f), std::clamp(x.y, 0.0f, 1.0f),
                                           std::clamp(x.z, 0.0f, 1.0f));
        };
        // Simpson: exact for the cubic a trilinear cell is along a line.
        integral += (sEnd - s) * (1.0f / 6.0f) * (rho(s) + 4.0f * rho(0.5f * (s + sEnd)) + rho(sEnd));
        s = sEnd;
        if (s >= maxDistance)
            return kT * integral;      // the light is inside this cell
        if (kTmin * integral > 30.0f)  // e^-30: what lies beyond cannot matter
            return kT * integral;
        lastBrick = brick, lastCorner = corner, lastOrigin = origin;
        cell[axis] += stepDir[axis];
        sNext[axis] += sDelta[axis];
    }
    if (lastBrick < 0)
        return kT * integral;
    return kT * integral + latticeDepth(lastBrick, lastCorner, lastOrigin, p + toLight * s);
}

}  // namespace nimbus
