#include "metrics.hpp"

namespace rd {
namespace {

// Which evaluation (see HessianNeeds) metric m's records come from.
int evaluation_of(Metric m) {
  switch (m) {
    case Metric::HessianIsotropic:
    case Metric::HessianAnisotropic: return 1;
    case Metric::HessianUnaware: return 2;
    case Metric::HessianGeometric: return 3;
    default: return 0;
  }
}

constexpr uint32_t kHessianBits[4] = {0, RADDIFF_HESSIAN_OCCLUSION_AWARE, RADDIFF_HESSIAN_UNAWARE,
                                      RADDIFF_HESSIAN_GEOMETRIC};

}  // namespace

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

uint32_t c_metric(Metric m) {
  switch (m) {
    case Metric::SplitSphere: return RADDIFF_METRIC_SPLIT_SPHERE;
    case Metric::BoundedSplitSphere: return RADDIFF_METRIC_BOUNDED_SPLIT_SPHERE;
    case Metric::Gradient: return RADDIFF_METRIC_GRADIENT;
    case Metric::HessianUnaware: return RADDIFF_METRIC_HESSIAN_UNAWARE;
    case Metric::HessianGeometric: return RADDIFF_METRIC_HESSIAN_GEOMETRIC;
    case Metric::HessianIsotropic: return RADDIFF_METRIC_HESSIAN_ISOTROPIC;
    case Metric::HessianAnisotropic: return RADDIFF_METRIC_HESSIAN_ANISOTROPIC;
  }
  return RADDIFF_METRIC_SPLIT_SPHERE;
}

bool uses_hessian(Metric m) { return evaluation_of(m) != 0; }
double radius_exponent(Metric m) { return uses_hessian(m) ? 0.25 : 1.0; }
double initial_parameter(Metric m) { return uses_hessian(m) ? 1e-3 : 0.2; }

HessianNeeds hessian_needs(const std::vector<Metric> &metrics) {
  HessianNeeds n;
  for (Metric m : metrics) n.kind[evaluation_of(m)] = true;
  return n;
}

Evaluated evaluate_gather(const TracedGather &g, const HessianNeeds &needs,
                          const raddiff_irradiance_settings &settings) {
  Evaluated e;
  raddiff_gather_input input{};
  input.directions = g.directions.data();
  input.distance = g.distance.data();
  input.radiance = g.radiance.data();
  input.channels = 3;
  for (int k = 0; k < 4; ++k) {
    if (!needs.kind[k]) continue;
    const double t0 = thread_cpu_seconds();
    raddiff_gather_evaluation *ev = raddiff_gather_evaluation_new(&settings, &g.layout, &g.frame, &input,
                                                                   g.hit_normals.data(), kHessianBits[k]);
    e.seconds[k] = thread_cpu_seconds() - t0;
    if (!ev) {
      // Every ray missed (or every hit was behind): raddiff finds nothing to build a record from.
      if (std::string(raddiff_last_error()).find("degenerate") != std::string::npos ||
          std::all_of(g.distance.begin(), g.distance.end(), [](double d) { return !std::isfinite(d); }))
        return Evaluated{};
      throw std::runtime_error(std::string("raddiff_gather_evaluation_new: ") + raddiff_last_error());
    }
    e.evaluation[k].reset(ev);
  }
  raddiff_gather_summary summary{};
  const int first = needs.kind[0] ? 0 : needs.kind[1] ? 1 : needs.kind[2] ? 2 : 3;
  check(raddiff_gather_evaluation_summary(e.evaluation[first].get(), &summary), "raddiff_gather_evaluation_summary");
  e.luminance = summary.scalar;
  e.harmonic_mean_distance = summary.harmonic_mean_distance;
  // The irradiance itself, as the records store it: from any record of this evaluation.
  raddiff_irradiance_settings any = settings;
  any.metric = RADDIFF_METRIC_SPLIT_SPHERE;
  any.world_radius_max = 1.0;  // any finite bound: only the record's value is read
  raddiff_cache_record r{};
  if (std::isfinite(summary.harmonic_mean_distance)) {
    check(raddiff_irradiance_record(&any, e.evaluation[first].get(), 0.0, &r), "raddiff_irradiance_record");
    std::copy(r.value, r.value + 3, e.value);
  } else {
    // Every ray missed: the irradiance is the environment's, which this renderer leaves black.
    std::fill(e.value, e.value + 3, 0.0f);
  }
  e.valid = true;
  return e;
}

double raddiff_seconds(Metric m, const Evaluated &e) { return e.seconds[evaluation_of(m)]; }

bool metric_record(Metric m, double p, const Evaluated &e, raddiff_irradiance_settings settings, double footprint,
                   raddiff_cache_record &record) {
  settings.metric = c_metric(m);
  settings.accuracy = p;
  if (uses_hessian(m)) settings.curvature_floor += e.noise_curvature_weight;
  if (uses_hessian(m) && e.hessian_shrink != 1) {
    settings.accuracy /= e.hessian_shrink;
    settings.curvature_floor /= e.hessian_shrink;
  }
  const raddiff_status st = raddiff_irradiance_record(&settings, e.evaluation[evaluation_of(m)].get(), footprint,
                                                      &record);
  if (st == RADDIFF_ERROR_DEGENERATE) return false;
  check(st, "raddiff_irradiance_record");
  record.value = e.value;
  return true;
}

}  // namespace rd
