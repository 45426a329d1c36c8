/* raddiff_refractive_mesh_* and raddiff_single_scatter through the C header only: the flat-interface
   value against the closed-form 1D Snell solution, and the error paths. */
#include "raddiff.h"
#include "check.h"
#include <float.h>
#include <math.h>
#include <string.h>

static const double ETA = 1.5, SIGMA_T = 0.8, SIGMA_S = 0.6, G = 0.4;
static const double LX = 0.3, LY = -0.2, LZ = 2.0;

/* Contribution per unit length at V = entry + x u below the plane z = 0 (closed form). */
static double reference(const double e[3], const double u[3], double x) {
  const double pi = 3.14159265358979323846;
  double v[3], fx, fy, r, lo, hi, rho, p[3], dl, dv, cl, cv, sag, tan_, rs, rp, t, mu, phase;
  int i;
  for (i = 0; i < 3; i++) v[i] = e[i] + x * u[i];
  fx = v[0] - LX;
  fy = v[1] - LY;
  r = sqrt(fx * fx + fy * fy);
  lo = 0.0;
  hi = r;
  for (i = 0; i < 200; i++) {
    double m = 0.5 * (lo + hi);
    double res = m / sqrt(m * m + LZ * LZ) - ETA * (r - m) / sqrt((r - m) * (r - m) + v[2] * v[2]);
    if (res < 0.0) lo = m; else hi = m;
  }
  rho = 0.5 * (lo + hi);
  p[0] = LX + rho * fx / r;
  p[1] = LY + rho * fy / r;
  p[2] = 0.0;
  dl = sqrt((LX - p[0]) * (LX - p[0]) + (LY - p[1]) * (LY - p[1]) + LZ * LZ);
  dv = sqrt((v[0] - p[0]) * (v[0] - p[0]) + (v[1] - p[1]) * (v[1] - p[1]) + v[2] * v[2]);
  cl = LZ / dl;
  cv = -v[2] / dv;
  sag = (ETA * dl + dv) / ETA;
  tan_ = dl * cv / cl + dv * cl / (ETA * cv);
  rs = (cl - ETA * cv) / (cl + ETA * cv);
  rp = (ETA * cl - cv) / (ETA * cl + cv);
  t = 1.0 - 0.5 * (rs * rs + rp * rp);
  mu = -((v[0] - p[0]) * u[0] + (v[1] - p[1]) * u[1] + v[2] * u[2]) / dv;
  phase = (1.0 - G * G) / (4.0 * pi * pow(1.0 + G * G - 2.0 * G * mu, 1.5));
  return SIGMA_S * phase * t * exp(-SIGMA_T * (x + dv)) / (sag * tan_);
}

