#include "fill.hpp"

#include "fill_experiments.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

namespace rd {
namespace {

// The error-norm experiment: rec's radii (an occlusion-aware Hessian metric's) replaced by those
// minimizing the image's L^p error at equal records (see BenchSettings::error_norm). The
// library's radii a ~ (tau/|lambda|)^(1/4) (its anisotropy and curvature floor) are raised to the
// power 4q, q = p/(2p + 2), in scene units, and scaled by the footprint^(1/(p+1)) (pixels are
// uniform on the image, not on surfaces); then the pixel bounds and the anisotropy limit are
// applied again.
void norm_radii(const BenchSettings &settings, Metric m, double p, const Evaluated &e,
                const raddiff_irradiance_settings &irr, double footprint, raddiff_cache_record &rec) {
  raddiff_gather_summary summary{};
  check(raddiff_gather_evaluation_summary(e.evaluation[1].get(), &summary), "raddiff_gather_evaluation_summary");
  const raddiff_vec3 n = to_c(normalize(from_c(rec.normal)));
  const double anisotropy = m == Metric::HessianIsotropic ? 1.0 : irr.max_anisotropy;
  const double distance = std::isfinite(e.harmonic_mean_distance) ? e.harmonic_mean_distance : 1e30;
  double radii[2];
  raddiff_vec3 axes[2];
  check(raddiff_surface_radii_floored(summary.occlusion_hessian, n, e.luminance, p,
                                      settings.absolute_error ? RADDIFF_ERROR_ABSOLUTE : RADDIFF_ERROR_RELATIVE,
                                      anisotropy, distance, irr.curvature_floor, radii, axes),
        "raddiff_surface_radii_floored");
  const double norm = settings.error_norm;
  const double q = norm / (2 * norm + 2);
  const double lo = irr.pixel_radius_min * footprint, hi = irr.pixel_radius_max * footprint;
  for (int k = 0; k < 2; ++k) {
    const double r = std::pow(std::min(radii[k], 1e6), 4 * q) * std::pow(footprint, 1 / (norm + 1));
    rec.radii[k] = std::clamp(r, lo, hi);
    rec.axes[k] = axes[k];
  }
  rec.radii[1] = std::min(rec.radii[1], anisotropy * rec.radii[0]);
  rec.radii[0] = std::min(rec.radii[0], rec.radii[1]);
  rec.radii[2] = rec.radii[0];
}

// Storage for a record's far-field gradients (three channels), which the record points into.
struct FarGradients {
  float gradient[9], rotation_gradient[9];
};

// One fill (see fill_bench_cache): its caches, the experiments' side caches, and what it measured.
class CacheFill {
 public:
  CacheFill(const FillInputs &in, Metric m, double p, bool render);
  BenchFill run();

 private:
  void check_combinations() const;
  CachePtr with_cache_state(CachePtr c) const;
  CachePtr new_cache() const;
  int band_of(double open) const;
  int pixel_band(size_t pixel) const { return band_of(pixel_near_ ? (*pixel_near_)[pixel][3] : 0.0); }
  raddiff_cache *cache_of(size_t pixel) const { return caches_[pixel_band(pixel)].get(); }
  raddiff_status lookup_pixel(raddiff_cache *c, size_t pixel, float *value) const;
  bool covered(size_t pixel) const;
  void make_side_caches();
  void place_records();
  void place_level(const std::vector<size_t> &level);
  void add_record(size_t pixel);
  void adjust_record(size_t pixel, const Evaluated &e, raddiff_cache_record &rec, FarGradients &far) const;
  void insert_record(size_t pixel, const Evaluated &e, const raddiff_cache_record &rec);
  void smooth_records();
  void make_adaptive_lookup();
  void render_image();

