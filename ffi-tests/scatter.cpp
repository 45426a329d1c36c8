// raddiff single scattering from C++17: RAII ownership of the mesh handle, a closed mesh (a
// tetrahedron) with its inside/outside checks, and agreement of repeated calls.
#include "raddiff.h"
#include "check.h"
#include <cstring>
#include <memory>
#include <vector>

struct MeshDeleter {
  void operator()(raddiff_refractive_mesh *m) const { raddiff_refractive_mesh_free(m); }
};
using Mesh = std::unique_ptr<raddiff_refractive_mesh, MeshDeleter>;

int main() {
  // Regular tetrahedron around the origin; vertex normals along the vertex directions.
  const std::vector<float> p = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};
  const std::vector<uint32_t> tris = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  Mesh mesh(raddiff_refractive_mesh_new(p.data(), p.data(), 4, tris.data(), 4));
  CHECK(mesh != nullptr);
  if (!mesh) CHECK_DONE("scatter.cpp");

  const raddiff_medium medium{1.33, 0.5, 0.4, -0.2};
  const raddiff_vec3 entry{-0.3, -0.1, 0.0}, exit{0.2, 0.1, 0.1}, light{3.0, 2.5, 2.0};
  double a = -1.0, b = -2.0;
  CHECK_STATUS(raddiff_single_scatter(mesh.get(), &medium, entry, exit, light, 1.0, &a), RADDIFF_OK);
  CHECK(std::isfinite(a) && a > 0.0);
  CHECK_STATUS(raddiff_single_scatter(mesh.get(), &medium, entry, exit, light, 2.0, &b), RADDIFF_OK);
  CHECK_CLOSE(b, 2.0 * a, 1e-14);

  // The light must be outside a closed mesh, the segment inside its bounding sphere.
  double r = 7.0;
  const raddiff_vec3 inside{0.05, 0.0, 0.0}, far_away{10.0, 0.0, 0.0};
  CHECK_STATUS(raddiff_single_scatter(mesh.get(), &medium, entry, exit, inside, 1.0, &r),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(std::strstr(raddiff_last_error(), "inside") != nullptr);
  CHECK_STATUS(raddiff_single_scatter(mesh.get(), &medium, far_away, exit, light, 1.0, &r),
               RADDIFF_ERROR_INVALID_ARGUMENT);
  CHECK(std::strstr(raddiff_last_error(), "outside") != nullptr);
  CHECK(r == 7.0);

  // Reversed winding: the normals face away from the geometric normals.
  const std::vector<uint32_t> reversed = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  Mesh bad(raddiff_refractive_mesh_new(p.data(), p.data(), 4, reversed.data(), 4));
  CHECK(bad == nullptr);
  CHECK(std::strstr(raddiff_last_error(), "counter-clockwise") != nullptr);
  CHECK_DONE("scatter.cpp");
}
