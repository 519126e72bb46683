/* brickdda.h: the 3D DDA over a grid's 8^3 brick cells (Amanatides & Woo 1987), one copy for the
 * path tracer's majorant walk (majorant.h, OpenCL) and the host's brick walks (the single-
 * scattering and shadow-map marches, span finding: src/render/BrickWalk.h).
 *
 * The ray is o + t d in the grid's index space (voxels; d need not be unit, so t keeps the
 * caller's units: world metres for the image of a unit world direction). The caller picks the
 * starting cell (the host floors the entry point, the majorant walk also clamps it to the box),
 * then nbBrickDdaAxis sets up each axis; nbBrickDdaExitAxis names the face through which the ray
 * leaves the current cell, at t = tNext[axis], and nbBrickDdaAdvance crosses it.
 */
#ifndef NIMBUS_KERNELS_SHARED_BRICKDDA_H
#define NIMBUS_KERNELS_SHARED_BRICKDDA_H

#include "brickgrid.h"

typedef struct {
    int cell[3];    /* current brick (index / 8) */
    int stepDir[3]; /* +1, -1, or 0 along an axis the ray does not move on */
    float tNext[3]; /* t of the next brick face per axis */
    float tDelta[3];
} NbBrickDda;

/* Axis a of the walk starting in brick `cell` along that axis; o, d the ray's a components. */
NB_FN void nbBrickDdaAxis(NB_PRIVATE NbBrickDda* s, int a, int cell, float o, float d)
{
    s->cell[a] = cell;
    if (d > 0.0f) {
        s->stepDir[a] = 1;
        s->tNext[a] = ((float)((cell + 1) * NB_BRICK) - o) / d;
        s->tDelta[a] = (float)NB_BRICK / d;
    } else if (d < 0.0f) {
        s->stepDir[a] = -1;
        s->tNext[a] = ((float)(cell * NB_BRICK) - o) / d;
        s->tDelta[a] = -(float)NB_BRICK / d;
    } else {
        s->stepDir[a] = 0;
        s->tNext[a] = INFINITY;
        s->tDelta[a] = INFINITY;
    }
}

/* The axis whose face the ray crosses first (a tie goes to the later axis). */
NB_FN int nbBrickDdaExitAxis(NB_PRIVATE const NbBrickDda* s)
{
    return s->tNext[0] < s->tNext[1] ? (s->tNext[0] < s->tNext[2] ? 0 : 2) : (s->tNext[1] < s->tNext[2] ? 1 : 2);
}

/* Crosses the face of `axis` into the next brick. */
NB_FN void nbBrickDdaAdvance(NB_PRIVATE NbBrickDda* s, int axis)
{
    s->cell[axis] += s->stepDir[axis];
    s->tNext[axis] += s->tDelta[axis];
}

#endif
