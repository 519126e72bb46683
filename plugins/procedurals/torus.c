/* torus.c: an example nimbus volume procedural: a smoke ring, a torus whose surface is pushed
 * in and out by fractal value noise.
 *
 * Parameters (scene "params", all optional; lengths in metres in the volume's space):
 *   major_radius  1.0    radius of the ring's centre line, in the xz plane around +y
 *   minor_radius  0.35   radius of the tube
 *   density       1.0    density inside (the medium's sigma_s, sigma_a are per unit density)
 *   softness      0.1    width of the edge over which density falls to 0
 *   noise         0.4    noise amplitude, as a fraction of minor_radius
 *   frequency     3.0    noise frequency, 1/m
 *   octaves       3      noise octaves (1..8)
 *   seed          1      noise seed (integer)
 *   voxel_size    0.02   lattice spacing nimbus samples with
 *
 * Example scene source:
 *   { "type": "plugin", "path": "libnimbus_torus.so", "params": { "major_radius": 1.2, "seed": 3 } }
 *
 * Written in C99 against src/abi/nimbus_volume_plugin.h only: it shows the whole interface,
 * including the optional block_empty cull. The state is read-only after init, so sample and
 * block_empty are thread-safe as the interface requires.
 */
#include "nimbus_volume_plugin.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct Torus {
    double majorRadius, minorRadius, density, softness, noise, frequency, voxelSize;
    int octaves;
    unsigned seed;
} Torus;

static unsigned hash3(int x, int y, int z, unsigned seed)
{
    unsigned h = seed * 0x9E3779B9u;
    h ^= (unsigned)x * 0x85EBCA6Bu;
    h = (h << 13) | (h >> 19);
    h ^= (unsigned)y * 0xC2B2AE35u;
    h = (h << 17) | (h >> 15);
    h ^= (unsigned)z * 0x27D4EB2Fu;
    h ^= h >> 16;
    h *= 0x7FEB352Du;
    h ^= h >> 15;
    h *= 0x846CA68Bu;
    h ^= h >> 16;
    return h;
}

/* Value in [-1, 1] at a lattice point. */
static double lattice(int x, int y, int z, unsigned seed)
{
    return (double)(hash3(x, y, z, seed) & 0xFFFFFF) / (double)0x7FFFFF - 1.0;
}

static double smooth(double t)
{
    return t * t * (3.0 - 2.0 * t);
}

/* Trilinear value noise with smoothstep weights, in [-1, 1]. */
static double valueNoise(double x, double y, double z, unsigned seed)
{
    double fx = floor(x), fy = floor(y), fz = floor(z);
    int ix = (int)fx, iy = (int)fy, iz = (int)fz;
    double tx = smooth(x - fx), ty = smooth(y - fy), tz = smooth(z - fz);
    double c[2][2][2];
    for (int k = 0; k < 2; ++k)
        for (int j = 0; j < 2; ++j)
            for (int i = 0; i < 2; ++i)
                c[k][j][i] = lattice(ix + i, iy + j, iz + k, seed);
    double y0 = (c[0][0][0] * (1 - tx) + c[0][0][1] * tx) * (1 - ty) + (c[0][1][0] * (1 - tx) + c[0][1][1] * tx) * ty;
    double y1 = (c[1][0][0] * (1 - tx) + c[1][0][1] * tx) * (1 - ty) + (c[1][1][0] * (1 - tx) + c[1][1][1] * tx) * ty;
    return y0 * (1 - tz) + y1 * tz;
}

/* Fractal sum, normalised to [-1, 1]. */
static double fbm(const Torus* t, double x, double y, double z)
{
    double sum = 0.0, amplitude = 1.0, norm = 0.0, f = t->frequency;
    for (int o = 0; o < t->octaves; ++o) {
        sum += amplitude * valueNoise(x * f, y * f, z * f, t->seed + 131u * (unsigned)o);
        norm += amplitude;
        amplitude *= 0.5;
        f *= 2.0;
    }
    return sum / norm;
}

/* The largest distance from the centre line at which the density can be non-zero. */
static double reach(const Torus* t)
{
    return t->minorRadius * (1.0 + t->noise) + t->softness;
}

static int parseNumber(const char* name, const char* text, double* out, char* error, size_t size)
{
    char* end = NULL;
    double v = strtod(text, &end);
    if (end == text || *end != '\0' || !isfinite(v)) {
        snprintf(error, size, "params.%s: expected a number, got '%s'", name, text);
        return 1;
    }
    *out = v;
    return 0;
}

NIMBUS_VOLUME_PLUGIN_EXPORT int nimbus_volume_plugin_version(void)
{
    return NIMBUS_VOLUME_PLUGIN_VERSION;
}

