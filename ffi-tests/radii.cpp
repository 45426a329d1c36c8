// raddiff_surface_radii / raddiff_volume_radii from C++17: std::array buffers, a tilted normal.
#include "raddiff.h"
#include "check.h"
#include <array>
#include <cmath>

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

  // error path: bad mode, outputs untouched
  r3[0] = 42.0;
  CHECK_STATUS(raddiff_volume_radii(h.data(), 2.0, 0.01, 9u, 2.0, r3.data(), a3.data()),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(r3[0] == 42.0);
  CHECK_DONE("radii.cpp");
}
