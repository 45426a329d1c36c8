// raddiff + Embree 3: irradiance caching in a C++17 renderer that includes nothing of raddiff but
// its installed header.
//
// Loads an OBJ scene (with its MTL: Kd diffuse reflectance, Ke emitted radiance), traces the gather
// directions raddiff gives it with Embree, turns what the rays found into records with raddiff,
// and renders the indirect irradiance from the cache. Two modes:
//  * render (default): fill one cache from many threads, render, save, reload, render again, and
//    check the result (render.cpp);
//  * --bench: the real-scene benchmark, every metric against a converged reference and against
//    path tracing at equal CPU time (bench.cpp; examples/embree/bench.sh runs it on scene folders).
// The hit radiance of every gather ray comes from radiance.cpp (production estimator by default).
// docs/embree.md and docs/real-scenes.md are the guides.

#include "bench.hpp"
#include "render.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

using namespace rd;

namespace {

V3 parse_v3(const std::string &s) {
  V3 v;
  if (std::sscanf(s.c_str(), "%lf,%lf,%lf", &v.x, &v.y, &v.z) != 3) throw std::runtime_error("expected x,y,z: " + s);
  return v;
}

void parse_pair(const std::string &s, double &a, double &b, const char *what) {
  if (std::sscanf(s.c_str(), "%lf,%lf", &a, &b) != 2) throw std::runtime_error(std::string(what) + " min,max");
}

const char *kUsage =
    "usage: raddiff_embree [--obj scene.obj] [--out prefix] [--size N] [--gather MxN] [--threads N]\n"
    "                      [--eye x,y,z] [--target x,y,z] [--fov degrees]\n"
    "                      [--radius min,max (world; default 0,inf)]\n"
    "                      [--radius-px min,max (times the pixel's footprint; default 1,150)]\n"
    "                      [--hit-radiance production[:N][xK] | one-shadow-ray[xK] (default production:4)]\n"
    "                      [--gradient-limit c (default 2, inf: off)] [--leak-guard relative,absolute]\n"
    "                      [--max-anisotropy r (default 2)] [--curvature-floor kappa (default 0.04)]\n"
    "                      [--smooth-derivative-strata A[,P] (derivatives from smoothed strata; default off)]\n"
    "                      [--lookup-scale k (records read over k times their radii, 1 to 8; default 1)]\n"
    "                      [--adaptive-lookup k0[,kmax[,exponent]] (bench: scale per pixel from the noise)]\n"
    "  render mode:        [--accuracy a | --hessian relative_error] [--records N] [--neighbour-clamp]\n"
    "                      [--check pixels (default 96)] [--near-field reach_px[,rays]]\n"
    "  both, with --near-field: [--open-fraction-tolerance t (default inf: off)]\n"
    "                      [--open-fraction-coverage-tolerance c (default 0: none)] [--open-fraction-keep-coverage (c inf)]\n"
    "  --bench:            [--records N (default pixels/32)] [--metrics name,name,...] [--thresholds N]\n"
    "                      [--reference-rays N (65536)] [--reference-grid G (64)] [--cache-dir DIR] [--floor-records N]\n"
    "                      [--floor-rays N] [--pt-max-spp N] [--no-path-trace] [--no-record-gradients]\n"
    "                      [--oracle-derivatives K] [--interpolation ward|tent|cubic] [--gradient-shrinkage k]\n"
    "                      [--hessian-shrinkage k] [--retraced-shrinkage-noise] [--noise-curvature z]\n"
    "                      [--gradient-noise-radius z]\n"
    "                      [--hessian-distance-bound k] [--smooth-records s]\n"
    "                      [--second-order k] [--error-norm p] [--absolute-error] [--neighbour-clamp]\n"
    "                      [--near-field reach_px[,rays]] [--far-field-gathers] [--near-at-reach] [--far-field-bins]\n"
    "                      [--open-fraction-bands width] [--noise-seed K] [--pixel-gathers]\n"
    "                      [--strata-variance DIR[,every (97)[,paths (16)]]]\n";

}  // namespace

