/* raddiff_gather_near_field / raddiff_gather_far_field_radiance / raddiff_gather_far_field through the
   C header only: the open
   fraction under a ceiling against its closed form, the identity E = E_near + V F of one gather
   split with itself, and every rejected argument (nothing written). */
#include "raddiff.h"
#include "check.h"
#include <string.h>

#define M 32
#define N 32
#define CELLS (M * N)

static raddiff_vec3 dirs[CELLS];
static double dist[CELLS];
static float rad[CELLS * 2], far_rad[CELLS * 2];

static double irradiance(const raddiff_gather_layout *layout, const raddiff_frame *frame, const float *radiance,
                         double e[2]) {
  raddiff_gather_input in;
  raddiff_gather_output out;
  memset(&in, 0, sizeof in);
  memset(&out, 0, sizeof out);
  in.directions = dirs;
  in.distance = dist;
  in.radiance = radiance;
  in.channels = 2;
  out.irradiance = e;
  CHECK_STATUS(raddiff_gather_evaluate(layout, frame, &in, &out), RADDIFF_OK);
  return e[0];
}

int main(void) {
  const double pi = 3.14159265358979323846;
  raddiff_gather_layout layout = {RADDIFF_LAYOUT_COSINE_POLAR, M, N, 5};
  raddiff_frame frame = {{0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
  double near[2], open = -1.0, e[2], f[2];
  int i;

  CHECK_STATUS(raddiff_gather_directions(&layout, &frame, dirs), RADDIFF_OK);

  /* A ceiling at height 1 of radiance (1, 3), reach 2: rays closer than the reach have
     cos(theta) > 1/2, a cosine-weighted share of 3/4; so V = 1/4 and E_near = (3/4) pi L, to the one
     ring of 32 that straddles the boundary. */
  for (i = 0; i < CELLS; i++) {
    dist[i] = 1.0 / dirs[i].z;
    rad[2 * i] = 1.0f;
    rad[2 * i + 1] = 3.0f;
  }
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, 2.0, near, &open), RADDIFF_OK);
  CHECK(fabs(open - 0.25) <= 1.0 / M);
  CHECK(fabs(near[0] - 0.75 * pi) <= pi / M);
  CHECK(fabs(near[1] - 3.0 * 0.75 * pi) <= 3.0 * pi / M);

  /* Mixed near hits, far hits and misses: the near field plus V times the far-field gather's
     irradiance gives back the whole gather's. */
  for (i = 0; i < CELLS; i++) {
    dist[i] = (i % 7 == 0) ? INFINITY : 0.1 + 0.37 * (i % 11);
    rad[2 * i] = (float)(0.5 + (i % 5));
    rad[2 * i + 1] = (float)(2.0 + (i % 3));
  }
  irradiance(&layout, &frame, rad, e);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, 1.5, near, &open), RADDIFF_OK);
  memcpy(far_rad, rad, sizeof rad);
  {
    double open_far = -1.0;
    CHECK_STATUS(raddiff_gather_far_field_radiance(&layout, dist, far_rad, 2, 1.5, &open_far), RADDIFF_OK);
    CHECK(open_far == open && open > 0.0 && open < 1.0);
  }
  irradiance(&layout, &frame, far_rad, f);
  CHECK_CLOSE(near[0] + open * f[0], e[0], 1e-6);
  CHECK_CLOSE(near[1] + open * f[1], e[1], 1e-6);
  /* open directions keep their radiance; near ones all carry one value, the far mean */
  for (i = 0; i < CELLS; i++) {
    if (dist[i] >= 1.5) CHECK(far_rad[2 * i] == rad[2 * i]);
    if (dist[i] < 1.5) CHECK(far_rad[2 * i + 1] == far_rad[3]);
  }
  /* the far-field gather with distances: the same radiance, near hits moved to the reach */
  {
    static double moved[CELLS];
    static float moved_rad[CELLS * 2];
    double open_gather = -1.0;
    memcpy(moved, dist, sizeof dist);
    memcpy(moved_rad, rad, sizeof rad);
    CHECK_STATUS(raddiff_gather_far_field(&layout, moved, moved_rad, 2, 1.5, &open_gather), RADDIFF_OK);
    CHECK(open_gather == open);
    CHECK(memcmp(moved_rad, far_rad, sizeof far_rad) == 0);
    for (i = 0; i < CELLS; i++) CHECK(moved[i] == (dist[i] < 1.5 ? 1.5 : dist[i]));
    CHECK_STATUS(raddiff_gather_far_field(&layout, moved, (float *)(void *)moved, 2, 1.5, NULL),
                 RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK_STATUS(raddiff_gather_far_field(&layout, NULL, moved_rad, 2, 1.5, NULL), RADDIFF_ERROR_NULL_POINTER);
    CHECK_STATUS(raddiff_gather_far_field(&layout, moved, moved_rad, 2, 0.0, &open_gather),
                 RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(open_gather == open);
  }
  /* open_fraction is optional for the far field */
  CHECK_STATUS(raddiff_gather_far_field_radiance(&layout, dist, far_rad, 2, 1.5, NULL), RADDIFF_OK);

  /* Rejected arguments: the status, and nothing written. */
  near[0] = near[1] = open = 42.0;
  CHECK_STATUS(raddiff_gather_near_field(NULL, dist, rad, 2, 1.5, near, &open), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_near_field(&layout, NULL, rad, 2, 1.5, near, &open), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, NULL, 2, 1.5, near, &open), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, 1.5, NULL, &open), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, 1.5, near, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 0, 1.5, near, &open), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, 0.0, near, &open), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, NAN, near, &open), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, INFINITY, near, &open),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "reach") != NULL);
  {
    raddiff_gather_layout bad = {7, M, N, 0};
    CHECK_STATUS(raddiff_gather_near_field(&bad, dist, rad, 2, 1.5, near, &open), RADDIFF_ERROR_INVALID_ARGUMENT);
  }
  dist[3] = NAN;
  CHECK_STATUS(raddiff_gather_near_field(&layout, dist, rad, 2, 1.5, near, &open), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(near[0] == 42.0 && near[1] == 42.0 && open == 42.0);
  memcpy(far_rad, rad, sizeof rad);
  CHECK_STATUS(raddiff_gather_far_field_radiance(&layout, dist, far_rad, 2, 1.5, &open),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(memcmp(far_rad, rad, sizeof rad) == 0 && open == 42.0);
  dist[3] = 1.0;
  rad[5] = INFINITY;
  CHECK_STATUS(raddiff_gather_far_field_radiance(&layout, dist, rad, 2, 1.5, &open), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(open == 42.0);
  rad[5] = 1.0f;
  CHECK_STATUS(raddiff_gather_far_field_radiance(&layout, dist, NULL, 2, 1.5, &open), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_far_field_radiance(&layout, NULL, rad, 2, 1.5, &open), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_far_field_radiance(NULL, dist, rad, 2, 1.5, &open), RADDIFF_ERROR_NULL_POINTER);

  CHECK_DONE("near_far");
}
