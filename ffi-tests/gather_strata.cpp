// raddiff::gather_evaluate (raddiff.hpp) refuses directions outside their strata with
// raddiff::Error (RADDIFF_ERROR_INVALID_ARGUMENT, the C message naming the first bad index), for the
// concentric layout the issue found accepting them; the same gather in order passes.
#include "hpp_check.h"
#include <cmath>
#include <utility>
#include <vector>

int main() {
  const raddiff_gather_layout layout{RADDIFF_LAYOUT_CONCENTRIC, 8, 8, 5};
  const raddiff_frame frame{{0.0, 0.0, 0.0}, {0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
  const std::vector<raddiff_vec3> good = raddiff::gather_directions(layout, frame);
  const std::size_t cells = good.size();
  std::vector<double> dist(cells, 1.5);
  std::vector<float> rad(cells);
  for (std::size_t i = 0; i < cells; i++) rad[i] = 0.1f + 0.1f * static_cast<float>(i % 4);

  raddiff::GatherInput in;
  in.directions = raddiff::Span<const raddiff_vec3>(good.data(), cells);
  in.distance = raddiff::Span<const double>(dist.data(), cells);
  in.radiance = raddiff::Span<const float>(rad.data(), cells);
  const raddiff::GatherResult ok = raddiff::gather_evaluate(layout, frame, in, raddiff::GATHER_ALL);
  CHECK(ok.irradiance.size() == 1 && std::isfinite(ok.hessian[0]));

  // rows cyclically shifted: row 0 holds row 7's directions, on the opposite side of the square
  std::vector<raddiff_vec3> shifted(cells);
  for (std::size_t i = 0; i < cells; i++) shifted[i] = good[(i + 7 * 8) % cells];
  in.directions = raddiff::Span<const raddiff_vec3>(shifted.data(), cells);
  CHECK_THROWS(raddiff::gather_evaluate(layout, frame, in, raddiff::GATHER_ALL), RADDIFF_ERROR_INVALID_ARGUMENT,
               "directions[0] (row j = 0, column k = 0 of the 8x8 Concentric layout) lies outside its stratum");

  // two neighbours swapped
  std::vector<raddiff_vec3> swapped = good;
  std::swap(swapped[27], swapped[28]);
  in.directions = raddiff::Span<const raddiff_vec3>(swapped.data(), cells);
  CHECK_THROWS(raddiff::gather_evaluate(layout, frame, in), RADDIFF_ERROR_INVALID_ARGUMENT,
               "directions[27] (row j = 3, column k = 3");
  CHECK_DONE("gather_strata.cpp");
}
