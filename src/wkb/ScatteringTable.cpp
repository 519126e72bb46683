#include "ScatteringTable.h"

#include <algorithm>

namespace nimbus::wkb {

namespace {

// The state a distance u into the stretch that starts at `e` and ends at `f` (u <= f.s - e.s).
TableEntry advance(const TableEntry& e, const TableEntry& f, double u)
{
    TableEntry r;
    const double len = f.s - e.s;
    const double w = len > 0.0 ? u / len : 0.0;
    const double beta = len > 0.0 ? (f.lhat - e.lhat) / len : 0.0;  // d lhat / ds in the stretch
    r.s = e.s + u;
    r.lhat = e.lhat + beta * u;
    for (int c = 0; c < 3; ++c) {
        r.l[c] = e.l[c] + w * (f.l[c] - e.l[c]);
        r.tauA[c] = e.tauA[c] + w * (f.tauA[c] - e.tauA[c]);
    }
    // lhat(s + v) = lhat + beta v: M1 += lhat u + beta u^2/2; P += M1 u + lhat u^2/2 + beta u^3/6.
    r.M1 = e.M1 + e.lhat * u + 0.5 * beta * u * u;
    r.P = e.P + e.M1 * u + 0.5 * e.lhat * u * u + beta * u * u * u / 6.0;
    return r;
}

}  // namespace

void ScatteringTable::reset(double s0)
{
    mEntries.clear();
    TableEntry e;
    e.s = s0;
    mEntries.push_back(e);
}

void ScatteringTable::append(double ds, const double b[3], const double a[3])
{
    if (!(ds > 0.0))
        return;
    const TableEntry& e = mEntries.back();
    TableEntry f;
    f.s = e.s + ds;
    double bhat = 0.0;
    for (int c = 0; c < 3; ++c) {
        f.l[c] = e.l[c] + b[c] * ds;
        f.tauA[c] = e.tauA[c] + a[c] * ds;
        bhat += b[c];
    }
    bhat /= 3.0;
    f.lhat = e.lhat + bhat * ds;
    f.M1 = e.M1 + e.lhat * ds + 0.5 * bhat * ds * ds;
    f.P = e.P + e.M1 * ds + 0.5 * e.lhat * ds * ds + bhat * ds * ds * ds / 6.0;
    mEntries.push_back(f);
}

double ScatteringTable::sAt(double lhat) const
{
    if (lhat <= mEntries.front().lhat)
        return mEntries.front().s;
    if (lhat >= mEntries.back().lhat) {
        // The first entry that reaches the end value (a trailing gap adds s but no l).
        auto it = std::lower_bound(mEntries.begin(), mEntries.end(), mEntries.back().lhat,
                                   [](const TableEntry& e, double v) { return e.lhat < v; });
        return it->s;
    }
    auto it = std::lower_bound(mEntries.begin(), mEntries.end(), lhat,
                               [](const TableEntry& e, double v) { return e.lhat < v; });
    const TableEntry& f = *it;
    const TableEntry& e = *(it - 1);
    const double dl = f.lhat - e.lhat;  // > 0: e.lhat < lhat <= f.lhat
    return e.s + (f.s - e.s) * std::min(1.0, (lhat - e.lhat) / dl);
}

TableEntry ScatteringTable::at(double s) const
{
    if (s <= mEntries.front().s)
        return mEntries.front();
    if (s >= mEntries.back().s)
        return mEntries.back();
    auto it =
        std::upper_bound(mEntries.begin(), mEntries.end(), s, [](double v, const TableEntry& e) { return v < e.s; });
    const TableEntry& f = *it;
    const TableEntry& e = *(it - 1);
    return advance(e, f, s - e.s);
}

}  // namespace nimbus::wkb
