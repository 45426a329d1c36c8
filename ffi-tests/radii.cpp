// raddiff_surface_radii / raddiff_volume_radii from C++17: std::array buffers, a tilted normal.
#include "raddiff.h"
#include "check.h"
#include <array>
#include <cmath>
#include <vector>

namespace {

// Traces a gather at `x` (normal +z): an emitter square |x|,|y| < 0.5 at z = 1 (radiance 4), a
// black occluder square [0.1, 0.6] x [-0.5, 0.5] at z = 0.5, a grey environment (0.5) elsewhere.
struct Traced {
  std::vector<raddiff_vec3> dirs;
  std::vector<double> dist;
  std::vector<float> rad;
};

Traced trace(const raddiff_gather_layout &layout, const raddiff_frame &frame) {
  const size_t cells = size_t(layout.m) * layout.n;
  Traced t{std::vector<raddiff_vec3>(cells), std::vector<double>(cells), std::vector<float>(cells)};
  CHECK_STATUS(raddiff_gather_directions(&layout, &frame, t.dirs.data()), RADDIFF_OK);
  for (size_t i = 0; i < cells; i++) {
    const raddiff_vec3 w = t.dirs[i];
    t.dist[i] = INFINITY;
    t.rad[i] = 0.5f;
    const double zs[2] = {0.5, 1.0};
    for (int s = 0; s < 2; s++) {
      if (w.z <= 0.0) break;
      const double d = (zs[s] - frame.position.z) / w.z;
      const double px = frame.position.x + d * w.x, py = frame.position.y + d * w.y;
      const bool hit = s == 0 ? (px > 0.1 && px < 0.6 && std::fabs(py) < 0.5)
                              : (std::fabs(px) < 0.5 && std::fabs(py) < 0.5);
      if (hit && d < t.dist[i]) {
        t.dist[i] = d;
        t.rad[i] = s == 0 ? 0.0f : 4.0f;
      }
    }
  }
  return t;
}

}  // namespace

