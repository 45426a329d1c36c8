/* raddiff_transmittance and the common conventions, through the C header only. */
#include "raddiff.h"
#include "check.h"
#include <string.h>

int main(void) {
  raddiff_vec3 x = {1.0, 2.0, 3.0}, y = {4.0, 6.0, 3.0}; /* |x-y| = 5 */
  raddiff_deriv3 d;
  const double sigma = 0.3, t = exp(-1.5);
  int i, j;

  CHECK(strcmp(raddiff_version(), "0.1.0") == 0);
  CHECK(RADDIFF_VERSION_MAJOR == 0 && RADDIFF_VERSION_MINOR == 1);
  CHECK(strcmp(raddiff_last_error(), "") == 0);

  CHECK_STATUS(raddiff_transmittance(x, y, sigma, RADDIFF_ORDER_HESSIAN, &d), RADDIFF_OK);
  CHECK_CLOSE(d.value, t, 1e-15);
  {
    const double u[3] = {-3.0 / 5.0, -4.0 / 5.0, 0.0};
    for (i = 0; i < 3; i++) CHECK_CLOSE(d.gradient[i], -sigma * t * u[i], 1e-15);
    for (i = 0; i < 3; i++)
      for (j = 0; j < 3; j++) {
        double expect = t * (sigma * sigma * u[i] * u[j] - sigma / 5.0 * ((i == j) - u[i] * u[j]));
        CHECK_CLOSE(d.hessian[3 * i + j], expect, 1e-15);
      }
  }

  /* order selects the work; higher parts are zero */
  CHECK_STATUS(raddiff_transmittance(x, y, sigma, RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK(d.gradient[0] == 0.0 && d.hessian[0] == 0.0);

  /* error paths: outputs untouched */
  d.value = 42.0;
  CHECK_STATUS(raddiff_transmittance(x, y, sigma, 3, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(strstr(raddiff_last_error(), "order") != NULL);
  CHECK_STATUS(raddiff_transmittance(x, y, sigma, RADDIFF_ORDER_VALUE, NULL), RADDIFF_ERROR_NULL_POINTER);
  CHECK(strstr(raddiff_last_error(), "out") != NULL);
  x.y = NAN;
  CHECK_STATUS(raddiff_transmittance(x, y, sigma, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  x.y = 2.0;
  CHECK_STATUS(raddiff_transmittance(x, y, INFINITY, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_transmittance(x, y, -1.0, RADDIFF_ORDER_VALUE, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK_STATUS(raddiff_transmittance(x, x, sigma, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_ERROR_DEGENERATE);
  CHECK(d.value == 42.0);
  /* value at x == y is fine */
  CHECK_STATUS(raddiff_transmittance(x, x, sigma, RADDIFF_ORDER_VALUE, &d), RADDIFF_OK);
  CHECK(d.value == 1.0);

  CHECK_DONE("transmittance.c");
}
