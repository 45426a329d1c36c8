// raddiff::IrradianceCache and raddiff::GatherEvaluation: a lambda traces, its exceptions come
// back to the caller (after the C call returned) with nothing inserted, sizes are checked, the
// settings' channel weights are the wrapper's own copy, and threads share one cache.
#include "raddiff.hpp"
#include "hpp_check.h"

#include <atomic>
#include <cmath>
#include <cstring>
#include <thread>
#include <vector>

namespace {

struct OutOfRays {
  int code;
};

const double kPi = 3.14159265358979323846;

// The plane z = 0 under a ceiling at z = 1 of radiance (2, 1, 0.5) where y > 0.
void half_ceiling(raddiff_vec3 o, raddiff::Span<const raddiff_vec3> d, raddiff::Span<double> distance,
                  raddiff::Span<float> radiance) {
  for (std::size_t i = 0; i < d.size(); ++i) {
    const double t = (1.0 - o.z) / std::max(d[i].z, 1e-12);
    const bool lit = o.y + t * d[i].y > 0.0;
    distance[i] = t;
    radiance[3 * i] = lit ? 2.0f : 0.0f;
    radiance[3 * i + 1] = lit ? 1.0f : 0.0f;
    radiance[3 * i + 2] = lit ? 0.5f : 0.0f;
  }
}

raddiff_irradiance_settings small_settings() {
  raddiff_irradiance_settings s = raddiff::irradiance_settings_default();
  s.gather_m = 8;
  s.gather_n = 24;
  s.world_radius_min = 0.01;
  s.world_radius_max = 2.0;
  return s;
}

}  // namespace

