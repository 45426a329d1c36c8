/*
 * raddiff.hpp: header-only C++17 wrapper over the C API in raddiff.h.
 *
 * - Failures become exceptions: every call whose C function returns a status other than RADDIFF_OK
 *   throws raddiff::Error, carrying that status and the message of raddiff_last_error().
 * - Handles (cache, cache cursor, gather evaluation, refractive mesh) are move-only owners that
 *   free them on destruction; IrradianceCache owns a cache and the settings it fills it with.
 * - Callbacks are any C++ callable: an exception thrown by one never crosses the C boundary (it is
 *   caught, the C call returns, and the exception is rethrown to the caller).
 * - Arrays are passed as raddiff::Span (pointer and size); where raddiff.h documents the length a
 *   function needs, the wrapper checks it before the call and throws raddiff::Error with
 *   RADDIFF_ERROR_INVALID_ARGUMENT otherwise. Outputs are returned by value.
 * - Nothing else: units, conventions and results are those of the C functions (see raddiff.h and
 *   the README); the wrapper adds no computation of its own.
 */
#ifndef RADDIFF_HPP
#define RADDIFF_HPP

#include "raddiff.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace raddiff {

/// The exception thrown for every failed raddiff call: `status()` is the `raddiff_status` the C
/// function returned (never `RADDIFF_OK`), `what()` the message of `raddiff_last_error()` at the
/// time of the failure (or the wrapper's own message for a size check).
class Error : public std::runtime_error {
 public:
  /// An error with status `status` and message `message`.
  Error(raddiff_status status, const std::string &message)
      : std::runtime_error(message), status_(status) {}

  /// The C status code of the failure (`RADDIFF_ERROR_*`).
  raddiff_status status() const noexcept { return status_; }

 private:
  raddiff_status status_;
};

/// Wraps `raddiff_last_error()`: the message of the last failed raddiff call on this thread ("" if
/// none failed yet), copied.
inline std::string last_error() { return std::string(raddiff_last_error()); }

/// Wraps `raddiff_version()`: the library version, "MAJOR.MINOR.PATCH".
inline std::string version() { return std::string(raddiff_version()); }

namespace detail {

/// Throws raddiff::Error(status, raddiff_last_error()) unless `status` is RADDIFF_OK.
inline void check(raddiff_status status) {
  if (status != RADDIFF_OK) throw Error(status, raddiff_last_error());
}

/// The status behind the message of a constructor that returned NULL (the C constructors report
/// no code): the message's prefix, as raddiff words it, else RADDIFF_ERROR_INVALID_ARGUMENT.
inline raddiff_status constructor_status(const std::string &message) {
  const auto starts = [&message](const char *prefix) { return message.rfind(prefix, 0) == 0; };
  if (starts("null pointer")) return RADDIFF_ERROR_NULL_POINTER;
  if (starts("degenerate")) return RADDIFF_ERROR_DEGENERATE;
  if (starts("not found")) return RADDIFF_ERROR_NOT_FOUND;
  if (starts("i/o error")) return RADDIFF_ERROR_IO;
  if (starts("corrupt")) return RADDIFF_ERROR_CORRUPT;
  if (starts("internal panic")) return RADDIFF_ERROR_PANIC;
  return RADDIFF_ERROR_INVALID_ARGUMENT;
}

/// Returns `handle`, or throws raddiff::Error with raddiff_last_error() when it is NULL.
template <class T>
T *check_handle(T *handle) {
  if (handle == nullptr) {
    std::string message = raddiff_last_error();
    throw Error(constructor_status(message), message);
  }
  return handle;
}

/// Throws raddiff::Error(RADDIFF_ERROR_INVALID_ARGUMENT) when an array holds `actual` elements
/// where the C function needs `expected`.
inline void check_size(const char *what, std::size_t actual, std::size_t expected) {
  if (actual != expected) {
    throw Error(RADDIFF_ERROR_INVALID_ARGUMENT, std::string("raddiff.hpp: ") + what + " holds " +
                                                    std::to_string(actual) + " elements, expected " +
                                                    std::to_string(expected));
  }
}

/// a * b, or SIZE_MAX when that overflows (no array holds SIZE_MAX elements, so a size check
/// against it fails instead of passing a wrapped-around product).
inline std::size_t mul(std::size_t a, std::size_t b) noexcept {
  return (a != 0 && b > SIZE_MAX / a) ? SIZE_MAX : a * b;
}

/// Wraps `raddiff_cache_free` (NULL is ignored).
inline void free_handle(raddiff_cache *p) noexcept { raddiff_cache_free(p); }
/// Wraps `raddiff_cache_cursor_free` (NULL is ignored).
inline void free_handle(raddiff_cache_cursor *p) noexcept { raddiff_cache_cursor_free(p); }
/// Wraps `raddiff_refractive_mesh_free` (NULL is ignored).
inline void free_handle(raddiff_refractive_mesh *p) noexcept { raddiff_refractive_mesh_free(p); }
/// Wraps `raddiff_gather_evaluation_free` (NULL is ignored).
inline void free_handle(raddiff_gather_evaluation *p) noexcept { raddiff_gather_evaluation_free(p); }

/// Move-only owner of one raddiff handle: frees it on destruction; a moved-from owner holds NULL
/// (and every C call on it then fails with RADDIFF_ERROR_NULL_POINTER).
template <class T>
class Owner {
 public:
  /// Not copyable: one owner per handle.
  Owner(const Owner &) = delete;
  /// Not copyable: one owner per handle.
  Owner &operator=(const Owner &) = delete;
  /// Takes the handle of `other`, which is left holding NULL.
  Owner(Owner &&other) noexcept : ptr_(other.ptr_) { other.ptr_ = nullptr; }
  /// Frees the current handle (with its C `_free`) and takes the handle of `other`.
  Owner &operator=(Owner &&other) noexcept {
    if (this != &other) {
      free_handle(ptr_);
      ptr_ = other.ptr_;
      other.ptr_ = nullptr;
    }
    return *this;
  }
  /// Frees the handle with its C `_free` (NULL is ignored).
  ~Owner() { free_handle(ptr_); }

  /// The raw C handle (still owned by this object; NULL after a move).
  T *get() const noexcept { return ptr_; }
  /// True unless moved from or released.
  explicit operator bool() const noexcept { return ptr_ != nullptr; }
  /// Gives up ownership: returns the raw handle, which the caller must free with the C `_free`.
  T *release() noexcept {
    T *p = ptr_;
    ptr_ = nullptr;
    return p;
  }

 protected:
  /// Owns `ptr` (NULL-checked by the derived class's constructor).
  explicit Owner(T *ptr) noexcept : ptr_(ptr) {}

 private:
  T *ptr_;
};

}  // namespace detail

