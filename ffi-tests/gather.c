/* raddiff_gather_directions / raddiff_gather_evaluate through the C header only. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

#define M 4
#define N 8
#define CELLS (M * N)

static raddiff_vec3 dirs[CELLS];
static double dist[CELLS];
static float rad[CELLS * 2];

static raddiff_gather_input make_input(void) {
  raddiff_gather_input in;
  memset(&in, 0, sizeof in);
  in.directions = dirs;
  in.distance = dist;
  in.radiance = rad;
  in.channels = 2;
  in.sigma_t = 0.0;
  return in;
}

int main(void) {
  const double pi = 3.14159265358979323846;
  raddiff_gather_layout layout = {RADDIFF_LAYOUT_COSINE_POLAR, M, N, 0};
  raddiff_frame frame = {{0.5, -1.0, 2.0}, {0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
  raddiff_gather_input in;
  raddiff_gather_output out;
  double e[2], g[6], rg[6], hess[18];
  int i;

  /* directions: stratum centres, unit, index j*n + k */
  CHECK_STATUS(raddiff_gather_directions(&layout, &frame, dirs), RADDIFF_OK);
  {
    double s = sqrt(0.5 / M), phi = 2.0 * pi * 0.5 / N;
    CHECK_CLOSE(dirs[0].x, s * cos(phi), 1e-14);
    CHECK_CLOSE(dirs[0].y, s * sin(phi), 1e-14);
    CHECK_CLOSE(dirs[0].z, sqrt(1.0 - 0.5 / M), 1e-14);
    s = sqrt(3.5 / M);
    phi = 2.0 * pi * 5.5 / N;
    CHECK_CLOSE(dirs[3 * N + 5].x, s * cos(phi), 1e-14);
    CHECK_CLOSE(dirs[3 * N + 5].z, sqrt(1.0 - 3.5 / M), 1e-14);
  }
  for (i = 0; i < CELLS; i++) {
    CHECK_CLOSE(dirs[i].x * dirs[i].x + dirs[i].y * dirs[i].y + dirs[i].z * dirs[i].z, 1.0, 1e-14);
  }
  /* jitter is deterministic and stays in the hemisphere */
  {
    raddiff_vec3 a[CELLS], b[CELLS];
    raddiff_gather_layout jl = {RADDIFF_LAYOUT_SPHERE, M, N, 99};
    CHECK_STATUS(raddiff_gather_directions(&jl, &frame, a), RADDIFF_OK);
    CHECK_STATUS(raddiff_gather_directions(&jl, &frame, b), RADDIFF_OK);
    CHECK(memcmp(a, b, sizeof a) == 0);
    CHECK(a[0].z > 0.5 && a[CELLS - 1].z < -0.5);
  }

  /* every ray hits at distance 2 with radiance (1, 3): E = pi L, no gradient */
  for (i = 0; i < CELLS; i++) {
    dist[i] = 2.0;
    rad[2 * i] = 1.0f;
    rad[2 * i + 1] = 3.0f;
  }
  in = make_input();
  memset(&out, 0, sizeof out);
  out.irradiance = e;
  out.gradient = g;
  out.rotation_gradient = rg;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
  CHECK_CLOSE(e[0], pi, 1e-13);
  CHECK_CLOSE(e[1], 3.0 * pi, 1e-13);
  for (i = 0; i < 6; i++) {
    CHECK(fabs(g[i]) < 1e-13);
    CHECK(fabs(rg[i]) < 1e-13);
  }
  CHECK_CLOSE(out.harmonic_mean_distance, 2.0, 1e-14);
  CHECK_CLOSE(out.min_distance, 2.0, 1e-14);

  /* a bright half-dome (phi < pi, the +y side) at distance 1, nothing on the other side: moving
     towards +y the dome subtends more, and tilting the normal towards +y (rotating about -x) too */
  for (i = 0; i < CELLS; i++) {
    int k = i % N;
    dist[i] = k < N / 2 ? 1.0 : INFINITY;
    rad[2 * i] = k < N / 2 ? 1.0f : 0.0f;
  }
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
  CHECK_CLOSE(e[0], pi / 2.0, 1e-13);
  CHECK(g[1] > 0.0);
  CHECK(fabs(g[0]) < 1e-12);
  CHECK(rg[0] < 0.0);
  CHECK(isinf(out.harmonic_mean_distance) == 0 && out.harmonic_mean_distance == 2.0);

  /* NULL outputs are skipped and left alone */
  {
    double keep[6] = {42, 42, 42, 42, 42, 42};
    raddiff_gather_output o2;
    memset(&o2, 0, sizeof o2);
    o2.gradient = keep;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &o2), RADDIFF_OK);
    for (i = 0; i < 6; i++) CHECK(keep[i] == g[i]);
    o2.gradient = NULL;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &o2), RADDIFF_OK);
    CHECK(o2.min_distance == 1.0);
  }

  /* error paths: status, message, outputs untouched */
  e[0] = 42.0;
  out.min_distance = 42.0;
  CHECK_STATUS(raddiff_gather_evaluate(NULL, &frame, &in, &out), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "layout") != NULL);
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, NULL, &out), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK_STATUS(raddiff_gather_directions(&layout, &frame, NULL), RADDIFF_ERROR_NULL_POINTER);
  {
    raddiff_gather_layout bad = layout;
    bad.kind = 7;
    CHECK_STATUS(raddiff_gather_evaluate(&bad, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "layout kind") != NULL);
    bad = layout;
    bad.m = 0;
    CHECK_STATUS(raddiff_gather_directions(&bad, &frame, dirs), RADDIFF_ERROR_INVALID_ARGUMENT);
    bad.m = RADDIFF_GATHER_MAX_STRATA_PER_AXIS + 1;
    CHECK_STATUS(raddiff_gather_evaluate(&bad, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
    bad = layout;
    bad.kind = RADDIFF_LAYOUT_SPHERE; /* the directions no longer match their strata */
    CHECK_STATUS(raddiff_gather_evaluate(&bad, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "stratum") != NULL);
  }
  {
    raddiff_frame bad = frame;
    bad.normal.z = 2.0;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &bad, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
    bad = frame;
    bad.tangent.z = 0.1;
    CHECK_STATUS(raddiff_gather_directions(&layout, &bad, dirs), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "tangent") != NULL);
    bad = frame;
    bad.position.x = NAN;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &bad, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  }
  dist[3] = -1.0;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "distance[3]") != NULL);
  dist[3] = 1.0;
  rad[7] = NAN;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  rad[7] = 0.0f;
  in.channels = 0;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  in.channels = 2;
  in.radiance = NULL;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_NULL_POINTER);
  in.radiance = rad;
  in.sigma_t = -0.5;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  in.sigma_t = 0.0;
  in.media_radiance_gradient = rad;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  in.media_radiance_gradient = NULL;
  {
    raddiff_vec3 saved = dirs[0];
    dirs[0].x *= 1.1;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
    CHECK(strstr(raddiff_last_error(), "directions[0]") != NULL);
    dirs[0] = saved;
  }
  /* a failing call leaves the occlusion-aware outputs alone too (their values: ffi-tests/radii.cpp) */
  for (i = 0; i < 18; i++) hess[i] = 42.0;
  out.hessian = hess;
  dist[3] = -1.0;
  CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(hess[0] == 42.0 && hess[17] == 42.0);
  dist[3] = 1.0;
  out.hessian = NULL;
  CHECK(e[0] == 42.0 && out.min_distance == 42.0);

  /* occlusion-aware gradient and Hessian (the Hessian pass) from the same validated input: the
     half-dome again; the occlusion gradient agrees in sign with Ward-Heckbert's, the Hessian is
     symmetric */
  {
    double og[6], h[18];
    raddiff_gather_output o3;
    for (i = 0; i < CELLS; i++) {
      int k = i % N;
      dist[i] = k < N / 2 ? 1.0 : INFINITY;
      rad[2 * i] = k < N / 2 ? 1.0f : 0.0f;
    }
    memset(&o3, 0, sizeof o3);
    o3.gradient = g;
    o3.occlusion_gradient = og;
    o3.hessian = h;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &o3), RADDIFF_OK);
    CHECK(og[1] > 0.0 && g[1] > 0.0);
    CHECK_CLOSE(h[1], h[3], 1e-12);
    CHECK_CLOSE(h[2], h[6], 1e-12);
    CHECK_CLOSE(h[9 + 5], h[9 + 7], 1e-12);
  }

  /* the concentric layout: irradiance and both gradients too */
  {
    raddiff_gather_layout cl = {RADDIFF_LAYOUT_CONCENTRIC, M, N, 5};
    CHECK_STATUS(raddiff_gather_directions(&cl, &frame, dirs), RADDIFF_OK);
    for (i = 0; i < CELLS; i++) {
      dist[i] = dirs[i].y > 0.0 ? 1.0 : INFINITY;
      rad[2 * i] = dirs[i].y > 0.0 ? 1.0f : 0.0f;
    }
    CHECK_STATUS(raddiff_gather_evaluate(&cl, &frame, &in, &out), RADDIFF_OK);
    CHECK(e[0] > 1.0 && e[0] < 2.2);
    CHECK(g[1] > 0.0);
    CHECK(rg[0] < 0.0);
    CHECK_STATUS(raddiff_gather_directions(&layout, &frame, dirs), RADDIFF_OK);
  }

  /* a medium: marched emissive radiance, no surfaces hit: E = pi q (1 - exp(-sigma T)) / sigma */
  {
    static float q[CELLS * 10 * 2];
    const double sigma = 0.5, step = 0.3;
    for (i = 0; i < CELLS; i++) dist[i] = INFINITY;
    for (i = 0; i < CELLS * 10 * 2; i++) q[i] = 0.25f;
    in.sigma_t = sigma;
    in.media_radiance = q;
    in.steps = 10;
    in.step = step;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_OK);
    CHECK_CLOSE(e[0], pi * 0.25 * (1.0 - exp(-sigma * 3.0)) / sigma, 1e-12);
    for (i = 0; i < 6; i++) CHECK(fabs(g[i]) < 1e-13);
    in.steps = 0;
    CHECK_STATUS(raddiff_gather_evaluate(&layout, &frame, &in, &out), RADDIFF_ERROR_INVALID_ARGUMENT);
  }

  CHECK_DONE("gather.c");
}
