#include "SourcePlacement.h"

#include <algorithm>
#include <cmath>

namespace nimbus::wkb {

double walkMeanDisplacement(double l, double g)
{
    const double k = 1.0 - std::min(g, 1.0);  // 1 - g: inverse persistence, in scattering lengths
    const double x = k * l;
    if (x < 1e-8)
        return l * (1.0 - 0.5 * x);
    return -std::expm1(-x) / k;
}

double walkVariance(double l, double g)
{
    const double k = 1.0 - std::min(g, 1.0);
    const double x = k * l;
    if (!(l > 0.0))
        return 0.0;
    // Var = (2 (x - E) - E^2) / k^2, E = 1 - e^{-x}; its series 2x^3/3 - x^4/2 + 7x^5/30 below
    // x = 1e-3, where the closed form cancels (-> Var = (2/3) k l^3 as k -> 0: a straight path).
    if (x < 1e-3)
        return l * l * l * k * (2.0 / 3.0 - 0.5 * x + 7.0 / 30.0 * x * x);
    const double E = -std::expm1(-x);
    return std::max(0.0, (2.0 * (x - E) - E * E) / (k * k));
}

SourceRead placeSource(PlacementModel model, const PlacementInput& in)
{
    SourceRead r;
    if (model == PlacementModel::Straight) {
        r.s = in.at.s;
        r.sigma = std::sqrt(std::max(0.0, 0.5 * in.blurK * in.mu * in.at.P));
        return r;
    }
    const double lD = walkMeanDisplacement(in.at.lhat, in.g);
    r.s = in.table->sAt(lD);
    // Metres per scattering length between the entry and the source: the table's own mean.
    const double span = r.s - in.sEntry;
    double bbar = span > 0.0 && lD > 0.0 ? lD / span : 0.0;
    if (!(bbar > 0.0)) {
        // At the very entry: the local coefficient of the stretch the quadrature point is in.
        const double ds = std::max(in.at.s - in.sEntry, 1e-30);
        bbar = in.at.lhat / ds;
    }
    const double var = walkVariance(in.at.lhat, in.g);
    r.sigma = bbar > 0.0 ? std::sqrt(var / 3.0) / bbar : 0.0;
    return r;
}

}  // namespace nimbus::wkb