/// A non-owning view of `size()` contiguous `T` (C++17 has no std::span): built from a pointer and
/// a size, a C array, a std::array or a std::vector (or anything with data() and size()). An empty
/// span stands for a NULL pointer where the C function accepts one. It does not keep its source
/// alive: a span of a temporary is valid only until the end of the full expression.
template <class T>
class Span {
 public:
  /// An empty span (NULL, 0).
  constexpr Span() noexcept = default;
  /// `size` elements from `data`.
  constexpr Span(T *data, std::size_t size) noexcept : data_(data), size_(size) {}
  /// A whole C array.
  template <std::size_t N>
  constexpr Span(T (&array)[N]) noexcept : data_(array), size_(N) {}  // NOLINT: implicit by design
  /// A whole container with contiguous data() and size() (std::vector, std::array, Span<U>).
  template <class C, class = std::enable_if_t<
                         std::is_convertible<decltype(std::declval<C &>().data()), T *>::value &&
                         !std::is_array<std::remove_reference_t<C>>::value>>
  constexpr Span(C &&container) noexcept  // NOLINT: implicit by design
      : data_(container.data()), size_(container.size()) {}

  /// First element (NULL for the default span).
  constexpr T *data() const noexcept { return data_; }
  /// Number of elements.
  constexpr std::size_t size() const noexcept { return size_; }
  /// True for zero elements.
  constexpr bool empty() const noexcept { return size_ == 0; }
  /// Element `i` (unchecked).
  constexpr T &operator[](std::size_t i) const noexcept { return data_[i]; }
  /// Iteration.
  constexpr T *begin() const noexcept { return data_; }
  /// Iteration.
  constexpr T *end() const noexcept { return data_ + size_; }

 private:
  T *data_ = nullptr;
  std::size_t size_ = 0;
};

/// Owner of a `raddiff_cache_cursor` (per-thread state for coherent lookups, see
/// `raddiff_cache_lookup_with`). Not thread-safe: one per thread; usable with any cache.
class CacheCursor : public detail::Owner<raddiff_cache_cursor> {
 public:
  /// Wraps `raddiff_cache_cursor_new`; throws raddiff::Error if it returns NULL.
  CacheCursor() : Owner(detail::check_handle(raddiff_cache_cursor_new())) {}
};

/// Owner of a `raddiff_cache` (thread-safe radiance cache; see the C docs of each function for
/// which calls may run concurrently: insert, lookup, lookup_with, clamp_record may; compact,
/// clamp_neighbours, set_gradient_limit may not).
class Cache : public detail::Owner<raddiff_cache> {
 public:
  /// Wraps `raddiff_cache_new`: an empty cache; throws raddiff::Error (with the C message) for an
  /// invalid configuration.
  explicit Cache(const raddiff_cache_config &config)
      : Owner(detail::check_handle(raddiff_cache_new(&config))) {}

  /// Wraps `raddiff_cache_load`: a cache saved by save(); throws raddiff::Error with
  /// RADDIFF_ERROR_IO or RADDIFF_ERROR_CORRUPT (from the message's wording) for bad files.
  static Cache load(const std::string &path) {
    return Cache(detail::check_handle(raddiff_cache_load(path.c_str())));
  }

  /// Takes ownership of a handle from `raddiff_cache_new` / `raddiff_cache_load`; NULL throws
  /// raddiff::Error with raddiff_last_error(), so `adopt(raddiff_cache_new(&config))` reports why.
  static Cache adopt(raddiff_cache *cache) { return Cache(detail::check_handle(cache)); }

  /// Wraps `raddiff_cache_insert` (thread-safe). The record's arrays hold `channels` floats (value)
  /// and 3*channels floats (gradients, nullable), as documented in raddiff.h.
  void insert(const raddiff_cache_record &record) { detail::check(raddiff_cache_insert(get(), &record)); }

  /// Wraps `raddiff_cache_lookup`: interpolates at `position` (normal `normal`, ignored in volumes)
  /// into `value` (must hold the cache's channel count; the C API does not expose it, so this is
  /// not checked) and returns the weight sum. A point no record covers throws raddiff::Error with
  /// RADDIFF_ERROR_NOT_FOUND (use try_lookup in loops where misses are common).
  double lookup(raddiff_vec3 position, raddiff_vec3 normal, Span<float> value) const {
    double weight_sum = 0.0;
    detail::check(raddiff_cache_lookup(get(), position, normal, value.data(), &weight_sum));
    return weight_sum;
  }

  /// `raddiff_cache_lookup` without an exception for a miss: false on RADDIFF_ERROR_NOT_FOUND
  /// (`value` untouched), true on success (weight sum in `*weight_sum` if not NULL); other
  /// failures throw raddiff::Error.
  bool try_lookup(raddiff_vec3 position, raddiff_vec3 normal, Span<float> value,
                  double *weight_sum = nullptr) const {
    const raddiff_status s = raddiff_cache_lookup(get(), position, normal, value.data(), weight_sum);
    if (s == RADDIFF_ERROR_NOT_FOUND) return false;
    detail::check(s);
    return true;
  }

  /// Wraps `raddiff_cache_lookup_with`: lookup() through `cursor` (same results bit for bit).
  double lookup_with(CacheCursor &cursor, raddiff_vec3 position, raddiff_vec3 normal,
                     Span<float> value) const {
    double weight_sum = 0.0;
    detail::check(
        raddiff_cache_lookup_with(get(), cursor.get(), position, normal, value.data(), &weight_sum));
    return weight_sum;
  }

  /// Wraps `raddiff_cache_lookup_open`: lookup() for a query whose open fraction is
  /// `open_fraction` (in [0, 1]), through `cursor` when it is not NULL. The cache's open-fraction
  /// test refuses the records whose open fraction differs by more than its tolerance; a point no
  /// admitted record covers throws raddiff::Error with RADDIFF_ERROR_NOT_FOUND.
  double lookup_open(raddiff_vec3 position, raddiff_vec3 normal, double open_fraction, Span<float> value,
                     CacheCursor *cursor = nullptr) const {
    double weight_sum = 0.0;
    detail::check(raddiff_cache_lookup_open(get(), cursor ? cursor->get() : nullptr, position, normal,
                                            open_fraction, value.data(), &weight_sum));
    return weight_sum;
  }

  /// lookup_open() without an exception for a miss: false on RADDIFF_ERROR_NOT_FOUND (`value`
  /// untouched), true on success (weight sum in `*weight_sum` if not NULL); other failures throw.
  bool try_lookup_open(raddiff_vec3 position, raddiff_vec3 normal, double open_fraction, Span<float> value,
                       double *weight_sum = nullptr, CacheCursor *cursor = nullptr) const {
    const raddiff_status s = raddiff_cache_lookup_open(get(), cursor ? cursor->get() : nullptr, position, normal,
                                                       open_fraction, value.data(), weight_sum);
    if (s == RADDIFF_ERROR_NOT_FOUND) return false;
    detail::check(s);
    return true;
  }

  /// Wraps `raddiff_cache_compact` (not thread-safe): prepares a lookup-only phase.
  void compact() { detail::check(raddiff_cache_compact(get())); }

  /// Wraps `raddiff_cache_len`: the number of records (0 after a move).
  std::size_t size() const noexcept { return raddiff_cache_len(get()); }

  /// Wraps `raddiff_cache_save`: writes the cache to `path` atomically (RADDIFF_ERROR_IO on failure).
  void save(const std::string &path) const { detail::check(raddiff_cache_save(get(), path.c_str())); }

  /// Wraps `raddiff_cache_merge`: adds every record of `from` not held yet (`from` may be *this).
  void merge(const Cache &from) { detail::check(raddiff_cache_merge(get(), from.get())); }

