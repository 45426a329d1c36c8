/* The open-fraction test of far-field caches from C: records with and without an open fraction,
   lookups with the query's (index and cursor paths), keeping coverage, the setters' validation,
   irradiance settings that carry the tolerance, a save/load round trip, and the one-call
   near/far query under a ledge. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

static raddiff_cache_record disc(double x, const float *value, const double *open_fraction) {
  raddiff_cache_record r;
  memset(&r, 0, sizeof r);
  r.position.x = x;
  r.normal.z = 1.0;
  r.value = value;
  r.radii[0] = r.radii[1] = r.radii[2] = 1.0;
  r.open_fraction = open_fraction;
  return r;
}

/* A ceiling of radiance 1 at height 0.5 over x < 0, sky of radiance 0.25 beyond; counts calls. */
typedef struct {
  int calls;
} ledge_state;

static int ledge(void *user, raddiff_vec3 origin, const raddiff_vec3 *directions, size_t count,
                 double max_distance, double *distance, float *radiance) {
  size_t i;
  ((ledge_state *)user)->calls++;
  for (i = 0; i < count; ++i) {
    const raddiff_vec3 w = directions[i];
    const double t = (0.5 - origin.z) / (w.z > 1e-12 ? w.z : 1e-12);
    const int under = origin.x + t * w.x < 0.0;
    distance[i] = under && t < max_distance ? t : INFINITY;
    radiance[i] = under ? 1.0f : 0.25f;
  }
  return 0;
}

