/* The batch kernels from C99: a float4-strided Embree-style mesh and a double soup against the
   single-triangle calls, closed-surface identities, and the validation paths (outputs untouched). */
#include "raddiff.h"
#include "check.h"
#include <stdint.h>
#include <string.h>

#define PI 3.14159265358979323846

/* An octahedron around the origin: float4 vertices (w unused) and uint4 index rows (4th unused),
   the padded layout Embree buffers often use. */
static const float OCTA_V[6][4] = {{1, 0, 0, 9}, {0, 1, 0, 9}, {0, 0, 1, 9}, {-1, 0, 0, 9}, {0, -1, 0, 9}, {0, 0, -1, 9}};
static const uint32_t OCTA_I[8][4] = {{0, 1, 2, 99}, {1, 3, 2, 99}, {3, 4, 2, 99}, {4, 0, 2, 99},
                                      {1, 0, 5, 99}, {3, 1, 5, 99}, {4, 3, 5, 99}, {0, 4, 5, 99}};

static raddiff_vec3 vtx(int i) {
  raddiff_vec3 v = {OCTA_V[i][0], OCTA_V[i][1], OCTA_V[i][2]};
  return v;
}

static raddiff_triangle_mesh octahedron(void) {
  raddiff_triangle_mesh m;
  m.vertices = OCTA_V;
  m.vertex_format = RADDIFF_VERTEX_FLOAT3;
  m.vertex_stride = 4 * sizeof(float);
  m.vertex_count = 6;
  m.indices = &OCTA_I[0][0];
  m.index_stride = 4 * sizeof(uint32_t);
  m.triangle_count = 8;
  return m;
}

/* max |a - b| over value, gradient, Hessian, relative to the largest entry of each part of b */
static double rel_diff(double va, const double *ga, const double *ha, const raddiff_deriv3 *b) {
  double gs = 0, hs = 0, e = fabs(va - b->value) / fmax(fabs(b->value), 1e-300);
  int i;
  for (i = 0; i < 3; i++) gs = fmax(gs, fabs(b->gradient[i]));
  for (i = 0; i < 9; i++) hs = fmax(hs, fabs(b->hessian[i]));
  for (i = 0; i < 3; i++) e = fmax(e, fabs(ga[i] - b->gradient[i]) / fmax(gs, 1e-300));
  for (i = 0; i < 9; i++) e = fmax(e, fabs(ha[i] - b->hessian[i]) / fmax(hs, 1e-300));
  return e;
}

