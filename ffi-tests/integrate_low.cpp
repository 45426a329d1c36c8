// The same toy C++ renderer with raddiff's low-level calls (through the raddiff.hpp wrappers).
#include "raddiff.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

constexpr int kSize = 32;
constexpr double kPixel = 2.0 / kSize;

// The scene: a floor (z = 0) under a ceiling (z = 1) that emits (1, 0.8, 0.6) where y > 0.
void trace(raddiff_vec3 o, const std::vector<raddiff_vec3> &dirs, std::vector<double> &distance,
           std::vector<float> &radiance) {
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    const double t = dirs[i].z > 0.0 ? (1.0 - o.z) / dirs[i].z : INFINITY;
    const bool lit = t < INFINITY && o.y + t * dirs[i].y > 0.0;
    distance[i] = t;
    radiance[3 * i + 0] = lit ? 1.0f : 0.0f;
    radiance[3 * i + 1] = lit ? 0.8f : 0.0f;
    radiance[3 * i + 2] = lit ? 0.6f : 0.0f;
  }
}

// What raddiff_cache_irradiance does on a miss: directions, trace, evaluate, radii, record, insert.
void insert_record(raddiff::Cache &cache, raddiff_vec3 x, raddiff_vec3 n, std::uint64_t seed) {
  const raddiff_gather_layout layout{RADDIFF_LAYOUT_COSINE_POLAR, 16, 48, seed};
  const raddiff_frame frame{x, n, {1, 0, 0}};
  const std::vector<raddiff_vec3> dirs = raddiff::gather_directions(layout, frame);
  std::vector<double> distance(dirs.size());
  std::vector<float> radiance(3 * dirs.size());
  trace(x, dirs, distance, radiance);
  raddiff::GatherInput in;
  in.directions = dirs, in.distance = distance, in.radiance = radiance, in.channels = 3;
  const raddiff::GatherResult g = raddiff::gather_evaluate(layout, frame, in, raddiff::GATHER_ALL);
  // the luminance's irradiance and Hessian drive the radii
  const double w[3] = {0.2126, 0.7152, 0.0722};
  double e = 0.0, h[9] = {};
  for (int c = 0; c < 3; ++c) {
    e += w[c] * g.irradiance[c];
    for (int k = 0; k < 9; ++k) h[k] += w[c] * g.hessian[9 * c + k];
  }
  const raddiff::SurfaceRadii r =
      std::isfinite(g.harmonic_mean_distance)
          ? raddiff::surface_radii_floored(h, n, e, 1e-4, RADDIFF_ERROR_RELATIVE, 2.0, g.harmonic_mean_distance,
                                           RADDIFF_CURVATURE_FLOOR_WEIGHT)
          : raddiff::surface_radii(h, n, e, 1e-4, RADDIFF_ERROR_RELATIVE, 2.0);
  // doubles to floats; radii clamped to 1..150 pixels, radii[2] the smaller one
  std::vector<float> value(g.irradiance.begin(), g.irradiance.end());
  std::vector<float> gradient(g.gradient.begin(), g.gradient.end());
  std::vector<float> rotation(g.rotation_gradient.begin(), g.rotation_gradient.end());
  raddiff_cache_record rec{};
  rec.position = x, rec.normal = n;
  rec.value = value.data(), rec.gradient = gradient.data(), rec.rotation_gradient = rotation.data();
  for (int k = 0; k < 2; ++k) {
    rec.radii[k] = std::clamp(r.radii[k], kPixel, 150.0 * kPixel);
    rec.axes[k] = r.axes[k];
  }
  rec.radii[2] = std::min(rec.radii[0], rec.radii[1]);
  cache.insert(rec);
}

int main() {
  try {
    raddiff::Cache cache({3, RADDIFF_DOMAIN_SURFACE,
                          RADDIFF_INTERP_TENT | RADDIFF_INTERP_NON_NEGATIVE | RADDIFF_INTERP_GRADIENT_LIMIT, 0.2});
    const raddiff_vec3 n{0, 0, 1};
    double err2 = 0.0, ref2 = 0.0;
    for (int step = 8; step >= 1; step /= 2)
      for (int j = 0; j < kSize; j += step)
        for (int i = 0; i < kSize; i += step) {
          const raddiff_vec3 x{-1.0 + (i + 0.5) * kPixel, -1.0 + (j + 0.5) * kPixel, 2e-4};
          float e[3];
          if (!cache.try_lookup(x, n, e)) {
            insert_record(cache, x, n, 1 + static_cast<std::uint64_t>(j * kSize + i));
            cache.lookup(x, n, e);
          }
          if (step > 1) continue;
          const double exact = 3.14159265358979 * (1.0 + x.y / std::hypot(x.y, 1.0 - x.z)) / 2.0;
          err2 += (e[0] - exact) * (e[0] - exact);
          ref2 += exact * exact;
        }
    std::printf("%zu records, relative RMS error %.4f\n", cache.size(), std::sqrt(err2 / ref2));
    return std::sqrt(err2 / ref2) < 0.02 ? 0 : 1;
  } catch (const raddiff::Error &e) {
    std::fprintf(stderr, "raddiff error %d: %s\n", static_cast<int>(e.status()), e.what());
    return 1;
  }
}
