#include "SampleAllocation.h"

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

namespace {

double workTimesVariance(const PilotMeasure& m, int k)
{
    return (k * m.cameraWork + m.restWork) * (m.cameraVariance / k + m.restVariance);
}

}  // namespace

int chooseCameraPaths(const PilotMeasure& m, int fallback)
{
    const double values[] = {m.cameraVariance, m.restVariance, m.cameraWork, m.restWork};
    for (double v : values)
        if (!std::isfinite(v) || v < 0.0)
            return fallback;
    if (!(m.cameraVariance > 0.0) || !(m.cameraWork > 0.0))
        return 1;  // camera paths that vary not at all (or cost nothing): one is enough
    if (!(m.restVariance > 0.0) || !(m.restWork > 0.0))
        return fallback;  // nothing to weigh them against
    // The product is convex in K: its continuous minimum, then the better integer beside it.
    const double best = std::sqrt(m.cameraVariance * m.restWork / (m.restVariance * m.cameraWork));
    const int below = int(std::clamp(std::floor(best), 1.0, double(kMaxCameraPaths)));
    const int above = std::min(below + 1, kMaxCameraPaths);
    return workTimesVariance(m, above) < workTimesVariance(m, below) ? above : below;
}

}  // namespace nimbus::vrl
