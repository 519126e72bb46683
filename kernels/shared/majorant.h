/* majorant.h: the piecewise-constant majorant of extinction along a ray, for delta tracking,
 * ratio tracking and emission (pathtrace.cl), walked with one 3D DDA per volume.
 *
 * Each volume's majorant is constant over a brick slot (8^3 voxels): sigma_t's largest channel
 * times the slot's maximum density, which bounds trilinear interpolation exactly (brickgrid.h).
 * Where volumes overlap, their coefficients add, and so do their majorants. The walk visits
 * the stretches of the ray over which the summed majorant is constant; stretches with a zero
 * majorant (empty slots, gaps between volumes) are skipped without drawing a random number,
 * which is the empty-space skipping of free-flight sampling (Skanberg sec. 6.2 with a
 * majorant grid instead of one global maximum; Novak et al. 2018, "Monte Carlo methods for
 * volumetric light transport simulation", sec. 5.1 on local majorants).
 *
 * Amanatides & Woo (1987) stepping, per volume, in that volume's index space (brickdda.h, the
 * same DDA as the host's brick walks): the index-space ray o_i + t d_i keeps the world
 * parameter t (d_i is not normalised), so crossings of all volumes are ordered on one axis. NB_GLOBAL_MAJORANT=1
 * replaces the grid by one majorant per volume (its largest slot), for benchmarks.
 */
#ifndef NIMBUS_KERNELS_SHARED_MAJORANT_H
#define NIMBUS_KERNELS_SHARED_MAJORANT_H

#include "brickdda.h"
#include "motion.h"
#include "ptscene.h"

#ifndef NB_NUM_VOLUMES
#define NB_NUM_VOLUMES 8 /* host builds: the most the kernel supports */
#endif
#ifndef NB_HAS_EMISSION
#define NB_HAS_EMISSION 1
#endif
#ifndef NB_GLOBAL_MAJORANT
#define NB_GLOBAL_MAJORANT 0
#endif
#ifndef NB_HAS_VELOCITY
#define NB_HAS_VELOCITY 1
#endif
#ifndef NB_GRID_PNANOVDB
#define NB_GRID_PNANOVDB 0 /* 1: densities through PNanoVDB (nanogrid.h), a measured alternative */
#endif
#if NB_GRID_PNANOVDB
#include "nanogrid.h"
#endif
#ifndef NB_HAS_MOTION
#define NB_HAS_MOTION 1 /* some volume's transform moves within the shutter (motion.h) */
#endif

#define NB_INF INFINITY

NB_FN float nbComponent(float3 v, int axis)
{
    return axis == 0 ? v.x : (axis == 1 ? v.y : v.z);
}

typedef struct {
    float3 o[NB_NUM_VOLUMES];       /* index-space ray origin, per volume */
    float3 d[NB_NUM_VOLUMES];       /* index-space direction (world t is kept) */
    NbBrickDda dda[NB_NUM_VOLUMES]; /* the slot walk per volume */
    float tEvent[NB_NUM_VOLUMES];   /* next change of this volume's majorant; NB_INF when done */
    float tEnd[NB_NUM_VOLUMES];     /* where the ray leaves this volume's box */
    float maj[NB_NUM_VOLUMES];      /* current majorant, 1/m; 0 outside */
    int state[NB_NUM_VOLUMES];      /* 0 before the box, 1 inside, 2 past it */
    float t;                        /* the tracker's position along the ray */
    float seconds;                  /* the path's shutter time (velocity blur, ptscene.h) */
} NbMajorantIter;

/* The majorant (1/m) of volume vd over brick slot (cx, cy, cz). An emitting slot gets at least
 * the volume's emission rate (boundsLo[3]): emission is gathered at tentative collisions, so
 * the collision rate must be positive wherever there is emission, even with zero density. */
NB_FN float nbSlotMajorant(NB_GLOBAL const NbVolumeDesc* vd, NB_GLOBAL const float* majorants, int cx, int cy, int cz)
{
#if NB_HAS_VELOCITY
    if (vd->motionMajorant.dims[3] > 0) /* a moving volume: the grown, max-filtered slots */
        return nbGridMajorant(vd->motionMajorant, majorants, cx, cy, cz);
#endif
    float m = vd->sigma_t[3] * nbGridMajorant(vd->density, majorants, cx, cy, cz);
#if NB_HAS_EMISSION
    if (vd->emission.dims[3] > 0 && nbGridMajorant(vd->emission, majorants, cx, cy, cz) > 0.0f)
        m = nbFmax(m, vd->boundsLo[3]);
#endif
    return m;
}

