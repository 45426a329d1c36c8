/* raddiff_cache_irradiance_near_far through the header: a point under a ceiling against the
   closed form (miss and hit), what the callback is asked for, the far-field marker saved and
   loaded, the plain call refused on a far-field cache, every refusal leaving `out` and the cache
   untouched, and the near field's parts (raddiff_cache_irradiance_near_far_parts). */
#include "raddiff.h"
#include "check.h"
#include <stdio.h>
#include <string.h>

#define PI 3.14159265358979323846

/* The plane z = 0 under a ceiling at height 0.5 of radiance (2, 1, 0.5); rays stop at
   `max_distance`. */
typedef struct scene {
  int calls;
  size_t last_count;
  double last_max;
  int fail;
  int poison; /* write a negative distance */
  float scale;
} scene;

static int trace(void *user, raddiff_vec3 o, const raddiff_vec3 *d, size_t count, double max_distance,
                 double *distance, float *radiance) {
  scene *s = (scene *)user;
  size_t i;
  s->calls++;
  s->last_count = count;
  s->last_max = max_distance;
  if (s->fail) return s->fail;
  for (i = 0; i < count; ++i) {
    const double t = (0.5 - o.z) / (d[i].z > 1e-12 ? d[i].z : 1e-12);
    if (t >= max_distance) {
      distance[i] = INFINITY; /* radiance left as it is */
      continue;
    }
    distance[i] = t;
    radiance[3 * i] = 2.0f * s->scale;
    radiance[3 * i + 1] = 1.0f * s->scale;
    radiance[3 * i + 2] = 0.5f * s->scale;
  }
  if (s->poison) distance[0] = -1.0;
  return 0;
}

static raddiff_irradiance_settings near_far_settings(void) {
  raddiff_irradiance_settings s = raddiff_irradiance_settings_default();
  s.gather_m = 16;
  s.gather_n = 48;
  s.world_radius_min = 0.01;
  s.world_radius_max = 5.0;
  s.near_field_reach_pixels = 100.0; /* with footprint 0.01: a reach of 1 */
  s.near_field_m = 8;
  s.near_field_n = 8;
  return s;
}

