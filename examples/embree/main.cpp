// raddiff + Embree 3: irradiance caching in a C++17 renderer.
//
// Loads an OBJ scene (with its MTL: Kd diffuse reflectance, Ke emitted radiance), traces the gather
// directions raddiff gives it with Embree, turns what the rays found into records with raddiff
// (irradiance, gradients, radius), fills one raddiff_cache from many threads, renders the indirect
// irradiance from the cache, saves the cache, reloads it and renders a second pass from the file.
// Safeguards: the cache's gradient limit (always), neighbour clamping (--neighbour-clamp); --records N
// tunes the metric's parameter to about N records, for comparisons at equal record counts.
//
// Only two headers matter: <embree3/rtcore.h> and "raddiff.h". See the README section
// "C++ integration (Embree)" for the walk-through.

#include <embree3/rtcore.h>

#include "raddiff.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------------------------
// Small vector type (double precision, like raddiff).
struct V3 {
  double x = 0, y = 0, z = 0;
};
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator*(V3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
V3 operator*(V3 a, V3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
V3 normalize(V3 a) { return a * (1.0 / std::sqrt(dot(a, a))); }
raddiff_vec3 to_c(V3 a) { return {a.x, a.y, a.z}; }
double luminance(const float *rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

// A tangent perpendicular to a unit normal (Duff et al. 2017).
V3 tangent_of(V3 n) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double b = n.x * n.y * a;
  return {1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x};
}

// Throws with raddiff's message when a call fails.
void check(raddiff_status status, const char *what) {
  if (status != RADDIFF_OK) {
    throw std::runtime_error(std::string(what) + ": " + raddiff_last_error());
  }
}

// splitmix64, for the per-record layout seeds and light sample jitter.
uint64_t mix(uint64_t z) {
  z += 0x9E3779B97F4A7C15ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
double unit(uint64_t z) { return static_cast<double>(mix(z) >> 11) * (1.0 / 9007199254740992.0); }

// ---------------------------------------------------------------------------------------------
// OBJ + MTL loading (positions, polygon faces fanned into triangles, usemtl, Kd, Ke).
struct Material {
  V3 kd, ke;
};
struct Mesh {
  std::vector<float> positions;  // 3 per vertex
  std::vector<uint32_t> indices;  // 3 per triangle
  std::vector<uint32_t> material;  // per triangle
  std::vector<Material> materials;
};

std::map<std::string, Material> load_mtl(const std::string &path) {
  std::map<std::string, Material> out;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string line, current;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "newmtl") {
      s >> current;
      out[current] = Material{};
    } else if (tag == "Kd" && !current.empty()) {
      s >> out[current].kd.x >> out[current].kd.y >> out[current].kd.z;
    } else if (tag == "Ke" && !current.empty()) {
      s >> out[current].ke.x >> out[current].ke.y >> out[current].ke.z;
    }
  }
  return out;
}

Mesh load_obj(const std::string &path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  const std::string dir = path.find('/') == std::string::npos ? "" : path.substr(0, path.rfind('/') + 1);
  Mesh mesh;
  std::map<std::string, Material> library;
  std::map<std::string, uint32_t> slot;
  uint32_t current = 0;
  mesh.materials.push_back(Material{{0.5, 0.5, 0.5}, {0, 0, 0}});  // default grey
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      float x, y, z;
      s >> x >> y >> z;
      mesh.positions.insert(mesh.positions.end(), {x, y, z});
    } else if (tag == "f") {
      std::vector<uint32_t> face;
      std::string vert;
      while (s >> vert) {
        long i = std::stol(vert);  // "i", "i/t", "i/t/n", "i//n": the position index comes first
        const long count = static_cast<long>(mesh.positions.size() / 3);
        if (i < 0) i += count + 1;
        if (i < 1 || i > count) throw std::runtime_error("bad vertex index in " + line);
        face.push_back(static_cast<uint32_t>(i - 1));
      }
      for (size_t k = 1; k + 1 < face.size(); ++k) {
        mesh.indices.insert(mesh.indices.end(), {face[0], face[k], face[k + 1]});
        mesh.material.push_back(current);
      }
    } else if (tag == "mtllib") {
      std::string file;
      s >> file;
      library = load_mtl(dir + file);
    } else if (tag == "usemtl") {
      std::string name;
      s >> name;
      auto found = slot.find(name);
      if (found == slot.end()) {
        const auto m = library.find(name);
        mesh.materials.push_back(m == library.end() ? mesh.materials[0] : m->second);
        found = slot.emplace(name, static_cast<uint32_t>(mesh.materials.size() - 1)).first;
      }
      current = found->second;
    }
  }
  if (mesh.indices.empty()) throw std::runtime_error(path + " has no faces");
  return mesh;
}

