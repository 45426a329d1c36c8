#include "fill_experiments.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace rd {

CachePtr surface_cache(int interpolation, double c, uint32_t channels, bool non_negative) {
  const raddiff_cache_config config{
      channels, RADDIFF_DOMAIN_SURFACE,
      static_cast<uint32_t>(interpolation) | (non_negative ? RADDIFF_INTERP_NON_NEGATIVE : 0u), 0.2};
  CachePtr cache(raddiff_cache_new(&config), raddiff_cache_free);
  if (!cache) throw std::runtime_error(std::string("raddiff_cache_new: ") + raddiff_last_error());
  check(raddiff_cache_set_gradient_limit(cache.get(), c), "raddiff_cache_set_gradient_limit");
  return cache;
}

KeptRecord::KeptRecord(const raddiff_cache_record &rec) : rec_(rec) {
  if (rec.gradient) std::copy(rec.gradient, rec.gradient + 9, gradient_.begin());
  if (rec.rotation_gradient) std::copy(rec.rotation_gradient, rec.rotation_gradient + 9, rotation_gradient_.begin());
}

raddiff_cache_record KeptRecord::get() const {
  raddiff_cache_record r = rec_;
  if (r.gradient) r.gradient = gradient_.data();
  if (r.rotation_gradient) r.rotation_gradient = rotation_gradient_.data();
  return r;
}

void insert_scaled(raddiff_cache *cache, const std::vector<KeptRecord> &kept, double scale) {
  for (const KeptRecord &k : kept) {
    raddiff_cache_record rec = k.get();
    for (double &x : rec.radii) x *= scale;
    check(raddiff_cache_insert(cache, &rec), "raddiff_cache_insert");
  }
}

double binned_far(double far, const std::array<float, kDirBins> &open_bins, const float *bins, int c) {
  double d = 0;
  for (int b = 0; b < kDirBins; ++b) d += open_bins[b] * bins[3 * b + c];
  return std::max(0.0, far + kPi * d);
}

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

double quadratic_term(const V3 &p, const float *b) {
  const double x = p.x, y = p.y, z = p.z;
  const double xhx = b[0] * x * x + b[1] * y * y + b[2] * z * z + 2 * (b[3] * x * y + b[4] * x * z + b[5] * y * z);
  return 0.5 * xhx - (b[6] * x + b[7] * y + b[8] * z) + b[9];
}

void AdaptiveLookup::fill(const std::vector<KeptRecord> &kept, const std::vector<float> &noise) {
  std::vector<float> sorted(noise);
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  median_ = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  for (size_t r = 0; r < ladder_.size(); ++r)
    check(raddiff_cache_set_lookup_radius_scale(ladder_[r].get(), std::exp2(r / 4.0)),
          "raddiff_cache_set_lookup_radius_scale");
  check(raddiff_cache_set_lookup_radius_scale(noise_.get(), 1.0), "raddiff_cache_set_lookup_radius_scale");
  for (size_t i = 0; i < kept.size(); ++i) {
    raddiff_cache_record rec = kept[i].get();
    for (CachePtr &c : ladder_) check(raddiff_cache_insert(c.get(), &rec), "raddiff_cache_insert");
    rec.value = &noise[i];
    rec.gradient = rec.rotation_gradient = nullptr;
    check(raddiff_cache_insert(noise_.get(), &rec), "raddiff_cache_insert");
  }
  for (CachePtr &c : ladder_) check(raddiff_cache_compact(c.get()), "raddiff_cache_compact");
  check(raddiff_cache_compact(noise_.get()), "raddiff_cache_compact");
  uses_ = std::vector<std::atomic<size_t>>(ladder_.size());
}

raddiff_cache *AdaptiveLookup::rung(float blended_noise) {
  size_t r = 0;
  if (blended_noise > 0) {
    const double kmax = std::exp2((ladder_.size() - 1) / 4.0);
    const double k = std::clamp(k0_ * std::pow(blended_noise / median_, exponent_), 1.0, kmax);
    r = std::min(ladder_.size() - 1, static_cast<size_t>(std::lround(4 * std::log2(k))));
  }
  ++uses_[r];
  return ladder_[r].get();
}

double AdaptiveLookup::mean_scale() const {
  double n = 0, sum = 0;
  for (size_t r = 0; r < uses_.size(); ++r) n += uses_[r], sum += uses_[r] * std::exp2(r / 4.0);
  return n > 0 ? sum / n : 1.0;
}

}  // namespace rd
