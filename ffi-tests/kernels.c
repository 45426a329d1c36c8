/* raddiff_triangle_solid_angle, raddiff_segment_form_factor_2d and raddiff_transmittance_marched
   through the C header only: known values, derivatives against finite differences, documented
   limits, and error paths (NULL pointers, non-finite input, bad order, bad count), with outputs
   left untouched on failure. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

static const double PI = 3.14159265358979323846;

static raddiff_vec3 v3(double x, double y, double z) {
  raddiff_vec3 v;
  v.x = x;
  v.y = y;
  v.z = z;
  return v;
}

static raddiff_vec2 v2(double x, double y) {
  raddiff_vec2 v;
  v.x = x;
  v.y = y;
  return v;
}

static int untouched3(const raddiff_deriv3 *d) {
  int i;
  if (d->value != 42.0) return 0;
  for (i = 0; i < 3; i++)
    if (d->gradient[i] != 42.0) return 0;
  for (i = 0; i < 9; i++)
    if (d->hessian[i] != 42.0) return 0;
  return 1;
}

static void fill3(raddiff_deriv3 *d) {
  int i;
  d->value = 42.0;
  for (i = 0; i < 3; i++) d->gradient[i] = 42.0;
  for (i = 0; i < 9; i++) d->hessian[i] = 42.0;
}

static raddiff_vec3 shifted(raddiff_vec3 x, int axis, double h) {
  if (axis == 0) x.x += h;
  if (axis == 1) x.y += h;
  if (axis == 2) x.z += h;
  return x;
}

/* gradient and Hessian of the solid angle at x against central differences of the C API itself */
static void check_solid_angle_fd(raddiff_vec3 x, raddiff_vec3 a, raddiff_vec3 b, raddiff_vec3 c) {
  raddiff_deriv3 d, p, m;
  const double h = 1e-5;
  int i, j;
  double gmax = 0.0, hmax = 0.0;
  CHECK_STATUS(raddiff_triangle_solid_angle(x, a, b, c, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  for (i = 0; i < 3; i++) gmax = fmax(gmax, fabs(d.gradient[i]));
  for (i = 0; i < 9; i++) hmax = fmax(hmax, fabs(d.hessian[i]));
  for (i = 0; i < 3; i++) {
    CHECK_STATUS(raddiff_triangle_solid_angle(shifted(x, i, h), a, b, c, RADDIFF_ORDER_GRADIENT, &p), RADDIFF_OK);
    CHECK_STATUS(raddiff_triangle_solid_angle(shifted(x, i, -h), a, b, c, RADDIFF_ORDER_GRADIENT, &m), RADDIFF_OK);
    CHECK(fabs((p.value - m.value) / (2 * h) - d.gradient[i]) <= 1e-8 * gmax);
    for (j = 0; j < 3; j++) {
      CHECK(fabs((p.gradient[j] - m.gradient[j]) / (2 * h) - d.hessian[3 * i + j]) <= 1e-8 * hmax);
      CHECK(d.hessian[3 * i + j] == d.hessian[3 * j + i]);
    }
  }
}

static void solid_angle(void) {
  const raddiff_vec3 o = v3(0, 0, 0), ex = v3(1, 0, 0), ey = v3(0, 1, 0), ez = v3(0, 0, 1);
  /* regular tetrahedron around the origin: each face subtends 4π/4 */
  const raddiff_vec3 t[4] = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  raddiff_deriv3 d;
  int i;

  /* the octant: π/2 from the origin, in either winding, at any scale */
  CHECK_STATUS(raddiff_triangle_solid_angle(o, ex, ey, ez, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, PI / 2, 1e-15);
  CHECK(d.gradient[0] > 0 && fabs(d.gradient[0] - d.gradient[1]) < 1e-15 && fabs(d.gradient[1] - d.gradient[2]) < 1e-15);
  CHECK_STATUS(raddiff_triangle_solid_angle(o, ex, ez, ey, RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, PI / 2, 1e-15);
  CHECK(d.gradient[0] == 0.0 && d.hessian[4] == 0.0); /* parts above the order are zero */
  CHECK_STATUS(raddiff_triangle_solid_angle(o, v3(1e6, 0, 0), v3(0, 1e6, 0), v3(0, 0, 1e6), RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, PI / 2, 1e-15);
  for (i = 0; i < 4; i++) {
    CHECK_STATUS(raddiff_triangle_solid_angle(o, t[i], t[(i + 1) % 4], t[(i + 2) % 4], RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
    CHECK_CLOSE(d.value, PI, 1e-14);
  }
  check_solid_angle_fd(v3(0.2, 0.3, 0.7), ex, ey, ez);
  check_solid_angle_fd(v3(-2.0, 0.5, 1.5), t[0], t[1], t[2]);

  /* documented limits: in the plane 2π inside, 0 outside, zero derivatives; edge and vertex degenerate */
  CHECK_STATUS(raddiff_triangle_solid_angle(v3(0.2, 0.2, 0), o, ex, ey, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK(d.value == 2 * PI && d.gradient[2] == 0.0 && d.hessian[8] == 0.0);
  CHECK_STATUS(raddiff_triangle_solid_angle(v3(2, 2, 0), o, ex, ey, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK(d.value == 0.0);
  CHECK_STATUS(raddiff_triangle_solid_angle(ez, o, ex, v3(2, 0, 0), RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK(d.value == 0.0); /* zero-area triangle */
  fill3(&d);
  CHECK_STATUS(raddiff_triangle_solid_angle(v3(0.5, 0, 0), o, ex, ey, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_DEGENERATE);
  CHECK(strstr(raddiff_last_error(), "edge") != NULL);
  CHECK_STATUS(raddiff_triangle_solid_angle(ex, o, ex, ey, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_ERROR_DEGENERATE);
  CHECK(strstr(raddiff_last_error(), "vertex") != NULL);
  CHECK(untouched3(&d));

  /* error paths */
  CHECK_STATUS(raddiff_triangle_solid_angle(o, ex, ey, ez, RADDIFF_ORDER_VALUE, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "out") != NULL);
  CHECK_STATUS(raddiff_triangle_solid_angle(o, ex, ey, ez, 3, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "order") != NULL);
  CHECK_STATUS(raddiff_triangle_solid_angle(v3(NAN, 0, 0), ex, ey, ez, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_triangle_solid_angle(o, ex, v3(0, INFINITY, 0), ez, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "b") != NULL);
  CHECK(untouched3(&d));
}

static void segment(void) {
  raddiff_deriv2 d;
  const double f = 1.0 / (2 * PI);
  /* x = 0 below the segment (-1,1)-(1,1): θ(0,y) = 2 atan(1/(1-y)); Laplacian of θ is 0 */
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, 0), v2(-1, 1), v2(1, 1), RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, 0.25, 1e-15);
  CHECK(fabs(d.gradient[0]) < 1e-16);
  CHECK_CLOSE(d.gradient[1], f, 1e-15);
  CHECK_CLOSE(d.hessian[0], -f, 1e-15);
  CHECK_CLOSE(d.hessian[3], f, 1e-15);
  CHECK(fabs(d.hessian[1]) < 1e-16 && d.hessian[1] == d.hessian[2]);
  /* orientation does not matter; a quarter turn from the corner */
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, 0), v2(1, 1), v2(-1, 1), RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, 0.25, 1e-15);
  CHECK(d.gradient[1] == 0.0);
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, 0), v2(1, 0), v2(0, 1), RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, 0.25, 1e-15);
  /* far away: θ ≈ length · cos / distance */
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, -1e6), v2(-0.5, 0), v2(0.5, 0), RADDIFF_ORDER_GRADIENT, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, 2 * atan(0.5e-6) * f, 1e-15);
  CHECK(fabs(d.gradient[1] - f * 1e-12 / (1 + 0.25e-12)) <= 1e-14 * f * 1e-12);
  /* limits: on the segment 1/2, beyond 0, zero-length 0, endpoint degenerate */
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0.3, 0), v2(0, 0), v2(1, 0), RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK(d.value == 0.5 && d.gradient[1] == 0.0 && d.hessian[3] == 0.0);
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(3, 0), v2(0, 0), v2(1, 0), RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK(d.value == 0.0);
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(3, 1), v2(1, 1), v2(1, 1), RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK(d.value == 0.0);
  d.value = 42.0;
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(1, 0), v2(0, 0), v2(1, 0), RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_DEGENERATE);
  CHECK(strstr(raddiff_last_error(), "endpoint") != NULL);
  /* error paths */
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, 0), v2(1, 0), v2(0, 1), RADDIFF_ORDER_VALUE, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, 0), v2(1, 0), v2(0, 1), 99, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, NAN), v2(1, 0), v2(0, 1), RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_segment_form_factor_2d(v2(0, 0), v2(-INFINITY, 0), v2(0, 1), RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(d.value == 42.0);
}

static void marched(void) {
  const raddiff_vec3 x = v3(0, 0, 0), y = v3(2, 0, 0);
  const double sigma[4] = {0.5, 0.5, 0.5, 0.5};
  const raddiff_vec3 grad[4] = {{0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}};
  raddiff_deriv3 d, h;
  const double t = exp(-1.0);
  double bad[4] = {0.5, -0.1, 0.5, 0.5};
  raddiff_vec3 bad_grad[4] = {{0, 1, 0}, {0, NAN, 0}, {0, 1, 0}, {0, 1, 0}};

  /* constant samples without gradients: the homogeneous kernel */
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, NULL, 4, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_OK);
  CHECK_STATUS(raddiff_transmittance(x, y, 0.5, RADDIFF_ORDER_GRADIENT, &h), RADDIFF_OK);
  CHECK_CLOSE(d.value, h.value, 1e-15);
  CHECK_CLOSE(d.gradient[0], h.gradient[0], 1e-15);
  CHECK(d.hessian[0] == 0.0);
  /* with gradients: ∇σ̄ = mean(1 - t_i) g = (0, 0.5, 0); ∇τ = σ̄ (x - y)/L + L ∇σ̄ = (-0.5, 1, 0) */
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, grad, 4, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, t, 1e-15);
  CHECK_CLOSE(d.gradient[0], 0.5 * t, 1e-15);
  CHECK_CLOSE(d.gradient[1], -t, 1e-15);
  CHECK(d.gradient[2] == 0.0);
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, grad, 1, RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, t, 1e-15);
  /* x == y: value 1; gradient undefined when σ̄ > 0 */
  CHECK_STATUS(raddiff_transmittance_marched(x, x, sigma, grad, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK(d.value == 1.0);
  fill3(&d);
  CHECK_STATUS(raddiff_transmittance_marched(x, x, sigma, grad, 4, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_ERROR_DEGENERATE);
  /* error paths: Hessian order, bad count, NULL, negative or non-finite samples */
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, grad, 4, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "Hessian") != NULL);
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, grad, 4, 5, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, grad, 0, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "count") != NULL);
  CHECK_STATUS(raddiff_transmittance_marched(x, y, NULL, grad, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "sigma_t") != NULL);
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, grad, 4, RADDIFF_ORDER_VALUE, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_transmittance_marched(x, y, bad, NULL, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "sigma_t[1]") != NULL);
  bad[1] = NAN;
  CHECK_STATUS(raddiff_transmittance_marched(x, y, bad, NULL, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_transmittance_marched(x, y, sigma, bad_grad, 4, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "sigma_t_gradient[1]") != NULL);
  CHECK_STATUS(raddiff_transmittance_marched(v3(0, INFINITY, 0), y, sigma, grad, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(untouched3(&d));
}

int main(void) {
  solid_angle();
  segment();
  marched();
  CHECK_DONE("kernels.c");
}
