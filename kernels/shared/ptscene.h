/* ptscene.h: the path tracer's scene as the OpenCL kernel reads it: one descriptor per volume
 * and the per-launch parameters. Plain data with fixed-width members, sizes static_asserted on
 * the host (src/pathtracer/PathtraceScene.cpp), so host and device agree byte for byte.
 *
 * The volumes' grids live in three buffers shared by all volumes (concatenated BrickGrid table,
 * pool and slot-majorant arrays, see brickgrid.h); a descriptor holds the offsets into them,
 * the transform from world to the grid's index space and the medium.
 */
#ifndef NIMBUS_KERNELS_SHARED_PTSCENE_H
#define NIMBUS_KERNELS_SHARED_PTSCENE_H

#include "brickgrid.h"
#include "camera.h"
#include "envmap.h"
#include "filter.h"
#include "geometry.h"
#include "phase.h"

/* 352 bytes. Coefficients in 1/m with the density scale folded in: sigma at a point is
 * sigma_* times the trilinear density there.
 *
 * Velocity motion blur (docs/motion-blur.md): a path at shutter time s (seconds after the
 * frame's) reads the volume at index point q - v(q) s, v the velocity grid. Then boundsLo/Hi
 * are grown by the largest displacement over the shutter, and motionMajorant holds, over the
 * grown box's brick slots, the slot extinction majorants max-filtered over that displacement:
 * a bound on sigma_t at any point and any time of the shutter, so tracking stays unbiased.
 *
 * Transform motion blur (motion.h): a path at shutter time s sees a moving volume through its
 * indexFromWorld at s, interpolated from the transform's knots. The box and the slot majorants
 * are in index space, so they hold at every time unchanged. */
typedef struct {
    float indexFromWorld[12]; /* 3x4 row-major: p_index = M p_world + t (rows: M | t) */
    float sigma_s[4];         /* xyz RGB scattering; w: 0 */
    float sigma_t[4];         /* xyz RGB extinction; w: majorant scale = max channel (x 1 + 1e-5) */
    NbPhase phase;
    float boundsLo[4];   /* xyz: index-space box of the active bricks (density and emission),
                          * brick aligned; w: extinction majorant (1/m) of an emitting slot
                          * (see pathtrace.cl, "emission") */
    float boundsHi[4];   /* xyz: upper corner; w: emission scale (medium.emissionScale) */
    NbGridDesc density;  /* 1 channel: density after the shader */
    NbGridDesc emission; /* 3 channels: emitted radiance per metre W/(m^3 sr); or absent */
    NbGridDesc velocity; /* 3 channels: index voxels per second (velocity blur); or absent */
    NbGridDesc motionMajorant; /* velocity blur: slot majorants (1/m) of the grown box, no
                                * table or pool; or absent */
    float shutter[4];          /* velocity blur: xy the shutter's open and close, seconds after
                                * the frame's time (the same in every volume); zw unused */
    int motion[4];             /* a transform moving within the shutter (motion.h): x the offset
                                * of its block (indexFromUser, then knots) in the majorant
                                * buffer, y the knot count; 0 0: still (indexFromWorld holds).
                                * zw unused */
} NbVolumeDesc;

/* Per-launch parameters, 324 bytes. */
typedef struct {
    NbCamera camera;
    float background[4]; /* radiance seen by camera rays that leave the volumes (L0) */
    int width, height;   /* full image, pixels */
    int x0, y0;          /* the data window's (crop's) top-left pixel */
    int cropWidth;       /* data window width; the launch covers cropWidth x rows pixels */
    int pixelCount;
    nb_uint seed;
    nb_uint sampleStart; /* global index of this launch's first sample per pixel */
    int samples;         /* samples per pixel in this launch */
    int maxDepth;        /* the most scattering events a path may have */
    int rrDepth;         /* Russian roulette from this many scattering events on */
    int lightCount;
    int volumeCount;
    int countDepthCap; /* 1: maxDepth is the safety cap of an unbounded render; paths reaching
                        * it are counted in counters[NB_COUNTER_DEPTH_CAP] */
    int filterType;    /* NB_FILTER_* (filter.h) */
    float filterWidth; /* pixels */
    nb_uint accStart;  /* the sample index the accumulator's running means start from: 0, or the
                        * first sample of a sample split (--samples A-B: A). Sample s is the
                        * (s - accStart + 1)-th the means have seen. */
    NbGeomScene geom;  /* the geometry's BVH and planes (geometry.h); all 0 without geometry */
    int holdoutDepthWidth, holdoutDepthHeight; /* camera.holdout_depth's image (holdoutdepth.h) */
    float holdoutDepthScale[2];                /* its pixels per camera pixel, x and y */
    NbEnvMap envMap;   /* the environment light's map (envmap.h), its data in the envData buffer */
    int envLight;      /* index in the light list of the light with that map; -1: none */
    /* Bounded launches (pathtrace.cl, NbPathState): the launch covers the work items
     * [rangeStart, rangeStart + its global size); each may do eventBudget steps (flight starts,
     * tentative collisions, shadow-ray steps; 0: 2^31 - 1) before it saves its path in the state
     * buffer and stops; resume 1: each item continues from its saved path (or returns, where it
     * had finished). */
    int eventBudget;
    int resume;
    int rangeStart;
} NbPtParams;

/* The kernel's event counters (one int each). */
#define NB_COUNTER_BAD_SAMPLES 0 /* non-finite path samples dropped */
#define NB_COUNTER_DEPTH_CAP 1   /* paths ended by the safety cap on the depth (countDepthCap) */
#define NB_COUNTER_SUSPENDED 2   /* work items of the last launch whose eventBudget stopped them */
#define NB_COUNTER_COUNT 3

/* Per-pixel accumulator layout (floats), running means over the samples so far (Skanberg
 * eq. 39) and Welford's M2 of the per-sample channel average of beauty. */
#define NB_ACC_L0 0
#define NB_ACC_L1 3
#define NB_ACC_L2 6
#define NB_ACC_TRANSMITTANCE 9 /* camera-ray transmittance (channel average) */
#define NB_ACC_DEPTH_SUM 10    /* mean of depth * hit */
#define NB_ACC_DEPTH_HITS 11   /* mean of hit (a first scattering vertex exists) */
#define NB_ACC_MEAN_Y 12       /* mean of the channel average of beauty */
#define NB_ACC_M2_Y 13         /* Welford's sum of squared deviations of the same */
#define NB_ACC_LIGHTS 14       /* 3 floats per light, NEE contributions of that light */
#define NB_ACC_STRIDE(lightCount) (NB_ACC_LIGHTS + 3 * (lightCount))

#endif
