#include "bench.hpp"

#include "fill.hpp"
#include "fill_experiments.hpp"
#include "gather_store.hpp"
#include "image.hpp"
#include "pathtrace.hpp"

#include <sys/resource.h>

#include <array>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>

namespace rd {
namespace {

class Bench {
 public:
  Bench(const Scene &scene, const View &view, const BenchSettings &settings)
      : scene_(scene),
        view_(view),
        settings_(settings),
        camera_(view),
        primary_(primary_hits(scene, camera_, settings.threads)),
        store_(scene, primary_, settings_, hessian_needs(settings.metrics)),
        fill_inputs_{settings_, primary_, view_.width, view_.height, store_,
                     [this]() -> const NearFields & {
                       near_field();
                       return near_;
                     }} {}

  const std::vector<Primary> &primary() const { return primary_; }
  const Camera &camera() const { return camera_; }
  GatherStore &store() { return store_; }

  // The binned far-field experiment's per-pixel open_bins (empty without it), filled with near_field().
  const std::vector<std::array<float, kDirBins>> &near_bins() {
    near_field();
    return near_.bins;
  }

  // The near-field experiment: every pixel's near irradiance (RGB) and open fraction, traced once
  // and shared by every fill, and what that cost in CPU seconds.
  const std::vector<std::array<float, 4>> &near_field() {
    if (!near_.near.empty() || settings_.near_field_px <= 0) return near_.near;
    near_.near.assign(primary_.size(), {0, 0, 0, 1});
    if (settings_.far_field_bins) near_.bins.assign(primary_.size(), {});
    CpuSum cpu;
    const size_t w = static_cast<size_t>(view_.width);
    parallel_for(static_cast<size_t>(view_.height), settings_.threads, [&](size_t row) {
      const double t0 = thread_cpu_seconds();
      for (size_t i = row * w; i < (row + 1) * w; ++i) {
        const Primary &px = primary_[i];
        if (!px.hit) continue;
        uint64_t rays = 0;
        const NearField f = trace_near_field(scene_, settings_.radiance, px.p, px.n,
                                             settings_.near_field_px * px.footprint, settings_.near_field_m,
                                             reseeded(mix(i) ^ 0x6e656172ull, settings_.noise_seed), rays);
        near_.near[i] = {static_cast<float>(f.near[0]), static_cast<float>(f.near[1]), static_cast<float>(f.near[2]),
                    static_cast<float>(f.open_fraction)};
        if (settings_.far_field_bins)
          std::copy(std::begin(f.open_bins), std::end(f.open_bins), near_.bins[i].begin());
      }
      cpu.add(thread_cpu_seconds() - t0);
    });
    near_.seconds = cpu.total();
    std::printf("near field: %u x %u rays of %.3g pixels' reach per pixel, %.2f CPU s\n", settings_.near_field_m,
                settings_.near_field_m, settings_.near_field_px, near_.seconds);
    std::fflush(stdout);
    return near_.near;
  }

  // Fills a fresh cache for metric m with parameter p (see fill_bench_cache).
  BenchFill fill(Metric m, double p, bool render) { return fill_bench_cache(fill_inputs_, m, p, render); }

  // Tunes metric m's parameter until the record count is within 5% of `target` (at most 14
  // fills): power-law jumps until the target is bracketed, then bisection in log space.
  double tune(Metric m, size_t target) {
    double p = initial_parameter(m);
    double k = 2 * radius_exponent(m);  // records ~ p^-k: area per record ~ radius^2
    double too_many = 0, too_few = 0, last_p = 0, last_n = 0, best_p = p, best_miss = INFINITY;
    for (int fills = 0; fills < 14; ++fills) {
      const BenchFill f = fill(m, p, false);
      const double n = static_cast<double>(f.records.size());
      const double miss = std::abs(std::log(std::max(n, 1.0) / target));
      std::printf("  tune %s: p = %.5g -> %zu records (%zu gathers so far)\n", metric_name(m), p, f.records.size(),
                  store_.computed());
      std::fflush(stdout);
      if (miss < best_miss) best_p = p, best_miss = miss;
      if (std::abs(n / target - 1) <= 0.05) break;
      if (n > target) {
        too_many = std::max(too_many, p);
      } else {
        too_few = too_few > 0 ? std::min(too_few, p) : p;
      }
      if (last_p > 0 && last_p != p && last_n > 0 && n > 0 && last_n != n)
        k = std::clamp(std::log(last_n / n) / std::log(p / last_p), 0.05, 10.0);
      last_p = p, last_n = n;
      if (too_many > 0 && too_few > 0) {
        p = std::sqrt(too_many * too_few);
      } else {
        p *= std::pow(std::max(n, 1.0) / target, 1.0 / k);
      }
    }
    return best_p;
  }