int main() {
  // Hessian of f(x) = x^T A x / 2 with A = diag(8, 2, 0.5) rotated; normal tilted.
  const raddiff_vec3 n{0.0, 0.6, 0.8};
  std::array<double, 9> h{8.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.5};
  std::array<double, 2> r2{};
  std::array<raddiff_vec3, 2> a2{};
  CHECK_STATUS(raddiff_surface_radii(h.data(), n, 2.0, 0.01, RADDIFF_ERROR_RELATIVE, 2.0, r2.data(), a2.data()),
               RADDIFF_OK);
  CHECK(r2[0] > 0.0 && r2[0] <= r2[1] && r2[1] <= 2.0 * r2[0] * (1.0 + 1e-12));
  for (const auto &a : a2) {
    CHECK_CLOSE(a.x * n.x + a.y * n.y + a.z * n.z, 0.0, 1e-13);
    CHECK_CLOSE(a.x * a.x + a.y * a.y + a.z * a.z, 1.0, 1e-13);
  }
  // The x axis is tangent with curvature 8, the largest: it is the short axis.
  CHECK_CLOSE(std::fabs(a2[0].x), 1.0, 1e-12);

  std::array<double, 3> r3{};
  std::array<raddiff_vec3, 3> a3{};
  CHECK_STATUS(raddiff_volume_radii(h.data(), 2.0, 0.01, RADDIFF_ERROR_ABSOLUTE, 100.0, r3.data(), a3.data()),
               RADDIFF_OK);
  // Area-optimal shape: radii proportional to |lambda|^(-1/2), i.e. 1 : 2 : 4.
  CHECK_CLOSE(r3[1] / r3[0], 2.0, 1e-12);
  CHECK_CLOSE(r3[2] / r3[0], 4.0, 1e-12);
  CHECK_CLOSE(std::fabs(a3[2].z), 1.0, 1e-12);
  // (2 pi / 15) a b c (8 a^2 + 2 b^2 + 0.5 c^2) = error
  const double bound = 2.0 * 3.14159265358979323846 / 15.0 * r3[0] * r3[1] * r3[2] *
                       (8.0 * r3[0] * r3[0] + 2.0 * r3[1] * r3[1] + 0.5 * r3[2] * r3[2]);
  CHECK_CLOSE(bound, 0.01, 1e-12);

  // From a gather to record radii: occlusion-aware gradient and Hessian, then surface radii.
  {
    const raddiff_gather_layout layout{RADDIFF_LAYOUT_CONCENTRIC, 32, 32, 7};
    const raddiff_frame frame{{0.3, 0.0, 0.0}, {0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
    Traced t = trace(layout, frame);
    raddiff_gather_input in{};
    in.directions = t.dirs.data();
    in.distance = t.dist.data();
    in.radiance = t.rad.data();
    in.channels = 1;
    double e = 0.0, og[3] = {0, 0, 0}, h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    raddiff_gather_output out{};
    out.irradiance = &e;
    out.occlusion_gradient = og;
    out.hessian = h;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
    CHECK(e > 0.5 && std::isfinite(e));
    // In the occluder's penumbra, moving towards -x uncovers the emitter.
    CHECK(og[0] < 0.0 && std::isfinite(og[1]) && std::isfinite(og[2]));
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) CHECK_CLOSE(h[3 * i + j], h[3 * j + i], 1e-12);
    CHECK(std::fabs(h[0]) > 0.0);
    std::array<double, 2> r{};
    std::array<raddiff_vec3, 2> a{};
    CHECK_STATUS(raddiff_surface_radii(h, frame.normal, e, 0.05, RADDIFF_ERROR_RELATIVE, 2.0, r.data(), a.data()),
                 RADDIFF_OK);
    CHECK(r[0] > 0.0 && r[0] < 10.0 && r[1] <= 2.0 * r[0] * (1.0 + 1e-12));

    // Gradient only: the Hessian stays untouched when not requested.
    double og2[3] = {0, 0, 0};
    out.occlusion_gradient = og2;
    out.hessian = nullptr;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
    for (int i = 0; i < 3; i++) CHECK_CLOSE(og2[i], og[i], 1e-12);

    // All black: the Hessian falls back to the geometric one (finite, not zero).
    std::vector<float> black(t.rad.size(), 0.0f);
    in.radiance = black.data();
    out.hessian = h;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
    CHECK(e == 0.0 && std::isfinite(h[8]));

    // Marched media radiance adds one hemisphere ring per step: still finite and symmetric.
    std::vector<float> media(t.rad.size() * 2, 0.1f);
    in.media_radiance = media.data();
    in.steps = 2;
    in.step = 0.1;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
    CHECK(e > 0.0 && std::isfinite(h[0]) && std::isfinite(og[0]));
    CHECK_CLOSE(h[1], h[3], 1e-12);

    // Error path: a negative extinction is refused and nothing is written.
    in.sigma_t = -1.0;
    h[0] = 42.0;
    e = 42.0;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(h[0] == 42.0 && e == 42.0);
  }

  // A point in a medium: sphere layout, marched media radiance.
  {
    const raddiff_gather_layout layout{RADDIFF_LAYOUT_SPHERE, 8, 16, 0};
    const raddiff_frame frame{{0.0, 0.0, 0.2}, {0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
    Traced t = trace(layout, frame);
    std::vector<float> media(t.rad.size() * 4, 0.2f);
    raddiff_gather_input in{};
    in.directions = t.dirs.data();
    in.distance = t.dist.data();
    in.radiance = t.rad.data();
    in.channels = 1;
    in.sigma_t = 0.3;
    in.media_radiance = media.data();
    in.steps = 4;
    in.step = 0.1;
    double e = 0.0, og[3] = {0, 0, 0}, h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    raddiff_gather_output out{};
    out.irradiance = &e;
    out.occlusion_gradient = og;
    out.hessian = h;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
    CHECK(e > 0.0 && std::isfinite(og[2]) && std::isfinite(h[4]));
    std::array<double, 3> r{};
    std::array<raddiff_vec3, 3> a{};
    CHECK_STATUS(raddiff_volume_radii(h, e, 0.05, RADDIFF_ERROR_RELATIVE, 4.0, r.data(), a.data()), RADDIFF_OK);
    CHECK(r[0] > 0.0 && r[0] <= r[1] && r[1] <= r[2]);
  }

  // error path: bad mode, outputs untouched
  r3[0] = 42.0;
  CHECK_STATUS(raddiff_volume_radii(h.data(), 2.0, 0.01, 9u, 2.0, r3.data(), a3.data()),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(r3[0] == 42.0);
  CHECK_DONE("radii.cpp");
}
