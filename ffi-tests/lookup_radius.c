/* The lookup radius scale from C: a covered query blends a record beyond its own radius, a query
   no record covers at its own radius stays NOT_FOUND, the index and cursor paths agree, the
   setter's validation, a save/load round trip, and irradiance settings that carry the scale. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

static raddiff_cache_record disc(double x, const float *value) {
  raddiff_cache_record r;
  memset(&r, 0, sizeof r);
  r.position.x = x;
  r.normal.z = 1.0;
  r.value = value;
  r.radii[0] = r.radii[1] = r.radii[2] = 1.0;
  return r;
}

int main(int argc, char **argv) {
  char path[4096];
  raddiff_cache_config config = {1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
  raddiff_cache *cache = raddiff_cache_new(&config), *loaded, *made;
  raddiff_cache_cursor *cursor = raddiff_cache_cursor_new();
  raddiff_irradiance_settings s = raddiff_irradiance_settings_default();
  const float one = 1.0f, three = 3.0f;
  raddiff_cache_record a = disc(0.0, &one), b = disc(3.0, &three);
  /* 0.5: inside a only; 1.5: in neither disc; 2.5: inside b only */
  raddiff_vec3 near_a = {0.5, 0.0, 0.0}, gap = {1.5, 0.0, 0.0}, near_b = {2.5, 0.0, 0.0};
  raddiff_vec3 n = {0.0, 0.0, 1.0};
  float out = 0.0f, with_cursor = 0.0f, blended = 0.0f, again = 0.0f;
  double scale = 0.0, w = 0.0, w_cursor = 0.0, w_one = 0.0;
  const double bad[] = {0.5, 0.999, 8.5, NAN, INFINITY};
  size_t i;
  (void)argc;
  if (strlen(argv[0]) > 4000) return 1;
  sprintf(path, "%s.rdfcache", argv[0]);

  CHECK_STATUS(raddiff_cache_insert(cache, &a), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_insert(cache, &b), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_get_lookup_radius_scale(cache, &scale), RADDIFF_OK);
  CHECK(scale == 1.0);
  /* at 1 each query sees its own disc only */
  CHECK_STATUS(raddiff_cache_lookup(cache, near_a, n, &out, &w_one), RADDIFF_OK);
  CHECK(out == 1.0f);
  CHECK_STATUS(raddiff_cache_lookup(cache, gap, n, &out, NULL), RADDIFF_ERROR_NOT_FOUND);

  /* at 3, x = 0.5 also blends b (2.5 away, read over 3): between the two values, and a's
     Ward weight 1/(0.5/3) - 1 = 5 against b's 1/(2.5/3) - 1 = 0.2 */
  CHECK_STATUS(raddiff_cache_set_lookup_radius_scale(cache, 3.0), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_get_lookup_radius_scale(cache, &scale), RADDIFF_OK);
  CHECK(scale == 3.0);
  CHECK_STATUS(raddiff_cache_lookup(cache, near_a, n, &out, &w), RADDIFF_OK);
  CHECK_CLOSE(out, (5.0 * 1.0 + 0.2 * 3.0) / 5.2, 1e-6);
  CHECK_CLOSE(w, 5.2, 1e-9);
  CHECK_STATUS(raddiff_cache_lookup_with(cache, cursor, near_a, n, &with_cursor, &w_cursor), RADDIFF_OK);
  CHECK(with_cursor == out && w_cursor == w);
  blended = out;
  /* nothing covers x = 1.5 at its own radius: still NOT_FOUND, on both paths */
  CHECK_STATUS(raddiff_cache_lookup(cache, gap, n, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  CHECK_STATUS(raddiff_cache_lookup_with(cache, cursor, gap, n, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  CHECK_STATUS(raddiff_cache_lookup(cache, near_b, n, &out, NULL), RADDIFF_OK);
  CHECK(out > 1.0f && out < 3.0f);

  /* the largest scale is accepted, and a scale is set back exactly */
  CHECK_STATUS(raddiff_cache_set_lookup_radius_scale(cache, RADDIFF_LOOKUP_RADIUS_SCALE_MAX), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_get_lookup_radius_scale(cache, &scale), RADDIFF_OK);
  CHECK(scale == RADDIFF_LOOKUP_RADIUS_SCALE_MAX);
  CHECK_STATUS(raddiff_cache_set_lookup_radius_scale(cache, 3.0), RADDIFF_OK);
  /* invalid scales: refused, nothing changed */
  for (i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    CHECK_STATUS(raddiff_cache_set_lookup_radius_scale(cache, bad[i]), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "lookup radius scale") != NULL);
  }
  CHECK_STATUS(raddiff_cache_set_lookup_radius_scale(NULL, 2.0), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_lookup_radius_scale(cache, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_lookup_radius_scale(cache, &scale), RADDIFF_OK);
  CHECK(scale == 3.0);

  /* saved with the cache */
  CHECK_STATUS(raddiff_cache_save(cache, path), RADDIFF_OK);
  loaded = raddiff_cache_load(path);
  CHECK(loaded != NULL);
  CHECK_STATUS(raddiff_cache_get_lookup_radius_scale(loaded, &scale), RADDIFF_OK);
  CHECK(scale == 3.0);
  CHECK_STATUS(raddiff_cache_lookup(loaded, near_a, n, &again, NULL), RADDIFF_OK);
  CHECK(again == blended);
  remove(path);

  /* back to 1: the lookups of the unscaled cache */
  CHECK_STATUS(raddiff_cache_set_lookup_radius_scale(cache, 1.0), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_with(cache, cursor, near_a, n, &out, &w), RADDIFF_OK);
  CHECK(out == 1.0f && w == w_one);

  /* the settings carry it to raddiff_irradiance_cache_new */
  CHECK(s.lookup_radius_scale == 1.0);
  s.lookup_radius_scale = 1.5;
  made = raddiff_irradiance_cache_new(&s);
  CHECK(made != NULL);
  CHECK_STATUS(raddiff_cache_get_lookup_radius_scale(made, &scale), RADDIFF_OK);
  CHECK(scale == 1.5);
  s.lookup_radius_scale = 0.5;
  CHECK(raddiff_irradiance_cache_new(&s) == NULL);
  CHECK(strstr(raddiff_last_error(), "lookup radius scale") != NULL);

  raddiff_cache_free(made);
  raddiff_cache_free(loaded);
  raddiff_cache_free(cache);
  raddiff_cache_cursor_free(cursor);
  CHECK_DONE("lookup_radius.c");
}