  const FillInputs &in_;
  const BenchSettings &settings_;
  const std::vector<Primary> &primary_;
  Metric m_;
  double p_;
  bool render_;
  raddiff_irradiance_settings irr_;
  // With --open-fraction-tolerance, the library's open-fraction test in every cache of the records.
  bool open_test_;
  // With --open-fraction-bands, one cache per band of open fraction (a record goes into its own
  // band's and the two neighbouring bands' caches; a pixel looks only into its own band's).
  bool banded_;
  int bands_;
  const std::vector<std::array<float, 4>> *pixel_near_ = nullptr;  // with bands or the test
  bool smooth_, adaptive_, clamp_;
  // The kernel of the experiments' side caches: the one the settings force, or the metric's own.
  int kernel_;
  std::vector<CachePtr> caches_;  // one per band
  // The second-order experiment's cache of the records' quadratic terms (same extents, same kernel).
  CachePtr quadratic_{nullptr, raddiff_cache_free};
  // The binned far-field experiment's caches of the records' bins (same extents, same kernel, no
  // gradients; one per band of open fraction, as the records').
  std::vector<CachePtr> binned_caches_;
  // The inserted records, kept for the smoothing and adaptive-lookup experiments (their values
  // and open fractions point into the store's evaluations, which outlive the fill), in the order
  // of out_.records.
  std::vector<KeptRecord> kept_;
  std::unique_ptr<AdaptiveLookup> adaptive_lookup_;
  CpuSum cache_cpu_;
  BenchFill out_;
};

CacheFill::CacheFill(const FillInputs &in, Metric m, double p, bool render)
    : in_(in),
      settings_(in.settings),
      primary_(in.primary),
      m_(m),
      p_(p),
      render_(render),
      irr_(in.settings.irradiance),
      open_test_(std::isfinite(in.settings.open_fraction_tolerance) && in.settings.near_field_px > 0),
      banded_(in.settings.open_fraction_bands > 0 && in.settings.near_field_px > 0),
      bands_(banded_ ? static_cast<int>(std::ceil(1.0 / in.settings.open_fraction_bands)) + 1 : 1),
      smooth_(render && in.settings.smooth_records > 0),
      adaptive_(render && in.settings.adaptive_lookup > 0),
      clamp_(in.settings.neighbour_clamp),
      kernel_(in.settings.interpolation >= 0 ? in.settings.interpolation
              : uses_hessian(m)              ? RADDIFF_INTERP_TENT
                                             : RADDIFF_INTERP_WARD) {
  out_.metric = m;
  out_.parameter = p;
  irr_.metric = c_metric(m);
  irr_.accuracy = p;
  check_combinations();
  if (banded_ || open_test_) pixel_near_ = &in_.near_fields().near;
  for (int b = 0; b < bands_; ++b) caches_.push_back(new_cache());
  make_side_caches();
}

void CacheFill::check_combinations() const {
  const BenchSettings &s = settings_;
  if ((banded_ || open_test_) && (s.neighbour_clamp || s.smooth_records > 0 || s.second_order > 0))
    throw std::runtime_error("--open-fraction-bands and --open-fraction-tolerance do not combine with "
                             "--neighbour-clamp, --smooth-records or --second-order");
  if (adaptive_ && (banded_ || s.neighbour_clamp || smooth_ || s.second_order > 0 || s.far_field_bins))
    throw std::runtime_error("--adaptive-lookup does not combine with --open-fraction-bands, --neighbour-clamp, "
                             "--smooth-records, --second-order or --far-field-bins");
  if (clamp_ && (s.smooth_records > 0 || s.second_order > 0))
    throw std::runtime_error("--neighbour-clamp does not combine with --smooth-records or --second-order");
}

// The settings' leak guard (which raddiff_irradiance_cache_new sets and the experiments' caches
// made with surface_cache would otherwise lack); with the test, the cache's open-fraction
// tolerance and coverage tolerance; with --lookup-scale, records read over their radii times it.
CachePtr CacheFill::with_cache_state(CachePtr c) const {
  check(raddiff_cache_set_leak_guard(c.get(), irr_.leak_guard_relative, irr_.leak_guard_absolute),
        "raddiff_cache_set_leak_guard");
  if (open_test_) {
    check(raddiff_cache_set_open_fraction_tolerance(c.get(), settings_.open_fraction_tolerance),
          "raddiff_cache_set_open_fraction_tolerance");
    check(raddiff_cache_set_open_fraction_coverage_tolerance(c.get(), settings_.open_fraction_coverage_tolerance),
          "raddiff_cache_set_open_fraction_coverage_tolerance");
  }
  check(raddiff_cache_set_lookup_radius_scale(c.get(), settings_.lookup_scale),
        "raddiff_cache_set_lookup_radius_scale");
  return c;
}

// The cache this metric wants: Ward or tent weights, extrapolation clamped at zero, the gradient
// limit and the leak guard of the settings (or the interpolation the settings force).
CachePtr CacheFill::new_cache() const {
  if (settings_.interpolation >= 0)
    return with_cache_state(surface_cache(settings_.interpolation, irr_.gradient_limit));
  CachePtr c(raddiff_irradiance_cache_new(&irr_), raddiff_cache_free);
  if (!c) throw std::runtime_error(std::string("raddiff_irradiance_cache_new: ") + raddiff_last_error());
  return with_cache_state(std::move(c));
}

int CacheFill::band_of(double open) const {
  return banded_ ? std::clamp(static_cast<int>(open / settings_.open_fraction_bands), 0, bands_ - 1) : 0;
}

// A pixel's lookup: with the open-fraction test, with its near field's open fraction.
raddiff_status CacheFill::lookup_pixel(raddiff_cache *c, size_t pixel, float *value) const {
  const raddiff_vec3 p = to_c(primary_[pixel].p), n = to_c(primary_[pixel].n);
  return open_test_ ? raddiff_cache_lookup_open(c, nullptr, p, n, (*pixel_near_)[pixel][3], value, nullptr)
                    : raddiff_cache_lookup(c, p, n, value, nullptr);
}

bool CacheFill::covered(size_t pixel) const {
  float v[3];
  const raddiff_status st = lookup_pixel(cache_of(pixel), pixel, v);
  if (st != RADDIFF_OK && st != RADDIFF_ERROR_NOT_FOUND) check(st, "raddiff_cache_lookup");
  return st == RADDIFF_OK;
}

void CacheFill::make_side_caches() {
  if (render_ && settings_.second_order > 0) {
    quadratic_ = with_cache_state(surface_cache(kernel_, irr_.gradient_limit, kQuadraticChannels, false));
  }
  if (render_ && settings_.far_field_bins)
    for (int b = 0; b < bands_; ++b)
      binned_caches_.push_back(with_cache_state(surface_cache(kernel_, irr_.gradient_limit, 3 * kDirBins, false)));
}

BenchFill CacheFill::run() {
  place_records();
  if (smooth_) smooth_records();
  if (adaptive_) make_adaptive_lookup();
  if (render_) render_image();
  out_.cache_seconds = cache_cpu_.total();
  return std::move(out_);
}

// Coarse to fine over the image. With neighbour clamping, the two-sided pass runs after each
// level; it can uncover pixels, so the finest level is repeated over every pixel until a round
// inserts nothing, the last allowed round filling only (as the render mode does).
void CacheFill::place_records() {
  constexpr int kClampRounds = 3;
  int finest_rounds = 0;
  for (int step = 16;;) {
    std::vector<size_t> level;
    if (finest_rounds == 0) {
      for (size_t i : level_pixels(in_.width, in_.height, step))
        if (primary_[i].hit) level.push_back(i);
    } else {
      for (size_t i = 0; i < primary_.size(); ++i)
        if (primary_[i].hit) level.push_back(i);
    }
    const size_t records_before = out_.records.size();
    place_level(level);
    const bool last_round = step == 1 && finest_rounds == kClampRounds;
    if (clamp_ && !last_round) {
      const double t0 = thread_cpu_seconds();
      size_t shrunk = 0;
      check(raddiff_cache_clamp_neighbours(caches_[0].get(), &shrunk), "raddiff_cache_clamp_neighbours");
      cache_cpu_.add(thread_cpu_seconds() - t0);
    }
    if (step > 1) {
      step /= 2;
      continue;
    }
    ++finest_rounds;
    if (!clamp_ || out_.records.size() == records_before || last_round) break;
  }
}

// The level's pixels the cache misses when it starts, in pixel order, a batch of gathers at a time.
void CacheFill::place_level(const std::vector<size_t> &level) {
  std::vector<char> missed(level.size(), 0);
  parallel_for((level.size() + 255) / 256, settings_.threads, [&](size_t chunk) {
    const double t0 = thread_cpu_seconds();
    for (size_t k = chunk * 256; k < std::min(level.size(), (chunk + 1) * 256); ++k) missed[k] = !covered(level[k]);
    cache_cpu_.add(thread_cpu_seconds() - t0);
  });
  std::vector<size_t> candidates;
  for (size_t k = 0; k < level.size(); ++k)
    if (missed[k]) candidates.push_back(level[k]);
  const size_t batch = 4 * std::max(1u, settings_.threads);
  for (size_t b = 0; b < candidates.size(); b += batch) {
    const double t0 = thread_cpu_seconds();
    std::vector<size_t> still;
    for (size_t k = b; k < std::min(candidates.size(), b + batch); ++k)
      if (!covered(candidates[k])) still.push_back(candidates[k]);
    cache_cpu_.add(thread_cpu_seconds() - t0);
    in_.store.ensure(still);
    for (size_t i : still) add_record(i);
  }
}

// A candidate still missed after the records inserted before it: its gather's record, when the
// metric is defined there.
void CacheFill::add_record(size_t pixel) {
  double t0 = thread_cpu_seconds();
  const bool skip = covered(pixel);
  cache_cpu_.add(thread_cpu_seconds() - t0);
  if (skip) return;
  const Slot &slot = in_.store.get(pixel);
  const Evaluated &e = *slot.evaluated;
  out_.trace_seconds += slot.trace_seconds;  // a miss traces the gather: its cost counts
  out_.raddiff_seconds += raddiff_seconds(m_, e);
  if (!e.valid) return;
  t0 = thread_cpu_seconds();
  raddiff_cache_record rec{};
  const bool defined = metric_record(m_, p_, e, irr_, primary_[pixel].footprint, rec);
  out_.raddiff_seconds += thread_cpu_seconds() - t0;
  if (!defined) return;
  FarGradients far;
  adjust_record(pixel, e, rec, far);
  insert_record(pixel, e, rec);
}

// What the settings change in a metric's record: no gradients, the open fraction for the test, the
// far field's value and gradients under the near field, and the radius experiments.
void CacheFill::adjust_record(size_t pixel, const Evaluated &e, raddiff_cache_record &rec, FarGradients &far) const {
  if (!settings_.record_gradients) rec.gradient = rec.rotation_gradient = nullptr;
  if (open_test_) rec.open_fraction = &e.open_fraction;
  if (settings_.near_field_px > 0 || e.gradient_shrink != 1) {
    // The far field's record: its value, and the gather's gradients in the same ratio (the
    // translational ones shrunk by the gradient-shrinkage experiment's factor).
    if (settings_.near_field_px > 0) rec.value = e.far_value;
    for (int c = 0; c < 3; ++c) {
      const double ratio =
          settings_.near_field_px <= 0 ? 1.0 : e.value[c] > 0 ? e.far_value[c] / e.value[c] : 0.0;
      for (int k = 0; k < 3; ++k) {
        if (rec.gradient)
          far.gradient[3 * c + k] = static_cast<float>(rec.gradient[3 * c + k] * ratio * e.gradient_shrink);
        if (rec.rotation_gradient)
          far.rotation_gradient[3 * c + k] = static_cast<float>(rec.rotation_gradient[3 * c + k] * ratio);
      }
    }
    if (rec.gradient) rec.gradient = far.gradient;
    if (rec.rotation_gradient) rec.rotation_gradient = far.rotation_gradient;
  }
  if (settings_.hessian_distance_bound > 0 && uses_hessian(m_)) {
    const double bound = std::max(settings_.hessian_distance_bound * e.harmonic_mean_distance,
                                  irr_.pixel_radius_min * primary_[pixel].footprint);
    for (double &r : rec.radii) r = std::min(r, bound);
  }
  if (settings_.gradient_noise_radius > 0 && uses_hessian(m_) && e.relative_gradient_noise > 0) {
    // where the gradient's noise, extrapolated, alone reaches z p of the value
    const double bound = std::max(settings_.gradient_noise_radius * p_ / e.relative_gradient_noise,
                                  irr_.pixel_radius_min * primary_[pixel].footprint);
    for (double &r : rec.radii) r = std::min(r, bound);
  }
  if (settings_.error_norm > 0 && (m_ == Metric::HessianAnisotropic || m_ == Metric::HessianIsotropic))
    norm_radii(settings_, m_, p_, e, irr_, primary_[pixel].footprint, rec);
}

// Into the caches of its band and the two neighbouring ones, and every side cache.
void CacheFill::insert_record(size_t pixel, const Evaluated &e, const raddiff_cache_record &rec) {
  const double t0 = thread_cpu_seconds();
  const int band = band_of(e.open_fraction);
  const int first_band = std::max(0, band - 1), last_band = std::min(bands_ - 1, band + 1);
  for (int b = first_band; b <= last_band; ++b)
    check(raddiff_cache_insert(caches_[b].get(), &rec), "raddiff_cache_insert");
  cache_cpu_.add(thread_cpu_seconds() - t0);
  if (!binned_caches_.empty()) {
    raddiff_cache_record br = rec;
    br.value = e.far_bins;
    br.gradient = br.rotation_gradient = nullptr;
    for (int b = first_band; b <= last_band; ++b)
      check(raddiff_cache_insert(binned_caches_[b].get(), &br), "raddiff_cache_insert");
  }
  out_.records.push_back(RecordInfo{pixel,
                                    primary_[pixel].p,
                                    primary_[pixel].n,
                                    {rec.radii[0], rec.radii[1]},
                                    {rec.axes[0], rec.axes[1]},
                                    luminance(rec.value),
                                    e.open_fraction,
                                    e.relative_noise,
                                    e.gradient_shrink,
                                    e.hessian_shrink,
                                    e.noise_curvature_weight,
                                    e.relative_gradient_noise});
  if (smooth_ || adaptive_) kept_.emplace_back(rec);
  if (quadratic_) {
    if (!e.evaluation[1]) throw std::runtime_error("--second-order needs an occlusion-aware Hessian metric");
    raddiff_gather_summary summary{};
    check(raddiff_gather_evaluation_summary(e.evaluation[1].get(), &summary), "raddiff_gather_evaluation_summary");
    const std::array<float, kQuadraticChannels> q =
        quadratic_channels(from_c(rec.position), normalize(from_c(rec.normal)), summary.occlusion_hessian);
    raddiff_cache_record qr = rec;
    qr.value = q.data();
    qr.gradient = qr.rotation_gradient = nullptr;
    check(raddiff_cache_insert(quadratic_.get(), &qr), "raddiff_cache_insert");
  }
}

// The smoothing experiment (not timed): every record's value replaced by the tent-weighted blend
// of the records covering its position (its own included, radii times smooth_records), each
// extrapolated through its gradient; the cache rebuilt from the same records.
void CacheFill::smooth_records() {
  CachePtr blend = surface_cache(RADDIFF_INTERP_TENT, irr_.gradient_limit);
  insert_scaled(blend.get(), kept_, settings_.smooth_records);
  check(raddiff_cache_compact(blend.get()), "raddiff_cache_compact");
  caches_[0] = new_cache();
  for (const KeptRecord &k : kept_) {
    raddiff_cache_record rec = k.get();
    float smoothed[3];
    const raddiff_status st = raddiff_cache_lookup(blend.get(), rec.position, rec.normal, smoothed, nullptr);
    if (st != RADDIFF_ERROR_NOT_FOUND) check(st, "raddiff_cache_lookup");
    if (st == RADDIFF_OK) rec.value = smoothed;
    check(raddiff_cache_insert(caches_[0].get(), &rec), "raddiff_cache_insert");
  }
}

// The adaptive-lookup experiment's caches (not timed), with the records' state.
void CacheFill::make_adaptive_lookup() {
  CachePtr noise_cache = with_cache_state(surface_cache(kernel_, irr_.gradient_limit, 1, false));
  std::vector<float> noise;
  for (const RecordInfo &r : out_.records) noise.push_back(static_cast<float>(r.relative_noise));
  adaptive_lookup_ = std::make_unique<AdaptiveLookup>(kept_, noise, settings_.adaptive_lookup,
                                                      settings_.adaptive_lookup_max, settings_.adaptive_lookup_exponent,
                                                      [this] { return new_cache(); },
                                                      std::move(noise_cache));
}

// Every pixel's irradiance from the caches: the near field's plus the open fraction times the
// interpolated far field (binned, second-order or adaptive as the experiments say).
void CacheFill::render_image() {
  const NearFields &fields = in_.near_fields();
  const std::vector<std::array<float, 4>> &near = fields.near;
  out_.trace_seconds += fields.seconds;
  const int w = in_.width, h = in_.height;
  out_.image = Image(w, h);
  for (CachePtr &c : caches_) check(raddiff_cache_compact(c.get()), "raddiff_cache_compact");
  std::atomic<size_t> uncovered{0};
  parallel_for(static_cast<size_t>(h), settings_.threads, [&](size_t row) {
    const double t0 = thread_cpu_seconds();
    for (int x = 0; x < w; ++x) {
      const size_t i = row * w + x;
      if (!primary_[i].hit) continue;
      float *v = out_.image.at(i);
      const auto lookup_here = [&](raddiff_cache *cache, float *value) { return lookup_pixel(cache, i, value); };
      raddiff_cache *c = adaptive_lookup_ ? adaptive_lookup_->cache_for(lookup_here) : cache_of(i);
      const raddiff_status st = lookup_pixel(c, i, v);
      if (st == RADDIFF_ERROR_NOT_FOUND) {
        ++uncovered;
      } else {
        check(st, "raddiff_cache_lookup");
      }
      float b[kQuadraticChannels];
      if (st == RADDIFF_OK && quadratic_ &&
          raddiff_cache_lookup(quadratic_.get(), to_c(primary_[i].p), to_c(primary_[i].n), b, nullptr) == RADDIFF_OK) {
        // the scalar's term shared by the channels in proportion to the interpolated value
        const double lum = luminance(v);
        const double scale = lum > 0 ? 1 + settings_.second_order * quadratic_term(primary_[i].p, b) / lum : 1;
        for (int k = 0; k < 3; ++k) v[k] = static_cast<float>(std::max(0.0, v[k] * scale));
      }
      float q[3 * kDirBins];
      const bool bins = st == RADDIFF_OK && !binned_caches_.empty() &&
                        lookup_pixel(binned_caches_[pixel_band(i)].get(), i, q) == RADDIFF_OK;
      if (st == RADDIFF_OK && !near.empty())
        for (int k = 0; k < 3; ++k) {
          const double far = bins ? binned_far(v[k], fields.bins[i], q, k) : v[k];
          v[k] = static_cast<float>(far * near[i][3] + near[i][k]);
        }
    }
    cache_cpu_.add(thread_cpu_seconds() - t0);
  });
  out_.uncovered = uncovered;
  if (adaptive_lookup_)
    std::printf("adaptive lookup: records' median relative noise %.4g, pixels' mean scale %.3f\n",
                adaptive_lookup_->median(), adaptive_lookup_->mean_scale());
  for (float v : out_.image.rgb) {
    out_.non_finite += !std::isfinite(v);
    out_.negative += v < 0;
  }
}

}  // namespace

BenchFill fill_bench_cache(const FillInputs &in, Metric m, double p, bool render) {
  return CacheFill(in, m, p, render).run();
}

}  // namespace rd
