// The converged reference: indirect irradiance at the primary hits of stratified pixels, from the
// same hit-radiance estimator as the gathers with many more rays, in two independent halves whose
// difference measures the reference's own noise. Cached on disk under a name that changes with
// the scene's files, the view, the pixels and every setting that changes a value.
#pragma once

#include "camera.hpp"
#include "radiance.hpp"

#include <string>
#include <vector>

namespace rd {

// One measured pixel.
struct ReferencePixel {
  size_t pixel = 0;   // index y * width + x
  V3 half[2];         // irradiance from each half of the rays
  V3 value() const { return (half[0] + half[1]) * 0.5; }
};

struct ReferenceSettings {
  // grid x grid strata, one jittered pixel each. The squared error is heavy-tailed (a few pixels at
  // thin geometry hold much of it), so many pixels with fewer rays each measure it more stably than
  // few pixels with many rays.
  int grid = 64;
  uint32_t rays = 1u << 16;    // per pixel, both halves together
  std::string cache_dir;       // where reference files are kept ("" = not kept)
  uint64_t seed = 0x5eed;      // which pixel of each stratum
};

struct Reference {
  std::vector<ReferencePixel> pixels;
  double seconds = 0;  // CPU seconds to compute (0 when loaded)
  bool loaded = false;
  std::string file;
  // Relative RMS noise of the reference's luminance (the two halves' difference / 2 against the
  // RMS value): its own error, which must stay well below the errors it measures.
  double relative_noise() const;
};

// A content hash of a file (FNV-1a 64), for cache keys.
uint64_t file_hash(const std::string &path);

// The stratified measured pixels: one per stratum, among those whose primary hit shows indirect
// light (strata with none are skipped).
std::vector<size_t> stratified_pixels(const std::vector<Primary> &primary, int width, int height, int grid,
                                      uint64_t seed);

// Loads the reference from settings.cache_dir when a file with this key exists, else computes it
// (progress on stdout) and saves it there. `scene_key` names the scene's content (file hashes).
Reference reference(const Scene &scene, const std::vector<Primary> &primary, const View &view,
                    const HitRadianceSettings &radiance, const ReferenceSettings &settings,
                    const std::string &scene_key, unsigned threads);

// Irradiance at (p, n) from `rays` rays in two halves (used for the reference and for the
// gather-noise floor at record positions).
ReferencePixel converged_irradiance(const Scene &scene, const HitRadianceSettings &radiance, V3 p, V3 n, uint32_t rays,
                                    uint64_t seed);

}  // namespace rd
