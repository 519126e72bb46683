// PhaseMixture.h: the mean cosine of the phase function where volumes overlap: each volume's
// nbPhaseMeanCos weighted by its share of sigma_s there (VolumeSet::sample's phaseWeights,
// index-aligned with the volumes). The skin cells' and the view focus's diffusion lengths read it.
#pragma once

#include "../../kernels/shared/phase.h"

#include <cstddef>
#include <vector>

namespace nimbus::vrl {

// 0 where every weight is 0 (no medium).
inline double mixedMeanCosine(const std::vector<NbPhase>& phases, const float* weights)
{
    double g = 0.0, sum = 0.0;
    for (size_t v = 0; v < phases.size(); ++v)
        if (weights[v] > 0.0f) {
            g += double(weights[v]) * double(nbPhaseMeanCos(phases[v]));
            sum += double(weights[v]);
        }
    return sum > 0.0 ? g / sum : 0.0;
}

}  // namespace nimbus::vrl
