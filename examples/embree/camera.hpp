// The pinhole camera and the primary hits of an image: where the cache is looked up.
#pragma once

#include "scene.hpp"

#include <vector>

namespace rd {

struct View {
  V3 eye{0.5, 0.5, 2.35}, target{0.5, 0.5, 0.0};
  double fov = 38.0;  // vertical, degrees
  int width = 256, height = 256;
};

// A pixel's primary hit (through the pixel's centre).
struct Primary {
  bool hit = false;
  V3 p, n;            // surface point (pulled back towards the eye by 1e-4 of the distance), unit normal
  uint32_t triangle = 0;
  double footprint = 0;  // world size of the pixel at p, across the view ray (L)
  bool shows_indirect = false;  // a reflecting, non-emitting surface: its pixel shows indirect light
};

class Camera {
 public:
  explicit Camera(const View &view);
  // The unit direction through image position (px, py) in pixels (pixel centres at i + 0.5).
  V3 direction(double px, double py) const;
  const View &view() const { return view_; }
  // The pixel containing the projection of p, or false when p is behind the eye or off the image.
  bool project(V3 p, double &px, double &py) const;
  // World size of one pixel at distance t along the central ray.
  double pixel_angle() const { return 2 * tan_half_ / view_.height; }

 private:
  View view_;
  V3 forward_, right_, up_;
  double tan_half_, aspect_;
};

std::vector<Primary> primary_hits(const Scene &scene, const Camera &camera, unsigned threads);

// Pixel indices of one level of a coarse-to-fine pass over a w x h image: the grid of step `step`
// (16, 8, ..., 1) without the coarser grid's pixels (the coarsest level, 16, takes its whole grid).
inline std::vector<size_t> level_pixels(int w, int h, int step) {
  std::vector<size_t> level;
  for (int y = 0; y < h; y += step)
    for (int x = 0; x < w; x += step)
      if (step == 16 || x % (2 * step) != 0 || y % (2 * step) != 0) level.push_back(static_cast<size_t>(y) * w + x);
  return level;
}

}  // namespace rd
