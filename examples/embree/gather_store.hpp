// The benchmark's gathers: each pixel's record gather traced and evaluated at most once, shared by
// every metric and threshold, with the near-field experiments' far fields made from it.
#pragma once

#include "bench.hpp"

#include <atomic>
#include <memory>
#include <mutex>
#include <vector>

namespace rd {

// A gather computed at most once per pixel and shared by every metric and threshold, with what it
// cost. Gathers depend only on their pixel (its primary hit and the seed 1 + pixel, or a stream of
// --noise-seed).
struct Slot {
  std::once_flag once;
  std::unique_ptr<Evaluated> evaluated;
  double trace_seconds = 0;
  uint64_t rays = 0;
};

// `seed` itself for noise seed 0 (the usual samples), else a seed of another stream.
inline uint64_t reseeded(uint64_t seed, uint64_t noise_seed) {
  return noise_seed == 0 ? seed : mix(seed ^ mix(noise_seed + 0x5eedull));
}

class GatherStore {
 public:
  GatherStore(const Scene &scene, const std::vector<Primary> &primary, const BenchSettings &settings,
              HessianNeeds needs)
      : scene_(scene), primary_(primary), settings_(settings), needs_(needs), slots_(new Slot[primary.size()]) {}

  // The gather of `pixel`, traced and evaluated on the first call.
  const Slot &get(size_t pixel);
  // Every one of `pixels` computed, in parallel.
  void ensure(const std::vector<size_t> &pixels);
  // Gathers computed so far.
  size_t computed() const { return computed_; }

 private:
  // The adaptive-gather experiment's file for the gather `g` of `pixel` (format in
  // strata_allocation.py): m, n and the trace count as uint32, the near field's reach (0: none) as
  // float64, then per stratum its luminance in each of strata_paths traces of independent hit
  // radiance (float32, stratum-major), then per stratum its hit distance (float64).
  void write_strata(size_t pixel, const TracedGather &g, double reach) const;

  const Scene &scene_;
  const std::vector<Primary> &primary_;
  const BenchSettings &settings_;
  HessianNeeds needs_;
  std::unique_ptr<Slot[]> slots_;
  std::atomic<size_t> computed_{0};
};

}  // namespace rd
