#include "gather_noise.hpp"

#include <array>
#include <cmath>
#include <vector>

namespace rd {
namespace {

// Each direction's luminance of `g`, as T.
template <class T>
std::vector<T> luminances(const TracedGather &g) {
  std::vector<T> lum(g.distance.size());
  for (size_t i = 0; i < lum.size(); ++i) lum[i] = static_cast<T>(luminance(&g.radiance[3 * i]));
  return lum;
}

// Stratum (j, k)'s value minus its azimuthal neighbour's, (j, k + 1 mod n), in an m x n layout:
// a stratum's noise is estimated as half the square of this difference (an overestimate by the
// signal's own change between neighbours, small at 128 azimuthal strata).
template <class T>
T azimuthal_difference(const std::vector<T> &values, uint32_t n, uint32_t j, uint32_t k) {
  return values[j * n + k] - values[j * n + (k + 1) % n];
}

// The derivatives of one value per direction of `g`: the Ward-Heckbert gradient (world axes) and
// the occlusion-aware Hessian (3x3, row-major; computed only when `hessian` is not null).
std::array<double, 3> scalar_derivatives(const TracedGather &g, const std::vector<float> &values,
                                         double *hessian = nullptr, double *irradiance = nullptr,
                                         double *harmonic_mean_distance = nullptr) {
  raddiff_gather_input input{};
  input.directions = g.directions.data();
  input.distance = g.distance.data();
  input.radiance = values.data();
  input.channels = 1;
  std::array<double, 3> gradient{};
  raddiff_gather_output output{};
  output.gradient = gradient.data();
  output.hessian = hessian;
  output.irradiance = irradiance;
  check(raddiff_gather_evaluate(&g.layout, &g.frame, &input, &output), "raddiff_gather_evaluate");
  if (harmonic_mean_distance) *harmonic_mean_distance = output.harmonic_mean_distance;
  return gradient;
}

// Squared Frobenius norm of the 3x3 row-major `h` projected on the plane of unit normal `n`,
// (I - n n^T) h (I - n n^T): the part of a Hessian the surface radii read.
double tangent_norm2(const double h[9], V3 n) {
  const double nn[3] = {n.x, n.y, n.z};
  double p[3][3], ph[3][3], sum = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) p[i][j] = (i == j) - nn[i] * nn[j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) ph[i][j] = p[i][0] * h[j] + p[i][1] * h[3 + j] + p[i][2] * h[6 + j];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const double t = ph[i][0] * p[0][j] + ph[i][1] * p[1][j] + ph[i][2] * p[2][j];
      sum += t * t;
    }
  return sum;
}

}  // namespace

double relative_noise(const TracedGather &g) {
  const uint32_t m = g.layout.m, n = g.layout.n;
  const std::vector<double> lum = luminances<double>(g);
  double sum = 0, squares = 0;
  for (uint32_t j = 0; j < m; ++j)
    for (uint32_t k = 0; k < n; ++k) {
      const double d = azimuthal_difference(lum, n, j, k);
      sum += lum[j * n + k];
      squares += 0.5 * d * d;
    }
  return sum > 0 ? std::sqrt(squares) / sum : 0.0;
}

DerivativeNoise derivative_noise(const TracedGather &g, const TracedGather *retraced, double gradient_k,
                                 double hessian_k, bool hessian_noise, uint64_t seed) {
  const uint32_t m = g.layout.m, n = g.layout.n;
  const std::vector<float> lum = luminances<float>(g);
  std::vector<float> amplitude(lum.size()), probe(lum.size());
  const std::vector<float> other = retraced ? luminances<float>(*retraced) : std::vector<float>();
  for (uint32_t j = 0; j < m; ++j)
    for (uint32_t k = 0; k < n; ++k) {
      const size_t i = j * n + k;
      amplitude[i] = std::abs(retraced ? lum[i] - other[i] : azimuthal_difference(lum, n, j, k)) / std::sqrt(2.0f);
    }
  const bool hessian = hessian_noise || hessian_k > 0;
  const V3 normal = from_c(g.frame.normal);
  double h0[9] = {}, irradiance = 0, distance = 0;
  const std::array<double, 3> g0 = scalar_derivatives(g, lum, hessian ? h0 : nullptr, &irradiance, &distance);
  const double gradient_signal = g0[0] * g0[0] + g0[1] * g0[1] + g0[2] * g0[2];
  const double hessian_signal = hessian ? tangent_norm2(h0, normal) : 0;
  constexpr int kProbes = 8;
  double gradient_variance = 0, hessian_variance = 0;
  for (int p = 0; p < kProbes; ++p) {
    for (size_t i = 0; i < probe.size(); ++i)
      probe[i] = (mix(seed ^ mix(p * probe.size() + i)) & 1) ? amplitude[i] : -amplitude[i];
    double h[9] = {};
    const std::array<double, 3> noise = scalar_derivatives(g, probe, hessian ? h : nullptr);
    gradient_variance += (noise[0] * noise[0] + noise[1] * noise[1] + noise[2] * noise[2]) / kProbes;
    if (hessian) hessian_variance += tangent_norm2(h, normal) / kProbes;
  }
  DerivativeNoise s;
  if (gradient_k > 0 && gradient_signal > 0)
    s.gradient_shrink = std::max(0.0, 1.0 - gradient_k * gradient_variance / gradient_signal);
  if (hessian_k > 0 && hessian_signal > 0)
    s.hessian_shrink = std::max(kMinHessianShrink, 1.0 - hessian_k * hessian_variance / hessian_signal);
  if (irradiance > 0) {
    s.relative_gradient_noise = std::sqrt(gradient_variance) / irradiance;
    if (std::isfinite(distance))
      s.hessian_noise_weight = std::sqrt(hessian_variance / 2) * distance * distance / irradiance;
  }
  return s;
}

}  // namespace rd
