// SampleAllocation.h: how many camera paths one vrl iteration spends on each pixel.
//
// An iteration is one unbiased sample per pixel of two kinds of term: K camera paths estimate
// L0 and L1 (and emission), and the gathers from every VRL with the path technique of
// BeamPathMis.h (on the first camera path) estimate L2plus. With c_k the work of one camera path
// and c_r the rest of an iteration's work per pixel (its gathers, its path technique, its share
// of the light pass), and v_k and v_r the variances of one camera path's L0 + L1 and of the
// iteration's L2plus, the iteration's work times its variance is
//     (K c_k + c_r) (v_k / K + v_r),
// the inverse of the estimator's efficiency (Veach 1997, sec. 2.4.1: at equal time the error is
// this product over the time). It is least at
//     K* = sqrt((v_k c_r) / (v_r c_k)).
// The scenes differ by more than a factor of ten in where that lies: in thin haze a VRL gather
// costs far more than a camera path and L1 is a large part of the image (K about 15-20); in a
// medium-dense sphere under a point light the camera paths cost as much as the gathers and
// L2plus carries most of the noise (K = 2-4; docs/vrl.md, "Camera paths per iteration").
//
// The terms are measured by a short pilot before the render (VrlIntegrator.cpp) on streams of
// its own, so that every render of a scene and seed, split, resumed or on any thread count, makes
// the same choice; work is VrlMedium's count of majorant segments and density reads
// (setWorkCounter), not time, for the same reason.
#pragma once

namespace nimbus::vrl {

// What the pilot measured. Variances are in nimbus compare's relMSE units: each pixel's variance
// over its squared value plus (0.1 x the image mean)^2, averaged over the pilot's pixels. Work in
// VrlMedium's units, per pixel.
struct PilotMeasure {
    double cameraVariance = 0;  // v_k: one camera path's L0 + L1
    double restVariance = 0;    // v_r: one iteration's L2plus
    double cameraWork = 0;      // c_k: one camera path
    double restWork = 0;        // c_r: the rest of an iteration
};

constexpr int kMaxCameraPaths = 64;

// The K in [1, kMaxCameraPaths] of least work x variance: 1 where the camera paths do not vary;
// `fallback` where L2plus has no variance or no work to weigh them against, or a value is
// negative or not finite.
int chooseCameraPaths(const PilotMeasure& m, int fallback);

}  // namespace nimbus::vrl
