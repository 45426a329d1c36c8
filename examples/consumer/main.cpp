// C++17 consumer of the installed raddiff package through CMake (see CMakeLists.txt): calls the C
// ABI, checks the answers, and exits non-zero on any mismatch.
#include "raddiff.h"
#include "raddiff.hpp"

#include <cmath>
#include <cstdio>
#include <string>

int main() {
  const std::string expected = std::to_string(RADDIFF_VERSION_MAJOR) + "." +
                               std::to_string(RADDIFF_VERSION_MINOR) + "." +
                               std::to_string(RADDIFF_VERSION_PATCH);
  if (expected != raddiff_version()) {
    std::fprintf(stderr, "library version %s, header version %s\n", raddiff_version(),
                 expected.c_str());
    return 1;
  }
  raddiff_deriv3 d{};
  if (raddiff_transmittance({0, 0, 0}, {0, 0, 2}, 0.5, RADDIFF_ORDER_HESSIAN, &d) != RADDIFF_OK) {
    std::fprintf(stderr, "raddiff: %s\n", raddiff_last_error());
    return 1;
  }
  if (std::fabs(d.value - std::exp(-1.0)) > 1e-15 || !(d.gradient[2] > 0.0)) {
    std::fprintf(stderr, "wrong transmittance %.17g\n", d.value);
    return 1;
  }
  // A failing call reports through raddiff_last_error() and leaves the output alone.
  if (raddiff_transmittance({0, 0, 0}, {0, 0, NAN}, 0.5, RADDIFF_ORDER_VALUE, &d) == RADDIFF_OK ||
      raddiff_last_error()[0] == '\0') {
    std::fprintf(stderr, "a NaN input was accepted\n");
    return 1;
  }
  // The installed C++ wrapper: the same call by value, and a failure as an exception.
  const raddiff_deriv3 w = raddiff::transmittance({0, 0, 0}, {0, 0, 2}, 0.5);
  if (w.value != d.value) {
    std::fprintf(stderr, "raddiff.hpp disagrees with the C call\n");
    return 1;
  }
  try {
    raddiff::transmittance({0, 0, 0}, {0, 0, NAN}, 0.5);
    std::fprintf(stderr, "raddiff.hpp accepted a NaN input\n");
    return 1;
  } catch (const raddiff::Error &e) {
    if (e.status() != RADDIFF_ERROR_INVALID_ARGUMENT) return 1;
  }
  std::printf("raddiff %s (C++): T = %g, dT/dz = %g\n", raddiff_version(), d.value, d.gradient[2]);
  return 0;
}
