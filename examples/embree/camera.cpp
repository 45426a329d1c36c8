#include "camera.hpp"

namespace rd {

Camera::Camera(const View &view) : view_(view) {
  forward_ = normalize(view.target - view.eye);
  right_ = normalize(cross(forward_, {0, 1, 0}));
  up_ = cross(right_, forward_);
  tan_half_ = std::tan(view.fov * kPi / 360.0);
  aspect_ = static_cast<double>(view.width) / view.height;
}

V3 Camera::direction(double px, double py) const {
  const double sx = (2.0 * px / view_.width - 1.0) * tan_half_ * aspect_;
  const double sy = (1.0 - 2.0 * py / view_.height) * tan_half_;
  return normalize(forward_ + right_ * sx + up_ * sy);
}

bool Camera::project(V3 p, double &px, double &py) const {
  const V3 d = p - view_.eye;
  const double z = dot(d, forward_);
  if (!(z > 0)) return false;
  const double sx = dot(d, right_) / z, sy = dot(d, up_) / z;
  px = (sx / (tan_half_ * aspect_) + 1.0) * 0.5 * view_.width;
  py = (1.0 - sy / tan_half_) * 0.5 * view_.height;
  return px >= 0 && py >= 0 && px < view_.width && py < view_.height;
}

std::vector<Primary> primary_hits(const Scene &scene, const Camera &camera, unsigned threads) {
  const int w = camera.view().width, h = camera.view().height;
  std::vector<Primary> primary(static_cast<size_t>(w) * h);
  parallel_for(primary.size(), threads, [&](size_t i) {
    const V3 d = camera.direction(i % w + 0.5, i / w + 0.5);
    const Hit hit = scene.intersect(camera.view().eye, d);
    if (!hit.found()) return;
    Primary &px = primary[i];
    px.hit = true;
    // Pulled back along the ray (relative 1e-4): a hit exactly on a seam (wall on floor) would
    // otherwise send gather rays through the neighbouring surface (light leaking into corners).
    px.p = camera.view().eye + d * (hit.distance * (1 - 1e-4));
    px.n = hit.normal;
    px.triangle = hit.triangle;
    px.footprint = hit.distance * camera.pixel_angle();
    px.shows_indirect = !scene.is_emitter(hit.triangle) && max_component(scene.material(hit.triangle).kd) > 0;
  });
  return primary;
}

}  // namespace rd
