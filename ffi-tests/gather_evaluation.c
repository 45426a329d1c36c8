/* The mid-level irradiance calls: one traced gather evaluated once (with all three Hessians),
   records of several metrics and thresholds from it, radii checked by hand, and the errors. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

#define M 8
#define N 24

int main(void) {
  raddiff_irradiance_settings s = raddiff_irradiance_settings_default(), bad;
  raddiff_gather_layout layout = {RADDIFF_LAYOUT_COSINE_POLAR, M, N, 5};
  raddiff_frame frame = {{0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
  raddiff_vec3 dirs[M * N], normals[M * N];
  double distance[M * N];
  float radiance[3 * M * N];
  raddiff_gather_input input;
  raddiff_gather_evaluation *e, *no_normals;
  raddiff_gather_summary sum;
  raddiff_cache_record rec;
  raddiff_cache *cache;
  const uint32_t all = RADDIFF_HESSIAN_OCCLUSION_AWARE | RADDIFF_HESSIAN_UNAWARE | RADDIFF_HESSIAN_GEOMETRIC;
  double previous = 0.0;
  int i, metric;

  /* a ceiling at height 1 facing down, lit where y > 0 */
  CHECK_STATUS(raddiff_gather_directions(&layout, &frame, dirs), RADDIFF_OK);
  for (i = 0; i < M * N; ++i) {
    const double t = 1.0 / dirs[i].z;
    const float l = dirs[i].y > 0.0 ? 1.0f : 0.0f;
    distance[i] = t;
    radiance[3 * i] = radiance[3 * i + 1] = radiance[3 * i + 2] = l;
    normals[i].x = 0.0, normals[i].y = 0.0, normals[i].z = -1.0;
  }
  memset(&input, 0, sizeof input);
  input.directions = dirs, input.distance = distance, input.radiance = radiance, input.channels = 3;
  s.world_radius_max = 10.0;

  e = raddiff_gather_evaluation_new(&s, &layout, &frame, &input, normals, all);
  CHECK(e != NULL);
  CHECK_STATUS(raddiff_gather_evaluation_summary(e, &sum), RADDIFF_OK);
  CHECK(sum.hessians == all);
  /* equal channels: the luminance is the channel (weights sum to 1) */
  {
    double irr[3];
    raddiff_gather_output out;
    memset(&out, 0, sizeof out);
    out.irradiance = irr;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &input, &out), RADDIFF_OK);
    CHECK_CLOSE(sum.scalar, irr[0], 1e-12);
    CHECK_CLOSE(sum.harmonic_mean_distance, out.harmonic_mean_distance, 0.0);
  }
  CHECK(sum.scalar_gradient[1] > 0.0);
  CHECK(sum.occlusion_hessian[0] != 0.0 && sum.unaware_hessian[4] != 0.0 && sum.geometric_hessian[8] != 0.0);

  /* the split sphere by hand: a * D */
  s.metric = RADDIFF_METRIC_SPLIT_SPHERE;
  s.accuracy = 0.25;
  CHECK_STATUS(raddiff_irradiance_record(&s, e, 0.0, &rec), RADDIFF_OK);
  CHECK_CLOSE(rec.radii[0], 0.25 * sum.harmonic_mean_distance, 1e-15);
  CHECK(rec.value[0] > 0.0f && rec.gradient != NULL && rec.rotation_gradient != NULL);
  CHECK(rec.normal.z == 1.0 && rec.position.x == 0.0);
  /* the bounded split sphere: a * min(D, E / |grad E|) */
  s.metric = RADDIFF_METRIC_BOUNDED_SPLIT_SPHERE;
  CHECK_STATUS(raddiff_irradiance_record(&s, e, 0.0, &rec), RADDIFF_OK);
  {
    const double g = sqrt(sum.scalar_gradient[0] * sum.scalar_gradient[0] +
                          sum.scalar_gradient[1] * sum.scalar_gradient[1] +
                          sum.scalar_gradient[2] * sum.scalar_gradient[2]);
    const double bound = sum.scalar / g < sum.harmonic_mean_distance ? sum.scalar / g : sum.harmonic_mean_distance;
    CHECK_CLOSE(rec.radii[0], 0.25 * bound, 1e-15);
  }
  /* every Hessian metric from the same evaluation; radii shrink with the threshold */
  cache = raddiff_irradiance_cache_new(&s);
  for (metric = RADDIFF_METRIC_HESSIAN_UNAWARE; metric <= RADDIFF_METRIC_HESSIAN_ANISOTROPIC; ++metric) {
    s.metric = (uint32_t)metric;
    s.accuracy = 1e-3;
    CHECK_STATUS(raddiff_irradiance_record(&s, e, 0.0, &rec), RADDIFF_OK);
    CHECK(rec.radii[0] > 0.0 && rec.radii[0] <= rec.radii[1] && rec.radii[1] <= 10.0);
    if (metric == RADDIFF_METRIC_HESSIAN_ISOTROPIC) CHECK(rec.radii[0] == rec.radii[1]);
    previous = rec.radii[0];
    s.accuracy = 1e-5;
    CHECK_STATUS(raddiff_irradiance_record(&s, e, 0.0, &rec), RADDIFF_OK);
    CHECK(rec.radii[0] < previous);
  }
  /* the occlusion-aware radii against raddiff_surface_radii_floored on the summary's Hessian */
  {
    double radii[2];
    raddiff_vec3 axes[2], up = {0.0, 0.0, 1.0};
    CHECK_STATUS(raddiff_surface_radii_floored(sum.occlusion_hessian, up, sum.scalar, 1e-5, RADDIFF_ERROR_RELATIVE,
                                               2.0, sum.harmonic_mean_distance, RADDIFF_CURVATURE_FLOOR_WEIGHT,
                                               radii, axes),
                 RADDIFF_OK);
    CHECK(rec.radii[0] == radii[0] && rec.radii[1] == radii[1]);
  }
  CHECK_STATUS(raddiff_cache_insert(cache, &rec), RADDIFF_OK);
  CHECK(raddiff_cache_len(cache) == 1);
  /* pixel bounds through the footprint: 150 px of 1e-4 cap every radius at 0.015 */
  s.accuracy = 1.0;
  s.world_radius_max = INFINITY;
  CHECK_STATUS(raddiff_irradiance_record(&s, e, 1e-4, &rec), RADDIFF_OK);
  CHECK_CLOSE(rec.radii[1], 150.0 * 1e-4, 1e-15);
  CHECK_STATUS(raddiff_irradiance_record(&s, e, 0.0, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "maximum") != NULL);
  s.world_radius_max = 10.0;

  /* errors */
  no_normals = raddiff_gather_evaluation_new(&s, &layout, &frame, &input, NULL, RADDIFF_HESSIAN_OCCLUSION_AWARE);
  CHECK(no_normals != NULL);
  s.metric = RADDIFF_METRIC_HESSIAN_GEOMETRIC;
  CHECK_STATUS(raddiff_irradiance_record(&s, no_normals, 0.0, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "Hessian") != NULL);
  CHECK(raddiff_gather_evaluation_new(&s, &layout, &frame, &input, NULL, RADDIFF_HESSIAN_UNAWARE) == NULL);
  CHECK(strstr(raddiff_last_error(), "hit normals") != NULL);
  CHECK(raddiff_gather_evaluation_new(&s, &layout, &frame, &input, normals, 8) == NULL);
  CHECK(raddiff_gather_evaluation_new(NULL, &layout, &frame, &input, NULL, 0) == NULL);
  CHECK(raddiff_gather_evaluation_new(&s, &layout, &frame, NULL, NULL, 0) == NULL);
  bad = s, bad.channels = 1;
  CHECK(raddiff_gather_evaluation_new(&bad, &layout, &frame, &input, NULL, 0) == NULL);
  CHECK(strstr(raddiff_last_error(), "channels") != NULL);
  distance[3] = -1.0;
  CHECK(raddiff_gather_evaluation_new(&s, &layout, &frame, &input, NULL, 0) == NULL);
  distance[3] = 1.0 / dirs[3].z;
  CHECK_STATUS(raddiff_gather_evaluation_summary(NULL, &sum), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_evaluation_summary(e, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_irradiance_record(NULL, e, 0.0, &rec), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_irradiance_record(&s, NULL, 0.0, &rec), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_irradiance_record(&s, e, 0.0, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_irradiance_record(&s, e, NAN, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_irradiance_record(&s, e, -1.0, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);
  bad = s, bad.channels = 2;
  CHECK_STATUS(raddiff_irradiance_record(&bad, e, 0.0, &rec), RADDIFF_ERROR_INVALID_ARGUMENT);

  /* derivatives from smoothed strata: the value and the distance from the strata as traced,
     the derivatives changed; more passes than allowed refused */
  {
    raddiff_gather_evaluation *smoothed;
    raddiff_gather_summary ss;
    bad = s, bad.derivative_smoothing_azimuthal = 2, bad.derivative_smoothing_polar = 1;
    smoothed = raddiff_gather_evaluation_new(&bad, &layout, &frame, &input, normals, all);
    CHECK(smoothed != NULL);
    CHECK_STATUS(raddiff_gather_evaluation_summary(smoothed, &ss), RADDIFF_OK);
    CHECK(ss.scalar == sum.scalar && ss.harmonic_mean_distance == sum.harmonic_mean_distance);
    CHECK(ss.scalar_gradient[1] > 0.0 && ss.scalar_gradient[1] != sum.scalar_gradient[1]);
    CHECK(ss.occlusion_hessian[4] != sum.occlusion_hessian[4]);
    raddiff_gather_evaluation_free(smoothed);
    bad.derivative_smoothing_polar = RADDIFF_STRATA_SMOOTHING_MAX_PASSES + 1;
    CHECK(raddiff_gather_evaluation_new(&bad, &layout, &frame, &input, normals, all) == NULL);
    CHECK(strstr(raddiff_last_error(), "smoothing") != NULL);
    CHECK(raddiff_irradiance_cache_new(&bad) == NULL);
  }
  raddiff_gather_evaluation_free(no_normals);
  raddiff_gather_evaluation_free(e);
  raddiff_gather_evaluation_free(NULL);
  raddiff_cache_free(cache);
  CHECK_DONE("gather_evaluation.c");
}