  /// Wraps `raddiff_cache_clamp_neighbours` (not thread-safe): two-sided neighbour clamping of the
  /// stored records; returns how many shrank.
  std::size_t clamp_neighbours() {
    std::size_t shrunk = 0;
    detail::check(raddiff_cache_clamp_neighbours(get(), &shrunk));
    return shrunk;
  }

  /// Wraps `raddiff_cache_clamp_record` (thread-safe): shrinks `record.radii` in place against the
  /// stored records before it is inserted (untouched on error).
  void clamp_record(raddiff_cache_record &record) const {
    detail::check(raddiff_cache_clamp_record(get(), &record));
  }

  /// Wraps `raddiff_cache_set_gradient_limit` (not thread-safe): the gradient limit c for records
  /// inserted from now on (INFINITY: off; c <= 0 or NaN throws).
  void set_gradient_limit(double c) { detail::check(raddiff_cache_set_gradient_limit(get(), c)); }

  /// Wraps `raddiff_cache_get_gradient_limit`: the current c (INFINITY when off).
  double gradient_limit() const {
    double c = 0.0;
    detail::check(raddiff_cache_get_gradient_limit(get(), &c));
    return c;
  }

  /// Wraps `raddiff_cache_set_leak_guard` (not thread-safe): the "record in front of the query"
  /// tolerances (relative INFINITY: off; NaN or negative throws).
  void set_leak_guard(double relative, double absolute = 0.0) {
    detail::check(raddiff_cache_set_leak_guard(get(), relative, absolute));
  }

  /// Wraps `raddiff_cache_get_leak_guard`: the tolerances (relative, absolute); relative is
  /// INFINITY when the guard is off.
  std::pair<double, double> leak_guard() const {
    double relative = 0.0, absolute = 0.0;
    detail::check(raddiff_cache_get_leak_guard(get(), &relative, &absolute));
    return {relative, absolute};
  }

  /// Wraps `raddiff_cache_set_open_fraction_tolerance` (not thread-safe): the open-fraction test
  /// of a far-field cache (INFINITY: off; NaN or negative throws).
  void set_open_fraction_tolerance(double tolerance) {
    detail::check(raddiff_cache_set_open_fraction_tolerance(get(), tolerance));
  }

  /// Wraps `raddiff_cache_get_open_fraction_tolerance`: the tolerance (INFINITY when off).
  double open_fraction_tolerance() const {
    double tolerance = 0.0;
    detail::check(raddiff_cache_get_open_fraction_tolerance(get(), &tolerance));
    return tolerance;
  }

  /// Wraps `raddiff_cache_set_open_fraction_coverage_tolerance` (not thread-safe): a query whose
  /// covering records the open-fraction test all refuses reads those within this tolerance
  /// (INFINITY: all; 0, the default: none; NaN or negative throws).
  void set_open_fraction_coverage_tolerance(double coverage_tolerance) {
    detail::check(raddiff_cache_set_open_fraction_coverage_tolerance(get(), coverage_tolerance));
  }

  /// Wraps `raddiff_cache_get_open_fraction_coverage_tolerance`.
  double open_fraction_coverage_tolerance() const {
    double coverage_tolerance = 0.0;
    detail::check(raddiff_cache_get_open_fraction_coverage_tolerance(get(), &coverage_tolerance));
    return coverage_tolerance;
  }

  /// Wraps `raddiff_cache_set_open_fraction_keeps_coverage` (not thread-safe): whether a query
  /// whose covering records the open-fraction test all refuses reads them all (a coverage
  /// tolerance of INFINITY) or none (0).
  void set_open_fraction_keeps_coverage(bool keeps) {
    detail::check(raddiff_cache_set_open_fraction_keeps_coverage(get(), keeps ? 1u : 0u));
  }

  /// Wraps `raddiff_cache_get_open_fraction_keeps_coverage`: whether the coverage tolerance is
  /// INFINITY.
  bool open_fraction_keeps_coverage() const {
    uint32_t keeps = 0;
    detail::check(raddiff_cache_get_open_fraction_keeps_coverage(get(), &keeps));
    return keeps != 0;
  }

  /// Wraps `raddiff_cache_set_lookup_radius_scale` (not thread-safe): records are read over
  /// `scale` times their radii, in [1, RADDIFF_LOOKUP_RADIUS_SCALE_MAX] (anything else throws);
  /// misses stay where they are at 1.
  void set_lookup_radius_scale(double scale) {
    detail::check(raddiff_cache_set_lookup_radius_scale(get(), scale));
  }

  /// Wraps `raddiff_cache_get_lookup_radius_scale`: the scale (1 unless set).
  double lookup_radius_scale() const {
    double scale = 0.0;
    detail::check(raddiff_cache_get_lookup_radius_scale(get(), &scale));
    return scale;
  }

  /// Wraps `raddiff_cache_get_far_field`: the far-field reach (world, pixels) its records were
  /// made at; both 0 when they hold irradiance.
  std::pair<double, double> far_field() const {
    double world = 0.0, pixels = 0.0;
    detail::check(raddiff_cache_get_far_field(get(), &world, &pixels));
    return {world, pixels};
  }

 private:
  /// Owns `cache` (already NULL-checked).
  explicit Cache(raddiff_cache *cache) noexcept : Owner(cache) {}
};

/// Owner of a `raddiff_refractive_mesh` (immutable, shareable between threads).
class RefractiveMesh : public detail::Owner<raddiff_refractive_mesh> {
 public:
  /// Wraps `raddiff_refractive_mesh_new`: `positions` and `normals` hold 3 floats per vertex (the
  /// same count), `indices` 3 per triangle (counter-clockwise seen from outside; normals point
  /// outwards). Sizes that are not multiples of 3, or normals not matching positions, throw
  /// raddiff::Error (RADDIFF_ERROR_INVALID_ARGUMENT) before the call; the C errors throw with
  /// their message. The arrays are copied.
  RefractiveMesh(Span<const float> positions, Span<const float> normals, Span<const std::uint32_t> indices)
      : Owner(create(positions, normals, indices)) {}

 private:
  /// The size checks and the C constructor (NULL throws).
  static raddiff_refractive_mesh *create(Span<const float> positions, Span<const float> normals,
                                         Span<const std::uint32_t> indices) {
    detail::check_size("positions", positions.size(), positions.size() / 3 * 3);
    detail::check_size("normals", normals.size(), positions.size());
    detail::check_size("indices", indices.size(), indices.size() / 3 * 3);
    return detail::check_handle(raddiff_refractive_mesh_new(positions.data(), normals.data(),
                                                             positions.size() / 3, indices.data(),
                                                             indices.size() / 3));
  }
};

/// Wraps `raddiff_transmittance`: exp(-sigma_t |x - y|) with gradient and Hessian with respect to
/// `x` up to `order` (`RADDIFF_ORDER_*`; higher parts 0).
inline raddiff_deriv3 transmittance(raddiff_vec3 x, raddiff_vec3 y, double sigma_t,
                                    std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  raddiff_deriv3 out{};
  detail::check(raddiff_transmittance(x, y, sigma_t, order, &out));
  return out;
}

