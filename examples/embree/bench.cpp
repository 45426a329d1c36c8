#include "bench.hpp"

#include "gather_store.hpp"
#include "image.hpp"
#include "pathtrace.hpp"

#include <sys/resource.h>

#include <array>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>

namespace rd {
namespace {

// The binned far-field experiment's far field for channel c: F plus pi times the records' bin
// departures `bins` weighted by the pixel's open rays' bins, at least 0.
double binned_far(double far, const std::array<float, kDirBins> &open_bins, const float *bins, int c) {
  double d = 0;
  for (int b = 0; b < kDirBins; ++b) d += open_bins[b] * bins[3 * b + c];
  return std::max(0.0, far + kPi * d);
}

// A record kept after its insertion (the smoothing experiment), with copies of its gradients
// (three channels, as every record of the bench): the far field's are computed in the fill's
// locals.
class KeptRecord {
 public:
  explicit KeptRecord(const raddiff_cache_record &rec) : rec_(rec) {
    if (rec.gradient) std::copy(rec.gradient, rec.gradient + 9, gradient_.begin());
    if (rec.rotation_gradient) std::copy(rec.rotation_gradient, rec.rotation_gradient + 9, rotation_gradient_.begin());
  }
  // The record, its gradients pointing into this object (valid while it lives and does not move).
  raddiff_cache_record get() const {
    raddiff_cache_record r = rec_;
    if (r.gradient) r.gradient = gradient_.data();
    if (r.rotation_gradient) r.rotation_gradient = rotation_gradient_.data();
    return r;
  }

 private:
  raddiff_cache_record rec_;
  std::array<float, 9> gradient_{}, rotation_gradient_{};
};

// Inserts the `kept` records into `cache` with their radii times `scale`.
void insert_scaled(raddiff_cache *cache, const std::vector<KeptRecord> &kept, double scale) {
  for (const KeptRecord &k : kept) {
    raddiff_cache_record rec = k.get();
    for (double &x : rec.radii) x *= scale;
    check(raddiff_cache_insert(cache, &rec), "raddiff_cache_insert");
  }
}


// CPU seconds summed over threads.
class CpuSum {
 public:
  void add(double s) {
    std::lock_guard<std::mutex> g(lock_);
    total_ += s;
  }
  double total() const { return total_; }

 private:
  std::mutex lock_;
  double total_ = 0;
};

using CachePtr = std::unique_ptr<raddiff_cache, void (*)(raddiff_cache *)>;

// A surface cache of `channels` channels with `interpolation` (RADDIFF_INTERP_*), clamped at zero
// when `non_negative`, with gradient limit c.
CachePtr surface_cache(int interpolation, double c, uint32_t channels = 3, bool non_negative = true) {
  const raddiff_cache_config config{
      channels, RADDIFF_DOMAIN_SURFACE,
      static_cast<uint32_t>(interpolation) | (non_negative ? RADDIFF_INTERP_NON_NEGATIVE : 0u), 0.2};
  CachePtr cache(raddiff_cache_new(&config), raddiff_cache_free);
  if (!cache) throw std::runtime_error(std::string("raddiff_cache_new: ") + raddiff_last_error());
  check(raddiff_cache_set_gradient_limit(cache.get(), c), "raddiff_cache_set_gradient_limit");
  return cache;
}

// The second-order experiment (--second-order): the blend of the covering records' terms
// q_i(x) = 1/2 (x - x_i)^T H_i (x - x_i) is linear in the records' constants H_i, H_i x_i and
// 1/2 x_i^T H_i x_i, so a cache of those ten channels (no gradients; the main cache's kernel, hence
// its weights) blends them, and q(x) = 1/2 x^T <H> x - <H x_i> . x + <1/2 x_i^T H x_i>.
constexpr uint32_t kQuadraticChannels = 10;

// The ten channels of a record at `p` (unit normal `n`) whose scalar has Hessian `h` (row-major),
// projected on the tangent plane (the Hessian's normal rows carry robustness terms, not curvature).
std::array<float, kQuadraticChannels> quadratic_channels(const V3 &p, const V3 &n, const double h[9]) {
  // P H P with P = I - n n^T: H - n (n^T H) - (H n) n^T + (n^T H n) n n^T
  const double nv[3] = {n.x, n.y, n.z}, x[3] = {p.x, p.y, p.z};
  double hn[3], nh[3], ht[9], hx[3];
  for (int i = 0; i < 3; ++i) {
    hn[i] = h[3 * i] * nv[0] + h[3 * i + 1] * nv[1] + h[3 * i + 2] * nv[2];
    nh[i] = nv[0] * h[i] + nv[1] * h[3 + i] + nv[2] * h[6 + i];
  }
  const double nhn = nv[0] * hn[0] + nv[1] * hn[1] + nv[2] * hn[2];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      ht[3 * i + j] = h[3 * i + j] - nv[i] * nh[j] - hn[i] * nv[j] + nhn * nv[i] * nv[j];
  for (int i = 0; i < 3; ++i) hx[i] = ht[3 * i] * x[0] + ht[3 * i + 1] * x[1] + ht[3 * i + 2] * x[2];
  const double c = 0.5 * (x[0] * hx[0] + x[1] * hx[1] + x[2] * hx[2]);
  return {static_cast<float>(ht[0]), static_cast<float>(ht[4]), static_cast<float>(ht[8]),
          static_cast<float>(0.5 * (ht[1] + ht[3])), static_cast<float>(0.5 * (ht[2] + ht[6])),
          static_cast<float>(0.5 * (ht[5] + ht[7])), static_cast<float>(hx[0]), static_cast<float>(hx[1]),
          static_cast<float>(hx[2]), static_cast<float>(c)};
}

// q(x) from the blended channels `b` of kQuadraticChannels.
double quadratic_term(const V3 &p, const float *b) {
  const double x = p.x, y = p.y, z = p.z;
  const double xhx = b[0] * x * x + b[1] * y * y + b[2] * z * z + 2 * (b[3] * x * y + b[4] * x * z + b[5] * y * z);
  return 0.5 * xhx - (b[6] * x + b[7] * y + b[8] * z) + b[9];
}

struct RecordInfo {
  size_t pixel;
  V3 p, n;
  double radii[2];
  raddiff_vec3 axes[2];
  double value;          // the luminance the cache interpolates (the far field under --near-field)
  double open_fraction;  // its gather's open fraction (1 without --near-field)
};

struct Fill {
  Metric metric;
  double parameter = 0;
  std::vector<RecordInfo> records;
  double trace_seconds = 0, raddiff_seconds = 0, cache_seconds = 0;
  Image image;
  size_t uncovered = 0, non_finite = 0, negative = 0;
  double total_seconds() const { return trace_seconds + raddiff_seconds + cache_seconds; }
};

// Pixel indices of one coarse-to-fine level: the grid of step `step` without the coarser grid's
// pixels (the coarsest level, 16, takes its whole grid).
std::vector<size_t> level_pixels(int w, int h, int step) {
  std::vector<size_t> level;
  for (int y = 0; y < h; y += step)
    for (int x = 0; x < w; x += step)
      if (step == 16 || x % (2 * step) != 0 || y % (2 * step) != 0) level.push_back(static_cast<size_t>(y) * w + x);
  return level;
}

class Bench {
 public:
  Bench(const Scene &scene, const View &view, const BenchSettings &settings)
      : scene_(scene),
        view_(view),
        settings_(settings),
        camera_(view),
        primary_(primary_hits(scene, camera_, settings.threads)),
        store_(scene, primary_, settings_, hessian_needs(settings.metrics)) {}

