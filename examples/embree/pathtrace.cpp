#include "pathtrace.hpp"

#include "trace.hpp"

#include <mutex>

namespace rd {

void path_trace(const Scene &scene, const std::vector<Primary> &primary, const View &view,
                const HitRadianceSettings &radiance, uint32_t max_spp, double max_cpu_seconds, unsigned threads,
                const std::function<void(const PathTraceSnapshot &)> &snapshot) {
  std::vector<V3> sum(primary.size());
  double cpu = 0;
  uint64_t rays = 0;
  uint32_t done = 0;
  std::mutex lock;
  for (uint32_t spp = 1; spp <= max_spp; spp *= 2) {
    const uint32_t first = done, count = spp - done;
    // Rows as work items: enough of them to balance two threads, few enough to keep overhead low.
    parallel_for(static_cast<size_t>(view.height), threads, [&](size_t row) {
      const double t0 = thread_cpu_seconds();
      uint64_t traced = 0;
      for (int x = 0; x < view.width; ++x) {
        const size_t i = row * view.width + x;
        if (!primary[i].hit) continue;
        sum[i] += irradiance_sum(scene, radiance, primary[i].p, primary[i].n, first, count, mix(i ^ 0xa11ce), traced);
      }
      const double dt = thread_cpu_seconds() - t0;
      std::lock_guard<std::mutex> g(lock);
      cpu += dt;
      rays += traced;
    });
    done = spp;
    PathTraceSnapshot s;
    s.spp = spp;
    s.cpu_seconds = cpu;
    s.rays = rays;
    s.image = Image(view.width, view.height);
    for (size_t i = 0; i < primary.size(); ++i) {
      const V3 e = sum[i] * (kPi / spp);
      s.image.at(i)[0] = static_cast<float>(e.x);
      s.image.at(i)[1] = static_cast<float>(e.y);
      s.image.at(i)[2] = static_cast<float>(e.z);
    }
    snapshot(s);
    if (cpu > max_cpu_seconds) break;
  }
}

Image albedo_buffer(const Scene &scene, const std::vector<Primary> &primary, const View &view) {
  Image out(view.width, view.height);
  for (size_t i = 0; i < primary.size(); ++i) {
    if (!primary[i].hit) continue;
    const V3 kd = scene.material(primary[i].triangle).kd;
    out.at(i)[0] = static_cast<float>(kd.x);
    out.at(i)[1] = static_cast<float>(kd.y);
    out.at(i)[2] = static_cast<float>(kd.z);
  }
  return out;
}

Image normal_buffer(const std::vector<Primary> &primary, const View &view) {
  Image out(view.width, view.height);
  for (size_t i = 0; i < primary.size(); ++i) {
    if (!primary[i].hit) continue;
    out.at(i)[0] = static_cast<float>(primary[i].n.x);
    out.at(i)[1] = static_cast<float>(primary[i].n.y);
    out.at(i)[2] = static_cast<float>(primary[i].n.z);
  }
  return out;
}

}  // namespace rd
