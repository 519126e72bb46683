// AdaptiveSampling.h: more camera samples where a pixel is noisy (single, wkb; render.adaptive_threshold,
// render.adaptive_max_spp; docs/scene-format.md).
//
// Every pixel first takes `spp` samples. Then, in rounds, each pixel whose mean is still too noisy
// takes as many samples again as it has (at most up to maxSpp): too noisy where the standard error
// of its mean luminance exceeds `threshold` times that mean,
//
//     sqrt(s^2 / n) > threshold * mean        (s^2: the unbiased variance of its n samples)
//
// of what the camera sees directly and by single scattering, L0 + L1: the terms `single` and `wkb`
// share, so that both take the same samples in every pixel and wkb's L0 and L1 stay single's pixel
// for pixel (wkb = single + L2+). Where a pixel's L1 is noisy (a cloud's edge across it, a
// shadow's edge, thin wisps) its L2+ varies across it too.
//
// Arnold's AA_samples / AA_samples_max / AA_adaptive_threshold and Cycles' adaptive sampling are
// the models. The decision is each pixel's own, from its own samples: a pixel's image does not
// depend on its neighbours, its tile or the thread count (a tile that sees no volume decides as a
// marched one would). A pixel's estimate stays the mean of all its samples, each uniform over the
// pixel filter; the stopping rule's bias (a pixel whose first samples all missed a bright feature
// stops early) measured against uniform sampling at the most samples in docs/validation.md
// "Adaptive pixel sampling".
#pragma once

#include "../scene/Scene.h"

#include <algorithm>
#include <climits>
#include <cmath>

namespace nimbus {

// The count, sum and sum of squares of a pixel's sample values.
struct PixelMoments {
    int n = 0;
    double sum = 0.0, sumSq = 0.0;
    void add(double v)
    {
        ++n;
        sum += v;
        sumSq += v * v;
    }
    double mean() const { return n > 0 ? sum / double(n) : 0.0; }
    // The variance of the mean (s^2 / n, s^2 the unbiased sample variance); 0 below two samples.
    double varianceOfMean() const
    {
        if (n < 2)
            return 0.0;
        const double m = mean();
        return std::max(0.0, (sumSq - double(n) * m * m) / double(n - 1)) / double(n);
    }
};

struct AdaptiveSampling {
    // Relative standard error a pixel's mean may keep; 0: no adaptive sampling.
    double threshold = 0.0;
    int maxSpp = 0;  // the most samples a pixel takes

    bool enabled() const { return threshold > 0.0; }
    // The samples the pixel with moments m takes next (0: it is done): as many again as it has,
    // up to maxSpp. One sample tells no variance: a pixel of spp 1 (a preview) is done.
    int moreSamples(const PixelMoments& m) const
    {
        if (!enabled() || m.n < 2 || m.n >= maxSpp)
            return 0;
        if (!(m.varianceOfMean() > threshold * threshold * m.mean() * m.mean()))
            return 0;
        return std::min(m.n, maxSpp - m.n);
    }
};

// The scene's adaptive sampling for base spp `spp`: off where render.adaptive_threshold is 0 or the
// most samples are no more than spp; render.adaptive_max_spp 0 is 4 spp.
inline AdaptiveSampling adaptiveSamplingOf(const RenderSettings& r, int spp)
{
    AdaptiveSampling a;
    a.maxSpp = r.adaptiveMaxSpp > 0 ? r.adaptiveMaxSpp : int(std::min(4LL * spp, (long long)INT_MAX));
    a.threshold = a.maxSpp > spp ? r.adaptiveThreshold : 0.0;
    return a;
}

}  // namespace nimbus