/// Wraps `raddiff_transmittance_marched`: heterogeneous transmittance from the extinction samples
/// `sigma_t` at the segment's midpoints; `sigma_t_gradient` is empty (unknown) or holds one vector
/// per sample (checked). `order` is RADDIFF_ORDER_VALUE or RADDIFF_ORDER_GRADIENT.
inline raddiff_deriv3 transmittance_marched(raddiff_vec3 x, raddiff_vec3 y, Span<const double> sigma_t,
                                            Span<const raddiff_vec3> sigma_t_gradient = {},
                                            std::uint32_t order = RADDIFF_ORDER_GRADIENT) {
  if (!sigma_t_gradient.empty()) {
    detail::check_size("sigma_t_gradient", sigma_t_gradient.size(), sigma_t.size());
  }
  raddiff_deriv3 out{};
  detail::check(raddiff_transmittance_marched(x, y, sigma_t.data(),
                                              sigma_t_gradient.empty() ? nullptr : sigma_t_gradient.data(),
                                              sigma_t.size(), order, &out));
  return out;
}

/// Wraps `raddiff_triangle_solid_angle`: unsigned solid angle (steradians) of triangle (a, b, c)
/// seen from `x`, with derivatives with respect to `x`.
inline raddiff_deriv3 triangle_solid_angle(raddiff_vec3 x, raddiff_vec3 a, raddiff_vec3 b, raddiff_vec3 c,
                                           std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  raddiff_deriv3 out{};
  detail::check(raddiff_triangle_solid_angle(x, a, b, c, order, &out));
  return out;
}

/// Wraps `raddiff_triangle_form_factor`: form factor from a differential area at `x` with unit
/// normal `n` to triangle (a, b, c) (clipped at the tangent plane), derivatives with respect to `x`.
inline raddiff_deriv3 triangle_form_factor(raddiff_vec3 x, raddiff_vec3 n, raddiff_vec3 a, raddiff_vec3 b,
                                           raddiff_vec3 c, std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  raddiff_deriv3 out{};
  detail::check(raddiff_triangle_form_factor(x, n, a, b, c, order, &out));
  return out;
}

/// Wraps `raddiff_polygon_form_factor`: triangle_form_factor for a planar simple polygon (the C
/// function needs at least 3 vertices and reports fewer itself).
inline raddiff_deriv3 polygon_form_factor(raddiff_vec3 x, raddiff_vec3 n, Span<const raddiff_vec3> vertices,
                                          std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  raddiff_deriv3 out{};
  detail::check(raddiff_polygon_form_factor(x, n, vertices.data(), vertices.size(), order, &out));
  return out;
}

/// Wraps `raddiff_segment_form_factor_2d`: flatland angle subtended at `x` by segment (a, b) over
/// 2 pi, with gradient and 2x2 Hessian with respect to `x`.
inline raddiff_deriv2 segment_form_factor_2d(raddiff_vec2 x, raddiff_vec2 a, raddiff_vec2 b,
                                             std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  raddiff_deriv2 out{};
  detail::check(raddiff_segment_form_factor_2d(x, a, b, order, &out));
  return out;
}

/// A `raddiff_triangle_mesh` over packed float vertices (3 per vertex) and uint32 index triples
/// (3 per triangle); sizes that are not multiples of 3 throw before any call. The mesh reads the
/// arrays in place: they must outlive its use.
inline raddiff_triangle_mesh triangle_mesh(Span<const float> vertices, Span<const std::uint32_t> indices) {
  detail::check_size("vertices", vertices.size(), vertices.size() / 3 * 3);
  detail::check_size("indices", indices.size(), indices.size() / 3 * 3);
  return raddiff_triangle_mesh{vertices.data(), RADDIFF_VERTEX_FLOAT3, 0, vertices.size() / 3,
                               indices.data(), 0, indices.size() / 3};
}

/// triangle_mesh over packed double vertices (3 per vertex).
inline raddiff_triangle_mesh triangle_mesh(Span<const double> vertices, Span<const std::uint32_t> indices) {
  detail::check_size("vertices", vertices.size(), vertices.size() / 3 * 3);
  detail::check_size("indices", indices.size(), indices.size() / 3 * 3);
  return raddiff_triangle_mesh{vertices.data(), RADDIFF_VERTEX_DOUBLE3, 0, vertices.size() / 3,
                               indices.data(), 0, indices.size() / 3};
}

/// triangle_mesh over raddiff_vec3 vertices.
inline raddiff_triangle_mesh triangle_mesh(Span<const raddiff_vec3> vertices, Span<const std::uint32_t> indices) {
  detail::check_size("indices", indices.size(), indices.size() / 3 * 3);
  return raddiff_triangle_mesh{vertices.data(), RADDIFF_VERTEX_DOUBLE3, 0, vertices.size(),
                               indices.data(), 0, indices.size() / 3};
}

/// A triangle soup: triangle t is vertices[3t], vertices[3t+1], vertices[3t+2] (the size must be a
/// multiple of 3, checked).
inline raddiff_triangle_mesh triangle_soup(Span<const raddiff_vec3> vertices) {
  detail::check_size("vertices", vertices.size(), vertices.size() / 3 * 3);
  return raddiff_triangle_mesh{vertices.data(), RADDIFF_VERTEX_DOUBLE3, 0, vertices.size(), nullptr, 0,
                               vertices.size() / 3};
}

/// Per-element results of the batch calls: `values[i]`, `gradients[3i + axis]`,
/// `hessians[9i + 3 row + col]`; the arrays above the requested order are empty.
struct BatchResult {
  /// One value per element.
  std::vector<double> values;
  /// 3 per element (from RADDIFF_ORDER_GRADIENT on).
  std::vector<double> gradients;
  /// 9 per element, row-major (RADDIFF_ORDER_HESSIAN).
  std::vector<double> hessians;
};

namespace detail {

/// Checks caller arrays for `count` elements at `order` (the arrays above the order may be empty).
inline void check_batch_outputs(std::size_t count, std::uint32_t order, Span<double> values,
                                Span<double> gradients, Span<double> hessians) {
  check_size("values", values.size(), count);
  if (order >= RADDIFF_ORDER_GRADIENT) check_size("gradients", gradients.size(), mul(count, 3));
  if (order >= RADDIFF_ORDER_HESSIAN) check_size("hessians", hessians.size(), mul(count, 9));
}

/// A BatchResult sized for `count` elements at `order`.
inline BatchResult batch_result(std::size_t count, std::uint32_t order) {
  BatchResult r;
  r.values.resize(count);
  if (order >= RADDIFF_ORDER_GRADIENT) r.gradients.resize(mul(count, 3));
  if (order >= RADDIFF_ORDER_HESSIAN) r.hessians.resize(mul(count, 9));
  return r;
}

}  // namespace detail

/// Wraps `raddiff_mesh_solid_angle`: the sum over the triangles of `mesh` of their unsigned solid
/// angles seen from `x`, with derivatives up to `order`.
inline raddiff_deriv3 mesh_solid_angle(raddiff_vec3 x, const raddiff_triangle_mesh &mesh,
                                       std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  raddiff_deriv3 out{};
  detail::check(raddiff_mesh_solid_angle(x, &mesh, order, &out));
  return out;
}

