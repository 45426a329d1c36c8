#include "raddiff.hpp"
#include <cstdio>

int main() {
  try {
    raddiff_deriv3 d = raddiff::transmittance({0, 0, 0}, {0, 0, 2}, 0.5);  // value, gradient, Hessian
    std::printf("T = %g, dT/dz = %g\n", d.value, d.gradient[2]);
    raddiff::Cache cache({1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT, 0.2});  // freed by ~Cache
    float value = 0.0f;
    if (!cache.try_lookup({0, 0, 0}, {0, 0, 1}, {&value, 1})) std::printf("cache miss\n");
    cache.lookup({0, 0, 0}, {0, 0, 1}, {&value, 1});  // throws raddiff::Error (NOT_FOUND)
  } catch (const raddiff::Error &e) {
    std::printf("raddiff error %d: %s\n", static_cast<int>(e.status()), e.what());
  }
  return 0;
}
