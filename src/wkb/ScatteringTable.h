// ScatteringTable.h: the {l, s} table of Tessendorf sec. 6.3.4 for one camera ray.
//
// The march advances in scattering length l (eq. 89: l = int_0^s b(x - n s') ds'); the table
// keeps every (l, s) pair it has passed, so that any later question "at which distance s did the
// ray reach scattering length l?" (eq. 73, inverted) has an exact answer. Between two entries
// the coefficients are constant (one medium sample per stretch, like the L1 march), so l and the
// optical depth are linear in s there and the inversion is a division.
//
// Per entry: s (metres from the ray origin, the camera), the march variable lhat (the mean of the
// three channels' l: one shared step for RGB, see WkbMarcher.cpp), per-channel l and absorption
// depth tau_a = tau - l, and the two moments the blur width needs (docs/wkb.md, "blur"):
//   M1(s) = int_0^s lhat ds'     and     P(s) = int_0^s lhat(s') (s - s') ds'
// In a homogeneous medium entered at s = 0, 6 P = l s^2, the product in eq. 79's s sqrt(24 mu l).
#pragma once

#include <cstddef>
#include <vector>

namespace nimbus::wkb {

struct TableEntry {
    double s = 0.0;
    double lhat = 0.0;
    double l[3] = {0.0, 0.0, 0.0};
    double tauA[3] = {0.0, 0.0, 0.0};
    double M1 = 0.0;
    double P = 0.0;
};

class ScatteringTable {
public:
    // Starts a table at distance s0 with l = tau = 0 (s0 is where the first medium can be; the
    // empty space before it adds nothing to any column).
    void reset(double s0);

    // Appends a stretch of length ds (metres) with constant scattering b and absorption a (1/m,
    // per channel). A stretch with b = a = 0 is a gap: l stays, M1 and P keep growing.
    void append(double ds, const double b[3], const double a[3]);

    const TableEntry& back() const { return mEntries.back(); }
    const TableEntry& operator[](size_t i) const { return mEntries[i]; }
    size_t size() const { return mEntries.size(); }

    // The first distance s at which lhat reaches `lhat` (clamped to the table's range).
    double sAt(double lhat) const;
    // The exact state at distance s (clamped to the table's range).
    TableEntry at(double s) const;

private:
    std::vector<TableEntry> mEntries;
};

}  // namespace nimbus::wkb