 private:
  const Scene &scene_;
  View view_;
  const BenchSettings &settings_;
  Camera camera_;
  std::vector<Primary> primary_;
  GatherStore store_;
  NearFields near_;
  FillInputs fill_inputs_;
};

// Errors at the measured pixels.
struct Measured {
  double rel_rms = 0, rms = 0, worst_share = 0;
  std::vector<double> errors;  // luminance error per measured pixel (value - reference)
};

Measured measure(const Image &image, const Reference &ref) {
  Measured m;
  double e2 = 0, r2 = 0;
  std::vector<double> sq;
  for (const ReferencePixel &p : ref.pixels) {
    const double e = luminance(image.at(p.pixel)) - luminance(p.value());
    m.errors.push_back(e);
    sq.push_back(e * e);
    e2 += e * e;
    r2 += luminance(p.value()) * luminance(p.value());
  }
  if (ref.pixels.empty()) return m;
  m.rms = std::sqrt(e2 / ref.pixels.size());
  m.rel_rms = r2 > 0 ? std::sqrt(e2 / r2) : 0;
  std::sort(sq.begin(), sq.end(), std::greater<double>());
  const size_t worst = std::max<size_t>(1, sq.size() / 100);
  double top = 0;
  for (size_t k = 0; k < worst; ++k) top += sq[k];
  m.worst_share = e2 > 0 ? top / e2 : 0;
  return m;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

// The records' smallest radii in pixels (radius / the footprint of the record's pixel).
std::vector<double> radii_in_pixels(const BenchFill &f, const std::vector<Primary> &primary) {
  std::vector<double> out;
  for (const RecordInfo &r : f.records)
    out.push_back(std::min(r.radii[0], r.radii[1]) / std::max(primary[r.pixel].footprint, 1e-300));
  return out;
}

// Converged irradiance at record positions for the gather-noise floor, cached on disk by pixel.
class FloorReferences {
 public:
  FloorReferences(const std::string &file) : file_(file) {
    std::ifstream in(file_, std::ios::binary);
    uint64_t pixel;
    double v[6];
    while (in && in.read(reinterpret_cast<char *>(&pixel), 8) && in.read(reinterpret_cast<char *>(v), sizeof v)) {
      ReferencePixel r;
      r.pixel = pixel;
      r.half[0] = {v[0], v[1], v[2]};
      r.half[1] = {v[3], v[4], v[5]};
      map_[pixel] = r;
    }
  }

  // Computes the missing ones in parallel and appends them to the file.
  void ensure(const std::vector<size_t> &pixels, const Scene &scene, const std::vector<Primary> &primary,
              const BenchSettings &s) {
    std::vector<size_t> missing;
    for (size_t p : pixels)
      if (!map_.count(p)) missing.push_back(p);
    std::sort(missing.begin(), missing.end());
    missing.erase(std::unique(missing.begin(), missing.end()), missing.end());
    if (missing.empty()) return;
    std::printf("floor: converged irradiance at %zu record positions (%u rays each)...\n", missing.size(),
                s.floor_rays);
    std::fflush(stdout);
    std::vector<ReferencePixel> found(missing.size());
    HitRadianceSettings single = s.radiance;
    single.paths = 1;
    parallel_for(missing.size(), s.threads, [&](size_t k) {
      const Primary &px = primary[missing[k]];
      found[k] = converged_irradiance(scene, single, px.p, px.n, s.floor_rays, mix(missing[k] ^ 0xf100ull));
      found[k].pixel = missing[k];
    });
    std::ofstream out(file_, std::ios::binary | std::ios::app);
    for (const ReferencePixel &r : found) {
      map_[r.pixel] = r;
      const uint64_t pixel = r.pixel;
      const double v[6] = {r.half[0].x, r.half[0].y, r.half[0].z, r.half[1].x, r.half[1].y, r.half[1].z};
      out.write(reinterpret_cast<const char *>(&pixel), 8);
      out.write(reinterpret_cast<const char *>(v), sizeof v);
    }
  }

  const ReferencePixel &at(size_t pixel) const { return map_.at(pixel); }

 private:
  std::string file_;
  std::map<size_t, ReferencePixel> map_;
};

// The records sampled for the floor: the `count` with the smallest hash of their pixel (so that
// metrics whose records share pixels share the samples).
std::vector<size_t> floor_sample(const BenchFill &f, size_t count) {
  std::vector<std::pair<uint64_t, size_t>> keyed;
  for (const RecordInfo &r : f.records) keyed.push_back({mix(r.pixel ^ 0xf1008ull), r.pixel});
  std::sort(keyed.begin(), keyed.end());
  std::vector<size_t> out;
  for (size_t k = 0; k < std::min(count, keyed.size()); ++k) out.push_back(keyed[k].second);
  return out;
}

// The luminance pixel `p` shows from its own gather `g`, with no cache between them: the gather's
// irradiance, or with the near field (`near` not empty) the pixel's own near field plus its open
// fraction times the gather's far field (binned when `near_bins` is not empty).
double shown_from_own_gather(size_t p, const Evaluated &g, const std::vector<std::array<float, 4>> &near,
                             const std::vector<std::array<float, kDirBins>> &near_bins) {
  if (near.empty()) return g.luminance;
  double rgb[3];
  for (int c = 0; c < 3; ++c) {
    const double far =
        near_bins.empty() ? g.far_value[c] : binned_far(g.far_value[c], near_bins[p], g.far_bins, c);
    rgb[c] = near[p][c] + near[p][3] * far;
  }
  return luminance(rgb);
}

// Relative RMS error of the records' own gathers against converged irradiance at their positions,
// the reference's own noise removed: the error a cache would have if every pixel had its record.
// With the near field a record's pixel shows its own near field plus its open fraction times the
// record's far field, so that is what is compared.
double gather_floor(const std::vector<size_t> &pixels, GatherStore &store, const FloorReferences &refs,
                    const std::vector<std::array<float, 4>> &near,
                    const std::vector<std::array<float, kDirBins>> &near_bins) {
  double e2 = 0, n2 = 0, r2 = 0;
  for (size_t p : pixels) {
    const ReferencePixel &r = refs.at(p);
    const double e = shown_from_own_gather(p, *store.get(p).evaluated, near, near_bins) - luminance(r.value());
    const double noise = 0.5 * (luminance(r.half[0]) - luminance(r.half[1]));
    e2 += e * e;
    n2 += noise * noise;
    r2 += luminance(r.value()) * luminance(r.value());
  }
  return r2 > 0 ? std::sqrt(std::max(0.0, e2 - n2) / r2) : 0;
}

std::string fmt(const char *f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

void write_records_csv(const std::string &path, const BenchFill &f, const Camera &camera,
                       const std::vector<Primary> &primary) {
  std::ofstream out(path);
  out << "pixel,px,py,ux,uy,vx,vy,radius_px,value,open_fraction,relative_noise,gradient_shrink,hessian_shrink,"
         "noise_curvature_weight,relative_gradient_noise\n";
  for (const RecordInfo &r : f.records) {
    double cx, cy;
    if (!camera.project(r.p, cx, cy)) continue;
    V3 a0 = from_c(r.axes[0]), a1 = from_c(r.axes[1]);
    if (length(a0) == 0 || length(a1) == 0) {
      a0 = tangent_of(r.n);
      a1 = cross(r.n, a0);
    }
    // A short semi-axis projects well enough through a pinhole; off-screen ends keep their values.
    double ax = cx, ay = cy, bx = cx, by = cy;
    camera.project(r.p + normalize(a0) * r.radii[0], ax, ay);
    camera.project(r.p + normalize(a1) * r.radii[1], bx, by);
    out << r.pixel << "," << cx << "," << cy << "," << ax - cx << "," << ay - cy << "," << bx - cx << "," << by - cy
        << "," << std::min(r.radii[0], r.radii[1]) / std::max(primary[r.pixel].footprint, 1e-300) << "," << r.value
        << "," << r.open_fraction << "," << r.relative_noise << "," << r.gradient_shrink << ","
        << r.hessian_shrink << "," << r.noise_curvature_weight << "," << r.relative_gradient_noise << "\n";
  }
}

long max_rss_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss / 1024;
}

// The option combinations the bench refuses, with the reason.
void check_combinations(const BenchSettings &settings) {
  if (settings.far_field_bins && settings.near_field_px <= 0)
    throw std::runtime_error("--far-field-bins needs --near-field");
  if (settings.open_fraction_bands > 0 && settings.near_field_px <= 0)
    throw std::runtime_error("--open-fraction-bands needs --near-field");
  if (std::isfinite(settings.open_fraction_tolerance) && settings.near_field_px <= 0)
    throw std::runtime_error("--open-fraction-tolerance needs --near-field");
  if (settings.near_at_reach && !settings.far_field_gathers)
    throw std::runtime_error("--near-at-reach needs --far-field-gathers");
  if (settings.far_field_gathers && settings.near_field_px <= 0)
    throw std::runtime_error("--far-field-gathers needs --near-field");
  const bool noise_probes = settings.noise_probes();
  if (noise_probes && settings.oracle_derivative_paths > 0)
    throw std::runtime_error("--gradient-shrinkage, --hessian-shrinkage, --noise-curvature and --gradient-noise-radius "
                             "do not combine with --oracle-derivatives (their noise estimate is the usual gather's, "
                             "the derivatives the averaged one's)");
  if (settings.retraced_shrinkage_noise && !noise_probes)
    throw std::runtime_error("--retraced-shrinkage-noise needs --gradient-shrinkage, --hessian-shrinkage, "
                             "--noise-curvature or --gradient-noise-radius");
  if ((settings.hessian_shrinkage > 0 || settings.noise_curvature > 0 || settings.gradient_noise_radius > 0) &&
      settings.error_norm > 0)
    throw std::runtime_error("--hessian-shrinkage, --noise-curvature and --gradient-noise-radius do not combine with "
                             "--error-norm (which solves its own radii)");
  if (settings.smooths_derivatives() && (settings.oracle_derivative_paths > 0 || noise_probes))
    throw std::runtime_error("--smooth-derivative-strata does not combine with --oracle-derivatives or the "
                             "noise-probe experiments (their derivatives are another gather's)");
}

// What the images and the summary take from the reference: its mean luminance, and the exposure
// that maps its 99th percentile to 0.9.
struct ReferenceScale {
  double mean = 1;
  double exposure = 1;
};

// Writes `<out>-measured.csv` (each measured pixel's reference and the noise of its two halves).
ReferenceScale write_reference(const Reference &ref, const View &view, const BenchSettings &settings) {
  std::ofstream out(settings.out + "-measured.csv");
  out << "pixel,x,y,reference,noise\n";
  std::vector<double> l;
  double sum = 0;
  for (const ReferencePixel &p : ref.pixels) {
    out << p.pixel << "," << p.pixel % view.width << "," << p.pixel / view.width << "," << luminance(p.value()) << ","
        << 0.5 * std::abs(luminance(p.half[0]) - luminance(p.half[1])) << "\n";
    l.push_back(luminance(p.value()));
    sum += l.back();
  }
  ReferenceScale scale;
  scale.mean = ref.pixels.empty() ? 1.0 : sum / ref.pixels.size();
  scale.exposure = 0.9 / std::max(1e-12, percentile(l, 0.99));
  return scale;
}

// Pixel p's open fraction, from its near field (1 without one).
double pixel_open_fraction(Bench &bench, const BenchSettings &settings, size_t p) {
  return settings.near_field_px > 0 ? static_cast<double>(bench.near_field()[p][3]) : 1.0;
}

// The fills of every metric at equal records (tuned) and over the threshold sweep around it,
// written to `<out>-fills.csv` and, for the equal-records fills, to their images and CSVs.
struct Sweep {
  std::vector<BenchFill> tuned;  // one per metric, at equal records
  double longest = 0;            // CPU seconds of the costliest fill
  bool ok = true;                // every fill covered every pixel with finite, non-negative values
};
Sweep sweep_metrics(Bench &bench, const Reference &ref, const View &view, const BenchSettings &settings,
                    size_t target, double exposure) {
  const std::vector<Primary> &primary = bench.primary();
  std::ofstream fills(settings.out + "-fills.csv");
  fills << "metric,parameter,records,equal_records,trace_s,raddiff_s,cache_s,total_s,rel_rms,rms,worst1_share,"
           "radius_px_min,radius_px_p5,radius_px_median,radius_px_p95,uncovered,non_finite,negative\n";
  Sweep sweep;
  for (Metric m : settings.metrics) {
    std::printf("%s: tuning to %zu records\n", metric_name(m), target);
    std::fflush(stdout);
    const double p = bench.tune(m, target);
    // Thresholds spaced so that radii change by 2^0.75 per step: one below the tuned one (more
    // records), the tuned one, then above it.
    const int first = settings.thresholds >= 2 ? -1 : 0;
    for (int k = first; k < first + settings.thresholds; ++k) {
      const double pk = p * std::pow(2.0, 0.75 * k / radius_exponent(m));
      BenchFill f = bench.fill(m, pk, true);
      const Measured err = measure(f.image, ref);
      const std::vector<double> rpx = radii_in_pixels(f, primary);
      const bool equal = k == 0;
      sweep.ok = sweep.ok && f.uncovered == 0 && f.non_finite == 0 && f.negative == 0 && !f.records.empty();
      fills << metric_name(m) << "," << pk << "," << f.records.size() << "," << equal << "," << f.trace_seconds << ","
            << f.raddiff_seconds << "," << f.cache_seconds << "," << f.total_seconds() << "," << err.rel_rms << ","
            << err.rms << "," << err.worst_share << "," << percentile(rpx, 0) << "," << percentile(rpx, 0.05) << ","
            << percentile(rpx, 0.5) << "," << percentile(rpx, 0.95) << "," << f.uncovered << "," << f.non_finite
            << "," << f.negative << "\n";
      fills.flush();
      std::printf("  %-22s p = %-10.5g %6zu records  %7.2f CPU s (trace %.2f, raddiff %.2f, cache %.2f)  error %.4f  "
                  "worst 1%%: %.2f\n",
                  metric_name(m), pk, f.records.size(), f.total_seconds(), f.trace_seconds, f.raddiff_seconds,
                  f.cache_seconds, err.rel_rms, err.worst_share);
      std::fflush(stdout);
      sweep.longest = std::max(sweep.longest, f.total_seconds());
      if (equal) {
        const std::string prefix = settings.out + "-" + metric_name(m);
        write_images(prefix, f.image, exposure);
        write_records_csv(prefix + "-records.csv", f, bench.camera(), primary);
        std::ofstream px(prefix + "-pixels.csv");
        px << "pixel,x,y,value,reference,error,open_fraction\n";
        for (size_t i = 0; i < ref.pixels.size(); ++i) {
          const size_t q = ref.pixels[i].pixel;
          px << q << "," << q % view.width << "," << q / view.width << "," << luminance(f.image.at(q)) << ","
             << luminance(ref.pixels[i].value()) << "," << err.errors[i] << "," << pixel_open_fraction(bench, settings, q) << "\n";
        }
        sweep.tuned.push_back(std::move(f));
      }
    }
  }
  return sweep;
}

// The gathers' own error at the records of each equal-records cache (`<out>-floor.csv`).
void write_floors(Bench &bench, const std::vector<BenchFill> &tuned, const Scene &scene, const Reference &ref,
                  const BenchSettings &settings) {
  FloorReferences floor_refs(settings.reference.cache_dir.empty()
                                 ? std::string()
                                 : settings.reference.cache_dir + "/floor-" +
                                       fmt("%.0f", static_cast<double>(settings.floor_rays)) + "-" +
                                       (ref.file.empty() ? std::string("x") : ref.file.substr(ref.file.rfind('-') + 1)));
  std::ofstream floor_csv(settings.out + "-floor.csv");
  floor_csv << "metric,records_sampled,floor_rel_rms\n";
  std::vector<size_t> all_samples;
  for (const BenchFill &f : tuned) {
    const std::vector<size_t> s = floor_sample(f, settings.floor_records);
    all_samples.insert(all_samples.end(), s.begin(), s.end());
  }
  floor_refs.ensure(all_samples, scene, bench.primary(), settings);
  for (const BenchFill &f : tuned) {
    const std::vector<size_t> s = floor_sample(f, settings.floor_records);
    const double floor = gather_floor(s, bench.store(), floor_refs, bench.near_field(), bench.near_bins());
    floor_csv << metric_name(f.metric) << "," << s.size() << "," << floor << "\n";
    std::printf("floor %-22s %.4f (gathers of %zu records against converged irradiance)\n", metric_name(f.metric),
                floor, s.size());
  }
}

// Every measured pixel shown from its own gather, no cache: the error no record placement removes
// (the gathers' and near fields' noise, the near/far decomposition's bias, the reference's noise).
// Writes `<out>-pixel-gathers-pixels.csv`; returns the relative RMS error.
double pixel_gathers_error(Bench &bench, const Reference &ref, const View &view, const BenchSettings &settings) {
  std::vector<size_t> measured;
  for (const ReferencePixel &r : ref.pixels) measured.push_back(r.pixel);
  bench.store().ensure(measured);
  std::ofstream px(settings.out + "-pixel-gathers-pixels.csv");
  px << "pixel,x,y,value,reference,error,open_fraction\n";
  const std::vector<std::array<float, 4>> &near = bench.near_field();
  const std::vector<std::array<float, kDirBins>> &near_bins = bench.near_bins();
  double e2 = 0, r2 = 0;
  size_t degenerate = 0;  // gathers raddiff found degenerate: shown with a zero far field
  for (const ReferencePixel &r : ref.pixels) {
    const size_t p = r.pixel;
    const Evaluated &g = *bench.store().get(p).evaluated;
    degenerate += !g.valid;
    const double shown = shown_from_own_gather(p, g, near, near_bins);
    const double reference_value = luminance(r.value());
    e2 += (shown - reference_value) * (shown - reference_value);
    r2 += reference_value * reference_value;
    px << p << "," << p % view.width << "," << p / view.width << "," << shown << "," << reference_value << ","
       << shown - reference_value << "," << pixel_open_fraction(bench, settings, p) << "\n";
  }
  const double error = r2 > 0 ? std::sqrt(e2 / r2) : 0;
  std::printf("pixel gathers: every measured pixel from its own gather, error %.4f (%zu degenerate)\n", error,
              degenerate);
  return error;
}

// Path tracing the indirect irradiance per pixel, up to 1.3 times `longest` CPU seconds: its
// snapshots' errors in `<out>-pt.csv`, their images beside it.
void write_path_tracing(const Scene &scene, const std::vector<Primary> &primary, const Reference &ref,
                        const View &view, const BenchSettings &settings, double longest, double exposure) {
  write_pfm(settings.out + "-albedo.pfm", albedo_buffer(scene, primary, view));
  std::ofstream pt(settings.out + "-pt.csv");
  pt << "spp,cpu_s,rays,rel_rms,rms,worst1_share,file\n";
  path_trace(scene, primary, view, settings.radiance, settings.path_trace_max_spp, 1.3 * longest, settings.threads,
             [&](const PathTraceSnapshot &s) {
               const Measured err = measure(s.image, ref);
               const std::string file = settings.out + "-pt-spp" + std::to_string(s.spp);
               write_pfm(file + ".pfm", s.image);
               if (s.spp == 1 || s.cpu_seconds > longest) write_png(file + ".png", s.image, exposure);
               pt << s.spp << "," << s.cpu_seconds << "," << s.rays << "," << err.rel_rms << "," << err.rms << ","
                  << err.worst_share << "," << file << ".pfm\n";
               pt.flush();
               std::printf("path tracing: %5u spp  %7.2f CPU s  error %.4f\n", s.spp, s.cpu_seconds, err.rel_rms);
               std::fflush(stdout);
             });
}

}  // namespace

int run_bench(const Scene &scene, const View &view, const std::string &scene_key, const BenchSettings &settings) {
  check_combinations(settings);
  const double wall0 = process_cpu_seconds();
  Bench bench(scene, view, settings);
  const std::vector<Primary> &primary = bench.primary();
  const size_t pixels = static_cast<size_t>(view.width) * view.height;
  const size_t target = settings.target_records ? settings.target_records : std::max<size_t>(16, pixels / 32);

  // The converged reference.
  const Reference ref = reference(scene, primary, view, settings.radiance, settings.reference, scene_key,
                                  settings.threads);
  std::printf("reference: %zu pixels, %u rays each, relative noise %.5f (%s)\n", ref.pixels.size(),
              settings.reference.rays, ref.relative_noise(),
              ref.loaded ? ("loaded from " + ref.file).c_str() : ("computed in " + fmt("%.0f", ref.seconds) + " CPU s").c_str());
  const ReferenceScale scale = write_reference(ref, view, settings);

  const Sweep sweep = sweep_metrics(bench, ref, view, settings, target, scale.exposure);
  write_floors(bench, sweep.tuned, scene, ref, settings);
  const double pixel_gathers = settings.pixel_gathers ? pixel_gathers_error(bench, ref, view, settings) : -1;
  // The primary hits' normals: the denoiser's guide, and where the report finds geometric edges.
  write_pfm(settings.out + "-normal.pfm", normal_buffer(primary, view));
  if (settings.path_trace) write_path_tracing(scene, primary, ref, view, settings, sweep.longest, scale.exposure);

  std::ofstream summary(settings.out + "-summary.csv");
  summary << "key,value\n"
          << "width," << view.width << "\nheight," << view.height << "\ntriangles," << scene.triangle_count()
          << "\nscene_size," << scene.size() << "\ngather," << settings.irradiance.gather_m << "x"
          << settings.irradiance.gather_n
          << "\nhit_radiance," << settings.radiance.describe() << "\ntarget_records," << target
          << "\nmeasured_pixels," << ref.pixels.size() << "\nreference_grid," << settings.reference.grid << "\nreference_rays," << settings.reference.rays
          << "\nreference_relative_noise," << ref.relative_noise() << "\nreference_mean," << scale.mean
          << "\ngathers_computed," << bench.store().computed() << "\nmax_rss_mib," << max_rss_mib()
          << "\nprocess_cpu_s," << process_cpu_seconds() - wall0 << "\nexposure," << scale.exposure << "\nreference_cpu_s," << ref.seconds
          << "\nreference_loaded," << ref.loaded << "\ngradient_limit," << settings.irradiance.gradient_limit
          << "\nleak_guard," << settings.irradiance.leak_guard_relative << " " << settings.irradiance.leak_guard_absolute
          << "\nradius_bounds," << settings.irradiance.world_radius_min << " " << settings.irradiance.world_radius_max
          << " " << settings.irradiance.pixel_radius_min << " " << settings.irradiance.pixel_radius_max
          << "\nopen_fraction_tolerance," << settings.open_fraction_tolerance
          << "\nopen_fraction_coverage_tolerance," << settings.open_fraction_coverage_tolerance
          << "\nlookup_radius_scale," << settings.lookup_scale << "\nnoise_seed," << settings.noise_seed << "\npixel_gathers_rel_rms," << pixel_gathers << "\n";
  std::printf("bench: %zu gathers computed, max RSS %ld MiB, %.0f CPU s\n", bench.store().computed(), max_rss_mib(),
              process_cpu_seconds() - wall0);
  std::printf("%s\n", sweep.ok ? "OK" : "FAILED");
  return sweep.ok ? 0 : 1;
}

}  // namespace rd
