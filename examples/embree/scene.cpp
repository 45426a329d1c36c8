#include "scene.hpp"

#include <fstream>
#include <map>
#include <sstream>

namespace rd {
namespace {

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

}  // namespace

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
  std::vector<uint32_t> face;
  mesh.files.push_back(path);
  while (std::getline(in, line)) {
    std::istringstream s(line);
    std::string tag;
    s >> tag;
    if (tag == "v") {
      float x, y, z;
      s >> x >> y >> z;
      mesh.positions.insert(mesh.positions.end(), {x, y, z});
    } else if (tag == "f") {
      face.clear();
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
      mesh.files.push_back(dir + file);
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

Scene::Scene(const std::string &obj) : mesh_(load_obj(obj)) {
  device_ = rtcNewDevice(nullptr);
  if (!device_) throw std::runtime_error("rtcNewDevice failed");
  scene_ = rtcNewScene(device_);
  rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
  RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
  const size_t nv = mesh_.positions.size() / 3, nt = mesh_.indices.size() / 3;
  auto *vb = static_cast<float *>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), nv));
  auto *ib = static_cast<uint32_t *>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(uint32_t), nt));
  std::copy(mesh_.positions.begin(), mesh_.positions.end(), vb);
  std::copy(mesh_.indices.begin(), mesh_.indices.end(), ib);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene_, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene_);

  V3 lo{1e30, 1e30, 1e30}, hi{-1e30, -1e30, -1e30};
  for (size_t i = 0; i < nv; ++i) {
    const V3 p = vertex(static_cast<uint32_t>(i));
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  size_ = std::max(length(hi - lo), 1e-30);
  epsilon_ = 1e-6 * size_;

  for (uint32_t t = 0; t < nt; ++t) {
    if (!is_emitter(t)) continue;
    const double area = 0.5 * length(cross(corner(t, 1) - corner(t, 0), corner(t, 2) - corner(t, 0)));
    if (!(area > 0)) continue;
    emitters_.push_back(t);
    emitter_area_ += area;
    emitter_cdf_.push_back(emitter_area_);
  }
  for (double &c : emitter_cdf_) c /= emitter_area_;
  if (!emitter_cdf_.empty()) emitter_cdf_.back() = 1.0;
}

Scene::~Scene() {
  rtcReleaseScene(scene_);
  rtcReleaseDevice(device_);
}

Hit Scene::intersect(V3 o, V3 d, double tfar) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh{};
  rh.ray.org_x = static_cast<float>(o.x);
  rh.ray.org_y = static_cast<float>(o.y);
  rh.ray.org_z = static_cast<float>(o.z);
  rh.ray.dir_x = static_cast<float>(d.x);
  rh.ray.dir_y = static_cast<float>(d.y);
  rh.ray.dir_z = static_cast<float>(d.z);
  rh.ray.tnear = static_cast<float>(epsilon_);
  rh.ray.tfar = static_cast<float>(tfar);
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(scene_, &context, &rh);
  Hit hit;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
  hit.distance = rh.ray.tfar;
  hit.triangle = rh.hit.primID;
  hit.normal = normalize(V3{rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z});
  if (dot(hit.normal, d) > 0) hit.normal = hit.normal * -1.0;
  return hit;
}

bool Scene::occluded(V3 o, V3 d, double tfar) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r{};
  r.org_x = static_cast<float>(o.x);
  r.org_y = static_cast<float>(o.y);
  r.org_z = static_cast<float>(o.z);
  r.dir_x = static_cast<float>(d.x);
  r.dir_y = static_cast<float>(d.y);
  r.dir_z = static_cast<float>(d.z);
  r.tnear = static_cast<float>(epsilon_);
  r.tfar = static_cast<float>(tfar);
  r.mask = 0xFFFFFFFFu;
  rtcOccluded1(scene_, &context, &r);
  return r.tfar < 0;
}

V3 Scene::emitted(uint32_t triangle, V3 outgoing) const {
  const V3 face = cross(corner(triangle, 1) - corner(triangle, 0), corner(triangle, 2) - corner(triangle, 0));
  return dot(face, outgoing) > 0 ? material(triangle).ke : V3{};
}

LightSample Scene::sample_light(V3 p, double u1, double u2) const {
  LightSample s{{0, 0, 1}, 0, {}, 0};
  if (emitters_.empty()) return s;
  // The triangle by its area share; u1 is rescaled within the chosen share, so that stratified
  // (u1, u2) stay stratified over each triangle.
  const size_t k = static_cast<size_t>(std::lower_bound(emitter_cdf_.begin(), emitter_cdf_.end(), u1) -
                                       emitter_cdf_.begin());
  const size_t e = std::min(k, emitters_.size() - 1);
  const double lo = e == 0 ? 0.0 : emitter_cdf_[e - 1];
  const double v1 = std::clamp((u1 - lo) / std::max(emitter_cdf_[e] - lo, 1e-300), 0.0, 1.0);
  const uint32_t t = emitters_[e];
  const V3 a = corner(t, 0), b = corner(t, 1), c = corner(t, 2);
  const double su = std::sqrt(v1);  // uniform on the triangle
  const V3 q = a * (1 - su) + b * (su * (1 - u2)) + c * (su * u2);
  const V3 d = q - p;
  const double r2 = dot(d, d);
  if (!(r2 > 0)) return s;
  const double r = std::sqrt(r2);
  const V3 w = d * (1.0 / r);
  const V3 face = cross(b - a, c - a);
  const double cos_l = -dot(normalize(face), w);
  if (!(cos_l > 0)) return s;
  s.direction = w;
  s.distance = r;
  s.radiance = material(t).ke;
  s.pdf = r2 / (cos_l * emitter_area_);
  return s;
}

double Scene::light_pdf(uint32_t triangle, V3 direction, double distance) const {
  const V3 face = cross(corner(triangle, 1) - corner(triangle, 0), corner(triangle, 2) - corner(triangle, 0));
  const double cos_l = -dot(normalize(face), direction);
  if (!(cos_l > 0) || emitter_area_ <= 0) return 0;
  return distance * distance / (cos_l * emitter_area_);
}

}  // namespace rd
