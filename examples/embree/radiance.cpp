#include "radiance.hpp"

#include <cctype>
#include <cstdio>

namespace rd {
namespace {

// A cosine-distributed direction about the unit normal n from (u1, u2) (Malley's method).
V3 cosine_direction(V3 n, double u1, double u2) {
  const double r = std::sqrt(u1), phi = 2 * kPi * u2;
  const double lx = r * std::cos(phi), ly = r * std::sin(phi), lz = std::sqrt(std::max(0.0, 1 - u1));
  const V3 t = tangent_of(n), b = cross(n, t);
  return normalize(t * lx + b * ly + n * lz);
}

// Power heuristic for a sample of density `own` taken `own_count` times, against `other`.
double power_weight(double own_count, double own, double other) {
  const double a = own_count * own;
  return a * a / (a * a + other * other);
}

// The surface point of a hit, pulled back towards the ray's origin (relative 1e-4, as the gather
// points are): a hit on a seam would otherwise send rays through the neighbouring surface.
V3 hit_point(V3 origin, V3 direction, const Hit &hit) { return origin + direction * (hit.distance * (1 - 1e-4)); }

thread_local uint64_t rays_traced = 0;

// Direct light at p (unit normal n facing the viewer), `count` stratified light samples, MIS
// weights against one cosine-sampled BSDF direction. Returns the reflected radiance factor:
// the estimate of (1/pi) * integral of L_e cos dw, to be multiplied by Kd.
V3 direct_light(const Scene &scene, V3 p, V3 n, int count, Rng &rng) {
  V3 sum;
  const int side = std::max(1, static_cast<int>(std::lround(std::sqrt(static_cast<double>(count)))));
  const bool square = side * side == count;
  for (int s = 0; s < count; ++s) {
    double u1 = rng.next(), u2 = rng.next();
    if (square) {
      u1 = (s % side + u1) / side;
      u2 = (s / side + u2) / side;
    } else {
      u1 = (s + u1) / count;  // stratified along the triangle choice only
    }
    const LightSample l = scene.sample_light(p, u1, u2);
    if (!(l.pdf > 0)) continue;
    const double cos_r = dot(n, l.direction);
    if (!(cos_r > 0)) continue;
    ++rays_traced;
    if (scene.occluded(p, l.direction, l.distance * (1 - 1e-4))) continue;
    const double bsdf_pdf = cos_r / kPi;
    const double w = power_weight(count, l.pdf, bsdf_pdf);
    sum += l.radiance * (cos_r / kPi / l.pdf * w / count);
  }
  return sum;
}

V3 production(const Scene &scene, const HitRadianceSettings &settings, V3 origin, V3 direction, const Hit &first,
              uint64_t seed) {
  Rng rng(seed);
  V3 total;
  V3 throughput{1, 1, 1};  // of the radiance factor at the current vertex, before its Kd
  V3 o = origin, d = direction;
  Hit hit = first;
  int light_count = std::max(1, settings.light_samples);
  for (int bounce = 0; bounce < settings.max_bounces; ++bounce) {
    const Material &m = scene.material(hit.triangle);
    if (max_component(m.kd) <= 0) break;  // black or an emitter: nothing is reflected
    const V3 p = hit_point(o, d, hit), n = hit.normal;
    throughput = throughput * m.kd;
    total += throughput * direct_light(scene, p, n, light_count, rng);
    // Continue with a cosine-sampled direction; it also carries the BSDF half of the MIS.
    if (bounce >= 1) {
      const double survive = std::min(0.95, max_component(throughput));
      if (rng.next() >= survive) break;
      throughput = throughput * (1.0 / survive);
    }
    const V3 next = cosine_direction(n, rng.next(), rng.next());
    ++rays_traced;
    const Hit h = scene.intersect(p, next);
    if (!h.found()) break;
    if (scene.is_emitter(h.triangle)) {
      const V3 le = scene.emitted(h.triangle, next * -1.0);
      if (max_component(le) > 0) {
        const double bsdf_pdf = std::max(0.0, dot(n, next)) / kPi;
        const double w = power_weight(1, bsdf_pdf, light_count * scene.light_pdf(h.triangle, next, h.distance));
        total += throughput * le * w;  // (Kd/pi) cos / (cos/pi) = Kd, already in throughput
      }
    }
    o = p, d = next, hit = h;
    light_count = 1;
  }
  return total;
}

// Today's noisy estimator: direct light only, one jittered shadow ray per emitter triangle.
V3 one_shadow_ray(const Scene &scene, V3 origin, V3 direction, const Hit &hit, uint64_t seed) {
  const V3 kd = scene.material(hit.triangle).kd;
  if (max_component(kd) <= 0) return {};
  const V3 p = hit_point(origin, direction, hit), n = hit.normal;
  V3 sum;
  for (uint32_t e : scene.emitters()) {
    const V3 a = scene.corner(e, 0), b = scene.corner(e, 1), c = scene.corner(e, 2);
    const V3 ng = cross(b - a, c - a);
    const double area = 0.5 * length(ng);
    const V3 ln = normalize(ng);
    double u = unit(seed ^ mix(1)), v = unit(seed ^ mix(2));
    if (u + v > 1) u = 1 - u, v = 1 - v;
    const V3 q = a + (b - a) * u + (c - a) * v;
    const V3 d = q - p;
    const double r2 = dot(d, d), r = std::sqrt(r2);
    const V3 w = d * (1.0 / r);
    const double cos_r = dot(n, w), cos_l = -dot(ln, w);
    ++rays_traced;
    if (cos_r <= 0 || cos_l <= 0 || scene.occluded(p, w, r * (1 - 1e-4))) continue;
    sum += scene.material(e).ke * (cos_r * cos_l / r2 * area);
  }
  return kd * (1.0 / kPi) * sum;
}

}  // namespace

HitRadianceSettings HitRadianceSettings::parse(const std::string &spec) {
  HitRadianceSettings s;
  std::string text = spec;
  const size_t x = text.rfind('x');
  if (x != std::string::npos && x + 1 < text.size() && std::isdigit(static_cast<unsigned char>(text[x + 1]))) {
    s.paths = std::stoi(text.substr(x + 1));
    if (s.paths < 1) throw std::runtime_error("--hit-radiance ...xK needs K >= 1");
    text = text.substr(0, x);
  }
  if (text == "one-shadow-ray") {
    s.mode = Mode::OneShadowRay;
  } else if (text == "production") {
    s.mode = Mode::Production;
  } else if (text.rfind("production:", 0) == 0) {
    s.mode = Mode::Production;
    s.light_samples = std::stoi(text.substr(11));
    if (s.light_samples < 1) throw std::runtime_error("--hit-radiance production:N needs N >= 1");
  } else {
    throw std::runtime_error("--hit-radiance production[:N] | one-shadow-ray, not " + text);
  }
  return s;
}

std::string HitRadianceSettings::describe() const {
  const std::string averaged = paths > 1 ? ", " + std::to_string(paths) + " estimates averaged per ray" : "";
  if (mode == Mode::OneShadowRay) return "one shadow ray per emitter triangle, direct light only" + averaged;
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "production: %d stratified light samples + MIS at the hit, path continuation with "
                "Russian roulette (1 light sample per further vertex)",
                light_samples);
  return buf + averaged;
}

std::string HitRadianceSettings::key() const {
  const std::string averaged = paths > 1 ? "x" + std::to_string(paths) : "";
  if (mode == Mode::OneShadowRay) return "osr" + averaged;
  return "prod" + std::to_string(light_samples) + "b" + std::to_string(max_bounces) + averaged;
}

std::string HitRadianceSettings::converged_key() const {
  return mode == Mode::OneShadowRay ? "direct" : "paths-b" + std::to_string(max_bounces);
}

V3 hit_radiance(const Scene &scene, const HitRadianceSettings &settings, V3 origin, V3 direction, const Hit &hit,
                uint64_t seed) {
  if (!hit.found()) return {};
  V3 sum;
  for (int k = 0; k < settings.paths; ++k) {
    const uint64_t s = k == 0 ? seed : mix(seed + 0x9E3779B97F4A7C15ull * k);
    sum += settings.mode == HitRadianceSettings::Mode::OneShadowRay
               ? one_shadow_ray(scene, origin, direction, hit, s)
               : production(scene, settings, origin, direction, hit, s);
  }
  return settings.paths == 1 ? sum : sum * (1.0 / settings.paths);
}

uint64_t &hit_radiance_rays() { return rays_traced; }

}  // namespace rd
