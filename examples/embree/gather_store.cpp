#include "gather_store.hpp"

#include "gather_noise.hpp"

#include <algorithm>
#include <fstream>
#include <string>

namespace rd {
namespace {

// The binned far-field experiment's record (Evaluated::far_bins): over the rays that reach at
// least `reach`, each bin's mean radiance minus the mean of them all, shrunk by n_b / (n_b + 16).
void bin_far_radiance(const TracedGather &g, double reach, float out[3 * kDirBins]) {
  double sum[kDirBins][3] = {}, count[kDirBins] = {}, all[3] = {}, n = 0;
  for (size_t k = 0; k < g.distance.size(); ++k) {
    if (g.distance[k] < reach) continue;
    const int b = direction_bin(from_c(g.directions[k]));
    for (int c = 0; c < 3; ++c) sum[b][c] += g.radiance[3 * k + c], all[c] += g.radiance[3 * k + c];
    ++count[b], ++n;
  }
  std::fill(out, out + 3 * kDirBins, 0.0f);
  if (n == 0) return;
  for (int b = 0; b < kDirBins; ++b)
    if (count[b] > 0)
      for (int c = 0; c < 3; ++c)
        out[3 * b + c] = static_cast<float>((sum[b][c] / count[b] - all[c] / n) * count[b] / (count[b] + 16));
}

// The near-field experiment's far-field gather (raddiff_gather_far_field_radiance): the radiance
// of the hits closer than `reach` replaced by the mean radiance of the directions that reach
// farther, so that the gather's irradiance, derivatives and radii are the far field's.
// With `near_at_reach` the near hits also move to the reach (raddiff_gather_far_field; their
// normals then face x), so that the far field's derivatives and radii do not see the near geometry.
double fill_near_with_far(TracedGather &g, double reach, bool near_at_reach) {
  double open = 0;
  if (!near_at_reach) {
    check(raddiff_gather_far_field_radiance(&g.layout, g.distance.data(), g.radiance.data(), 3, reach, &open),
          "raddiff_gather_far_field_radiance");
    return open;
  }
  for (size_t k = 0; k < g.distance.size(); ++k)
    if (g.distance[k] < reach) g.hit_normals[k] = {-g.directions[k].x, -g.directions[k].y, -g.directions[k].z};
  check(raddiff_gather_far_field(&g.layout, g.distance.data(), g.radiance.data(), 3, reach, &open),
        "raddiff_gather_far_field");
  return open;
}

// The near-field experiment's far field of an evaluated gather at `reach`: with far-field gathers
// (`open` from fill_near_with_far) its value; otherwise (E - E_near) / V of the gather itself
// (raddiff_gather_near_field), 0 where nothing is open.
void split_far_field(const TracedGather &g, double reach, double open, Evaluated &e, bool far_field_gather) {
  if (far_field_gather) {
    e.open_fraction = open;
    std::copy(std::begin(e.value), std::end(e.value), std::begin(e.far_value));
    return;
  }
  double near[3];
  check(raddiff_gather_near_field(&g.layout, g.distance.data(), g.radiance.data(), 3, reach, near, &e.open_fraction),
        "raddiff_gather_near_field");
  for (int c = 0; c < 3; ++c)
    e.far_value[c] =
        e.open_fraction > 0 ? static_cast<float>(std::max(0.0, (e.value[c] - near[c]) / e.open_fraction)) : 0.0f;
}

// The oracle experiment: the records' radii and derivatives from another evaluation of the same
// pixel (`other`, ignored when not valid), their values and CPU times from the usual one
// (`usual`): usual becomes other with usual's values and times.
void take_derivatives(Evaluated other, Evaluated &usual) {
  if (!other.valid) return;
  std::copy(std::begin(usual.value), std::end(usual.value), std::begin(other.value));
  other.luminance = usual.luminance;
  std::copy(std::begin(usual.seconds), std::end(usual.seconds), std::begin(other.seconds));
  usual = std::move(other);
}

}  // namespace

const Slot &GatherStore::get(size_t pixel) {
  Slot &s = slots_[pixel];
  std::call_once(s.once, [&] {
    const Primary &px = primary_[pixel];
    const double t0 = thread_cpu_seconds();
    const raddiff_irradiance_settings &irr = settings_.irradiance;
    TracedGather g = trace_gather(scene_, settings_.radiance, px.p, px.n, irr.gather_m, irr.gather_n,
                                  reseeded(1 + pixel, settings_.noise_seed));
    s.trace_seconds = thread_cpu_seconds() - t0;
    s.rays = g.rays;
    const double reach = settings_.near_field_px * px.footprint;
    if (!settings_.strata_dir.empty() && pixel % settings_.strata_every == 0) write_strata(pixel, g, reach);
    const bool far_field_gather = settings_.near_field_px > 0 && settings_.far_field_gathers;
    float far_bins[3 * kDirBins] = {};
    if (settings_.near_field_px > 0 && settings_.far_field_bins) bin_far_radiance(g, reach, far_bins);
    std::unique_ptr<TracedGather> retraced;
    if (settings_.retraced_shrinkage_noise) {
      // The same directions with independent hit-radiance samples: the shrinkage experiments'
      // noise amplitudes from a second trace instead of the azimuthal neighbours (not timed).
      retraced = std::make_unique<TracedGather>(g);
      uint64_t rays = 0;
      trace_directions(scene_, settings_.radiance, px.p, g.directions.data(), g.directions.size(),
                       reseeded(mix(1 + pixel) ^ 0x2ea7ull, settings_.noise_seed), retraced->distance.data(),
                       retraced->radiance.data(), rays, retraced->hit_normals.data());
      if (far_field_gather) fill_near_with_far(*retraced, reach, settings_.near_at_reach);
    }
    const double open = far_field_gather ? fill_near_with_far(g, reach, settings_.near_at_reach) : 1.0;
    s.evaluated = std::make_unique<Evaluated>(evaluate_gather(g, needs_, irr));
    if (settings_.oracle_derivative_paths > 0 && s.evaluated->valid) {
      // Derivatives from the same directions with radiance averaged over K independent paths:
      // what the records would be with less noisy derivatives (an experiment; not timed).
      HitRadianceSettings averaged = settings_.radiance;
      averaged.paths = settings_.oracle_derivative_paths;
      TracedGather q = trace_gather(scene_, averaged, px.p, px.n, irr.gather_m, irr.gather_n,
                                    reseeded(mix(1 + pixel) ^ 0x0facull, settings_.noise_seed));
      // the same far-field gather as the records' (their derivatives must not see the near hits)
      if (far_field_gather) fill_near_with_far(q, reach, settings_.near_at_reach);
      // the records' CPU times from the usual gather (the averaged one is not timed)
      take_derivatives(evaluate_gather(q, needs_, irr), *s.evaluated);
    }
    // after the oracle experiment, whose evaluation replaces the record's without the bins
    std::copy(std::begin(far_bins), std::end(far_bins), std::begin(s.evaluated->far_bins));
    if (settings_.near_field_px > 0) split_far_field(g, reach, open, *s.evaluated, far_field_gather);
    s.evaluated->relative_noise = relative_noise(g);
    if (settings_.noise_probes() && s.evaluated->valid) {
      const DerivativeNoise noise =
          derivative_noise(g, retraced.get(), settings_.gradient_shrinkage, settings_.hessian_shrinkage,
                           settings_.noise_curvature > 0, mix(pixel ^ 0x5471ull));
      s.evaluated->gradient_shrink = noise.gradient_shrink;
      s.evaluated->hessian_shrink = noise.hessian_shrink;
      s.evaluated->relative_gradient_noise = noise.relative_gradient_noise;
      s.evaluated->noise_curvature_weight = settings_.noise_curvature * noise.hessian_noise_weight;
    }
    ++computed_;
  });
  return s;
}

void GatherStore::ensure(const std::vector<size_t> &pixels) {
  if (pixels.size() == 1) {
    get(pixels[0]);
    return;
  }
  parallel_for(pixels.size(), settings_.threads, [&](size_t k) { get(pixels[k]); });
}

// The adaptive-gather experiment's file for the gather `g` of `pixel` (format in
// strata_allocation.py): m, n and the trace count as uint32, the near field's reach (0: none) as
// float64, then per stratum its luminance in each of strata_paths traces of independent hit
// radiance (float32, stratum-major), then per stratum its hit distance (float64).
void GatherStore::write_strata(size_t pixel, const TracedGather &g, double reach) const {
  const Primary &px = primary_[pixel];
  const raddiff_irradiance_settings &irr = settings_.irradiance;
  const size_t count = g.distance.size(), paths = settings_.strata_paths;
  std::vector<float> lum(count * paths);
  for (size_t k = 0; k < paths; ++k) {
    const TracedGather q = trace_gather(scene_, settings_.radiance, px.p, px.n, irr.gather_m, irr.gather_n,
                                        reseeded(1 + pixel, settings_.noise_seed + 0x57a7a0000ull + k));
    for (size_t i = 0; i < count; ++i) lum[i * paths + k] = static_cast<float>(luminance(&q.radiance[3 * i]));
  }
  const std::string name = settings_.strata_dir + "/p" + std::to_string(pixel) + ".strata";
  std::ofstream f(name, std::ios::binary);
  const uint32_t header[3] = {irr.gather_m, irr.gather_n, static_cast<uint32_t>(paths)};
  f.write(reinterpret_cast<const char *>(header), sizeof header);
  f.write(reinterpret_cast<const char *>(&reach), sizeof reach);
  f.write(reinterpret_cast<const char *>(lum.data()), static_cast<std::streamsize>(lum.size() * sizeof(float)));
  f.write(reinterpret_cast<const char *>(g.distance.data()),
          static_cast<std::streamsize>(count * sizeof(double)));
  if (!f) throw std::runtime_error("cannot write " + name);
}

}  // namespace rd
