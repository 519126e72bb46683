// PathtraceState.h: the path tracer's running estimate (its per-pixel accumulator, ptscene.h's
// NB_ACC_* layout) as float AOVs of a film, so that a checkpoint resumes exactly and sample splits
// merge exactly (docs/farm.md).
//
// The accumulator holds, per pixel, running means over the n samples so far (Skanberg eq. 39):
// L0, L1, L2plus (RGB), the camera-ray transmittance, depth x hit and hit, the channel average y
// of the beauty, each light's NEE contribution, and Welford's M2 of y. The output AOVs are
// functions of it (beauty = L0 + L1 + L2plus, alpha = 1 - T, depth = sum / hits, variance =
// M2 / (n (n - 1))); it is the state itself that pools:
//   N = sum n_i, mean = sum n_i mean_i / N, M2 = sum M2_i + sum n_i (mean_i - mean)^2
// (Chan, Golub & LeVeque 1979, the pairwise update of Welford's M2), exact in real arithmetic.
//
// The AOVs are "state_L0", "state_L1", "state_L2plus", "state_transmittance", "state_depth_sum",
// "state_depth_hits", "state_mean_y", "state_m2_y" and "state_<light AOV>" per light, all float,
// so the EXR round trip is exact.
#pragma once

#include "../render/Film.h"

#include <string>
#include <vector>

namespace nimbus {

// The state AOVs' names begin with this.
inline constexpr const char* kStateAovPrefix = "state_";

bool isStateAov(const std::string& name);

// The state AOVs for a scene with these light AOVs ("light_<name>"), in accumulator order, with
// their channel counts.
std::vector<std::pair<std::string, int>> stateAovLayout(const std::vector<std::string>& lightAovs);

// Adds the state AOVs to the film (float, zeroed) where it lacks them.
void addStateAovs(Film& film, const std::vector<std::string>& lightAovs);

// Removes the state AOVs from the film.
void dropStateAovs(Film& film);

// Accumulator floats per pixel: NB_ACC_STRIDE(lights).
int stateStride(size_t lightCount);

// The film's data window's accumulator (row-major over [x0, x1) x [y0, y1), stateStride floats a
// pixel) from its state AOVs. Returns false when the film lacks one of them.
bool readState(const Film& film, const std::vector<std::string>& lightAovs, std::vector<float>& acc);

// Writes the accumulator (as readState lays it out) into the state AOVs the film has, and resolves
// it after n samples into the output AOVs it has: beauty (RGB, and A = alpha), L0, L1, L2plus,
// alpha, depth, variance and each light AOV.
void resolveState(const std::vector<float>& acc, long long n, const std::vector<std::string>& lightAovs, Film& film);

// The beauty's relMSE from its own noise after n samples: the mean over pixels of var / (y^2 +
// eps), y the running mean's channel average (NB_ACC_MEAN_Y) and var its variance of the mean
// (M2 / (n (n - 1))), eps = (0.1 mean(y))^2 so that black pixels do not dominate (nimbus
// compare's measure of its reference's floor). INFINITY below 2 samples. The noise target of the
// path tracer and of vrl.
double stateNoiseRelMse(const std::vector<float>& acc, int stride, long long n);

// One part of a pooled estimate: its accumulator and sample count.
struct StatePart {
    const std::vector<float>* acc = nullptr;
    long long n = 0;
};

// The pooled accumulator of independent parts of one pixel window (the formulas above, in
// double), their total sample count in `total`.
std::vector<float> poolStates(const std::vector<StatePart>& parts, size_t lightCount, long long& total);

}  // namespace nimbus
