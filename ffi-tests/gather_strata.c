/* raddiff_gather_evaluate refuses directions that are not in their own strata (issue 17), for every
   layout kind, with RADDIFF_ERROR_INVALID_ARGUMENT, a message naming the first bad index, and no
   output written; valid gathers of many seeds pass. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

#define M 6
#define N 10
#define CELLS (M * N)
#define SENTINEL 12345.0

static raddiff_vec3 good[CELLS];
static raddiff_vec3 dirs[CELLS];
static double dist[CELLS];
static float rad[CELLS];

static double e[1], g[3], rg[3], og[3], hess[9];

static raddiff_gather_output sentinel_output(void) {
  raddiff_gather_output out;
  int i;
  e[0] = SENTINEL;
  for (i = 0; i < 3; i++) g[i] = rg[i] = og[i] = SENTINEL;
  for (i = 0; i < 9; i++) hess[i] = SENTINEL;
  out.irradiance = e;
  out.gradient = g;
  out.rotation_gradient = rg;
  out.occlusion_gradient = og;
  out.hessian = hess;
  out.harmonic_mean_distance = SENTINEL;
  out.min_distance = SENTINEL;
  return out;
}

static int untouched(const raddiff_gather_output *out) {
  int i, ok = e[0] == SENTINEL && out->harmonic_mean_distance == SENTINEL && out->min_distance == SENTINEL;
  for (i = 0; i < 3; i++) ok = ok && g[i] == SENTINEL && rg[i] == SENTINEL && og[i] == SENTINEL;
  for (i = 0; i < 9; i++) ok = ok && hess[i] == SENTINEL;
  return ok;
}

static raddiff_status evaluate(const raddiff_gather_layout *layout, const raddiff_frame *frame,
                               raddiff_gather_output *out) {
  raddiff_gather_input in;
  memset(&in, 0, sizeof in);
  in.directions = dirs;
  in.distance = dist;
  in.radiance = rad;
  in.channels = 1;
  return raddiff_gather_evaluate(layout, frame, &in, out);
}

/* The modified `dirs` must be refused, naming directions[first] and its stratum. */
static void expect_refused(const raddiff_gather_layout *layout, const raddiff_frame *frame, int first,
                           const char *what) {
  char want[64];
  raddiff_gather_output out = sentinel_output();
  raddiff_status s = evaluate(layout, frame, &out);
  if (s != RADDIFF_ERROR_INVALID_ARGUMENT) {
    fprintf(stderr, "layout %u seed %lu, %s: status %d\n", layout->kind, (unsigned long)layout->seed, what, (int)s);
  }
  CHECK(s == RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(untouched(&out));
  sprintf(want, "directions[%d] (row j = %d, column k = %d", first, first / N, first % N);
  if (strstr(raddiff_last_error(), want) == NULL) {
    fprintf(stderr, "layout %u, %s: expected \"%s\" in \"%s\"\n", layout->kind, what, want, raddiff_last_error());
    check_failures++;
  }
}

int main(void) {
  const unsigned kinds[3] = {RADDIFF_LAYOUT_COSINE_POLAR, RADDIFF_LAYOUT_CONCENTRIC, RADDIFF_LAYOUT_SPHERE};
  const raddiff_frame frame = {{0.5, -1.0, 2.0}, {0.0, 0.6, 0.8}, {1.0, 0.0, 0.0}};
  int kind, i, j, k;
  unsigned long seed;

  for (i = 0; i < CELLS; i++) {
    dist[i] = 1.0 + 0.1 * (i % 7);
    rad[i] = (float)(0.2 + 0.05 * (i % 5));
  }
  for (kind = 0; kind < 3; kind++) {
    /* valid gathers of many seeds pass */
    for (seed = 0; seed < 200; seed++) {
      raddiff_gather_layout layout = {kinds[kind], M, N, seed * 7919u};
      raddiff_gather_output out = sentinel_output();
      CHECK_STATUS(raddiff_gather_directions(&layout, &frame, dirs), RADDIFF_OK);
      CHECK_STATUS(evaluate(&layout, &frame, &out), RADDIFF_OK);
      CHECK(isfinite(e[0]) && isfinite(hess[0]));
    }
    for (seed = 0; seed < 3; seed++) {
      raddiff_gather_layout layout = {kinds[kind], M, N, seed * 31u};
      CHECK_STATUS(raddiff_gather_directions(&layout, &frame, good), RADDIFF_OK);

      /* rows shifted by one (row j holds row j - 1's directions): row 1 is the first wrong one */
      memcpy(dirs, good, sizeof dirs);
      memmove(dirs + N, good, sizeof(raddiff_vec3) * (CELLS - N));
      expect_refused(&layout, &frame, N, "rows shifted by one");

      /* rows cyclically shifted (row j holds row j + 1's, the last row the first's) */
      for (i = 0; i < CELLS; i++) dirs[i] = good[(i + N) % CELLS];
      expect_refused(&layout, &frame, 0, "rows cyclically shifted");

      /* columns shifted by one within each row */
      for (j = 0; j < M; j++) {
        for (k = 0; k < N; k++) dirs[j * N + k] = good[j * N + (k + 1) % N];
      }
      expect_refused(&layout, &frame, 0, "columns shifted by one");

      /* the whole array off by one index */
      memcpy(dirs, good, sizeof dirs);
      memmove(dirs + 1, good, sizeof(raddiff_vec3) * (CELLS - 1));
      expect_refused(&layout, &frame, 1, "off by one index");

      /* two neighbours swapped, along a row and across rows */
      memcpy(dirs, good, sizeof dirs);
      dirs[2 * N + 3] = good[2 * N + 4];
      dirs[2 * N + 4] = good[2 * N + 3];
      expect_refused(&layout, &frame, 2 * N + 3, "neighbours swapped in a row");
      memcpy(dirs, good, sizeof dirs);
      dirs[3 * N + 5] = good[4 * N + 5];
      dirs[4 * N + 5] = good[3 * N + 5];
      expect_refused(&layout, &frame, 3 * N + 5, "neighbours swapped across rows");

      /* a direction from the far side: the opposite azimuth (hemisphere) or the antipode */
      memcpy(dirs, good, sizeof dirs);
      {
        const raddiff_vec3 w = good[4 * N + 7];
        const raddiff_vec3 n = frame.normal;
        const double wn = w.x * n.x + w.y * n.y + w.z * n.z;
        if (kinds[kind] == RADDIFF_LAYOUT_SPHERE) {
          dirs[4 * N + 7].x = -w.x;
          dirs[4 * N + 7].y = -w.y;
          dirs[4 * N + 7].z = -w.z;
        } else {
          /* rotate by pi about the normal: same elevation, opposite azimuth */
          dirs[4 * N + 7].x = 2.0 * wn * n.x - w.x;
          dirs[4 * N + 7].y = 2.0 * wn * n.y - w.y;
          dirs[4 * N + 7].z = 2.0 * wn * n.z - w.z;
        }
      }
      expect_refused(&layout, &frame, 4 * N + 7, "far side");
      if (kinds[kind] != RADDIFF_LAYOUT_SPHERE) {
        /* below the horizon: mirrored through the tangent plane */
        memcpy(dirs, good, sizeof dirs);
        {
          const raddiff_vec3 w = good[N + 2];
          const raddiff_vec3 n = frame.normal;
          const double wn = w.x * n.x + w.y * n.y + w.z * n.z;
          dirs[N + 2].x = w.x - 2.0 * wn * n.x;
          dirs[N + 2].y = w.y - 2.0 * wn * n.y;
          dirs[N + 2].z = w.z - 2.0 * wn * n.z;
        }
        expect_refused(&layout, &frame, N + 2, "below the horizon");
        CHECK(strstr(raddiff_last_error(), "below the horizon") != NULL);
      }
      /* the directions of another seed: only strata whose jitter differs enough move out, but
         a frame turned by 90 degrees about the normal moves every column */
      {
        raddiff_frame turned = frame;
        turned.tangent.x = 0.0;
        turned.tangent.y = 0.8;
        turned.tangent.z = -0.6;
        memcpy(dirs, good, sizeof dirs);
        expect_refused(&layout, &turned, 0, "turned frame");
        CHECK(strstr(raddiff_last_error(), "lies outside its stratum") != NULL);
      }
    }
  }
  CHECK_DONE("gather_strata");
}
