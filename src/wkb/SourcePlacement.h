// SourcePlacement.h: where along the camera ray, and how blurred, the source Lblur is read for
// the paths of scattering length l (Tessendorf eqs. 69, 79, 82; DESIGN "Where WKB is weak").
//
// This is the one replaceable part of the L2+ march: the angular kernels and weights do not
// depend on it. Both models read Lblur on the camera ray, at distance `s` from the camera, with
// a Gaussian blur of standard deviation `sigma` (metres, per axis).
//
//  Straight (sec. 6.3.6): the source sits at s(l), the point where the ray itself has reached
//    scattering length l (eq. 89), blurred by eq. 79's width W = s sqrt(K mu l), read as a box
//    of width W: sigma = W / sqrt(12). In a medium that does not start at the camera, s^2 l is
//    replaced by 6 P = 6 int_0^s l(s') (s - s') ds', which equals l s^2 for a homogeneous medium
//    entered at the camera and adds nothing for the empty space in front of the medium
//    (docs/wkb.md "blur": a path's lateral wander accumulates only after it has scattered).
//    So sigma^2 = K mu P / 2.
//  RandomWalk: the source sits at the mean displacement of an angular random walk of l steps
//    with mean cosine g, l_D = (1 - e^{-(1-g) l}) / (1-g) scattering lengths behind the entry
//    point (D = l_D / b in a homogeneous medium), found in the (l, s) table; its spread is the
//    walk's (worm-like chain with persistence 1/(1-g)): Var = (2 (x - E) - E^2)/(1-g)^2,
//    x = (1-g) l, E = 1 - e^{-x}, sigma^2 = Var / 3 / bbar^2 with bbar the mean scattering
//    coefficient between the entry and the source.
#pragma once

#include "ScatteringTable.h"

namespace nimbus::wkb {

enum class PlacementModel { Straight, RandomWalk };

struct SourceRead {
    double s = 0.0;      // distance from the camera along the ray, metres
    double sigma = 0.0;  // blur, metres (Gaussian standard deviation per axis)
};

struct PlacementInput {
    const ScatteringTable* table = nullptr;
    TableEntry at;        // the table's state at the quadrature point (scattering length at.lhat)
    double sEntry = 0.0;  // where the ray's scattering length starts to grow
    double mu = 0.0;      // squared angular width of the phase function's forward peak
    double g = 0.0;       // mean cosine of the phase function
    double blurK = 24.0;  // K of eq. 79
};

SourceRead placeSource(PlacementModel model, const PlacementInput& in);

// The two pieces of the random-walk model, exposed for tests: the mean displacement l_D and the
// displacement variance, both in scattering lengths, for l steps with mean cosine g.
double walkMeanDisplacement(double l, double g);
double walkVariance(double l, double g);

}  // namespace nimbus::wkb
