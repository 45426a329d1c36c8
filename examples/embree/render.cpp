#include "render.hpp"

#include "image.hpp"
#include "metrics.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace rd {
namespace {

// What raddiff_cache_irradiance's callback needs: the scene and how radiance is estimated.
struct TraceContext {
  const Scene *scene;
  const HitRadianceSettings *radiance;
  std::atomic<uint64_t> rays{0};
};

// raddiff_trace_bounded_fn (raddiff_cache_irradiance_near_far): traces the batch with Embree, rays
// stopping at `max_distance` (the near field's short rays; INFINITY for a record's gather). The hit
// radiance's samples are seeded from the origin, so that a gather is the same whichever thread asks
// for it.
int trace_bounded_callback(void *user, raddiff_vec3 origin, const raddiff_vec3 *directions, size_t count,
                           double max_distance, double *distance, float *radiance) {
  auto *ctx = static_cast<TraceContext *>(user);
  try {
    uint64_t seed = 0, rays = 0;
    for (double c : {origin.x, origin.y, origin.z}) {
      uint64_t bits;
      std::memcpy(&bits, &c, sizeof bits);
      seed = mix(seed ^ bits);
    }
    trace_directions(*ctx->scene, *ctx->radiance, from_c(origin), directions, count, seed, distance, radiance, rays,
                     nullptr, max_distance);
    ctx->rays += rays;
    return 0;
  } catch (...) {
    return 1;  // no exception crosses raddiff's C boundary: the call reports RADDIFF_ERROR_CALLBACK
  }
}

// raddiff_trace_fn (raddiff_cache_irradiance): the whole gather, rays as far as they go.
int trace_callback(void *user, raddiff_vec3 origin, const raddiff_vec3 *directions, size_t count, double *distance,
                   float *radiance) {
  return trace_bounded_callback(user, origin, directions, count, INFINITY, distance, radiance);
}

bool near_field_on(const raddiff_irradiance_settings &s) {
  return s.near_field_reach_pixels > 0 || s.near_field_reach_world > 0;
}

// A pixel's near field as its fill call found it: E_near + V * F is its irradiance for any far
// field F, so the render passes need no ray. `valid` is false until a call succeeded.
struct NearParts {
  double irradiance[3] = {0, 0, 0};
  double open_fraction = 0;
  bool valid = false;
};

// One shading point through the one-call API: raddiff_cache_irradiance, or with a near-field reach
// raddiff_cache_irradiance_near_far_parts (every call traces the pixel's near rays, a miss its
// gather), keeping the pixel's near field in `*parts` (not NULL with a near-field reach).
raddiff_status shade_pixel(raddiff_cache *cache, const raddiff_irradiance_settings &s, TraceContext &ctx,
                           const Primary &px, float *e, NearParts *parts) {
  if (!near_field_on(s))
    return raddiff_cache_irradiance(cache, &s, to_c(px.p), to_c(px.n), px.footprint, trace_callback, &ctx, e);
  const raddiff_status st =
      raddiff_cache_irradiance_near_far_parts(cache, &s, to_c(px.p), to_c(px.n), px.footprint, trace_bounded_callback,
                                              &ctx, e, parts->irradiance, &parts->open_fraction);
  parts->valid = st == RADDIFF_OK;
  return st;
}

raddiff_irradiance_settings settings_of(const RenderSettings &cfg) {
  raddiff_irradiance_settings s = cfg.irradiance;
  s.metric = cfg.hessian_error > 0 ? RADDIFF_METRIC_HESSIAN_ANISOTROPIC : RADDIFF_METRIC_SPLIT_SPHERE;
  s.accuracy = cfg.hessian_error > 0 ? cfg.hessian_error : cfg.accuracy;
  return s;
}

struct Fill {
  raddiff_cache *cache = nullptr;
  // per pixel, with a near-field reach: the near field of the call that filled it
  std::vector<NearParts> near;
  size_t records = 0;
  uint64_t rays = 0;
  double seconds = 0;
  size_t shrunk = 0;
  int finest_rounds = 0;
};

constexpr int kClampRounds = 3;

// The miss path by hand, for neighbour clamping (which needs the record before its insert): trace,
// evaluate, build the record, clamp it to its neighbours, insert.
void insert_clamped(raddiff_cache *cache, const raddiff_irradiance_settings &s, const Scene &scene,
                    TraceContext &ctx, const Primary &px, uint64_t seed) {
  const TracedGather g = trace_gather(scene, *ctx.radiance, px.p, px.n, s.gather_m, s.gather_n, seed);
  ctx.rays += g.rays;
  HessianNeeds needs;
  needs.kind[0] = s.metric != RADDIFF_METRIC_HESSIAN_ANISOTROPIC;
  needs.kind[1] = !needs.kind[0];
  const Evaluated e = evaluate_gather(g, needs, s);
  if (!e.valid) return;
  raddiff_cache_record record{};
  if (!metric_record(s.metric == RADDIFF_METRIC_HESSIAN_ANISOTROPIC ? Metric::HessianAnisotropic : Metric::SplitSphere,
                     s.accuracy, e, s, px.footprint, record))
    return;
  check(raddiff_cache_clamp_record(cache, &record), "raddiff_cache_clamp_record");
  check(raddiff_cache_insert(cache, &record), "raddiff_cache_insert");
}

// Fills a fresh cache coarse to fine (pixel steps 16, 8, ..., 1); all threads look up and insert
// concurrently, one raddiff_cache_irradiance call per pixel. With neighbour clamping the two-sided
// pass (raddiff_cache_clamp_neighbours, single-threaded) runs after each level; it can uncover
// pixels, so the finest level is repeated until a round inserts nothing, the last allowed round
// filling only.
Fill fill_cache(const Scene &scene, const RenderSettings &cfg, const View &view, const std::vector<Primary> &primary) {
  using clock = std::chrono::steady_clock;
  const raddiff_irradiance_settings s = settings_of(cfg);
  Fill out;
  out.cache = raddiff_irradiance_cache_new(&s);
  if (!out.cache) throw std::runtime_error(std::string("raddiff_irradiance_cache_new: ") + raddiff_last_error());
  raddiff_cache *cache = out.cache;
  check(raddiff_cache_set_open_fraction_coverage_tolerance(cache, cfg.open_fraction_coverage_tolerance),
        "raddiff_cache_set_open_fraction_coverage_tolerance");
  if (near_field_on(s)) out.near.resize(primary.size());
  try {
    TraceContext ctx{&scene, &cfg.radiance};
    std::atomic<size_t> inserted{0};
    auto shade = [&](size_t i) {
      const Primary &px = primary[i];
      if (!px.hit) return;
      const size_t before = cfg.neighbour_clamp ? 0 : raddiff_cache_len(cache);
      if (cfg.neighbour_clamp) {
        float v[3];
        const raddiff_status st = raddiff_cache_lookup(cache, to_c(px.p), to_c(px.n), v, nullptr);
        if (st == RADDIFF_OK) return;
        if (st != RADDIFF_ERROR_NOT_FOUND) check(st, "raddiff_cache_lookup");
        insert_clamped(cache, s, scene, ctx, px, 1 + i);
        ++inserted;
        return;
      }
      float e[3];
      const raddiff_status st = shade_pixel(cache, s, ctx, px, e, out.near.empty() ? nullptr : &out.near[i]);
      if (st != RADDIFF_ERROR_DEGENERATE) check(st, "raddiff_cache_irradiance");  // degenerate: every ray missed
      if (raddiff_cache_len(cache) > before) ++inserted;
    };
    const int w = view.width, h = view.height;
    std::vector<size_t> all(primary.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = i;
    const auto t0 = clock::now();
    int step = 16;
    for (;;) {
      const std::vector<size_t> level = out.finest_rounds == 0 ? level_pixels(w, h, step) : all;
      inserted = 0;
      parallel_for(level.size(), cfg.threads, [&](size_t k) { shade(level[k]); });
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
      if (!cfg.neighbour_clamp || inserted == 0 || last_round) break;
    }
    out.seconds = std::chrono::duration<double>(clock::now() - t0).count();
    out.records = raddiff_cache_len(cache);
    out.rays = ctx.rays.load();
  } catch (...) {
    raddiff_cache_free(cache);
    throw;
  }
  return out;
}

double &tuned_parameter(RenderSettings &cfg) { return cfg.hessian_error > 0 ? cfg.hessian_error : cfg.accuracy; }

Fill tune(const Scene &scene, RenderSettings &cfg, const View &view, const std::vector<Primary> &primary) {
  const double target = static_cast<double>(cfg.target_records);
  const char *name = cfg.hessian_error > 0 ? "hessian e" : "accuracy a";
  double p = tuned_parameter(cfg);
  double k = cfg.hessian_error > 0 ? 0.5 : 2.0;
  double too_many = 0, too_few = 0;
  double last_p = 0, last_n = 0;
  Fill best;
  double best_p = p, best_miss = INFINITY, seconds = 0;
  int fills = 0;
  for (; fills < 10; ++fills) {
    RenderSettings trial = cfg;
    tuned_parameter(trial) = p;
    Fill f = fill_cache(scene, trial, view, primary);
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
    if (last_p > 0 && last_p != p && last_n > 0 && n > 0 && last_n != n)
      k = std::clamp(std::log(last_n / n) / std::log(p / last_p), 0.1, 10.0);
    last_p = p, last_n = n;
    p = too_many > 0 && too_few > 0 ? std::sqrt(too_many * too_few) : p * std::pow(std::max(n, 1.0) / target, 1.0 / k);
  }
  tuned_parameter(cfg) = best_p;
  const bool hit = std::abs(static_cast<double>(best.records) / target - 1) <= 0.05;
  std::printf("tuned: %s = %.5g, %zu records for %zu wanted (%s), %d fills, %.2f s\n", name, best_p, best.records,
              cfg.target_records, hit ? "within 5%" : "NOT within 5%", fills, seconds);
  return best;
}

}  // namespace

int run_render(const Scene &scene, const View &view, const RenderSettings &settings) {
  using clock = std::chrono::steady_clock;
  const Camera camera(view);
  const std::vector<Primary> primary = primary_hits(scene, camera, settings.threads);
  const int w = view.width, h = view.height;

  RenderSettings used = settings;
  const Fill filled = settings.target_records > 0 ? tune(scene, used, view, primary)
                                                  : fill_cache(scene, used, view, primary);
  raddiff_cache *cache = filled.cache;
  std::printf("placement: %s = %.5g, gradient limit %g, neighbour clamp %s\n",
              used.hessian_error > 0 ? "hessian e" : "split sphere a", tuned_parameter(used),
              used.irradiance.gradient_limit, used.neighbour_clamp ? "on" : "off");
  if (settings.neighbour_clamp)
    std::printf("neighbour clamp: %zu records shrunk by the two-sided passes, %d finest-level rounds\n",
                filled.shrunk, filled.finest_rounds);
  if (near_field_on(used.irradiance))
    std::printf("near field: reach %g px, %u x %u rays per pixel; records hold far fields\n",
                used.irradiance.near_field_reach_pixels, used.irradiance.near_field_m, used.irradiance.near_field_n);
  if (near_field_on(used.irradiance) && std::isfinite(used.irradiance.near_field_open_fraction_tolerance))
    std::printf("open-fraction test: records used only at pixels whose open fraction is within %g of theirs%s\n",
                used.irradiance.near_field_open_fraction_tolerance,
                settings.open_fraction_coverage_tolerance > used.irradiance.near_field_open_fraction_tolerance
                    ? " (or, where none is, the refused ones within the coverage tolerance)"
                    : "");
  if (used.irradiance.lookup_radius_scale != 1)
    std::printf("lookup radius scale: records read over %g times their radii, misses decided at their own\n",
                used.irradiance.lookup_radius_scale);
  if (used.irradiance.derivative_smoothing_azimuthal > 0 || used.irradiance.derivative_smoothing_polar > 0)
    std::printf("derivative smoothing: %u azimuthal and %u polar passes over the strata, values from the raw ones\n",
                used.irradiance.derivative_smoothing_azimuthal, used.irradiance.derivative_smoothing_polar);

  // Render through a per-thread cursor, or with plain lookups (the library keeps a cursor per
  // thread). Both give the same bits; pass 2 uses the other one, so its check covers that too.
  struct Cursor {
    raddiff_cache_cursor *p = raddiff_cache_cursor_new();
    ~Cursor() { raddiff_cache_cursor_free(p); }
  };
  // With a near field a pixel shows E_near + V * F: its near field as its fill call found it, the
  // far field F looked up in the finished cache. No ray is traced.
  const std::vector<NearParts> &near = filled.near;
  auto render = [&](raddiff_cache *c, bool use_cursor, size_t &misses) {
    Image image(w, h);
    std::atomic<size_t> miss{0};
    parallel_for(primary.size(), settings.threads, [&](size_t i) {
      if (!primary[i].hit) return;
      if (!near.empty() && !near[i].valid) return;  // its fill call found no value (every ray missed)
      thread_local Cursor cursor;
      float *value = image.at(i);
      const raddiff_vec3 p = to_c(primary[i].p), n = to_c(primary[i].n);
      // with a near field the lookup passes the pixel's open fraction: the cache's open-fraction
      // test, if it has one, needs it (without one, the same bits as the plain lookup)
      const raddiff_status st =
          !near.empty() ? raddiff_cache_lookup_open(c, use_cursor ? cursor.p : nullptr, p, n, near[i].open_fraction,
                                                    value, nullptr)
          : use_cursor  ? raddiff_cache_lookup_with(c, cursor.p, p, n, value, nullptr)
                        : raddiff_cache_lookup(c, p, n, value, nullptr);
      if (st == RADDIFF_ERROR_NOT_FOUND) {
        ++miss;
        return;
      }
      check(st, "raddiff_cache_lookup");
      if (!near.empty())
        for (int k = 0; k < 3; ++k)
          value[k] = static_cast<float>(near[i].irradiance[k] + near[i].open_fraction * value[k]);
    });
    misses = miss.load();
    return image;
  };
  size_t misses1 = 0;
  check(raddiff_cache_compact(cache), "raddiff_cache_compact");
  const size_t records = raddiff_cache_len(cache);
  const auto t1 = clock::now();
  const Image first = render(cache, true, misses1);
  const double render_seconds = std::chrono::duration<double>(clock::now() - t1).count();
  std::printf("pass 1: %zu records, %.2f Mrays, fill %.2f s, render %.3f s, %zu uncovered pixels\n", records,
              filled.rays * 1e-6, filled.seconds, render_seconds, misses1);
  write_images(settings.out + "-irradiance", first);

  const std::string file = settings.out + ".rdc";
  check(raddiff_cache_save(cache, file.c_str()), "raddiff_cache_save");
  raddiff_cache_free(cache);
  raddiff_cache *loaded = raddiff_cache_load(file.c_str());
  if (!loaded) throw std::runtime_error(std::string("raddiff_cache_load: ") + raddiff_last_error());
  size_t misses2 = 0;
  const Image second = render(loaded, false, misses2);
  const bool same = raddiff_cache_len(loaded) == records && misses2 == misses1 &&
                    std::memcmp(first.rgb.data(), second.rgb.data(), first.rgb.size() * sizeof(float)) == 0;
  std::printf("pass 2 (reloaded %s, plain lookups): %zu records, images %s\n", file.c_str(),
              raddiff_cache_len(loaded), same ? "identical" : "DIFFER");

  // Accuracy, for information: the cache against fresh gathers with 4x the strata per axis at
  // some pixels. Those gathers carry their own noise, so this is not a pass/fail figure; the
  // real-scene benchmark (--bench) measures against a converged reference.
  const uint32_t m = 4 * settings.irradiance.gather_m, n = 4 * settings.irradiance.gather_n;
  double err2 = 0, ref2 = 0;
  int checked = 0;
  for (int k = 0; k < settings.check_pixels; ++k) {
    const size_t i = mix(0xC0FFEE + k) % primary.size();
    if (!primary[i].hit) continue;
    const TracedGather g = trace_gather(scene, settings.radiance, primary[i].p, primary[i].n, m, n, 7 + i);
    raddiff_gather_input input{};
    input.directions = g.directions.data();
    input.distance = g.distance.data();
    input.radiance = g.radiance.data();
    input.channels = 3;
    double irradiance[3];
    raddiff_gather_output output{};
    output.irradiance = irradiance;
    const raddiff_status st = raddiff_gather_evaluate(&g.layout, &g.frame, &input, &output);
    if (st == RADDIFF_ERROR_DEGENERATE) continue;
    check(st, "raddiff_gather_evaluate");
    const double e = luminance(second.at(i)) - luminance(irradiance);
    err2 += e * e;
    ref2 += luminance(irradiance) * luminance(irradiance);
    ++checked;
  }
  const double rel_rms = checked ? std::sqrt(err2 / std::max(ref2, 1e-300)) : 0.0;
  std::printf("check: relative RMS error of the cache against %d fresh %ux%u gathers: %.4f\n", checked, m, n, rel_rms);
  raddiff_cache_free(loaded);

  size_t non_finite = 0, negative = 0;
  for (float v : first.rgb) {
    non_finite += !std::isfinite(v);
    negative += v < 0;
  }
  std::printf("values: %zu non-finite, %zu negative of %zu\n", non_finite, negative, first.rgb.size());
  // Correctness, on any scene: records exist, every pixel is covered, the values are finite and
  // non-negative, the reloaded cache renders the identical image. Quality is the benchmark's.
  const bool ok = same && misses1 == 0 && records > 0 && (settings.check_pixels == 0 || checked > 0) &&
                  non_finite == 0 && negative == 0;
  std::printf("%s\n", ok ? "OK" : "FAILED");
  return ok ? 0 : 1;
}

}  // namespace rd