/// Wraps `raddiff_mesh_solid_angle_each` into caller arrays: `values` holds mesh.triangle_count,
/// `gradients` 3 and `hessians` 9 per triangle when `order` needs them (checked; the others may be
/// empty). Untouched on error.
inline void mesh_solid_angle_each(raddiff_vec3 x, const raddiff_triangle_mesh &mesh, std::uint32_t order,
                                  Span<double> values, Span<double> gradients = {},
                                  Span<double> hessians = {}) {
  detail::check_batch_outputs(mesh.triangle_count, order, values, gradients, hessians);
  detail::check(raddiff_mesh_solid_angle_each(x, &mesh, order, values.data(), gradients.data(),
                                              hessians.data()));
}

/// Wraps `raddiff_mesh_solid_angle_each`, returning the per-triangle results.
inline BatchResult mesh_solid_angle_each(raddiff_vec3 x, const raddiff_triangle_mesh &mesh,
                                         std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  BatchResult r = detail::batch_result(mesh.triangle_count, order);
  mesh_solid_angle_each(x, mesh, order, r.values, r.gradients, r.hessians);
  return r;
}

/// Wraps `raddiff_mesh_form_factor`: the sum over the triangles of `mesh` of the form factors from
/// a differential area at `x` with unit normal `n` (no occlusion between triangles).
inline raddiff_deriv3 mesh_form_factor(raddiff_vec3 x, raddiff_vec3 n, const raddiff_triangle_mesh &mesh,
                                       std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  raddiff_deriv3 out{};
  detail::check(raddiff_mesh_form_factor(x, n, &mesh, order, &out));
  return out;
}

/// Wraps `raddiff_mesh_form_factor_each` into caller arrays (sizes as mesh_solid_angle_each).
inline void mesh_form_factor_each(raddiff_vec3 x, raddiff_vec3 n, const raddiff_triangle_mesh &mesh,
                                  std::uint32_t order, Span<double> values, Span<double> gradients = {},
                                  Span<double> hessians = {}) {
  detail::check_batch_outputs(mesh.triangle_count, order, values, gradients, hessians);
  detail::check(raddiff_mesh_form_factor_each(x, n, &mesh, order, values.data(), gradients.data(),
                                              hessians.data()));
}

/// Wraps `raddiff_mesh_form_factor_each`, returning the per-triangle results.
inline BatchResult mesh_form_factor_each(raddiff_vec3 x, raddiff_vec3 n, const raddiff_triangle_mesh &mesh,
                                         std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  BatchResult r = detail::batch_result(mesh.triangle_count, order);
  mesh_form_factor_each(x, n, mesh, order, r.values, r.gradients, r.hessians);
  return r;
}

/// Wraps `raddiff_points_solid_angle` into caller arrays sized for points.size() (checked).
inline void points_solid_angle(Span<const raddiff_vec3> points, raddiff_vec3 a, raddiff_vec3 b, raddiff_vec3 c,
                               std::uint32_t order, Span<double> values, Span<double> gradients = {},
                               Span<double> hessians = {}) {
  detail::check_batch_outputs(points.size(), order, values, gradients, hessians);
  detail::check(raddiff_points_solid_angle(points.data(), points.size(), a, b, c, order, values.data(),
                                           gradients.data(), hessians.data()));
}

/// Wraps `raddiff_points_solid_angle`, returning the per-point results.
inline BatchResult points_solid_angle(Span<const raddiff_vec3> points, raddiff_vec3 a, raddiff_vec3 b,
                                      raddiff_vec3 c, std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  BatchResult r = detail::batch_result(points.size(), order);
  points_solid_angle(points, a, b, c, order, r.values, r.gradients, r.hessians);
  return r;
}

/// Wraps `raddiff_points_form_factor` into caller arrays; `normals` holds one unit normal per
/// point (checked).
inline void points_form_factor(Span<const raddiff_vec3> points, Span<const raddiff_vec3> normals,
                               raddiff_vec3 a, raddiff_vec3 b, raddiff_vec3 c, std::uint32_t order,
                               Span<double> values, Span<double> gradients = {}, Span<double> hessians = {}) {
  detail::check_size("normals", normals.size(), points.size());
  detail::check_batch_outputs(points.size(), order, values, gradients, hessians);
  detail::check(raddiff_points_form_factor(points.data(), normals.data(), points.size(), a, b, c, order,
                                           values.data(), gradients.data(), hessians.data()));
}

/// Wraps `raddiff_points_form_factor`, returning the per-point results.
inline BatchResult points_form_factor(Span<const raddiff_vec3> points, Span<const raddiff_vec3> normals,
                                      raddiff_vec3 a, raddiff_vec3 b, raddiff_vec3 c,
                                      std::uint32_t order = RADDIFF_ORDER_HESSIAN) {
  BatchResult r = detail::batch_result(points.size(), order);
  points_form_factor(points, normals, a, b, c, order, r.values, r.gradients, r.hessians);
  return r;
}

/// m*n of a layout (the number of directions of a gather), in 64 bits.
inline std::size_t gather_size(const raddiff_gather_layout &layout) noexcept {
  return static_cast<std::size_t>(static_cast<std::uint64_t>(layout.m) * layout.n);
}

/// Wraps `raddiff_gather_directions`: writes the m*n world directions (index j*n + k) into
/// `directions`, which must hold exactly m*n (checked).
inline void gather_directions(const raddiff_gather_layout &layout, const raddiff_frame &frame,
                              Span<raddiff_vec3> directions) {
  detail::check_size("directions", directions.size(), gather_size(layout));
  detail::check(raddiff_gather_directions(&layout, &frame, directions.data()));
}

/// Wraps `raddiff_gather_directions`, returning the m*n directions (index j*n + k). A layout with
/// m*n above RADDIFF_GATHER_MAX_STRATA throws RADDIFF_ERROR_INVALID_ARGUMENT before allocating.
inline std::vector<raddiff_vec3> gather_directions(const raddiff_gather_layout &layout,
                                                   const raddiff_frame &frame) {
  if (static_cast<std::uint64_t>(layout.m) * layout.n > RADDIFF_GATHER_MAX_STRATA) {
    throw Error(RADDIFF_ERROR_INVALID_ARGUMENT, "raddiff.hpp: layout m*n exceeds RADDIFF_GATHER_MAX_STRATA");
  }
  std::vector<raddiff_vec3> directions(gather_size(layout));
  gather_directions(layout, frame, Span<raddiff_vec3>(directions));
  return directions;
}

/// What the rays of a gather found (`raddiff_gather_input` with sized arrays). With i = j*n + k:
/// `directions` and `distance` hold m*n, `radiance` m*n*channels, `media_radiance` empty or
/// m*n*steps*channels, `media_radiance_gradient` empty or m*n*steps*3*channels (all checked).
struct GatherInput {
  /// The layout's directions, as returned by gather_directions.
  Span<const raddiff_vec3> directions;
  /// Hit distances (> 0); INFINITY for a miss.
  Span<const double> distance;
  /// Radiance leaving each hit towards x, before attenuation; index i*channels + c.
  Span<const float> radiance;
  /// Values per direction (>= 1).
  std::uint32_t channels = 1;
  /// Homogeneous extinction between x and the hits (0: no medium).
  double sigma_t = 0.0;
  /// Optional in-scattered radiance along each direction (see raddiff_gather_input).
  Span<const float> media_radiance;
  /// Optional gradient of media_radiance (see raddiff_gather_input).
  Span<const float> media_radiance_gradient;
  /// Media march steps per direction.
  std::uint32_t steps = 0;
  /// Media march step length.
  double step = 0.0;
};