// ---------------------------------------------------------------------------------------------
// Embree scene and the renderer's shading: one-bounce indirect light from emissive triangles.
struct Scene {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  Mesh mesh;
  std::vector<uint32_t> emitters;  // triangle indices with Ke > 0
  double epsilon = 1e-4;

  V3 vertex(uint32_t i) const {
    return {mesh.positions[3 * i], mesh.positions[3 * i + 1], mesh.positions[3 * i + 2]};
  }
  V3 corner(uint32_t tri, int k) const { return vertex(mesh.indices[3 * tri + k]); }
  const Material &material(uint32_t tri) const { return mesh.materials[mesh.material[tri]]; }

  explicit Scene(const std::string &obj) : mesh(load_obj(obj)) {
    device = rtcNewDevice(nullptr);
    if (!device) throw std::runtime_error("rtcNewDevice failed");
    scene = rtcNewScene(device);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    const size_t nv = mesh.positions.size() / 3, nt = mesh.indices.size() / 3;
    auto *vb = static_cast<float *>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
    auto *ib = static_cast<uint32_t *>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), nt));
    std::copy(mesh.positions.begin(), mesh.positions.end(), vb);
    std::copy(mesh.indices.begin(), mesh.indices.end(), ib);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene);
    V3 lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
    for (size_t i = 0; i < nv; ++i) {
      const V3 p = vertex(static_cast<uint32_t>(i));
      lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
      hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
    }
    epsilon = 1e-6 * std::sqrt(dot(hi - lo, hi - lo));  // ray tnear; hit points are pulled back by 1e-4
    for (uint32_t t = 0; t < nt; ++t) {
      const V3 ke = material(t).ke;
      if (ke.x + ke.y + ke.z > 0) emitters.push_back(t);
    }
  }
  ~Scene() {
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }
  Scene(const Scene &) = delete;
  Scene &operator=(const Scene &) = delete;

  struct Hit {
    double distance = INFINITY;
    uint32_t triangle = 0;
    V3 normal;  // unit geometric normal, facing the ray origin
  };

  Hit intersect(V3 o, V3 d) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rh{};
    rh.ray.org_x = static_cast<float>(o.x);
    rh.ray.org_y = static_cast<float>(o.y);
    rh.ray.org_z = static_cast<float>(o.z);
    rh.ray.dir_x = static_cast<float>(d.x);
    rh.ray.dir_y = static_cast<float>(d.y);
    rh.ray.dir_z = static_cast<float>(d.z);
    rh.ray.tnear = static_cast<float>(epsilon);
    rh.ray.tfar = INFINITY;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene, &context, &rh);
    Hit hit;
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
    hit.distance = rh.ray.tfar;
    hit.triangle = rh.hit.primID;
    hit.normal = normalize(V3{rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z});
    if (dot(hit.normal, d) > 0) hit.normal = hit.normal * -1.0;
    return hit;
  }

  bool occluded(V3 o, V3 d, double tfar) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay r{};
    r.org_x = static_cast<float>(o.x);
    r.org_y = static_cast<float>(o.y);
    r.org_z = static_cast<float>(o.z);
    r.dir_x = static_cast<float>(d.x);
    r.dir_y = static_cast<float>(d.y);
    r.dir_z = static_cast<float>(d.z);
    r.tnear = static_cast<float>(epsilon);
    r.tfar = static_cast<float>(tfar);
    r.mask = 0xFFFFFFFFu;
    rtcOccluded1(scene, &context, &r);
    return r.tfar < 0;
  }

  // Direct irradiance (RGB) at p with normal n from the emissive triangles, `samples` jittered
  // samples per emitter (jitter from `seed`).
  V3 direct(V3 p, V3 n, int samples, uint64_t seed) const {
    V3 sum;
    for (uint32_t e : emitters) {
      const V3 a = corner(e, 0), b = corner(e, 1), c = corner(e, 2);
      const V3 ng = cross(b - a, c - a);
      const double area = 0.5 * std::sqrt(dot(ng, ng));
      const V3 ln = normalize(ng);
      for (int s = 0; s < samples; ++s) {
        double u = unit(seed ^ mix(2 * s + 1)), v = unit(seed ^ mix(2 * s + 2));
        if (u + v > 1) u = 1 - u, v = 1 - v;
        const V3 q = a + (b - a) * u + (c - a) * v;
        const V3 d = q - p;
        const double r2 = dot(d, d), r = std::sqrt(r2);
        const V3 w = d * (1.0 / r);
        const double cos_r = dot(n, w), cos_l = -dot(ln, w);
        if (cos_r <= 0 || cos_l <= 0 || occluded(p, w, r * (1 - 1e-4))) continue;
        sum = sum + material(e).ke * (cos_r * cos_l / r2 * area / samples);
      }
    }
    return sum;
  }
};

