/* raddiff_surface_radii, raddiff_surface_radii_floored and raddiff_volume_radii on hostile but
   finite Hessians (issue 17): entries of +-1e300, +-DBL_MAX, subnormal, zero, indefinite,
   non-symmetric. Every call succeeds with finite radii in [0, RADDIFF_MAX_RADIUS], ascending;
   non-finite entries are refused with outputs untouched. */
#include "raddiff.h"
#include "check.h"
#include <float.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

static int radii_ok(const double *r, int count) {
  int i, ok = 1;
  for (i = 0; i < count; i++) ok = ok && isfinite(r[i]) && r[i] >= 0.0 && r[i] <= RADDIFF_MAX_RADIUS;
  for (i = 1; i < count; i++) ok = ok && r[i - 1] <= r[i];
  return ok;
}

int main(void) {
  const double entries[12] = {0.0, 1.0, -1.0, 1e300, -1e300, DBL_MAX, -DBL_MAX, 4.9e-324, -4.9e-324, 1e-300, 2.5, -7e150};
  const raddiff_vec3 normal = {0.6, 0.0, 0.8};
  unsigned long state = 12345;
  int s, i, calls = 0;
  double radii[3];
  raddiff_vec3 axes[3];

  for (s = 0; s < 4000; s++) {
    double h[9];
    for (i = 0; i < 9; i++) {
      state = state * 6364136223846793005UL + 1442695040888963407UL;
      h[i] = entries[(state >> 33) % 12];
    }
    if (s % 3 == 0) { /* diagonal, often indefinite */
      h[1] = h[2] = h[3] = h[5] = h[6] = h[7] = 0.0;
    }
    CHECK_STATUS(raddiff_surface_radii(h, normal, 1.0, 0.05, RADDIFF_ERROR_RELATIVE, 2.0, radii, axes), RADDIFF_OK);
    CHECK(radii_ok(radii, 2));
    CHECK_STATUS(raddiff_surface_radii(h, normal, 1e300, 1e300, RADDIFF_ERROR_ABSOLUTE, 1e200, radii, axes), RADDIFF_OK);
    CHECK(radii_ok(radii, 2));
    CHECK_STATUS(raddiff_surface_radii_floored(h, normal, 1e-300, 0.05, RADDIFF_ERROR_ABSOLUTE, 2.0, 1e-200,
                                               RADDIFF_CURVATURE_FLOOR_WEIGHT, radii, axes),
                 RADDIFF_OK);
    CHECK(radii_ok(radii, 2));
    CHECK_STATUS(raddiff_volume_radii(h, 2.0, 1e-300, RADDIFF_ERROR_RELATIVE, 4.0, radii, axes), RADDIFF_OK);
    CHECK(radii_ok(radii, 3));
    calls += 4;
  }
  CHECK(calls == 16000);

  /* 1e300 * identity: the isotropic radius (4 tau / (pi 1e300))^(1/4) = 1.1284e-75 * tau^(1/4) */
  {
    double h[9] = {1e300, 0, 0, 0, 1e300, 0, 0, 0, 1e300};
    CHECK_STATUS(raddiff_surface_radii(h, normal, 1.0, 0.01, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes), RADDIFF_OK);
    CHECK_CLOSE(radii[0] * 1e75, pow(4.0 * 0.01 / PI, 0.25), 1e-12);
    CHECK_CLOSE(radii[1], radii[0], 1e-12);
  }
  /* a subnormal Hessian: the radius formula exceeds RADDIFF_MAX_RADIUS */
  {
    double h[9] = {4.9e-324, 0, 0, 0, 4.9e-324, 0, 0, 0, 4.9e-324};
    CHECK_STATUS(raddiff_volume_radii(h, 1.0, 0.01, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes), RADDIFF_OK);
    CHECK(radii[0] == RADDIFF_MAX_RADIUS && radii[2] == RADDIFF_MAX_RADIUS);
  }
  /* non-finite entries are refused, outputs untouched */
  {
    double h[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    h[4] = INFINITY;
    radii[0] = radii[1] = -3.0;
    CHECK_STATUS(raddiff_surface_radii(h, normal, 1.0, 0.05, RADDIFF_ERROR_RELATIVE, 2.0, radii, axes),
                 RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(radii[0] == -3.0 && radii[1] == -3.0);
    CHECK(strstr(raddiff_last_error(), "hessian") != NULL);
  }
  CHECK_DONE("radii_hostile");
}