int main(void) {
  const raddiff_triangle_mesh octa = octahedron();
  const raddiff_vec3 inside = {0.1, -0.2, 0.05};
  const raddiff_vec3 outside = {1.5, 0.7, -0.4};
  const double s = 0.57735026918962576451;
  const raddiff_vec3 n = {s, s, s};
  raddiff_deriv3 d;
  int t, i;

  /* closed surface: the solid angles sum to 4 pi inside (constant: zero derivatives) */
  CHECK_STATUS(raddiff_mesh_solid_angle(inside, &octa, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, 4.0 * PI, 1e-13);
  for (i = 0; i < 3; i++) CHECK(fabs(d.gradient[i]) < 1e-12);
  for (i = 0; i < 9; i++) CHECK(fabs(d.hessian[i]) < 1e-11);
  /* ... and the clipped form factors cover the hemisphere exactly once: 1 */
  CHECK_STATUS(raddiff_mesh_form_factor(inside, n, &octa, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, 1.0, 1e-12);
  for (i = 0; i < 3; i++) CHECK(fabs(d.gradient[i]) < 1e-11);
  for (i = 0; i < 9; i++) CHECK(fabs(d.hessian[i]) < 1e-10);

  /* per triangle: the single-triangle calls, from outside (generic lanes) and inside */
  {
    double values[8], gradients[24], hessians[72];
    const raddiff_vec3 xs[2] = {inside, outside};
    int k;
    for (k = 0; k < 2; k++) {
      CHECK_STATUS(raddiff_mesh_solid_angle_each(xs[k], &octa, RADDIFF_ORDER_HESSIAN, values, gradients, hessians),
                   RADDIFF_OK);
      for (t = 0; t < 8; t++) {
        raddiff_deriv3 r;
        CHECK_STATUS(raddiff_triangle_solid_angle(xs[k], vtx((int)OCTA_I[t][0]), vtx((int)OCTA_I[t][1]),
                                                  vtx((int)OCTA_I[t][2]), RADDIFF_ORDER_HESSIAN, &r),
                     RADDIFF_OK);
        CHECK(rel_diff(values[t], gradients + 3 * t, hessians + 9 * t, &r) < 1e-12);
      }
      CHECK_STATUS(raddiff_mesh_form_factor_each(xs[k], n, &octa, RADDIFF_ORDER_HESSIAN, values, gradients, hessians),
                   RADDIFF_OK);
      for (t = 0; t < 8; t++) {
        raddiff_deriv3 r;
        CHECK_STATUS(raddiff_triangle_form_factor(xs[k], n, vtx((int)OCTA_I[t][0]), vtx((int)OCTA_I[t][1]),
                                                  vtx((int)OCTA_I[t][2]), RADDIFF_ORDER_HESSIAN, &r),
                     RADDIFF_OK);
        CHECK(rel_diff(values[t], gradients + 3 * t, hessians + 9 * t, &r) < 1e-12);
      }
    }
    /* value only: gradients and hessians may be NULL */
    CHECK_STATUS(raddiff_mesh_solid_angle_each(outside, &octa, RADDIFF_ORDER_VALUE, values, NULL, NULL), RADDIFF_OK);
    CHECK(values[0] > 0.0);
  }

  /* a double soup gives the same sums as the float mesh (the coordinates are exact in both) */
  {
    raddiff_vec3 soup[24];
    raddiff_triangle_mesh m;
    raddiff_deriv3 a, b;
    for (t = 0; t < 8; t++)
      for (i = 0; i < 3; i++) soup[3 * t + i] = vtx((int)OCTA_I[t][i]);
    m.vertices = soup;
    m.vertex_format = RADDIFF_VERTEX_DOUBLE3;
    m.vertex_stride = 0;
    m.vertex_count = 24;
    m.indices = NULL;
    m.index_stride = 0;
    m.triangle_count = 8;
    CHECK_STATUS(raddiff_mesh_solid_angle(outside, &m, RADDIFF_ORDER_HESSIAN, &a), RADDIFF_OK);
    CHECK_STATUS(raddiff_mesh_solid_angle(outside, &octa, RADDIFF_ORDER_HESSIAN, &b), RADDIFF_OK);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
    /* outside a closed surface the unsigned solid angles count the near and far side: 2x the
       silhouette's, not 0; the signed sum would be 0. Just check it is within (0, 4 pi). */
    CHECK(a.value > 0.0 && a.value < 4.0 * PI);
  }

  /* many points against one triangle */
  {
    const raddiff_vec3 a = {0.1, 0.2, 1.0}, b = {1.3, -0.1, 1.2}, c = {0.4, 1.1, 0.9};
    raddiff_vec3 pts[37], nrm[37];
    double values[37], gradients[111], hessians[333];
    for (i = 0; i < 37; i++) {
      pts[i].x = sin(0.37 * i) * 2.0;
      pts[i].y = cos(0.61 * i) * 2.0;
      pts[i].z = -0.5 + 0.2 * sin(0.23 * i);
      nrm[i].x = 0.0;
      nrm[i].y = 0.6;
      nrm[i].z = 0.8;
    }
    CHECK_STATUS(raddiff_points_solid_angle(pts, 37, a, b, c, RADDIFF_ORDER_HESSIAN, values, gradients, hessians),
                 RADDIFF_OK);
    for (i = 0; i < 37; i++) {
      raddiff_deriv3 r;
      CHECK_STATUS(raddiff_triangle_solid_angle(pts[i], a, b, c, RADDIFF_ORDER_HESSIAN, &r), RADDIFF_OK);
      CHECK(rel_diff(values[i], gradients + 3 * i, hessians + 9 * i, &r) < 1e-12);
    }
    CHECK_STATUS(raddiff_points_form_factor(pts, nrm, 37, a, b, c, RADDIFF_ORDER_GRADIENT, values, gradients, NULL),
                 RADDIFF_OK);
    for (i = 0; i < 37; i++) {
      raddiff_deriv3 r;
      double zero[9] = {0};
      CHECK_STATUS(raddiff_triangle_form_factor(pts[i], nrm[i], a, b, c, RADDIFF_ORDER_GRADIENT, &r), RADDIFF_OK);
      CHECK(rel_diff(values[i], gradients + 3 * i, zero, &r) < 1e-12);
    }

    /* a point at a vertex: DEGENERATE naming it, outputs untouched */
    pts[5] = b;
    values[0] = -7.0;
    CHECK_STATUS(raddiff_points_solid_angle(pts, 37, a, b, c, RADDIFF_ORDER_VALUE, values, NULL, NULL),
                 RADDIFF_ERROR_DEGENERATE);
    CHECK(strstr(raddiff_last_error(), "point 5") != NULL);
    CHECK(values[0] == -7.0);
    /* a non-unit normal: INVALID_ARGUMENT naming it */
    nrm[3].z = 2.0;
    CHECK_STATUS(raddiff_points_form_factor(pts, nrm, 3, a, b, c, RADDIFF_ORDER_VALUE, values, NULL, NULL),
                 RADDIFF_OK);
    CHECK_STATUS(raddiff_points_form_factor(pts, nrm, 4, a, b, c, RADDIFF_ORDER_VALUE, values, NULL, NULL),
                 RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "normal 3") != NULL);
  }

  /* validation: the first bad element is named, nothing is written */
  {
    raddiff_triangle_mesh m = octa;
    uint32_t bad_i[8][4];
    double values[8];
    raddiff_deriv3 untouched;
    untouched.value = -1.0;
    memcpy(bad_i, OCTA_I, sizeof bad_i);
    bad_i[5][2] = 6;
    m.indices = &bad_i[0][0];
    CHECK_STATUS(raddiff_mesh_solid_angle(inside, &m, RADDIFF_ORDER_VALUE, &untouched), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "index 2 of triangle 5 is 6") != NULL);
    CHECK(untouched.value == -1.0);
    m = octa;
    m.vertex_stride = 6; /* not a multiple of sizeof(float) ... and below 12 */
    CHECK_STATUS(raddiff_mesh_solid_angle(inside, &m, RADDIFF_ORDER_VALUE, &untouched), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "vertex stride 6") != NULL);
    m = octa;
    m.vertex_format = 7;
    CHECK_STATUS(raddiff_mesh_solid_angle(inside, &m, RADDIFF_ORDER_VALUE, &untouched), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "vertex_format 7") != NULL);
    m = octa;
    m.vertices = NULL;
    CHECK_STATUS(raddiff_mesh_solid_angle(inside, &m, RADDIFF_ORDER_VALUE, &untouched), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_mesh_solid_angle(inside, NULL, RADDIFF_ORDER_VALUE, &untouched), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_mesh_solid_angle(inside, &octa, 3, &untouched), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(untouched.value == -1.0);
    values[0] = -3.0;
    CHECK_STATUS(raddiff_mesh_solid_angle_each(inside, &octa, RADDIFF_ORDER_GRADIENT, values, NULL, NULL),
                 RADDIFF_ERROR_NULL_POINTER);
    CHECK(strstr(raddiff_last_error(), "gradients") != NULL);
    CHECK(values[0] == -3.0);
    /* x in the plane of triangles with derivatives: DEGENERATE naming the first such triangle */
    {
      const raddiff_vec3 on_plane = {0.5, 0.5, 0.0};
      const raddiff_vec3 up = {0, 0, 1};
      CHECK_STATUS(raddiff_mesh_form_factor(on_plane, up, &octa, RADDIFF_ORDER_GRADIENT, &untouched),
                   RADDIFF_ERROR_DEGENERATE);
      CHECK(strstr(raddiff_last_error(), "triangle 0") != NULL);
    }
    /* an empty mesh sums to 0 */
    m = octa;
    m.triangle_count = 0;
    CHECK_STATUS(raddiff_mesh_form_factor(inside, n, &m, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
    CHECK(d.value == 0.0);
  }
  CHECK_DONE("batch.c");
}