int main() {
  const raddiff_vec3 up{0, 0, 1};
  raddiff::IrradianceCache cache(small_settings());
  int calls = 0;
  auto trace = [&calls](raddiff_vec3 o, raddiff::Span<const raddiff_vec3> d, raddiff::Span<double> t,
                        raddiff::Span<float> l) {
    ++calls;
    CHECK(d.size() == 8 * 24 && t.size() == d.size() && l.size() == 3 * d.size());
    half_ceiling(o, d, t, l);
  };
  const std::vector<float> e = cache.irradiance({0.1, -0.05, 0}, up, 0.0, trace);
  CHECK(calls == 1 && cache.cache().size() == 1 && e.size() == 3);
  CHECK(e[0] > 0.5 * kPi && e[0] < 2.0 * kPi && std::fabs(e[1] - 0.5f * e[0]) < 1e-5f * e[0]);
  CHECK(cache.irradiance({0.1, -0.05, 0}, up, 0.0, trace) == e && calls == 1);

  // an exception in the lambda comes back as itself; nothing is inserted
  bool caught = false;
  try {
    cache.irradiance({0.9, 0.9, 0}, up, 0.0,
                     [](raddiff_vec3, raddiff::Span<const raddiff_vec3>, raddiff::Span<double>,
                        raddiff::Span<float>) { throw OutOfRays{42}; });
  } catch (const OutOfRays &error) {
    caught = error.code == 42;
  }
  CHECK(caught && cache.cache().size() == 1);
  // traced values the gather refuses throw raddiff::Error, and insert nothing either
  auto backwards = [](raddiff_vec3 o, raddiff::Span<const raddiff_vec3> d, raddiff::Span<double> t,
                      raddiff::Span<float> l) {
    half_ceiling(o, d, t, l);
    t[0] = -1.0;
  };
  const raddiff_vec3 far_point{0.9, 0.9, 0}, nan_point{NAN, 0, 0};
  CHECK_THROWS(cache.irradiance(far_point, up, 0.0, backwards), RADDIFF_ERROR_INVALID_ARGUMENT, "traced gather");
  CHECK_THROWS(cache.irradiance(nan_point, up, 0.0, trace), RADDIFF_ERROR_INVALID_ARGUMENT, "not finite");
  float two[2];
  CHECK_THROWS(cache.irradiance(far_point, up, 0.0, trace, raddiff::Span<float>(two)),
               RADDIFF_ERROR_INVALID_ARGUMENT, "out holds 2");
  CHECK(cache.cache().size() == 1);

  // the settings' weights are copied: the caller's array may go away
  raddiff::IrradianceCache green = [] {
    std::vector<double> weights{0.0, 1.0, 0.0};
    raddiff_irradiance_settings s = small_settings();
    s.channel_weights = weights.data();
    return raddiff::IrradianceCache(s);
  }();
  CHECK(green.settings().channel_weights != nullptr && green.settings().channel_weights[1] == 1.0);
  CHECK(green.irradiance({0.1, -0.05, 0}, up, 0.0, trace).size() == 3);
  // a loaded cache with its settings
  raddiff::IrradianceCache moved(std::move(green));
  CHECK(moved.cache().size() == 1 && moved.settings().channel_weights[1] == 1.0);

  // the mid-level calls share one gather between metrics
  {
    raddiff_irradiance_settings s = small_settings();
    const raddiff_gather_layout layout{RADDIFF_LAYOUT_COSINE_POLAR, 8, 24, 3};
    const raddiff_frame frame{{0.1, -0.05, 0}, up, {1, 0, 0}};
    const std::vector<raddiff_vec3> dirs = raddiff::gather_directions(layout, frame);
    std::vector<double> t(dirs.size());
    std::vector<float> l(3 * dirs.size());
    half_ceiling(frame.position, dirs, t, l);
    raddiff::GatherInput in;
    in.directions = dirs, in.distance = t, in.radiance = l, in.channels = 3;
    raddiff::GatherEvaluation ev(s, layout, frame, in, {}, RADDIFF_HESSIAN_OCCLUSION_AWARE);
    const raddiff_gather_summary sum = ev.summary();
    CHECK(sum.hessians == RADDIFF_HESSIAN_OCCLUSION_AWARE && sum.scalar > 0.0);
    raddiff::Cache shared(raddiff::Cache::adopt(raddiff_irradiance_cache_new(&s)));
    for (double accuracy : {1e-2, 1e-3, 1e-4}) {
      s.accuracy = accuracy;
      shared.insert(ev.record(s, 0.0));
    }
    CHECK(shared.size() == 3);
    s.metric = RADDIFF_METRIC_SPLIT_SPHERE;
    s.accuracy = 0.2;
    CHECK(std::fabs(ev.record(s, 0.0).radii[0] - 0.2 * sum.harmonic_mean_distance) <
          1e-12 * sum.harmonic_mean_distance);
    s.metric = RADDIFF_METRIC_HESSIAN_UNAWARE;
    CHECK_THROWS(ev.record(s, 0.0), RADDIFF_ERROR_INVALID_ARGUMENT, "Hessian");
    std::vector<raddiff_vec3> few(3);
    CHECK_THROWS(raddiff::GatherEvaluation(s, layout, frame, in, few, RADDIFF_HESSIAN_UNAWARE),
                 RADDIFF_ERROR_INVALID_ARGUMENT, "hit_normals holds 3");
  }

  // the leak guard through the wrapper
  raddiff::Cache plain({1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT, 0.2});
  CHECK(std::isinf(plain.leak_guard().first));
  plain.set_leak_guard(0.1);
  CHECK(plain.leak_guard() == std::make_pair(0.1, 0.0));
  CHECK_THROWS(plain.set_leak_guard(-1.0), RADDIFF_ERROR_INVALID_ARGUMENT, "leak guard");

  // four threads fill one cache; every call succeeds
  raddiff::IrradianceCache threaded(small_settings());
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k) {
    threads.emplace_back([&, k] {
      for (int j = 0; j < 20; ++j) {
        const int i = (j + 5 * k) % 20;
        try {
          const std::vector<float> v =
              threaded.irradiance({0.3 * (i % 5) - 0.6, 0.4 * (i / 5) - 0.6, 0}, up, 0.0, half_ceiling);
          if (!(v[0] >= 0.0f)) ++failures;
        } catch (...) {
          ++failures;
        }
      }
    });
  }
  for (std::thread &t : threads) t.join();
  CHECK(failures == 0 && threaded.cache().size() >= 1);
  CHECK_DONE("irradiance.cpp");
}
