#include "reference.hpp"

#include "trace.hpp"

#include <cinttypes>
#include <cstdio>
#include <fstream>
#include <sys/stat.h>

namespace rd {
namespace {

constexpr uint32_t kFormat = 2;  // bump when the file layout or the estimator's meaning changes

uint64_t fnv(uint64_t h, const void *data, size_t n) {
  const auto *p = static_cast<const unsigned char *>(data);
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  return h;
}

template <class T>
uint64_t fnv_value(uint64_t h, const T &v) {
  return fnv(h, &v, sizeof v);
}

}  // namespace

uint64_t file_hash(const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot open " + path);
  uint64_t h = 0xcbf29ce484222325ull;
  std::vector<char> buf(1 << 16);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    h = fnv(h, buf.data(), static_cast<size_t>(in.gcount()));
  }
  return h;
}

double Reference::relative_noise() const {
  double noise = 0, value = 0;
  for (const ReferencePixel &p : pixels) {
    const double d = 0.5 * (luminance(p.half[0]) - luminance(p.half[1]));
    const double v = luminance(p.value());
    noise += d * d;  // the variance of the mean of two independent halves a, b: E[((a - b) / 2)^2]
    value += v * v;
  }
  return value > 0 ? std::sqrt(noise / value) : 0.0;
}

std::vector<size_t> stratified_pixels(const std::vector<Primary> &primary, int width, int height, int grid,
                                      uint64_t seed) {
  std::vector<size_t> out;
  for (int gy = 0; gy < grid; ++gy) {
    for (int gx = 0; gx < grid; ++gx) {
      const int x0 = gx * width / grid, x1 = (gx + 1) * width / grid;
      const int y0 = gy * height / grid, y1 = (gy + 1) * height / grid;
      if (x1 <= x0 || y1 <= y0) continue;
      // A few jittered tries, then the stratum's pixels in order: the first that shows indirect light.
      const uint64_t s = mix(seed ^ mix(static_cast<uint64_t>(gy) * grid + gx));
      size_t chosen = SIZE_MAX;
      for (int k = 0; k < 16 && chosen == SIZE_MAX; ++k) {
        const int x = x0 + static_cast<int>(unit(s + 2 * k) * (x1 - x0));
        const int y = y0 + static_cast<int>(unit(s + 2 * k + 1) * (y1 - y0));
        const size_t i = static_cast<size_t>(y) * width + x;
        if (primary[i].hit && primary[i].shows_indirect) chosen = i;
      }
      for (int y = y0; y < y1 && chosen == SIZE_MAX; ++y)
        for (int x = x0; x < x1 && chosen == SIZE_MAX; ++x) {
          const size_t i = static_cast<size_t>(y) * width + x;
          if (primary[i].hit && primary[i].shows_indirect) chosen = i;
        }
      if (chosen != SIZE_MAX) out.push_back(chosen);
    }
  }
  return out;
}

ReferencePixel converged_irradiance(const Scene &scene, const HitRadianceSettings &radiance, V3 p, V3 n, uint32_t rays,
                                    uint64_t seed) {
  ReferencePixel r;
  const uint32_t half = std::max(1u, rays / 2);
  uint64_t traced = 0;
  for (int h = 0; h < 2; ++h) {
    // Independent scrambles: the halves' difference is pure noise.
    r.half[h] = irradiance_sum(scene, radiance, p, n, 0, half, mix(seed * 2 + h), traced) * (kPi / half);
  }
  return r;
}

