// The batch kernels through raddiff.hpp: spans in, BatchResult or caller arrays out, raddiff::Error
// with raddiff_last_error() on failure (and the wrapper's own size checks).
#include "hpp_check.h"
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

namespace {

// max |a - b| relative to the largest entry of each part of b
double rel_diff(const raddiff::BatchResult &r, std::size_t i, const raddiff_deriv3 &b) {
  double gs = 0, hs = 0, e = std::fabs(r.values[i] - b.value) / std::fmax(std::fabs(b.value), 1e-300);
  for (double g : b.gradient) gs = std::fmax(gs, std::fabs(g));
  for (double h : b.hessian) hs = std::fmax(hs, std::fabs(h));
  for (std::size_t k = 0; k < 3; k++) e = std::fmax(e, std::fabs(r.gradients[3 * i + k] - b.gradient[k]) / std::fmax(gs, 1e-300));
  for (std::size_t k = 0; k < 9; k++) e = std::fmax(e, std::fabs(r.hessians[9 * i + k] - b.hessian[k]) / std::fmax(hs, 1e-300));
  return e;
}

}  // namespace

int main() {
  // A tetrahedron in f32 (renderer-style buffers) seen from outside and inside.
  const std::vector<float> vf{0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::vector<std::uint32_t> ix{0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  const raddiff_triangle_mesh tet = raddiff::triangle_mesh(vf, ix);
  const auto vertex = [&vf](std::uint32_t i) {
    return raddiff_vec3{vf[3 * i], vf[3 * i + 1], vf[3 * i + 2]};
  };

  const raddiff_vec3 inside{0.2, 0.25, 0.3};
  const raddiff_deriv3 total = raddiff::mesh_solid_angle(inside, tet);
  CHECK_CLOSE(total.value, 4.0 * 3.14159265358979323846, 1e-13);
  for (double g : total.gradient) CHECK(std::fabs(g) < 1e-12);

  const raddiff_vec3 x{0.9, -0.7, 1.3};
  const raddiff_vec3 n{0.0, 0.6, -0.8};
  const raddiff::BatchResult sa = raddiff::mesh_solid_angle_each(x, tet);
  const raddiff::BatchResult ff = raddiff::mesh_form_factor_each(x, n, tet);
  CHECK(sa.values.size() == 4 && sa.hessians.size() == 36 && ff.gradients.size() == 12);
  raddiff_deriv3 sum{};
  for (std::size_t t = 0; t < 4; t++) {
    const raddiff_vec3 a = vertex(ix[3 * t]), b = vertex(ix[3 * t + 1]), c = vertex(ix[3 * t + 2]);
    CHECK(rel_diff(sa, t, raddiff::triangle_solid_angle(x, a, b, c)) < 1e-12);
    const raddiff_deriv3 f = raddiff::triangle_form_factor(x, n, a, b, c);
    CHECK(rel_diff(ff, t, f) < 1e-12);
    sum.value += f.value;
    for (std::size_t k = 0; k < 3; k++) sum.gradient[k] += f.gradient[k];
  }
  const raddiff_deriv3 ffsum = raddiff::mesh_form_factor(x, n, tet, RADDIFF_ORDER_GRADIENT);
  CHECK_CLOSE(ffsum.value, sum.value, 1e-14);
  for (std::size_t k = 0; k < 3; k++) CHECK_CLOSE(ffsum.gradient[k], sum.gradient[k], 1e-14);
  for (double h : ffsum.hessian) CHECK(h == 0.0);  // not requested: written as 0

  // Caller arrays, value only: the gradient and Hessian spans may stay empty.
  std::array<double, 4> values{};
  raddiff::mesh_solid_angle_each(x, tet, RADDIFF_ORDER_VALUE, values);
  for (std::size_t t = 0; t < 4; t++) CHECK(values[t] == sa.values[t]);

  // Many points against one triangle.
  const raddiff_vec3 a{0.1, 0.2, 1.0}, b{1.3, -0.1, 1.2}, c{0.4, 1.1, 0.9};
  std::vector<raddiff_vec3> pts, nrm;
  for (int i = 0; i < 21; i++) {
    pts.push_back(raddiff_vec3{std::sin(0.37 * i) * 2.0, std::cos(0.61 * i) * 2.0, -0.5});
    nrm.push_back(raddiff_vec3{0.0, 0.0, 1.0});
  }
  const raddiff::BatchResult ps = raddiff::points_solid_angle(pts, a, b, c);
  const raddiff::BatchResult pf = raddiff::points_form_factor(pts, nrm, a, b, c);
  for (std::size_t i = 0; i < pts.size(); i++) {
    CHECK(rel_diff(ps, i, raddiff::triangle_solid_angle(pts[i], a, b, c)) < 1e-12);
    CHECK(rel_diff(pf, i, raddiff::triangle_form_factor(pts[i], nrm[i], a, b, c)) < 1e-12);
  }

  // Errors: the wrapper's size checks, and the C messages naming the element.
  std::array<double, 3> short_values{};
  CHECK_THROWS(raddiff::mesh_solid_angle_each(x, tet, RADDIFF_ORDER_VALUE, short_values),
               RADDIFF_ERROR_INVALID_ARGUMENT, "values holds 3 elements, expected 4");
  CHECK_THROWS(raddiff::mesh_solid_angle_each(x, tet, RADDIFF_ORDER_GRADIENT, values),
               RADDIFF_ERROR_INVALID_ARGUMENT, "gradients holds 0 elements, expected 12");
  CHECK_THROWS(raddiff::points_form_factor(pts, raddiff::Span<const raddiff_vec3>(nrm.data(), 3), a, b, c),
               RADDIFF_ERROR_INVALID_ARGUMENT, "normals holds 3");
  const std::vector<std::uint32_t> bad{0, 2, 1, 0, 1, 4};
  CHECK_THROWS(raddiff::mesh_solid_angle(x, raddiff::triangle_mesh(vf, bad)), RADDIFF_ERROR_INVALID_ARGUMENT,
               "index 2 of triangle 1 is 4");
  CHECK_THROWS(raddiff::triangle_mesh(vf, std::vector<std::uint32_t>{0, 1}), RADDIFF_ERROR_INVALID_ARGUMENT,
               "indices holds 2");
  CHECK_THROWS(raddiff::mesh_solid_angle(vertex(3), tet), RADDIFF_ERROR_DEGENERATE, "triangle 1");
  CHECK_DONE("batch.cpp");
}