// ---------------------------------------------------------------------------------------------
// One irradiance-cache record from a gather traced with Embree.
struct Settings {
  std::string obj = "cornell.obj";
  std::string out = "embree-out";
  int width = 256, height = 256;
  uint32_t gather_m = 16, gather_n = 48;
  double accuracy = 0.25;      // split-sphere a
  double hessian_error = 0.0;  // > 0: occlusion-aware Hessian radii with this relative error
  unsigned threads = 0;
  V3 eye{0.5, 0.5, 2.35}, target{0.5, 0.5, 0.0};
  double fov = 38.0;
  double min_radius = 0.005, max_radius = 0.25;
  int check_pixels = 96;
  double gradient_limit = RADDIFF_GRADIENT_LIMIT_DEFAULT;  // slope limit c (INFINITY: off)
  bool neighbour_clamp = false;  // clamp records to their neighbours (one-sided at insert, two-sided passes)
  size_t target_records = 0;     // > 0: tune the metric's parameter to about this many records
};

struct Stats {
  std::atomic<uint64_t> rays{0}, records{0};
};

// Traces the gather of a record at (p, n), evaluates it with raddiff and builds the record.
// Returns false when raddiff finds it degenerate (e.g. every ray missed): no record then.
bool make_record(const Scene &scene, const Settings &cfg, V3 p, V3 n, uint64_t seed, Stats &stats,
                 std::array<float, 3> &value, std::array<float, 9> &gradient,
                 std::array<float, 9> &rotation, raddiff_cache_record &record, uint32_t m, uint32_t nn) {
  const raddiff_gather_layout layout{RADDIFF_LAYOUT_COSINE_POLAR, m, nn, seed};
  const raddiff_frame frame{to_c(p), to_c(n), to_c(tangent_of(n))};
  const size_t count = static_cast<size_t>(m) * nn;
  std::vector<raddiff_vec3> dirs(count);
  check(raddiff_gather_directions(&layout, &frame, dirs.data()), "raddiff_gather_directions");

  // Trace: hit distance and the radiance leaving each hit towards p (one bounce of direct light).
  std::vector<double> distance(count);
  std::vector<float> radiance(3 * count);
  for (size_t i = 0; i < count; ++i) {
    const V3 d{dirs[i].x, dirs[i].y, dirs[i].z};
    const Scene::Hit hit = scene.intersect(p, d);
    distance[i] = hit.distance;
    V3 l;
    if (std::isfinite(hit.distance)) {
      const V3 y = p + d * (hit.distance * (1 - 1e-4));
      const V3 kd = scene.material(hit.triangle).kd;
      if (kd.x + kd.y + kd.z > 0) l = kd * (1.0 / kPi) * scene.direct(y, hit.normal, 1, mix(seed + i));
    }
    radiance[3 * i] = static_cast<float>(l.x);
    radiance[3 * i + 1] = static_cast<float>(l.y);
    radiance[3 * i + 2] = static_cast<float>(l.z);
  }
  stats.rays += count * (1 + scene.emitters.size());

  raddiff_gather_input input{};
  input.directions = dirs.data();
  input.distance = distance.data();
  input.radiance = radiance.data();
  input.channels = 3;
  double irradiance[3], grad[9], rot[9], hessian[27];
  raddiff_gather_output output{};
  output.irradiance = irradiance;
  output.gradient = grad;
  output.rotation_gradient = rot;
  output.hessian = cfg.hessian_error > 0 ? hessian : nullptr;  // NULL: not computed
  const raddiff_status st = raddiff_gather_evaluate(&layout, &frame, &input, &output);
  if (st == RADDIFF_ERROR_DEGENERATE) return false;
  check(st, "raddiff_gather_evaluate");

  for (int c = 0; c < 3; ++c) value[c] = static_cast<float>(irradiance[c]);
  for (int k = 0; k < 9; ++k) {
    gradient[k] = static_cast<float>(grad[k]);
    rotation[k] = static_cast<float>(rot[k]);
  }
  record = raddiff_cache_record{};
  record.position = to_c(p);
  record.normal = to_c(n);
  record.value = value.data();
  record.gradient = gradient.data();
  record.rotation_gradient = rotation.data();
  if (cfg.hessian_error > 0) {
    // Luminance Hessian -> anisotropic ellipse bounding the relative interpolation error.
    double h[9];
    for (int k = 0; k < 9; ++k) h[k] = 0.2126 * hessian[k] + 0.7152 * hessian[9 + k] + 0.0722 * hessian[18 + k];
    // The curvature floor kappa |E| / D^2 (D: harmonic-mean hit distance) keeps a record whose
    // estimated Hessian (nearly) vanishes from growing to the largest radius.
    double radii[2];
    raddiff_vec3 axes[2];
    const double d = output.harmonic_mean_distance;
    if (std::isfinite(d) && d > 0) {
      check(raddiff_surface_radii_floored(h, to_c(n), luminance(value.data()), cfg.hessian_error,
                                          RADDIFF_ERROR_RELATIVE, 2.0, d, RADDIFF_CURVATURE_FLOOR_WEIGHT, radii,
                                          axes),
            "raddiff_surface_radii_floored");
    } else {  // every ray missed: no distance for the floor
      check(raddiff_surface_radii(h, to_c(n), luminance(value.data()), cfg.hessian_error, RADDIFF_ERROR_RELATIVE,
                                  2.0, radii, axes),
            "raddiff_surface_radii");
    }
    for (int k = 0; k < 2; ++k) {
      record.radii[k] = std::clamp(radii[k], cfg.min_radius, cfg.max_radius);
      record.axes[k] = axes[k];
    }
    record.radii[2] = std::min(record.radii[0], record.radii[1]);
  } else {
    // Ward's split sphere: a times the harmonic mean distance, clamped.
    const double r = std::clamp(cfg.accuracy * output.harmonic_mean_distance, cfg.min_radius, cfg.max_radius);
    record.radii[0] = record.radii[1] = record.radii[2] = r;
  }
  stats.records += 1;
  return true;
}

