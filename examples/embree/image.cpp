#include "image.hpp"

#include "common.hpp"

#include <png.h>

#include <cstdio>
#include <fstream>
#include <memory>

namespace rd {

void write_pfm(const std::string &path, const Image &image) {
  std::ofstream f(path, std::ios::binary);
  f << "PF\n" << image.width << " " << image.height << "\n-1\n";  // little-endian, bottom row first
  for (int y = image.height - 1; y >= 0; --y)
    f.write(reinterpret_cast<const char *>(&image.rgb[3 * static_cast<size_t>(image.width) * y]),
            static_cast<std::streamsize>(3 * image.width * sizeof(float)));
  if (!f) throw std::runtime_error("cannot write " + path);
}

void write_png(const std::string &path, const Image &image, double exposure) {
  std::vector<png_byte> bytes(image.rgb.size());
  for (size_t i = 0; i < image.rgb.size(); ++i) {
    const double v = std::clamp(image.rgb[i] * exposure, 0.0, 1.0);
    const double srgb = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
    bytes[i] = static_cast<png_byte>(255.0 * srgb + 0.5);
  }
  std::unique_ptr<FILE, int (*)(FILE *)> file(std::fopen(path.c_str(), "wb"), std::fclose);
  if (!file) throw std::runtime_error("cannot write " + path);
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw std::runtime_error("libpng: out of memory");
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("libpng failed to write " + path);
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.width), static_cast<png_uint_32>(image.height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < image.height; ++y) png_write_row(png, &bytes[3 * static_cast<size_t>(image.width) * y]);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

double exposure_of(const Image &image) {
  std::vector<float> lum;
  lum.reserve(image.rgb.size() / 3);
  for (size_t i = 0; i < image.rgb.size(); i += 3) lum.push_back(static_cast<float>(luminance(&image.rgb[i])));
  if (lum.empty()) return 1.0;
  std::nth_element(lum.begin(), lum.begin() + lum.size() * 99 / 100, lum.end());
  return 0.9 / std::max(1e-12, static_cast<double>(lum[lum.size() * 99 / 100]));
}

void write_images(const std::string &prefix, const Image &image, double exposure) {
  write_pfm(prefix + ".pfm", image);
  write_png(prefix + ".png", image, exposure > 0 ? exposure : exposure_of(image));
}

}  // namespace rd
