#include "MarchEightRays.h"

#include "SkyTail.h"

#include "../render/BrickLanes.h"

#include "../core/ExpNeg.h"

#include <cmath>
#include <cstdint>
#include <limits>

namespace nimbus {

#if NIMBUS_EIGHT_RAY_MARCH

bool marchGreyDistantEight(const RenderContext& ctx, const VolumeData& vol, const LightEntry* const* lights,
                           int lightCount, int n, const float3* o, const float3* d, const float* tFar,
                           const float* jitter, CameraSample* out, float* perLight, size_t perLightStride,
                           const InScatterGrid* grid, float3* gridL)
{
    const BrickGrid& density = vol.density;
    // Gathers index the pools with 32-bit integers; each light's baked optical depth shares the
    // density's bricks (LightCache), so one stencil index serves every pool.
    if (lightCount < 1 || lightCount > kMaxEightRayLights || !lanes::gatherable(density))
        return false;
    // Skies (SkyLight.h) apart: they read their grid, the distant lights their baked depth.
    const LightEntry* skies[kMaxEightRaySkies];
    int skyCount = 0;
    const LightEntry* distant[kMaxEightRayLights];
    int distantCount = 0;
    for (int l = 0; l < lightCount; ++l) {
        if (lights[l]->sky) {
            if (skyCount == kMaxEightRaySkies)
                return false;
            const SkyLight::Geometry g = lights[l]->sky->geometry(0);
            if (g.nx < 2 || g.ny < 2 || g.nz < 2)
                return false;  // a grid one node thin: the scalar march reads it
            skies[skyCount++] = lights[l];
        } else {
            distant[distantCount++] = lights[l];
        }
    }
    lights = distant;
    lightCount = distantCount;
    const float* tauPools[kMaxEightRayLights];
    for (int l = 0; l < lightCount; ++l) {
        const BrickGrid& cache = lights[l]->cache->grid(0);
        if (cache.pool().size() != density.pool().size())
            return false;
        tauPools[l] = cache.pool().data();
    }
    const float kT = vol.sigmaT().x;
    const float cutoff = ctx.scene->render.tolerance;
    const float dt = ctx.scene->render.step * vol.voxelSize;
    constexpr float B = float(BrickGrid::kBrick);

    // Each lane's ray in the grid's index space, clipped as walkVolume clips it: to the
    // volume's world bounds, then to the occupied bricks' index bounds. Lanes past n, and rays
    // that miss, start dead.
    alignas(32) float ox[8], oy[8], oz[8], dx[8], dy[8], dz[8], tIn[8], tOut[8], jit[8];
    alignas(32) int32_t live[8];
    // Sample indices k are floats, exact up to 2^24: longer marches (a step thousands of times
    // finer than the volume) go to the scalar walk.
    constexpr float kLongestMarch = 1 << 22;
    for (int i = 0; i < 8; ++i) {
        ox[i] = oy[i] = oz[i] = dx[i] = dy[i] = dz[i] = tIn[i] = tOut[i] = jit[i] = 0.0f;
        live[i] = 0;
        if (i >= n)
            continue;
        const float3 oi = vol.indexFromWorld.point(o[i]), di = vol.indexFromWorld.vector(d[i]);
        float t0, t1, s0, s1;
        if (!(dt > 0.0f) || !vol.worldBounds.intersect(o[i], safeInverse(d[i]), 0.0f, 1e30f, t0, t1))
            continue;
        if (tFar && tFar[i] < INFINITY)
            t1 = std::min(t1, tFar[i]);  // held out: walkVolume's tMax
        if (!(t1 >= t0) || !density.activeIndexBounds().intersect(oi, safeInverse(di), t0, t1, s0, s1) || !(s1 > s0))
            continue;
        const float3 p = oi + di * s0;
        if (!(std::fabs(p.x) < 1e9f && std::fabs(p.y) < 1e9f && std::fabs(p.z) < 1e9f))
            continue;  // as BrickDda::start: nothing to walk
        if (!((s1 - s0) / dt < kLongestMarch))
            return false;
        ox[i] = oi.x, oy[i] = oi.y, oz[i] = oi.z, dx[i] = di.x, dy[i] = di.y, dz[i] = di.z;
        tIn[i] = s0, tOut[i] = s1, jit[i] = jitter[i];
        live[i] = -1;
    }
    const __m256 Ox = _mm256_load_ps(ox), Oy = _mm256_load_ps(oy), Oz = _mm256_load_ps(oz);
    const __m256 Dx = _mm256_load_ps(dx), Dy = _mm256_load_ps(dy), Dz = _mm256_load_ps(dz);
    const __m256 TIn = _mm256_load_ps(tIn), TOut = _mm256_load_ps(tOut), Jit = _mm256_load_ps(jit);
    __m256 alive = _mm256_castsi256_ps(_mm256_load_si256(reinterpret_cast<const __m256i*>(live)));

    // An empty brick's exit along each axis: the face ahead, at (cell + 1) 8 for a positive
    // direction, cell 8 for a negative one; never, along an axis the ray does not move on.
    const __m256 zero = _mm256_setzero_ps(), one = _mm256_set1_ps(1.0f);
    const __m256 inf = _mm256_set1_ps(std::numeric_limits<float>::infinity());
    const __m256 aheadX = _mm256_and_ps(_mm256_cmp_ps(Dx, zero, _CMP_GT_OQ), one);
    const __m256 aheadY = _mm256_and_ps(_mm256_cmp_ps(Dy, zero, _CMP_GT_OQ), one);
    const __m256 aheadZ = _mm256_and_ps(_mm256_cmp_ps(Dz, zero, _CMP_GT_OQ), one);
    const __m256 stillX = _mm256_cmp_ps(Dx, zero, _CMP_EQ_OQ), stillY = _mm256_cmp_ps(Dy, zero, _CMP_EQ_OQ);
    const __m256 stillZ = _mm256_cmp_ps(Dz, zero, _CMP_EQ_OQ);
    const __m256 invDx = _mm256_div_ps(one, Dx), invDy = _mm256_div_ps(one, Dy), invDz = _mm256_div_ps(one, Dz);

    const __m256 Dt = _mm256_set1_ps(dt), InvDt = _mm256_set1_ps(1.0f / dt);
    const __m256 KT = _mm256_set1_ps(kT), Cutoff = _mm256_set1_ps(cutoff);
    const __m256 brickSide = _mm256_set1_ps(B);
    const lanes::BrickTable table(density);
    const float* rhoPool = density.pool().data();

    // L1[l]: light l's sum over samples of T w rho e^{-tau_l}, eq. 31 per step over sigma_s / rho
    // and L_l p_l (constant along the ray for a distant light, applied after the march).
    __m256 L1[kMaxEightRayLights];
    for (int l = 0; l < lightCount; ++l)
        L1[l] = _mm256_setzero_ps();
    __m256 k = zero, T = one, depthSum = zero, opacitySum = zero;

    // Skies: per lane the ray's contraction a_jm = p_j y_jm(-d) and the grid cell it last read,
    // with that cell's eight corners contracted (SkyLight::radiance's cursor, one per lane, laid
    // out by corner and channel so that the trilinear blend is lane-parallel loads). The cell
    // changes every spacing / step samples or so; then the lane's corners are contracted anew
    // (four of them where the new cell shares a face with the last).
    struct SkyLanes {
        const SkyLight* sky;
        size_t index;  // in ctx.lights
        float a[8][SkyLight::kCountMax];
        alignas(32) float corner[8][3][8];
        alignas(32) int32_t cell[8];
        int32_t ijk[8][3];  // each lane's cell's node indices
        __m256 origin[3], inv, hi[3], hiCell[3];
        __m256i nx, nxy;
        __m256 L1[3];
    };
    SkyLanes skyLanes[kMaxEightRaySkies];
    for (int s = 0; s < skyCount; ++s) {
        SkyLanes& sl = skyLanes[s];
        sl.sky = &*skies[s]->sky;
        sl.index = size_t(skies[s] - ctx.lights.data());
        for (int i = 0; i < 8; ++i) {
            sl.cell[i] = -1;
            if (live[i])  // light scatters toward the camera, along -d; dead lanes read no sky
                sl.sky->contraction(vol.medium.phase, -d[i], sl.a[i]);
        }
        const SkyLight::Geometry g = sl.sky->geometry(0);
        sl.origin[0] = _mm256_set1_ps(g.origin.x), sl.origin[1] = _mm256_set1_ps(g.origin.y);
        sl.origin[2] = _mm256_set1_ps(g.origin.z);
        sl.inv = _mm256_set1_ps(g.invSpacing);
        const int n3[3] = {g.nx, g.ny, g.nz};
        for (int a = 0; a < 3; ++a) {
            sl.hi[a] = _mm256_set1_ps(float(n3[a] - 1));
            sl.hiCell[a] = _mm256_set1_ps(float(n3[a] - 2));
            sl.L1[a] = zero;
        }
        sl.nx = _mm256_set1_epi32(g.nx);
        sl.nxy = _mm256_set1_epi32(g.nx * g.ny);
    }
    // The in-scatter grid (InScatterGrid.h): each lane's cell-centred coordinates
    // u = (o + d t - lo) / cell - 1/2, affine in the march's t (the index-space ray has the world
    // ray's parameter), clamped into the grid; the eight corners' offsets from the low one, 0
    // along an axis one cell thin.
    struct GridLanes {
        __m256 u0[3], du[3], hi[3], hiCell[3];
        __m256i nx, nxy, floats, corner[8];
        int layers;
        __m256 L[kMaxInScatterLayers][3];
        // A group of up to `group` samples shares one read (see the march below): their summed
        // weights W and weighted positions sum w t.
        __m256 W, Wt;
        unsigned group, inGroup;
        // L += weight S(o + d t), S trilinear (InScatterGrid.h); min before max sends a NaN
        // coordinate (a dead lane) to the grid's edge, so every gather stays inside.
        void read(const float* rgb, __m256 t, __m256 weight)
        {
            const __m256 zero = _mm256_setzero_ps();
            __m256 f[3], c[3];
            for (int a = 0; a < 3; ++a) {
                const __m256 u = _mm256_max_ps(_mm256_min_ps(_mm256_fmadd_ps(du[a], t, u0[a]), hi[a]), zero);
                c[a] = _mm256_min_ps(_mm256_floor_ps(u), hiCell[a]);
                f[a] = _mm256_sub_ps(u, c[a]);
            }
            const __m256i cell = _mm256_add_epi32(_mm256_cvttps_epi32(c[0]),
                                                  _mm256_add_epi32(_mm256_mullo_epi32(_mm256_cvttps_epi32(c[1]), nx),
                                                                   _mm256_mullo_epi32(_mm256_cvttps_epi32(c[2]), nxy)));
            const __m256i base = _mm256_mullo_epi32(cell, floats);
            auto lerp = [](__m256 a, __m256 b, __m256 s) { return _mm256_fmadd_ps(_mm256_sub_ps(b, a), s, a); };
            for (int k = 0; k < 3 * layers; ++k) {
                auto at = [&](int cc) { return _mm256_i32gather_ps(rgb + k, _mm256_add_epi32(base, corner[cc]), 4); };
                const __m256 x00 = lerp(at(0), at(1), f[0]), x10 = lerp(at(2), at(3), f[0]);
                const __m256 x01 = lerp(at(4), at(5), f[0]), x11 = lerp(at(6), at(7), f[0]);
                __m256& acc = L[k / 3][k % 3];
                acc = _mm256_fmadd_ps(weight, lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2]), acc);
            }
        }
    } gl{};
    if (grid) {
        const float inv = 1.0f / grid->cell;
        alignas(32) float u0[3][8], du[3][8];
        for (int i = 0; i < 8; ++i) {
            const float3 a = i < n ? (o[i] - grid->lo) * inv - splat(0.5f) : splat(0.0f);
            const float3 b = i < n ? d[i] * inv : splat(0.0f);
            u0[0][i] = a.x, u0[1][i] = a.y, u0[2][i] = a.z;
            du[0][i] = b.x, du[1][i] = b.y, du[2][i] = b.z;
        }
        gl.layers = grid->layers;
        // Samples per read: as many as span at most one cell, (group - 1) dt <= cell, from 2 to 8.
        gl.group = unsigned(std::clamp(int(1.0f + grid->cell / dt), 2, 8));
        gl.inGroup = 0;
        gl.W = gl.Wt = zero;
        const int F = 3 * grid->layers;  // floats per cell
        gl.floats = _mm256_set1_epi32(F);
        int stride[3] = {F, F * grid->n[0], F * grid->n[0] * grid->n[1]};
        for (int a = 0; a < 3; ++a) {
            gl.u0[a] = _mm256_load_ps(u0[a]);
            gl.du[a] = _mm256_load_ps(du[a]);
            gl.hi[a] = _mm256_set1_ps(float(grid->n[a] - 1));
            gl.hiCell[a] = _mm256_set1_ps(float(std::max(grid->n[a] - 2, 0)));
            if (grid->n[a] < 2)
                stride[a] = 0;
        }
        gl.nx = _mm256_set1_epi32(grid->n[0]);
        gl.nxy = _mm256_set1_epi32(grid->n[0] * grid->n[1]);
        for (int c = 0; c < 8; ++c)
            gl.corner[c] =
                _mm256_set1_epi32((c & 1 ? stride[0] : 0) + (c & 2 ? stride[1] : 0) + (c & 4 ? stride[2] : 0));
    }
    // A stopped render (RenderControl.h) ends the lanes' march early; its film is discarded.
    for (unsigned polled = 1;; ++polled) {
        if (polled % kStopPollInterval == 0 && ctx.stop.raised())
            break;
        const __m256 tk = _mm256_fmadd_ps(_mm256_add_ps(k, Jit), Dt, TIn);
        alive = _mm256_and_ps(alive, _mm256_cmp_ps(tk, TOut, _CMP_LT_OQ));
        if (lanes::none(alive))
            break;
        const __m256 qx = _mm256_fmadd_ps(Dx, tk, Ox), qy = _mm256_fmadd_ps(Dy, tk, Oy),
                     qz = _mm256_fmadd_ps(Dz, tk, Oz);
        __m256 cellX, cellY, cellZ;
        const __m256i brick = table.brickAt(qx, qy, qz, alive, cellX, cellY, cellZ);
        const __m256 occ = _mm256_castsi256_ps(_mm256_cmpgt_epi32(brick, _mm256_set1_epi32(-1)));

        __m256 stepWeight = zero;  // this iteration's T w rho per lane (0 outside occupied bricks)
        if (!lanes::none(occ)) {
            const lanes::Stencil8 st = lanes::stencilAt(brick, occ, qx, qy, qz, cellX, cellY, cellZ);
            // Lanes outside an occupied brick read index 0 (a valid value), masked out here.
            const __m256 rho = _mm256_and_ps(occ, _mm256_max_ps(lanes::trilinear(rhoPool, st), zero));
            // stepTerms (SingleScatter.cpp): the step's transmittance and int exp(-sigma s) ds,
            // by the series where sigma dt < 1e-3, else from one exponential.
            const __m256 sigma = _mm256_mul_ps(KT, rho), x = _mm256_mul_ps(sigma, Dt);
            const __m256 thin = _mm256_cmp_ps(x, _mm256_set1_ps(1e-3f), _CMP_LT_OQ);
            const __m256 e = expNeg8(x);
            const __m256 transmitThin = _mm256_fnmadd_ps(x, _mm256_fnmadd_ps(_mm256_set1_ps(0.5f), x, one), one);
            const __m256 weightThin = _mm256_mul_ps(
                Dt, _mm256_fnmadd_ps(x, _mm256_fnmadd_ps(x, _mm256_set1_ps(1.0f / 6.0f), _mm256_set1_ps(0.5f)), one));
            const __m256 transmit = _mm256_blendv_ps(e, transmitThin, thin);
            const __m256 weight = _mm256_blendv_ps(_mm256_div_ps(_mm256_sub_ps(one, e), sigma), weightThin, thin);
            const __m256 Twrho = _mm256_and_ps(occ, _mm256_mul_ps(_mm256_mul_ps(T, weight), rho));
            for (int l = 0; l < lightCount; ++l)
                L1[l] = _mm256_add_ps(L1[l], _mm256_mul_ps(Twrho, expNeg8(lanes::trilinear(tauPools[l], st))));
            for (int s = 0; s < skyCount; ++s) {
                SkyLanes& sl = skyLanes[s];
                // Node coordinates, clamped into the grid, and the cell (SkyLight::radiance).
                const __m256 q[3] = {qx, qy, qz};
                __m256 f[3], c[3];
                for (int a = 0; a < 3; ++a) {
                    const __m256 g = _mm256_min_ps(
                        _mm256_max_ps(_mm256_mul_ps(_mm256_sub_ps(q[a], sl.origin[a]), sl.inv), zero), sl.hi[a]);
                    c[a] = _mm256_min_ps(_mm256_floor_ps(g), sl.hiCell[a]);
                    f[a] = _mm256_sub_ps(g, c[a]);
                }
                const __m256i ci = _mm256_cvttps_epi32(c[0]), cj = _mm256_cvttps_epi32(c[1]),
                              ck = _mm256_cvttps_epi32(c[2]);
                const __m256i cell = _mm256_add_epi32(
                    ci, _mm256_add_epi32(_mm256_mullo_epi32(cj, sl.nx), _mm256_mullo_epi32(ck, sl.nxy)));
                const __m256i known = _mm256_load_si256(reinterpret_cast<const __m256i*>(sl.cell));
                const int changed = _mm256_movemask_ps(_mm256_andnot_ps(
                                        _mm256_castsi256_ps(_mm256_cmpeq_epi32(cell, known)), occ)) &
                                    ((1 << n) - 1);
                if (changed) {
                    alignas(32) int32_t cells[8], is[8], js[8], ks[8];
                    _mm256_store_si256(reinterpret_cast<__m256i*>(cells), cell);
                    _mm256_store_si256(reinterpret_cast<__m256i*>(is), ci);
                    _mm256_store_si256(reinterpret_cast<__m256i*>(js), cj);
                    _mm256_store_si256(reinterpret_cast<__m256i*>(ks), ck);
                    for (int i = 0; i < 8; ++i) {
                        if (!(changed >> i & 1))
                            continue;
                        Rgb corner[8];
                        const bool held = sl.cell[i] >= 0;
                        if (held)
                            for (int cc = 0; cc < 8; ++cc)
                                corner[cc] = make_float3(sl.corner[cc][0][i], sl.corner[cc][1][i], sl.corner[cc][2][i]);
                        sl.sky->corners(0, is[i], js[i], ks[i], sl.a[i], corner, held ? sl.ijk[i] : nullptr);
                        sl.ijk[i][0] = is[i], sl.ijk[i][1] = js[i], sl.ijk[i][2] = ks[i];
                        for (int cc = 0; cc < 8; ++cc) {
                            sl.corner[cc][0][i] = corner[cc].x;
                            sl.corner[cc][1][i] = corner[cc].y;
                            sl.corner[cc][2][i] = corner[cc].z;
                        }
                        sl.cell[i] = cells[i];
                    }
                }
                for (int ch = 0; ch < 3; ++ch) {
                    auto at = [&](int cc) { return _mm256_load_ps(sl.corner[cc][ch]); };
                    auto lerp = [](__m256 a, __m256 b, __m256 t) { return _mm256_fmadd_ps(_mm256_sub_ps(b, a), t, a); };
                    const __m256 x00 = lerp(at(0), at(1), f[0]), x10 = lerp(at(2), at(3), f[0]);
                    const __m256 x01 = lerp(at(4), at(5), f[0]), x11 = lerp(at(6), at(7), f[0]);
                    const __m256 v = _mm256_max_ps(lerp(lerp(x00, x10, f[1]), lerp(x01, x11, f[1]), f[2]), zero);
                    // Lanes outside an occupied brick have Twrho 0; a lane never contracted
                    // holds stale corners only where Twrho is 0.
                    sl.L1[ch] = _mm256_fmadd_ps(Twrho, v, sl.L1[ch]);
                }
            }
            stepWeight = Twrho;
            const __m256 opacity = _mm256_mul_ps(Twrho, KT);  // stepOpacity (SingleScatter.cpp)
            opacitySum = _mm256_add_ps(opacitySum, opacity);
            depthSum = _mm256_fmadd_ps(opacity, tk, depthSum);
            T = _mm256_blendv_ps(T, _mm256_mul_ps(T, transmit), occ);
            const __m256 opaque = _mm256_and_ps(occ, _mm256_cmp_ps(T, Cutoff, _CMP_LT_OQ));
            T = _mm256_andnot_ps(opaque, T);
            alive = _mm256_andnot_ps(opaque, alive);
        }

        if (grid) {
            // The grid read once per group of samples (S once for up to `group` samples: a read
            // costs 3 x layers x 8 gathers), at the group's weighted mean position t = sum w t /
            // sum w with weight sum w: for an S linear along the ray (trilinear S within a cell is
            // nearly so) this equals sum_k w_k S(t_k), L1's own quadrature, exactly. A group ends
            // after `group` iterations, or early where a lane that holds weight moves into empty
            // bricks (its next samples may lie far along the ray); the flush after the march
            // reads what is left.
            gl.W = _mm256_add_ps(gl.W, stepWeight);
            gl.Wt = _mm256_fmadd_ps(stepWeight, tk, gl.Wt);
            const __m256 holding = _mm256_cmp_ps(gl.W, zero, _CMP_GT_OQ);
            if (++gl.inGroup == gl.group || !lanes::none(_mm256_andnot_ps(occ, _mm256_and_ps(alive, holding)))) {
                gl.read(grid->rgb, _mm256_blendv_ps(tk, _mm256_div_ps(gl.Wt, gl.W), holding), gl.W);
                gl.W = gl.Wt = zero;
                gl.inGroup = 0;
            }
        }

        // Lanes in an empty brick (or, by rounding, just outside the table) move to the first
        // sample past the brick's exit, as the scalar walk's next occupied brick would start.
        __m256 kNext = _mm256_add_ps(k, one);
        const __m256 skip = _mm256_andnot_ps(occ, alive);
        if (!lanes::none(skip)) {
            auto exitAlong = [&](__m256 cell, __m256 ahead, __m256 o, __m256 invD, __m256 still) {
                const __m256 face = _mm256_mul_ps(_mm256_add_ps(cell, ahead), brickSide);
                return _mm256_blendv_ps(_mm256_mul_ps(_mm256_sub_ps(face, o), invD), inf, still);
            };
            const __m256 tExit = _mm256_min_ps(
                _mm256_min_ps(exitAlong(cellX, aheadX, Ox, invDx, stillX), exitAlong(cellY, aheadY, Oy, invDy, stillY)),
                exitAlong(cellZ, aheadZ, Oz, invDz, stillZ));
            const __m256 kExit = _mm256_ceil_ps(_mm256_sub_ps(_mm256_mul_ps(_mm256_sub_ps(tExit, TIn), InvDt), Jit));
            kNext = _mm256_blendv_ps(kNext, _mm256_max_ps(kNext, kExit), skip);
        }
        k = kNext;
    }

    alignas(32) float Ts[8], depthSums[8], opacitySums[8], L1s[kMaxEightRayLights][8];
    _mm256_store_ps(Ts, T);
    _mm256_store_ps(depthSums, depthSum);
    _mm256_store_ps(opacitySums, opacitySum);
    for (int l = 0; l < lightCount; ++l)
        _mm256_store_ps(L1s[l], L1[l]);
    const Rgb sigmaS = vol.sigmaS();
    alignas(32) float skyL1[kMaxEightRaySkies][3][8];
    for (int s = 0; s < skyCount; ++s)
        for (int ch = 0; ch < 3; ++ch)
            _mm256_store_ps(skyL1[s][ch], skyLanes[s].L1[ch]);
    if (grid) {
        const __m256 holding = _mm256_cmp_ps(gl.W, zero, _CMP_GT_OQ);
        if (!lanes::none(holding))
            gl.read(grid->rgb, _mm256_blendv_ps(zero, _mm256_div_ps(gl.Wt, gl.W), holding), gl.W);
        for (int layer = 0; layer < gl.layers; ++layer) {
            alignas(32) float gL[3][8];
            for (int ch = 0; ch < 3; ++ch)
                _mm256_store_ps(gL[ch], gl.L[layer][ch]);
            for (int i = 0; i < n; ++i)
                gridL[size_t(i) * size_t(gl.layers) + size_t(layer)] =
                    sigmaS * make_float3(gL[0][i], gL[1][i], gL[2][i]);
        }
    }
    for (int i = 0; i < n; ++i) {
        for (int s = 0; s < skyCount; ++s) {
            const Rgb l1 = sigmaS * make_float3(skyL1[s][0][i], skyL1[s][1][i], skyL1[s][2][i]);
            out[i].L1 += l1;
            float* pl = perLight + perLightStride * size_t(i) + 3 * skyLanes[s].index;
            pl[0] += l1.x, pl[1] += l1.y, pl[2] += l1.z;
        }
        for (int l = 0; l < lightCount; ++l) {
            const LightEntry& e = *lights[l];
            // Light travels along its direction, then toward the camera (along -d).
            const Rgb weight =
                nbLoad3(e.light.color) * nbPhaseEval(vol.medium.phase, -dot(nbLoad3(e.light.direction), d[i]));
            const Rgb l1 = sigmaS * weight * L1s[l][i];
            out[i].L1 += l1;
            float* pl = perLight + perLightStride * size_t(i) + 3 * size_t(&e - ctx.lights.data());
            pl[0] += l1.x, pl[1] += l1.y, pl[2] += l1.z;
        }
        const bool heldOut = tFar && tFar[i] < INFINITY;
        if (skyCount > 0)  // the phase tails of the skies (SkyTail.h)
            addSkyTailsOneVolume(ctx, vol, o[i], d[i], splat(Ts[i]), heldOut, out[i],
                                 perLight + perLightStride * size_t(i));
        if (!heldOut)  // a held-out ray sees no background
            out[i].L0 += Ts[i] * ctx.backgroundAlong(d[i]);
        out[i].transmittance = splat(Ts[i]);
        out[i].depth = opacitySums[i] > 0.0f ? depthSums[i] / opacitySums[i] : 0.0f;
        out[i].opacity = opacitySums[i];
    }
    return true;
}

#endif

}  // namespace nimbus
