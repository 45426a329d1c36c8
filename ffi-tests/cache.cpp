// C++17: one raddiff_cache shared by std::threads that insert and look up at the same time.
#include "raddiff.h"
#include "check.h"
#include <atomic>
#include <cstring>
#include <thread>
#include <vector>

namespace {
constexpr int kThreads = 4;
constexpr int kPerThread = 500;

raddiff_cache_record record_for(int id, const float *value) {
  raddiff_cache_record r;
  std::memset(&r, 0, sizeof r);
  // records on a line in the plane z = 0, every one unique
  r.position = raddiff_vec3{0.01 * id, 0.0, 0.0};
  r.normal = raddiff_vec3{0.0, 0.0, 1.0};
  r.value = value;
  r.radii[0] = r.radii[1] = r.radii[2] = 0.05;
  return r;
}
}  // namespace

int main() {
  const raddiff_cache_config cfg{1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT, 0.2};
  raddiff_cache *cache = raddiff_cache_new(&cfg);
  CHECK(cache != nullptr);
  std::atomic<int> failures{0}, found{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int i = 0; i < kPerThread; ++i) {
        int id = i * kThreads + t;
        float value = 1.0f;  // every record holds 1: any interpolation must return 1
        raddiff_cache_record r = record_for(id, &value);
        if (raddiff_cache_insert(cache, &r) != RADDIFF_OK) failures++;
        // look up around records other threads may be inserting right now
        float out = 0.0f;
        raddiff_vec3 q{0.01 * (id / 2) + 0.003, 0.0, 0.0};
        raddiff_status s = raddiff_cache_lookup(cache, q, raddiff_vec3{0.0, 0.0, 1.0}, &out, nullptr);
        if (s == RADDIFF_OK) {
          found++;
          if (std::fabs(out - 1.0f) > 1e-6f) failures++;
        } else if (s != RADDIFF_ERROR_NOT_FOUND) {
          failures++;
        }
        // our own record is visible to us right after the insert returned
        float own = 0.0f;
        if (raddiff_cache_lookup(cache, r.position, r.normal, &own, nullptr) != RADDIFF_OK) failures++;
      }
    });
  }
  for (auto &th : threads) th.join();
  // a lookup-only phase: compact once, then every thread walks the line with its own cursor and
  // must get exactly what the plain lookup gives
  CHECK(raddiff_cache_compact(cache) == RADDIFF_OK);
  threads.clear();
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      raddiff_cache_cursor *cursor = raddiff_cache_cursor_new();
      if (cursor == nullptr) {
        failures++;
        return;
      }
      for (int i = 0; i < 4000; ++i) {
        raddiff_vec3 q{0.0051 * i + 0.0007 * t, 0.001 * t, 0.0};
        const raddiff_vec3 n{0.0, 0.0, 1.0};
        float a = -1.0f, b = -2.0f;
        double wa = 0.0, wb = 1.0;
        raddiff_status sa = raddiff_cache_lookup(cache, q, n, &a, &wa);
        raddiff_status sb = raddiff_cache_lookup_with(cache, cursor, q, n, &b, &wb);
        if (sa != sb) failures++;
        if (sa == RADDIFF_OK && (std::memcmp(&a, &b, sizeof a) != 0 || wa != wb)) failures++;
      }
      raddiff_cache_cursor_free(cursor);
    });
  }
  for (auto &th : threads) th.join();
  CHECK(failures.load() == 0);
  CHECK(found.load() > 0);
  CHECK(raddiff_cache_len(cache) == static_cast<size_t>(kThreads * kPerThread));
  raddiff_cache_free(cache);
  CHECK_DONE("cache.cpp");
}