  const std::vector<Primary> &primary() const { return primary_; }
  const Camera &camera() const { return camera_; }
  GatherStore &store() { return store_; }

  // The binned far-field experiment's per-pixel open_bins (empty without it), filled with near_field().
  const std::vector<std::array<float, kDirBins>> &near_bins() {
    near_field();
    return near_bins_;
  }

  // The near-field experiment: every pixel's near irradiance (RGB) and open fraction, traced once
  // and shared by every fill, and what that cost in CPU seconds.
  const std::vector<std::array<float, 4>> &near_field() {
    if (!near_.empty() || settings_.near_field_px <= 0) return near_;
    near_.assign(primary_.size(), {0, 0, 0, 1});
    if (settings_.far_field_bins) near_bins_.assign(primary_.size(), {});
    CpuSum cpu;
    const size_t w = static_cast<size_t>(view_.width);
    parallel_for(static_cast<size_t>(view_.height), settings_.threads, [&](size_t row) {
      const double t0 = thread_cpu_seconds();
      for (size_t i = row * w; i < (row + 1) * w; ++i) {
        const Primary &px = primary_[i];
        if (!px.hit) continue;
        uint64_t rays = 0;
        const NearField f = trace_near_field(scene_, settings_.radiance, px.p, px.n,
                                             settings_.near_field_px * px.footprint, settings_.near_field_m,
                                             reseeded(mix(i) ^ 0x6e656172ull, settings_.noise_seed), rays);
        near_[i] = {static_cast<float>(f.near[0]), static_cast<float>(f.near[1]), static_cast<float>(f.near[2]),
                    static_cast<float>(f.open_fraction)};
        if (settings_.far_field_bins)
          std::copy(std::begin(f.open_bins), std::end(f.open_bins), near_bins_[i].begin());
      }
      cpu.add(thread_cpu_seconds() - t0);
    });
    near_seconds_ = cpu.total();
    std::printf("near field: %u x %u rays of %.3g pixels' reach per pixel, %.2f CPU s\n", settings_.near_field_m,
                settings_.near_field_m, settings_.near_field_px, near_seconds_);
    std::fflush(stdout);
    return near_;
  }

