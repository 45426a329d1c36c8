// The error metrics compared, and a gather evaluated once for all of them.
//
// raddiff does the work: raddiff_gather_evaluation_new evaluates a traced gather (irradiance,
// gradients and the Hessian a metric needs), raddiff_irradiance_record builds a metric's record
// from it under the settings (threshold, radius bounds at the pixel's footprint, anisotropy,
// curvature floor). One evaluation per kind of Hessian, so that each metric is charged for the
// raddiff work it needs and nothing else.
#pragma once

#include "trace.hpp"

#include <memory>
#include <string>
#include <vector>

namespace rd {

enum class Metric {
  SplitSphere,         // Ward 1988: a R, R the harmonic-mean hit distance
  BoundedSplitSphere,  // a min(R, E / |grad E|) (Ward-Heckbert, Krivanek)
  Gradient,            // eps E / |grad E| (Jarosz et al. 2008)
  HessianUnaware,      // radiometric (occlusion-unaware) Hessian, thesis ch. 4
  HessianGeometric,    // geometric Hessian, thesis eq. 4.23
  HessianIsotropic,    // occlusion-aware Hessian, discs
  HessianAnisotropic,  // occlusion-aware Hessian, ellipses of anisotropy <= 2
};

const std::vector<Metric> &all_metrics();
const char *metric_name(Metric m);
Metric parse_metric(const std::string &name);
uint32_t c_metric(Metric m);  // RADDIFF_METRIC_*
bool uses_hessian(Metric m);
// How a record's radius scales with the metric's parameter (1 for the split-sphere family, 1/4
// for the Hessians, whose radii bound an error integrated over the record's disc).
double radius_exponent(Metric m);
double initial_parameter(Metric m);

// The evaluations a set of metrics needs: index 0 without a Hessian, then one per Hessian kind
// (occlusion-aware, unaware, geometric).
struct HessianNeeds {
  bool kind[4] = {true, false, false, false};
};
HessianNeeds hessian_needs(const std::vector<Metric> &metrics);

struct EvaluationDeleter {
  void operator()(raddiff_gather_evaluation *e) const { raddiff_gather_evaluation_free(e); }
};

// A gather evaluated once, with the CPU time of each evaluation, shared by every metric.
struct Evaluated {
  bool valid = false;  // false: raddiff found the gather degenerate (no record)
  std::unique_ptr<raddiff_gather_evaluation, EvaluationDeleter> evaluation[4];
  double seconds[4] = {0, 0, 0, 0};
  double luminance = 0;     // the evaluation's scalar
  double harmonic_mean_distance = INFINITY;
  float value[3] = {0, 0, 0};  // irradiance the records store (the gather's own)
  // The near-field experiment (BenchSettings::near_field_px): the gather's irradiance from hits at
  // least the near reach away, divided by the fraction of its directions that reach that far (the
  // far field as if the near geometry did not block it: what the records store then), and that
  // fraction.
  float far_value[3] = {0, 0, 0};
  double open_fraction = 1;
  // The binned far-field experiment: per direction bin b and channel c, [3 b + c], the mean far
  // radiance of the gather's open rays in the bin minus the mean over all its open rays, shrunk
  // towards 0 by n_b / (n_b + 16) for a bin of n_b rays (0 for an empty bin).
  float far_bins[3 * kDirBins] = {};
  // The adaptive-lookup experiment: the standard error of the gather's mean luminance relative to
  // that mean, from its own strata (0 for a black gather). With far-field gathers it is the far
  // field's, the record's value; otherwise the whole gather's.
  double relative_noise = 0;
  // The gradient-shrinkage experiment (BenchSettings::gradient_shrinkage): the factor in [0, 1]
  // the records' translational gradients are multiplied by (1 when off).
  double gradient_shrink = 1;
  // The Hessian-shrinkage experiment (BenchSettings::hessian_shrinkage): the factor in
  // [kMinHessianShrink, 1] the Hessian metrics' curvature is multiplied by (1 when off).
  double hessian_shrink = 1;
  // The noise-bound experiments (BenchSettings::noise_curvature, ::gradient_noise_radius): the
  // weight added to the Hessian metrics' curvature floor, z sigma D^2 / E, and the gradient's noise
  // over E (DerivativeNoise; 0 when off).
  double noise_curvature_weight = 0;
  double relative_gradient_noise = 0;
};

// The smallest Hessian-shrinkage factor: at it the curvature floor all but sets the radii (the
// curvature counts a thousandth); a floor above 0 keeps the factor from dividing by zero, since it
// divides the accuracy and the floor's weight, which must stay in their domains.
constexpr double kMinHessianShrink = 1e-3;

// `settings` gives the channels and their weights.
Evaluated evaluate_gather(const TracedGather &gather, const HessianNeeds &needs,
                          const raddiff_irradiance_settings &settings);

// Seconds of raddiff evaluation that metric m's records cost.
double raddiff_seconds(Metric m, const Evaluated &e);

// Metric m's record from the evaluation (settings.metric and .accuracy are set from m and p),
// its value the gather's own irradiance. A Hessian metric's radii are those of its Hessian times
// e.hessian_shrink: the radii solve (s |lambda| + kappa E / D^2) a^2 terms = p E, the same as
// accuracy p / s with the floor's weight kappa / s (the pixel bounds then apply as usual); the
// floor's weight is kappa + e.noise_curvature_weight before that.
// False when raddiff finds the metric undefined there.
bool metric_record(Metric m, double p, const Evaluated &e, raddiff_irradiance_settings settings, double footprint,
                   raddiff_cache_record &record);

}  // namespace rd