int main(int argc, char **argv) {
  std::string obj = "cornell.obj";
  View view;
  RenderSettings render;
  BenchSettings bench;
  render.irradiance.gather_m = 16;  // the render mode's quick default; the benchmark's is 32 x 128
  render.irradiance.gather_n = 48;
  bool bench_mode = false, gather_given = false;
  unsigned threads = 0;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto next = [&]() -> std::string {
        if (i + 1 >= argc) throw std::runtime_error(a + " needs a value");
        return argv[++i];
      };
      if (a == "--obj") obj = next();
      else if (a == "--out") render.out = bench.out = next();
      else if (a == "--size") view.width = view.height = std::stoi(next());
      else if (a == "--gather") {
        const std::string g = next();
        uint32_t m, n;
        if (std::sscanf(g.c_str(), "%ux%u", &m, &n) != 2) throw std::runtime_error("--gather MxN");
        render.irradiance.gather_m = m;
        render.irradiance.gather_n = n;
        gather_given = true;
      } else if (a == "--accuracy") render.accuracy = std::stod(next());
      else if (a == "--hessian") render.hessian_error = std::stod(next());
      else if (a == "--threads") threads = static_cast<unsigned>(std::stoul(next()));
      else if (a == "--eye") view.eye = parse_v3(next());
      else if (a == "--target") view.target = parse_v3(next());
      else if (a == "--fov") view.fov = std::stod(next());
      else if (a == "--radius") {
        parse_pair(next(), render.irradiance.world_radius_min, render.irradiance.world_radius_max, "--radius");
      } else if (a == "--radius-px") {
        parse_pair(next(), render.irradiance.pixel_radius_min, render.irradiance.pixel_radius_max, "--radius-px");
      } else if (a == "--records") {
        const long n = std::stol(next());
        if (n < 1) throw std::runtime_error("--records N needs N >= 1");
        render.target_records = bench.target_records = static_cast<size_t>(n);
      } else if (a == "--neighbour-clamp") render.neighbour_clamp = bench.neighbour_clamp = true;
      else if (a == "--gradient-limit") render.irradiance.gradient_limit = std::stod(next());
      else if (a == "--max-anisotropy") render.irradiance.max_anisotropy = std::stod(next());
      else if (a == "--curvature-floor") render.irradiance.curvature_floor = std::stod(next());
      else if (a == "--smooth-derivative-strata") {
        const std::string v = next();
        const size_t comma = v.find(',');
        const int azimuthal = std::stoi(v.substr(0, comma));
        const int polar = comma == std::string::npos ? 0 : std::stoi(v.substr(comma + 1));
        if (azimuthal < 0 || polar < 0) throw std::runtime_error("--smooth-derivative-strata takes pass counts >= 0");
        render.irradiance.derivative_smoothing_azimuthal = static_cast<uint32_t>(azimuthal);
        render.irradiance.derivative_smoothing_polar = static_cast<uint32_t>(polar);
      }
      else if (a == "--leak-guard") parse_pair(next(), render.irradiance.leak_guard_relative,
                                               render.irradiance.leak_guard_absolute, "--leak-guard");
      else if (a == "--check") render.check_pixels = std::stoi(next());
      else if (a == "--hit-radiance") render.radiance = bench.radiance = HitRadianceSettings::parse(next());
      else if (a == "--bench") bench_mode = true;
      else if (a == "--metrics") {
        bench.metrics.clear();
        std::stringstream s(next());
        std::string name;
        while (std::getline(s, name, ',')) bench.metrics.push_back(parse_metric(name));
      } else if (a == "--thresholds") bench.thresholds = std::max(1, std::stoi(next()));
      else if (a == "--reference-rays") bench.reference.rays = static_cast<uint32_t>(std::stoul(next()));
      else if (a == "--reference-grid") bench.reference.grid = std::stoi(next());
      else if (a == "--cache-dir") bench.reference.cache_dir = next();
      else if (a == "--floor-records") bench.floor_records = static_cast<uint32_t>(std::stoul(next()));
      else if (a == "--floor-rays") bench.floor_rays = static_cast<uint32_t>(std::stoul(next()));
      else if (a == "--pt-max-spp") bench.path_trace_max_spp = static_cast<uint32_t>(std::stoul(next()));
      else if (a == "--no-path-trace") bench.path_trace = false;
      else if (a == "--smooth-records") bench.smooth_records = std::stod(next());
      else if (a == "--lookup-scale")
        render.irradiance.lookup_radius_scale = bench.lookup_scale = std::stod(next());
      else if (a == "--adaptive-lookup") {
        // k0[,kmax[,exponent]]
        std::stringstream v(next());
        std::string part;
        double *fields[3] = {&bench.adaptive_lookup, &bench.adaptive_lookup_max, &bench.adaptive_lookup_exponent};
        for (double *f : fields)
          if (std::getline(v, part, ',')) *f = std::stod(part);
      } else if (a == "--second-order") bench.second_order = std::stod(next());
      else if (a == "--error-norm") bench.error_norm = std::stod(next());
      else if (a == "--far-field-gathers") bench.far_field_gathers = true;
      else if (a == "--near-at-reach") bench.near_at_reach = true;
      else if (a == "--far-field-bins") bench.far_field_bins = true;
      else if (a == "--open-fraction-bands") bench.open_fraction_bands = std::stod(next());
      else if (a == "--open-fraction-tolerance")
        render.irradiance.near_field_open_fraction_tolerance = bench.open_fraction_tolerance = std::stod(next());
      else if (a == "--open-fraction-coverage-tolerance")
        render.open_fraction_coverage_tolerance = bench.open_fraction_coverage_tolerance = std::stod(next());
      else if (a == "--open-fraction-keep-coverage")
        render.open_fraction_coverage_tolerance = bench.open_fraction_coverage_tolerance = INFINITY;
      else if (a == "--noise-seed") bench.noise_seed = std::stoull(next());
      else if (a == "--pixel-gathers") bench.pixel_gathers = true;
      else if (a == "--strata-variance") {
        // DIR[,every[,paths]]
        std::stringstream s(next());
        std::string part;
        std::getline(s, bench.strata_dir, ',');
        if (std::getline(s, part, ',')) bench.strata_every = static_cast<uint32_t>(std::stoul(part));
        if (std::getline(s, part, ',')) bench.strata_paths = static_cast<uint32_t>(std::stoul(part));
        if (bench.strata_dir.empty() || bench.strata_every < 1 || bench.strata_paths < 2)
          throw std::runtime_error("--strata-variance DIR[,every[,paths]]: every >= 1, paths >= 2");
      }
      else if (a == "--near-field") {
        // K (pixel footprints of reach) or K,N (N rays per pixel)
        const std::string v = next();
        const size_t comma = v.find(',');
        bench.near_field_px = std::stod(v.substr(0, comma));
        const unsigned long rays = comma == std::string::npos ? 16 : std::stoul(v.substr(comma + 1));
        bench.near_field_m = static_cast<uint32_t>(std::lround(std::sqrt(static_cast<double>(rays))));
        if (!(bench.near_field_px > 0) || rays < 1 || static_cast<unsigned long>(bench.near_field_m) * bench.near_field_m != rays)
          throw std::runtime_error("--near-field K[,N]: K > 0 pixels, N rays a square (16, 256, 1024)");
        // the render mode: raddiff_cache_irradiance_near_far_parts with this reach and these rays
        render.irradiance.near_field_reach_pixels = bench.near_field_px;
        render.irradiance.near_field_m = render.irradiance.near_field_n = bench.near_field_m;
      }
      else if (a == "--absolute-error") bench.absolute_error = true;
      else if (a == "--no-record-gradients") bench.record_gradients = false;
      else if (a == "--gradient-shrinkage") bench.gradient_shrinkage = std::stod(next());
      else if (a == "--hessian-shrinkage") bench.hessian_shrinkage = std::stod(next());
      else if (a == "--retraced-shrinkage-noise") bench.retraced_shrinkage_noise = true;
      else if (a == "--noise-curvature") bench.noise_curvature = std::stod(next());
      else if (a == "--gradient-noise-radius") bench.gradient_noise_radius = std::stod(next());
      else if (a == "--oracle-derivatives") bench.oracle_derivative_paths = std::stoi(next());
      else if (a == "--hessian-distance-bound") bench.hessian_distance_bound = std::stod(next());
      else if (a == "--interpolation") {
        const std::string k = next();
        bench.interpolation = k == "ward" ? RADDIFF_INTERP_WARD : k == "tent" ? RADDIFF_INTERP_TENT
                              : k == "cubic" ? RADDIFF_INTERP_CUBIC : throw std::runtime_error("--interpolation ward|tent|cubic");
      }
      else {
        std::printf("%s", kUsage);
        return a == "--help" || a == "-h" ? 0 : 2;
      }
    }
    if (view.width < 1 || view.height < 1 || render.irradiance.gather_m < 1 || render.irradiance.gather_n < 1)
      throw std::runtime_error("sizes must be positive");
    threads = threads ? threads : std::max(1u, std::thread::hardware_concurrency());
    render.threads = bench.threads = threads;

    std::printf("raddiff %s, Embree %d.%d.%d, %u threads\n", raddiff_version(), RTC_VERSION_MAJOR, RTC_VERSION_MINOR,
                RTC_VERSION_PATCH, threads);
    const Scene scene(obj);
    std::printf("scene %s: %zu triangles, %zu emitters, size %.4g\n", obj.c_str(), scene.triangle_count(),
                scene.emitter_count(), scene.size());
    if (scene.emitter_count() == 0) throw std::runtime_error("the scene has no emitter (Ke > 0)");
    std::printf("hit radiance: %s\n", render.radiance.describe().c_str());
    // Radius bounds: raddiff's defaults (one to 150 pixels of the query's footprint) unless given;
    // they follow the image's pixels whatever the scene's size.
    bench.irradiance = render.irradiance;
    bench.irradiance.near_field_reach_pixels = 0;  // the benchmark splits its gathers itself
    if (!bench_mode && render.neighbour_clamp && render.irradiance.near_field_reach_pixels > 0)
      throw std::runtime_error("--neighbour-clamp makes records by hand: not with --near-field in render mode");
    if (!gather_given) {
      bench.irradiance.gather_m = 32;
      bench.irradiance.gather_n = 128;
    }
    if (!bench_mode) return run_render(scene, view, render);
    std::string key;
    for (const std::string &f : scene.files()) key += std::to_string(file_hash(f)) + ";";
    return run_bench(scene, view, key, bench);
  } catch (const std::exception &e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
}
