/* raddiff_cache_irradiance and its settings: defaults, the one-call path against the mid-level
   calls, failing callbacks, NULLs, non-finite input, settings that disagree with the cache, and
   several threads filling one cache. */
#include "raddiff.h"
#include "check.h"
#include <pthread.h>
#include <string.h>

/* The scene every trace sees: the plane z = 0 under a ceiling at z = 1 whose radiance is
   (2, 1, 0.5) where y > 0 (or everywhere, for `uniform`) and 0 elsewhere. */
typedef struct scene {
  int uniform;
  int calls;       /* how many times the callback ran */
  int fail;        /* return this from the callback when non-zero */
  int poison;      /* write a NaN distance */
} scene;

static int trace(void *user, raddiff_vec3 o, const raddiff_vec3 *d, size_t count, double *distance,
                 float *radiance) {
  scene *s = (scene *)user;
  size_t i;
  s->calls++;
  if (s->fail) return s->fail;
  for (i = 0; i < count; ++i) {
    const double t = (1.0 - o.z) / (d[i].z > 1e-12 ? d[i].z : 1e-12);
    const int lit = s->uniform || o.y + t * d[i].y > 0.0;
    distance[i] = t;
    radiance[3 * i] = lit ? 2.0f : 0.0f;
    radiance[3 * i + 1] = lit ? 1.0f : 0.0f;
    radiance[3 * i + 2] = lit ? 0.5f : 0.0f;
  }
  if (s->poison) distance[count / 2] = NAN;
  return 0;
}

static raddiff_irradiance_settings small_settings(void) {
  raddiff_irradiance_settings s = raddiff_irradiance_settings_default();
  s.gather_m = 8;
  s.gather_n = 24;
  s.world_radius_min = 0.01;
  s.world_radius_max = 2.0;
  return s;
}

/* The tangent raddiff picks for a normal (Duff et al.'s branchless basis), bit for bit. */
static raddiff_vec3 tangent_of(raddiff_vec3 n) {
  const double sign = n.z >= 0.0 ? 1.0 : -1.0, a = -1.0 / (sign + n.z), b = n.x * n.y * a;
  raddiff_vec3 t;
  t.x = 1.0 + sign * n.x * n.x * a;
  t.y = sign * b;
  t.z = -sign * n.x;
  return t;
}

/* Several threads fill one cache over the same points in different orders. */
typedef struct worker {
  raddiff_cache *cache;
  const raddiff_irradiance_settings *settings;
  int first, failures, calls;
} worker;

static void *fill(void *arg) {
  worker *w = (worker *)arg;
  scene s = {0, 0, 0, 0};
  int k;
  for (k = 0; k < 30; ++k) {
    const int i = (k + w->first) % 30;
    raddiff_vec3 x = {0.3 * (i % 6) - 0.75, 0.4 * (i / 6) - 0.8, 0.0}, n = {0.0, 0.0, 1.0};
    float out[3] = {-1.0f, -1.0f, -1.0f};
    if (raddiff_cache_irradiance(w->cache, w->settings, x, n, 0.0, trace, &s, out) != RADDIFF_OK) w->failures++;
    /* irradiance is never negative; extrapolation moves a record's value by at most c = 2 times */
    if (!(out[0] >= 0.0f && out[0] <= 3.0f * 6.3f)) w->failures++;
  }
  w->calls = s.calls;
  return NULL;
}

/* Several threads miss at the same point at once. */
static void *same_point(void *arg) {
  worker *w = (worker *)arg;
  scene s = {1, 0, 0, 0};
  raddiff_vec3 x = {0.1, 0.2, 0.0}, n = {0.0, 0.0, 1.0};
  float out[3] = {-1.0f, -1.0f, -1.0f};
  if (raddiff_cache_irradiance(w->cache, w->settings, x, n, 0.0, trace, &s, out) != RADDIFF_OK) w->failures++;
  if (fabs(out[0] - 2.0 * 3.14159265358979) > 1e-4) w->failures++;
  return NULL;
}

