// The scene: an OBJ mesh (with its MTL's Kd and Ke) in an Embree 3 BVH, its emitters, and the
// length scale that every offset, clamp and step of the renderer follows.
#pragma once

#include "common.hpp"

#include <embree3/rtcore.h>

#include <string>
#include <vector>

namespace rd {

struct Material {
  V3 kd;  // diffuse reflectance
  V3 ke;  // emitted radiance, on the side the triangle's winding faces
};

struct Mesh {
  std::vector<float> positions;   // 3 per vertex
  std::vector<uint32_t> indices;  // 3 per triangle
  std::vector<uint32_t> material;  // per triangle, into `materials`
  std::vector<Material> materials;
  std::vector<std::string> files;  // the OBJ and every MTL it named, as read
};

// Positions (v), polygon faces (f, fanned into triangles), usemtl, mtllib with Kd and Ke.
Mesh load_obj(const std::string &path);

struct Hit {
  double distance = INFINITY;  // along the unit ray direction; INFINITY for a miss
  uint32_t triangle = 0;
  V3 normal;  // unit geometric normal, facing the ray's origin
  bool found() const { return std::isfinite(distance); }
};

// A sampled point on the emitters, seen from a shading point.
struct LightSample {
  V3 direction;      // unit, from the shading point towards the sample
  double distance;   // to the sample
  V3 radiance;       // emitted towards the shading point (0 when it sees the back)
  double pdf;        // solid-angle density of the direction (0 when the sample is unusable)
};

class Scene {
 public:
  explicit Scene(const std::string &obj);
  ~Scene();
  Scene(const Scene &) = delete;
  Scene &operator=(const Scene &) = delete;

  // The first hit along origin + t direction, t in (tnear, tfar]; a miss when there is none.
  Hit intersect(V3 origin, V3 direction, double tfar = INFINITY) const;
  // Whether anything lies on the open segment origin + t direction, t in (tnear, tfar).
  bool occluded(V3 origin, V3 direction, double tfar) const;

  V3 vertex(uint32_t i) const {
    return {mesh_.positions[3 * i], mesh_.positions[3 * i + 1], mesh_.positions[3 * i + 2]};
  }
  V3 corner(uint32_t triangle, int k) const { return vertex(mesh_.indices[3 * triangle + k]); }
  const Material &material(uint32_t triangle) const { return mesh_.materials[mesh_.material[triangle]]; }
  bool is_emitter(uint32_t triangle) const { return max_component(material(triangle).ke) > 0; }
  // Emitted radiance leaving `triangle` along the unit direction `outgoing` (0 from its back).
  V3 emitted(uint32_t triangle, V3 outgoing) const;

  // One point on the emitters (area-uniform, a triangle chosen by its share of the emitting area)
  // from the uniform pair (u1, u2), seen from `p`.
  LightSample sample_light(V3 p, double u1, double u2) const;
  // The solid-angle density with which sample_light picks `direction` at a hit on emitter
  // `triangle` at `distance` from p.
  double light_pdf(uint32_t triangle, V3 direction, double distance) const;

  // The files the scene was read from (for cache keys).
  const std::vector<std::string> &files() const { return mesh_.files; }
  size_t triangle_count() const { return mesh_.indices.size() / 3; }
  size_t emitter_count() const { return emitters_.size(); }
  const std::vector<uint32_t> &emitters() const { return emitters_; }
  // Bounding-box diagonal (L): the scene's length scale.
  double size() const { return size_; }
  // Ray tnear and the offset of secondary-ray origins (L): 1e-6 of the scene size.
  double epsilon() const { return epsilon_; }

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  Mesh mesh_;
  std::vector<uint32_t> emitters_;
  std::vector<double> emitter_cdf_;  // cumulative area share, ends at 1
  double emitter_area_ = 0;
  double size_ = 1;
  double epsilon_ = 1e-6;
};

}  // namespace rd
