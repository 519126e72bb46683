// PathtraceState (pathtracer/PathtraceState.h): the running estimate as film AOVs, and the pooling
// that merges sample splits. Pinned against an independent computation: per-pixel samples drawn
// here, split into parts, each part accumulated in float as the kernel does (running means,
// Welford's M2, kernels/pathtrace.cl), pooled; against the mean and the sum of squared
// deviations of all the samples computed directly in double (two passes).
#include "pathtracer/PathtraceState.h"

#include "../../kernels/shared/ptscene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

using namespace nimbus;

namespace {

// The kernel's accumulation of one sample into a pixel's accumulator (pathtrace.cl).
void accumulate(float* a, const std::vector<float>& sample, long long index, int stride)
{
    const float inv = 1.0f / float(index + 1);
    for (int k = 0; k < stride; ++k)
        if (k != NB_ACC_MEAN_Y && k != NB_ACC_M2_Y)
            a[k] += (sample[size_t(k)] - a[k]) * inv;
    const float y = sample[NB_ACC_MEAN_Y];
    const float delta = y - a[NB_ACC_MEAN_Y];
    a[NB_ACC_MEAN_Y] += delta * inv;
    a[NB_ACC_M2_Y] += delta * (y - a[NB_ACC_MEAN_Y]);
}

}  // namespace

TEST(PathtraceState, PoolingSplitsEqualsAllTheirSamplesAtOnce)
{
    const size_t lights = 2, pixels = 50;
    const int stride = stateStride(lights);
    const long long sizes[] = {7, 33, 120, 2};
    std::mt19937 rng(16);
    std::lognormal_distribution<float> heavy(-1.0f, 1.2f);  // a heavy-tailed radiance
    // samples[pixel][i][k]
    std::vector<std::vector<std::vector<float>>> samples(pixels);
    long long total = 0;
    for (long long n : sizes)
        total += n;
    for (auto& px : samples)
        for (long long i = 0; i < total; ++i) {
            std::vector<float> s(static_cast<size_t>(stride));
            for (int k = 0; k < stride; ++k)
                s[size_t(k)] = heavy(rng);
            px.push_back(s);
        }
    std::vector<std::vector<float>> parts;
    long long first = 0;
    for (long long n : sizes) {
        std::vector<float> acc(pixels * size_t(stride), 0.0f);
        for (size_t p = 0; p < pixels; ++p)
            for (long long i = 0; i < n; ++i)
                accumulate(acc.data() + p * size_t(stride), samples[p][size_t(first + i)], i, stride);
        parts.push_back(acc);
        first += n;
    }
    std::vector<StatePart> pool;
    for (size_t i = 0; i < parts.size(); ++i)
        pool.push_back({&parts[i], sizes[i]});
    long long pooledCount = 0;
    const std::vector<float> pooled = poolStates(pool, lights, pooledCount);
    ASSERT_EQ(pooledCount, total);
    ASSERT_EQ(pooled.size(), pixels * size_t(stride));
    // Float running means of up to 120 terms: a few hundred float epsilons at most.
    const double tol = 200 * 0x1p-24;
    for (size_t p = 0; p < pixels; ++p) {
        for (int k = 0; k < stride; ++k) {
            if (k == NB_ACC_M2_Y)
                continue;
            double mean = 0;
            for (const auto& s : samples[p])
                mean += s[size_t(k)];
            mean /= double(total);
            EXPECT_NEAR(pooled[p * size_t(stride) + size_t(k)], mean, tol * (std::fabs(mean) + 1.0))
                << "pixel " << p << " slot " << k;
        }
        double mean = 0, m2 = 0;
        for (const auto& s : samples[p])
            mean += s[NB_ACC_MEAN_Y];
        mean /= double(total);
        for (const auto& s : samples[p])
            m2 += (s[NB_ACC_MEAN_Y] - mean) * (s[NB_ACC_MEAN_Y] - mean);
        EXPECT_NEAR(pooled[p * size_t(stride) + NB_ACC_M2_Y], m2, tol * m2 * 10) << "pixel " << p;
    }
}

TEST(PathtraceState, ResolvesTheOutputAovsAndRoundTripsTheState)
{
    const std::vector<std::string> lights = {"light_key"};
    const int stride = stateStride(lights.size());
    Film film;
    film.width = 4, film.height = 3;
    film.x0 = 1, film.x1 = 3, film.y0 = 0, film.y1 = 2;
    for (const char* name : {"beauty", "L0", "L1", "L2plus", "light_key"})
        film.add(name, std::string(name) == "beauty" ? 4 : 3, false);
    for (const char* name : {"alpha", "depth", "variance"})
        film.add(name, 1, true);
    addStateAovs(film, lights);
    std::vector<float> acc(4 * size_t(stride));
    for (size_t i = 0; i < acc.size(); ++i)
        acc[i] = 0.01f * float(i + 1);
    const long long n = 10;
    resolveState(acc, n, lights, film);
    // Pixel (2, 1) is the window's fourth.
    const float* a = acc.data() + 3 * size_t(stride);
    const float* beauty = film.pixel(*film.find("beauty"), 2, 1);
    EXPECT_FLOAT_EQ(beauty[0], a[0] + a[3] + a[6]);
    EXPECT_FLOAT_EQ(beauty[3], 1.0f - a[NB_ACC_TRANSMITTANCE]);
    EXPECT_FLOAT_EQ(*film.pixel(*film.find("alpha"), 2, 1), 1.0f - a[NB_ACC_TRANSMITTANCE]);
    EXPECT_FLOAT_EQ(*film.pixel(*film.find("depth"), 2, 1), a[NB_ACC_DEPTH_SUM] / a[NB_ACC_DEPTH_HITS]);
    EXPECT_FLOAT_EQ(*film.pixel(*film.find("variance"), 2, 1), float(a[NB_ACC_M2_Y] / double(n * (n - 1))));
    EXPECT_FLOAT_EQ(film.pixel(*film.find("light_key"), 2, 1)[2], a[NB_ACC_LIGHTS + 2]);
    std::vector<float> back;
    ASSERT_TRUE(readState(film, lights, back));
    EXPECT_EQ(back, acc);
    dropStateAovs(film);
    EXPECT_FALSE(readState(film, lights, back));
    EXPECT_EQ(film.find("state_L0"), nullptr);
    EXPECT_NE(film.find("L0"), nullptr);
}
