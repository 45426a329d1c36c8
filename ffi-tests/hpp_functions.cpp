// raddiff.hpp free functions: kernels, gathers, radii (single scattering: hpp_owners.cpp), against
// the values ffi-tests/transmittance.c, kernels.c, form_factor.c, gather.c and radii.c assert
// through the C API; their errors as raddiff::Error with the C status and message; the size checks.
#include "hpp_check.h"
#include <array>
#include <limits>
#include <vector>

namespace {

const double kPi = 3.14159265358979323846;
const double kInf = std::numeric_limits<double>::infinity();
const double kNaN = std::numeric_limits<double>::quiet_NaN();

void transmittance() {
  const raddiff_vec3 x{1.0, 2.0, 3.0}, y{4.0, 6.0, 3.0};  // |x-y| = 5
  const double sigma = 0.3, t = std::exp(-1.5);
  const raddiff_deriv3 d = raddiff::transmittance(x, y, sigma);  // default order: Hessian
  CHECK_CLOSE(d.value, t, 1e-15);
  const double u[3] = {-3.0 / 5.0, -4.0 / 5.0, 0.0};
  for (int i = 0; i < 3; i++) {
    CHECK_CLOSE(d.gradient[i], -sigma * t * u[i], 1e-15);
    for (int j = 0; j < 3; j++) {
      const double expect = t * (sigma * sigma * u[i] * u[j] - sigma / 5.0 * ((i == j) - u[i] * u[j]));
      CHECK_CLOSE(d.hessian[3 * i + j], expect, 1e-15);
    }
  }
  const raddiff_deriv3 v = raddiff::transmittance(x, y, sigma, RADDIFF_ORDER_VALUE);
  CHECK(v.value == d.value && v.gradient[0] == 0.0 && v.hessian[0] == 0.0);
  CHECK(raddiff::transmittance(x, x, sigma, RADDIFF_ORDER_VALUE).value == 1.0);
  CHECK_THROWS(raddiff::transmittance(x, y, sigma, 3), RADDIFF_ERROR_INVALID_ARGUMENT, "order");
  CHECK_THROWS(raddiff::transmittance(x, y, -1.0), RADDIFF_ERROR_INVALID_ARGUMENT, "invalid argument");
  CHECK_THROWS(raddiff::transmittance(x, x, sigma, RADDIFF_ORDER_GRADIENT), RADDIFF_ERROR_DEGENERATE, "degenerate");
}

void marched() {
  const raddiff_vec3 x{0, 0, 0}, y{2, 0, 0};
  const std::vector<double> sigma = {0.5, 0.5, 0.5, 0.5};
  const std::vector<raddiff_vec3> grad = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  const double t = std::exp(-1.0);
  // without gradients: the homogeneous kernel
  raddiff_deriv3 d = raddiff::transmittance_marched(x, y, sigma);
  const raddiff_deriv3 h = raddiff::transmittance(x, y, 0.5, RADDIFF_ORDER_GRADIENT);
  CHECK_CLOSE(d.value, h.value, 1e-15);
  CHECK_CLOSE(d.gradient[0], h.gradient[0], 1e-15);
  // with gradients: gradient (0.5 t, -t, 0)
  d = raddiff::transmittance_marched(x, y, sigma, grad);
  CHECK_CLOSE(d.value, t, 1e-15);
  CHECK_CLOSE(d.gradient[0], 0.5 * t, 1e-15);
  CHECK_CLOSE(d.gradient[1], -t, 1e-15);
  CHECK(d.gradient[2] == 0.0);
  d = raddiff::transmittance_marched(x, y, raddiff::Span<const double>(sigma.data(), 1),
                                     raddiff::Span<const raddiff_vec3>(grad.data(), 1), RADDIFF_ORDER_VALUE);
  CHECK_CLOSE(d.value, t, 1e-15);
  CHECK_THROWS(raddiff::transmittance_marched(x, y, sigma, grad, RADDIFF_ORDER_HESSIAN),
               RADDIFF_ERROR_INVALID_ARGUMENT, "Hessian");
  CHECK_THROWS(raddiff::transmittance_marched(x, x, sigma, grad), RADDIFF_ERROR_DEGENERATE, "degenerate");
  const std::vector<double> bad = {0.5, -0.1, 0.5, 0.5};
  CHECK_THROWS(raddiff::transmittance_marched(x, y, bad), RADDIFF_ERROR_INVALID_ARGUMENT, "sigma_t[1]");
  CHECK_THROWS(raddiff::transmittance_marched(x, y, raddiff::Span<const double>()), RADDIFF_ERROR_INVALID_ARGUMENT,
               "count");
  // size check: one gradient per sample
  CHECK_THROWS(raddiff::transmittance_marched(x, y, sigma, raddiff::Span<const raddiff_vec3>(grad.data(), 3)),
               RADDIFF_ERROR_INVALID_ARGUMENT, "sigma_t_gradient holds 3 elements, expected 4");
}

void solid_angle_and_segment() {
  const raddiff_vec3 o{0, 0, 0}, ex{1, 0, 0}, ey{0, 1, 0}, ez{0, 0, 1};
  raddiff_deriv3 d = raddiff::triangle_solid_angle(o, ex, ey, ez);
  CHECK_CLOSE(d.value, kPi / 2, 1e-15);
  CHECK(d.gradient[0] > 0 && std::fabs(d.gradient[0] - d.gradient[1]) < 1e-15);
  d = raddiff::triangle_solid_angle(o, ex, ez, ey, RADDIFF_ORDER_VALUE);
  CHECK_CLOSE(d.value, kPi / 2, 1e-15);
  CHECK(d.gradient[0] == 0.0 && d.hessian[4] == 0.0);
  d = raddiff::triangle_solid_angle(raddiff_vec3{0.2, 0.2, 0}, o, ex, ey);
  CHECK(d.value == 2 * kPi && d.gradient[2] == 0.0);
  CHECK_THROWS(raddiff::triangle_solid_angle(raddiff_vec3{0.5, 0, 0}, o, ex, ey), RADDIFF_ERROR_DEGENERATE, "edge");
  CHECK_THROWS(raddiff::triangle_solid_angle(o, ex, ey, ez, 3), RADDIFF_ERROR_INVALID_ARGUMENT, "order");

  const double f = 1.0 / (2 * kPi);
  raddiff_deriv2 s = raddiff::segment_form_factor_2d(raddiff_vec2{0, 0}, raddiff_vec2{-1, 1}, raddiff_vec2{1, 1});
  CHECK_CLOSE(s.value, 0.25, 1e-15);
  CHECK(std::fabs(s.gradient[0]) < 1e-16);
  CHECK_CLOSE(s.gradient[1], f, 1e-15);
  CHECK_CLOSE(s.hessian[0], -f, 1e-15);
  CHECK_CLOSE(s.hessian[3], f, 1e-15);
  s = raddiff::segment_form_factor_2d(raddiff_vec2{0.3, 0}, raddiff_vec2{0, 0}, raddiff_vec2{1, 0});
  CHECK(s.value == 0.5);
  CHECK_THROWS(raddiff::segment_form_factor_2d(raddiff_vec2{1, 0}, raddiff_vec2{0, 0}, raddiff_vec2{1, 0}),
               RADDIFF_ERROR_DEGENERATE, "endpoint");
  CHECK_THROWS(raddiff::segment_form_factor_2d(raddiff_vec2{0, kNaN}, raddiff_vec2{1, 0}, raddiff_vec2{0, 1}),
               RADDIFF_ERROR_INVALID_ARGUMENT, "invalid argument");
}

double corner(double w, double l, double h) {
  const double X = w / h, Y = l / h, sx = std::sqrt(1.0 + X * X), sy = std::sqrt(1.0 + Y * Y);
  return (X / sx * std::atan(Y / sx) + Y / sy * std::atan(X / sy)) / (2.0 * kPi);
}

void form_factors() {
  const raddiff_vec3 x{0.0, 0.0, 0.0}, n{0.0, 0.0, 1.0};
  const std::array<raddiff_vec3, 4> sq = {{{-0.5, -0.5, 1.0}, {0.5, -0.5, 1.0}, {0.5, 0.5, 1.0}, {-0.5, 0.5, 1.0}}};
  const raddiff_deriv3 d = raddiff::polygon_form_factor(x, n, sq);
  CHECK_CLOSE(d.value, 4.0 * corner(0.5, 0.5, 1.0), 1e-14);
  CHECK_CLOSE(d.gradient[0], 0.0, 1e-14);
  CHECK(d.gradient[2] != 0.0 && d.hessian[8] != 0.0);
  const double sum = raddiff::triangle_form_factor(x, n, sq[0], sq[1], sq[2]).value +
                     raddiff::triangle_form_factor(x, n, sq[3], sq[2], sq[0]).value;
  CHECK_CLOSE(sum, d.value, 1e-14);
  const raddiff_deriv3 g = raddiff::triangle_form_factor(x, n, sq[0], sq[1], sq[2], RADDIFF_ORDER_GRADIENT);
  CHECK(g.gradient[2] != 0.0 && g.hessian[8] == 0.0);
  CHECK(raddiff::polygon_form_factor(x, raddiff_vec3{0, 0, -1}, sq).value == 0.0);
  // C++ arrays and raw pointer + size work alike
  const raddiff_vec3 c_array[4] = {sq[0], sq[1], sq[2], sq[3]};
  CHECK(raddiff::polygon_form_factor(x, n, c_array).value == d.value);
  CHECK(raddiff::polygon_form_factor(x, n, raddiff::Span<const raddiff_vec3>(sq.data(), 4)).value == d.value);
  // errors
  CHECK_THROWS(raddiff::polygon_form_factor(x, n, raddiff::Span<const raddiff_vec3>(sq.data(), 2)),
               RADDIFF_ERROR_INVALID_ARGUMENT, "3");
  CHECK_THROWS(raddiff::polygon_form_factor(x, n, sq, 3), RADDIFF_ERROR_INVALID_ARGUMENT, "order");
  CHECK_THROWS(raddiff::triangle_form_factor(x, raddiff_vec3{0, 0, 2}, sq[0], sq[1], sq[2]),
               RADDIFF_ERROR_INVALID_ARGUMENT, "unit");
  CHECK_THROWS(raddiff::triangle_form_factor(x, n, sq[0], sq[1], sq[1]), RADDIFF_ERROR_DEGENERATE, "degenerate");
  std::array<raddiff_vec3, 4> poly = sq;
  poly[2].z = 1.1;
  CHECK_THROWS(raddiff::polygon_form_factor(x, n, poly), RADDIFF_ERROR_INVALID_ARGUMENT, "planar");
}

constexpr std::uint32_t kM = 4, kN = 8, kCells = kM * kN;

void gathers() {
  const raddiff_gather_layout layout{RADDIFF_LAYOUT_COSINE_POLAR, kM, kN, 0};
  const raddiff_frame frame{{0.5, -1.0, 2.0}, {0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
  const std::vector<raddiff_vec3> dirs = raddiff::gather_directions(layout, frame);
  CHECK(dirs.size() == kCells);
  {
    double s = std::sqrt(0.5 / kM), phi = 2.0 * kPi * 0.5 / kN;
    CHECK_CLOSE(dirs[0].x, s * std::cos(phi), 1e-14);
    CHECK_CLOSE(dirs[0].y, s * std::sin(phi), 1e-14);
    CHECK_CLOSE(dirs[0].z, std::sqrt(1.0 - 0.5 / kM), 1e-14);
    s = std::sqrt(3.5 / kM);
    phi = 2.0 * kPi * 5.5 / kN;
    CHECK_CLOSE(dirs[3 * kN + 5].x, s * std::cos(phi), 1e-14);
  }
  // the span overload writes the same; its size is checked
  std::vector<raddiff_vec3> again(kCells);
  raddiff::gather_directions(layout, frame, again);
  CHECK(std::memcmp(again.data(), dirs.data(), sizeof(raddiff_vec3) * kCells) == 0);
  std::vector<raddiff_vec3> short_buffer(kCells - 1);
  CHECK_THROWS(raddiff::gather_directions(layout, frame, short_buffer), RADDIFF_ERROR_INVALID_ARGUMENT,
               "directions holds 31 elements, expected 32");
  {
    const raddiff_gather_layout jl{RADDIFF_LAYOUT_SPHERE, kM, kN, 99};
    const std::vector<raddiff_vec3> a = raddiff::gather_directions(jl, frame), b = raddiff::gather_directions(jl, frame);
    CHECK(std::memcmp(a.data(), b.data(), sizeof(raddiff_vec3) * kCells) == 0);
    CHECK(a[0].z > 0.5 && a[kCells - 1].z < -0.5);
  }
  {
    raddiff_gather_layout bad = layout;
    bad.kind = 7;
    CHECK_THROWS(raddiff::gather_directions(bad, frame), RADDIFF_ERROR_INVALID_ARGUMENT, "layout kind");
    bad = layout;
    bad.m = RADDIFF_GATHER_MAX_STRATA_PER_AXIS;
    bad.n = RADDIFF_GATHER_MAX_STRATA_PER_AXIS;
    CHECK_THROWS(raddiff::gather_directions(bad, frame), RADDIFF_ERROR_INVALID_ARGUMENT, "MAX_STRATA");
    raddiff_frame bf = frame;
    bf.tangent.z = 0.1;
    CHECK_THROWS(raddiff::gather_directions(layout, bf), RADDIFF_ERROR_INVALID_ARGUMENT, "tangent");
  }

  // every ray hits at distance 2 with radiance (1, 3): E = pi L, no gradient
  std::vector<double> dist(kCells, 2.0);
  std::vector<float> rad(kCells * 2);
  for (std::uint32_t i = 0; i < kCells; i++) {
    rad[2 * i] = 1.0f;
    rad[2 * i + 1] = 3.0f;
  }
  raddiff::GatherInput in;
  in.directions = dirs;
  in.distance = dist;
  in.radiance = rad;
  in.channels = 2;
  raddiff::GatherResult r = raddiff::gather_evaluate(layout, frame, in);
  CHECK(r.irradiance.size() == 2 && r.gradient.size() == 6 && r.rotation_gradient.size() == 6);
  CHECK(r.occlusion_gradient.empty() && r.hessian.empty());
  CHECK_CLOSE(r.irradiance[0], kPi, 1e-13);
  CHECK_CLOSE(r.irradiance[1], 3.0 * kPi, 1e-13);
  for (int i = 0; i < 6; i++) CHECK(std::fabs(r.gradient[i]) < 1e-13 && std::fabs(r.rotation_gradient[i]) < 1e-13);
  CHECK_CLOSE(r.harmonic_mean_distance, 2.0, 1e-14);
  CHECK_CLOSE(r.min_distance, 2.0, 1e-14);

  // the bright half-dome at distance 1: every output, against the C call
  for (std::uint32_t i = 0; i < kCells; i++) {
    const std::uint32_t k = i % kN;
    dist[i] = k < kN / 2 ? 1.0 : kInf;
    rad[2 * i] = k < kN / 2 ? 1.0f : 0.0f;
  }
  r = raddiff::gather_evaluate(layout, frame, in, raddiff::GATHER_ALL);
  CHECK_CLOSE(r.irradiance[0], kPi / 2.0, 1e-13);
  CHECK(r.gradient[1] > 0.0 && std::fabs(r.gradient[0]) < 1e-12 && r.rotation_gradient[0] < 0.0);
  CHECK(r.occlusion_gradient[1] > 0.0);
  CHECK_CLOSE(r.hessian[1], r.hessian[3], 1e-12);
  CHECK_CLOSE(r.hessian[9 + 5], r.hessian[9 + 7], 1e-12);
  CHECK(r.harmonic_mean_distance == 2.0 && r.min_distance == 1.0);
  {
    double e[2], g[6], rg[6], og[6], hh[18];
    raddiff_gather_input cin{};
    cin.directions = dirs.data();
    cin.distance = dist.data();
    cin.radiance = rad.data();
    cin.channels = 2;
    raddiff_gather_output cout{e, g, rg, og, hh, 0.0, 0.0};
    CHECK(raddiff_gather_evaluate(&layout, &frame, &cin, &cout) == RADDIFF_OK);
    CHECK(std::memcmp(e, r.irradiance.data(), sizeof e) == 0 && std::memcmp(g, r.gradient.data(), sizeof g) == 0);
    CHECK(std::memcmp(og, r.occlusion_gradient.data(), sizeof og) == 0);
    CHECK(std::memcmp(hh, r.hessian.data(), sizeof hh) == 0);
  }
  r = raddiff::gather_evaluate(layout, frame, in, raddiff::GATHER_HESSIAN);
  CHECK(r.irradiance.empty() && r.gradient.empty() && r.hessian.size() == 18 && r.min_distance == 1.0);
  // a floored surface record from the gather's Hessian and harmonic-mean distance
  {
    const raddiff::SurfaceRadii sr =
        raddiff::surface_radii_floored(raddiff::Span<const double>(r.hessian.data(), 9), frame.normal,
                                       kPi / 2.0, 0.05, RADDIFF_ERROR_RELATIVE, 2.0, r.harmonic_mean_distance);
    CHECK(sr.radii[0] > 0.0 && sr.radii[0] <= sr.radii[1] && sr.radii[1] < RADDIFF_MAX_RADIUS);
  }

  // C errors and the wrapper's size checks
  dist[3] = -1.0;
  CHECK_THROWS(raddiff::gather_evaluate(layout, frame, in), RADDIFF_ERROR_INVALID_ARGUMENT, "distance[3]");
  dist[3] = 1.0;
  {
    raddiff_gather_layout bad = layout;
    bad.kind = RADDIFF_LAYOUT_SPHERE;  // the directions no longer match their strata
    CHECK_THROWS(raddiff::gather_evaluate(bad, frame, in), RADDIFF_ERROR_INVALID_ARGUMENT, "stratum");
    raddiff_frame bf = frame;
    bf.normal.z = 2.0;
    CHECK_THROWS(raddiff::gather_evaluate(layout, bf, in), RADDIFF_ERROR_INVALID_ARGUMENT, "invalid argument");
  }
  raddiff::GatherInput bad_in = in;
  bad_in.channels = 3;
  CHECK_THROWS(raddiff::gather_evaluate(layout, frame, bad_in), RADDIFF_ERROR_INVALID_ARGUMENT,
               "radiance holds 64 elements, expected 96");
  bad_in = in;
  bad_in.distance = raddiff::Span<const double>(dist.data(), kCells - 1);
  CHECK_THROWS(raddiff::gather_evaluate(layout, frame, bad_in), RADDIFF_ERROR_INVALID_ARGUMENT, "distance holds 31");
  bad_in = in;
  bad_in.directions = raddiff::Span<const raddiff_vec3>();
  CHECK_THROWS(raddiff::gather_evaluate(layout, frame, bad_in), RADDIFF_ERROR_INVALID_ARGUMENT, "directions holds 0");

  // size products saturate instead of wrapping around
  CHECK(raddiff::detail::mul(SIZE_MAX / 2, 3) == SIZE_MAX && raddiff::detail::mul(0, SIZE_MAX) == 0);
  CHECK(raddiff::detail::mul(std::size_t(1) << 32, std::size_t(1) << 31) == std::size_t(1) << 63);

  // a medium: marched emissive radiance, no surfaces hit: E = pi q (1 - exp(-sigma T)) / sigma
  {
    std::vector<float> q(kCells * 10 * 2, 0.25f);
    const double sigma = 0.5, step = 0.3;
    for (auto &v : dist) v = kInf;
    in.sigma_t = sigma;
    in.media_radiance = q;
    in.steps = 10;
    in.step = step;
    r = raddiff::gather_evaluate(layout, frame, in);
    CHECK_CLOSE(r.irradiance[0], kPi * 0.25 * (1.0 - std::exp(-sigma * 3.0)) / sigma, 1e-12);
    for (int i = 0; i < 6; i++) CHECK(std::fabs(r.gradient[i]) < 1e-13);
    // with a zero media gradient: the same values
    std::vector<float> qg(kCells * 10 * 3 * 2, 0.0f);
    in.media_radiance_gradient = qg;
    const raddiff::GatherResult r2 = raddiff::gather_evaluate(layout, frame, in);
    CHECK_CLOSE(r2.irradiance[0], r.irradiance[0], 1e-14);
    in.media_radiance_gradient = raddiff::Span<const float>(qg.data(), qg.size() - 1);
    CHECK_THROWS(raddiff::gather_evaluate(layout, frame, in), RADDIFF_ERROR_INVALID_ARGUMENT,
                 "media_radiance_gradient holds");
    in.media_radiance_gradient = raddiff::Span<const float>();
    in.steps = 9;
    CHECK_THROWS(raddiff::gather_evaluate(layout, frame, in), RADDIFF_ERROR_INVALID_ARGUMENT, "media_radiance holds");
  }
}

void radii() {
  const double h[9] = {3, 0, 0, 0, 3, 0, 0, 0, 3};
  const raddiff_vec3 z{0.0, 0.0, 1.0};
  const double iso = std::pow(4.0 * 0.02 / (kPi * 3.0), 0.25);
  raddiff::SurfaceRadii s = raddiff::surface_radii(h, z, 1.0, 0.02, RADDIFF_ERROR_ABSOLUTE, 2.0);
  CHECK_CLOSE(s.radii[0], iso, 1e-13);
  CHECK_CLOSE(s.radii[1], iso, 1e-13);
  for (const raddiff_vec3 &a : s.axes) {
    CHECK_CLOSE(a.z, 0.0, 1e-15);
    CHECK_CLOSE(a.x * a.x + a.y * a.y, 1.0, 1e-14);
  }
  s = raddiff::surface_radii(h, z, 4.0, 0.005, RADDIFF_ERROR_RELATIVE, 2.0);
  CHECK_CLOSE(s.radii[0], iso, 1e-13);
  {
    const std::vector<double> ha = {1, 0, 0, 0, 16, 0, 0, 0, 100};
    const double a = std::pow(0.01 / (16.0 * kPi), 0.25);
    s = raddiff::surface_radii(ha, z, 1.0, 0.01, RADDIFF_ERROR_ABSOLUTE, 10.0);
    CHECK_CLOSE(s.radii[0], a, 1e-13);
    CHECK_CLOSE(s.radii[1], 4.0 * a, 1e-13);
    CHECK_CLOSE(std::fabs(s.axes[0].y), 1.0, 1e-13);
    s = raddiff::surface_radii(ha, z, 1.0, 0.01, RADDIFF_ERROR_ABSOLUTE, 2.0);
    CHECK_CLOSE(s.radii[1] / s.radii[0], 2.0, 1e-13);
  }
  const raddiff::VolumeRadii v = raddiff::volume_radii(h, 2.0, 0.05, RADDIFF_ERROR_RELATIVE, 2.0);
  for (double r : v.radii) CHECK_CLOSE(r, std::pow(5.0 * 0.1 / (2.0 * kPi * 3.0), 0.2), 1e-13);
  CHECK_CLOSE(v.axes[0].x * v.axes[1].x + v.axes[0].y * v.axes[1].y + v.axes[0].z * v.axes[1].z, 0.0, 1e-13);
  const std::array<double, 9> zero{};
  CHECK(raddiff::volume_radii(zero, 1.0, 0.1, RADDIFF_ERROR_RELATIVE, 2.0).radii[2] == RADDIFF_MAX_RADIUS);
  CHECK(raddiff::surface_radii(zero, z, 1.0, 0.1, RADDIFF_ERROR_RELATIVE, 2.0).radii[1] == RADDIFF_MAX_RADIUS);
  // the curvature floor (default weight RADDIFF_CURVATURE_FLOOR_WEIGHT)
  {
    const double d = 0.5, eps = 1e-3;
    const double expect = std::pow(4.0 * eps * d * d / (kPi * RADDIFF_CURVATURE_FLOOR_WEIGHT), 0.25);
    s = raddiff::surface_radii_floored(zero, z, 2.0, eps, RADDIFF_ERROR_RELATIVE, 2.0, d);
    CHECK_CLOSE(s.radii[0], expect, 1e-12);
    CHECK_CLOSE(s.radii[1], expect, 1e-12);
    s = raddiff::surface_radii_floored(zero, z, 0.0, eps, RADDIFF_ERROR_RELATIVE, 2.0, d,
                                       RADDIFF_CURVATURE_FLOOR_WEIGHT);
    CHECK_CLOSE(s.radii[0], expect, 1e-12);
    s = raddiff::surface_radii_floored(h, z, 1.0, 0.02, RADDIFF_ERROR_ABSOLUTE, 2.0, d, 0.0);
    CHECK_CLOSE(s.radii[0], iso, 1e-13);
    CHECK_THROWS(raddiff::surface_radii_floored(zero, z, 2.0, eps, RADDIFF_ERROR_RELATIVE, 2.0, 0.0),
                 RADDIFF_ERROR_INVALID_ARGUMENT, "distance");
  }
  // errors: the C ones, and the 9-element size check
  CHECK_THROWS(raddiff::surface_radii(h, z, 1.0, 0.1, 7, 2.0), RADDIFF_ERROR_INVALID_ARGUMENT, "mode");
  CHECK_THROWS(raddiff::surface_radii(h, raddiff_vec3{0, 0, 2}, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0),
               RADDIFF_ERROR_INVALID_ARGUMENT, "unit");
  CHECK_THROWS(raddiff::volume_radii(h, 1.0, kInf, RADDIFF_ERROR_ABSOLUTE, 2.0), RADDIFF_ERROR_INVALID_ARGUMENT,
               "invalid argument");
  const raddiff::Span<const double> eight(h, 8);
  CHECK_THROWS(raddiff::surface_radii(eight, z, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0),
               RADDIFF_ERROR_INVALID_ARGUMENT, "hessian holds 8 elements, expected 9");
  CHECK_THROWS(raddiff::surface_radii_floored(eight, z, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, 1.0),
               RADDIFF_ERROR_INVALID_ARGUMENT, "hessian holds 8");
  CHECK_THROWS(raddiff::volume_radii(eight, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0), RADDIFF_ERROR_INVALID_ARGUMENT,
               "hessian holds 8");
  // a deriv3's Hessian passes straight in
  const raddiff_deriv3 t = raddiff::transmittance(raddiff_vec3{0, 0, 0}, raddiff_vec3{0, 0, 2}, 0.5);
  const raddiff::VolumeRadii tv = raddiff::volume_radii(t.hessian, t.value, 0.01, RADDIFF_ERROR_RELATIVE, 4.0);
  CHECK(tv.radii[0] > 0.0 && tv.radii[0] <= tv.radii[2]);
}

}  // namespace

int main() {
  transmittance();
  marched();
  solid_angle_and_segment();
  form_factors();
  gathers();
  radii();
  CHECK_DONE("hpp_functions.cpp");
}
