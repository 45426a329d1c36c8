// The real-scene benchmark: every metric's cache, tuned to equal records and swept over
// thresholds, against a converged reference, with the error split into the gathers' own noise and
// interpolation, and path tracing at equal CPU time. Writes CSV files, images and PFMs under a
// prefix; examples/embree/report.py turns several runs into the report.
#pragma once

#include "camera.hpp"
#include "metrics.hpp"
#include "reference.hpp"

#include <cmath>
#include <string>
#include <vector>

namespace rd {

struct BenchSettings {
  std::vector<Metric> metrics = all_metrics();
  size_t target_records = 0;  // 0: one record per 32 pixels
  int thresholds = 4;         // fills per metric along its error-against-time curve (>= 1)
  // raddiff's settings of every record: gather size, radius bounds (world and pixels), gradient
  // limit, leak guard, anisotropy, curvature floor (metric and threshold are set per fill).
  raddiff_irradiance_settings irradiance = raddiff_irradiance_settings_default();
  HitRadianceSettings radiance;
  ReferenceSettings reference;
  uint32_t floor_records = 200;       // records per metric whose gathers are checked against a reference
  uint32_t floor_rays = 1u << 16;     // rays of the reference at each of those records
  uint32_t path_trace_max_spp = 4096;
  bool path_trace = true;
  double smooth_records = 0;          // > 0: records' values blended with their neighbours' (tent, radii x this)
  bool record_gradients = true;       // false: records without gradients (to measure what they add)
  // != 1: every cache of the records read over their radii times this
  // (raddiff_cache_set_lookup_radius_scale, in [1, 8]; the leak guard's radius with them). Misses,
  // and so the records the fills place, are those at 1: lookups blend more records (less noise,
  // more bias) at the same record count. The render mode passes it to raddiff_irradiance_cache_new.
  double lookup_scale = 1;
  // > 0: the adaptive-lookup experiment (render fills; instead of lookup_scale; not with bands,
  // neighbour clamping, smoothing, second order or bins). Each pixel reads the records over k
  // times their radii, k = adaptive_lookup * (s / s_median)^(1/3) within [1, adaptive_lookup_max]
  // (rounded to a quarter octave), s the records' relative noise (Evaluated::relative_noise)
  // blended at the pixel and s_median the records' median: blending ~k^2 records divides the noise
  // by k while the interpolation's bias grows as k^2, so their sum is least at k ~ (noise/bias)^(1/3).
  double adaptive_lookup = 0;
  double adaptive_lookup_max = 4;
  double adaptive_lookup_exponent = 1.0 / 3.0;  // the power of s / s_median (1/3: the balance above)
  // > 0: the gradient-shrinkage experiment. Each record's translational gradients are multiplied
  // by max(0, 1 - gradient_shrinkage * v / |g|^2), g the Ward-Heckbert gradient of its gather's
  // luminance and v that gradient's variance under the strata's own noise: the gradient is linear
  // in the strata's radiance, so v is the mean of |gradient|^2 over 8 gathers whose radiance is
  // each stratum's noise amplitude (as Evaluated::relative_noise estimates it) with a random sign.
  // At 1, the empirical Wiener factor (|g|^2 - v) / |g|^2.
  double gradient_shrinkage = 0;
  // > 0: the Hessian-shrinkage experiment. The Hessian metrics' radii are solved for their
  // Hessian times max(1e-3, 1 - hessian_shrinkage * v / |H|^2), H the tangent projection of the
  // occlusion-aware Hessian of the gather's luminance and v its variance under the strata's noise
  // (the same probes as gradient_shrinkage): curvature the noise explains does not shrink radii.
  double hessian_shrinkage = 0;
  // With either shrinkage: each stratum's noise amplitude from a second trace of the same
  // directions with independent hit-radiance samples (untimed; what a better noise estimate would
  // give) instead of from its azimuthal neighbour, whose difference also holds the signal's change.
  bool retraced_shrinkage_noise = false;
  // > 0: the noise-curvature experiment. The Hessian metrics' curvature floor adds z times the
  // tangent Hessian's noise (a per-eigenvalue standard deviation under the strata's noise, the
  // same probes as gradient_shrinkage) to each eigenvalue's magnitude: radii from an upper
  // confidence bound on the curvature, z standard deviations above the estimate.
  double noise_curvature = 0;
  // > 0: the gradient-noise-radius experiment. Hessian records' radii at most z p E / sigma_g
  // (at least the pixel minimum), p the metric's accuracy, sigma_g the norm of the gradient's noise
  // (the same probes): where the gradient's noise, extrapolated, alone reaches z p of the value,
  // the budget the radii solve gives the curvature.
  double gradient_noise_radius = 0;
  // > 0: the records' derivatives (gradients, Hessians) from the same gather with radiance averaged
  // over this many paths, their values from the usual gather: what derivative noise costs.
  int oracle_derivative_paths = 0;
  // > 0: Hessian records' radii at most this times the gather's harmonic-mean distance (experiment).
  double hessian_distance_bound = 0;
  // >= 0: every cache interpolates with this RADDIFF_INTERP_* kernel instead of its metric's
  // (experiment; -1: the metric's own).
  int interpolation = -1;
  // > 0: lookups add this times the covering records' blended second-order term, 1/2 d^T H d with
  // H the occlusion-aware Hessian of the record's gather projected on its tangent plane (experiment;
  // needs hessian-anisotropic or hessian-isotropic among the metrics).
  double second_order = 0;
  // > 0: the occlusion-aware Hessian metrics' radii chosen for the image's L^p error at equal
  // records (experiment): R ~ (tau / |lambda|)^(p / (2p + 2)) * footprint^(1 / (p + 1)), from the
  // library's radii (p = 1 without the footprint term is the library's own rule), bounds and
  // anisotropy applied again.
  double error_norm = 0;
  bool absolute_error = false;  // with error_norm: tau absolute instead of relative to the record's value
  // Two-sided neighbour clamping (raddiff_cache_clamp_neighbours) after each coarse-to-fine level,
  // the finest level repeated until covered, as the render mode's --neighbour-clamp (the records'
  // radii in <out>-<metric>-records.csv and -fills.csv are those inserted, before clamping).
  bool neighbour_clamp = false;
  // > 0: the near-field experiment (Arikan et al. 2005's decomposition, raddiff_gather_near_field
  // and raddiff_gather_far_field_radiance). Each pixel traces a near_field_m x near_field_m
  // jittered cosine-polar layout of rays of this many pixel footprints' reach and takes the
  // radiance of what they hit as its near irradiance; the records store the far field (their
  // gathers' irradiance minus the near field at the same reach, over the open fraction), and a
  // pixel's irradiance is its near irradiance plus the interpolated far field times its own open
  // fraction. The pixels' rays count in every rendered fill's CPU time.
  double near_field_px = 0;
  uint32_t near_field_m = 4;
  // With near_field_px: the records made from their far-field gathers (near hits' radiance replaced
  // by the far directions' mean), so that their derivatives and radii are the far field's too.
  bool far_field_gathers = false;
  // With far_field_gathers: the near hits also moved to the reach (distance = reach, a surface
  // facing the record), so that the far field's derivatives and radii do not see the near geometry.
  bool near_at_reach = false;
  // An experiment (with a near field): records also store their far radiance per world-direction
  // bin (Evaluated::far_bins), and each pixel's far field is corrected by the bins' deviations
  // weighted by its own open rays' bins, F + pi * sum_b w_b delta_b, instead of its open fraction
  // times the record's mean alone.
  bool far_field_bins = false;
  // An experiment (with a near field; 0: off): records kept in bands of their gather's open
  // fraction, this wide, and a pixel interpolating only records within one band of its own open
  // fraction (its near field's), so that a record beside a step, whose hemisphere is partly
  // closed, does not lend its far field to pixels that see more of theirs.
  double open_fraction_bands = 0;
  // The library's open-fraction test (with a near field; INFINITY: off): records keep their
  // gather's open fraction, every pixel's lookup passes its near field's, and a record whose open
  // fraction differs from the pixel's by more than this is not used (raddiff_cache_lookup_open).
  double open_fraction_tolerance = INFINITY;
  // With the test, its coverage tolerance (raddiff_cache_set_open_fraction_coverage_tolerance): a
  // pixel that no record passes reads the refused records within it (INFINITY: all of them, so
  // the test decides which records a pixel reads, never where records are made; 0: none).
  double open_fraction_coverage_tolerance = 0;
  // 0: the usual samples. Otherwise every gather's, near field's and hit radiance's random numbers
  // drawn from another stream (the references' are not): two runs that differ only here measure
  // how much of each metric's error is the samples' noise.
  uint64_t noise_seed = 0;
  // Also show every measured pixel from its own gather, with no cache (<out>-pixel-gathers-pixels.csv,
  // summary key pixel_gathers_rel_rms; -1 when off): the error no record placement removes. Costs
  // one gather per measured pixel not already a record's.
  bool pixel_gathers = false;
  // Non-empty: the adaptive-gather experiment (examples/embree/strata_allocation.py reads it). Every
  // record gather whose pixel index is a multiple of strata_every is traced strata_paths more times
  // with independent hit-radiance samples (same directions and hits; not timed), and each
  // stratum's luminance per trace is written to <strata_dir>/p<pixel>.strata.
  std::string strata_dir;
  uint32_t strata_every = 97;
  uint32_t strata_paths = 16;
  std::string out = "bench";          // file prefix
  unsigned threads = 2;

  // Whether an experiment needs the derivatives' noise probes (derivative_noise).
  bool noise_probes() const {
    return gradient_shrinkage > 0 || hessian_shrinkage > 0 || noise_curvature > 0 || gradient_noise_radius > 0;
  }
  // Whether the records' derivatives come from smoothed strata (--smooth-derivative-strata:
  // raddiff's derivative_smoothing, which the mid-level evaluation applies).
  bool smooths_derivatives() const {
    return irradiance.derivative_smoothing_azimuthal > 0 || irradiance.derivative_smoothing_polar > 0;
  }
};

// Runs the benchmark on one view; returns 0 when every fill covered the image with finite,
// non-negative values.
int run_bench(const Scene &scene, const View &view, const std::string &scene_key, const BenchSettings &settings);

}  // namespace rd
