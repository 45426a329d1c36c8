/* Irradiance caching in a toy C renderer, one raddiff call per shading point. */
#include "raddiff.h"
#include <math.h>
#include <stdio.h>

#define SIZE 32 /* image pixels per side; the camera looks straight down at the floor [-1, 1]^2 */

/* The scene: a floor (z = 0) under a ceiling (z = 1) that emits (1, 0.8, 0.6) where y > 0. Trace
   every direction from `o`: hit distance (INFINITY: miss) and the radiance arriving along it. */
static int trace(void *user, raddiff_vec3 o, const raddiff_vec3 *dirs, size_t count,
                 double *distance, float *radiance) {
  size_t i;
  (void)user; /* your scene, BVH, ray packets, ... */
  for (i = 0; i < count; ++i) {
    const double t = dirs[i].z > 0.0 ? (1.0 - o.z) / dirs[i].z : INFINITY;
    const int lit = t < INFINITY && o.y + t * dirs[i].y > 0.0;
    distance[i] = t;
    radiance[3 * i + 0] = lit ? 1.0f : 0.0f;
    radiance[3 * i + 1] = lit ? 0.8f : 0.0f;
    radiance[3 * i + 2] = lit ? 0.6f : 0.0f;
  }
  return 0; /* non-zero abandons the call: RADDIFF_ERROR_CALLBACK, nothing inserted */
}

static int fail(void) {
  fprintf(stderr, "raddiff: %s\n", raddiff_last_error());
  return 1;
}

int main(void) {
  const double pixel = 2.0 / SIZE; /* the footprint: one pixel's size on the floor */
  const raddiff_vec3 n = {0.0, 0.0, 1.0};
  static float image[SIZE][SIZE][3];
  raddiff_irradiance_settings s = raddiff_irradiance_settings_default();
  raddiff_cache *cache, *reloaded;
  double err2 = 0.0, ref2 = 0.0;
  int step, i, j;
  s.gather_m = 16, s.gather_n = 48; /* 768 rays per record */
  s.accuracy = 1e-4;                /* the Hessian metric's error bound (L^2) */
  cache = raddiff_irradiance_cache_new(&s);
  if (cache == NULL) return fail();

  /* coarse to fine (an overture over every 8th, 4th, 2nd pixel, then all): early records spread */
  for (step = 8; step >= 1; step /= 2)
    for (j = 0; j < SIZE; j += step)
      for (i = 0; i < SIZE; i += step) {
        /* the camera ray hits the floor at distance 2; pull the point back towards the camera */
        const raddiff_vec3 x = {-1.0 + (i + 0.5) * pixel, -1.0 + (j + 0.5) * pixel, 1e-4 * 2.0};
        if (raddiff_cache_irradiance(cache, &s, x, n, pixel, trace, NULL, image[j][i]) != RADDIFF_OK)
          return fail();
      }

  /* against the exact irradiance of the half-lit ceiling, pi L (1 + y / sqrt(y^2 + h^2)) / 2 */
  for (j = 0; j < SIZE; ++j)
    for (i = 0; i < SIZE; ++i) {
      const double y = -1.0 + (j + 0.5) * pixel, h = 1.0 - 2e-4;
      const double exact = 3.14159265358979 * (1.0 + y / sqrt(y * y + h * h)) / 2.0;
      err2 += (image[j][i][0] - exact) * (image[j][i][0] - exact);
      ref2 += exact * exact;
    }
  printf("%zu records for %d pixels, relative RMS error %.4f\n", raddiff_cache_len(cache), SIZE * SIZE,
         sqrt(err2 / ref2));

  /* save the cache and use it again (another frame, another run) */
  if (raddiff_cache_save(cache, "irradiance.rdc") != RADDIFF_OK) return fail();
  reloaded = raddiff_cache_load("irradiance.rdc");
  if (reloaded == NULL) return fail();
  raddiff_cache_free(reloaded);
  raddiff_cache_free(cache);
  return sqrt(err2 / ref2) < 0.02 ? 0 : 1;
}
