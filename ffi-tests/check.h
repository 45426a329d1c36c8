/* Minimal assertion helpers shared by the ffi-tests programs (C99 and C++17). */
#ifndef RADDIFF_FFI_CHECK_H
#define RADDIFF_FFI_CHECK_H
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

static int check_failures = 0;

#define CHECK(cond)                                                                     \
  do {                                                                                  \
    if (!(cond)) {                                                                      \
      fprintf(stderr, "%s:%d: CHECK failed: %s (last error: %s)\n", __FILE__, __LINE__,  \
              #cond, raddiff_last_error());                                             \
      check_failures++;                                                                 \
    }                                                                                   \
  } while (0)

#define CHECK_STATUS(call, expected) CHECK((call) == (expected))

/* |a - b| <= tol * max(1, |b|) */
#define CHECK_CLOSE(a, b, tol) CHECK(fabs((double)(a) - (double)(b)) <= (tol) * fmax(1.0, fabs((double)(b))))

#define CHECK_DONE(name)                                                                \
  do {                                                                                  \
    if (check_failures) {                                                               \
      fprintf(stderr, "%s: %d check(s) failed\n", name, check_failures);               \
      return 1;                                                                         \
    }                                                                                   \
    printf("%s: all checks passed\n", name);                                            \
    return 0;                                                                           \
  } while (0)

#endif
