// The near/far decomposition through raddiff.hpp: a pixel's near field and a record's far-field
// gather compose to the whole gather's irradiance; sizes are checked before any call and a rejected
// reach throws with the library's status.
#include "raddiff.hpp"
#include "hpp_check.h"

#include <cmath>
#include <limits>
#include <vector>

int main() {
  const raddiff_gather_layout layout{RADDIFF_LAYOUT_CONCENTRIC, 16, 16, 3};
  const raddiff_frame frame{{1.0, 2.0, 3.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
  const std::vector<raddiff_vec3> directions = raddiff::gather_directions(layout, frame);
  std::vector<double> distance(directions.size());
  std::vector<float> radiance(directions.size());
  for (std::size_t i = 0; i < distance.size(); ++i) {
    distance[i] = i % 5 == 0 ? std::numeric_limits<double>::infinity() : 0.05 * static_cast<double>(i % 13 + 1);
    radiance[i] = static_cast<float>(1 + i % 4);
  }
  raddiff::GatherInput in;
  in.directions = directions;
  in.distance = distance;
  in.radiance = radiance;
  const double whole = raddiff::gather_evaluate(layout, frame, in, raddiff::GATHER_IRRADIANCE).irradiance[0];

  const raddiff::NearField near = raddiff::gather_near_field(layout, distance, radiance, 1, 0.3);
  std::vector<float> far = radiance;
  const double open = raddiff::gather_far_field_radiance(layout, distance, far, 1, 0.3);
  CHECK(open == near.open_fraction && open > 0.0 && open < 1.0);
  in.radiance = far;
  const double far_field = raddiff::gather_evaluate(layout, frame, in, raddiff::GATHER_IRRADIANCE).irradiance[0];
  CHECK(std::fabs(near.irradiance[0] + open * far_field - whole) <= 1e-6 * whole);

  // The far-field gather with distances: the same radiance, the near hits at the reach.
  std::vector<double> moved = distance;
  std::vector<float> moved_radiance = radiance;
  CHECK(raddiff::gather_far_field(layout, moved, moved_radiance, 1, 0.3) == open);
  CHECK(moved_radiance == far);
  for (std::size_t i = 0; i < moved.size(); ++i) CHECK(moved[i] == (distance[i] < 0.3 ? 0.3 : distance[i]));

  // Sizes are checked before the call; a bad reach comes back as the library's status.
  std::vector<float> short_radiance(radiance.size() - 1);
  CHECK_THROWS(raddiff::gather_near_field(layout, distance, short_radiance, 1, 0.3), RADDIFF_ERROR_INVALID_ARGUMENT,
               "radiance");
  CHECK_THROWS(raddiff::gather_far_field_radiance(layout, distance, short_radiance, 1, 0.3),
               RADDIFF_ERROR_INVALID_ARGUMENT, "radiance");
  CHECK_THROWS(raddiff::gather_near_field(layout, distance, radiance, 1, -1.0), RADDIFF_ERROR_INVALID_ARGUMENT, "reach");
  std::vector<float> kept = radiance;
  CHECK_THROWS(raddiff::gather_far_field_radiance(layout, distance, kept, 1, std::nan("")),
               RADDIFF_ERROR_INVALID_ARGUMENT, "reach");
  CHECK(kept == radiance);
  CHECK_DONE("near_far (C++)");
}