// ---------------------------------------------------------------------------------------------
// Images: a minimal PNG writer (stored deflate blocks, no dependency) and a PFM writer.
uint32_t crc32(const uint8_t *data, size_t n, uint32_t crc = 0xFFFFFFFFu) {
  for (size_t i = 0; i < n; ++i) {
    crc ^= data[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc;
}

void write_png(const std::string &path, int w, int h, const std::vector<uint8_t> &rgb) {
  std::vector<uint8_t> raw;
  for (int y = 0; y < h; ++y) {
    raw.push_back(0);
    raw.insert(raw.end(), rgb.begin() + 3 * w * y, rgb.begin() + 3 * w * (y + 1));
  }
  std::vector<uint8_t> z{0x78, 0x01};
  uint32_t a = 1, b = 0;
  for (uint8_t c : raw) a = (a + c) % 65521, b = (b + a) % 65521;
  for (size_t pos = 0; pos < raw.size() || pos == 0; pos += 65535) {
    const size_t len = std::min<size_t>(65535, raw.size() - pos);
    const bool last = pos + len >= raw.size();
    z.push_back(last ? 1 : 0);
    z.push_back(len & 0xFF), z.push_back(len >> 8), z.push_back(~len & 0xFF), z.push_back((~len >> 8) & 0xFF);
    z.insert(z.end(), raw.begin() + pos, raw.begin() + pos + len);
    if (last) break;
  }
  const uint32_t adler = (b << 16) | a;
  for (int s = 24; s >= 0; s -= 8) z.push_back((adler >> s) & 0xFF);
  std::ofstream f(path, std::ios::binary);
  auto be32 = [&](uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) f.put(static_cast<char>((v >> s) & 0xFF));
  };
  auto chunk = [&](const char *type, const std::vector<uint8_t> &data) {
    be32(static_cast<uint32_t>(data.size()));
    std::vector<uint8_t> td(type, type + 4);
    td.insert(td.end(), data.begin(), data.end());
    f.write(reinterpret_cast<const char *>(td.data()), static_cast<std::streamsize>(td.size()));
    be32(crc32(td.data(), td.size()) ^ 0xFFFFFFFFu);
  };
  const uint8_t sig[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  f.write(reinterpret_cast<const char *>(sig), 8);
  std::vector<uint8_t> ihdr;
  for (uint32_t v : {static_cast<uint32_t>(w), static_cast<uint32_t>(h)})
    for (int s = 24; s >= 0; s -= 8) ihdr.push_back((v >> s) & 0xFF);
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});
  chunk("IHDR", ihdr);
  chunk("IDAT", z);
  chunk("IEND", {});
  if (!f) throw std::runtime_error("cannot write " + path);
}

void write_images(const std::string &prefix, int w, int h, const std::vector<float> &rgb) {
  std::vector<float> lum;
  for (size_t i = 0; i < rgb.size(); i += 3) lum.push_back(static_cast<float>(luminance(&rgb[i])));
  std::sort(lum.begin(), lum.end());
  const double exposure = 0.9 / std::max(1e-12, static_cast<double>(lum[lum.size() * 99 / 100]));
  std::vector<uint8_t> png(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) {
    const double v = std::clamp(rgb[i] * exposure, 0.0, 1.0);
    png[i] = static_cast<uint8_t>(255.0 * (v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055) + 0.5);
  }
  write_png(prefix + ".png", w, h, png);
  std::ofstream f(prefix + ".pfm", std::ios::binary);
  f << "PF\n" << w << " " << h << "\n-1\n";
  for (int y = h - 1; y >= 0; --y)
    f.write(reinterpret_cast<const char *>(&rgb[3 * static_cast<size_t>(w) * y]),
            static_cast<std::streamsize>(3 * w * sizeof(float)));
}

