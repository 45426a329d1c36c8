/* The same toy C renderer with raddiff's low-level calls: what raddiff_cache_irradiance does on a
   miss, step by step, for renderers that need control over it. */
#include "raddiff.h"
#include <math.h>
#include <stdio.h>

#define SIZE 32
#define M 16
#define N 48

/* The scene: a floor (z = 0) under a ceiling (z = 1) that emits (1, 0.8, 0.6) where y > 0. */
static void trace(raddiff_vec3 o, const raddiff_vec3 *dirs, double *distance, float *radiance) {
  int i;
  for (i = 0; i < M * N; ++i) {
    const double t = dirs[i].z > 0.0 ? (1.0 - o.z) / dirs[i].z : INFINITY;
    const int lit = t < INFINITY && o.y + t * dirs[i].y > 0.0;
    distance[i] = t;
    radiance[3 * i + 0] = lit ? 1.0f : 0.0f;
    radiance[3 * i + 1] = lit ? 0.8f : 0.0f;
    radiance[3 * i + 2] = lit ? 0.6f : 0.0f;
  }
}

static double clamp(double r, double lo, double hi) { return r < lo ? lo : r > hi ? hi : r; }

/* A record for the shading point x (normal n, pixel footprint `pixel`, gather seed `seed`). */
static raddiff_status insert_record(raddiff_cache *cache, raddiff_vec3 x, raddiff_vec3 n, double pixel,
                                    uint64_t seed) {
  static const double luminance[3] = {0.2126, 0.7152, 0.0722};
  const raddiff_gather_layout layout = {RADDIFF_LAYOUT_COSINE_POLAR, M, N, seed};
  const raddiff_frame frame = {x, n, {1.0, 0.0, 0.0}}; /* any unit tangent perpendicular to n */
  raddiff_vec3 dirs[M * N], axes[2];
  double distance[M * N], irradiance[3], gradient[9], rotation[9], hessian[27], h[9] = {0}, radii[2], e;
  float radiance[3 * M * N], value[3], gradient_f[9], rotation_f[9];
  raddiff_gather_input in = {0};
  raddiff_gather_output out = {0};
  raddiff_cache_record rec;
  raddiff_status status;
  int c, k;
  /* 1. directions, 2. trace them */
  if ((status = raddiff_gather_directions(&layout, &frame, dirs)) != RADDIFF_OK) return status;
  trace(x, dirs, distance, radiance);
  /* 3. irradiance, gradients and the occlusion-aware Hessian, per channel */
  in.directions = dirs, in.distance = distance, in.radiance = radiance, in.channels = 3;
  out.irradiance = irradiance, out.gradient = gradient, out.rotation_gradient = rotation;
  out.hessian = hessian;
  if ((status = raddiff_gather_evaluate(&layout, &frame, &in, &out)) != RADDIFF_OK) return status;
  /* 4. radii from the luminance Hessian, with the curvature floor of the harmonic-mean distance D
        (every ray missed: D is infinite and there is no floor), clamped to 1..150 pixels */
  e = 0.0;
  for (c = 0; c < 3; ++c) {
    e += luminance[c] * irradiance[c];
    for (k = 0; k < 9; ++k) h[k] += luminance[c] * hessian[9 * c + k];
  }
  status = isfinite(out.harmonic_mean_distance)
               ? raddiff_surface_radii_floored(h, n, e, 1e-4, RADDIFF_ERROR_RELATIVE, 2.0,
                                               out.harmonic_mean_distance, RADDIFF_CURVATURE_FLOOR_WEIGHT,
                                               radii, axes)
               : raddiff_surface_radii(h, n, e, 1e-4, RADDIFF_ERROR_RELATIVE, 2.0, radii, axes);
  if (status != RADDIFF_OK) return status;
  /* 5. the record: doubles to floats, radii[2] the smaller radius (along the normal) */
  for (k = 0; k < 9; ++k) gradient_f[k] = (float)gradient[k], rotation_f[k] = (float)rotation[k];
  for (c = 0; c < 3; ++c) value[c] = (float)irradiance[c];
  rec.position = x, rec.normal = n;
  rec.value = value, rec.gradient = gradient_f, rec.rotation_gradient = rotation_f;
  rec.radii[0] = clamp(radii[0], pixel, 150.0 * pixel);
  rec.radii[1] = clamp(radii[1], pixel, 150.0 * pixel);
  rec.radii[2] = rec.radii[0] < rec.radii[1] ? rec.radii[0] : rec.radii[1];
  rec.axes[0] = axes[0], rec.axes[1] = axes[1], rec.axes[2] = n;
  /* 6. insert (thread-safe; the cache limits the gradients as configured) */
  return raddiff_cache_insert(cache, &rec);
}

int main(void) {
  const double pixel = 2.0 / SIZE;
  const raddiff_vec3 n = {0.0, 0.0, 1.0};
  /* tent weights for Hessian radii, values clamped at 0, the default gradient limit */
  const raddiff_cache_config config = {
      3, RADDIFF_DOMAIN_SURFACE,
      RADDIFF_INTERP_TENT | RADDIFF_INTERP_NON_NEGATIVE | RADDIFF_INTERP_GRADIENT_LIMIT, 0.2};
  raddiff_cache *cache = raddiff_cache_new(&config);
  double err2 = 0.0, ref2 = 0.0;
  int step, i, j;
  if (cache == NULL) return 1;
  for (step = 8; step >= 1; step /= 2)
    for (j = 0; j < SIZE; j += step)
      for (i = 0; i < SIZE; i += step) {
        const raddiff_vec3 x = {-1.0 + (i + 0.5) * pixel, -1.0 + (j + 0.5) * pixel, 1e-4 * 2.0};
        float e[3];
        if (raddiff_cache_lookup(cache, x, n, e, NULL) == RADDIFF_ERROR_NOT_FOUND) {
          /* a seed per pixel: the same records whatever the thread that gets there first */
          if (insert_record(cache, x, n, pixel, 1 + (uint64_t)(j * SIZE + i)) != RADDIFF_OK ||
              raddiff_cache_lookup(cache, x, n, e, NULL) != RADDIFF_OK) {
            fprintf(stderr, "raddiff: %s\n", raddiff_last_error());
            return 1;
          }
        }
        if (step == 1) {
          const double y = x.y, h = 1.0 - x.z;
          const double exact = 3.14159265358979 * (1.0 + y / sqrt(y * y + h * h)) / 2.0;
          err2 += (e[0] - exact) * (e[0] - exact);
          ref2 += exact * exact;
        }
      }
  printf("%zu records, relative RMS error %.4f\n", raddiff_cache_len(cache), sqrt(err2 / ref2));
  raddiff_cache_free(cache);
  return sqrt(err2 / ref2) < 0.02 ? 0 : 1;
}
