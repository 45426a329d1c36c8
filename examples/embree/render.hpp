// The renderer's everyday mode: fill one cache from many threads, render the indirect
// irradiance from it, save it, reload it and render again, and check that it all holds.
#pragma once

#include "bench.hpp"

namespace rd {

struct RenderSettings {
  std::string out = "embree-out";
  // raddiff's settings: gather size, radius bounds, gradient limit, leak guard, ...; the metric and
  // its threshold come from the two fields below.
  raddiff_irradiance_settings irradiance = raddiff_irradiance_settings_default();
  double accuracy = 0.25;      // split-sphere a
  double hessian_error = 0.0;  // > 0: anisotropic occlusion-aware Hessian records with this error
  int check_pixels = 96;
  bool neighbour_clamp = false;
  double open_fraction_coverage_tolerance = 0;  // with the open-fraction test (see BenchSettings)
  size_t target_records = 0;  // > 0: tune the metric's parameter to about this many records
  HitRadianceSettings radiance;
  unsigned threads = 2;
};

// Returns 0 when the self-checks pass: every pixel covered, finite and non-negative values, the
// reloaded cache renders the identical image, the accuracy check ran.
int run_render(const Scene &scene, const View &view, const RenderSettings &settings);

}  // namespace rd
