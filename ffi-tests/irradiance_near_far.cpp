// raddiff::IrradianceCache::irradiance_near_far: a lambda traces with a maximum distance, the
// value matches the closed form under a ceiling, exceptions come back with nothing inserted,
// Cache::far_field reads the marker, and irradiance_near_far_parts returns the near field.
#include "raddiff.hpp"
#include "hpp_check.h"

#include <cmath>
#include <vector>

namespace {

struct OutOfRays {
  int code;
};

const double kPi = 3.14159265358979323846;

// The plane z = 0 under a ceiling at height 0.5 of radiance (2, 1, 0.5); rays stop at `max`.
void ceiling(raddiff_vec3 o, raddiff::Span<const raddiff_vec3> d, double max, raddiff::Span<double> distance,
             raddiff::Span<float> radiance) {
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double t = (0.5 - o.z) / std::max(d[i].z, 1e-12);
    if (t >= max) {
      distance[i] = INFINITY;
      continue;
    }
    distance[i] = t;
    radiance[3 * i] = 2.0f;
    radiance[3 * i + 1] = 1.0f;
    radiance[3 * i + 2] = 0.5f;
  }
}

}  // namespace

int main() {
  raddiff_irradiance_settings s = raddiff::irradiance_settings_default();
  s.gather_m = 16;
  s.gather_n = 48;
  s.world_radius_min = 0.01;
  s.world_radius_max = 5.0;
  s.near_field_reach_world = 1.0;
  s.near_field_m = 8;
  s.near_field_n = 8;
  raddiff::IrradianceCache cache(s);
  CHECK(cache.cache().far_field() == std::make_pair(1.0, 0.0));
  const raddiff_vec3 up{0, 0, 1};
  std::vector<std::size_t> counts;
  std::vector<double> maxima;
  auto trace = [&](raddiff_vec3 o, raddiff::Span<const raddiff_vec3> d, double max, raddiff::Span<double> t,
                   raddiff::Span<float> l) {
    counts.push_back(d.size());
    maxima.push_back(max);
    CHECK(t.size() == d.size() && l.size() == 3 * d.size());
    ceiling(o, d, max, t, l);
  };
  const std::vector<float> miss = cache.irradiance_near_far({0, 0, 0}, up, 0.0, trace);
  const std::vector<float> hit = cache.irradiance_near_far({0.003, 0.001, 0}, up, 0.0, trace);
  CHECK(counts == std::vector<std::size_t>({16 * 48, 64}));
  CHECK(std::isinf(maxima[0]) && maxima[1] == 1.0);
  CHECK(cache.cache().size() == 1);
  for (int c = 0; c < 3; ++c) {
    const double want = kPi * 2.0 / (1 << c);
    CHECK(std::fabs(miss[c] - want) < 1e-5 * want && std::fabs(hit[c] - want) < 1e-5 * want);
  }
  // the parts: E_near = (3/4) pi L and V = 1/4 on a hit, and E_near + V * F with F the cache's
  // plain lookup gives the value
  {
    const raddiff_vec3 p{0.002, -0.003, 0};
    const raddiff::NearFarParts parts = cache.irradiance_near_far_parts(p, up, 0.0, trace);
    CHECK(parts.value.size() == 3 && parts.near_irradiance.size() == 3);
    CHECK(std::fabs(parts.open_fraction - 0.25) < 1e-12);
    float far[3];
    cache.cache().lookup(p, up, raddiff::Span<float>(far));
    for (int c = 0; c < 3; ++c) {
      const double want = kPi * 2.0 / (1 << c);
      CHECK(std::fabs(parts.near_irradiance[c] - 0.75 * want) < 1e-9 * want);
      CHECK(std::fabs(parts.value[c] - (parts.near_irradiance[c] + parts.open_fraction * far[c])) < 1e-5 * want);
    }
    CHECK(counts.size() == 3 && counts[2] == 64 && cache.cache().size() == 1);
  }
  // an exception in the lambda comes back as itself; nothing is inserted
  bool caught = false;
  try {
    cache.irradiance_near_far({3, 3, 0}, up, 0.0,
                              [](raddiff_vec3, raddiff::Span<const raddiff_vec3>, double, raddiff::Span<double>,
                                 raddiff::Span<float>) { throw OutOfRays{7}; });
  } catch (const OutOfRays &error) {
    caught = error.code == 7;
  }
  CHECK(caught && cache.cache().size() == 1);
  float two[2];
  CHECK_THROWS(cache.irradiance_near_far({0, 0, 0}, up, 0.0, trace, raddiff::Span<float>(two)),
               RADDIFF_ERROR_INVALID_ARGUMENT, "out holds 2");
  // the plain call refuses a cache of far fields
  CHECK_THROWS(cache.irradiance({0, 0, 0}, up, 0.0,
                                [](raddiff_vec3, raddiff::Span<const raddiff_vec3>, raddiff::Span<double>,
                                   raddiff::Span<float>) {}),
               RADDIFF_ERROR_INVALID_ARGUMENT, "far fields");
  CHECK_DONE("irradiance_near_far.cpp");
}
