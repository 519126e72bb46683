// LegendreSeries.h: the Legendre polynomials P_0(x), P_1(x), P_2(x), ... in turn, for the order
// sum of a delta-direction source (eq. 88 closed by the addition theorem,
// sum_j (2j+1)/(4 pi) p_j R_j(l) P_j(n . N); docs/wkb.md).
//
// One step is Bonnet's recurrence (j+1) P_{j+1} = (2j+1) x P_j - j P_{j-1}, as
// boost::math::legendre_next writes it; boost::math::legendre_p(j, x) runs the same recurrence
// from P_0 on every call, so calling it per order would cost O(J^2) per march node where the
// series costs O(J) (J up to render.wkb_order_max, 4096 at most). tests/wkb/test_wkb_legendre.cpp
// holds the series against boost::math::legendre_p over every order the renderer allows.
#pragma once

#include <boost/math/special_functions/legendre.hpp>

namespace nimbus::wkb {

class LegendreSeries {
public:
    // x = cos of the angle, in [-1, 1].
    explicit LegendreSeries(double x) : mX(x) {}

    int order() const { return int(mJ); }
    double value() const { return mP; }  // P_order(x)

    void advance()
    {
        const double next = boost::math::legendre_next(mJ, mX, mP, mPrev);
        mPrev = mP;
        mP = next;
        ++mJ;
    }

private:
    double mX;
    double mPrev = 0.0;  // P_{j-1}; P_{-1} = 0 makes the first step give P_1 = x
    double mP = 1.0;     // P_j
    unsigned mJ = 0;
};

}  // namespace nimbus::wkb
