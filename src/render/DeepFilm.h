// DeepFilm.h: deep pixels (docs/output.md "Deep output"): per pixel a short list of samples along
// the camera ray, each a depth interval [Z, ZBack] of camera-space depth with its own premultiplied
// colour and alpha, as OpenEXR's deep images hold them (Kainz et al., "Interpreting OpenEXR Deep
// Pixels"). Compositing a pixel's samples front to back with `over` (flattening) gives its beauty
// and alpha.
//
// How the samples are made (src/engine/TileDriver.cpp): the volumes' camera-space depth range is cut
// into `deep_samples` slices; every camera sample of a pixel is marched once whole and once up to
// each slice's back (the march's own holdout cut, so the prefix takes exactly the samples the whole
// march takes in front of that depth), giving per pixel the radiance L(z) and transmittance T(z)
// gathered in front of each slice edge. A slice's deep sample is then
//
//     alpha_k = 1 - T(z_k) / T(z_{k-1}),   C_k = (L(z_k) - L(z_{k-1})) / T(z_{k-1})
//
// (its light, unattenuated by what lies in front), so flattening telescopes to L and 1 - T of the
// whole march: the beauty and alpha, to float rounding. What the whole march sees past the last
// slice (the background) is one more sample, at Z = ZBack = FLT_MAX, with alpha 0.
#pragma once

#include "../core/Vec.h"

#include <vector>

namespace nimbus {

// One deep sample: [z, zBack] camera-space depth (metres along the view axis), premultiplied
// colour (W/(m^2 sr), scene-linear Rec.709) and alpha.
struct DeepSample {
    float z = 0.0f, zBack = 0.0f;
    Rgb color = splat(0.0f);
    float alpha = 0.0f;
};

// Adjacent samples are merged where their merge is at most this opaque: a holdout then cuts inside
// such a sample by at most this much alpha (docs/output.md). Flattening never changes.
constexpr float kDeepMergeAlpha = 0.001f;

// A pixel's light and transmittance in front of each slice edge. edges: n + 1 depths z_0 < ... <
// z_n (slice k is [z_{k-1}, z_k]); L and T: n + 2 entries, [0] in front of z_0 (0 and 1), [k] in
// front of z_k, [n + 1] the whole march, background included. T is the mean over the channels.
struct DeepCurve {
    std::vector<float> edges;
    std::vector<Rgb> L;
    std::vector<float> T;
};

// The pixel's deep samples, front to back: one per slice that holds light or opacity, plus the
// background sample, merged where kDeepMergeAlpha allows and then, if still more than maxSamples,
// pairwise where the merge is least opaque. Estimators that are not exactly consistent from one
// prefix to the next (emission scattering, wkb's traced order 2) can make L(z) dip or T(z) rise;
// the curves are first made monotone from the back (the whole march's values kept), so colours
// and alphas are never negative and flattening stays exact.
std::vector<DeepSample> deepSamplesOf(DeepCurve curve, int maxSamples);

// Flattens samples (front to back) with `over`: premultiplied colour and alpha.
void flattenDeep(const std::vector<DeepSample>& samples, Rgb& color, float& alpha);

struct DeepFilm {
    int width = 0, height = 0;
    int maxSamples = 32;
    std::vector<std::vector<DeepSample>> pixels;  // row-major from the top-left, the film's full frame

    std::vector<DeepSample>& at(int x, int y) { return pixels[size_t(y) * size_t(width) + size_t(x)]; }
    const std::vector<DeepSample>& at(int x, int y) const { return pixels[size_t(y) * size_t(width) + size_t(x)]; }
};

}  // namespace nimbus