  // Fills a fresh cache for metric m with parameter p, coarse to fine over the image. Which pixels
  // get records does not depend on the thread count: a level's candidates are the pixels the cache
  // misses when the level starts, taken in pixel order; gathers are computed in parallel, a batch at
  // a time, and inserted one by one after a second lookup.
  Fill fill(Metric m, double p, bool render) {
    Fill out;
    out.metric = m;
    out.parameter = p;
    raddiff_irradiance_settings irr = settings_.irradiance;
    irr.metric = c_metric(m);
    irr.accuracy = p;
    // With --open-fraction-tolerance, the library's open-fraction test in every cache of the records;
    // with --lookup-scale, every such cache read over the records' radii times it.
    const bool open_test = std::isfinite(settings_.open_fraction_tolerance) && settings_.near_field_px > 0;
    auto with_cache_state = [&](CachePtr c) {
      if (open_test)
        check(raddiff_cache_set_open_fraction_tolerance(c.get(), settings_.open_fraction_tolerance),
              "raddiff_cache_set_open_fraction_tolerance");
      check(raddiff_cache_set_lookup_radius_scale(c.get(), settings_.lookup_scale),
            "raddiff_cache_set_lookup_radius_scale");
      return c;
    };
    // The cache this metric wants: Ward or tent weights, extrapolation clamped at zero, the
    // gradient limit and the leak guard of the settings (or the interpolation the settings force).
    auto new_cache = [&] {
      if (settings_.interpolation >= 0) return with_cache_state(surface_cache(settings_.interpolation, irr.gradient_limit));
      CachePtr c(raddiff_irradiance_cache_new(&irr), raddiff_cache_free);
      if (!c) throw std::runtime_error(std::string("raddiff_irradiance_cache_new: ") + raddiff_last_error());
      return with_cache_state(std::move(c));
    };
    // With --open-fraction-bands, one cache per band of open fraction (a record goes into its own
    // band's and the two neighbouring bands' caches; a pixel looks only into its own band's).
    const bool banded = settings_.open_fraction_bands > 0 && settings_.near_field_px > 0;
    const int bands = banded ? static_cast<int>(std::ceil(1.0 / settings_.open_fraction_bands)) + 1 : 1;
    auto band_of = [&](double open) {
      return banded ? std::clamp(static_cast<int>(open / settings_.open_fraction_bands), 0, bands - 1) : 0;
    };
    if ((banded || open_test) &&
        (settings_.neighbour_clamp || settings_.smooth_records > 0 || settings_.second_order > 0))
      throw std::runtime_error("--open-fraction-bands and --open-fraction-tolerance do not combine with "
                               "--neighbour-clamp, --smooth-records or --second-order");
    const std::vector<std::array<float, 4>> *pixel_near = banded || open_test ? &near_field() : nullptr;
    std::vector<CachePtr> caches;
    for (int b = 0; b < bands; ++b) caches.push_back(new_cache());
    CachePtr &cache = caches[0];
    auto pixel_band = [&](size_t pixel) { return band_of(pixel_near ? (*pixel_near)[pixel][3] : 0.0); };
    auto cache_of = [&](size_t pixel) { return caches[pixel_band(pixel)].get(); };
    // A pixel's lookup: with the open-fraction test, with its near field's open fraction.
    auto lookup_pixel = [&](raddiff_cache *c, size_t pixel, float *value) {
      const raddiff_vec3 p = to_c(primary_[pixel].p), n = to_c(primary_[pixel].n);
      return open_test ? raddiff_cache_lookup_open(c, nullptr, p, n, (*pixel_near)[pixel][3], value, nullptr)
                       : raddiff_cache_lookup(c, p, n, value, nullptr);
    };
    CpuSum cache_cpu;
    const int w = view_.width, h = view_.height;
    // The inserted records, kept for the smoothing experiment (their values and open fractions
    // point into the store's evaluations, which outlive the fill).
    const bool smooth = render && settings_.smooth_records > 0;
    std::vector<KeptRecord> kept;
    // The kernel of the experiments' side caches: the one the settings force, or the metric's own.
    const int kernel = settings_.interpolation >= 0 ? settings_.interpolation
                       : uses_hessian(m)            ? RADDIFF_INTERP_TENT
                                                    : RADDIFF_INTERP_WARD;
    // The second-order experiment's cache of the records' quadratic terms (same extents, same kernel).
    CachePtr quadratic(nullptr, raddiff_cache_free);
    if (render && settings_.second_order > 0) {
      quadratic = surface_cache(kernel, irr.gradient_limit, kQuadraticChannels, false);
      check(raddiff_cache_set_lookup_radius_scale(quadratic.get(), settings_.lookup_scale),
            "raddiff_cache_set_lookup_radius_scale");
      check(raddiff_cache_set_leak_guard(quadratic.get(), irr.leak_guard_relative, irr.leak_guard_absolute),
            "raddiff_cache_set_leak_guard");
    }
    // The binned far-field experiment's caches of the records' bins (same extents, same kernel, no
    // gradients; one per band of open fraction, as the records').
    std::vector<CachePtr> binned_caches;
    if (render && settings_.far_field_bins)
      for (int b = 0; b < bands; ++b) {
        binned_caches.push_back(with_cache_state(surface_cache(kernel, irr.gradient_limit, 3 * kDirBins, false)));
        check(raddiff_cache_set_leak_guard(binned_caches.back().get(), irr.leak_guard_relative,
                                           irr.leak_guard_absolute),
              "raddiff_cache_set_leak_guard");
      }
    const bool binned = !binned_caches.empty();
    auto binned_of = [&](size_t pixel) { return binned_caches[pixel_band(pixel)].get(); };
    auto covered = [&](size_t i) {
      float v[3];
      const raddiff_status st = lookup_pixel(cache_of(i), i, v);
      if (st != RADDIFF_OK && st != RADDIFF_ERROR_NOT_FOUND) check(st, "raddiff_cache_lookup");
      return st == RADDIFF_OK;
    };
    // With neighbour clamping, the two-sided pass runs after each level; it can uncover pixels, so
    // the finest level is repeated over every pixel until a round inserts nothing, the last
    // allowed round filling only (as the render mode does).
    const bool clamp = settings_.neighbour_clamp;
    if (clamp && (settings_.smooth_records > 0 || settings_.second_order > 0))
      throw std::runtime_error("--neighbour-clamp does not combine with --smooth-records or --second-order");
    constexpr int kClampRounds = 3;
    int finest_rounds = 0;
    for (int step = 16;;) {
      std::vector<size_t> level;
      if (finest_rounds == 0) {
        for (size_t i : level_pixels(w, h, step))
          if (primary_[i].hit) level.push_back(i);
      } else {
        for (size_t i = 0; i < primary_.size(); ++i)
          if (primary_[i].hit) level.push_back(i);
      }
      const size_t records_before = out.records.size();
      std::vector<char> missed(level.size(), 0);
      parallel_for((level.size() + 255) / 256, settings_.threads, [&](size_t chunk) {
        const double t0 = thread_cpu_seconds();
        for (size_t k = chunk * 256; k < std::min(level.size(), (chunk + 1) * 256); ++k) missed[k] = !covered(level[k]);
        cache_cpu.add(thread_cpu_seconds() - t0);
      });
      std::vector<size_t> candidates;
      for (size_t k = 0; k < level.size(); ++k)
        if (missed[k]) candidates.push_back(level[k]);
      const size_t batch = 4 * std::max(1u, settings_.threads);
      for (size_t b = 0; b < candidates.size(); b += batch) {
        double t0 = thread_cpu_seconds();
        std::vector<size_t> still;
        for (size_t k = b; k < std::min(candidates.size(), b + batch); ++k)
          if (!covered(candidates[k])) still.push_back(candidates[k]);
        cache_cpu.add(thread_cpu_seconds() - t0);
        store_.ensure(still);
        for (size_t i : still) {
          t0 = thread_cpu_seconds();
          const bool skip = covered(i);
          cache_cpu.add(thread_cpu_seconds() - t0);
          if (skip) continue;
          const Slot &slot = store_.get(i);
          const Evaluated &e = *slot.evaluated;
          out.trace_seconds += slot.trace_seconds;  // a miss traces the gather: its cost counts
          out.raddiff_seconds += raddiff_seconds(m, e);
          if (!e.valid) continue;
          t0 = thread_cpu_seconds();
          raddiff_cache_record rec{};
          const bool defined = metric_record(m, p, e, irr, primary_[i].footprint, rec);
          out.raddiff_seconds += thread_cpu_seconds() - t0;
          if (!defined) continue;
          if (!settings_.record_gradients) rec.gradient = rec.rotation_gradient = nullptr;
          if (open_test) rec.open_fraction = &e.open_fraction;
          float far_gradient[9], far_rotation_gradient[9];
          if (settings_.near_field_px > 0) {
            // The far field's record: its value, and the gather's gradients in the same ratio.
            rec.value = e.far_value;
            for (int c = 0; c < 3; ++c) {
              const double ratio = e.value[c] > 0 ? e.far_value[c] / e.value[c] : 0.0;
              for (int k = 0; k < 3; ++k) {
                if (rec.gradient) far_gradient[3 * c + k] = static_cast<float>(rec.gradient[3 * c + k] * ratio);
                if (rec.rotation_gradient)
                  far_rotation_gradient[3 * c + k] = static_cast<float>(rec.rotation_gradient[3 * c + k] * ratio);
              }
            }
            if (rec.gradient) rec.gradient = far_gradient;
            if (rec.rotation_gradient) rec.rotation_gradient = far_rotation_gradient;
          }
          if (settings_.hessian_distance_bound > 0 && uses_hessian(m)) {
            const double bound = std::max(settings_.hessian_distance_bound * e.harmonic_mean_distance,
                                          irr.pixel_radius_min * primary_[i].footprint);
            for (double &r : rec.radii) r = std::min(r, bound);
          }
          if (settings_.error_norm > 0 && (m == Metric::HessianAnisotropic || m == Metric::HessianIsotropic))
            norm_radii(m, p, e, irr, primary_[i].footprint, rec);
          RecordInfo info{i,
                          primary_[i].p,
                          primary_[i].n,
                          {rec.radii[0], rec.radii[1]},
                          {rec.axes[0], rec.axes[1]},
                          luminance(rec.value),
                          e.open_fraction};
          t0 = thread_cpu_seconds();
          const int band = band_of(e.open_fraction);
          const int first_band = std::max(0, band - 1), last_band = std::min(bands - 1, band + 1);
          for (int b = first_band; b <= last_band; ++b)
            check(raddiff_cache_insert(caches[b].get(), &rec), "raddiff_cache_insert");
          cache_cpu.add(thread_cpu_seconds() - t0);
          if (binned) {
            raddiff_cache_record br = rec;
            br.value = e.far_bins;
            br.gradient = br.rotation_gradient = nullptr;
            for (int b = first_band; b <= last_band; ++b)
              check(raddiff_cache_insert(binned_caches[b].get(), &br), "raddiff_cache_insert");
          }
          out.records.push_back(info);
          if (smooth) kept.emplace_back(rec);
          if (quadratic) {
            if (!e.evaluation[1]) throw std::runtime_error("--second-order needs an occlusion-aware Hessian metric");
            raddiff_gather_summary summary{};
            check(raddiff_gather_evaluation_summary(e.evaluation[1].get(), &summary),
                  "raddiff_gather_evaluation_summary");
            const std::array<float, kQuadraticChannels> q = quadratic_channels(
                from_c(rec.position), normalize(from_c(rec.normal)), summary.occlusion_hessian);
            raddiff_cache_record qr = rec;
            qr.value = q.data();
            qr.gradient = qr.rotation_gradient = nullptr;
            check(raddiff_cache_insert(quadratic.get(), &qr), "raddiff_cache_insert");
          }
        }
      }
      const bool last_round = step == 1 && finest_rounds == kClampRounds;
      if (clamp && !last_round) {
        const double t0 = thread_cpu_seconds();
        size_t shrunk = 0;
        check(raddiff_cache_clamp_neighbours(cache.get(), &shrunk), "raddiff_cache_clamp_neighbours");
        cache_cpu.add(thread_cpu_seconds() - t0);
      }
      if (step > 1) {
        step /= 2;
        continue;
      }
      ++finest_rounds;
      if (!clamp || out.records.size() == records_before || last_round) break;
    }
    if (smooth) {
      // Experiment (not timed): every record's value replaced by the tent-weighted blend of the
      // records covering its position (its own included, radii times smooth_records), each
      // extrapolated through its gradient; the cache rebuilt from the same records.
      CachePtr blend = surface_cache(RADDIFF_INTERP_TENT, irr.gradient_limit);
      insert_scaled(blend.get(), kept, settings_.smooth_records);
      check(raddiff_cache_compact(blend.get()), "raddiff_cache_compact");
      cache = new_cache();
      for (const KeptRecord &k : kept) {
        raddiff_cache_record rec = k.get();
        float smoothed[3];
        const raddiff_status st = raddiff_cache_lookup(blend.get(), rec.position, rec.normal, smoothed, nullptr);
        if (st != RADDIFF_ERROR_NOT_FOUND) check(st, "raddiff_cache_lookup");
        if (st == RADDIFF_OK) rec.value = smoothed;
        check(raddiff_cache_insert(cache.get(), &rec), "raddiff_cache_insert");
      }
    }
    if (render) {
      const std::vector<std::array<float, 4>> &near = near_field();
      out.trace_seconds += near_seconds_;
      out.image = Image(w, h);
      for (CachePtr &c : caches) check(raddiff_cache_compact(c.get()), "raddiff_cache_compact");
      std::atomic<size_t> uncovered{0};
      parallel_for(static_cast<size_t>(h), settings_.threads, [&](size_t row) {
        const double t0 = thread_cpu_seconds();
        for (int x = 0; x < w; ++x) {
          const size_t i = row * w + x;
          if (!primary_[i].hit) continue;
          float *v = out.image.at(i);
          const raddiff_status st = lookup_pixel(cache_of(i), i, v);
          if (st == RADDIFF_ERROR_NOT_FOUND) {
            ++uncovered;
          } else {
            check(st, "raddiff_cache_lookup");
          }
          float b[kQuadraticChannels];
          if (st == RADDIFF_OK && quadratic &&
              raddiff_cache_lookup(quadratic.get(), to_c(primary_[i].p), to_c(primary_[i].n), b, nullptr) ==
                  RADDIFF_OK) {
            // the scalar's term shared by the channels in proportion to the interpolated value
            const double lum = luminance(v);
            const double scale = lum > 0 ? 1 + settings_.second_order * quadratic_term(primary_[i].p, b) / lum : 1;
            for (int c = 0; c < 3; ++c) v[c] = static_cast<float>(std::max(0.0, v[c] * scale));
          }
          float q[3 * kDirBins];
          const bool bins = st == RADDIFF_OK && binned && lookup_pixel(binned_of(i), i, q) == RADDIFF_OK;
          if (st == RADDIFF_OK && !near.empty())
            for (int c = 0; c < 3; ++c) {
              const double far = bins ? binned_far(v[c], near_bins_[i], q, c) : v[c];
              v[c] = static_cast<float>(far * near[i][3] + near[i][c]);
            }
        }
        cache_cpu.add(thread_cpu_seconds() - t0);
      });
      out.uncovered = uncovered;
      for (float v : out.image.rgb) {
        out.non_finite += !std::isfinite(v);
        out.negative += v < 0;
      }
    }
    out.cache_seconds = cache_cpu.total();
    return out;
  }