int main(void) {
  const float positions[9] = {-100, -100, 0, 200, -100, 0, -100, 200, 0};
  const float normals[9] = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  const uint32_t indices[3] = {0, 1, 2};
  const uint32_t bad_indices[3] = {0, 1, 3};
  const float nan_normals[9] = {0, 0, 1, 0, 0, NAN, 0, 0, 1};
  const float zero_normals[9] = {0, 0, 1, 0, 0, 0, 0, 0, 1};
  const float flat_positions[9] = {0, 0, 0, 1, 1, 1, 2, 2, 2};
  raddiff_medium medium = {1.5, 0.8, 0.6, 0.4};
  raddiff_vec3 entry = {-0.5, 0.1, -0.2}, exit = {0.8, 0.3, -1.5}, light = {0.3, -0.2, 2.0};
  double e[3], u[3], len, ref = 0.0, radiance = -1.0;
  int i, k;
  raddiff_refractive_mesh *mesh = raddiff_refractive_mesh_new(positions, normals, 3, indices, 1);
  CHECK(mesh != NULL);

  /* Closed-form reference: composite Simpson with 20000 intervals (error ~1e-14 here). */
  e[0] = entry.x; e[1] = entry.y; e[2] = entry.z;
  u[0] = exit.x - entry.x; u[1] = exit.y - entry.y; u[2] = exit.z - entry.z;
  len = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
  for (i = 0; i < 3; i++) u[i] /= len;
  {
    const int n = 20000;
    const double h = len / n;
    for (k = 0; k <= n; k++) {
      double w = (k == 0 || k == n) ? 1.0 : (k % 2 ? 4.0 : 2.0);
      ref += w * reference(e, u, k * h);
    }
    ref *= h / 3.0;
  }
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, exit, light, 3.0, &radiance), RADDIFF_OK);
  CHECK_CLOSE(radiance / 3.0, ref, 1e-6 * ref);

  /* Linear in the intensity up to the largest double; past it, refused rather than infinite. A light
     1e-6 above the interface beside an eye segment that starts 1e-6 below it gives about 1e4 per
     unit intensity, so an intensity of DBL_MAX overflows and DBL_MAX / (2 * that) does not. */
  {
    const raddiff_vec3 near_entry = {0.1, 0.1, -1e-6}, near_exit = {0.5, 0.1, -1.0}, near_light = {0.1 + 1e-6, 0.1, 1e-6};
    double unit = -1.0, fits;
    CHECK_STATUS(raddiff_single_scatter(mesh, &medium, near_entry, near_exit, near_light, 1.0, &unit), RADDIFF_OK);
    CHECK(unit > 1.0 && isfinite(unit));
    fits = DBL_MAX / (2.0 * unit);
    CHECK_STATUS(raddiff_single_scatter(mesh, &medium, near_entry, near_exit, near_light, fits, &radiance), RADDIFF_OK);
    CHECK(isfinite(radiance));
    CHECK_CLOSE(radiance / (0.5 * DBL_MAX), 1.0, 1e-12);
    radiance = 42.0;
    CHECK_STATUS(raddiff_single_scatter(mesh, &medium, near_entry, near_exit, near_light, DBL_MAX, &radiance), RADDIFF_ERROR_DEGENERATE);
    CHECK(strstr(raddiff_last_error(), "overflows") != NULL);
    CHECK(radiance == 42.0);
  }

  /* error paths: the output stays untouched */
  radiance = 42.0;
  CHECK_STATUS(raddiff_single_scatter(NULL, &medium, entry, exit, light, 1.0, &radiance), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "mesh") != NULL);
  CHECK_STATUS(raddiff_single_scatter(mesh, NULL, entry, exit, light, 1.0, &radiance), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, exit, light, 1.0, NULL), RADDIFF_ERROR_NULL_POINTER);
  medium.eta = 1.0;
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, exit, light, 1.0, &radiance), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "eta") != NULL);
  medium.eta = 0.5;
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, exit, light, 1.0, &radiance), RADDIFF_ERROR_INVALID_ARGUMENT);
  medium.eta = 1.5;
  medium.sigma_s = 2.0;
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, exit, light, 1.0, &radiance), RADDIFF_ERROR_INVALID_ARGUMENT);
  medium.sigma_s = 0.6;
  entry.y = NAN;
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, exit, light, 1.0, &radiance), RADDIFF_ERROR_INVALID_ARGUMENT);
  entry.y = 0.1;
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, exit, light, INFINITY, &radiance), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(radiance == 42.0);
  /* a zero-length segment is legal and gives 0 */
  CHECK_STATUS(raddiff_single_scatter(mesh, &medium, entry, entry, light, 1.0, &radiance), RADDIFF_OK);
  CHECK(radiance == 0.0);

  /* constructor failures return NULL with a message */
  CHECK(raddiff_refractive_mesh_new(NULL, normals, 3, indices, 1) == NULL);
  CHECK(strstr(raddiff_last_error(), "positions") != NULL);
  CHECK(raddiff_refractive_mesh_new(positions, NULL, 3, indices, 1) == NULL);
  CHECK(raddiff_refractive_mesh_new(positions, normals, 3, NULL, 1) == NULL);
  CHECK(raddiff_refractive_mesh_new(positions, normals, 3, bad_indices, 1) == NULL);
  CHECK(strstr(raddiff_last_error(), "vertex 3") != NULL);
  CHECK(raddiff_refractive_mesh_new(positions, normals, 3, indices, 0) == NULL);
  CHECK(strstr(raddiff_last_error(), "no triangles") != NULL);
  CHECK(raddiff_refractive_mesh_new(positions, nan_normals, 3, indices, 1) == NULL);
  CHECK(strstr(raddiff_last_error(), "not finite") != NULL);
  CHECK(raddiff_refractive_mesh_new(positions, zero_normals, 3, indices, 1) == NULL);
  CHECK(strstr(raddiff_last_error(), "zero") != NULL);
  CHECK(raddiff_refractive_mesh_new(flat_positions, normals, 3, indices, 1) == NULL);
  CHECK(strstr(raddiff_last_error(), "zero area") != NULL);
  CHECK(raddiff_refractive_mesh_new(positions, normals, (size_t)-1, indices, 1) == NULL);

  raddiff_refractive_mesh_free(mesh);
  raddiff_refractive_mesh_free(NULL);
  CHECK_DONE("scatter.c");
}
