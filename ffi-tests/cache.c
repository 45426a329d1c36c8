/* raddiff_cache_*: every function, its error paths, a save/load round trip and corrupt files. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

static raddiff_cache_record make_record(double x, const float *value, const float *gradient) {
  raddiff_cache_record r;
  memset(&r, 0, sizeof r);
  r.position.x = x;
  r.normal.z = 1.0;
  r.value = value;
  r.gradient = gradient;
  r.rotation_gradient = NULL;
  r.radii[0] = r.radii[1] = r.radii[2] = 1.0;
  return r; /* isotropic: axes may stay zero */
}

int main(int argc, char **argv) {
  char path[4096], bad_path[4096];
  const float v0[3] = {1.0f, 2.0f, 3.0f}, v1[3] = {2.0f, 2.0f, 2.0f};
  /* channel-major: channel c's gradient is g[3c..3c+2]; only channel 0 varies along x */
  const float g0[9] = {0.5f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  raddiff_cache_config cfg = {3, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
  raddiff_cache *cache, *loaded, *other;
  raddiff_cache_record rec;
  raddiff_vec3 p = {0.25, 0.0, 0.0}, n = {0.0, 0.0, 1.0}, far = {10.0, 0.0, 0.0};
  float out[3] = {-1.0f, -1.0f, -1.0f}, out2[3];
  double wsum = -1.0;
  FILE *f;
  (void)argc;
  if (strlen(argv[0]) > 4000) return 1;
  sprintf(path, "%s.rdfcache", argv[0]);
  sprintf(bad_path, "%s.no-such-dir/x.rdfcache", argv[0]);

  /* constructor errors */
  CHECK(raddiff_cache_new(NULL) == NULL);
  CHECK(strstr(raddiff_last_error(), "null") != NULL);
  cfg.domain = 7;
  CHECK(raddiff_cache_new(&cfg) == NULL);
  CHECK(strstr(raddiff_last_error(), "domain") != NULL);
  cfg.domain = RADDIFF_DOMAIN_SURFACE;
  cfg.interpolation = 99;
  CHECK(raddiff_cache_new(&cfg) == NULL);
  cfg.interpolation = RADDIFF_INTERP_WARD;
  cfg.channels = 0;
  CHECK(raddiff_cache_new(&cfg) == NULL);
  cfg.channels = 3;
  cfg.max_normal_deviation = -1.0;
  CHECK(raddiff_cache_new(&cfg) == NULL);
  cfg.max_normal_deviation = 0.2;
  raddiff_cache_free(NULL);

  cache = raddiff_cache_new(&cfg);
  CHECK(cache != NULL);
  CHECK(raddiff_cache_len(cache) == 0);
  CHECK(raddiff_cache_len(NULL) == 0);

  /* empty cache: not found, outputs untouched */
  CHECK_STATUS(raddiff_cache_lookup(cache, p, n, out, &wsum), RADDIFF_ERROR_NOT_FOUND);
  CHECK(out[0] == -1.0f && wsum == -1.0);

  /* insert errors */
  rec = make_record(0.0, v0, g0);
  CHECK_STATUS(raddiff_cache_insert(NULL, &rec), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_insert(cache, NULL), RADDIFF_ERROR_NULL_POINTER);
  rec.value = NULL;
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_ERROR_NULL_POINTER);
  rec.value = v0;
  rec.position.y = NAN;
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);
  rec.position.y = 0.0;
  rec.radii[0] = 0.0;
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);
  rec.radii[0] = 1.0;
  rec.normal.z = 0.0;
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);
  rec.normal.z = 1.0;
  CHECK(raddiff_cache_len(cache) == 0);

  /* two records: at x = 0 (value v0, d(channel 0)/dx = 0.5) and at x = 1 (value v1) */
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_OK); /* duplicate: no-op */
  CHECK(raddiff_cache_len(cache) == 1);
  rec = make_record(1.0, v1, NULL);
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_OK);
  CHECK(raddiff_cache_len(cache) == 2);

  /* at x = 0.25: w0 = 1/0.25 - 1 = 3, w1 = 1/0.75 - 1 = 1/3 */
  CHECK_STATUS(raddiff_cache_lookup(cache, p, n, out, &wsum), RADDIFF_OK);
  CHECK_CLOSE(wsum, 10.0 / 3.0, 1e-12);
  CHECK_CLOSE(out[0], (3.0 * (1.0 + 0.25 * 0.5) + 2.0 / 3.0) / (10.0 / 3.0), 1e-6);
  CHECK_CLOSE(out[1], 2.0, 1e-6);
  CHECK_CLOSE(out[2], (3.0 * 3.0 + 2.0 / 3.0) / (10.0 / 3.0), 1e-6);
  CHECK_STATUS(raddiff_cache_lookup(cache, p, n, out2, NULL), RADDIFF_OK);
  CHECK(memcmp(out, out2, sizeof out) == 0);

  /* lookup errors */
  CHECK_STATUS(raddiff_cache_lookup(NULL, p, n, out, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_lookup(cache, p, n, NULL, NULL), RADDIFF_ERROR_NULL_POINTER);
  {
    /* the cursor path: same result bit for bit, NULL checks, compaction keeps results */
    raddiff_cache_cursor *cursor = raddiff_cache_cursor_new();
    float out3[3] = {0.0f, 0.0f, 0.0f};
    double w3 = 0.0;
    CHECK(cursor != NULL);
    CHECK_STATUS(raddiff_cache_lookup_with(cache, cursor, p, n, out3, &w3), RADDIFF_OK);
    CHECK(memcmp(out3, out, sizeof out3) == 0 && w3 == wsum);
    CHECK_STATUS(raddiff_cache_lookup_with(cache, cursor, p, n, out3, &w3), RADDIFF_OK);
    CHECK(memcmp(out3, out, sizeof out3) == 0 && w3 == wsum);
    CHECK_STATUS(raddiff_cache_lookup_with(cache, NULL, p, n, out3, NULL), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_cache_lookup_with(NULL, cursor, p, n, out3, NULL), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_cache_lookup_with(cache, cursor, p, n, NULL, NULL), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_cache_compact(NULL), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_cache_compact(cache), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_lookup_with(cache, cursor, p, n, out3, &w3), RADDIFF_OK);
    CHECK(memcmp(out3, out, sizeof out3) == 0 && w3 == wsum);
    raddiff_cache_cursor_free(cursor);
    raddiff_cache_cursor_free(NULL);
  }
  {
    raddiff_vec3 nanp = {NAN, 0.0, 0.0}, zero = {0.0, 0.0, 0.0};
    CHECK_STATUS(raddiff_cache_lookup(cache, nanp, n, out2, NULL), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_cache_lookup(cache, p, zero, out2, NULL), RADDIFF_ERROR_INVALID_ARGUMENT);
  }
  CHECK_STATUS(raddiff_cache_lookup(cache, far, n, out2, NULL), RADDIFF_ERROR_NOT_FOUND);
  CHECK(strlen(raddiff_last_error()) > 0);

  /* save / load round trip */
  CHECK_STATUS(raddiff_cache_save(NULL, path), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_save(cache, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_save(cache, bad_path), RADDIFF_ERROR_IO);
  CHECK_STATUS(raddiff_cache_save(cache, path), RADDIFF_OK);
  loaded = raddiff_cache_load(path);
  CHECK(loaded != NULL);
  CHECK(raddiff_cache_len(loaded) == 2);
  CHECK_STATUS(raddiff_cache_lookup(loaded, p, n, out2, NULL), RADDIFF_OK);
  CHECK(memcmp(out, out2, sizeof out) == 0);

  /* merge: duplicates are skipped, mismatched caches refused */
  CHECK_STATUS(raddiff_cache_merge(loaded, cache), RADDIFF_OK);
  CHECK(raddiff_cache_len(loaded) == 2);
  CHECK_STATUS(raddiff_cache_merge(loaded, loaded), RADDIFF_OK);
  CHECK_STATUS(raddiff_cache_merge(NULL, cache), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_merge(loaded, NULL), RADDIFF_ERROR_NULL_POINTER);
  cfg.domain = RADDIFF_DOMAIN_VOLUME;
  cfg.interpolation = RADDIFF_INTERP_CUBIC;
  other = raddiff_cache_new(&cfg);
  CHECK(other != NULL);
  CHECK_STATUS(raddiff_cache_merge(other, cache), RADDIFF_ERROR_INVALID_ARGUMENT);
  /* volume domain: the normal is ignored, cubic kernel at t = 0.5: w = 0.5 */
  rec = make_record(0.0, v0, NULL);
  rec.normal.z = 0.0;
  CHECK_STATUS(raddiff_cache_insert(other, &rec), RADDIFF_OK);
  {
    raddiff_vec3 q = {0.0, 0.5, 0.0}, zero = {0.0, 0.0, 0.0};
    CHECK_STATUS(raddiff_cache_lookup(other, q, zero, out2, &wsum), RADDIFF_OK);
    CHECK_CLOSE(wsum, 0.5, 1e-12);
    CHECK_CLOSE(out2[2], 3.0, 1e-7);
  }
  raddiff_cache_free(other);
  raddiff_cache_free(loaded);

  /* RADDIFF_INTERP_NON_NEGATIVE: a record extrapolating below zero gives 0, not 1 - 0.6 * 2;
     the flag survives save / load; unknown flag bits are refused */
  {
    const float one[1] = {1.0f}, steep[3] = {-2.0f, 0.0f, 0.0f};
    raddiff_vec3 q = {0.6, 0.0, 0.0};
    raddiff_cache_config flagged = {1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
    raddiff_cache *signed_cache = raddiff_cache_new(&flagged), *clamped, *reloaded;
    float v = 1.0f;
    flagged.interpolation = RADDIFF_INTERP_WARD | RADDIFF_INTERP_NON_NEGATIVE;
    clamped = raddiff_cache_new(&flagged);
    CHECK(signed_cache != NULL && clamped != NULL);
    rec = make_record(0.0, one, steep);
    CHECK_STATUS(raddiff_cache_insert(signed_cache, &rec), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_insert(clamped, &rec), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_lookup(signed_cache, q, n, &v, NULL), RADDIFF_OK);
    CHECK_CLOSE(v, -0.2, 1e-6);
    CHECK_STATUS(raddiff_cache_lookup(clamped, q, n, &v, NULL), RADDIFF_OK);
    CHECK(v == 0.0f);
    CHECK_STATUS(raddiff_cache_save(clamped, path), RADDIFF_OK);
    reloaded = raddiff_cache_load(path);
    CHECK(reloaded != NULL);
    v = 1.0f;
    CHECK_STATUS(raddiff_cache_lookup(reloaded, q, n, &v, NULL), RADDIFF_OK);
    CHECK(v == 0.0f);
    flagged.interpolation = RADDIFF_INTERP_WARD | 0x400;
    CHECK(raddiff_cache_new(&flagged) == NULL);
    raddiff_cache_free(reloaded);
    raddiff_cache_free(clamped);
    raddiff_cache_free(signed_cache);
  }

  /* RADDIFF_INTERP_GRADIENT_LIMIT: a record with |gradient| R / E = 132 extrapolates by at most
     c |E| (c = RADDIFF_GRADIENT_LIMIT_DEFAULT = 2: the value may change sign, which
     RADDIFF_INTERP_NON_NEGATIVE catches); raddiff_cache_set_gradient_limit changes c for later
     inserts; the limit survives save / load */
  {
    const float one[1] = {1.0f}, steep[3] = {-132.0f, 0.0f, 0.0f};
    raddiff_vec3 q = {0.99, 0.0, 0.0}, q2 = {10.99, 0.0, 0.0};
    raddiff_cache_config plain_cfg = {1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
    raddiff_cache_config limit_cfg = {1, RADDIFF_DOMAIN_SURFACE,
                                      RADDIFF_INTERP_WARD | RADDIFF_INTERP_GRADIENT_LIMIT, 0.2};
    raddiff_cache *plain = raddiff_cache_new(&plain_cfg), *limited = raddiff_cache_new(&limit_cfg);
    raddiff_cache *reloaded;
    float v = 0.0f, v2 = 0.0f;
    double c = 0.0;
    CHECK(plain != NULL && limited != NULL);
    CHECK(RADDIFF_GRADIENT_LIMIT_DEFAULT == 2.0);
    CHECK_STATUS(raddiff_cache_get_gradient_limit(limited, &c), RADDIFF_OK);
    CHECK(c == RADDIFF_GRADIENT_LIMIT_DEFAULT);
    CHECK_STATUS(raddiff_cache_get_gradient_limit(plain, &c), RADDIFF_OK);
    CHECK(isinf(c) && c > 0.0);
    rec = make_record(0.0, one, steep);
    CHECK_STATUS(raddiff_cache_insert(plain, &rec), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_insert(limited, &rec), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_lookup(plain, q, n, &v, NULL), RADDIFF_OK);
    CHECK_CLOSE(v, 1.0 - 0.99 * 132.0, 1e-4);
    CHECK_STATUS(raddiff_cache_lookup(limited, q, n, &v, NULL), RADDIFF_OK);
    CHECK_CLOSE(v, 1.0 - 0.99 * 2.0, 1e-3);
    /* c = 0.5 for the next records; the stored one keeps its gradient */
    CHECK_STATUS(raddiff_cache_set_gradient_limit(plain, 0.5), RADDIFF_OK);
    rec = make_record(10.0, one, steep);
    CHECK_STATUS(raddiff_cache_insert(plain, &rec), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_lookup(plain, q2, n, &v, NULL), RADDIFF_OK);
    CHECK_CLOSE(v, 1.0 - 0.99 * 0.5, 1e-3);
    CHECK_STATUS(raddiff_cache_lookup(plain, q, n, &v, NULL), RADDIFF_OK);
    CHECK_CLOSE(v, 1.0 - 0.99 * 132.0, 1e-4);
    /* errors leave the limit as it was */
    CHECK_STATUS(raddiff_cache_set_gradient_limit(NULL, 1.0), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_cache_set_gradient_limit(plain, 0.0), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "gradient limit") != NULL);
    CHECK_STATUS(raddiff_cache_set_gradient_limit(plain, -1.0), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_cache_set_gradient_limit(plain, NAN), RADDIFF_ERROR_INVALID_ARGUMENT);
    c = -1.0;
    CHECK_STATUS(raddiff_cache_get_gradient_limit(NULL, &c), RADDIFF_ERROR_NULL_POINTER);
    CHECK(c == -1.0);
    CHECK_STATUS(raddiff_cache_get_gradient_limit(plain, NULL), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_cache_get_gradient_limit(plain, &c), RADDIFF_OK);
    CHECK(c == 0.5);
    CHECK_STATUS(raddiff_cache_set_gradient_limit(plain, INFINITY), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_get_gradient_limit(plain, &c), RADDIFF_OK);
    CHECK(isinf(c));
    /* save / load keeps the limit and the limited records */
    CHECK_STATUS(raddiff_cache_save(limited, path), RADDIFF_OK);
    reloaded = raddiff_cache_load(path);
    CHECK(reloaded != NULL);
    CHECK_STATUS(raddiff_cache_get_gradient_limit(reloaded, &c), RADDIFF_OK);
    CHECK(c == 2.0);
    CHECK_STATUS(raddiff_cache_lookup(limited, q, n, &v, NULL), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_lookup(reloaded, q, n, &v2, NULL), RADDIFF_OK);
    CHECK(v == v2);
    raddiff_cache_free(reloaded);
    raddiff_cache_free(limited);
    raddiff_cache_free(plain);
  }

  /* neighbour clamping: raddiff_cache_clamp_record shrinks a record's radii in place before it
     is inserted (one-sided); raddiff_cache_clamp_neighbours shrinks stored records both ways and
     reaches the same radius */
  {
    const float one[1] = {1.0f};
    raddiff_cache_config ccfg = {1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
    raddiff_cache *pre = raddiff_cache_new(&ccfg), *post = raddiff_cache_new(&ccfg);
    raddiff_cache_record small = make_record(0.5, one, NULL), big = make_record(0.0, one, NULL);
    raddiff_vec3 inside = {0.3, 0.0, 0.0}, outside = {-1.0, 0.0, 0.0};
    double bound = (double)0.1f + 0.5;
    size_t shrunk = 99;
    float a = 0.0f, b = 0.0f;
    CHECK(pre != NULL && post != NULL);
    small.radii[0] = small.radii[1] = small.radii[2] = 0.1;
    big.radii[0] = 4.0;
    big.radii[1] = big.radii[2] = 2.0;
    big.axes[0].x = 1.0;
    CHECK_STATUS(raddiff_cache_insert(pre, &small), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_insert(post, &small), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_insert(post, &big), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_lookup(post, outside, n, &a, NULL), RADDIFF_OK);
    /* errors leave the record untouched */
    CHECK_STATUS(raddiff_cache_clamp_record(NULL, &big), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_cache_clamp_record(pre, NULL), RADDIFF_ERROR_NULL_POINTER);
    big.position.y = NAN;
    CHECK_STATUS(raddiff_cache_clamp_record(pre, &big), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(big.radii[0] == 4.0 && big.radii[1] == 2.0);
    big.position.y = 0.0;
    /* the small record 0.5 away bounds the big one by 0.1 + 0.5; anisotropy is kept */
    CHECK_STATUS(raddiff_cache_clamp_record(pre, &big), RADDIFF_OK);
    CHECK(big.radii[0] <= bound && big.radii[0] > bound * (1.0 - 1e-6));
    CHECK_CLOSE(big.radii[1], big.radii[0] / 2.0, 1e-6);
    CHECK_STATUS(raddiff_cache_insert(pre, &big), RADDIFF_OK);
    /* two-sided pass over the stored records: the big one shrinks, the small one does not */
    CHECK_STATUS(raddiff_cache_clamp_neighbours(NULL, &shrunk), RADDIFF_ERROR_NULL_POINTER);
    CHECK(shrunk == 99);
    CHECK_STATUS(raddiff_cache_clamp_neighbours(post, &shrunk), RADDIFF_OK);
    CHECK(shrunk == 1);
    CHECK(raddiff_cache_len(post) == 2);
    CHECK_STATUS(raddiff_cache_clamp_neighbours(post, &shrunk), RADDIFF_OK);
    CHECK(shrunk == 0);
    CHECK_STATUS(raddiff_cache_clamp_neighbours(post, NULL), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_clamp_neighbours(pre, &shrunk), RADDIFF_OK);
    CHECK(shrunk == 0);
    /* both ways give the same records: the same lookups, and x = -1 is no longer covered */
    CHECK_STATUS(raddiff_cache_lookup(pre, inside, n, &a, NULL), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_lookup(post, inside, n, &b, NULL), RADDIFF_OK);
    CHECK(a == b);
    CHECK_STATUS(raddiff_cache_lookup(post, outside, n, &a, NULL), RADDIFF_ERROR_NOT_FOUND);
    CHECK_STATUS(raddiff_cache_lookup(pre, outside, n, &a, NULL), RADDIFF_ERROR_NOT_FOUND);
    raddiff_cache_free(pre);
    raddiff_cache_free(post);
  }

  /* unreadable and corrupt files: NULL with an IO / CORRUPT message */
  CHECK(raddiff_cache_load(NULL) == NULL);
  CHECK(raddiff_cache_load(bad_path) == NULL);
  CHECK(strstr(raddiff_last_error(), "i/o error") != NULL);
  f = fopen(path, "r+b");
  CHECK(f != NULL);
  if (f) {
    fseek(f, 60, SEEK_SET);
    fputc(0x5a, f);
    fclose(f);
  }
  CHECK(raddiff_cache_load(path) == NULL);
  CHECK(strstr(raddiff_last_error(), "corrupt") != NULL);
  f = fopen(path, "wb");
  CHECK(f != NULL);
  if (f) {
    fputs("RDFCACHE", f); /* truncated right after the magic */
    fclose(f);
  }
  CHECK(raddiff_cache_load(path) == NULL);
  CHECK(strstr(raddiff_last_error(), "truncated") != NULL);
  remove(path);

  raddiff_cache_free(cache);
  CHECK_DONE("cache.c");
}
