/* Smallest consumer of the installed raddiff package (C99), built by scripts/check-install.sh
 * through pkg-config, shared and static:
 *   cc hello.c $(pkg-config --cflags --libs raddiff) -o hello
 *   cc hello.c $(pkg-config --static --cflags raddiff) -Wl,-Bstatic -lraddiff -Wl,-Bdynamic \
 *      $(pkg-config --static --libs-only-other --libs-only-L raddiff) ... (see the script)
 * Exits 0 only when the library answers and the value is right. */
#include "raddiff.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

int main(void) {
  const char *version = raddiff_version();
  char expected[32];
  snprintf(expected, sizeof expected, "%d.%d.%d", RADDIFF_VERSION_MAJOR, RADDIFF_VERSION_MINOR,
           RADDIFF_VERSION_PATCH);
  if (strcmp(version, expected) != 0) {
    fprintf(stderr, "library version %s, header version %s\n", version, expected);
    return 1;
  }
  raddiff_vec3 x = {0, 0, 0}, y = {0, 0, 2};
  raddiff_deriv3 d;
  if (raddiff_transmittance(x, y, 0.5, RADDIFF_ORDER_HESSIAN, &d) != RADDIFF_OK) {
    fprintf(stderr, "raddiff: %s\n", raddiff_last_error());
    return 1;
  }
  if (fabs(d.value - exp(-1.0)) > 1e-15 || !(d.gradient[2] > 0.0)) {
    fprintf(stderr, "wrong transmittance %.17g\n", d.value);
    return 1;
  }
  printf("raddiff %s: T = %g, dT/dz = %g, d2T/dz2 = %g\n", version, d.value, d.gradient[2],
         d.hessian[8]);
  return 0;
}