/// Bits selecting the outputs of gather_evaluate (the others stay empty and cost nothing).
enum GatherOutputs : unsigned {
  /// `irradiance` (channels).
  GATHER_IRRADIANCE = 1u,
  /// `gradient` (3*channels).
  GATHER_GRADIENT = 2u,
  /// `rotation_gradient` (3*channels).
  GATHER_ROTATION_GRADIENT = 4u,
  /// `occlusion_gradient` (3*channels).
  GATHER_OCCLUSION_GRADIENT = 8u,
  /// `hessian` (9*channels).
  GATHER_HESSIAN = 16u,
  /// All of the above.
  GATHER_ALL = 31u,
};

/// The outputs of gather_evaluate (`raddiff_gather_output` by value): each vector is empty unless
/// selected; layouts as in raddiff.h (`gradient[3*c + axis]`, `hessian[9*c + 3*row + col]`).
struct GatherResult {
  /// Irradiance (hemisphere layouts) or scalar fluence (sphere), per channel.
  std::vector<double> irradiance;
  /// Ward-Heckbert translational gradient (with the media terms when a medium is given).
  std::vector<double> gradient;
  /// Rotational gradient.
  std::vector<double> rotation_gradient;
  /// Occlusion-aware gradient of the triangulated environment.
  std::vector<double> occlusion_gradient;
  /// Occlusion-aware 3x3 translation Hessian per channel, row-major.
  std::vector<double> hessian;
  /// Harmonic mean of the hit distances (INFINITY if every ray missed).
  double harmonic_mean_distance = 0.0;
  /// Smallest hit distance (INFINITY if every ray missed).
  double min_distance = 0.0;
};

namespace detail {

/// The C input of a GatherInput for `layout`, after checking every array's size.
inline raddiff_gather_input gather_input(const raddiff_gather_layout &layout, const GatherInput &input) {
  const std::size_t cells = gather_size(layout);
  const std::size_t ch = input.channels;
  check_size("directions", input.directions.size(), cells);
  check_size("distance", input.distance.size(), cells);
  check_size("radiance", input.radiance.size(), mul(cells, ch));
  const std::size_t samples = mul(mul(cells, input.steps), ch);
  if (!input.media_radiance.empty()) {
    check_size("media_radiance", input.media_radiance.size(), samples);
  }
  if (!input.media_radiance_gradient.empty()) {
    check_size("media_radiance_gradient", input.media_radiance_gradient.size(), mul(samples, 3));
  }
  raddiff_gather_input in{};
  in.directions = input.directions.data();
  in.distance = input.distance.data();
  in.radiance = input.radiance.data();
  in.channels = input.channels;
  in.sigma_t = input.sigma_t;
  in.media_radiance = input.media_radiance.empty() ? nullptr : input.media_radiance.data();
  in.media_radiance_gradient =
      input.media_radiance_gradient.empty() ? nullptr : input.media_radiance_gradient.data();
  in.steps = input.steps;
  in.step = input.step;
  return in;
}

}  // namespace detail

/// Wraps `raddiff_gather_evaluate`: irradiance (or fluence) and the derivatives selected by
/// `outputs` (GatherOutputs bits) from a traced gather. Array sizes are checked first.
inline GatherResult gather_evaluate(const raddiff_gather_layout &layout, const raddiff_frame &frame,
                                    const GatherInput &input,
                                    unsigned outputs = GATHER_IRRADIANCE | GATHER_GRADIENT |
                                                       GATHER_ROTATION_GRADIENT) {
  const std::size_t ch = input.channels;
  const raddiff_gather_input in = detail::gather_input(layout, input);

  GatherResult result;
  raddiff_gather_output out{};
  // each requested output gets a buffer of its documented size; the others stay NULL (not computed)
  auto wanted = [outputs](unsigned flag, std::vector<double> &buffer, std::size_t size) -> double * {
    if (!(outputs & flag)) return nullptr;
    buffer.resize(size);
    return buffer.data();
  };
  out.irradiance = wanted(GATHER_IRRADIANCE, result.irradiance, ch);
  out.gradient = wanted(GATHER_GRADIENT, result.gradient, 3 * ch);
  out.rotation_gradient = wanted(GATHER_ROTATION_GRADIENT, result.rotation_gradient, 3 * ch);
  out.occlusion_gradient = wanted(GATHER_OCCLUSION_GRADIENT, result.occlusion_gradient, 3 * ch);
  out.hessian = wanted(GATHER_HESSIAN, result.hessian, 9 * ch);
  detail::check(raddiff_gather_evaluate(&layout, &frame, &in, &out));
  result.harmonic_mean_distance = out.harmonic_mean_distance;
  result.min_distance = out.min_distance;
  return result;
}

/// The near field at a pixel's point (`raddiff_gather_near_field`): the irradiance of the hits
/// closer than the reach, per channel, and the open fraction (share of the layout's measure whose
/// rays reach at least that far). The pixel's irradiance is `irradiance[c] + open_fraction * F[c]`
/// with F the far field interpolated from far-field records at the same reach.
struct NearField {
  /// Irradiance (fluence for the sphere layout) from hits closer than the reach, per channel.
  std::vector<double> irradiance;
  /// In [0, 1].
  double open_fraction = 0.0;
};

/// Wraps `raddiff_gather_near_field`: `distance` (m*n) and `radiance` (m*n*channels) of the
/// layout's directions traced no farther than `reach` (sizes checked).
inline NearField gather_near_field(const raddiff_gather_layout &layout, Span<const double> distance,
                                   Span<const float> radiance, std::uint32_t channels, double reach) {
  const std::size_t cells = gather_size(layout);
  detail::check_size("distance", distance.size(), cells);
  detail::check_size("radiance", radiance.size(), detail::mul(cells, channels));
  NearField f;
  f.irradiance.resize(channels);
  detail::check(raddiff_gather_near_field(&layout, distance.data(), radiance.data(), channels, reach,
                                          f.irradiance.data(), &f.open_fraction));
  return f;
}

/// Wraps `raddiff_gather_far_field_radiance`: replaces, in place, the radiance of the hits closer
/// than `reach` by the mean radiance of the directions that reach farther, so that evaluating the
/// gather gives the far field; returns the open fraction (sizes checked; `radiance` unchanged on
/// failure).
inline double gather_far_field_radiance(const raddiff_gather_layout &layout, Span<const double> distance,
                                        Span<float> radiance, std::uint32_t channels, double reach) {
  const std::size_t cells = gather_size(layout);
  detail::check_size("distance", distance.size(), cells);
  detail::check_size("radiance", radiance.size(), detail::mul(cells, channels));
  double open = 0.0;
  detail::check(
      raddiff_gather_far_field_radiance(&layout, distance.data(), radiance.data(), channels, reach, &open));
  return open;
}

/// Wraps `raddiff_gather_far_field`: as gather_far_field_radiance, and the hits closer than
/// `reach` move to the reach (`distance` written), so that the far field's derivatives and radii
/// see only the far geometry; returns the open fraction (sizes checked; nothing changed on failure).
inline double gather_far_field(const raddiff_gather_layout &layout, Span<double> distance, Span<float> radiance,
                               std::uint32_t channels, double reach) {
  const std::size_t cells = gather_size(layout);
  detail::check_size("distance", distance.size(), cells);
  detail::check_size("radiance", radiance.size(), detail::mul(cells, channels));
  double open = 0.0;
  detail::check(raddiff_gather_far_field(&layout, distance.data(), radiance.data(), channels, reach, &open));
  return open;
}

