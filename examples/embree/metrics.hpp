// The error metrics compared, and what each needs of a gather.
#pragma once

#include "trace.hpp"

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
bool uses_hessian(Metric m);
// How a record's radius scales with the metric's parameter (1 for the split-sphere family, 1/4
// for the Hessians, whose radii bound an error integrated over the record's disc).
double radius_exponent(Metric m);
double initial_parameter(Metric m);

// Which Hessians a set of metrics needs.
struct HessianNeeds {
  bool aware = false, unaware = false, geometric = false;
};
HessianNeeds hessian_needs(const std::vector<Metric> &metrics);

// A gather evaluated once, with the CPU time of each part, shared by every metric.
struct Evaluated {
  bool valid = false;  // false: raddiff found the gather degenerate (no record)
  double irradiance[3] = {}, gradient[9] = {}, rotation[9] = {};
  double hessian[3][27] = {};  // aware, unaware, geometric (channel-major, row-major 3x3 each)
  double harmonic_mean_distance = INFINITY;
  double evaluate_seconds = 0;           // irradiance and Ward-Heckbert gradients
  double hessian_seconds[3] = {0, 0, 0};  // each Hessian
  double luminance() const { return rd::luminance(irradiance); }
};

Evaluated evaluate_gather(const TracedGather &gather, const HessianNeeds &needs);

// Seconds of raddiff work the metric's records cost from this evaluation.
double raddiff_seconds(Metric m, const Evaluated &e);

// The record extent of metric m with parameter p, before any clamp: radii along axes (tangent
// plane). Returns false when the metric is undefined for this gather (no record then).
bool metric_extent(Metric m, double p, const Evaluated &e, V3 normal, double radii[2], raddiff_vec3 axes[2]);

}  // namespace rd
