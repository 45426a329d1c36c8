/* raddiff_triangle_form_factor / raddiff_polygon_form_factor through the C header only. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

static const double PI = 3.14159265358979323846;

/* Form factor from a point to a w x l rectangle parallel to its tangent plane at height h, with the
   point below one corner (the classic closed form). */
static double corner(double w, double l, double h) {
  double X = w / h, Y = l / h, sx = sqrt(1.0 + X * X), sy = sqrt(1.0 + Y * Y);
  return (X / sx * atan(Y / sx) + Y / sy * atan(X / sy)) / (2.0 * PI);
}

/* unit square centred above the point at height h */
static double square(double h) { return 4.0 * corner(0.5, 0.5, h); }

int main(void) {
  raddiff_vec3 x = {0.0, 0.0, 0.0}, n = {0.0, 0.0, 1.0};
  raddiff_vec3 sq[4] = {{-0.5, -0.5, 1.0}, {0.5, -0.5, 1.0}, {0.5, 0.5, 1.0}, {-0.5, 0.5, 1.0}};
  raddiff_deriv3 d, e;
  int i, j;

  /* unit square directly above x at height 1: closed form; d/dz = -d/dh */
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, sq, 4, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, square(1.0), 1e-14);
  {
    const double s = 1e-4;
    double dfdh = (square(1.0 + s) - square(1.0 - s)) / (2.0 * s);
    double d2fdh2 = (square(1.0 + s) - 2.0 * square(1.0) + square(1.0 - s)) / (s * s);
    CHECK_CLOSE(d.gradient[0], 0.0, 1e-14);
    CHECK_CLOSE(d.gradient[1], 0.0, 1e-14);
    CHECK_CLOSE(d.gradient[2], -dfdh, 1e-7);
    CHECK_CLOSE(d.hessian[8], d2fdh2, 1e-5);
    CHECK_CLOSE(d.hessian[0], d.hessian[4], 1e-13); /* square symmetry */
    for (i = 0; i < 3; i++)
      for (j = 0; j < 3; j++) {
        CHECK(d.hessian[3 * i + j] == d.hessian[3 * j + i] || fabs(d.hessian[3 * i + j] - d.hessian[3 * j + i]) < 1e-14);
        if (i != j) CHECK_CLOSE(d.hessian[3 * i + j], 0.0, 1e-13);
      }
  }
  /* the two triangles of the square sum to the square; either orientation */
  {
    double sum = 0.0;
    CHECK_STATUS(raddiff_triangle_form_factor(x, n, sq[0], sq[1], sq[2], RADDIFF_ORDER_HESSIAN, &e), RADDIFF_OK);
    sum += e.value;
    CHECK_STATUS(raddiff_triangle_form_factor(x, n, sq[3], sq[2], sq[0], RADDIFF_ORDER_HESSIAN, &e), RADDIFF_OK);
    sum += e.value;
    CHECK_CLOSE(sum, d.value, 1e-14);
  }

  /* a triangle partly below the tangent plane: value and gradient equal those of its clipped part
     held fixed (the integrand vanishes on the clip line); 0 < F < 1 */
  {
    raddiff_vec3 a = {1.0, 0.0, 1.0}, b = {0.0, 1.0, 1.0}, c = {0.2, 0.3, -1.0};
    /* clip points on z = 0: midpoints in z of c-a and c-b */
    raddiff_vec3 ca = {0.6, 0.15, 0.0}, cb = {0.1, 0.65, 0.0};
    raddiff_vec3 quad[4];
    quad[0] = a;
    quad[1] = b;
    quad[2] = cb;
    quad[3] = ca;
    CHECK_STATUS(raddiff_triangle_form_factor(x, n, a, b, c, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
    CHECK_STATUS(raddiff_polygon_form_factor(x, n, quad, 4, RADDIFF_ORDER_GRADIENT, &e), RADDIFF_OK);
    CHECK(d.value > 0.0 && d.value < 1.0);
    CHECK_CLOSE(d.value, e.value, 1e-14);
    for (i = 0; i < 3; i++) CHECK_CLOSE(d.gradient[i], e.gradient[i], 1e-13);
    for (i = 0; i < 9; i++) CHECK(isfinite(d.hessian[i]));
  }

  /* order selects the work; higher parts are zero */
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, sq, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK(d.gradient[2] == 0.0 && d.hessian[8] == 0.0);
  CHECK_STATUS(raddiff_triangle_form_factor(x, n, sq[0], sq[1], sq[2], RADDIFF_ORDER_GRADIENT, &d), RADDIFF_OK);
  CHECK(d.gradient[2] != 0.0 && d.hessian[8] == 0.0);

  /* error paths: outputs untouched */
  memset(&d, 0, sizeof d);
  d.value = 42.0;
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, sq, 4, RADDIFF_ORDER_VALUE, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "out") != NULL);
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, NULL, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "vertices") != NULL);
  CHECK_STATUS(raddiff_triangle_form_factor(x, n, sq[0], sq[1], sq[2], RADDIFF_ORDER_VALUE, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, sq, 2, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, NULL, 0, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "3") != NULL);
  CHECK_STATUS(raddiff_polygon_form_factor(x, n, sq, 4, 3, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "order") != NULL);
  CHECK_STATUS(raddiff_triangle_form_factor(x, n, sq[0], sq[1], sq[2], 7, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  {
    raddiff_vec3 bad = x, big = {0.0, 0.0, 2.0}, zero = {0.0, 0.0, 0.0};
    bad.y = NAN;
    CHECK_STATUS(raddiff_triangle_form_factor(bad, n, sq[0], sq[1], sq[2], RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_triangle_form_factor(x, n, bad, sq[1], sq[2], RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
    bad.y = INFINITY;
    CHECK_STATUS(raddiff_triangle_form_factor(x, bad, sq[0], sq[1], sq[2], RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_triangle_form_factor(x, big, sq[0], sq[1], sq[2], RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "unit") != NULL);
    CHECK_STATUS(raddiff_triangle_form_factor(x, zero, sq[0], sq[1], sq[2], RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
    {
      raddiff_vec3 poly[4];
      memcpy(poly, sq, sizeof poly);
      poly[2].x = NAN;
      CHECK_STATUS(raddiff_polygon_form_factor(x, n, poly, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
      /* bow tie: not simple */
      memcpy(poly, sq, sizeof poly);
      poly[1].x = 0.8;
      poly[1].y = 0.6;
      poly[2] = sq[1];
      CHECK_STATUS(raddiff_polygon_form_factor(x, n, poly, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
      CHECK(strstr(raddiff_last_error(), "simple") != NULL);
      /* not planar */
      memcpy(poly, sq, sizeof poly);
      poly[2].z = 1.1;
      CHECK_STATUS(raddiff_polygon_form_factor(x, n, poly, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
      CHECK(strstr(raddiff_last_error(), "planar") != NULL);
    }
  }
  /* degenerate: zero-area triangle; x in the plane of the triangle (value 0 is fine, gradient is not) */
  CHECK_STATUS(raddiff_triangle_form_factor(x, n, sq[0], sq[1], sq[1], RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_DEGENERATE);
  {
    raddiff_vec3 inplane = {3.0, 0.0, 1.0}, side = {1.0, 0.0, 0.0};
    CHECK_STATUS(raddiff_polygon_form_factor(inplane, side, sq, 4, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_ERROR_DEGENERATE);
    CHECK(d.value == 42.0);
    CHECK_STATUS(raddiff_polygon_form_factor(inplane, side, sq, 4, RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
    CHECK(d.value == 0.0);
  }
  /* a polygon entirely below the tangent plane contributes nothing */
  {
    raddiff_vec3 down = {0.0, 0.0, -1.0};
    CHECK_STATUS(raddiff_polygon_form_factor(x, down, sq, 4, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
    CHECK(d.value == 0.0 && d.gradient[2] == 0.0 && d.hessian[8] == 0.0);
  }

  CHECK_DONE("form_factor.c");
}