NIMBUS_VOLUME_PLUGIN_EXPORT void* nimbus_volume_init(const NimbusVolumeParam* params, size_t count, char* error,
                                                     size_t errorSize)
{
    Torus t = {1.0, 0.35, 1.0, 0.1, 0.4, 3.0, 0.02, 3, 1u};
    for (size_t i = 0; i < count; ++i) {
        const char* name = params[i].name;
        double v = 0.0;
        if (parseNumber(name, params[i].value, &v, error, errorSize))
            return NULL;
        if (!strcmp(name, "major_radius"))
            t.majorRadius = v;
        else if (!strcmp(name, "minor_radius"))
            t.minorRadius = v;
        else if (!strcmp(name, "density"))
            t.density = v;
        else if (!strcmp(name, "softness"))
            t.softness = v;
        else if (!strcmp(name, "noise"))
            t.noise = v;
        else if (!strcmp(name, "frequency"))
            t.frequency = v;
        else if (!strcmp(name, "voxel_size"))
            t.voxelSize = v;
        else if (!strcmp(name, "octaves"))
            t.octaves = (int)v;
        else if (!strcmp(name, "seed"))
            t.seed = (unsigned)v;
        else {
            snprintf(error, errorSize,
                     "params.%s: unknown parameter (expected major_radius, minor_radius, density, softness, noise, "
                     "frequency, octaves, seed, voxel_size)",
                     name);
            return NULL;
        }
    }
    if (!(t.majorRadius > 0) || !(t.minorRadius > 0) || !(t.voxelSize > 0) || t.density < 0 || t.softness < 0 ||
        t.noise < 0 || t.noise >= 1 || !(t.frequency > 0) || t.octaves < 1 || t.octaves > 8) {
        snprintf(error, errorSize,
                 "params: need major_radius, minor_radius, voxel_size, frequency > 0, density, softness >= 0, "
                 "noise in [0, 1), octaves in [1, 8]");
        return NULL;
    }
    Torus* state = (Torus*)malloc(sizeof(Torus));
    if (!state) {
        snprintf(error, errorSize, "out of memory");
        return NULL;
    }
    *state = t;
    return state;
}

NIMBUS_VOLUME_PLUGIN_EXPORT int nimbus_volume_bounds(void* state, NimbusVolumeBounds* b, char* error, size_t errorSize)
{
    const Torus* t = (const Torus*)state;
    double r = reach(t), R = t->majorRadius + r;
    b->min[0] = -R, b->min[1] = -r, b->min[2] = -R;
    b->max[0] = R, b->max[1] = r, b->max[2] = R;
    b->voxel_size = t->voxelSize;
    (void)error, (void)errorSize;
    return 0;
}

NIMBUS_VOLUME_PLUGIN_EXPORT int nimbus_volume_sample(void* state, const double* p, size_t count, float* densities,
                                                     char* error, size_t errorSize)
{
    const Torus* t = (const Torus*)state;
    for (size_t i = 0; i < count; ++i) {
        double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
        double ring = sqrt(x * x + z * z) - t->majorRadius;
        double d = sqrt(ring * ring + y * y); /* distance to the centre line */
        double surface = t->minorRadius * (1.0 + t->noise * fbm(t, x, y, z));
        double inside = surface - d; /* > 0 inside the tube */
        double w = t->softness > 0 ? inside / t->softness : (inside > 0 ? 1.0 : 0.0);
        w = w < 0 ? 0 : (w > 1 ? 1 : w);
        densities[i] = (float)(t->density * smooth(w));
    }
    (void)error, (void)errorSize;
    return 0;
}

/* Empty if the box is farther from the centre line than the noise can push the surface. */
NIMBUS_VOLUME_PLUGIN_EXPORT int nimbus_volume_block_empty(void* state, const double* lo, const double* hi)
{
    const Torus* t = (const Torus*)state;
    /* Distance from the y axis over the box: nearest and farthest points in xz. */
    double nx = lo[0] > 0 ? lo[0] : (hi[0] < 0 ? hi[0] : 0), nz = lo[2] > 0 ? lo[2] : (hi[2] < 0 ? hi[2] : 0);
    double fx = fabs(lo[0]) > fabs(hi[0]) ? lo[0] : hi[0], fz = fabs(lo[2]) > fabs(hi[2]) ? lo[2] : hi[2];
    double rhoMin = sqrt(nx * nx + nz * nz), rhoMax = sqrt(fx * fx + fz * fz);
    double dRho =
        t->majorRadius < rhoMin ? rhoMin - t->majorRadius : (t->majorRadius > rhoMax ? t->majorRadius - rhoMax : 0.0);
    double dy = lo[1] > 0 ? lo[1] : (hi[1] < 0 ? -hi[1] : 0.0);
    return sqrt(dRho * dRho + dy * dy) > reach(t) ? 1 : 0;
}

NIMBUS_VOLUME_PLUGIN_EXPORT void nimbus_volume_cleanup(void* state)
{
    free(state);
}
