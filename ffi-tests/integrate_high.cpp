// Irradiance caching in a toy C++ renderer, one raddiff call per shading point, on two threads.
#include "raddiff.hpp"

#include <cmath>
#include <cstdio>
#include <thread>
#include <vector>

constexpr int kSize = 32;  // image pixels per side; the camera looks straight down at [-1, 1]^2
constexpr double kPixel = 2.0 / kSize;

// The scene: a floor (z = 0) under a ceiling (z = 1) that emits (1, 0.8, 0.6) where y > 0.
void trace(raddiff_vec3 o, raddiff::Span<const raddiff_vec3> dirs, raddiff::Span<double> distance,
           raddiff::Span<float> radiance) {
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    const double t = dirs[i].z > 0.0 ? (1.0 - o.z) / dirs[i].z : INFINITY;
    const bool lit = t < INFINITY && o.y + t * dirs[i].y > 0.0;
    distance[i] = t;
    radiance[3 * i + 0] = lit ? 1.0f : 0.0f;
    radiance[3 * i + 1] = lit ? 0.8f : 0.0f;
    radiance[3 * i + 2] = lit ? 0.6f : 0.0f;
  }
}

// The shading point of pixel (i, j), pulled back from the floor towards the camera (at distance 2).
raddiff_vec3 shading_point(int i, int j) { return {-1.0 + (i + 0.5) * kPixel, -1.0 + (j + 0.5) * kPixel, 2e-4}; }

int main() {
  try {
    raddiff_irradiance_settings s = raddiff::irradiance_settings_default();
    s.gather_m = 16, s.gather_n = 48;
    s.accuracy = 1e-4;
    raddiff::IrradianceCache cache(s);
    const raddiff_vec3 n{0, 0, 1};
    // coarse to fine; the two threads share the cache (lookups never block, inserts are serialized)
    for (int step = 8; step >= 1; step /= 2) {
      auto rows = [&](int first) {
        for (int j = first * step; j < kSize; j += 2 * step)
          for (int i = 0; i < kSize; i += step) cache.irradiance(shading_point(i, j), n, kPixel, trace);
      };
      std::thread other(rows, 1);
      rows(0);
      other.join();
    }
    // the filled cache, saved, then reused with its settings by a lookup-only pass
    cache.cache().save("irradiance-cpp.rdc");
    raddiff::IrradianceCache reused(raddiff::Cache::load("irradiance-cpp.rdc"), s);
    reused.cache().compact();
    double err2 = 0.0, ref2 = 0.0;
    for (int j = 0; j < kSize; ++j)
      for (int i = 0; i < kSize; ++i) {
        const raddiff_vec3 x = shading_point(i, j);
        float e[3];
        reused.cache().lookup(x, n, e);  // a miss would throw: every pixel is covered
        const double exact = 3.14159265358979 * (1.0 + x.y / std::hypot(x.y, 1.0 - x.z)) / 2.0;
        err2 += (e[0] - exact) * (e[0] - exact);
        ref2 += exact * exact;
      }
    std::printf("%zu records, relative RMS error %.4f\n", reused.cache().size(), std::sqrt(err2 / ref2));
    return std::sqrt(err2 / ref2) < 0.02 ? 0 : 1;
  } catch (const raddiff::Error &e) {
    std::fprintf(stderr, "raddiff error %d: %s\n", static_cast<int>(e.status()), e.what());
    return 1;
  }
}
