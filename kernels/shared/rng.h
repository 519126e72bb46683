/* rng.h: counter-based random numbers, shared by host and kernels.
 *
 * A random number is a pure function of (seed, pixel, sample, dimension), so an image does not
 * depend on the thread count, the tile order or the OpenCL work-group size (STYLE rule 7).
 * The mixer is the PCG output permutation applied to a combined key (O'Neill 2014), hashed
 * twice to decorrelate neighbouring keys.
 */
#ifndef NIMBUS_KERNELS_SHARED_RNG_H
#define NIMBUS_KERNELS_SHARED_RNG_H

#include "compat.h"

NB_FN nb_uint nbPcgHash(nb_uint v)
{
    nb_uint state = v * 747796405u + 2891336453u;
    nb_uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

/* The stream of one pixel sample: advanced by one per dimension drawn. */
typedef struct {
    nb_uint key;
    nb_uint dimension;
} NbRng;

NB_FN NbRng nbRngStart(nb_uint seed, nb_uint pixelIndex, nb_uint sampleIndex)
{
    NbRng r;
    r.key = nbPcgHash(seed ^ nbPcgHash(pixelIndex ^ nbPcgHash(sampleIndex + 0x9e3779b9u)));
    r.dimension = 0u;
    return r;
}

/* Uniform float in [0, 1): the top 24 bits, so 1 is never returned. */
NB_FN float nbRngNext(NB_PRIVATE NbRng* r)
{
    nb_uint h = nbPcgHash(r->key ^ nbPcgHash(r->dimension++ * 0x85ebca6bu + 0x632be5abu));
    return (float)(h >> 8) * (1.0f / 16777216.0f);
}

#endif
