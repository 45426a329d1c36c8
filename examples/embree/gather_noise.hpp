// The benchmark experiments' estimates of a gather's own noise, from its strata (or a second
// trace of the same directions): the relative noise of its mean (the adaptive lookup) and the
// noise of its gradients and Hessian (the derivative-shrinkage and noise-bound experiments).
#pragma once

#include "metrics.hpp"
#include "trace.hpp"

#include <cstdint>

namespace rd {

// The standard error of the gather's mean luminance relative to that mean: a stratified
// estimate's variance is the sum of its strata's variances over (m n)^2, each stratum's estimated
// as half the squared difference with its azimuthal neighbour. 0 for a black gather.
double relative_noise(const TracedGather &g);

// The noise of gather `g`'s derivatives under its strata's own noise, for the experiments that
// use it (BenchSettings::gradient_shrinkage, ::hessian_shrinkage, ::noise_curvature,
// ::gradient_noise_radius). The derivatives of its luminance are linear in the strata's radiance
// at fixed hits, so a derivative d's noise variance v is the mean of |d|^2 over 8 gathers whose
// radiance is each stratum's noise amplitude with a random sign from `seed`. The Hessian's norm
// is its tangent projection's (Frobenius). A stratum's noise amplitude is |L - L'| / sqrt(2), L'
// its azimuthal neighbour's luminance, or with `retraced` (nullable) the same direction's from
// independent hit radiance. The Hessian's probes are run when `hessian_noise` or hessian_k > 0.
struct DerivativeNoise {
  // max(0, 1 - k v / |d|^2) for the gradient and the Hessian (the Hessian's at least
  // kMinHessianShrink); 1 where k is 0 or d vanishes.
  double gradient_shrink = 1, hessian_shrink = 1;
  // sqrt(v) of the Ward-Heckbert gradient over the gather's luminance irradiance E (1/L; 0 for a
  // black gather): the relative error per unit length the gradient's noise adds to an extrapolation.
  double relative_gradient_noise = 0;
  // sqrt(v / 2) of the tangent Hessian (a per-eigenvalue standard deviation) times D^2 / E, D the
  // harmonic-mean hit distance: the noise in the curvature floor's units (kappa E / D^2); 0 for a
  // black gather or one whose rays all missed.
  double hessian_noise_weight = 0;
};
DerivativeNoise derivative_noise(const TracedGather &g, const TracedGather *retraced, double gradient_k,
                                 double hessian_k, bool hessian_noise, uint64_t seed);


}  // namespace rd