int main(int argc, char **argv) {
  char path[4096];
  raddiff_cache_config config = {1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
  raddiff_cache *cache = raddiff_cache_new(&config), *loaded, *tested, *plain, *kept;
  raddiff_cache_cursor *cursor = raddiff_cache_cursor_new();
  raddiff_irradiance_settings s = raddiff_irradiance_settings_default();
  const float closed_value = 1.0f, open_value = 3.0f, plain_value = 2.0f;
  const double closed = 0.25, open = 0.875;
  raddiff_cache_record a = disc(-0.1, &closed_value, &closed), b = disc(0.1, &open_value, &open),
                       c = disc(0.0, &plain_value, NULL);
  raddiff_vec3 x = {0.0, 0.0, 0.0}, n = {0.0, 0.0, 1.0};
  raddiff_vec3 under = {-1.0, 0.0, 0.0}, beyond = {1.0, 0.0, 0.0};
  float out = 0.0f, with_cursor = 0.0f, all = 0.0f, first = 0.0f;
  double tolerance = 0.0, coverage = -1.0, w = 0.0, w_cursor = 0.0, v = 0.0;
  uint32_t keeps = 7;
  ledge_state st = {0};
  const double bad[] = {-0.5, 1.5, NAN};
  size_t i;
  (void)argc;
  if (strlen(argv[0]) > 4000) return 1;
  sprintf(path, "%s.rdfcache", argv[0]);

  CHECK_STATUS(raddiff_cache_insert(cache, &a), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_insert(cache, &b), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_get_open_fraction_tolerance(cache, &tolerance), RADDIFF_OK);
  CHECK(isinf(tolerance));
  /* the test off: the lookup with an open fraction is the plain one, bit for bit */
  CHECK_STATUS(raddiff_cache_lookup(cache, x, n, &all, &w), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, closed, &out, &w_cursor), RADDIFF_OK);
  CHECK(out == all && w == w_cursor && all > 1.0f && all < 3.0f);
  /* tolerance 0.25: a query open at 0.3 admits the record at 0.25 only, one at 0.8 the other */
  CHECK_STATUS(raddiff_cache_set_open_fraction_tolerance(cache, 0.25), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.3, &out, &w), RADDIFF_OK);
  CHECK(fabsf(out - 1.0f) < 1e-6f);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, cursor, x, n, 0.3, &with_cursor, &w_cursor), RADDIFF_OK);
  CHECK(with_cursor == out && w_cursor == w);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.8, &out, NULL), RADDIFF_OK);
  CHECK(fabsf(out - 3.0f) < 1e-6f);
  /* between the two, beyond the tolerance of both: nothing covers */
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.56, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, cursor, x, n, 0.56, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  /* keeping coverage: that query reads the refused records (the plain lookup, bit for bit, on
     both paths), while a query that some record passes still reads that record alone */
  CHECK_STATUS(raddiff_cache_get_open_fraction_keeps_coverage(cache, &keeps), RADDIFF_OK);
  CHECK(keeps == 0);
  CHECK_STATUS(raddiff_cache_set_open_fraction_keeps_coverage(cache, 1), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.56, &out, &w), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup(cache, x, n, &all, &w_cursor), RADDIFF_OK);
  CHECK(out == all && w == w_cursor);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, cursor, x, n, 0.56, &with_cursor, &w_cursor), RADDIFF_OK);
  CHECK(with_cursor == all && w_cursor == w);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, cursor, x, n, 0.3, &out, NULL), RADDIFF_OK);
  CHECK(fabsf(out - 1.0f) < 1e-6f);
  /* the tolerance's setter keeps it; invalid values and NULL change nothing */
  CHECK_STATUS(raddiff_cache_set_open_fraction_tolerance(cache, 0.25), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_set_open_fraction_keeps_coverage(cache, 2), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_cache_set_open_fraction_keeps_coverage(NULL, 1), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_open_fraction_keeps_coverage(cache, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_open_fraction_keeps_coverage(cache, &keeps), RADDIFF_OK);
  CHECK(keeps == 1);
  CHECK_STATUS(raddiff_cache_set_open_fraction_keeps_coverage(cache, 0), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.56, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  /* a finite coverage tolerance, 0.3: a query open at 0.6 reads the refused record at 0.875
     (0.275 away) alone, one at 0.56 neither (0.31 and 0.315 away), on both paths */
  CHECK_STATUS(raddiff_cache_get_open_fraction_coverage_tolerance(cache, &coverage), RADDIFF_OK);
  CHECK(coverage == 0.0);
  CHECK_STATUS(raddiff_cache_set_open_fraction_coverage_tolerance(cache, 0.3), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.6, &out, NULL), RADDIFF_OK);
  CHECK(fabsf(out - 3.0f) < 1e-6f);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, cursor, x, n, 0.6, &with_cursor, NULL), RADDIFF_OK);
  CHECK(with_cursor == out);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.56, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, cursor, x, n, 0.56, &out, NULL), RADDIFF_ERROR_NOT_FOUND);
  CHECK_STATUS(raddiff_cache_get_open_fraction_keeps_coverage(cache, &keeps), RADDIFF_OK);
  CHECK(keeps == 0);
  CHECK_STATUS(raddiff_cache_set_open_fraction_coverage_tolerance(cache, NAN), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_cache_set_open_fraction_coverage_tolerance(cache, -0.1), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_cache_set_open_fraction_coverage_tolerance(NULL, 0.3), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_open_fraction_coverage_tolerance(cache, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_open_fraction_coverage_tolerance(cache, &coverage), RADDIFF_OK);
  CHECK(coverage == 0.3);
  /* keeping all coverage is an infinite coverage tolerance, keeping none 0 */
  CHECK_STATUS(raddiff_cache_set_open_fraction_keeps_coverage(cache, 1), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_get_open_fraction_coverage_tolerance(cache, &coverage), RADDIFF_OK);
  CHECK(isinf(coverage) && coverage > 0.0);
  CHECK_STATUS(raddiff_cache_set_open_fraction_keeps_coverage(cache, 0), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_get_open_fraction_coverage_tolerance(cache, &coverage), RADDIFF_OK);
  CHECK(coverage == 0.0);
  /* the plain lookup is not tested */
  CHECK_STATUS(raddiff_cache_lookup(cache, x, n, &out, NULL), RADDIFF_OK);
  CHECK(out == all);
  /* a record without an open fraction is never refused */
  CHECK_STATUS(raddiff_cache_insert(cache, &c), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.56, &out, NULL), RADDIFF_OK);
  CHECK(fabsf(out - 2.0f) < 1e-6f);
  /* invalid open fractions and tolerances change nothing */
  for (i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
    raddiff_cache_record r = disc(0.5, &plain_value, &bad[i]);
    CHECK_STATUS(raddiff_cache_insert(cache, &r), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, bad[i], &out, NULL), RADDIFF_ERROR_INVALID_ARGUMENT);
  }
  CHECK(raddiff_cache_len(cache) == 3);
  CHECK_STATUS(raddiff_cache_set_open_fraction_tolerance(cache, NAN), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_cache_set_open_fraction_tolerance(cache, -0.1), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_cache_set_open_fraction_tolerance(NULL, 0.1), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_open_fraction_tolerance(cache, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.5, NULL, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_get_open_fraction_tolerance(cache, &tolerance), RADDIFF_OK);
  CHECK(tolerance == 0.25);
  /* saved with the cache: the tolerance, the coverage tolerance and every record's open
     fraction */
  CHECK_STATUS(raddiff_cache_set_open_fraction_coverage_tolerance(cache, 0.35), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_lookup_open(cache, NULL, x, n, 0.3, &first, NULL), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_save(cache, path), RADDIFF_OK);
  loaded = raddiff_cache_load(path);
  CHECK(loaded != NULL);
  CHECK_STATUS(raddiff_cache_get_open_fraction_tolerance(loaded, &tolerance), RADDIFF_OK);
  CHECK(tolerance == 0.25);
  CHECK_STATUS(raddiff_cache_get_open_fraction_coverage_tolerance(loaded, &coverage), RADDIFF_OK);
  CHECK(coverage == 0.35);
  CHECK_STATUS(raddiff_cache_lookup_open(loaded, NULL, x, n, 0.3, &out, NULL), RADDIFF_OK);
  CHECK(out == first);
  CHECK_STATUS(raddiff_cache_lookup_open(loaded, NULL, x, n, 0.56, &out, NULL), RADDIFF_OK);
  CHECK(fabsf(out - 2.0f) < 1e-6f);
  remove(path);

  /* irradiance settings carry the tolerance into the cache they make, and the one-call query
     under a ledge: the records under it (open fraction 1/4) do not serve x = +1 (open fraction
     1), which traces its near rays, misses, and traces its own gather */
  s.channels = 1;
  s.gather_m = 16;
  s.gather_n = 48;
  s.world_radius_min = s.world_radius_max = 4.0;
  s.near_field_reach_world = 1.0;
  s.near_field_m = s.near_field_n = 8;
  plain = raddiff_irradiance_cache_new(&s);
  s.near_field_open_fraction_tolerance = 0.1;
  tested = raddiff_irradiance_cache_new(&s);
  CHECK(tested != NULL && plain != NULL);
  CHECK_STATUS(raddiff_cache_get_open_fraction_tolerance(tested, &tolerance), RADDIFF_OK);
  CHECK(tolerance == 0.1);
  CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(tested, &s, under, n, 0.0, ledge, &st, &out, NULL, &v),
               RADDIFF_OK);
  CHECK(st.calls == 2 && v == 0.25);
  CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(tested, &s, beyond, n, 0.0, ledge, &st, &out, NULL, &v),
               RADDIFF_OK);
  CHECK(st.calls == 4 && v == 1.0 && raddiff_cache_len(tested) == 2);
  /* keeping coverage (the cache's choice: the settings need not say it): x = +1 reads the
     record under the ledge, refused, instead of tracing a gather of its own */
  kept = raddiff_irradiance_cache_new(&s);
  CHECK(kept != NULL);
  CHECK_STATUS(raddiff_cache_set_open_fraction_keeps_coverage(kept, 1), RADDIFF_OK);
  st.calls = 0;
  CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(kept, &s, under, n, 0.0, ledge, &st, &out, NULL, &v),
               RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_irradiance_near_far_parts(kept, &s, beyond, n, 0.0, ledge, &st, &out, NULL, &v),
               RADDIFF_OK);
  CHECK(st.calls == 3 && v == 1.0 && raddiff_cache_len(kept) == 1);
  raddiff_cache_free(kept);
  /* the settings and the cache must agree on the test */
  CHECK_STATUS(raddiff_cache_irradiance_near_far(plain, &s, beyond, n, 0.0, ledge, &st, &out),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  s.near_field_open_fraction_tolerance = -1.0;
  CHECK(raddiff_irradiance_cache_new(&s) == NULL);
  raddiff_cache_free(tested);
  raddiff_cache_free(plain);
  raddiff_cache_free(loaded);
  raddiff_cache_cursor_free(cursor);
  raddiff_cache_free(cache);
  CHECK_DONE("open_fraction.c");
}