NB_FN float nbVolumeMajorant(NB_GLOBAL const NbVolumeDesc* vd)
{
#if NB_HAS_VELOCITY
    if (vd->motionMajorant.dims[3] > 0)
        return vd->motionMajorant.maxValue;
#endif
    float m = vd->sigma_t[3] * vd->density.maxValue;
#if NB_HAS_EMISSION
    if (vd->emission.dims[3] > 0 && vd->emission.maxValue > 0.0f)
        m = nbFmax(m, vd->boundsLo[3]);
#endif
    return m;
}

/* Volume vd's world-to-index transform (3x4 row-major) at shutter time `seconds`: its
 * indexFromWorld, or where its transform moves within the shutter, the knots' (motion.h). */
NB_FN void nbVolumeIndexFromWorld(NB_GLOBAL const NbVolumeDesc* vd, NB_GLOBAL const float* majorants, float seconds,
                                  NB_PRIVATE float* m)
{
#if NB_HAS_MOTION
    if (vd->motion[1] > 0) {
        nbMotionIndexFromWorld(majorants + vd->motion[0], vd->motion[1], seconds, m);
        return;
    }
#endif
    for (int i = 0; i < 12; ++i)
        m[i] = vd->indexFromWorld[i];
}

/* Starts the walk along o + t d (world space, d unit), t in [tMin, tMax], of a path at shutter
 * time `seconds` (0 without motion blur). The index-space ray of a volume whose transform moves
 * is its ray at that time; the box and slot majorants live in index space and hold at any time. */
NB_FN void nbMajorantInit(NB_PRIVATE NbMajorantIter* it, NB_GLOBAL const NbVolumeDesc* vols, int count, float3 o,
                          float3 d, float tMin, float tMax, float seconds, NB_GLOBAL const float* majorants)
{
    it->t = tMin;
    it->seconds = seconds;
    for (int v = 0; v < NB_NUM_VOLUMES; ++v) {
        it->state[v] = 2;
        it->tEvent[v] = NB_INF;
        it->tEnd[v] = tMin;
        it->maj[v] = 0.0f;
        if (v >= count)
            continue;
        float m[12];
        nbVolumeIndexFromWorld(vols + v, majorants, seconds, m);
        float3 oi =
            make_float3(m[0] * o.x + m[1] * o.y + m[2] * o.z + m[3], m[4] * o.x + m[5] * o.y + m[6] * o.z + m[7],
                        m[8] * o.x + m[9] * o.y + m[10] * o.z + m[11]);
        float3 di = make_float3(m[0] * d.x + m[1] * d.y + m[2] * d.z, m[4] * d.x + m[5] * d.y + m[6] * d.z,
                                m[8] * d.x + m[9] * d.y + m[10] * d.z);
        it->o[v] = oi;
        it->d[v] = di;
        float t0 = tMin, t1 = tMax;
        int hit = 1;
        for (int a = 0; a < 3; ++a) {
            float oa = nbComponent(oi, a), da = nbComponent(di, a);
            float lo = vols[v].boundsLo[a], hi = vols[v].boundsHi[a];
            if (da == 0.0f) {
                if (oa < lo || oa > hi)
                    hit = 0;
                continue;
            }
            float ta = (lo - oa) / da, tb = (hi - oa) / da;
            t0 = nbFmax(t0, nbFmin(ta, tb));
            t1 = nbFmin(t1, nbFmax(ta, tb));
        }
        if (hit && t0 < t1) {
            it->state[v] = 0;
            it->tEvent[v] = t0;
            it->tEnd[v] = t1;
        }
    }
}

/* Processes volume v's next event (entering its box, crossing a slot boundary, leaving). */
NB_FN void nbMajorantStep(NB_PRIVATE NbMajorantIter* it, int v, NB_GLOBAL const NbVolumeDesc* vols,
                          NB_GLOBAL const float* majorants)
{
    NB_GLOBAL const NbVolumeDesc* vd = vols + v;
    NB_PRIVATE NbBrickDda* dda = &it->dda[v];
    if (it->state[v] == 0) {
        it->state[v] = 1;
#if NB_GLOBAL_MAJORANT
        it->maj[v] = nbVolumeMajorant(vd);
        it->tEvent[v] = it->tEnd[v];
#else
        float3 p = it->o[v] + it->d[v] * it->tEvent[v];
        for (int a = 0; a < 3; ++a) {
            /* The entry point lies on the box; clamping only undoes rounding. */
            int lo = (int)floor(vd->boundsLo[a] * (1.0f / NB_BRICK));
            int hi = (int)ceil(vd->boundsHi[a] * (1.0f / NB_BRICK)) - 1;
            int c = (int)floor(nbComponent(p, a) * (1.0f / NB_BRICK));
            c = c < lo ? lo : (c > hi ? hi : c);
            nbBrickDdaAxis(dda, a, c, nbComponent(it->o[v], a), nbComponent(it->d[v], a));
        }
        it->maj[v] = nbSlotMajorant(vd, majorants, dda->cell[0], dda->cell[1], dda->cell[2]);
        it->tEvent[v] = nbFmin(nbFmin(dda->tNext[0], nbFmin(dda->tNext[1], dda->tNext[2])), it->tEnd[v]);
#endif
        return;
    }
#if !NB_GLOBAL_MAJORANT
    int axis = nbBrickDdaExitAxis(dda);
    if (dda->tNext[axis] < it->tEnd[v]) {
        nbBrickDdaAdvance(dda, axis);
        it->maj[v] = nbSlotMajorant(vd, majorants, dda->cell[0], dda->cell[1], dda->cell[2]);
        it->tEvent[v] = nbFmin(nbFmin(dda->tNext[0], nbFmin(dda->tNext[1], dda->tNext[2])), it->tEnd[v]);
        return;
    }
#endif
    it->state[v] = 2;
    it->maj[v] = 0.0f;
    it->tEvent[v] = NB_INF;
}