int main(void) {
  raddiff_irradiance_settings d = raddiff_irradiance_settings_default(), s = small_settings(), bad;
  raddiff_cache *cache, *mid, *plain;
  raddiff_cache_config plain_config = {3, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT, 0.2};
  raddiff_vec3 x = {0.1, -0.05, 0.0}, up = {0.0, 0.0, 1.0}, tilted = {0.2, -0.1, 0.97};
  float out[3] = {-1.0f, -1.0f, -1.0f}, again[3], from_mid[3];
  scene uniform = {1, 0, 0, 0}, half = {0, 0, 0, 0}, failing = {0, 0, 7, 0}, poisoned = {0, 0, 0, 1};
  const double pi = 3.14159265358979323846;
  const double weights[3] = {0.0, 1.0, 0.0};
  int k;

  /* the defaults: one default per safeguard */
  CHECK(d.metric == RADDIFF_METRIC_HESSIAN_ANISOTROPIC && RADDIFF_METRIC_HESSIAN == d.metric);
  CHECK(d.channels == 3 && d.channel_weights == NULL && d.gather_kind == RADDIFF_LAYOUT_COSINE_POLAR);
  CHECK(d.gather_m == 32 && d.gather_n == 128 && d.seed_policy == RADDIFF_SEED_FROM_QUERY);
  CHECK(d.gradient_limit == RADDIFF_GRADIENT_LIMIT_DEFAULT && RADDIFF_GRADIENT_LIMIT_DEFAULT == 2.0);
  CHECK(d.curvature_floor == RADDIFF_CURVATURE_FLOOR_WEIGHT && d.max_anisotropy == 2.0);
  CHECK(d.pixel_radius_min == 1.0 && d.pixel_radius_max == 150.0 && isinf(d.world_radius_max));
  CHECK(isinf(d.leak_guard_relative) && d.leak_guard_absolute == 0.0);
  CHECK(d.derivative_smoothing_azimuthal == 0 && d.derivative_smoothing_polar == 0);
  CHECK(RADDIFF_STRATA_SMOOTHING_MAX_PASSES == 64);

  /* a uniform ceiling: E = pi L per channel, exactly, whatever the radii */
  cache = raddiff_irradiance_cache_new(&s);
  CHECK(cache != NULL);
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.0, trace, &uniform, out), RADDIFF_OK);
  CHECK(uniform.calls == 1 && raddiff_cache_len(cache) == 1);
  CHECK_CLOSE(out[0], 2.0 * pi, 1e-6);
  CHECK_CLOSE(out[1], pi, 1e-6);
  CHECK_CLOSE(out[2], 0.5 * pi, 1e-6);
  /* covered now: no trace, the same value */
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.0, trace, &failing, again), RADDIFF_OK);
  CHECK(failing.calls == 0 && memcmp(out, again, sizeof out) == 0);
  raddiff_cache_free(cache);

  /* the one call against the mid-level calls it is made of (stratum centres: seed 0) */
  s.seed_policy = RADDIFF_SEED_CENTRES;
  cache = raddiff_irradiance_cache_new(&s);
  mid = raddiff_irradiance_cache_new(&s);
  for (k = 0; k < 2; ++k) {
    const raddiff_vec3 n = k == 0 ? up : tilted;
    raddiff_vec3 unit = n, dirs[8 * 24];
    double distance[8 * 24], len = sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    float radiance[3 * 8 * 24];
    raddiff_gather_layout layout = {RADDIFF_LAYOUT_COSINE_POLAR, 8, 24, 0};
    raddiff_frame frame;
    raddiff_gather_input input;
    raddiff_gather_evaluation *e;
    raddiff_cache_record rec;
    unit.x /= len, unit.y /= len, unit.z /= len;
    frame.position = x, frame.normal = unit, frame.tangent = tangent_of(unit);
    half.calls = 0;
    CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, n, 0.0, trace, &half, out), RADDIFF_OK);
    CHECK(half.calls == 1);
    CHECK_STATUS(raddiff_gather_directions(&layout, &frame, dirs), RADDIFF_OK);
    trace(&half, x, dirs, 8 * 24, distance, radiance);
    memset(&input, 0, sizeof input);
    input.directions = dirs, input.distance = distance, input.radiance = radiance, input.channels = 3;
    e = raddiff_gather_evaluation_new(&s, &layout, &frame, &input, NULL, RADDIFF_HESSIAN_OCCLUSION_AWARE);
    CHECK(e != NULL);
    CHECK_STATUS(raddiff_irradiance_record(&s, e, 0.0, &rec), RADDIFF_OK);
    CHECK_STATUS(raddiff_cache_insert(mid, &rec), RADDIFF_OK);
    raddiff_gather_evaluation_free(e);
    CHECK_STATUS(raddiff_cache_lookup(mid, x, n, from_mid, NULL), RADDIFF_OK);
    CHECK(memcmp(out, from_mid, sizeof out) == 0);
    CHECK(out[0] > 0.5 * pi && out[0] < 2.0 * pi); /* a penumbra, half lit */
  }
  CHECK(raddiff_cache_len(cache) == 2 && raddiff_cache_len(mid) == 2);
  raddiff_cache_free(mid);

  /* failures insert nothing and leave `out` untouched */
  x.x = 0.9;
  memcpy(again, out, sizeof out);
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.0, trace, &failing, out), RADDIFF_ERROR_CALLBACK);
  CHECK(failing.calls == 1 && strstr(raddiff_last_error(), "returned 7") != NULL);
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.0, trace, &poisoned, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "traced gather") != NULL);
  CHECK(raddiff_cache_len(cache) == 2 && memcmp(out, again, sizeof out) == 0);
  /* NULLs */
  CHECK_STATUS(raddiff_cache_irradiance(NULL, &s, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_irradiance(cache, NULL, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.0, NULL, &half, out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.0, trace, &half, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "out") != NULL);
  /* non-finite or meaningless input never reaches the callback */
  half.calls = 0;
  {
    raddiff_vec3 nan_x = {NAN, 0.0, 0.0}, inf_n = {0.0, INFINITY, 1.0}, zero = {0.0, 0.0, 0.0};
    CHECK_STATUS(raddiff_cache_irradiance(cache, &s, nan_x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, inf_n, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, zero, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, NAN, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, -1.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  }
  /* settings the cache was not made for, or invalid ones */
  bad = s, bad.gradient_limit = 1.0;
  CHECK_STATUS(raddiff_cache_irradiance(cache, &bad, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "gradient limit") != NULL);
  bad = s, bad.metric = RADDIFF_METRIC_HESSIAN_UNAWARE;
  CHECK_STATUS(raddiff_cache_irradiance(cache, &bad, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "normals") != NULL);
  bad = s, bad.metric = 99;
  CHECK_STATUS(raddiff_cache_irradiance(cache, &bad, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  bad = s, bad.accuracy = -1.0;
  CHECK_STATUS(raddiff_cache_irradiance(cache, &bad, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  bad = s, bad.world_radius_max = INFINITY; /* no finite maximum without a footprint */
  CHECK_STATUS(raddiff_cache_irradiance(cache, &bad, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  bad = s, bad.seed_policy = 5;
  CHECK_STATUS(raddiff_cache_irradiance(cache, &bad, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  plain = raddiff_cache_new(&plain_config);
  CHECK_STATUS(raddiff_cache_irradiance(plain, &s, x, up, 0.0, trace, &half, out), RADDIFF_ERROR_INVALID_ARGUMENT);
  raddiff_cache_free(plain);
  CHECK(half.calls == 0 && raddiff_cache_len(cache) == 2);
  bad = s, bad.channels = 0;
  CHECK(raddiff_irradiance_cache_new(&bad) == NULL);
  CHECK(raddiff_irradiance_cache_new(NULL) == NULL);
  raddiff_cache_free(cache);

  /* the footprint makes the pixel bounds: 1 px of 0.5 is a 0.5 minimum */
  s.world_radius_min = 0.0;
  s.world_radius_max = INFINITY;
  cache = raddiff_irradiance_cache_new(&s);
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.5, trace, &half, out), RADDIFF_OK);
  {
    /* a point 0.45 away is inside that record's smallest radius */
    raddiff_vec3 near = {x.x, x.y + 0.45, 0.0};
    CHECK_STATUS(raddiff_cache_lookup(cache, near, up, again, NULL), RADDIFF_OK);
  }
  raddiff_cache_free(cache);

  /* channel weights: the green channel alone drives the metric (copied per call) */
  s = small_settings();
  s.channel_weights = weights;
  cache = raddiff_irradiance_cache_new(&s);
  CHECK_STATUS(raddiff_cache_irradiance(cache, &s, x, up, 0.0, trace, &half, out), RADDIFF_OK);
  raddiff_cache_free(cache);

  /* threads: four fill one cache over 30 points in different orders; every record comes from
     one miss, and four racing on one point insert it once */
  s = small_settings();
  cache = raddiff_irradiance_cache_new(&s);
  {
    pthread_t threads[4];
    worker workers[4];
    int calls = 0, failures = 0;
    for (k = 0; k < 4; ++k) {
      workers[k].cache = cache, workers[k].settings = &s, workers[k].first = 7 * k;
      workers[k].failures = 0, workers[k].calls = 0;
      CHECK(pthread_create(&threads[k], NULL, fill, &workers[k]) == 0);
    }
    for (k = 0; k < 4; ++k) {
      pthread_join(threads[k], NULL);
      calls += workers[k].calls, failures += workers[k].failures;
    }
    CHECK(failures == 0);
    CHECK(raddiff_cache_len(cache) >= 1 && raddiff_cache_len(cache) <= (size_t)calls);
    raddiff_cache_free(cache);
    cache = raddiff_irradiance_cache_new(&s);
    for (k = 0; k < 4; ++k) {
      workers[k].cache = cache, workers[k].failures = 0;
      CHECK(pthread_create(&threads[k], NULL, same_point, &workers[k]) == 0);
    }
    for (k = 0; k < 4; ++k) {
      pthread_join(threads[k], NULL);
      CHECK(workers[k].failures == 0);
    }
    CHECK(raddiff_cache_len(cache) == 1);
    raddiff_cache_free(cache);
  }
  CHECK_DONE("irradiance.c");
}