// Runs body(i) for i in [0, count) on `threads` threads (dynamic scheduling).
void parallel_for(size_t count, unsigned threads, const std::function<void(size_t)> &body) {
  std::atomic<size_t> next{0};
  std::vector<std::thread> pool;
  std::exception_ptr error;
  std::atomic<bool> failed{false};
  for (unsigned t = 0; t < threads; ++t) {
    pool.emplace_back([&] {
      try {
        while (!failed) {
          const size_t i = next++;
          if (i >= count) break;
          body(i);
        }
      } catch (...) {
        if (!failed.exchange(true)) error = std::current_exception();
      }
    });
  }
  for (auto &th : pool) th.join();
  if (error) std::rethrow_exception(error);
}

struct Primary {
  bool hit = false;
  V3 p, n;
};

// Pixel indices of one coarse-to-fine level: the grid of step `step` without the coarser grid's
// pixels (the coarsest level, 16, takes its whole grid).
std::vector<size_t> level_pixels(int w, int h, int step) {
  std::vector<size_t> level;
  for (int y = 0; y < h; y += step)
    for (int x = 0; x < w; x += step)
      if (step == 16 || x % (2 * step) != 0 || y % (2 * step) != 0) level.push_back(static_cast<size_t>(y) * w + x);
  return level;
}

// A filled cache (owned by the caller) and what the fill cost.
struct Fill {
  raddiff_cache *cache = nullptr;
  size_t records = 0;
  uint64_t rays = 0;
  double seconds = 0;
  size_t shrunk = 0;      // records shrunk by the two-sided neighbour passes
  int finest_rounds = 0;  // visits of the finest level (1 without neighbour clamping)
};

// Repeated visits of every pixel after the finest level when neighbour clamping: this many end with
// the two-sided pass (the first is the finest level itself), then one only fills.
constexpr int kClampRounds = 3;

