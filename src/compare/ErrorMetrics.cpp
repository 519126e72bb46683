// ErrorMetrics.cpp: the errors of a render against the reference (measureError, the metrics
// in Compare.h), the reference's own noise, and the path tracer's time to reach an error. Apart
// from running the comparison so that the tests can check the numbers alone.
#include "Compare.h"
#include "FilmAccess.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

namespace nimbus {

namespace {

double meanOf(const Aov& a, int n)
{
    double s = 0;
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            s += a.pixels[size_t(i) * size_t(a.channels) + size_t(c)];
    return s / std::max(1, 3 * n);
}

}  // namespace

ErrorMetrics measureError(const Film& x, const Film& ref, const std::string& aov)
{
    const Aov& a = requireAov(x, aov);
    const Aov& r = requireAov(ref, aov);
    if (x.width != ref.width || x.height != ref.height)
        throw Error("compare: film sizes differ");
    const int n = ref.width * ref.height;
    const double m = meanOf(r, n);
    const double eps = std::max((0.1 * m) * (0.1 * m), 1e-20);
    double se = 0, absErr = 0, absRef = 0, sx = 0, sr = 0;
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            const double p = a.pixels[size_t(i) * size_t(a.channels) + size_t(c)];
            const double q = r.pixels[size_t(i) * size_t(r.channels) + size_t(c)];
            se += (p - q) * (p - q) / (q * q + eps);
            absErr += std::fabs(p - q);
            absRef += std::fabs(q);
            sx += p;
            sr += q;
        }
    ErrorMetrics e;
    e.relMse = se / std::max(1, 3 * n);
    e.meanRel = absRef > 0 ? absErr / absRef : 0;
    e.energyRel = sr != 0 ? (sx - sr) / sr : 0;
    return e;
}

double referenceNoiseRelMse(const Film& ref)
{
    const Aov* v = ref.find("variance");
    const Aov* b = ref.find("beauty");
    if (!v || !b)
        return 0;
    const int n = ref.width * ref.height;
    std::vector<double> y(static_cast<size_t>(n));
    double m = 0;
    for (int i = 0; i < n; ++i)
        m += (y[size_t(i)] = lum(*b, size_t(i)));
    m /= std::max(1, n);
    const double eps = (0.1 * m) * (0.1 * m) + 1e-20;
    double s = 0;
    for (int i = 0; i < n; ++i)
        s += v->pixels[size_t(i)] / (y[size_t(i)] * y[size_t(i)] + eps);
    return s / std::max(1, n);
}

double ptTimeToError(const std::vector<CompareRow>& rows, double relMse, double floor)
{
    // Seed-averaged (time, relMSE) per ladder label.
    std::map<std::string, std::pair<double, double>> sum;
    std::map<std::string, int> count;
    for (const CompareRow& r : rows)
        if (r.method == "pathtrace" && r.label.rfind("t=", 0) == 0) {
            auto& s = sum[r.label];
            s.first += r.seconds, s.second += r.beauty.relMse;
            ++count[r.label];
        }
    std::vector<std::pair<double, double>> pts;
    for (auto& [label, s] : sum)
        pts.push_back({s.first / count[label], s.second / count[label]});
    if (pts.empty() || !(relMse > 0))
        return 0;
    std::sort(pts.begin(), pts.end());
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
        const auto& [t0, e0] = pts[i];
        const auto& [t1, e1] = pts[i + 1];
        if ((relMse <= e0 && relMse >= e1) || (relMse >= e0 && relMse <= e1)) {
            if (e0 == e1)
                return t0;
            const double f = std::log(relMse / e0) / std::log(e1 / e0);
            return std::exp(std::log(t0) + f * (std::log(t1) - std::log(t0)));
        }
    }
    // Outside the measured range. Against a reference of its own noise `floor` (independent of
    // the render's), the path tracer's relMSE is floor + c / t: its own noise falls as 1/t, the
    // reference's stays. c from the nearest ladder step; a relMSE at or under the floor is one the
    // path tracer reaches only as t -> infinity. With no floor (or a ladder step under it, where
    // the floor was overestimated) the whole relMSE falls as 1/t.
    const auto& end = relMse < pts.back().second ? pts.back() : pts.front();
    if (floor > 0.0 && end.second > floor) {
        if (relMse <= floor)
            return std::numeric_limits<double>::infinity();
        return end.first * (end.second - floor) / (relMse - floor);
    }
    return end.first * end.second / relMse;
}

}  // namespace nimbus
