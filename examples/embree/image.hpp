// Image files: PFM (linear RGB, what OIDN and the report read) and PNG (tone mapped, for viewing).
#pragma once

#include <string>
#include <vector>

namespace rd {

// Linear RGB, row 0 at the top, 3 floats per pixel.
struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;
  Image() = default;
  Image(int w, int h) : width(w), height(h), rgb(3 * static_cast<size_t>(w) * h, 0.0f) {}
  float *at(size_t pixel) { return &rgb[3 * pixel]; }
  const float *at(size_t pixel) const { return &rgb[3 * pixel]; }
};

void write_pfm(const std::string &path, const Image &image);
// 8-bit sRGB PNG of image * exposure (clamped).
void write_png(const std::string &path, const Image &image, double exposure);
// The exposure that maps the 99th percentile of the luminance to 0.9.
double exposure_of(const Image &image);
// write_pfm and write_png (the exposure given, or exposure_of(image) when <= 0) at prefix.pfm/.png.
void write_images(const std::string &prefix, const Image &image, double exposure = 0);

}  // namespace rd