// Fills a fresh cache coarse to fine (pixel steps 16, 8, ..., 1); all threads look up and insert
// concurrently. With `neighbour_clamp`, each record is clamped to the stored records before its
// insert (raddiff_cache_clamp_record, thread-safe) and the two-sided pass
// (raddiff_cache_clamp_neighbours, single-threaded) runs after each level; the pass can uncover
// pixels, so the finest level is repeated over all pixels until a round inserts nothing, the last
// allowed round filling only (so no pixel is left uncovered).
Fill fill_cache(const Scene &scene, const Settings &cfg, const std::vector<Primary> &primary, unsigned threads) {
  using clock = std::chrono::steady_clock;
  // Irradiance is never negative: RADDIFF_INTERP_NON_NEGATIVE clamps each record's first-order
  // extrapolation at 0 (steep gradients in dark corners would otherwise dip below it).
  const uint32_t weights = cfg.hessian_error > 0 ? RADDIFF_INTERP_TENT : RADDIFF_INTERP_WARD;
  const raddiff_cache_config config{3, RADDIFF_DOMAIN_SURFACE, weights | RADDIFF_INTERP_NON_NEGATIVE, 0.2};
  Fill out;
  out.cache = raddiff_cache_new(&config);
  if (!out.cache) throw std::runtime_error(std::string("raddiff_cache_new: ") + raddiff_last_error());
  raddiff_cache *cache = out.cache;
  try {
    // Slope limiter at insert: over its extent a record extrapolates each channel by at most
    // c times its value (c = 1 here, as in the Rust demo: no value changes sign).
    check(raddiff_cache_set_gradient_limit(cache, cfg.gradient_limit), "raddiff_cache_set_gradient_limit");
    Stats stats;
    std::atomic<size_t> inserted{0};
    auto ensure_covered = [&](size_t i) {
      const Primary &px = primary[i];
      if (!px.hit) return;
      float v[3];
      const raddiff_status st = raddiff_cache_lookup(cache, to_c(px.p), to_c(px.n), v, nullptr);
      if (st == RADDIFF_OK) return;
      if (st != RADDIFF_ERROR_NOT_FOUND) check(st, "raddiff_cache_lookup");
      std::array<float, 3> value;
      std::array<float, 9> gradient, rotation;
      raddiff_cache_record record;
      if (!make_record(scene, cfg, px.p, px.n, 1 + i, stats, value, gradient, rotation, record, cfg.gather_m,
                       cfg.gather_n))
        return;
      if (cfg.neighbour_clamp) check(raddiff_cache_clamp_record(cache, &record), "raddiff_cache_clamp_record");
      check(raddiff_cache_insert(cache, &record), "raddiff_cache_insert");
      ++inserted;
    };
    const int w = cfg.width, h = cfg.height;
    std::vector<size_t> all(primary.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = i;
    const auto t0 = clock::now();
    int step = 16;
    for (;;) {
      const std::vector<size_t> level = out.finest_rounds == 0 ? level_pixels(w, h, step) : all;
      inserted = 0;
      parallel_for(level.size(), threads, [&](size_t k) { ensure_covered(level[k]); });
      const bool last_round = step == 1 && out.finest_rounds == kClampRounds;
      if (cfg.neighbour_clamp && !last_round) {
        size_t shrunk = 0;
        check(raddiff_cache_clamp_neighbours(cache, &shrunk), "raddiff_cache_clamp_neighbours");
        out.shrunk += shrunk;
      }
      if (step > 1) {
        step /= 2;
        continue;
      }
      ++out.finest_rounds;
      // Without clamping every pixel of the finest level is covered now; with it, a round that
      // inserted nothing found every pixel covered (and its pass had nothing new to shrink).
      if (!cfg.neighbour_clamp || inserted == 0 || last_round) break;
    }
    out.seconds = std::chrono::duration<double>(clock::now() - t0).count();
    out.records = raddiff_cache_len(cache);
    out.rays = stats.rays.load();
  } catch (...) {
    raddiff_cache_free(cache);
    throw;
  }
  return out;
}

// The parameter --records tunes: the Hessian's relative error, or the split sphere's accuracy a.
double &tuned_parameter(Settings &cfg) { return cfg.hessian_error > 0 ? cfg.hessian_error : cfg.accuracy; }

// Fills fresh caches, tuning the metric's parameter p until the record count is within 5% of
// `cfg.target_records` (at most 10 fills). Until the target is bracketed, p jumps along the power
// law records ~ p^-k (k from the last two fills, at first 2 for the split sphere's radius a*D and
// 1/2 for the Hessian's error-to-the-1/4 radii); then it bisects the bracket in log space. Keeps the
// fill closest to the target (the others are freed) and writes its parameter into `cfg`.
Fill tune(const Scene &scene, Settings &cfg, const std::vector<Primary> &primary, unsigned threads) {
  const double target = static_cast<double>(cfg.target_records);
  const char *name = cfg.hessian_error > 0 ? "hessian e" : "accuracy a";
  double p = tuned_parameter(cfg);
  double k = cfg.hessian_error > 0 ? 0.5 : 2.0;
  double too_many = 0, too_few = 0;  // parameters known to give more / fewer records than wanted
  double last_p = 0, last_n = 0;
  Fill best;
  double best_p = p, best_miss = INFINITY, seconds = 0;
  int fills = 0;
  for (; fills < 10; ++fills) {
    Settings trial = cfg;
    tuned_parameter(trial) = p;
    Fill f = fill_cache(scene, trial, primary, threads);
    seconds += f.seconds;
    const double n = static_cast<double>(f.records);
    const double miss = std::abs(std::log(std::max(n, 1.0) / target));
    std::printf("tune %d: %s = %.5g -> %zu records (fill %.2f s)\n", fills + 1, name, p, f.records, f.seconds);
    if (miss < best_miss) {
      raddiff_cache_free(best.cache);
      best = f, best_p = p, best_miss = miss;
    } else {
      raddiff_cache_free(f.cache);
    }
    if (std::abs(n / target - 1) <= 0.05) {
      ++fills;
      break;
    }
    if (n > target) too_many = std::max(too_many, p);
    else too_few = too_few > 0 ? std::min(too_few, p) : p;
    if (last_p > 0 && last_p != p && last_n > 0 && n > 0 && last_n != n) {
      k = std::clamp(std::log(last_n / n) / std::log(p / last_p), 0.1, 10.0);  // measured slope
    }
    last_p = p, last_n = n;
    if (too_many > 0 && too_few > 0) {
      p = std::sqrt(too_many * too_few);  // bisection in log space
    } else {
      p *= std::pow(std::max(n, 1.0) / target, 1.0 / k);  // power-law jump towards the target
    }
  }
  tuned_parameter(cfg) = best_p;
  const bool hit = std::abs(static_cast<double>(best.records) / target - 1) <= 0.05;
  std::printf("tuned: %s = %.5g, %zu records for %zu wanted (%s), %d fills, %.2f s\n", name, best_p, best.records,
              cfg.target_records, hit ? "within 5%" : "NOT within 5%", fills, seconds);
  return best;
}

int run(const Settings &cfg) {
  using clock = std::chrono::steady_clock;
  const unsigned threads = cfg.threads ? cfg.threads : std::max(1u, std::thread::hardware_concurrency());
  std::printf("raddiff %s, Embree %d.%d.%d, %u threads\n", raddiff_version(), RTC_VERSION_MAJOR,
              RTC_VERSION_MINOR, RTC_VERSION_PATCH, threads);
  Scene scene(cfg.obj);
  std::printf("scene %s: %zu triangles, %zu emitters\n", cfg.obj.c_str(), scene.mesh.indices.size() / 3,
              scene.emitters.size());
  if (scene.emitters.empty()) throw std::runtime_error("the scene has no emitter (Ke > 0)");

  // Primary hits.
  const int w = cfg.width, h = cfg.height;
  std::vector<Primary> primary(static_cast<size_t>(w) * h);
  const V3 fwd = normalize(cfg.target - cfg.eye), right = normalize(cross(fwd, {0, 1, 0})), up = cross(right, fwd);
  const double tan_half = std::tan(cfg.fov * kPi / 360.0), aspect = static_cast<double>(w) / h;
  parallel_for(primary.size(), threads, [&](size_t i) {
    const double px = (2.0 * (i % w + 0.5) / w - 1.0) * tan_half * aspect;
    const double py = (1.0 - 2.0 * (i / w + 0.5) / h) * tan_half;
    const V3 d = normalize(fwd + right * px + up * py);
    const Scene::Hit hit = scene.intersect(cfg.eye, d);
    // Pull the point back along the ray (relative 1e-4): a hit exactly on a seam (wall on floor)
    // would otherwise send gather rays through the neighbouring surface (light leaking into corners).
    if (std::isfinite(hit.distance)) primary[i] = {true, cfg.eye + d * (hit.distance * (1 - 1e-4)), hit.normal};
  });

  // Pass 1: fill the cache (tuned to a record count if asked).
  Settings used = cfg;
  const Fill filled = cfg.target_records > 0 ? tune(scene, used, primary, threads)
                                             : fill_cache(scene, used, primary, threads);
  raddiff_cache *cache = filled.cache;
  const double fill_seconds = filled.seconds;
  std::printf("placement: %s = %.5g, gradient limit %g, neighbour clamp %s\n",
              used.hessian_error > 0 ? "hessian e" : "split sphere a", tuned_parameter(used), used.gradient_limit,
              used.neighbour_clamp ? "on" : "off");
  if (cfg.neighbour_clamp)
    std::printf("neighbour clamp: %zu records shrunk by the two-sided passes, %d finest-level rounds\n",
                filled.shrunk, filled.finest_rounds);

  // Render from the cache: through a per-thread cursor (successive pixels of a thread are close,
  // so the cursor's remembered records serve most lookups), or with plain lookups (for which the
  // library keeps a cursor per thread). Both give the same bits; pass 2 below uses the other one,
  // so its "identical" check covers that too.
  struct Cursor {
    raddiff_cache_cursor *p = raddiff_cache_cursor_new();
    ~Cursor() { raddiff_cache_cursor_free(p); }
  };
  auto render = [&](const raddiff_cache *c, bool use_cursor, size_t &misses) {
    std::vector<float> image(3 * primary.size(), 0.0f);
    std::atomic<size_t> miss{0};
    parallel_for(primary.size(), threads, [&](size_t i) {
      if (!primary[i].hit) return;
      thread_local Cursor cursor;  // parallel_for's threads end with the pass, and so do their cursors
      const raddiff_status st =
          use_cursor ? raddiff_cache_lookup_with(c, cursor.p, to_c(primary[i].p), to_c(primary[i].n), &image[3 * i], nullptr)
                     : raddiff_cache_lookup(c, to_c(primary[i].p), to_c(primary[i].n), &image[3 * i], nullptr);
      if (st == RADDIFF_ERROR_NOT_FOUND) {
        ++miss;
      } else {
        check(st, "raddiff_cache_lookup");
      }
    });
    misses = miss;
    return image;
  };
  size_t misses1 = 0;
  // The fill is over: compact the cache for the lookup-only phase (no other thread uses it now).
  check(raddiff_cache_compact(cache), "raddiff_cache_compact");
  const auto t1 = clock::now();
  const std::vector<float> first = render(cache, true, misses1);
  const double render_seconds = std::chrono::duration<double>(clock::now() - t1).count();
  const size_t records = raddiff_cache_len(cache);
  std::printf("pass 1: %zu records, %.2f Mrays, fill %.2f s, render %.3f s, %zu uncovered pixels\n", records,
              filled.rays * 1e-6, fill_seconds, render_seconds, misses1);
  write_images(cfg.out + "-irradiance", w, h, first);

  // Save, reload, render again from the file (the overture/reuse workflow).
  const std::string file = cfg.out + ".rdc";
  check(raddiff_cache_save(cache, file.c_str()), "raddiff_cache_save");
  raddiff_cache_free(cache);
  raddiff_cache *loaded = raddiff_cache_load(file.c_str());
  if (!loaded) throw std::runtime_error(std::string("raddiff_cache_load: ") + raddiff_last_error());
  size_t misses2 = 0;
  const std::vector<float> second = render(loaded, false, misses2);
  const bool same = raddiff_cache_len(loaded) == records && misses2 == misses1 &&
                    std::memcmp(first.data(), second.data(), first.size() * sizeof(float)) == 0;
  std::printf("pass 2 (reloaded %s, plain lookups): %zu records, images %s\n", file.c_str(),
              raddiff_cache_len(loaded), same ? "identical" : "DIFFER");

  // Accuracy: the cache against fresh high-resolution gathers at some pixels.
  double err2 = 0, ref2 = 0;
  int checked = 0;
  Stats scratch;
  for (int k = 0; k < cfg.check_pixels; ++k) {
    const size_t i = mix(0xC0FFEE + k) % primary.size();
    if (!primary[i].hit) continue;
    std::array<float, 3> value;
    std::array<float, 9> g, r;
    raddiff_cache_record rec;
    Settings fine = cfg;
    fine.hessian_error = 0;
    if (!make_record(scene, fine, primary[i].p, primary[i].n, 7 + i, scratch, value, g, r, rec, 4 * cfg.gather_m,
                     4 * cfg.gather_n))
      continue;
    const double e = luminance(&second[3 * i]) - luminance(value.data());
    err2 += e * e;
    ref2 += luminance(value.data()) * luminance(value.data());
    ++checked;
  }
  const double rel_rms = checked ? std::sqrt(err2 / std::max(ref2, 1e-300)) : 0.0;
  std::printf("check: relative RMS error of the cache against %d fresh %ux%u gathers: %.4f\n", checked,
              4 * cfg.gather_m, 4 * cfg.gather_n, rel_rms);
  raddiff_cache_free(loaded);

  // Self-checks: the reloaded cache renders the same image, every pixel was covered, the values are
  // finite and non-negative (the cache clamps extrapolation) and the cache agrees with fresh gathers.
  size_t non_finite = 0, negative = 0;
  for (float v : first) {
    non_finite += !std::isfinite(v);
    negative += v < 0;
  }
  std::printf("values: %zu non-finite, %zu negative of %zu\n", non_finite, negative, first.size());
  const bool ok = same && misses1 == 0 && records > 0 && checked > 0 && rel_rms < 0.1 && non_finite == 0 &&
                  negative == 0;
  std::printf("%s\n", ok ? "OK" : "FAILED");
  return ok ? 0 : 1;
}

V3 parse_v3(const std::string &s) {
  V3 v;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf", &v.x, &v.y, &v.z) != 3) throw std::runtime_error("expected x,y,z: " + s);
  return v;
}

}  // namespace