Reference reference(const Scene &scene, const std::vector<Primary> &primary, const View &view,
                    const HitRadianceSettings &radiance, const ReferenceSettings &settings,
                    const std::string &scene_key, unsigned threads) {
  uint64_t key = 0xcbf29ce484222325ull;
  key = fnv(key, scene_key.data(), scene_key.size());
  for (double v : {view.eye.x, view.eye.y, view.eye.z, view.target.x, view.target.y, view.target.z, view.fov})
    key = fnv_value(key, v);
  key = fnv_value(key, view.width);
  key = fnv_value(key, view.height);
  // The converged quantity, not the estimator's sample counts: references are shared by every
  // estimator of the same light.
  const std::string rk = radiance.converged_key();
  key = fnv(key, rk.data(), rk.size());
  key = fnv_value(key, settings.grid);
  key = fnv_value(key, settings.rays);
  key = fnv_value(key, settings.seed);
  key = fnv_value(key, kFormat);

  Reference ref;
  const std::vector<size_t> pixels = stratified_pixels(primary, view.width, view.height, settings.grid, settings.seed);
  char name[64];
  std::snprintf(name, sizeof name, "reference-%016" PRIx64 ".bin", key);
  if (!settings.cache_dir.empty()) {
    mkdir(settings.cache_dir.c_str(), 0755);
    ref.file = settings.cache_dir + "/" + name;
    std::ifstream in(ref.file, std::ios::binary);
    uint64_t stored_key = 0, count = 0;
    if (in && in.read(reinterpret_cast<char *>(&stored_key), 8) && in.read(reinterpret_cast<char *>(&count), 8) &&
        stored_key == key && count == pixels.size()) {
      ref.pixels.resize(count);
      bool ok = true;
      for (ReferencePixel &p : ref.pixels) {
        uint64_t pixel = 0;
        double v[6];
        ok = ok && in.read(reinterpret_cast<char *>(&pixel), 8) && in.read(reinterpret_cast<char *>(v), sizeof v);
        p.pixel = pixel;
        p.half[0] = {v[0], v[1], v[2]};
        p.half[1] = {v[3], v[4], v[5]};
      }
      if (ok) {
        ref.loaded = true;
        return ref;
      }
      ref.pixels.clear();
    }
  }

  HitRadianceSettings single = radiance;
  single.paths = 1;  // the rays are many already: one estimate each
  std::printf("reference: %zu pixels x %u rays (%s), computing...\n", pixels.size(), settings.rays,
              single.describe().c_str());
  std::fflush(stdout);
  ref.pixels.resize(pixels.size());
  std::atomic<size_t> done{0};
  std::atomic<double> cpu{0};
  parallel_for(pixels.size(), threads, [&](size_t k) {
    const double t0 = thread_cpu_seconds();
    const Primary &px = primary[pixels[k]];
    ref.pixels[k] = converged_irradiance(scene, single, px.p, px.n, settings.rays, mix(pixels[k] ^ 0xfeedull));
    ref.pixels[k].pixel = pixels[k];
    double c = cpu.load();
    while (!cpu.compare_exchange_weak(c, c + thread_cpu_seconds() - t0)) {
    }
    const size_t d = ++done;
    if (d % std::max<size_t>(1, pixels.size() / 10) == 0) {
      std::printf("reference: %zu / %zu pixels\n", d, pixels.size());
      std::fflush(stdout);
    }
  });
  ref.seconds = cpu.load();
  if (!ref.file.empty()) {
    const std::string tmp = ref.file + ".tmp";
    std::ofstream out(tmp, std::ios::binary);
    const uint64_t count = ref.pixels.size();
    out.write(reinterpret_cast<const char *>(&key), 8);
    out.write(reinterpret_cast<const char *>(&count), 8);
    for (const ReferencePixel &p : ref.pixels) {
      const uint64_t pixel = p.pixel;
      const double v[6] = {p.half[0].x, p.half[0].y, p.half[0].z, p.half[1].x, p.half[1].y, p.half[1].z};
      out.write(reinterpret_cast<const char *>(&pixel), 8);
      out.write(reinterpret_cast<const char *>(v), sizeof v);
    }
    out.close();
    if (!out || std::rename(tmp.c_str(), ref.file.c_str()) != 0) throw std::runtime_error("cannot write " + ref.file);
  }
  return ref;
}

}  // namespace rd
