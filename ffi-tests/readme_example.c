#include "raddiff.h"
#include <stdio.h>

int main(void) {
  raddiff_vec3 x = {0, 0, 0}, y = {0, 0, 2};
  raddiff_deriv3 d;
  if (raddiff_transmittance(x, y, 0.5, RADDIFF_ORDER_HESSIAN, &d) != RADDIFF_OK) {
    fprintf(stderr, "raddiff: %s\n", raddiff_last_error());
    return 1;
  }
  printf("T = %g, dT/dz = %g, d2T/dz2 = %g\n", d.value, d.gradient[2], d.hessian[8]);
  return 0;
}
