// The radiance a gather ray brings back: what leaves the surface it hit towards the gather point.
//
// Two estimators, selected by --hit-radiance:
//  * production (default): what a production renderer computes at a final-gather hit. Direct light
//    with `light_samples` stratified samples over the emitters, combined by multiple importance
//    sampling (power heuristic) with the cosine-sampled direction that also continues the path;
//    further diffuse bounces by path continuation, one light sample and one continuation per
//    vertex, Russian roulette from the second continuation on. Unbiased: its mean is the radiance
//    of the full multi-bounce solution, whatever the sample counts, so a converged reference made
//    with the same estimator and many rays measures a cache's error and nothing else.
//    Path continuation rather than a second-level cache or a photon map: it adds no bias and no
//    state of its own, so every error the benchmark reports belongs to the irradiance cache.
//  * one-shadow-ray: direct light only, one shadow ray per emitter triangle (the noisy case the
//    renderer had before; no further bounces).
//
// Emission seen directly by a gather ray is not part of it (the gather measures indirect light;
// a renderer adds direct light at the shading point itself), so the light reads as black.
#pragma once

#include "scene.hpp"

#include <string>

namespace rd {

struct HitRadianceSettings {
  enum class Mode { Production, OneShadowRay } mode = Mode::Production;
  int light_samples = 4;  // at the gather hit (production): a square number stratifies best
  int max_bounces = 32;   // a hard stop far beyond where Russian roulette ends paths
  int paths = 1;          // independent estimates averaged per gather ray (> 1: less noisy gathers)

  // "production", "production:N" (N light samples), "one-shadow-ray"; any of them followed by
  // "xK" averages K independent estimates per ray ("production:4x8").
  static HitRadianceSettings parse(const std::string &text);
  std::string describe() const;
  // A short stable string that changes with every setting.
  std::string key() const;
  // A short stable string naming the quantity the estimator converges to: the estimator is
  // unbiased, so its sample counts do not change it (the reference's cache key).
  std::string converged_key() const;
};

// Radiance (RGB) leaving the hit `hit` of the ray from `origin` along the unit `direction`,
// towards `origin`: reflected light only. `seed` makes the estimate reproducible.
V3 hit_radiance(const Scene &scene, const HitRadianceSettings &settings, V3 origin, V3 direction, const Hit &hit,
                uint64_t seed);

// Rays the last hit_radiance calls on this thread traced (shadow and continuation rays).
uint64_t &hit_radiance_rays();

}  // namespace rd