  // The error-norm experiment: rec's radii (an occlusion-aware Hessian metric's) replaced by those
  // minimizing the image's L^p error at equal records (see BenchSettings::error_norm). The
  // library's radii a ~ (tau/|lambda|)^(1/4) (its anisotropy and curvature floor) are raised to the
  // power 4q, q = p/(2p + 2), in scene units, and scaled by the footprint^(1/(p+1)) (pixels are
  // uniform on the image, not on surfaces); then the pixel bounds and the anisotropy limit are
  // applied again.
  void norm_radii(Metric m, double p, const Evaluated &e, const raddiff_irradiance_settings &irr, double footprint,
                  raddiff_cache_record &rec) const {
    raddiff_gather_summary summary{};
    check(raddiff_gather_evaluation_summary(e.evaluation[1].get(), &summary), "raddiff_gather_evaluation_summary");
    const raddiff_vec3 n = to_c(normalize(from_c(rec.normal)));
    const double anisotropy = m == Metric::HessianIsotropic ? 1.0 : irr.max_anisotropy;
    const double distance = std::isfinite(e.harmonic_mean_distance) ? e.harmonic_mean_distance : 1e30;
    double radii[2];
    raddiff_vec3 axes[2];
    check(raddiff_surface_radii_floored(summary.occlusion_hessian, n, e.luminance, p,
                                        settings_.absolute_error ? RADDIFF_ERROR_ABSOLUTE : RADDIFF_ERROR_RELATIVE,
                                        anisotropy, distance, irr.curvature_floor, radii, axes),
          "raddiff_surface_radii_floored");
    const double norm = settings_.error_norm;
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

  // Tunes metric m's parameter until the record count is within 5% of `target` (at most 14
  // fills): power-law jumps until the target is bracketed, then bisection in log space.
  double tune(Metric m, size_t target) {
    double p = initial_parameter(m);
    double k = 2 * radius_exponent(m);  // records ~ p^-k: area per record ~ radius^2
    double too_many = 0, too_few = 0, last_p = 0, last_n = 0, best_p = p, best_miss = INFINITY;
    for (int fills = 0; fills < 14; ++fills) {
      const Fill f = fill(m, p, false);
      const double n = static_cast<double>(f.records.size());
      const double miss = std::abs(std::log(std::max(n, 1.0) / target));
      std::printf("  tune %s: p = %.5g -> %zu records (%zu gathers so far)\n", metric_name(m), p, f.records.size(),
                  store_.computed());
      std::fflush(stdout);
      if (miss < best_miss) best_p = p, best_miss = miss;
      if (std::abs(n / target - 1) <= 0.05) break;
      if (n > target) {
        too_many = std::max(too_many, p);
      } else {
        too_few = too_few > 0 ? std::min(too_few, p) : p;
      }
      if (last_p > 0 && last_p != p && last_n > 0 && n > 0 && last_n != n)
        k = std::clamp(std::log(last_n / n) / std::log(p / last_p), 0.05, 10.0);
      last_p = p, last_n = n;
      if (too_many > 0 && too_few > 0) {
        p = std::sqrt(too_many * too_few);
      } else {
        p *= std::pow(std::max(n, 1.0) / target, 1.0 / k);
      }
    }
    return best_p;
  }

 private:
  const Scene &scene_;
  View view_;
  const BenchSettings &settings_;
  Camera camera_;
  std::vector<Primary> primary_;
  GatherStore store_;
  std::vector<std::array<float, 4>> near_;
  std::vector<std::array<float, kDirBins>> near_bins_;  // the binned experiment's open_bins per pixel
  double near_seconds_ = 0;
};

// Errors at the measured pixels.
struct Measured {
  double rel_rms = 0, rms = 0, worst_share = 0;
  std::vector<double> errors;  // luminance error per measured pixel (value - reference)
};

Measured measure(const Image &image, const Reference &ref) {
  Measured m;
  double e2 = 0, r2 = 0;
  std::vector<double> sq;
  for (const ReferencePixel &p : ref.pixels) {
    const double e = luminance(image.at(p.pixel)) - luminance(p.value());
    m.errors.push_back(e);
    sq.push_back(e * e);
    e2 += e * e;
    r2 += luminance(p.value()) * luminance(p.value());
  }
  if (ref.pixels.empty()) return m;
  m.rms = std::sqrt(e2 / ref.pixels.size());
  m.rel_rms = r2 > 0 ? std::sqrt(e2 / r2) : 0;
  std::sort(sq.begin(), sq.end(), std::greater<double>());
  const size_t worst = std::max<size_t>(1, sq.size() / 100);
  double top = 0;
  for (size_t k = 0; k < worst; ++k) top += sq[k];
  m.worst_share = e2 > 0 ? top / e2 : 0;
  return m;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

// The records' smallest radii in pixels (radius / the footprint of the record's pixel).
std::vector<double> radii_in_pixels(const Fill &f, const std::vector<Primary> &primary) {
  std::vector<double> out;
  for (const RecordInfo &r : f.records)
    out.push_back(std::min(r.radii[0], r.radii[1]) / std::max(primary[r.pixel].footprint, 1e-300));
  return out;
}

// Converged irradiance at record positions for the gather-noise floor, cached on disk by pixel.
class FloorReferences {
 public:
  FloorReferences(const std::string &file) : file_(file) {
    std::ifstream in(file_, std::ios::binary);
    uint64_t pixel;
    double v[6];
    while (in && in.read(reinterpret_cast<char *>(&pixel), 8) && in.read(reinterpret_cast<char *>(v), sizeof v)) {
      ReferencePixel r;
      r.pixel = pixel;
      r.half[0] = {v[0], v[1], v[2]};
      r.half[1] = {v[3], v[4], v[5]};
      map_[pixel] = r;
    }
  }

  // Computes the missing ones in parallel and appends them to the file.
  void ensure(const std::vector<size_t> &pixels, const Scene &scene, const std::vector<Primary> &primary,
              const BenchSettings &s) {
    std::vector<size_t> missing;
    for (size_t p : pixels)
      if (!map_.count(p)) missing.push_back(p);
    std::sort(missing.begin(), missing.end());
    missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
    if (missing.empty()) return;
    std::printf("floor: converged irradiance at %zu record positions (%u rays each)...\n", missing.size(),
                s.floor_rays);
    std::fflush(stdout);
    std::vector<ReferencePixel> found(missing.size());
    HitRadianceSettings single = s.radiance;
    single.paths = 1;
    parallel_for(missing.size(), s.threads, [&](size_t k) {
      const Primary &px = primary[missing[k]];
      found[k] = converged_irradiance(scene, single, px.p, px.n, s.floor_rays, mix(missing[k] ^ 0xf100ull));
      found[k].pixel = missing[k];
    });
    std::ofstream out(file_, std::ios::binary | std::ios::app);
    for (const ReferencePixel &r : found) {
      map_[r.pixel] = r;
      const uint64_t pixel = r.pixel;
      const double v[6] = {r.half[0].x, r.half[0].y, r.half[0].z, r.half[1].x, r.half[1].y, r.half[1].z};
      out.write(reinterpret_cast<const char *>(&pixel), 8);
      out.write(reinterpret_cast<const char *>(v), sizeof v);
    }
  }

  const ReferencePixel &at(size_t pixel) const { return map_.at(pixel); }

 private:
  std::string file_;
  std::map<size_t, ReferencePixel> map_;
};

// The records sampled for the floor: the `count` with the smallest hash of their pixel (so that
// metrics whose records share pixels share the samples).
std::vector<size_t> floor_sample(const Fill &f, size_t count) {
  std::vector<std::pair<uint64_t, size_t>> keyed;
  for (const RecordInfo &r : f.records) keyed.push_back({mix(r.pixel ^ 0xf1008ull), r.pixel});
  std::sort(keyed.begin(), keyed.end());
  std::vector<size_t> out;
  for (size_t k = 0; k < std::min(count, keyed.size()); ++k) out.push_back(keyed[k].second);
  return out;
}

// The luminance pixel `p` shows from its own gather `g`, with no cache between them: the gather's
// irradiance, or with the near field (`near` not empty) the pixel's own near field plus its open
// fraction times the gather's far field (binned when `near_bins` is not empty).
double shown_from_own_gather(size_t p, const Evaluated &g, const std::vector<std::array<float, 4>> &near,
                             const std::vector<std::array<float, kDirBins>> &near_bins) {
  if (near.empty()) return g.luminance;
  double rgb[3];
  for (int c = 0; c < 3; ++c) {
    const double far =
        near_bins.empty() ? g.far_value[c] : binned_far(g.far_value[c], near_bins[p], g.far_bins, c);
    rgb[c] = near[p][c] + near[p][3] * far;
  }
  return luminance(rgb);
}

// Relative RMS error of the records' own gathers against converged irradiance at their positions,
// the reference's own noise removed: the error a cache would have if every pixel had its record.
// With the near field a record's pixel shows its own near field plus its open fraction times the
// record's far field, so that is what is compared.
double gather_floor(const std::vector<size_t> &pixels, GatherStore &store, const FloorReferences &refs,
                    const std::vector<std::array<float, 4>> &near,
                    const std::vector<std::array<float, kDirBins>> &near_bins) {
  double e2 = 0, n2 = 0, r2 = 0;
  for (size_t p : pixels) {
    const ReferencePixel &r = refs.at(p);
    const double e = shown_from_own_gather(p, *store.get(p).evaluated, near, near_bins) - luminance(r.value());
    const double noise = 0.5 * (luminance(r.half[0]) - luminance(r.half[1]));
    e2 += e * e;
    n2 += noise * noise;
    r2 += luminance(r.value()) * luminance(r.value());
  }
  return r2 > 0 ? std::sqrt(std::max(0.0, e2 - n2) / r2) : 0;
}

std::string fmt(const char *f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

void write_records_csv(const std::string &path, const Fill &f, const Camera &camera,
                       const std::vector<Primary> &primary) {
  std::ofstream out(path);
  out << "pixel,px,py,ux,uy,vx,vy,radius_px,value,open_fraction\n";
  for (const RecordInfo &r : f.records) {
    double cx, cy;
    if (!camera.project(r.p, cx, cy)) continue;
    V3 a0 = from_c(r.axes[0]), a1 = from_c(r.axes[1]);
    if (length(a0) == 0 || length(a1) == 0) {
      a0 = tangent_of(r.n);
      a1 = cross(r.n, a0);
    }
    // A short semi-axis projects well enough through a pinhole; off-screen ends keep their values.
    double ax = cx, ay = cy, bx = cx, by = cy;
    camera.project(r.p + normalize(a0) * r.radii[0], ax, ay);
    camera.project(r.p + normalize(a1) * r.radii[1], bx, by);
    out << r.pixel << "," << cx << "," << cy << "," << ax - cx << "," << ay - cy << "," << bx - cx << "," << by - cy
        << "," << std::min(r.radii[0], r.radii[1]) / std::max(primary[r.pixel].footprint, 1e-300) << "," << r.value
        << "," << r.open_fraction << "\n";
  }
}

long max_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024;
}

}  // namespace

int run_bench(const Scene &scene, const View &view, const std::string &scene_key, const BenchSettings &settings) {
  if (settings.far_field_bins && settings.near_field_px <= 0)
    throw std::runtime_error("--far-field-bins needs --near-field");
  if (settings.open_fraction_bands > 0 && settings.near_field_px <= 0)
    throw std::runtime_error("--open-fraction-bands needs --near-field");
  if (std::isfinite(settings.open_fraction_tolerance) && settings.near_field_px <= 0)
    throw std::runtime_error("--open-fraction-tolerance needs --near-field");
  if (settings.near_at_reach && !settings.far_field_gathers)
    throw std::runtime_error("--near-at-reach needs --far-field-gathers");
  if (settings.far_field_gathers && settings.near_field_px <= 0)
    throw std::runtime_error("--far-field-gathers needs --near-field");
  const double wall0 = process_cpu_seconds();
  Bench bench(scene, view, settings);
  const std::vector<Primary> &primary = bench.primary();
  const size_t pixels = static_cast<size_t>(view.width) * view.height;
  const size_t target = settings.target_records ? settings.target_records : std::max<size_t>(16, pixels / 32);

  // The converged reference.
  const Reference ref = reference(scene, primary, view, settings.radiance, settings.reference, scene_key,
                                  settings.threads);
  const double ref_mean = [&] {
    double s = 0;
    for (const ReferencePixel &p : ref.pixels) s += luminance(p.value());
    return ref.pixels.empty() ? 1.0 : s / ref.pixels.size();
  }();
  std::printf("reference: %zu pixels, %u rays each, relative noise %.5f (%s)\n", ref.pixels.size(),
              settings.reference.rays, ref.relative_noise(),
              ref.loaded ? ("loaded from " + ref.file).c_str() : ("computed in " + fmt("%.0f", ref.seconds) + " CPU s").c_str());
  {
    std::ofstream out(settings.out + "-measured.csv");
    out << "pixel,x,y,reference,noise\n";
    for (const ReferencePixel &p : ref.pixels)
      out << p.pixel << "," << p.pixel % view.width << "," << p.pixel / view.width << "," << luminance(p.value()) << ","
          << 0.5 * std::abs(luminance(p.half[0]) - luminance(p.half[1])) << "\n";
  }
  Image ref_blocks(view.width, view.height);  // the reference at the measured pixels, for the exposure
  for (const ReferencePixel &p : ref.pixels) {
    const V3 v = p.value();
    ref_blocks.at(p.pixel)[0] = static_cast<float>(v.x);
    ref_blocks.at(p.pixel)[1] = static_cast<float>(v.y);
    ref_blocks.at(p.pixel)[2] = static_cast<float>(v.z);
  }
  const double exposure = [&] {
    std::vector<double> l;
    for (const ReferencePixel &p : ref.pixels) l.push_back(luminance(p.value()));
    return 0.9 / std::max(1e-12, percentile(l, 0.99));
  }();

  // A measured pixel's open fraction, from its near field (1 without one).
  const auto pixel_open_fraction = [&](size_t p) {
    return settings.near_field_px > 0 ? static_cast<double>(bench.near_field()[p][3]) : 1.0;
  };

  std::ofstream fills(settings.out + "-fills.csv");
  fills << "metric,parameter,records,equal_records,trace_s,raddiff_s,cache_s,total_s,rel_rms,rms,worst1_share,"
           "radius_px_min,radius_px_p5,radius_px_median,radius_px_p95,uncovered,non_finite,negative\n";
  bool ok = true;
  std::vector<Fill> tuned;
  double longest = 0;
  FloorReferences floor_refs(settings.reference.cache_dir.empty()
                                 ? std::string()
                                 : settings.reference.cache_dir + "/floor-" +
                                       fmt("%.0f", static_cast<double>(settings.floor_rays)) + "-" +
                                       (ref.file.empty() ? std::string("x") : ref.file.substr(ref.file.rfind('-') + 1)));
  for (Metric m : settings.metrics) {
    std::printf("%s: tuning to %zu records\n", metric_name(m), target);
    std::fflush(stdout);
    const double p = bench.tune(m, target);
    // Thresholds spaced so that radii change by 2^0.75 per step: one below the tuned one (more
    // records), the tuned one, then above it.
    const int first = settings.thresholds >= 2 ? -1 : 0;
    for (int k = first; k < first + settings.thresholds; ++k) {
      const double pk = p * std::pow(2.0, 0.75 * k / radius_exponent(m));
      Fill f = bench.fill(m, pk, true);
      const Measured err = measure(f.image, ref);
      const std::vector<double> rpx = radii_in_pixels(f, primary);
      const bool equal = k == 0;
      ok = ok && f.uncovered == 0 && f.non_finite == 0 && f.negative == 0 && !f.records.empty();
      fills << metric_name(m) << "," << pk << "," << f.records.size() << "," << equal << "," << f.trace_seconds << ","
            << f.raddiff_seconds << "," << f.cache_seconds << "," << f.total_seconds() << "," << err.rel_rms << ","
            << err.rms << "," << err.worst_share << "," << percentile(rpx, 0) << "," << percentile(rpx, 0.05) << ","
            << percentile(rpx, 0.5) << "," << percentile(rpx, 0.95) << "," << f.uncovered << "," << f.non_finite
            << "," << f.negative << "\n";
      fills.flush();
      std::printf("  %-22s p = %-10.5g %6zu records  %7.2f CPU s (trace %.2f, raddiff %.2f, cache %.2f)  error %.4f  "
                  "worst 1%%: %.2f\n",
                  metric_name(m), pk, f.records.size(), f.total_seconds(), f.trace_seconds, f.raddiff_seconds,
                  f.cache_seconds, err.rel_rms, err.worst_share);
      std::fflush(stdout);
      longest = std::max(longest, f.total_seconds());
      if (equal) {
        const std::string prefix = settings.out + "-" + metric_name(m);
        write_images(prefix, f.image, exposure);
        write_records_csv(prefix + "-records.csv", f, bench.camera(), primary);
        std::ofstream px(prefix + "-pixels.csv");
        px << "pixel,x,y,value,reference,error,open_fraction\n";
        for (size_t i = 0; i < ref.pixels.size(); ++i) {
          const size_t p = ref.pixels[i].pixel;
          px << p << "," << p % view.width << "," << p / view.width << "," << luminance(f.image.at(p)) << ","
             << luminance(ref.pixels[i].value()) << "," << err.errors[i] << "," << pixel_open_fraction(p) << "\n";
        }
        tuned.push_back(std::move(f));
      }
    }
  }

  // The gathers' own error at the records of each equal-records cache.
  std::ofstream floor_csv(settings.out + "-floor.csv");
  floor_csv << "metric,records_sampled,floor_rel_rms\n";
  std::vector<size_t> all_samples;
  for (const Fill &f : tuned) {
    const std::vector<size_t> s = floor_sample(f, settings.floor_records);
    all_samples.insert(all_samples.end(), s.begin(), s.end());
  }
  floor_refs.ensure(all_samples, scene, primary, settings);
  for (const Fill &f : tuned) {
    const std::vector<size_t> s = floor_sample(f, settings.floor_records);
    const double floor = gather_floor(s, bench.store(), floor_refs, bench.near_field(), bench.near_bins());
    floor_csv << metric_name(f.metric) << "," << s.size() << "," << floor << "\n";
    std::printf("floor %-22s %.4f (gathers of %zu records against converged irradiance)\n", metric_name(f.metric),
                floor, s.size());
  }

  // Every measured pixel shown from its own gather, no cache: the error no record placement removes
  // (the gathers' and near fields' noise, the near/far decomposition's bias, the reference's noise).
  double pixel_gathers_error = -1;
  if (settings.pixel_gathers) {
    std::vector<size_t> measured;
    for (const ReferencePixel &r : ref.pixels) measured.push_back(r.pixel);
    bench.store().ensure(measured);
    std::ofstream px(settings.out + "-pixel-gathers-pixels.csv");
    px << "pixel,x,y,value,reference,error,open_fraction\n";
    const std::vector<std::array<float, 4>> &near = bench.near_field();
    const std::vector<std::array<float, kDirBins>> &near_bins = bench.near_bins();
    double e2 = 0, r2 = 0;
    size_t degenerate = 0;  // gathers raddiff found degenerate: shown with a zero far field
    for (const ReferencePixel &r : ref.pixels) {
      const size_t p = r.pixel;
      const Evaluated &g = *bench.store().get(p).evaluated;
      degenerate += !g.valid;
      const double shown = shown_from_own_gather(p, g, near, near_bins);
      const double reference_value = luminance(r.value());
      e2 += (shown - reference_value) * (shown - reference_value);
      r2 += reference_value * reference_value;
      px << p << "," << p % view.width << "," << p / view.width << "," << shown << "," << reference_value << ","
         << shown - reference_value << "," << pixel_open_fraction(p) << "\n";
    }
    pixel_gathers_error = r2 > 0 ? std::sqrt(e2 / r2) : 0;
    std::printf("pixel gathers: every measured pixel from its own gather, error %.4f (%zu degenerate)\n",
                pixel_gathers_error, degenerate);
  }

  // The primary hits' normals: the denoiser's guide, and where the report finds geometric edges.
  write_pfm(settings.out + "-normal.pfm", normal_buffer(primary, view));

  // Path tracing the indirect irradiance per pixel, up to past the costliest cache.
  if (settings.path_trace) {
    write_pfm(settings.out + "-albedo.pfm", albedo_buffer(scene, primary, view));
    std::ofstream pt(settings.out + "-pt.csv");
    pt << "spp,cpu_s,rays,rel_rms,rms,worst1_share,file\n";
    path_trace(scene, primary, view, settings.radiance, settings.path_trace_max_spp, 1.3 * longest, settings.threads,
               [&](const PathTraceSnapshot &s) {
                 const Measured err = measure(s.image, ref);
                 const std::string file = settings.out + "-pt-spp" + std::to_string(s.spp);
                 write_pfm(file + ".pfm", s.image);
                 if (s.spp == 1 || s.cpu_seconds > longest) write_png(file + ".png", s.image, exposure);
                 pt << s.spp << "," << s.cpu_seconds << "," << s.rays << "," << err.rel_rms << "," << err.rms << ","
                    << err.worst_share << "," << file << ".pfm\n";
                 pt.flush();
                 std::printf("path tracing: %5u spp  %7.2f CPU s  error %.4f\n", s.spp, s.cpu_seconds, err.rel_rms);
                 std::fflush(stdout);
               });
  }

  std::ofstream summary(settings.out + "-summary.csv");
  summary << "key,value\n"
          << "width," << view.width << "\nheight," << view.height << "\ntriangles," << scene.triangle_count()
          << "\nscene_size," << scene.size() << "\ngather," << settings.irradiance.gather_m << "x"
          << settings.irradiance.gather_n
          << "\nhit_radiance," << settings.radiance.describe() << "\ntarget_records," << target
          << "\nmeasured_pixels," << ref.pixels.size() << "\nreference_grid," << settings.reference.grid << "\nreference_rays," << settings.reference.rays
          << "\nreference_relative_noise," << ref.relative_noise() << "\nreference_mean," << ref_mean
          << "\ngathers_computed," << bench.store().computed() << "\nmax_rss_mib," << max_rss_mib()
          << "\nprocess_cpu_s," << process_cpu_seconds() - wall0 << "\nexposure," << exposure << "\nreference_cpu_s," << ref.seconds
          << "\nreference_loaded," << ref.loaded << "\ngradient_limit," << settings.irradiance.gradient_limit
          << "\nleak_guard," << settings.irradiance.leak_guard_relative << " " << settings.irradiance.leak_guard_absolute
          << "\nradius_bounds," << settings.irradiance.world_radius_min << " " << settings.irradiance.world_radius_max
          << " " << settings.irradiance.pixel_radius_min << " " << settings.irradiance.pixel_radius_max
          << "\nopen_fraction_tolerance," << settings.open_fraction_tolerance
          << "\nlookup_radius_scale," << settings.lookup_scale << "\nnoise_seed," << settings.noise_seed << "\npixel_gathers_rel_rms," << pixel_gathers_error << "\n";
  std::printf("bench: %zu gathers computed, max RSS %ld MiB, %.0f CPU s\n", bench.store().computed(), max_rss_mib(),
              process_cpu_seconds() - wall0);
  std::printf("%s\n", ok ? "OK" : "FAILED");
  return ok ? 0 : 1;
}

}  // namespace rd
