/* The textbook formulas a C user writes for the kernels that bench_kernels.c times: plain double
   arithmetic and libm's atan2, in their own translation unit (called, not inlined, as raddiff's
   entry points are). Valid in generic configurations only: no clipping, no care for x near the
   plane, an edge or a vertex, no rescaling. */
#include "textbook.h"

#include <math.h>

static const double PI = 3.14159265358979323846;

static raddiff_vec3 sub(raddiff_vec3 a, raddiff_vec3 b) {
  raddiff_vec3 r = {a.x - b.x, a.y - b.y, a.z - b.z};
  return r;
}

static double dot(raddiff_vec3 a, raddiff_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

static raddiff_vec3 cross(raddiff_vec3 a, raddiff_vec3 b) {
  raddiff_vec3 r = {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
  return r;
}

static double norm(raddiff_vec3 a) { return sqrt(dot(a, a)); }

/* Van Oosterom and Strackee: Omega = 2 atan2(|r0 . (r1 x r2)|, l0 l1 l2 + (r0.r1) l2 + (r0.r2) l1
   + (r1.r2) l0). */
double textbook_solid_angle(raddiff_vec3 x, raddiff_vec3 a, raddiff_vec3 b, raddiff_vec3 c) {
  raddiff_vec3 r0 = sub(a, x), r1 = sub(b, x), r2 = sub(c, x);
  double l0 = norm(r0), l1 = norm(r1), l2 = norm(r2);
  double num = fabs(dot(r0, cross(r1, r2)));
  double den = l0 * l1 * l2 + dot(r0, r1) * l2 + dot(r0, r2) * l1 + dot(r1, r2) * l0;
  return 2.0 * atan2(num, den);
}

/* Lambert: F = |sum_i beta_i n.(r_i x r_{i+1}) / |r_i x r_{i+1}|| / (2 pi), beta_i the angle between
   r_i and r_{i+1}. */
double textbook_triangle_form_factor(raddiff_vec3 x, raddiff_vec3 n, raddiff_vec3 a, raddiff_vec3 b,
                                     raddiff_vec3 c) {
  raddiff_vec3 r[3];
  double sum = 0.0;
  int i;
  r[0] = sub(a, x);
  r[1] = sub(b, x);
  r[2] = sub(c, x);
  for (i = 0; i < 3; i++) {
    raddiff_vec3 w = cross(r[i], r[(i + 1) % 3]);
    double s = norm(w);
    sum += atan2(s, dot(r[i], r[(i + 1) % 3])) * dot(n, w) / s;
  }
  return fabs(sum) / (2.0 * PI);
}
