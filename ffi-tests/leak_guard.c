/* The cache's leak guard from C: a step, the setters' validation, irradiance settings that carry
   it, and a save/load round trip. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

static raddiff_cache_record disc(double x, double z, const float *value, double radius) {
  raddiff_cache_record r;
  memset(&r, 0, sizeof r);
  r.position.x = x;
  r.position.z = z;
  r.normal.z = 1.0;
  r.value = value;
  r.radii[0] = r.radii[1] = r.radii[2] = radius;
  return r;
}

int main(int argc, char **argv) {
  char path[4096];
  raddiff_cache_config config = {1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
  raddiff_cache *cache = raddiff_cache_new(&config), *loaded, *from_settings;
  raddiff_irradiance_settings s = raddiff_irradiance_settings_default();
  const float upper_value = 2.0f;
  /* a step 0.2 high at x = 0: this record lies on the upper floor, 0.05 from the edge */
  raddiff_cache_record upper = disc(0.05, 0.2, &upper_value, 0.5);
  raddiff_vec3 below = {-0.1, 0.0, 0.0}, n = {0.0, 0.0, 1.0};
  float out = 0.0f;
  double relative = 0.0, absolute = 0.0;
  (void)argc;
  if (strlen(argv[0]) > 4000) return 1;
  sprintf(path, "%s.rdfcache", argv[0]);

  CHECK_STATUS(raddiff_cache_insert(cache, &upper), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_get_leak_guard(cache, &relative, &absolute), RADDIFF_OK);
  CHECK(isinf(relative) && absolute == 0.0);
  CHECK_STATUS(raddiff_cache_lookup(cache, below, n, &out, NULL), RADDIFF_OK);
  CHECK(out == 2.0f);
  /* tolerance 0.1 * 0.5 = 0.05, below the step's 0.2: the record is in front of the query */
  CHECK_STATUS(raddiff_cache_set_leak_guard(cache, 0.1, 0.0), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup(cache, below, n, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  /* an absolute tolerance above the step lets it through */
  CHECK_STATUS(raddiff_cache_set_leak_guard(cache, 0.0, 0.25), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup(cache, below, n, &out, NULL), RADDIFF_OK);
  /* invalid tolerances change nothing */
  CHECK_STATUS(raddiff_cache_set_leak_guard(cache, NAN, 0.0), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_cache_set_leak_guard(cache, 0.1, -1.0), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_cache_set_leak_guard(NULL, 0.1, 0.0), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_leak_guard(cache, NULL, &absolute), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_leak_guard(cache, &relative, &absolute), RADDIFF_OK);
  CHECK(relative == 0.0 && absolute == 0.25);
  /* saved with the cache */
  CHECK_STATUS(raddiff_cache_set_leak_guard(cache, 0.1, 0.001), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_save(cache, path), RADDIFF_OK);
  loaded = raddiff_cache_load(path);
  CHECK(loaded != NULL);
  CHECK_STATUS(raddiff_cache_get_leak_guard(loaded, &relative, &absolute), RADDIFF_OK);
  CHECK(relative == 0.1 && absolute == 0.001);
  CHECK_STATUS(raddiff_cache_lookup(loaded, below, n, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  remove(path);
  /* irradiance settings carry it into the cache they make */
  s.leak_guard_relative = 0.05;
  from_settings = raddiff_irradiance_cache_new(&s);
  CHECK(from_settings != NULL);
  CHECK_STATUS(raddiff_cache_get_leak_guard(from_settings, &relative, &absolute), RADDIFF_OK);
  CHECK(relative == 0.05 && absolute == 0.0);
  s.leak_guard_relative = -1.0;
  CHECK(raddiff_irradiance_cache_new(&s) == NULL);
  raddiff_cache_free(from_settings);
  raddiff_cache_free(loaded);
  raddiff_cache_free(cache);
  CHECK_DONE("leak_guard.c");
}
