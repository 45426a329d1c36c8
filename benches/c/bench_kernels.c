/* raddiff's C entry points for the triangle solid angle and the point-to-triangle form factor
   against the textbook formula a C user writes (textbook.c: plain doubles, libm's atan2), timed in
   one run, interleaved: every round times every case once, and each case reports the minimum over
   the rounds. Two sets of configurations: "spread", 256 generic configurations (well-shaped
   triangles seen from 0.5 to 3 sizes away, off their plane by more than 5% of the distance, the
   receiver's tangent plane clear of the triangle), and "fixed", the one generic configuration of
   benches/solid_angle_transmittance.rs (solid angle) and benches/form_factor.rs (form factor). Ratios are to the
   textbook value of the same kernel on the same set, measured in the same rounds. Times are
   per-thread CPU time, so that other processes on the machine distort them less.

   Built and run by scripts/bench-c-abi.sh (gcc -O2, against the release static library):
     scripts/bench-c-abi.sh [rounds]
   RADDIFF_C_ABI_PROFILE="CASE,CALLS" runs one case CALLS times and nothing else (for callgrind:
   scripts/instructions-per-call.sh <binary> RADDIFF_C_ABI_PROFILE 'CASE,{calls}'); CASE is a row
   name of the table without spaces, e.g. solid_angle_value or raddiff_form_factor_hessian. */
#include "raddiff.h"
#include "textbook.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define CONFIGS 256

typedef struct {
  raddiff_vec3 x, n, a, b, c;
} config;

static config configs[CONFIGS];
/* The fixed configurations: the solid angle's (benches/solid_angle_transmittance.rs) and the form factor's (benches/form_factor.rs). */
static config fixed[2];