int main(int argc, char **argv) {
  Settings cfg;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
        return argv[++i];
      };
      if (a == "--obj") cfg.obj = next();
      else if (a == "--out") cfg.out = next();
      else if (a == "--size") cfg.width = cfg.height = std::stoi(next());
      else if (a == "--gather") {
        const std::string g = next();
        if (std::sscanf(g.c_str(), "%ux%u", &cfg.gather_m, &cfg.gather_n) != 2) throw std::runtime_error("--gather MxN");
      } else if (a == "--accuracy") cfg.accuracy = std::stod(next());
      else if (a == "--hessian") cfg.hessian_error = std::stod(next());
      else if (a == "--threads") cfg.threads = static_cast<unsigned>(std::stoul(next()));
      else if (a == "--eye") cfg.eye = parse_v3(next());
      else if (a == "--target") cfg.target = parse_v3(next());
      else if (a == "--fov") cfg.fov = std::stod(next());
      else if (a == "--radius") {
        const std::string r = next();
        if (std::sscanf(r.c_str(), "%lf,%lf", &cfg.min_radius, &cfg.max_radius) != 2) throw std::runtime_error("--radius min,max");
      } else if (a == "--records") {
        const long n = std::stol(next());
        if (n < 1) throw std::runtime_error("--records N needs N >= 1");
        cfg.target_records = static_cast<size_t>(n);
      } else if (a == "--neighbour-clamp") cfg.neighbour_clamp = true;
      else if (a == "--gradient-limit") cfg.gradient_limit = std::stod(next());
      else if (a == "--check") cfg.check_pixels = std::stoi(next());
      else {
        std::printf(
            "usage: raddiff_embree [--obj scene.obj] [--out prefix] [--size N] [--gather MxN]\n"
            "                      [--accuracy a | --hessian relative_error] [--records N] [--threads N]\n"
            "                      [--neighbour-clamp] [--gradient-limit c (default 0.5, inf: off)]\n"
            "                      [--check pixels (default 96)]\n"
            "                      [--eye x,y,z] [--target x,y,z] [--fov degrees] [--radius min,max]\n");
        return a == "--help" || a == "-h" ? 0 : 2;
      }
    }
    if (cfg.width < 1 || cfg.height < 1 || cfg.gather_m < 1 || cfg.gather_n < 1)
      throw std::runtime_error("sizes must be positive");
    return run(cfg);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
