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

/* Legendre moments, int P_j(cos) p dOmega: g^j for one HG lobe, so the mixture's are
 * p_j = (1 - w) g^j + w g2^j, p_0 = 1 (w = blend; a blend <= 0 is one lobe, as nbPhaseEval reads it).
 *
 * Their arithmetic is nb_moment: double on the host, float in OpenCL, one text for both. This is
 * the one exception to compat.h's float-only rule, and a deliberate one: the WKB march
 * (src/wkb/WkbIntegrator.cpp) mixes the moments of every volume a node crosses, and its exact
 * angular kernel (src/wkb/AngularKernel.h) evaluates (e^{l p_j} - 1) / (e^l - 1) at scattering
 * lengths l up to 1e4, where it behaves as e^{-l (1 - p_j)}: a float p_j near 1 carries an absolute
 * error of ~6e-8 in 1 - p_j, a relative error of l * 6e-8 ~ 6e-4 in the kernel at l = 1e4, above
 * the march's tolerance. The path tracer samples the phase function and needs no moments; OpenCL
 * code that does gets the same functions in float. */
#ifdef __OPENCL_VERSION__
typedef float nb_moment;
#else
typedef double nb_moment;
#endif

NB_FN nb_moment nbPhaseBlend(NbPhase p)
{
    return p.blend > 0.0f ? (nb_moment)p.blend : (nb_moment)0;
}

/* Adds w p_j to pj[j] for j = 0..order, by running powers (one multiply per order and lobe; the
 * WKB march mixes volumes this way, weighting each by its share of the scattering). */
NB_FN void nbPhaseAddMoments(NbPhase p, nb_moment w, int order, NB_PRIVATE nb_moment* pj)
{
    nb_moment blend = nbPhaseBlend(p);
    nb_moment a = w * ((nb_moment)1 - blend), b = w * blend;
    for (int j = 0; j <= order; ++j) {
        pj[j] += a + b;
        a *= p.g;
        b *= p.g2;
    }
}

/* Mean cosine of the mixture, p_1. */
NB_FN nb_moment nbPhaseMeanCos(NbPhase p)
{
    nb_moment blend = nbPhaseBlend(p);
    return blend > 0 ? ((nb_moment)1 - blend) * p.g + blend * p.g2 : (nb_moment)p.g;
}

/* The largest |g| of the lobes: |p_j| <= nbPhaseMomentBound^j for every j, which bounds the tail
 * of an order sum. */
NB_FN nb_moment nbPhaseMomentBound(NbPhase p)
{
    nb_moment a = fabs(p.g), b = fabs(p.g2);
    return nbPhaseBlend(p) > 0 && b > a ? b : a;
}

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
