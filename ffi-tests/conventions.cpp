// C++17 use of the header: conventions that hold for every function (thread-local last error).
#include "raddiff.h"
#include "check.h"
#include <cstring>
#include <string>
#include <thread>

int main() {
  raddiff_vec3 x{0.0, 0.0, 0.0}, y{0.0, 0.0, 2.0};
  raddiff_deriv3 d{};
  CHECK_STATUS(raddiff_transmittance(x, y, 0.5, RADDIFF_ORDER_GRADIENT, &d), RADDIFF_OK);
  CHECK_CLOSE(d.gradient[2], 0.5 * std::exp(-1.0), 1e-15);

  // The last error is per thread: a failure on another thread is not seen here.
  CHECK_STATUS(raddiff_transmittance(x, y, 0.5, 7, &d), RADDIFF_ERROR_INVALID_ARGUMENT);
  std::string mine = raddiff_last_error();
  std::thread other([&] {
    std::string fresh = raddiff_last_error();
    CHECK(fresh.empty());
    CHECK_STATUS(raddiff_transmittance(x, y, 0.5, RADDIFF_ORDER_VALUE, nullptr), RADDIFF_ERROR_NULL_POINTER);
  });
  other.join();
  CHECK(mine == raddiff_last_error());
  CHECK_DONE("conventions.cpp");
}