int main(void) {
  raddiff_irradiance_settings s = near_far_settings(), bad;
  const raddiff_vec3 x = {0.0, 0.0, 0.0}, up = {0.0, 0.0, 1.0}, nearby = {0.003, -0.002, 0.0};
  const raddiff_vec3 nan_point = {NAN, 0.0, 0.0};
  scene sc = {0, 0, 0.0, 0, 0, 1.0f};
  float out[3] = {-1.0f, -1.0f, -1.0f};
  double world = -1.0, pixels = -1.0;
  raddiff_cache *cache, *loaded, *plain;
  const char *path = "raddiff-ffi-near-far.rdfcache";
  int c;

  /* the defaults: off, 32 x 32 near rays */
  {
    const raddiff_irradiance_settings d = raddiff_irradiance_settings_default();
    CHECK(d.near_field_reach_world == 0.0 && d.near_field_reach_pixels == 0.0);
    CHECK(d.near_field_m == 32 && d.near_field_n == 32);
  }
  cache = raddiff_irradiance_cache_new(&s);
  CHECK(cache != NULL);
  CHECK_STATUS(raddiff_cache_get_far_field(cache, &world, &pixels), RADDIFF_OK);
  CHECK(world == 0.0 && pixels == 100.0);

  /* a miss traces the record's gather without a bound; V = (h/rho)^2 = 1/4, and the value is
     pi L at every point (the far field is L everywhere) */
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, x, up, 0.01, trace, &sc, out), RADDIFF_OK);
  CHECK(sc.calls == 1 && sc.last_count == 16 * 48 && isinf(sc.last_max));
  CHECK(raddiff_cache_len(cache) == 1);
  for (c = 0; c < 3; ++c) CHECK_CLOSE(out[c], PI * (2.0 / (1 << c)), 1e-5);
  /* a hit traces the 8 x 8 near rays no farther than the reach */
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, nearby, up, 0.01, trace, &sc, out), RADDIFF_OK);
  CHECK(sc.calls == 2 && sc.last_count == 64 && sc.last_max == 1.0);
  CHECK(raddiff_cache_len(cache) == 1);
  for (c = 0; c < 3; ++c) CHECK_CLOSE(out[c], PI * (2.0 / (1 << c)), 1e-5);

  /* refusals: out and the cache untouched */
  out[0] = -7.0f;
  CHECK_STATUS(raddiff_cache_irradiance_near_far(NULL, &s, x, up, 0.01, trace, &sc, out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, NULL, x, up, 0.01, trace, &sc, out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, x, up, 0.01, NULL, &sc, out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, x, up, 0.01, trace, &sc, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, nan_point, up, 0.01, trace, &sc, out),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  /* a reach in pixels needs the footprint */
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, x, up, 0.0, trace, &sc, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "footprint") != NULL);
  /* settings without a reach, or with another one than the cache's */
  bad = s, bad.near_field_reach_pixels = 0.0;
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &bad, x, up, 0.01, trace, &sc, out),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "no near-field reach") != NULL);
  bad = s, bad.near_field_reach_pixels = 4.0;
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &bad, x, up, 0.01, trace, &sc, out),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "far-field reach") != NULL);
  bad = s, bad.near_field_m = 0;
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &bad, nearby, up, 0.01, trace, &sc, out),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "near-field rays") != NULL);
  CHECK(sc.calls == 2);
  /* a failing callback, refused near rays, a sum beyond float */
  sc.fail = 3;
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, nearby, up, 0.01, trace, &sc, out), RADDIFF_ERROR_CALLBACK);
  sc.fail = 0, sc.poison = 1;
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, nearby, up, 0.01, trace, &sc, out),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "traced near-field rays") != NULL);
  sc.poison = 0, sc.scale = 1.0e38f; /* 2e38 radiance is finite, pi x 2e38 x 3/4 is not */
  CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, nearby, up, 0.01, trace, &sc, out), RADDIFF_ERROR_DEGENERATE);
  sc.scale = 1.0f;
  CHECK(out[0] == -7.0f && raddiff_cache_len(cache) == 1);
  /* the plain call refuses a cache of far fields, and settings with a reach */
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.01, NULL, NULL, out), RADDIFF_ERROR_NULL_POINTER);
  {
    raddiff_irradiance_settings off = s;
    off.near_field_reach_pixels = 0.0;
    plain = raddiff_irradiance_cache_new(&off);
    CHECK_STATUS(raddiff_cache_get_far_field(plain, &world, &pixels), RADDIFF_OK);
    CHECK(world == 0.0 && pixels == 0.0);
    CHECK_STATUS(raddiff_cache_irradiance_near_far(plain, &s, x, up, 0.01, trace, &sc, out),
                 RADDIFF_ERROR_INVALID_ARGUMENT);
    raddiff_cache_free(plain);
  }
  /* invalid reaches: no cache */
  bad = s, bad.near_field_reach_world = -1.0;
  CHECK(raddiff_irradiance_cache_new(&bad) == NULL);
  bad = s, bad.near_field_reach_pixels = INFINITY;
  CHECK(raddiff_irradiance_cache_new(&bad) == NULL);
  CHECK(out[0] == -7.0f);
  CHECK_STATUS(raddiff_cache_get_far_field(NULL, &world, &pixels), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_far_field(cache, NULL, &pixels), RADDIFF_ERROR_NULL_POINTER);

  /* the parts: E_near = (3/4) pi L and V = 1/4 (exact: the stratum boundary), on a miss (from the
     record's gather) and on a hit (from the near rays); out = E_near + V F with F the plain lookup
     of the finished cache; NULL parts are not wanted; a refusal writes none of them */
  {
    raddiff_cache *fresh = raddiff_irradiance_cache_new(&s);
    const raddiff_vec3 points[2] = {{0.5, 0.5, 0.0}, {0.502, 0.499, 0.0}};
    double near[3], v = -1.0;
    float far[3], whole[3];
    int k;
    CHECK(fresh != NULL);
    for (k = 0; k < 2; ++k) {
      CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(fresh, &s, points[k], up, 0.01, trace, &sc, out, near, &v),
                   RADDIFF_OK);
      CHECK(raddiff_cache_len(fresh) == 1);
      CHECK_CLOSE(v, 0.25, 1e-12);
      for (c = 0; c < 3; ++c) CHECK_CLOSE(near[c], 0.75 * PI * (2.0 / (1 << c)), 1e-9);
      CHECK_STATUS(raddiff_cache_lookup(fresh, points[k], up, far, NULL), RADDIFF_OK);
      for (c = 0; c < 3; ++c) {
        CHECK_CLOSE(far[c], PI * (2.0 / (1 << c)), 1e-5);
        CHECK_CLOSE(out[c], near[c] + v * far[c], 1e-5);
      }
      /* the same call without parts gives the same value */
      CHECK_STATUS(raddiff_cache_irradiance_near_far(fresh, &s, points[k], up, 0.01, trace, &sc, whole), RADDIFF_OK);
      CHECK(memcmp(whole, out, sizeof whole) == 0);
      CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(fresh, &s, points[k], up, 0.01, trace, &sc, whole, NULL, NULL),
                   RADDIFF_OK);
      CHECK(memcmp(whole, out, sizeof whole) == 0);
    }
    near[0] = -7.0, v = -7.0, out[0] = -7.0f;
    sc.fail = 2;
    CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(fresh, &s, points[1], up, 0.01, trace, &sc, out, near, &v),
                 RADDIFF_ERROR_CALLBACK);
    sc.fail = 0;
    CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(fresh, &s, points[1], up, 0.01, trace, &sc, NULL, near, &v),
                 RADDIFF_ERROR_NULL_POINTER);
    CHECK(near[0] == -7.0 && v == -7.0 && out[0] == -7.0f && raddiff_cache_len(fresh) == 1);
    raddiff_cache_free(fresh);
  }

  /* saved and loaded, the marker stays and the loaded cache answers as the saved one */
  CHECK_STATUS(raddiff_cache_save(cache, path), RADDIFF_OK);
  loaded = raddiff_cache_load(path);
  remove(path);
  CHECK(loaded != NULL);
  if (loaded) {
    float a[3], b[3];
    world = pixels = -1.0;
    CHECK_STATUS(raddiff_cache_get_far_field(loaded, &world, &pixels), RADDIFF_OK);
    CHECK(world == 0.0 && pixels == 100.0);
    CHECK_STATUS(raddiff_cache_irradiance_near_far(cache, &s, nearby, up, 0.01, trace, &sc, a), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_irradiance_near_far(loaded, &s, nearby, up, 0.01, trace, &sc, b), RADDIFF_OK);
    CHECK(memcmp(a, b, sizeof a) == 0);
    raddiff_cache_free(loaded);
  }
  raddiff_cache_free(cache);
  CHECK_DONE("irradiance_near_far.c");
}
