// A C++ renderer's view of the gather: it asks raddiff for directions, traces an analytic scene
// itself (ray / axis-aligned quad intersection), hands back distances and radiance, and checks the
// Ward-Heckbert gradient against the exact one.
//  * unoccluded square emitter: exact irradiance from Lambert's polygon formula, computed here, and
//    its gradient by central differences of that closed form;
//  * the same emitter behind a black occluder: reference values from tests/gather_surfaces.rs (exact
//    clipped-polygon irradiance and 4th-order differences of it).
#include "raddiff.h"
#include "check.h"

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace {

struct Vec {
  double x, y, z;
};
Vec operator-(Vec a, Vec b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
double dot(Vec a, Vec b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
Vec cross(Vec a, Vec b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

struct Quad {
  double h, x0, x1, y0, y1;
  float radiance;
};

struct Hit {
  double distance;
  float radiance;
};

Hit trace(const std::vector<Quad> &scene, Vec o, raddiff_vec3 w, float environment) {
  Hit best{std::numeric_limits<double>::infinity(), environment};
  if (w.z <= 0.0) return best;
  for (const Quad &q : scene) {
    const double t = (q.h - o.z) / w.z;
    if (t <= 0.0 || t >= best.distance) continue;
    const double px = o.x + t * w.x, py = o.y + t * w.y;
    if (px >= q.x0 && px <= q.x1 && py >= q.y0 && py <= q.y1) best = {t, q.radiance};
  }
  return best;
}

// Lambert: irradiance pi*L*F of a convex polygon above the tangent plane of (x, n = +z).
double lambert_irradiance(const Quad &q, Vec x) {
  const std::array<Vec, 4> v = {{{q.x0, q.y0, q.h}, {q.x1, q.y0, q.h}, {q.x1, q.y1, q.h}, {q.x0, q.y1, q.h}}};
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    const Vec a = v[i] - x, b = v[(i + 1) % 4] - x, c = cross(a, b);
    const double len = std::sqrt(dot(c, c));
    sum += std::atan2(len, dot(a, b)) * c.z / len;
  }
  return q.radiance * std::fabs(sum) / 2.0;  // pi * L * |sum| / (2 pi)
}

struct Result {
  double irradiance;
  std::array<double, 3> gradient;
  raddiff_status status;
};

Result gather(const std::vector<Quad> &scene, Vec x, uint32_t m) {
  const raddiff_gather_layout layout{RADDIFF_LAYOUT_COSINE_POLAR, m, 2 * m, 0};
  const raddiff_frame frame{{x.x, x.y, x.z}, {0, 0, 1}, {1, 0, 0}};
  std::vector<raddiff_vec3> dirs(static_cast<size_t>(m) * 2 * m);
  Result r{};
  r.status = raddiff_gather_directions(&layout, &frame, dirs.data());
  if (r.status != RADDIFF_OK) return r;
  std::vector<double> distance;
  std::vector<float> radiance;
  for (const raddiff_vec3 &w : dirs) {
    const Hit h = trace(scene, x, w, 0.0f);
    distance.push_back(h.distance);
    radiance.push_back(h.radiance);
  }
  raddiff_gather_input in{};
  in.directions = dirs.data();
  in.distance = distance.data();
  in.radiance = radiance.data();
  in.channels = 1;
  raddiff_gather_output out{};
  out.irradiance = &r.irradiance;
  out.gradient = r.gradient.data();
  r.status = raddiff_gather_evaluate(&layout, &frame, &in, &out);
  return r;
}

double rel_error(const std::array<double, 3> &got, const std::array<double, 3> &want) {
  double num = 0.0, den = 0.0;
  for (int i = 0; i < 3; ++i) {
    num += (got[i] - want[i]) * (got[i] - want[i]);
    den += want[i] * want[i];
  }
  return std::sqrt(num / den);
}

}  // namespace

int main() {
  const Quad emitter{1.0, -0.3, 0.7, -0.2, 0.8, 1.0f};
  const Quad occluder{0.5, 0.05, 0.45, -0.1, 0.3, 0.0f};
  const Vec x{0.05, -0.1, 0.0};

  // Unoccluded: exact value and central differences of the closed form, computed here.
  {
    const double e = lambert_irradiance(emitter, x);
    std::array<double, 3> g{};
    const double h = 1e-5;
    for (int a = 0; a < 3; ++a) {
      Vec p = x, q = x;
      (a == 0 ? p.x : a == 1 ? p.y : p.z) += h;
      (a == 0 ? q.x : a == 1 ? q.y : q.z) -= h;
      g[a] = (lambert_irradiance(emitter, p) - lambert_irradiance(emitter, q)) / (2 * h);
    }
    double previous = 1.0;
    for (uint32_t m : {16u, 64u}) {
      const Result r = gather({emitter}, x, m);
      CHECK_STATUS(r.status, RADDIFF_OK);
      CHECK_CLOSE(r.irradiance, e, 1.5e-2 * e);
      const double err = rel_error(r.gradient, g);
      std::printf("gather.cpp: unoccluded M=%u: E %.6f (exact %.6f), gradient error %.2e\n", m, r.irradiance, e, err);
      CHECK(err < previous);
      previous = err;
    }
    CHECK(previous < 2e-2);
  }

  // One occluder: exact reference from the Rust test (clipped emitter polygon, environment 0).
  {
    const std::vector<Quad> scene{emitter, occluder};
    const Result r = gather(scene, x, 64);
    CHECK_STATUS(r.status, RADDIFF_OK);
    const double e_ref = 0.3040080277;
    const std::array<double, 3> g_ref{-0.6510830, -0.0671441, 0.2474822};
    const double err = rel_error(r.gradient, g_ref);
    std::printf("gather.cpp: occluded M=64: E %.6f (exact %.6f), gradient error %.2e\n", r.irradiance, e_ref, err);
    CHECK_CLOSE(r.irradiance, e_ref, 1.5e-2 * e_ref);
    CHECK(err < 3e-2);
  }

  CHECK_DONE("gather.cpp");
}
