// The alternative a user would pick: path tracing the indirect irradiance at every pixel's
// primary hit (cosine-distributed rays, the same hit-radiance estimator as the gathers),
// progressively, with a snapshot at each power-of-two sample count and its CPU time.
#pragma once

#include "camera.hpp"
#include "image.hpp"
#include "radiance.hpp"

#include <functional>
#include <vector>

namespace rd {

struct PathTraceSnapshot {
  uint32_t spp = 0;
  double cpu_seconds = 0;  // every thread's CPU time up to this snapshot
  uint64_t rays = 0;
  Image image;  // indirect irradiance
};

// Calls `snapshot` at 1, 2, 4, ... samples per pixel up to `max_spp`, or until the accumulated CPU
// time exceeds `max_cpu_seconds` (after at least one snapshot).
void path_trace(const Scene &scene, const std::vector<Primary> &primary, const View &view,
                const HitRadianceSettings &radiance, uint32_t max_spp, double max_cpu_seconds, unsigned threads,
                const std::function<void(const PathTraceSnapshot &)> &snapshot);

// The guide buffers of a denoiser: the primary hit's diffuse reflectance and its unit normal
// (zero where the primary ray missed).
Image albedo_buffer(const Scene &scene, const std::vector<Primary> &primary, const View &view);
Image normal_buffer(const std::vector<Primary> &primary, const View &view);

}  // namespace rd