/* SplitMix64: the same configurations on every run and platform. */
static unsigned long long rng_state = 0x9e3779b97f4a7c15ull;
static double uniform(void) {
  unsigned long long z = (rng_state += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return (double)(z >> 11) / 9007199254740992.0;
}

static raddiff_vec3 v3(double x, double y, double z) {
  raddiff_vec3 v;
  v.x = x;
  v.y = y;
  v.z = z;
  return v;
}
static raddiff_vec3 sub(raddiff_vec3 a, raddiff_vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static double dot(raddiff_vec3 a, raddiff_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static raddiff_vec3 cross(raddiff_vec3 a, raddiff_vec3 b) {
  return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static double norm(raddiff_vec3 a) { return sqrt(dot(a, a)); }
static raddiff_vec3 in_ball(double radius) {
  for (;;) {
    raddiff_vec3 p = v3(2.0 * uniform() - 1.0, 2.0 * uniform() - 1.0, 2.0 * uniform() - 1.0);
    if (dot(p, p) <= 1.0) return v3(p.x * radius, p.y * radius, p.z * radius);
  }
}

static void make_fixed(void) {
  fixed[0].x = v3(0.4, 0.3, 0.8);
  fixed[0].a = v3(0.1, -0.2, 0.05);
  fixed[0].b = v3(1.1, 0.1, 0.2);
  fixed[0].c = v3(0.3, 0.9, -0.1);
  fixed[0].n = v3(0.0, 0.0, 1.0);
  fixed[1].x = v3(0.1, -0.2, 0.05);
  fixed[1].n = v3(0.2, -0.1, 1.0);
  fixed[1].n = v3(fixed[1].n.x / norm(fixed[1].n), fixed[1].n.y / norm(fixed[1].n),
                  fixed[1].n.z / norm(fixed[1].n));
  fixed[1].a = v3(-0.4, -0.3, 1.0);
  fixed[1].b = v3(0.7, -0.1, 1.2);
  fixed[1].c = v3(0.0, 0.8, 0.9);
}

/* Generic configurations: the triangle's doubled area at least 0.2 of its largest squared edge, x
   between 0.5 and 3 sizes from every vertex and at least 5% of its distance off the plane, every
   vertex at least 10% of its distance above the receiver's tangent plane (nothing clipped). */
static void make_configs(void) {
  int k = 0;
  while (k < CONFIGS) {
    config g;
    raddiff_vec3 v[3], normal, centroid, towards;
    double size = 0.0, near = INFINITY, far = 0.0, height;
    int i, ok = 1;
    g.a = v[0] = in_ball(1.0);
    g.b = v[1] = in_ball(1.0);
    g.c = v[2] = in_ball(1.0);
    for (i = 0; i < 3; i++) size = fmax(size, norm(sub(v[(i + 1) % 3], v[i])));
    normal = cross(sub(v[1], v[0]), sub(v[2], v[0]));
    if (norm(normal) < 0.2 * size * size) continue;
    g.x = in_ball(3.0 * size);
    for (i = 0; i < 3; i++) {
      near = fmin(near, norm(sub(v[i], g.x)));
      far = fmax(far, norm(sub(v[i], g.x)));
    }
    height = fabs(dot(sub(v[0], g.x), normal)) / norm(normal);
    if (near < 0.5 * size || far > 3.0 * size || height < 0.05 * near) continue;
    centroid = v3((v[0].x + v[1].x + v[2].x) / 3.0, (v[0].y + v[1].y + v[2].y) / 3.0,
                  (v[0].z + v[1].z + v[2].z) / 3.0);
    towards = sub(centroid, g.x);
    g.n = in_ball(0.3 * norm(towards));
    g.n = v3(towards.x + g.n.x, towards.y + g.n.y, towards.z + g.n.z);
    g.n = v3(g.n.x / norm(g.n), g.n.y / norm(g.n), g.n.z / norm(g.n));
    for (i = 0; i < 3; i++) {
      raddiff_vec3 r = sub(v[i], g.x);
      if (dot(g.n, r) < 0.1 * norm(r)) ok = 0;
    }
    if (ok) configs[k++] = g;
  }
}

enum { VALUE = RADDIFF_ORDER_VALUE, GRADIENT = RADDIFF_ORDER_GRADIENT, HESSIAN = RADDIFF_ORDER_HESSIAN };
enum kernel { SOLID_ANGLE, FORM_FACTOR };

typedef struct {
  const char *name;
  enum kernel kernel;
  int textbook; /* 1: the textbook value, 0: raddiff at `order` */
  unsigned order;
  int fixed; /* 1: the fixed configuration, 0: the spread */
  int baseline; /* the row of the textbook value this case is compared with */
} bench_case;

static const bench_case cases[] = {
    {"solid_angle_textbook_value", SOLID_ANGLE, 1, VALUE, 0, 0},
    {"solid_angle_value", SOLID_ANGLE, 0, VALUE, 0, 0},
    {"solid_angle_gradient", SOLID_ANGLE, 0, GRADIENT, 0, 0},
    {"solid_angle_hessian", SOLID_ANGLE, 0, HESSIAN, 0, 0},
    {"form_factor_textbook_value", FORM_FACTOR, 1, VALUE, 0, 4},
    {"form_factor_value", FORM_FACTOR, 0, VALUE, 0, 4},
    {"form_factor_gradient", FORM_FACTOR, 0, GRADIENT, 0, 4},
    {"form_factor_hessian", FORM_FACTOR, 0, HESSIAN, 0, 4},
    {"fixed_solid_angle_textbook_value", SOLID_ANGLE, 1, VALUE, 1, 8},
    {"fixed_solid_angle_value", SOLID_ANGLE, 0, VALUE, 1, 8},
    {"fixed_solid_angle_gradient", SOLID_ANGLE, 0, GRADIENT, 1, 8},
    {"fixed_solid_angle_hessian", SOLID_ANGLE, 0, HESSIAN, 1, 8},
    {"fixed_form_factor_textbook_value", FORM_FACTOR, 1, VALUE, 1, 12},
    {"fixed_form_factor_value", FORM_FACTOR, 0, VALUE, 1, 12},
    {"fixed_form_factor_gradient", FORM_FACTOR, 0, GRADIENT, 1, 12},
    {"fixed_form_factor_hessian", FORM_FACTOR, 0, HESSIAN, 1, 12},
};
#define CASES ((int)(sizeof cases / sizeof cases[0]))

static volatile double sink;

/* `calls` calls of one case, cycling over the configurations; returns the sum of the values (kept
   in `sink`, so that nothing is optimized away). */
static double run(const bench_case *c, long calls) {
  double sum = 0.0;
  long i;
  for (i = 0; i < calls; i++) {
    const config *g = c->fixed ? &fixed[c->kernel] : &configs[i % CONFIGS];
    raddiff_deriv3 d;
    if (c->textbook) {
      sum += c->kernel == SOLID_ANGLE ? textbook_solid_angle(g->x, g->a, g->b, g->c)
                                      : textbook_triangle_form_factor(g->x, g->n, g->a, g->b, g->c);
      continue;
    }
    if (c->kernel == SOLID_ANGLE)
      raddiff_triangle_solid_angle(g->x, g->a, g->b, g->c, c->order, &d);
    else
      raddiff_triangle_form_factor(g->x, g->n, g->a, g->b, g->c, c->order, &d);
    sum += d.value + d.gradient[0] + d.hessian[0];
  }
  sink = sum;
  return sum;
}

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

/* raddiff agrees with the textbook value on every configuration (they are generic: both are
   accurate there), so that both sides compute the same thing. */
static int check(void) {
  double worst[2] = {0.0, 0.0};
  int k;
  for (k = 0; k < CONFIGS; k++) {
    const config *g = &configs[k];
    raddiff_deriv3 d;
    double t;
    if (raddiff_triangle_solid_angle(g->x, g->a, g->b, g->c, HESSIAN, &d) != RADDIFF_OK) return 1;
    t = textbook_solid_angle(g->x, g->a, g->b, g->c);
    worst[0] = fmax(worst[0], fabs(d.value - t) / t);
    if (raddiff_triangle_form_factor(g->x, g->n, g->a, g->b, g->c, HESSIAN, &d) != RADDIFF_OK) return 1;
    t = textbook_triangle_form_factor(g->x, g->n, g->a, g->b, g->c);
    worst[1] = fmax(worst[1], fabs(d.value - t) / t);
  }
  printf("%d generic configurations; largest relative difference to the textbook value: solid angle "
         "%.1e, form factor %.1e\n",
         CONFIGS, worst[0], worst[1]);
  return worst[0] > 1e-12 || worst[1] > 1e-12;
}

int main(int argc, char **argv) {
  const char *profile = getenv("RADDIFF_C_ABI_PROFILE");
  int rounds = argc > 1 ? atoi(argv[1]) : 30;
  double best[CASES];
  long calls[CASES];
  int r, k;
  make_configs();
  make_fixed();
  if (profile) {
    const char *comma = strchr(profile, ',');
    for (k = 0; k < CASES; k++)
      if (comma && strncmp(profile, cases[k].name, (size_t)(comma - profile)) == 0 &&
          cases[k].name[comma - profile] == '\0') {
        run(&cases[k], atol(comma + 1));
        return 0;
      }
    fprintf(stderr, "RADDIFF_C_ABI_PROFILE must be CASE,CALLS with CASE a row name\n");
    return 2;
  }
  if (check()) {
    fprintf(stderr, "raddiff failed or disagreed with the textbook value\n");
    return 1;
  }
  /* Calls per round: about 2 ms of each case, after a warm-up call of each. */
  for (k = 0; k < CASES; k++) {
    double t0, t;
    long n = CONFIGS;
    run(&cases[k], CONFIGS);
    for (;;) {
      t0 = now();
      run(&cases[k], n);
      t = now() - t0;
      if (t > 2e-3 || n > 100000000L) break;
      n *= 2;
    }
    calls[k] = n;
    best[k] = INFINITY;
  }
  for (r = 0; r < rounds; r++)
    for (k = 0; k < CASES; k++) {
      /* Rotated order, so that no case always follows the same one. */
      int c = (k + r) % CASES;
      double t0 = now(), t;
      run(&cases[c], calls[c]);
      t = (now() - t0) / (double)calls[c];
      if (t < best[c]) best[c] = t;
    }
  printf("ns per call, minimum over %d interleaved rounds; ratio to the textbook value of the same "
         "kernel in the same rounds\n",
         rounds);
  printf("| case | ns per call | ratio |\n|---|---|---|\n");
  /* "fixed_" rows: the fixed configuration; the others: the spread. */
  for (k = 0; k < CASES; k++) {
    double base = best[cases[k].baseline];
    printf("| %s | %.1f | %.2fx |\n", cases[k].name, 1e9 * best[k], best[k] / base);
  }
  return 0;
}
