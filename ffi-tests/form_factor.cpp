// raddiff_triangle_form_factor / raddiff_polygon_form_factor from C++17: invariances and error paths.
#include "raddiff.h"
#include "check.h"
#include <array>
#include <cstring>
#include <vector>

namespace {

raddiff_deriv3 polygon(raddiff_vec3 x, raddiff_vec3 n, const std::vector<raddiff_vec3> &v, uint32_t order) {
  raddiff_deriv3 d{};
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, v.data(), v.size(), order, &d), RADDIFF_OK);
  return d;
}

double max_diff(const raddiff_deriv3 &a, const raddiff_deriv3 &b) {
  double m = std::fabs(a.value - b.value);
  for (int i = 0; i < 3; i++) m = std::fmax(m, std::fabs(a.gradient[i] - b.gradient[i]));
  for (int i = 0; i < 9; i++) m = std::fmax(m, std::fabs(a.hessian[i] - b.hessian[i]) * 1e-2);
  return m;
}

}  // namespace

int main() {
  const raddiff_vec3 x{0.1, -0.2, 0.05};
  const double s = 1.0 / std::sqrt(3.0);
  const raddiff_vec3 n{s, s, s};
  // a convex pentagon in the plane z = 1 + 0.3 y (tilted), partly below the tangent plane
  std::vector<raddiff_vec3> penta;
  for (int i = 0; i < 5; i++) {
    double phi = 2.0 * 3.14159265358979323846 * i / 5.0;
    double px = std::cos(phi), py = std::sin(phi);
    penta.push_back(raddiff_vec3{px, py, 0.2 + 0.3 * py});
  }
  raddiff_deriv3 ref = polygon(x, n, penta, RADDIFF_ORDER_HESSIAN);
  CHECK(ref.value > 0.0 && ref.value < 1.0);

  // cyclic shifts and reversal do not change anything
  for (size_t k = 1; k < penta.size(); k++) {
    std::vector<raddiff_vec3> shifted(penta.begin() + static_cast<long>(k), penta.end());
    shifted.insert(shifted.end(), penta.begin(), penta.begin() + static_cast<long>(k));
    CHECK(max_diff(polygon(x, n, shifted, RADDIFF_ORDER_HESSIAN), ref) < 1e-13);
  }
  std::vector<raddiff_vec3> reversed(penta.rbegin(), penta.rend());
  CHECK(max_diff(polygon(x, n, reversed, RADDIFF_ORDER_HESSIAN), ref) < 1e-13);

  // the fan triangles sum to the polygon (value and gradient; the clip terms add up too)
  {
    raddiff_deriv3 sum{};
    for (size_t k = 1; k + 1 < penta.size(); k++) {
      raddiff_deriv3 t{};
      CHECK_STATUS(raddiff_triangle_form_factor(x, n, penta[0], penta[k], penta[k + 1], RADDIFF_ORDER_HESSIAN, &t),
                   RADDIFF_OK);
      sum.value += t.value;
      for (int i = 0; i < 3; i++) sum.gradient[i] += t.gradient[i];
      for (int i = 0; i < 9; i++) sum.hessian[i] += t.hessian[i];
    }
    CHECK(max_diff(sum, ref) < 1e-13);
  }

  // gradient against central differences of the value
  {
    const double h = 1e-6;
    for (int i = 0; i < 3; i++) {
      raddiff_vec3 xp = x, xm = x;
      (&xp.x)[i] += h;
      (&xm.x)[i] -= h;
      double fd = (polygon(xp, n, penta, RADDIFF_ORDER_VALUE).value - polygon(xm, n, penta, RADDIFF_ORDER_VALUE).value) / (2 * h);
      CHECK_CLOSE(ref.gradient[i], fd, 1e-8);
    }
  }

  // error paths leave the output untouched
  raddiff_deriv3 out{};
  out.value = -1.0;
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, penta.data(), 1, RADDIFF_ORDER_VALUE, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, nullptr, 5, RADDIFF_ORDER_VALUE, &out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, penta.data(), penta.size(), 99u, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_triangle_form_factor(x, n, penta[0], penta[1], penta[2], RADDIFF_ORDER_VALUE, nullptr),
               RADDIFF_ERROR_NULL_POINTER);
  raddiff_vec3 nan_x = x;
  nan_x.z = std::nan("");
  CHECK_STATUS(raddiff_triangle_form_factor(nan_x, n, penta[0], penta[1], penta[2], RADDIFF_ORDER_VALUE, &out),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_triangle_form_factor(x, n, penta[0], penta[0], penta[0], RADDIFF_ORDER_VALUE, &out),
               RADDIFF_ERROR_DEGENERATE);
  CHECK(out.value == -1.0);
  CHECK(std::strlen(raddiff_last_error()) > 0);

  CHECK_DONE("form_factor.cpp");
}