/* Applies every event at or before it->t, then returns 1 with the stretch [it->t, *segEnd) of
 * constant, positive majorant *maj; stretches of zero majorant are skipped. Returns 0 once the
 * ray has left every volume. The caller moves it->t forward and calls again. */
NB_FN int nbMajorantNext(NB_PRIVATE NbMajorantIter* it, NB_GLOBAL const NbVolumeDesc* vols,
                         NB_GLOBAL const float* majorants, NB_PRIVATE float* segEnd, NB_PRIVATE float* maj)
{
    for (int guard = 0; guard < (1 << 22); ++guard) {
        float tE = NB_INF, m = 0.0f;
        for (int v = 0; v < NB_NUM_VOLUMES; ++v) {
            while (it->state[v] != 2 && it->tEvent[v] <= it->t)
                nbMajorantStep(it, v, vols, majorants);
            tE = nbFmin(tE, it->tEvent[v]);
            m += it->maj[v];
        }
        if (!(tE < NB_INF))
            return 0;
        if (m > 0.0f) {
            *segEnd = tE;
            *maj = m;
            return 1;
        }
        it->t = tE;
    }
    return 0;
}

/* Volume v's index-space lookup point at the tracker's position: with velocity blur moved back
 * along the velocity read there, q - v(q) s (ptscene.h). */
NB_FN float3 nbMajorantLookup(NB_PRIVATE const NbMajorantIter* it, NB_GLOBAL const NbVolumeDesc* vols, int v,
                              NB_GLOBAL const int* tables, NB_GLOBAL const float* pools)
{
    float3 q = it->o[v] + it->d[v] * it->t;
#if NB_HAS_VELOCITY
    if (vols[v].velocity.dims[3] > 0)
        q = q - nbGridSample3(vols[v].velocity, tables, pools, q) * it->seconds;
#endif
    return q;
}

/* Density (after the shader, before the density scale is applied by sigma) of every volume at
 * the tracker's position; 0 for volumes the point is not inside. */
NB_FN void nbMajorantDensities(NB_PRIVATE const NbMajorantIter* it, NB_GLOBAL const NbVolumeDesc* vols,
                               NB_GLOBAL const int* tables, NB_GLOBAL const float* pools, NB_PRIVATE float* rho)
{
    for (int v = 0; v < NB_NUM_VOLUMES; ++v) {
        rho[v] = 0.0f;
        if (it->state[v] == 1)
#if NB_GRID_PNANOVDB
            rho[v] = nbFmax(0.0f, nbNanoSample(vols[v].density, pools, nbMajorantLookup(it, vols, v, tables, pools)));
#else
            rho[v] = nbFmax(0.0f, nbGridSample(vols[v].density, tables, pools, nbMajorantLookup(it, vols, v, tables, pools)));
#endif
    }
}

#if NB_HAS_EMISSION
/* Emitted radiance per metre, W/(m^3 sr), summed over volumes, at the tracker's position
 * (the grid times the medium's emission scale, boundsHi[3]). */
NB_FN float3 nbMajorantEmission(NB_PRIVATE const NbMajorantIter* it, NB_GLOBAL const NbVolumeDesc* vols,
                                NB_GLOBAL const int* tables, NB_GLOBAL const float* pools)
{
    float3 e = make_float3(0.0f, 0.0f, 0.0f);
    for (int v = 0; v < NB_NUM_VOLUMES; ++v)
        if (it->state[v] == 1 && vols[v].emission.dims[3] > 0)
            e = e + nbGridSample3(vols[v].emission, tables, pools, nbMajorantLookup(it, vols, v, tables, pools)) *
                        vols[v].boundsHi[3];
    return e;
}
#endif

#endif
