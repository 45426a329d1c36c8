// C++17 use of the C functions of src/ffi/kernels.rs: identities over closed shapes (solid angles of a closed
// mesh sum to 4π inside, flatland form factors of a closed polygon sum to 1, with vanishing
// derivative sums), the far-field limit, and the same error conventions as in C.
#include "raddiff.h"
#include "check.h"
#include <array>
#include <cmath>
#include <cstring>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

raddiff_vec3 add(raddiff_vec3 a, raddiff_vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }

double max_abs(const double *v, int n) {
  double m = 0.0;
  for (int i = 0; i < n; ++i) m = std::fmax(m, std::fabs(v[i]));
  return m;
}

void cube_around_points() {
  // 12 triangles of the cube [-1, 1]^3, in arbitrary winding (the unsigned solid angle ignores it).
  std::vector<std::array<raddiff_vec3, 3>> tris;
  for (int axis = 0; axis < 3; ++axis) {
    for (double s : {-1.0, 1.0}) {
      auto corner = [&](double u, double v) {
        double p[3];
        p[axis] = s;
        p[(axis + 1) % 3] = u;
        p[(axis + 2) % 3] = v;
        return raddiff_vec3{p[0], p[1], p[2]};
      };
      tris.push_back({corner(-1, -1), corner(1, -1), corner(1, 1)});
      tris.push_back({corner(-1, -1), corner(-1, 1), corner(1, 1)});
    }
  }
  const raddiff_vec3 offset{1e3, -2e3, 5e2};
  for (raddiff_vec3 x : {raddiff_vec3{0.1, -0.3, 0.45}, raddiff_vec3{-0.9, 0.9, -0.2}}) {
    raddiff_deriv3 sum{};
    double gscale = 0.0, hscale = 0.0;
    for (auto &t : tris) {
      raddiff_deriv3 d;
      CHECK_STATUS(raddiff_triangle_solid_angle(add(x, offset), add(t[0], offset), add(t[1], offset),
                                                add(t[2], offset), RADDIFF_ORDER_HESSIAN, &d),
                   RADDIFF_OK);
      sum.value += d.value;
      for (int i = 0; i < 3; ++i) sum.gradient[i] += d.gradient[i];
      for (int i = 0; i < 9; ++i) sum.hessian[i] += d.hessian[i];
      gscale = std::fmax(gscale, max_abs(d.gradient, 3));
      hscale = std::fmax(hscale, max_abs(d.hessian, 9));
    }
    CHECK(std::fabs(sum.value - 4 * kPi) < 1e-12);
    CHECK(max_abs(sum.gradient, 3) <= 1e-12 * gscale);
    CHECK(max_abs(sum.hessian, 9) <= 1e-12 * hscale);
  }
}

void far_field() {
  // A unit right triangle seen from distance R along its normal: Ω ≈ area / R², ∂Ω/∂z ≈ 2 area / R³.
  const double R = 1e5;
  raddiff_deriv3 d;
  CHECK_STATUS(raddiff_triangle_solid_angle({0.0, 0.0, -R}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0},
                                            RADDIFF_ORDER_HESSIAN, &d),
               RADDIFF_OK);
  CHECK(std::fabs(d.value / (0.5 / (R * R)) - 1.0) < 1e-4);
  CHECK(std::fabs(d.gradient[2] / (1.0 / (R * R * R)) - 1.0) < 1e-4);
  CHECK(d.hessian[1] == d.hessian[3] && d.hessian[2] == d.hessian[6] && d.hessian[5] == d.hessian[7]);
}

void polygon_flatland() {
  // Regular hexagon around x: the six segment form factors sum to 1, derivatives to 0.
  const raddiff_vec2 x{0.2, -0.1};
  raddiff_deriv2 sum{};
  double gscale = 0.0, hscale = 0.0;
  for (int i = 0; i < 6; ++i) {
    const double a0 = 2 * kPi * i / 6, a1 = 2 * kPi * (i + 1) / 6;
    raddiff_deriv2 d;
    CHECK_STATUS(raddiff_segment_form_factor_2d(x, {std::cos(a0), std::sin(a0)}, {std::cos(a1), std::sin(a1)},
                                                RADDIFF_ORDER_HESSIAN, &d),
                 RADDIFF_OK);
    sum.value += d.value;
    for (int k = 0; k < 2; ++k) sum.gradient[k] += d.gradient[k];
    for (int k = 0; k < 4; ++k) sum.hessian[k] += d.hessian[k];
    gscale = std::fmax(gscale, max_abs(d.gradient, 2));
    hscale = std::fmax(hscale, max_abs(d.hessian, 4));
  }
  CHECK(std::fabs(sum.value - 1.0) < 1e-14);
  CHECK(max_abs(sum.gradient, 2) <= 1e-13 * gscale);
  CHECK(max_abs(sum.hessian, 4) <= 1e-13 * hscale);
}

void marched_errors() {
  std::vector<double> sigma(8, 0.25);
  raddiff_deriv3 d{};
  d.value = 7.0;
  CHECK_STATUS(raddiff_transmittance_marched({0, 0, 0}, {4, 0, 0}, sigma.data(), nullptr, 0,
                                             RADDIFF_ORDER_VALUE, &d),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_transmittance_marched({0, 0, 0}, {4, 0, 0}, sigma.data(), nullptr, sigma.size(),
                                             RADDIFF_ORDER_HESSIAN, &d),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(d.value == 7.0);
  CHECK_STATUS(raddiff_transmittance_marched({0, 0, 0}, {4, 0, 0}, sigma.data(), nullptr, sigma.size(),
                                             RADDIFF_ORDER_GRADIENT, &d),
               RADDIFF_OK);
  CHECK_CLOSE(d.value, std::exp(-1.0), 1e-15);
  CHECK_CLOSE(d.gradient[0], 0.25 * std::exp(-1.0), 1e-15);  // towards y: T grows
  CHECK_STATUS(raddiff_triangle_solid_angle({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, 3, &d),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(std::strstr(raddiff_last_error(), "order") != nullptr);
  CHECK_STATUS(raddiff_segment_form_factor_2d({0, 0}, {1, 0}, {0, 1}, RADDIFF_ORDER_VALUE, nullptr),
               RADDIFF_ERROR_NULL_POINTER);
}

}  // namespace

int main() {
  cube_around_points();
  far_field();
  polygon_flatland();
  marched_errors();
  CHECK_DONE("kernels.cpp");
}
