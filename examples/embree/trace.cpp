#include "trace.hpp"

namespace rd {
namespace {

uint32_t reverse_bits(uint32_t v) {
  v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  v = ((v >> 4) & 0x0F0F0F0Fu) | ((v & 0x0F0F0F0Fu) << 4);
  v = ((v >> 8) & 0x00FF00FFu) | ((v & 0x00FF00FFu) << 8);
  return (v >> 16) | (v << 16);
}

// The second Sobol dimension; with the van der Corput sequence as the first, a (0,2)-sequence.
uint32_t sobol_second(uint32_t i) {
  uint32_t r = 0;
  for (uint32_t v = 1u << 31; i; i >>= 1, v ^= v >> 1)
    if (i & 1) r ^= v;
  return r;
}

}  // namespace

void trace_directions(const Scene &scene, const HitRadianceSettings &radiance, V3 x, const raddiff_vec3 *directions,
                      size_t count, uint64_t seed, double *distance, float *radiance_out, uint64_t &rays,
                      raddiff_vec3 *hit_normals, double max_distance) {
  hit_radiance_rays() = 0;
  const bool bounded = std::isfinite(max_distance);
  for (size_t i = 0; i < count; ++i) {
    const V3 d = from_c(directions[i]);
    const Hit hit = scene.intersect(x, d, max_distance);
    distance[i] = hit.distance;
    if (bounded && !hit.found()) continue;  // beyond the reach: its radiance is not read
    if (hit_normals) hit_normals[i] = hit.found() ? to_c(hit.normal) : raddiff_vec3{0, 0, 0};
    const V3 l = hit_radiance(scene, radiance, x, d, hit, mix(seed + i));
    radiance_out[3 * i] = static_cast<float>(l.x);
    radiance_out[3 * i + 1] = static_cast<float>(l.y);
    radiance_out[3 * i + 2] = static_cast<float>(l.z);
  }
  rays += count + hit_radiance_rays();
}

TracedGather trace_gather(const Scene &scene, const HitRadianceSettings &radiance, V3 x, V3 n, uint32_t m,
                          uint32_t nn, uint64_t seed) {
  TracedGather g;
  g.layout = {RADDIFF_LAYOUT_COSINE_POLAR, m, nn, seed};
  g.frame = {to_c(x), to_c(n), to_c(tangent_of(n))};
  const size_t count = static_cast<size_t>(m) * nn;
  g.directions.resize(count);
  check(raddiff_gather_directions(&g.layout, &g.frame, g.directions.data()), "raddiff_gather_directions");
  g.distance.resize(count);
  g.radiance.resize(3 * count);
  g.hit_normals.resize(count);
  trace_directions(scene, radiance, x, g.directions.data(), count, seed, g.distance.data(), g.radiance.data(),
                   g.rays, g.hit_normals.data());
  return g;
}

namespace {

// Point k of the scrambled (0,2)-sequence as a cosine-distributed direction about n (t, b, n a frame).
V3 cosine_direction(uint32_t k, uint32_t shift1, uint32_t shift2, V3 t, V3 b, V3 n) {
  // A digital shift keeps the (0,2)-sequence's stratification of every 2^k-point block.
  const double u1 = (reverse_bits(k) ^ shift1) * (1.0 / 4294967296.0);
  const double u2 = (sobol_second(k) ^ shift2) * (1.0 / 4294967296.0);
  const double r = std::sqrt(u1), phi = 2 * kPi * u2;
  return normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0, 1 - u1)));
}

}  // namespace

V3 irradiance_sum(const Scene &scene, const HitRadianceSettings &radiance, V3 x, V3 n, uint32_t first, uint32_t count,
                  uint64_t scramble, uint64_t &rays) {
  const V3 t = tangent_of(n), b = cross(n, t);
  const uint32_t shift1 = static_cast<uint32_t>(mix(scramble)), shift2 = static_cast<uint32_t>(mix(scramble + 1));
  V3 sum;
  hit_radiance_rays() = 0;
  for (uint32_t k = first; k < first + count; ++k) {
    const V3 d = cosine_direction(k, shift1, shift2, t, b, n);
    const Hit hit = scene.intersect(x, d);
    sum += hit_radiance(scene, radiance, x, d, hit, mix(scramble ^ (0x5bd1e995ull * (k + 1))));
  }
  rays += count + hit_radiance_rays();
  return sum;
}

NearField trace_near_field(const Scene &scene, const HitRadianceSettings &radiance, V3 x, V3 n, double reach,
                           uint32_t m, uint64_t seed, uint64_t &rays) {
  const raddiff_gather_layout layout{RADDIFF_LAYOUT_COSINE_POLAR, m, m, seed | 1};  // a nonzero seed: jitter
  const raddiff_frame frame{to_c(x), to_c(n), to_c(tangent_of(n))};
  const size_t count = static_cast<size_t>(m) * m;
  thread_local std::vector<raddiff_vec3> directions;
  thread_local std::vector<double> distance;
  thread_local std::vector<float> hit;
  directions.resize(count);
  distance.resize(count);
  hit.assign(3 * count, 0.0f);
  check(raddiff_gather_directions(&layout, &frame, directions.data()), "raddiff_gather_directions");
  hit_radiance_rays() = 0;
  for (size_t k = 0; k < count; ++k) {
    const V3 d = from_c(directions[k]);
    const Hit h = scene.intersect(x, d, reach);  // a short ray: its traversal stops at the reach
    distance[k] = h.found() ? h.distance : INFINITY;
    if (distance[k] < reach) {
      const V3 l = hit_radiance(scene, radiance, x, d, h, mix(seed ^ (0x5bd1e995ull * (k + 1))));
      hit[3 * k] = static_cast<float>(l.x);
      hit[3 * k + 1] = static_cast<float>(l.y);
      hit[3 * k + 2] = static_cast<float>(l.z);
    }
  }
  rays += count + hit_radiance_rays();
  NearField f;
  size_t open = 0;
  for (size_t k = 0; k < count; ++k)
    if (!(distance[k] < reach)) ++f.open_bins[direction_bin(from_c(directions[k]))], ++open;
  if (open > 0)
    for (float &b : f.open_bins) b /= static_cast<float>(open);
  check(raddiff_gather_near_field(&layout, distance.data(), hit.data(), 3, reach, f.near, &f.open_fraction),
        "raddiff_gather_near_field");
  return f;
}

}  // namespace rd