/// An elliptical surface record: `radii[0] <= radii[1]` along the world-space unit tangents `axes`.
struct SurfaceRadii {
  /// Semi-axes (caller's length unit; RADDIFF_MAX_RADIUS at most).
  std::array<double, 2> radii;
  /// Their directions.
  std::array<raddiff_vec3, 2> axes;
};

/// An ellipsoidal media record: `radii[0] <= radii[1] <= radii[2]` along the orthonormal `axes`.
struct VolumeRadii {
  /// Semi-axes (caller's length unit; RADDIFF_MAX_RADIUS at most).
  std::array<double, 3> radii;
  /// Their directions.
  std::array<raddiff_vec3, 3> axes;
};

/// Wraps `raddiff_surface_radii`: `hessian` is the 3x3 row-major Hessian (9 doubles, checked),
/// `mode` RADDIFF_ERROR_ABSOLUTE or RADDIFF_ERROR_RELATIVE.
inline SurfaceRadii surface_radii(Span<const double> hessian, raddiff_vec3 normal, double value, double error,
                                  std::uint32_t mode, double max_anisotropy) {
  detail::check_size("hessian", hessian.size(), 9);
  SurfaceRadii r{};
  detail::check(raddiff_surface_radii(hessian.data(), normal, value, error, mode, max_anisotropy, r.radii.data(),
                                      r.axes.data()));
  return r;
}

/// Wraps `raddiff_surface_radii_floored`: surface_radii with the curvature floor
/// `floor_weight * |value| / floor_distance^2` (floor_distance: the gather's harmonic-mean hit
/// distance; floor_weight: RADDIFF_CURVATURE_FLOOR_WEIGHT by default, 0 for none).
inline SurfaceRadii surface_radii_floored(Span<const double> hessian, raddiff_vec3 normal, double value,
                                          double error, std::uint32_t mode, double max_anisotropy,
                                          double floor_distance,
                                          double floor_weight = RADDIFF_CURVATURE_FLOOR_WEIGHT) {
  detail::check_size("hessian", hessian.size(), 9);
  SurfaceRadii r{};
  detail::check(raddiff_surface_radii_floored(hessian.data(), normal, value, error, mode, max_anisotropy,
                                              floor_distance, floor_weight, r.radii.data(), r.axes.data()));
  return r;
}

/// Wraps `raddiff_volume_radii`: ellipsoid from the 3x3 row-major Hessian (9 doubles, checked).
inline VolumeRadii volume_radii(Span<const double> hessian, double value, double error, std::uint32_t mode,
                                double max_anisotropy) {
  detail::check_size("hessian", hessian.size(), 9);
  VolumeRadii r{};
  detail::check(
      raddiff_volume_radii(hessian.data(), value, error, mode, max_anisotropy, r.radii.data(), r.axes.data()));
  return r;
}

/// Wraps `raddiff_single_scatter`: single-scattered radiance arriving at `entry` along the refracted
/// eye segment entry -> exit inside `mesh`, from a point light of intensity `intensity` (power per
/// steradian) at `light`; radiance inside the medium, before refraction out (see raddiff.h).
inline double single_scatter(const RefractiveMesh &mesh, const raddiff_medium &medium, raddiff_vec3 entry,
                             raddiff_vec3 exit, raddiff_vec3 light, double intensity) {
  double radiance = 0.0;
  detail::check(raddiff_single_scatter(mesh.get(), &medium, entry, exit, light, intensity, &radiance));
  return radiance;
}

/// Wraps `raddiff_irradiance_settings_default`: the library's default irradiance settings (3
/// channels, the anisotropic occlusion-aware Hessian, a 32 x 128 gather, 1 to 150 pixel radii,
/// the default safeguards).
inline raddiff_irradiance_settings irradiance_settings_default() { return raddiff_irradiance_settings_default(); }

/// Owner of a `raddiff_gather_evaluation`: a traced gather evaluated once, from which records of
/// any metric and threshold are built (the mid-level calls; `IrradianceCache` does all of it in
/// one call). Immutable: threads may share it.
class GatherEvaluation : public detail::Owner<raddiff_gather_evaluation> {
 public:
  /// Wraps `raddiff_gather_evaluation_new`: `settings` gives the channels and their weights,
  /// `hit_normals` (empty: none) the unit normal at every hit for the unaware and geometric
  /// Hessians, `hessians` the RADDIFF_HESSIAN_* bits. Array sizes are checked first; a NULL from
  /// C throws raddiff::Error with its message.
  GatherEvaluation(const raddiff_irradiance_settings &settings, const raddiff_gather_layout &layout,
                   const raddiff_frame &frame, const GatherInput &input,
                   Span<const raddiff_vec3> hit_normals = {}, std::uint32_t hessians = 0)
      : Owner(create(settings, layout, frame, input, hit_normals, hessians)) {}

  /// Wraps `raddiff_gather_evaluation_summary`: scalar, gradient, distance and Hessians.
  raddiff_gather_summary summary() const {
    raddiff_gather_summary s{};
    detail::check(raddiff_gather_evaluation_summary(get(), &s));
    return s;
  }

  /// Wraps `raddiff_irradiance_record`: the record of this gather under `settings` at the pixel
  /// `footprint` (0: unknown), ready for Cache::insert; its arrays point into this evaluation.
  raddiff_cache_record record(const raddiff_irradiance_settings &settings, double footprint) const {
    raddiff_cache_record r{};
    detail::check(raddiff_irradiance_record(&settings, get(), footprint, &r));
    return r;
  }

 private:
  static raddiff_gather_evaluation *create(const raddiff_irradiance_settings &settings,
                                           const raddiff_gather_layout &layout, const raddiff_frame &frame,
                                           const GatherInput &input, Span<const raddiff_vec3> hit_normals,
                                           std::uint32_t hessians) {
    const raddiff_gather_input in = detail::gather_input(layout, input);
    if (!hit_normals.empty()) detail::check_size("hit_normals", hit_normals.size(), gather_size(layout));
    return detail::check_handle(raddiff_gather_evaluation_new(&settings, &layout, &frame, &in,
                                                              hit_normals.empty() ? nullptr : hit_normals.data(),
                                                              hessians));
  }
};

