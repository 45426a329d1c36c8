// raddiff.hpp owners: raddiff::Cache, raddiff::CacheCursor, raddiff::RefractiveMesh (construction,
// move, destruction, every method) and raddiff::Error (status and message), against the values
// ffi-tests/cache.c and ffi-tests/scatter.cpp assert through the C API.
#include "hpp_check.h"
#include <cmath>
#include <cstdio>
#include <limits>
#include <type_traits>
#include <utility>
#include <vector>

namespace {

template <class T>
constexpr bool move_only() {
  return !std::is_copy_constructible<T>::value && !std::is_copy_assignable<T>::value &&
         std::is_nothrow_move_constructible<T>::value && std::is_nothrow_move_assignable<T>::value &&
         std::is_nothrow_destructible<T>::value;
}
static_assert(move_only<raddiff::Cache>(), "Cache is move-only");
static_assert(move_only<raddiff::CacheCursor>(), "CacheCursor is move-only");
static_assert(move_only<raddiff::RefractiveMesh>(), "RefractiveMesh is move-only");
static_assert(std::is_base_of<std::runtime_error, raddiff::Error>::value, "Error is a runtime_error");

raddiff_cache_record make_record(double x, const float *value, const float *gradient) {
  raddiff_cache_record r{};
  r.position.x = x;
  r.normal.z = 1.0;
  r.value = value;
  r.gradient = gradient;
  r.radii[0] = r.radii[1] = r.radii[2] = 1.0;
  return r;
}

const raddiff_vec3 kN{0.0, 0.0, 1.0};
std::string g_path;  // next to the test executable

void error_class() {
  const raddiff::Error e(RADDIFF_ERROR_DEGENERATE, "why");
  CHECK(e.status() == RADDIFF_ERROR_DEGENERATE);
  CHECK(std::string(e.what()) == "why");
  CHECK(raddiff::version() == "0.1.0");
  // the check helper: OK passes, anything else throws with raddiff_last_error()
  raddiff::detail::check(RADDIFF_OK);
  CHECK(raddiff_transmittance(kN, kN, 1.0, 9, nullptr) == RADDIFF_ERROR_NULL_POINTER);
  const std::string message = raddiff::last_error();
  CHECK(message.find("out") != std::string::npos);
  CHECK_THROWS(raddiff::detail::check(RADDIFF_ERROR_NULL_POINTER), RADDIFF_ERROR_NULL_POINTER, message.c_str());
}

void cache() {
  const float v0[3] = {1.0f, 2.0f, 3.0f}, v1[3] = {2.0f, 2.0f, 2.0f};
  const float g0[9] = {0.5f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  raddiff_cache_config cfg{3, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
  const raddiff_vec3 p{0.25, 0.0, 0.0}, far{10.0, 0.0, 0.0};

  // constructor errors carry the C message
  cfg.domain = 7;
  CHECK_THROWS(raddiff::Cache{cfg}, RADDIFF_ERROR_INVALID_ARGUMENT, "domain");
  cfg.domain = RADDIFF_DOMAIN_SURFACE;
  cfg.channels = 0;
  CHECK_THROWS(raddiff::Cache{cfg}, RADDIFF_ERROR_INVALID_ARGUMENT, "channel");
  cfg.channels = 3;

  raddiff::Cache cache(cfg);
  CHECK(cache && cache.get() != nullptr && cache.size() == 0);
  std::vector<float> out(3, -1.0f);
  // a miss: NOT_FOUND, outputs untouched; try_lookup says false
  CHECK_THROWS(cache.lookup(p, kN, out), RADDIFF_ERROR_NOT_FOUND, "not found");
  CHECK(out[0] == -1.0f);
  double w = -1.0;
  CHECK(!cache.try_lookup(p, kN, out, &w));
  CHECK(w == -1.0 && out[0] == -1.0f);

  // insert: errors, then two records as in cache.c
  raddiff_cache_record rec = make_record(0.0, v0, g0);
  rec.value = nullptr;
  CHECK_THROWS(cache.insert(rec), RADDIFF_ERROR_NULL_POINTER, "value");
  rec.value = v0;
  rec.radii[0] = 0.0;
  CHECK_THROWS(cache.insert(rec), RADDIFF_ERROR_INVALID_ARGUMENT, "invalid argument");
  rec.radii[0] = 1.0;
  cache.insert(rec);
  cache.insert(rec);  // duplicate: no-op
  CHECK(cache.size() == 1);
  cache.insert(make_record(1.0, v1, nullptr));
  CHECK(cache.size() == 2);

  // at x = 0.25: w0 = 3, w1 = 1/3
  const double wsum = cache.lookup(p, kN, out);
  CHECK_CLOSE(wsum, 10.0 / 3.0, 1e-12);
  CHECK_CLOSE(out[0], (3.0 * (1.0 + 0.25 * 0.5) + 2.0 / 3.0) / (10.0 / 3.0), 1e-6);
  CHECK_CLOSE(out[1], 2.0, 1e-6);
  CHECK_CLOSE(out[2], (3.0 * 3.0 + 2.0 / 3.0) / (10.0 / 3.0), 1e-6);
  std::vector<float> out2(3, 0.0f);
  CHECK(cache.try_lookup(p, kN, out2));
  CHECK(out2 == out);
  w = 0.0;
  CHECK(cache.try_lookup(p, kN, raddiff::Span<float>(out2.data(), out2.size()), &w) && w == wsum);
  CHECK_THROWS(cache.lookup(far, kN, out2), RADDIFF_ERROR_NOT_FOUND, "not found");
  CHECK_THROWS(cache.lookup(p, raddiff_vec3{0, 0, 0}, out2), RADDIFF_ERROR_INVALID_ARGUMENT, "normal");
  CHECK_THROWS(cache.lookup(p, kN, raddiff::Span<float>()), RADDIFF_ERROR_NULL_POINTER, "value");
  CHECK_THROWS(cache.try_lookup(p, kN, raddiff::Span<float>()), RADDIFF_ERROR_NULL_POINTER, "value");

  // cursor: same results bit for bit, before and after compact(); moved cursors
  {
    raddiff::CacheCursor cursor;
    CHECK(cursor.get() != nullptr);
    std::vector<float> out3(3, 0.0f);
    CHECK(cache.lookup_with(cursor, p, kN, out3) == wsum && out3 == out);
    cache.compact();
    out3.assign(3, 0.0f);
    CHECK(cache.lookup_with(cursor, p, kN, out3) == wsum && out3 == out);
    CHECK_THROWS(cache.lookup_with(cursor, far, kN, out3), RADDIFF_ERROR_NOT_FOUND, "not found");
    raddiff::CacheCursor moved(std::move(cursor));
    CHECK(!cursor && cursor.get() == nullptr && moved);
    CHECK_THROWS(cache.lookup_with(cursor, p, kN, out3), RADDIFF_ERROR_NULL_POINTER, "cursor");
    raddiff::CacheCursor other;
    other = std::move(moved);  // frees other's cursor, takes moved's
    CHECK(other && !moved);
    CHECK(cache.lookup_with(other, p, kN, out3) == wsum);
    raddiff_cache_cursor *raw = other.release();
    CHECK(raw != nullptr && !other);
    raddiff_cache_cursor_free(raw);
  }

  // save / load / merge
  const std::string path = g_path + ".rdfcache", bad_path = g_path + ".no-such-dir/x.rdfcache";
  CHECK_THROWS(cache.save(bad_path), RADDIFF_ERROR_IO, "i/o error");
  cache.save(path);
  raddiff::Cache loaded = raddiff::Cache::load(path);
  CHECK(loaded.size() == 2);
  out2.assign(3, 0.0f);
  loaded.lookup(p, kN, out2);
  CHECK(out2 == out);
  loaded.merge(cache);
  CHECK(loaded.size() == 2);
  loaded.merge(loaded);
  CHECK(loaded.size() == 2);
  {
    raddiff_cache_config vcfg{3, RADDIFF_DOMAIN_VOLUME, RADDIFF_INTERP_CUBIC, 0.2};
    raddiff::Cache volume(vcfg);
    CHECK_THROWS(volume.merge(cache), RADDIFF_ERROR_INVALID_ARGUMENT, "invalid argument");
    // volume domain: the normal is ignored, cubic kernel at t = 0.5: w = 0.5
    raddiff_cache_record vr = make_record(0.0, v0, nullptr);
    vr.normal.z = 0.0;
    volume.insert(vr);
    CHECK_CLOSE(volume.lookup(raddiff_vec3{0.0, 0.5, 0.0}, raddiff_vec3{0, 0, 0}, out2), 0.5, 1e-12);
    CHECK_CLOSE(out2[2], 3.0, 1e-7);
  }
  CHECK_THROWS(raddiff::Cache::load(bad_path), RADDIFF_ERROR_IO, "i/o error");
  {
    FILE *f = std::fopen(path.c_str(), "r+b");
    CHECK(f != nullptr);
    if (f) {
      std::fseek(f, 60, SEEK_SET);
      std::fputc(0x5a, f);
      std::fclose(f);
    }
    CHECK_THROWS(raddiff::Cache::load(path), RADDIFF_ERROR_CORRUPT, "corrupt");
    f = std::fopen(path.c_str(), "wb");
    CHECK(f != nullptr);
    if (f) {
      std::fputs("RDFCACHE", f);
      std::fclose(f);
    }
    CHECK_THROWS(raddiff::Cache::load(path), RADDIFF_ERROR_CORRUPT, "truncated");
    std::remove(path.c_str());
  }

  // move construction and assignment; a moved-from cache fails with NULL_POINTER
  raddiff::Cache moved(std::move(loaded));
  CHECK(!loaded && loaded.get() == nullptr && loaded.size() == 0 && moved.size() == 2);
  CHECK_THROWS(loaded.lookup(p, kN, out2), RADDIFF_ERROR_NULL_POINTER, "cache");
  CHECK_THROWS(loaded.insert(rec), RADDIFF_ERROR_NULL_POINTER, "cache");
  CHECK_THROWS(loaded.compact(), RADDIFF_ERROR_NULL_POINTER, "cache");
  CHECK_THROWS(loaded.gradient_limit(), RADDIFF_ERROR_NULL_POINTER, "cache");
  CHECK_THROWS(moved.merge(loaded), RADDIFF_ERROR_NULL_POINTER, "from");
  CHECK_THROWS(loaded.save(path), RADDIFF_ERROR_NULL_POINTER, "cache");
  loaded = std::move(moved);  // assignment into a moved-from owner
  CHECK(loaded.size() == 2 && !moved);
  {
    raddiff_cache_config one{1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT, 0.2};
    raddiff::Cache replaced(one);
    replaced = std::move(loaded);  // frees the one-channel cache
    CHECK(replaced.size() == 2 && !loaded);
    raddiff::Cache &alias = replaced;
    replaced = std::move(alias);  // self-move keeps the handle
    CHECK(replaced.size() == 2);
    raddiff::Cache adopted = raddiff::Cache::adopt(raddiff_cache_new(&one));
    CHECK(adopted.size() == 0);
    raddiff_cache_config bad = one;
    bad.domain = 7;
    CHECK_THROWS(raddiff::Cache::adopt(raddiff_cache_new(&bad)), RADDIFF_ERROR_INVALID_ARGUMENT, "domain");
    // a NULL argument: the status comes from the C message's "null pointer" wording
    CHECK_THROWS(raddiff::Cache::adopt(raddiff_cache_new(nullptr)), RADDIFF_ERROR_NULL_POINTER, "null pointer");
    CHECK_THROWS(raddiff::Cache::adopt(raddiff_cache_load(nullptr)), RADDIFF_ERROR_NULL_POINTER, "null pointer");
  }
}

void gradient_limit() {
  const float one[1] = {1.0f}, steep[3] = {-132.0f, 0.0f, 0.0f};
  const raddiff_vec3 q{0.99, 0.0, 0.0}, q2{10.99, 0.0, 0.0};
  raddiff::Cache plain(raddiff_cache_config{1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2});
  raddiff::Cache limited(raddiff_cache_config{1, RADDIFF_DOMAIN_SURFACE,
                                              RADDIFF_INTERP_WARD | RADDIFF_INTERP_GRADIENT_LIMIT, 0.2});
  CHECK(limited.gradient_limit() == RADDIFF_GRADIENT_LIMIT_DEFAULT);
  CHECK(plain.gradient_limit() == std::numeric_limits<double>::infinity());
  plain.insert(make_record(0.0, one, steep));
  limited.insert(make_record(0.0, one, steep));
  float v = 0.0f;
  plain.lookup(q, kN, raddiff::Span<float>(&v, 1));
  CHECK_CLOSE(v, 1.0 - 0.99 * 132.0, 1e-4);
  limited.lookup(q, kN, raddiff::Span<float>(&v, 1));
  CHECK_CLOSE(v, 1.0 - 0.99 * RADDIFF_GRADIENT_LIMIT_DEFAULT, 1e-3);
  plain.set_gradient_limit(0.5);
  CHECK(plain.gradient_limit() == 0.5);
  plain.insert(make_record(10.0, one, steep));
  plain.lookup(q2, kN, raddiff::Span<float>(&v, 1));
  CHECK_CLOSE(v, 1.0 - 0.99 * 0.5, 1e-3);
  CHECK_THROWS(plain.set_gradient_limit(0.0), RADDIFF_ERROR_INVALID_ARGUMENT, "gradient limit");
  CHECK_THROWS(plain.set_gradient_limit(-1.0), RADDIFF_ERROR_INVALID_ARGUMENT, "gradient limit");
  CHECK(plain.gradient_limit() == 0.5);
  plain.set_gradient_limit(std::numeric_limits<double>::infinity());
  CHECK(plain.gradient_limit() == std::numeric_limits<double>::infinity());
}

// The open-fraction test through the wrapper: the tolerance's setter and getter, lookup_open and
// try_lookup_open with and without a cursor, keeping coverage (the values ffi-tests/open_fraction.c asserts).
void open_fraction() {
  const float closed_value = 1.0f, open_value = 3.0f;
  const double closed = 0.25, open = 0.875;
  raddiff::Cache cache(raddiff_cache_config{1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2});
  raddiff::CacheCursor cursor;
  raddiff_cache_record a = make_record(-0.1, &closed_value, nullptr), b = make_record(0.1, &open_value, nullptr);
  a.open_fraction = &closed;
  b.open_fraction = &open;
  cache.insert(a);
  cache.insert(b);
  const raddiff_vec3 x{0.0, 0.0, 0.0};
  float v = 0.0f, plain = 0.0f;
  CHECK(std::isinf(cache.open_fraction_tolerance()));
  const double w_plain = cache.lookup(x, kN, raddiff::Span<float>(&plain, 1));
  CHECK(cache.lookup_open(x, kN, 0.3, raddiff::Span<float>(&v, 1)) == w_plain && v == plain);
  cache.set_open_fraction_tolerance(0.25);
  CHECK(cache.open_fraction_tolerance() == 0.25);
  cache.lookup_open(x, kN, 0.3, raddiff::Span<float>(&v, 1));
  CHECK_CLOSE(v, 1.0, 1e-6);
  double w = 0.0;
  CHECK(cache.try_lookup_open(x, kN, 0.8, raddiff::Span<float>(&v, 1), &w, &cursor) && w > 0.0);
  CHECK_CLOSE(v, 3.0, 1e-6);
  CHECK(!cache.try_lookup_open(x, kN, 0.56, raddiff::Span<float>(&v, 1)));
  CHECK_THROWS(cache.lookup_open(x, kN, 0.56, raddiff::Span<float>(&v, 1), &cursor), RADDIFF_ERROR_NOT_FOUND,
               "no cache record");
  CHECK_THROWS(cache.lookup_open(x, kN, 2.0, raddiff::Span<float>(&v, 1)), RADDIFF_ERROR_INVALID_ARGUMENT,
               "open fraction");
  CHECK_THROWS(cache.set_open_fraction_tolerance(-1.0), RADDIFF_ERROR_INVALID_ARGUMENT, "open-fraction");
  CHECK(cache.open_fraction_tolerance() == 0.25);
  // keeping coverage: the query that every record's open fraction refuses reads them all
  CHECK(!cache.open_fraction_keeps_coverage());
  cache.set_open_fraction_keeps_coverage(true);
  CHECK(cache.open_fraction_keeps_coverage());
  CHECK(cache.lookup_open(x, kN, 0.56, raddiff::Span<float>(&v, 1), &cursor) == w_plain && v == plain);
  CHECK(cache.open_fraction_coverage_tolerance() == INFINITY);
  cache.set_open_fraction_keeps_coverage(false);
  CHECK(!cache.try_lookup_open(x, kN, 0.56, raddiff::Span<float>(&v, 1)));
  // a finite coverage tolerance: the query open at 0.6 reads the record at 0.875 alone
  cache.set_open_fraction_coverage_tolerance(0.3);
  CHECK(cache.open_fraction_coverage_tolerance() == 0.3 && !cache.open_fraction_keeps_coverage());
  CHECK(cache.lookup_open(x, kN, 0.6, raddiff::Span<float>(&v, 1), &cursor) > 0.0);
  CHECK_CLOSE(v, 3.0, 1e-6);
  CHECK(!cache.try_lookup_open(x, kN, 0.56, raddiff::Span<float>(&v, 1)));
  CHECK_THROWS(cache.set_open_fraction_coverage_tolerance(-1.0), RADDIFF_ERROR_INVALID_ARGUMENT, "coverage");
  cache.set_open_fraction_coverage_tolerance(0.0);
}

// The lookup radius scale through the wrapper: its setter and getter, a covered query blending
// a record beyond its own radius, a gap staying uncovered (the values ffi-tests/lookup_radius.c
// asserts).
void lookup_radius() {
  const float one = 1.0f, three = 3.0f;
  raddiff::Cache cache(raddiff_cache_config{1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2});
  cache.insert(make_record(0.0, &one, nullptr));
  cache.insert(make_record(3.0, &three, nullptr));
  const raddiff_vec3 near_a{0.5, 0.0, 0.0}, gap{1.5, 0.0, 0.0};
  float v = 0.0f;
  CHECK(cache.lookup_radius_scale() == 1.0);
  cache.lookup(near_a, kN, raddiff::Span<float>(&v, 1));
  CHECK(v == 1.0f);
  cache.set_lookup_radius_scale(3.0);
  CHECK(cache.lookup_radius_scale() == 3.0);
  CHECK_CLOSE(cache.lookup(near_a, kN, raddiff::Span<float>(&v, 1)), 5.2, 1e-9);
  CHECK_CLOSE(v, (5.0 + 0.2 * 3.0) / 5.2, 1e-6);
  CHECK_THROWS(cache.lookup(gap, kN, raddiff::Span<float>(&v, 1)), RADDIFF_ERROR_NOT_FOUND, "no cache record");
  CHECK_THROWS(cache.set_lookup_radius_scale(0.5), RADDIFF_ERROR_INVALID_ARGUMENT, "lookup radius scale");
  CHECK(cache.lookup_radius_scale() == 3.0);
}

void clamping() {
  const float one[1] = {1.0f};
  const raddiff_cache_config ccfg{1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD, 0.2};
  raddiff::Cache pre(ccfg), post(ccfg);
  raddiff_cache_record small = make_record(0.5, one, nullptr), big = make_record(0.0, one, nullptr);
  const raddiff_vec3 inside{0.3, 0.0, 0.0}, outside{-1.0, 0.0, 0.0};
  const double bound = static_cast<double>(0.1f) + 0.5;
  small.radii[0] = small.radii[1] = small.radii[2] = 0.1;
  big.radii[0] = 4.0;
  big.radii[1] = big.radii[2] = 2.0;
  big.axes[0].x = 1.0;
  pre.insert(small);
  post.insert(small);
  post.insert(big);
  float a = 0.0f, b = 0.0f;
  post.lookup(outside, kN, raddiff::Span<float>(&a, 1));
  big.position.y = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS(pre.clamp_record(big), RADDIFF_ERROR_INVALID_ARGUMENT, "invalid argument");
  CHECK(big.radii[0] == 4.0 && big.radii[1] == 2.0);
  big.position.y = 0.0;
  pre.clamp_record(big);
  CHECK(big.radii[0] <= bound && big.radii[0] > bound * (1.0 - 1e-6));
  CHECK_CLOSE(big.radii[1], big.radii[0] / 2.0, 1e-6);
  pre.insert(big);
  CHECK(post.clamp_neighbours() == 1);
  CHECK(post.size() == 2);
  CHECK(post.clamp_neighbours() == 0);
  CHECK(pre.clamp_neighbours() == 0);
  pre.lookup(inside, kN, raddiff::Span<float>(&a, 1));
  post.lookup(inside, kN, raddiff::Span<float>(&b, 1));
  CHECK(a == b);
  CHECK(!post.try_lookup(outside, kN, raddiff::Span<float>(&a, 1)));
  CHECK_THROWS(pre.lookup(outside, kN, raddiff::Span<float>(&a, 1)), RADDIFF_ERROR_NOT_FOUND, "not found");
}

void mesh() {
  // the regular tetrahedron of scatter.cpp, vertex normals along the vertex directions
  const std::vector<float> p = {1, 1, 1, 1, -1, -1, -1, 1, -1, -1, -1, 1};
  const std::vector<std::uint32_t> tris = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
  raddiff::RefractiveMesh mesh(p, p, tris);
  CHECK(mesh && mesh.get() != nullptr);
  const raddiff_medium medium{1.33, 0.5, 0.4, -0.2};
  const raddiff_vec3 entry{-0.3, -0.1, 0.0}, exit{0.2, 0.1, 0.1}, light{3.0, 2.5, 2.0};
  const double a = raddiff::single_scatter(mesh, medium, entry, exit, light, 1.0);
  CHECK(std::isfinite(a) && a > 0.0);
  double c = 0.0;
  CHECK(raddiff_single_scatter(mesh.get(), &medium, entry, exit, light, 1.0, &c) == RADDIFF_OK && c == a);
  CHECK_CLOSE(raddiff::single_scatter(mesh, medium, entry, exit, light, 2.0), 2.0 * a, 1e-14);
  CHECK_THROWS(raddiff::single_scatter(mesh, medium, entry, exit, raddiff_vec3{0.05, 0.0, 0.0}, 1.0),
               RADDIFF_ERROR_INVALID_ARGUMENT, "inside");
  CHECK_THROWS(raddiff::single_scatter(mesh, medium, raddiff_vec3{10.0, 0.0, 0.0}, exit, light, 1.0),
               RADDIFF_ERROR_INVALID_ARGUMENT, "outside");
  CHECK_THROWS(raddiff::single_scatter(mesh, raddiff_medium{0.9, 0.5, 0.4, 0.0}, entry, exit, light, 1.0),
               RADDIFF_ERROR_INVALID_ARGUMENT, "eta");

  // C errors from the constructor carry the C message; size checks come first
  const std::vector<std::uint32_t> reversed = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  CHECK_THROWS(raddiff::RefractiveMesh(p, p, reversed), RADDIFF_ERROR_INVALID_ARGUMENT, "counter-clockwise");
  const std::vector<std::uint32_t> out_of_range = {0, 1, 7};
  CHECK_THROWS(raddiff::RefractiveMesh(p, p, out_of_range), RADDIFF_ERROR_INVALID_ARGUMENT, "invalid argument");
  CHECK_THROWS(raddiff::RefractiveMesh(p, p, raddiff::Span<const std::uint32_t>()), RADDIFF_ERROR_INVALID_ARGUMENT,
               "no triangles");
  CHECK_THROWS(raddiff::RefractiveMesh(raddiff::Span<const float>(), raddiff::Span<const float>(), tris),
               RADDIFF_ERROR_INVALID_ARGUMENT, "0 vertices");
  CHECK_THROWS(raddiff::RefractiveMesh(raddiff::Span<const float>(p.data(), 11), p, tris),
               RADDIFF_ERROR_INVALID_ARGUMENT, "positions holds 11");
  CHECK_THROWS(raddiff::RefractiveMesh(p, raddiff::Span<const float>(p.data(), 9), tris),
               RADDIFF_ERROR_INVALID_ARGUMENT, "normals holds 9");
  CHECK_THROWS(raddiff::RefractiveMesh(p, p, raddiff::Span<const std::uint32_t>(tris.data(), 4)),
               RADDIFF_ERROR_INVALID_ARGUMENT, "indices holds 4");

  // move: the moved-from mesh is NULL and single_scatter on it reports it
  raddiff::RefractiveMesh moved(std::move(mesh));
  CHECK(!mesh && moved);
  CHECK(raddiff::single_scatter(moved, medium, entry, exit, light, 1.0) == a);
  CHECK_THROWS(raddiff::single_scatter(mesh, medium, entry, exit, light, 1.0), RADDIFF_ERROR_NULL_POINTER, "mesh");
  mesh = std::move(moved);
  CHECK(raddiff::single_scatter(mesh, medium, entry, exit, light, 1.0) == a);
}

}  // namespace

int main(int argc, char **argv) {
  (void)argc;
  g_path = argv[0];
  error_class();
  cache();
  gradient_limit();
  open_fraction();
  lookup_radius();
  clamping();
  mesh();
  CHECK_DONE("hpp_owners.cpp");
}
