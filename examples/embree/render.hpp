// The renderer's everyday mode: fill one cache from many threads, render the indirect
// irradiance from it, save it, reload it and render again, and check that it all holds.
#pragma once

#include "bench.hpp"

namespace rd {

struct RenderSettings {
  std::string out = "embree-out";
  uint32_t gather_m = 16, gather_n = 48;
  double accuracy = 0.25;      // split-sphere a
  double hessian_error = 0.0;  // > 0: occlusion-aware Hessian radii with this relative error
  RadiusBounds bounds;
  int check_pixels = 96;
  double gradient_limit = RADDIFF_GRADIENT_LIMIT_DEFAULT;
  bool neighbour_clamp = false;
  size_t target_records = 0;  // > 0: tune the metric's parameter to about this many records
  HitRadianceSettings radiance;
  unsigned threads = 2;
};

// Returns 0 when the self-checks pass: every pixel covered, finite and non-negative values, the
// reloaded cache renders the identical image, the accuracy check ran.
int run_render(const Scene &scene, const View &view, const RenderSettings &settings);

}  // namespace rd
