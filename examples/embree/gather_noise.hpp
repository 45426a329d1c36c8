// The benchmark experiments' estimates of a gather's own noise, from its strata (or a second
// trace of the same directions): the relative noise of its mean (the adaptive lookup) and the
// factors the derivative-shrinkage experiments multiply its gradients and Hessian by.
#pragma once

#include "metrics.hpp"
#include "trace.hpp"

#include <cstdint>

namespace rd {

// The standard error of the gather's mean luminance relative to that mean: a stratified
// estimate's variance is the sum of its strata's variances over (m n)^2, each stratum's estimated
// as half the squared difference with its azimuthal neighbour. 0 for a black gather.
double relative_noise(const TracedGather &g);

// The derivative-shrinkage experiments' factors (BenchSettings::gradient_shrinkage,
// ::hessian_shrinkage) for gather `g`: max(0, 1 - k v / |d|^2) for each derivative d of its
// luminance (the Hessian's at least kMinHessianShrink; 1 where k is 0 or d vanishes), v the mean
// of |d|^2 over 8 gathers whose radiance is each stratum's noise amplitude with a random sign from
// `seed` (d is linear in the strata's radiance at fixed hits). The Hessian's norm is its tangent
// projection's. A stratum's noise amplitude is |L - L'| / sqrt(2), L' its azimuthal neighbour's
// luminance, or with `retraced` (nullable) the same direction's from independent hit radiance.
struct DerivativeShrink {
  double gradient = 1, hessian = 1;
};
DerivativeShrink derivative_shrink(const TracedGather &g, const TracedGather *retraced, double gradient_k,
                                   double hessian_k, uint64_t seed);

}  // namespace rd
