// Tracing what raddiff asks for: the gather of a record (raddiff's stratified directions, traced
// with Embree, radiance from the hit-radiance estimator), and plain irradiance estimates of the
// same light for the reference and for path tracing.
#pragma once

#include "radiance.hpp"

#include <cmath>
#include <vector>

namespace rd {

// A gather as raddiff's evaluation takes it: directions, hit distances, RGB radiance.
struct TracedGather {
  raddiff_gather_layout layout{};
  raddiff_frame frame{};
  std::vector<raddiff_vec3> directions;
  std::vector<double> distance;  // INFINITY for a miss
  std::vector<float> radiance;   // 3 per direction
  std::vector<raddiff_vec3> hit_normals;  // unit, facing x (zero for a miss)
  uint64_t rays = 0;             // every ray traced for it (gather, shadow and continuation rays)
};

// Traces the m x n cosine-polar gather at (x, n) with layout seed `seed`. The hit radiance of
// direction i draws its samples from mix(seed + i).
TracedGather trace_gather(const Scene &scene, const HitRadianceSettings &radiance, V3 x, V3 n, uint32_t m,
                          uint32_t nn, uint64_t seed);

// The same trace into caller-provided arrays (the high-level calls' callbacks): `count` directions
// from x, their distances and radiance written. Rays stop at `max_distance`: one that finds nothing
// closer gets INFINITY and its radiance is left as it is.
void trace_directions(const Scene &scene, const HitRadianceSettings &radiance, V3 x, const raddiff_vec3 *directions,
                      size_t count, uint64_t seed, double *distance, float *radiance_out, uint64_t &rays,
                      raddiff_vec3 *hit_normals = nullptr, double max_distance = INFINITY);

// Sum of the radiance arriving at (x, n) over `count` cosine-distributed directions from the
// (0,2)-sequence points [first, first + count) of a scrambled Sobol pair: pi * sum / N is an
// unbiased irradiance estimate for N points in total, stratified however many are taken, so
// progressive passes continue one sequence. `scramble` decorrelates pixels.
V3 irradiance_sum(const Scene &scene, const HitRadianceSettings &radiance, V3 x, V3 n, uint32_t first, uint32_t count,
                  uint64_t scramble, uint64_t &rays);

// The near field at (x, n) (Arikan et al. 2005's near/far decomposition, raddiff_gather_near_field):
// an m x m jittered cosine-polar layout's directions traced no farther than `reach`, the hits'
// radiance only where they are closer. `near` is the near irradiance (RGB), `open_fraction` the
// cosine-weighted share of the hemisphere whose rays reach farther.
// The binned far-field experiment's direction bins: the cube's 6 faces in world space, each in
// 2 x 2 quadrants (24 bins over the sphere, 12 to 16 of them over a hemisphere).
constexpr int kDirBins = 24;
inline int direction_bin(V3 w) {
  const double ax = std::fabs(w.x), ay = std::fabs(w.y), az = std::fabs(w.z);
  int face;
  double u, v;
  if (ax >= ay && ax >= az) face = w.x > 0 ? 0 : 1, u = w.y, v = w.z;
  else if (ay >= az) face = w.y > 0 ? 2 : 3, u = w.z, v = w.x;
  else face = w.z > 0 ? 4 : 5, u = w.x, v = w.y;
  return 4 * face + 2 * (u > 0) + (v > 0);
}

struct NearField {
  double near[3] = {0, 0, 0};
  double open_fraction = 1;
  // The binned experiment: the share of the open rays (reaching the reach) in each direction bin
  // (all 0 when none is open).
  float open_bins[kDirBins] = {};
};
NearField trace_near_field(const Scene &scene, const HitRadianceSettings &radiance, V3 x, V3 n, double reach,
                           uint32_t m, uint64_t seed, uint64_t &rays);

}  // namespace rd
