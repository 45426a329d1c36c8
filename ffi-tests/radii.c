/* raddiff_surface_radii and raddiff_volume_radii through the C header only. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

static const double PI = 3.14159265358979323846;

int main(void) {
  double h[9] = {3, 0, 0, 0, 3, 0, 0, 0, 3};
  raddiff_vec3 z = {0.0, 0.0, 1.0};
  double radii[3] = {0, 0, 0};
  raddiff_vec3 axes[3];
  int i;

  /* isotropic: thesis eq. 4.19, R = (4 eps / (pi lambda))^(1/4) */
  CHECK_STATUS(raddiff_surface_radii(h, z, 1.0, 0.02, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes), RADDIFF_OK);
  CHECK_CLOSE(radii[0], pow(4.0 * 0.02 / (PI * 3.0), 0.25), 1e-13);
  CHECK_CLOSE(radii[1], radii[0], 1e-13);
  for (i = 0; i < 2; i++) {
    CHECK_CLOSE(axes[i].z, 0.0, 1e-15);
    CHECK_CLOSE(axes[i].x * axes[i].x + axes[i].y * axes[i].y, 1.0, 1e-14);
  }
  /* relative mode divides by the value: same radii with error and value scaled inversely */
  CHECK_STATUS(raddiff_surface_radii(h, z, 4.0, 0.005, RADDIFF_ERROR_RELATIVE, 2.0, radii, axes), RADDIFF_OK);
  CHECK_CLOSE(radii[0], pow(4.0 * 0.02 / (PI * 3.0), 0.25), 1e-13);

  /* anisotropic tangent Hessian diag(16, 1): radii ratio sqrt(16) = 4, bound (pi/8) a b (16 a^2 + b^2) = eps */
  {
    double ha[9] = {1, 0, 0, 0, 16, 0, 0, 0, 100}; /* the zz entry is off the tangent plane: ignored */
    double a;
    CHECK_STATUS(raddiff_surface_radii(ha, z, 1.0, 0.01, RADDIFF_ERROR_ABSOLUTE, 10.0, radii, axes), RADDIFF_OK);
    a = pow(0.01 / (16.0 * PI), 0.25);
    CHECK_CLOSE(radii[0], a, 1e-13);
    CHECK_CLOSE(radii[1], 4.0 * a, 1e-13);
    CHECK_CLOSE(fabs(axes[0].y), 1.0, 1e-13); /* strongest curvature along y */
    CHECK_CLOSE(fabs(axes[1].x), 1.0, 1e-13);
    /* anisotropy clamp */
    CHECK_STATUS(raddiff_surface_radii(ha, z, 1.0, 0.01, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes), RADDIFF_OK);
    CHECK_CLOSE(radii[1] / radii[0], 2.0, 1e-13);
  }

  /* volume: isotropic R = (5 tau / (2 pi |lambda|))^(1/5) */
  CHECK_STATUS(raddiff_volume_radii(h, 2.0, 0.05, RADDIFF_ERROR_RELATIVE, 2.0, radii, axes), RADDIFF_OK);
  for (i = 0; i < 3; i++) CHECK_CLOSE(radii[i], pow(5.0 * 0.1 / (2.0 * PI * 3.0), 0.2), 1e-13);
  CHECK_CLOSE(axes[0].x * axes[1].x + axes[0].y * axes[1].y + axes[0].z * axes[1].z, 0.0, 1e-13);

  /* zero Hessian: the documented maximum radius */
  {
    double zero[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    CHECK_STATUS(raddiff_volume_radii(zero, 1.0, 0.1, RADDIFF_ERROR_RELATIVE, 2.0, radii, axes), RADDIFF_OK);
    CHECK(radii[0] == RADDIFF_MAX_RADIUS && radii[2] == RADDIFF_MAX_RADIUS);
    CHECK_STATUS(raddiff_surface_radii(zero, z, 1.0, 0.1, RADDIFF_ERROR_RELATIVE, 2.0, radii, axes), RADDIFF_OK);
    CHECK(radii[0] == RADDIFF_MAX_RADIUS && radii[1] == RADDIFF_MAX_RADIUS);
  }

  /* the curvature floor: a flat estimate or a black gather gets (4 eps D^2 / (pi kappa))^(1/4) */
  {
    double zero[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    double d = 0.5, eps = 1e-3;
    double expect = pow(4.0 * eps * d * d / (PI * RADDIFF_CURVATURE_FLOOR_WEIGHT), 0.25);
    CHECK_STATUS(raddiff_surface_radii_floored(zero, z, 2.0, eps, RADDIFF_ERROR_RELATIVE, 2.0, d,
                                               RADDIFF_CURVATURE_FLOOR_WEIGHT, radii, axes),
                 RADDIFF_OK);
    CHECK_CLOSE(radii[0], expect, 1e-12);
    CHECK_CLOSE(radii[1], expect, 1e-12);
    CHECK_STATUS(raddiff_surface_radii_floored(zero, z, 0.0, eps, RADDIFF_ERROR_RELATIVE, 2.0, d,
                                               RADDIFF_CURVATURE_FLOOR_WEIGHT, radii, axes),
                 RADDIFF_OK);
    CHECK_CLOSE(radii[0], expect, 1e-12);
    /* weight 0: exactly raddiff_surface_radii */
    CHECK_STATUS(raddiff_surface_radii_floored(h, z, 1.0, 0.02, RADDIFF_ERROR_ABSOLUTE, 2.0, d, 0.0, radii, axes),
                 RADDIFF_OK);
    CHECK_CLOSE(radii[0], pow(4.0 * 0.02 / (PI * 3.0), 0.25), 1e-13);
    radii[0] = 42.0;
    CHECK_STATUS(raddiff_surface_radii_floored(zero, z, 2.0, eps, RADDIFF_ERROR_RELATIVE, 2.0, 0.0,
                                               RADDIFF_CURVATURE_FLOOR_WEIGHT, radii, axes),
                 RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "distance") != NULL);
    CHECK(radii[0] == 42.0);
  }

  /* error paths: outputs untouched */
  radii[0] = radii[1] = radii[2] = 42.0;
  axes[0].x = 42.0;
  CHECK_STATUS(raddiff_surface_radii(NULL, z, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
               RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "hessian") != NULL);
  CHECK_STATUS(raddiff_surface_radii(h, z, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, NULL, axes),
               RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_surface_radii(h, z, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, NULL),
               RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "axes") != NULL);
  CHECK_STATUS(raddiff_surface_radii(h, z, 1.0, 0.1, 7, 2.0, radii, axes), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "mode") != NULL);
  CHECK_STATUS(raddiff_surface_radii(h, z, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 0.5, radii, axes),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_surface_radii(h, z, 1.0, -1.0, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_surface_radii(h, z, NAN, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  {
    raddiff_vec3 longer = {0.0, 0.0, 2.0};
    CHECK_STATUS(raddiff_surface_radii(h, longer, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
                 RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "unit") != NULL);
  }
  h[4] = INFINITY;
  CHECK_STATUS(raddiff_surface_radii(h, z, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_volume_radii(h, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  h[4] = 3.0;
  CHECK_STATUS(raddiff_volume_radii(NULL, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
               RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_volume_radii(h, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, NULL, axes),
               RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_volume_radii(h, 1.0, 0.1, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, NULL),
               RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_volume_radii(h, 1.0, 0.1, 2, 2.0, radii, axes), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_volume_radii(h, 1.0, INFINITY, RADDIFF_ERROR_ABSOLUTE, 2.0, radii, axes),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(radii[0] == 42.0 && radii[1] == 42.0 && radii[2] == 42.0 && axes[0].x == 42.0);

  CHECK_DONE("radii.c");
}
