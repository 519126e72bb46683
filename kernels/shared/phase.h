/* phase.h: Henyey-Greenstein and two-lobe HG phase functions, evaluated and sampled.
 *
 * Convention: cosTheta is the cosine between the direction light travels before and after the
 * scattering event (wi . wo with both pointing along propagation), so g > 0 scatters forward.
 * Normalisation: the integral over the sphere of p dOmega is 1 (units 1/sr).
 * Shared by the single-scattering marcher, the WKB marcher and the OpenCL path tracer.
 */
#ifndef NIMBUS_KERNELS_SHARED_PHASE_H
#define NIMBUS_KERNELS_SHARED_PHASE_H

#include "compat.h"

/* Plain-data phase description, the same on host and device. blend is the weight of lobe g2. */
typedef struct {
    float g;
    float g2;
    float blend;
    float pad;
} NbPhase;

/* Henyey-Greenstein 1941; Skanberg eq. 23. */
NB_FN float nbHgEval(float g, float cosTheta)
{
    float denom = 1.0f + g * g - 2.0f * g * cosTheta;
    denom = fmax(denom, 1e-12f);
    return NB_INV_4PI * (1.0f - g * g) / (denom * sqrt(denom));
}

/* Inverse-CDF sample of cosTheta (Skanberg eq. 37), stable at g -> 0. */
NB_FN float nbHgSampleCos(float g, float u)
{
    if (fabs(g) < 1e-3f)
        return 1.0f - 2.0f * u;
    float s = (1.0f - g * g) / (1.0f - g + 2.0f * g * u);
    float c = (1.0f + g * g - s * s) / (2.0f * g);
    return clamp(c, -1.0f, 1.0f);
}

NB_FN float nbPhaseEval(NbPhase p, float cosTheta)
{
    float a = nbHgEval(p.g, cosTheta);
    if (p.blend <= 0.0f)
        return a;
    return (1.0f - p.blend) * a + p.blend * nbHgEval(p.g2, cosTheta);
}

/* Legendre moment of order j: p_j = (1-w) g^j + w g2^j (for HG, int P_j(cos) p dOmega = g^j). */
NB_FN float nbPhaseMoment(NbPhase p, int j)
{
    float a = pow(p.g, (float)j);
    if (p.blend <= 0.0f)
        return j == 0 ? 1.0f : a;
    float b = pow(p.g2, (float)j);
    return j == 0 ? 1.0f : (1.0f - p.blend) * a + p.blend * b;
}

/* Mean cosine of the mixture. */
NB_FN float nbPhaseMeanCos(NbPhase p) { return (1.0f - p.blend) * p.g + p.blend * p.g2; }

/* Samples an outgoing direction given incoming travel direction wi; u0 picks the lobe
 * (and is reused, rescaled), u1 the cosine, u2 the azimuth. Returns the sampled direction;
 * the pdf equals nbPhaseEval, so the sample weight is exactly 1. */
NB_FN float3 nbPhaseSample(NbPhase p, float3 wi, float u0, float u1, float u2)
{
    float g = p.g;
    if (p.blend > 0.0f && u0 < p.blend)
        g = p.g2;
    float cosTheta = nbHgSampleCos(g, u1);
    float sinTheta = sqrt(fmax(0.0f, 1.0f - cosTheta * cosTheta));
    float phi = 2.0f * NB_PI * u2;
    float3 t, b;
    nbBasis(wi, &t, &b);
    return normalize(t * (sinTheta * cos(phi)) + b * (sinTheta * sin(phi)) + wi * cosTheta);
}

#endif
