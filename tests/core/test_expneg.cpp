// expNeg against the correctly rounded reference, in double: the bound ExpNeg.h states.
#include "../../src/core/ExpNeg.h"

#include <gtest/gtest.h>

#include <cmath>

using nimbus::expNeg;

TEST(ExpNeg, WithinThreeTenthsOfAMillionthOfExpOverTheClampRange)
{
    double worst = 0.0, at = 0.0;
    // Every float step of 2^-12 from -87 to 87 (700k points), plus the reduction's seams.
    for (int i = -87 * 4096; i <= 87 * 4096; ++i) {
        const float x = float(i) / 4096.0f;
        const double want = std::exp(-double(x));
        const double rel = std::fabs(double(expNeg(x)) - want) / want;
        if (rel > worst)
            worst = rel, at = x;
    }
    for (int k = -125; k <= 125; ++k)
        for (float x : {float((k + 0.5) * M_LN2), std::nextafter(float((k + 0.5) * M_LN2), 0.0f)}) {
            if (std::fabs(x) > 87.0f)
                continue;
            const double want = std::exp(-double(x));
            const double rel = std::fabs(double(expNeg(x)) - want) / want;
            if (rel > worst)
                worst = rel, at = x;
        }
    EXPECT_LT(worst, 3e-7) << "at x = " << at;
    std::printf("expNeg: worst relative error %.3g at x = %g\n", worst, at);
}

TEST(ExpNeg, ExactAtZeroAndClampedBeyondTheNormalRange)
{
    EXPECT_EQ(expNeg(0.0f), 1.0f);
    EXPECT_GT(expNeg(87.0f), 0.0f);
    EXPECT_EQ(expNeg(1e30f), expNeg(87.0f));  // opaque, not 0 / denormal / NaN
    EXPECT_TRUE(std::isfinite(expNeg(-1e30f)));
    EXPECT_TRUE(std::isnan(expNeg(NAN)));
    for (float x = 0.0f; x < 80.0f; x += 0.37f)
        EXPECT_LE(expNeg(x + 0.37f), expNeg(x));  // monotone: transmittance never grows with depth
}
