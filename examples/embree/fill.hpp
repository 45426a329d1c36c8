// One fill of the benchmark: a fresh cache of one metric at one threshold, records placed coarse to
// fine over the image, and (for the fills that are measured) the image it shows.
#pragma once

#include "bench.hpp"
#include "gather_store.hpp"
#include "image.hpp"

#include <array>
#include <functional>
#include <vector>

namespace rd {

struct RecordInfo {
  size_t pixel;
  V3 p, n;
  double radii[2];
  raddiff_vec3 axes[2];
  double value;          // the luminance the cache interpolates (the far field under --near-field)
  double open_fraction;  // its gather's open fraction (1 without --near-field)
  double relative_noise;  // its gather's (Evaluated::relative_noise)
  double gradient_shrink, hessian_shrink;  // the shrinkage experiments' factors (1 when off)
  double noise_curvature_weight, relative_gradient_noise;  // the noise-bound experiments' (0 when off)
};

struct BenchFill {
  Metric metric;
  double parameter = 0;
  std::vector<RecordInfo> records;
  double trace_seconds = 0, raddiff_seconds = 0, cache_seconds = 0;
  Image image;
  size_t uncovered = 0, non_finite = 0, negative = 0;
  double total_seconds() const { return trace_seconds + raddiff_seconds + cache_seconds; }
};

// The near-field experiment's traces (BenchSettings::near_field_px), made once and shared by
// every fill.
struct NearFields {
  std::vector<std::array<float, 4>> near;         // per pixel: near irradiance (RGB), open fraction
  std::vector<std::array<float, kDirBins>> bins;  // the binned experiment's open_bins per pixel
  double seconds = 0;                             // the CPU seconds they cost
};

// What a fill reads: the settings, the camera's primary hits (width x height), the gathers, and
// the near fields (traced on the first call; empty without a near field).
struct FillInputs {
  const BenchSettings &settings;
  const std::vector<Primary> &primary;
  int width, height;
  GatherStore &store;
  std::function<const NearFields &()> near_fields;
};

// Fills a fresh cache for metric m with parameter p, coarse to fine over the image; with `render`
// also the image it shows at every pixel (and the experiments that only change that image). Which
// pixels get records does not depend on the thread count: a level's candidates are the pixels the
// cache misses when the level starts, taken in pixel order; gathers are computed in parallel, a
// batch at a time, and inserted one by one after a second lookup.
BenchFill fill_bench_cache(const FillInputs &in, Metric m, double p, bool render);

}  // namespace rd
