#include "metrics.hpp"

namespace rd {

const std::vector<Metric> &all_metrics() {
  static const std::vector<Metric> all = {Metric::SplitSphere,      Metric::BoundedSplitSphere, Metric::Gradient,
                                          Metric::HessianUnaware,   Metric::HessianGeometric,
                                          Metric::HessianIsotropic, Metric::HessianAnisotropic};
  return all;
}

const char *metric_name(Metric m) {
  switch (m) {
    case Metric::SplitSphere: return "split-sphere";
    case Metric::BoundedSplitSphere: return "bounded-split-sphere";
    case Metric::Gradient: return "gradient";
    case Metric::HessianUnaware: return "hessian-unaware";
    case Metric::HessianGeometric: return "hessian-geometric";
    case Metric::HessianIsotropic: return "hessian-isotropic";
    case Metric::HessianAnisotropic: return "hessian-anisotropic";
  }
  return "?";
}

Metric parse_metric(const std::string &name) {
  for (Metric m : all_metrics())
    if (name == metric_name(m)) return m;
  throw std::runtime_error("unknown metric " + name);
}

bool uses_hessian(Metric m) {
  return m == Metric::HessianUnaware || m == Metric::HessianGeometric || m == Metric::HessianIsotropic ||
         m == Metric::HessianAnisotropic;
}

double radius_exponent(Metric m) { return uses_hessian(m) ? 0.25 : 1.0; }
double initial_parameter(Metric m) { return uses_hessian(m) ? 1e-3 : 0.2; }

HessianNeeds hessian_needs(const std::vector<Metric> &metrics) {
  HessianNeeds n;
  for (Metric m : metrics) {
    n.aware |= m == Metric::HessianIsotropic || m == Metric::HessianAnisotropic;
    n.unaware |= m == Metric::HessianUnaware;
    n.geometric |= m == Metric::HessianGeometric;
  }
  return n;
}

Evaluated evaluate_gather(const TracedGather &g, const HessianNeeds &needs) {
  Evaluated e;
  raddiff_gather_input input{};
  input.directions = g.directions.data();
  input.distance = g.distance.data();
  input.radiance = g.radiance.data();
  input.channels = 3;
  raddiff_gather_output out{};
  out.irradiance = e.irradiance;
  out.gradient = e.gradient;
  out.rotation_gradient = e.rotation;
  double t0 = thread_cpu_seconds();
  const raddiff_status st = raddiff_gather_evaluate(&g.layout, &g.frame, &input, &out);
  e.evaluate_seconds = thread_cpu_seconds() - t0;
  if (st == RADDIFF_ERROR_DEGENERATE) return e;
  check(st, "raddiff_gather_evaluate");
  e.harmonic_mean_distance = out.harmonic_mean_distance;
  e.valid = true;
  if (needs.aware) {
    raddiff_gather_output h{};
    h.hessian = e.hessian[0];
    t0 = thread_cpu_seconds();
    check(raddiff_gather_evaluate(&g.layout, &g.frame, &input, &h), "raddiff_gather_evaluate (Hessian)");
    e.hessian_seconds[0] = thread_cpu_seconds() - t0;
  }
  if (needs.unaware || needs.geometric)
    throw std::runtime_error("the radiometric and geometric Hessians are not in this build's C ABI yet");
  return e;
}

double raddiff_seconds(Metric m, const Evaluated &e) {
  double s = e.evaluate_seconds;
  if (m == Metric::HessianIsotropic || m == Metric::HessianAnisotropic) s += e.hessian_seconds[0];
  if (m == Metric::HessianUnaware) s += e.hessian_seconds[1];
  if (m == Metric::HessianGeometric) s += e.hessian_seconds[2];
  return s;
}

bool metric_extent(Metric m, double p, const Evaluated &e, V3 normal, double radii[2], raddiff_vec3 axes[2]) {
  const double lum = std::max(e.luminance(), 1e-12);
  const V3 grad{0.2126 * e.gradient[0] + 0.7152 * e.gradient[3] + 0.0722 * e.gradient[6],
                0.2126 * e.gradient[1] + 0.7152 * e.gradient[4] + 0.0722 * e.gradient[7],
                0.2126 * e.gradient[2] + 0.7152 * e.gradient[5] + 0.0722 * e.gradient[8]};
  const double g = length(grad);
  const double hmd = e.harmonic_mean_distance;
  axes[0] = axes[1] = raddiff_vec3{0, 0, 0};
  switch (m) {
    case Metric::SplitSphere:
      if (!std::isfinite(hmd)) return false;
      radii[0] = radii[1] = p * hmd;
      return true;
    case Metric::BoundedSplitSphere:
      if (!std::isfinite(hmd)) return false;
      radii[0] = radii[1] = p * (g > 0 ? std::min(hmd, lum / g) : hmd);
      return true;
    case Metric::Gradient:
      radii[0] = radii[1] = g > 0 ? p * lum / g : INFINITY;
      return true;
    default: break;
  }
  const int which = m == Metric::HessianUnaware ? 1 : m == Metric::HessianGeometric ? 2 : 0;
  double h[9];
  for (int k = 0; k < 9; ++k)
    h[k] = 0.2126 * e.hessian[which][k] + 0.7152 * e.hessian[which][9 + k] + 0.0722 * e.hessian[which][18 + k];
  const double anisotropy = m == Metric::HessianIsotropic ? 1.0 : 2.0;
  if (std::isfinite(hmd) && hmd > 0) {
    check(raddiff_surface_radii_floored(h, to_c(normal), e.luminance(), p, RADDIFF_ERROR_RELATIVE, anisotropy, hmd,
                                        RADDIFF_CURVATURE_FLOOR_WEIGHT, radii, axes),
          "raddiff_surface_radii_floored");
  } else {
    check(raddiff_surface_radii(h, to_c(normal), lum, p, RADDIFF_ERROR_RELATIVE, anisotropy, radii, axes),
          "raddiff_surface_radii");
  }
  return true;
}

}  // namespace rd