namespace detail {

/// What the C trampoline of IrradianceCache::irradiance needs: the caller's callable, the channel
/// count, and the exception it threw (kept to be rethrown once the C call has returned).
template <class Trace>
struct TraceCall {
  Trace *trace;
  std::size_t channels;
  std::exception_ptr error;
};

/// The raddiff_trace_fn of IrradianceCache::irradiance: calls the C++ callable; an exception
/// never crosses the C boundary (it is kept and reported as a non-zero return).
template <class Trace>
int trace_trampoline(void *user, raddiff_vec3 origin, const raddiff_vec3 *directions, std::size_t count,
                     double *distance, float *radiance) noexcept {
  auto *call = static_cast<TraceCall<Trace> *>(user);
  try {
    (*call->trace)(origin, Span<const raddiff_vec3>(directions, count), Span<double>(distance, count),
                   Span<float>(radiance, mul(count, call->channels)));
    return 0;
  } catch (...) {
    call->error = std::current_exception();
    return 1;
  }
}

/// The raddiff_trace_bounded_fn of IrradianceCache::irradiance_near_far, as trace_trampoline.
template <class Trace>
int trace_bounded_trampoline(void *user, raddiff_vec3 origin, const raddiff_vec3 *directions, std::size_t count,
                             double max_distance, double *distance, float *radiance) noexcept {
  auto *call = static_cast<TraceCall<Trace> *>(user);
  try {
    (*call->trace)(origin, Span<const raddiff_vec3>(directions, count), max_distance, Span<double>(distance, count),
                   Span<float>(radiance, mul(count, call->channels)));
    return 0;
  } catch (...) {
    call->error = std::current_exception();
    return 1;
  }
}

}  // namespace detail

/// What IrradianceCache::irradiance_near_far_parts returns: the irradiance E_near + V * F and the
/// query's near field (its near irradiance E_near per channel and its open fraction V in [0, 1]).
struct NearFarParts {
  std::vector<float> value;
  std::vector<double> near_irradiance;
  double open_fraction = 0;
};

/// A radiance cache filled one shading point at a time (`raddiff_cache_irradiance`), with the
/// settings it was made for (copied, channel weights included). Thread-safe like Cache.
class IrradianceCache {
 public:
  /// Wraps `raddiff_irradiance_cache_new`: an empty cache for `settings` (invalid settings throw).
  explicit IrradianceCache(const raddiff_irradiance_settings &settings)
      : weights_(weights_of(settings)),
        settings_(with_weights(settings, weights_)),
        cache_(Cache::adopt(raddiff_irradiance_cache_new(&settings_))) {}

  /// Uses `cache` (e.g. Cache::load of a saved IrradianceCache) with `settings`; the first miss
  /// checks that they agree (channels, gradient limit, leak guard; near/far queries check the
  /// far-field reach at every call).
  IrradianceCache(Cache cache, const raddiff_irradiance_settings &settings)
      : weights_(weights_of(settings)), settings_(with_weights(settings, weights_)), cache_(std::move(cache)) {}

  /// Wraps `raddiff_cache_irradiance`: the irradiance at `x` (normal `n`, pixel footprint
  /// `footprint`, 0 if unknown) into `out` (`channels` floats, checked). On a miss it calls
  /// `trace(origin, directions, distance, radiance)` once with Span<const raddiff_vec3>,
  /// Span<double> and Span<float> (`channels` per ray); an exception thrown by `trace` abandons
  /// the request (nothing inserted) and is rethrown here, after the C call has returned.
  template <class Trace>
  void irradiance(raddiff_vec3 x, raddiff_vec3 n, double footprint, Trace &&trace, Span<float> out) {
    detail::check_size("out", out.size(), settings_.channels);
    using Callable = std::remove_reference_t<Trace>;
    detail::TraceCall<Callable> call{&trace, settings_.channels, nullptr};
    const raddiff_status status = raddiff_cache_irradiance(cache_.get(), &settings_, x, n, footprint,
                                                           &detail::trace_trampoline<Callable>, &call, out.data());
    if (call.error) std::rethrow_exception(call.error);
    detail::check(status);
  }

  /// irradiance() returning the `channels` values.
  template <class Trace>
  std::vector<float> irradiance(raddiff_vec3 x, raddiff_vec3 n, double footprint, Trace &&trace) {
    std::vector<float> out(settings_.channels);
    irradiance(x, n, footprint, std::forward<Trace>(trace), Span<float>(out));
    return out;
  }

  /// Wraps `raddiff_cache_irradiance_near_far` (settings with a near-field reach): the irradiance
  /// E_near + V * F at `x` into `out` (`channels` floats, checked). Calls
  /// `trace(origin, directions, max_distance, distance, radiance)` once (unless the arguments are
  /// refused first): with the near rays and the reach when a record covers `x`, with the record's
  /// gather and INFINITY on a miss; with the settings' open-fraction tolerance finite, the near
  /// rays come first and a miss traces the gather too (twice). Rays that find nothing closer than
  /// `max_distance` get INFINITY. Exceptions as irradiance().
  template <class Trace>
  void irradiance_near_far(raddiff_vec3 x, raddiff_vec3 n, double footprint, Trace &&trace, Span<float> out) {
    detail::check_size("out", out.size(), settings_.channels);
    using Callable = std::remove_reference_t<Trace>;
    detail::TraceCall<Callable> call{&trace, settings_.channels, nullptr};
    const raddiff_status status =
        raddiff_cache_irradiance_near_far(cache_.get(), &settings_, x, n, footprint,
                                          &detail::trace_bounded_trampoline<Callable>, &call, out.data());
    if (call.error) std::rethrow_exception(call.error);
    detail::check(status);
  }

  /// irradiance_near_far() returning the `channels` values.
  template <class Trace>
  std::vector<float> irradiance_near_far(raddiff_vec3 x, raddiff_vec3 n, double footprint, Trace &&trace) {
    std::vector<float> out(settings_.channels);
    irradiance_near_far(x, n, footprint, std::forward<Trace>(trace), Span<float>(out));
    return out;
  }

  /// Wraps `raddiff_cache_irradiance_near_far_parts`: irradiance_near_far(), also returning the
  /// query's near field (E_near, `channels` values, and the open fraction V). A renderer keeps
  /// them from the call that filled a pixel and shows E_near + V * F later with F from
  /// cache().lookup() on the finished cache, without tracing again.
  template <class Trace>
  NearFarParts irradiance_near_far_parts(raddiff_vec3 x, raddiff_vec3 n, double footprint, Trace &&trace) {
    NearFarParts parts;
    parts.value.resize(settings_.channels);
    parts.near_irradiance.resize(settings_.channels);
    using Callable = std::remove_reference_t<Trace>;
    detail::TraceCall<Callable> call{&trace, settings_.channels, nullptr};
    const raddiff_status status = raddiff_cache_irradiance_near_far_parts(
        cache_.get(), &settings_, x, n, footprint, &detail::trace_bounded_trampoline<Callable>, &call,
        parts.value.data(), parts.near_irradiance.data(), &parts.open_fraction);
    if (call.error) std::rethrow_exception(call.error);
    detail::check(status);
    return parts;
  }

  /// The settings (their channel_weights point into this object).
  const raddiff_irradiance_settings &settings() const noexcept { return settings_; }
  /// The cache (lookups, save, compact, ...).
  Cache &cache() noexcept { return cache_; }
  /// The cache (lookups, save, ...).
  const Cache &cache() const noexcept { return cache_; }

 private:
  static std::vector<double> weights_of(const raddiff_irradiance_settings &s) {
    if (s.channel_weights == nullptr) return {};
    return std::vector<double>(s.channel_weights, s.channel_weights + s.channels);
  }
  static raddiff_irradiance_settings with_weights(raddiff_irradiance_settings s, const std::vector<double> &w) {
    s.channel_weights = w.empty() ? nullptr : w.data();
    return s;
  }

  std::vector<double> weights_;
  raddiff_irradiance_settings settings_;
  Cache cache_;
};

}  // namespace raddiff

#endif  // RADDIFF_HPP
