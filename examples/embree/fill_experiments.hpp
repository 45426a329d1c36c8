// What the benchmark's fills share with their experiments: owned caches, records kept after their
// insertion (smoothing, the adaptive lookup), the second-order experiment's quadratic channels,
// the binned far field, and the adaptive lookup's ladder of caches. See BenchSettings for what
// each experiment measures.
#pragma once

#include "common.hpp"
#include "trace.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <vector>

namespace rd {

using CachePtr = std::unique_ptr<raddiff_cache, void (*)(raddiff_cache *)>;

// A surface cache of `channels` channels with `interpolation` (RADDIFF_INTERP_*), clamped at zero
// when `non_negative`, with gradient limit c.
CachePtr surface_cache(int interpolation, double c, uint32_t channels = 3, bool non_negative = true);

// A record kept after its insertion, with copies of its gradients (three channels, as every record
// of the bench): the far field's are computed in the fill's locals.
class KeptRecord {
 public:
  explicit KeptRecord(const raddiff_cache_record &rec);
  // The record, its gradients pointing into this object (valid while it lives and does not move).
  raddiff_cache_record get() const;

 private:
  raddiff_cache_record rec_;
  std::array<float, 9> gradient_{}, rotation_gradient_{};
};

// Inserts the `kept` records into `cache` with their radii times `scale`.
void insert_scaled(raddiff_cache *cache, const std::vector<KeptRecord> &kept, double scale);

// The binned far-field experiment's far field for channel c: F plus pi times the records' bin
// departures `bins` weighted by the pixel's open rays' bins, at least 0.
double binned_far(double far, const std::array<float, kDirBins> &open_bins, const float *bins, int c);

// The second-order experiment (--second-order): the blend of the covering records' terms
// q_i(x) = 1/2 (x - x_i)^T H_i (x - x_i) is linear in the records' constants H_i, H_i x_i and
// 1/2 x_i^T H_i x_i, so a cache of those ten channels (no gradients; the main cache's kernel, hence
// its weights) blends them, and q(x) = 1/2 x^T <H> x - <H x_i> . x + <1/2 x_i^T H x_i>.
constexpr uint32_t kQuadraticChannels = 10;

// The ten channels of a record at `p` (unit normal `n`) whose scalar has Hessian `h` (row-major),
// projected on the tangent plane (the Hessian's normal rows carry robustness terms, not curvature).
std::array<float, kQuadraticChannels> quadratic_channels(const V3 &p, const V3 &n, const double h[9]);

// q(x) from the blended channels `b` of kQuadraticChannels.
double quadratic_term(const V3 &p, const float *b);

// The adaptive-lookup experiment's caches (BenchSettings::adaptive_lookup): the records read at
// every scale of a quarter-octave ladder from 1 to kmax, and a one-channel cache of their relative
// noise (read at scale 1) that picks a pixel's rung, k0 (s / s_median)^exponent.
class AdaptiveLookup {
 public:
  // `make_cache` returns an empty cache of the records' kind and state (guard, open-fraction test);
  // `noise_cache` is an empty one of a single channel. kept[i] has relative noise noise[i].
  template <class MakeCache>
  AdaptiveLookup(const std::vector<KeptRecord> &kept, const std::vector<float> &noise, double k0, double kmax,
                 double exponent, MakeCache make_cache, CachePtr noise_cache)
      : k0_(k0), exponent_(exponent), noise_(std::move(noise_cache)) {
    const int rungs = 1 + static_cast<int>(std::floor(4 * std::log2(std::clamp(kmax, 1.0, 8.0)) + 1e-9));
    for (int r = 0; r < rungs; ++r) ladder_.push_back(make_cache());
    fill(kept, noise);
  }

  // The cache a pixel reads: `lookup(cache, value)` looks the pixel up in a cache and returns the
  // status. Thread-safe.
  template <class Lookup>
  raddiff_cache *cache_for(Lookup lookup) {
    float s = 0;
    const bool found = median_ > 0 && lookup(noise_.get(), &s) == RADDIFF_OK;
    return rung(found ? s : 0.0f);
  }

  // The records' median relative noise, and the mean scale the pixels read at so far.
  double median() const { return median_; }
  double mean_scale() const;

 private:
  void fill(const std::vector<KeptRecord> &kept, const std::vector<float> &noise);
  raddiff_cache *rung(float blended_noise);

  double k0_, exponent_, median_ = 0;
  CachePtr noise_;
  std::vector<CachePtr> ladder_;
  std::vector<std::atomic<size_t>> uses_;
};

}  // namespace rd
