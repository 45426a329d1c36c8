// Shared small pieces of the Embree renderer: a double-precision vector, random numbers, thread
// CPU clocks, a parallel loop, a CPU-time sum, and raddiff status checks.
#pragma once

#include "raddiff.h"

#include <time.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace rd {

constexpr double kPi = 3.14159265358979323846;

struct V3 {
  double x = 0, y = 0, z = 0;
};
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator*(V3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline V3 operator*(V3 a, V3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
inline V3 &operator+=(V3 &a, V3 b) { return a = a + b; }
inline double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double length(V3 a) { return std::sqrt(dot(a, a)); }
inline V3 normalize(V3 a) { return a * (1.0 / length(a)); }
inline double max_component(V3 a) { return std::max(a.x, std::max(a.y, a.z)); }
inline raddiff_vec3 to_c(V3 a) { return {a.x, a.y, a.z}; }
inline V3 from_c(raddiff_vec3 a) { return {a.x, a.y, a.z}; }
// Rec. 709 luminance: the scalar every error figure and the Hessian metrics' radii use.
inline double luminance(V3 c) { return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z; }
inline double luminance(const float *rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }
inline double luminance(const double *rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

// A unit tangent perpendicular to the unit normal n (Duff et al. 2017).
inline V3 tangent_of(V3 n) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double b = n.x * n.y * a;
  return {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
}

// splitmix64: seeds and hashes.
inline uint64_t mix(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
// A uniform double in [0, 1) from a hash.
inline double unit(uint64_t z) { return static_cast<double>(mix(z) >> 11) * (1.0 / 9007199254740992.0); }

// A small random stream (splitmix64 over a counter): independent streams from distinct seeds.
struct Rng {
  uint64_t state;
  explicit Rng(uint64_t seed) : state(mix(seed)) {}
  double next() {
    state += 0x9E3779B97F4A7C15ull;
    uint64_t z = state;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    z ^= z >> 31;
    return static_cast<double>(z >> 11) * (1.0 / 9007199254740992.0);
  }
};

// Throws with raddiff's message when a call fails.
inline void check(raddiff_status status, const char *what) {
  if (status != RADDIFF_OK) throw std::runtime_error(std::string(what) + ": " + raddiff_last_error());
}

// CPU seconds used by the calling thread: timings that hold on a loaded machine.
inline double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// CPU seconds used by the whole process (every thread).
inline double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Runs body(i) for i in [0, count) on `threads` threads (dynamic scheduling); the first exception
// stops the loop and is rethrown on the caller's thread.
inline void parallel_for(size_t count, unsigned threads, const std::function<void(size_t)> &body) {
  std::atomic<size_t> next{0};
  std::vector<std::thread> pool;
  std::exception_ptr error;
  std::atomic<bool> failed{false};
  for (unsigned t = 0; t < std::max(1u, threads); ++t) {
    pool.emplace_back([&] {
      try {
        while (!failed) {
          const size_t i = next++;
          if (i >= count) break;
          body(i);
        }
      } catch (...) {
        if (!failed.exchange(true)) error = std::current_exception();
      }
    });
  }
  for (auto &th : pool) th.join();
  if (error) std::rethrow_exception(error);
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

}  // namespace rd
