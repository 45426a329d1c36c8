//! Everything an irradiance record depends on besides its gather, and the defaults of the
//! safeguards.

use super::bounds::RadiusBounds;
use super::evaluation::{check_weights, Hessians};
use super::metric::Metric;
use super::seed::SeedPolicy;
use crate::cache::{
    check_gradient_limit, check_lookup_radius_scale, CacheConfig, Domain, FarFieldReach, LeakGuard,
    OpenFractionTest, MAX_CHANNELS,
};
use crate::error::{Error, Result};
use crate::gather::radii::CURVATURE_FLOOR_WEIGHT;
use crate::gather::{Layout, LayoutKind, StrataSmoothing};

/// The gradient limit c irradiance caches use unless told otherwise (the one default of the
/// library, the C ABI's `RADDIFF_GRADIENT_LIMIT_DEFAULT`, the demo and the Embree example): over
/// its extent a record extrapolates each channel by at most twice its value. Measured on the
/// demo's Cornell box (`docs/demo.md`, "What the safeguards do"): c = 2 stops the outlier
/// gradients estimated a hair's breadth from a junction and changes sane records by less than
/// 1%; c = 1 (which keeps every extrapolated value's sign) trimmed the split sphere's legitimately
/// steep gradients next to the light, +9% error. Extrapolation can then go negative: irradiance
/// caches also clamp at zero ([`CacheConfig::non_negative`], set by
/// [`IrradianceSettings::cache_config`]).
pub const GRADIENT_LIMIT_DEFAULT: f64 = 2.0;

/// The anisotropy the anisotropic Hessian metrics allow by default: the thesis' 2.
pub const MAX_ANISOTROPY_DEFAULT: f64 = 2.0;

/// Rec. 709 / sRGB luminance weights of linear RGB: the scalar of 3-channel caches by default.
pub const LUMINANCE_WEIGHTS: [f64; 3] = [0.2126, 0.7152, 0.0722];

/// The near/far decomposition of
/// [`Cache::irradiance_near_far`](crate::cache::Cache::irradiance_near_far) (Arikan et al. 2005; see
/// [`gather::near_far`](crate::gather::near_far)). Off by default.
///
/// On the real-scene benchmark at 512 px (`docs/real-scenes.md`) a reach of 8 pixel footprints
/// with 32 × 32 near rays per pixel lowered every metric's error by 24-51% at the same record
/// count, for about 40 CPU s of short rays next to the 8,192 gathers' 65; 16 rays per pixel
/// doubled the error (the near field's noise is the pixel's and shows in the image).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NearFieldSettings {
    /// The reach ρ (default [`FarFieldReach::OFF`]): in L and in pixel footprints, the larger
    /// applies. Cache state: the cache must be made with the same reach
    /// ([`IrradianceSettings::cache_config`]).
    pub reach: FarFieldReach,
    /// Near rays along θ per query (default 32), in the gather's layout kind.
    pub m: u32,
    /// Near rays along φ per query (default 32).
    pub n: u32,
    /// The cache's open-fraction test (default [`OpenFractionTest::OFF`]): a record is not used
    /// at a query whose near rays' open fraction differs from the record's gather's by more than
    /// the tolerance. Cache state, like the reach. With it on, every query traces its near rays
    /// before it looks up (a miss then also traces its gather).
    pub open_fraction_test: OpenFractionTest,
}

impl Default for NearFieldSettings {
    /// Off, with 32 × 32 near rays once a reach is set.
    fn default() -> Self {
        NearFieldSettings {
            reach: FarFieldReach::OFF,
            m: 32,
            n: 32,
            open_fraction_test: OpenFractionTest::OFF,
        }
    }
}

/// How irradiance records are made: the error metric and its threshold, the gather, the radius
/// bounds and the safeguards. One value serves any number of threads and calls.
///
/// Defaults ([`IrradianceSettings::new`]) are the library's one set of safeguard defaults (the
/// table in `docs/cache.md`): the anisotropic occlusion-aware Hessian, a 32 × 128 cosine-polar
/// gather, radii from one pixel to 150 pixels, gradient limit [`GRADIENT_LIMIT_DEFAULT`],
/// curvature floor [`CURVATURE_FLOOR_WEIGHT`], anisotropy at most [`MAX_ANISOTROPY_DEFAULT`], leak
/// guard off.
#[derive(Debug, Clone, PartialEq)]
pub struct IrradianceSettings {
    /// The error metric (default [`Metric::HessianAnisotropic`]).
    pub metric: Metric,
    /// The metric's threshold, > 0: the accuracy a of the split-sphere family and ε of the
    /// gradient metric (dimensionless, typically 0.1-0.3), or the Hessian metrics' tolerance on
    /// the extrapolation error integrated over the record relative to the value (units L²,
    /// [`gather::radii`](crate::gather::radii): radii grow as its fourth root, so it scales with
    /// the square of the scene's size). Smaller: more, smaller records. Default 1e-3.
    pub accuracy: f64,
    /// Values per record (1..=4096; default 3).
    pub channels: usize,
    /// The weight of each channel in the scalar the metrics measure (one per channel, ≥ 0, not
    /// all 0). `None`: Rec. 709 luminance ([`LUMINANCE_WEIGHTS`]) for 3 channels, the mean
    /// otherwise.
    pub channel_weights: Option<Vec<f64>>,
    /// The gather's layout (a hemisphere layout; default cosine-polar).
    pub gather_kind: LayoutKind,
    /// Strata along θ (default 32).
    pub gather_m: u32,
    /// Strata along φ (default 128: 4096 rays per record). The occlusion-aware Hessian needs
    /// at least 6 (cosine-polar) or a 3 × 3 concentric grid.
    pub gather_n: u32,
    /// Where each gather's jitter comes from (default: hashed from the query).
    pub seed: SeedPolicy,
    /// Bounds on every radius, in L and in pixels (default 1 to 150 pixels).
    pub radius_bounds: RadiusBounds,
    /// The Hessian metrics' largest axis ratio (≥ 1; default 2; the isotropic metric uses 1).
    pub max_anisotropy: f64,
    /// Weight κ of the Hessian metrics' curvature floor κ·|E|/D²
    /// ([`CurvatureFloor`](crate::gather::radii::CurvatureFloor); ≥ 0, 0: off; default
    /// [`CURVATURE_FLOOR_WEIGHT`]).
    pub curvature_floor: f64,
    /// The cache's gradient limit c (> 0, `f64::INFINITY`: off; default
    /// [`GRADIENT_LIMIT_DEFAULT`]).
    pub gradient_limit: f64,
    /// The cache's leak guard (default [`LeakGuard::OFF`]).
    pub leak_guard: LeakGuard,
    /// The near/far decomposition (default off; its reach is cache state). With a reach, records
    /// hold far fields and the cache is queried with
    /// [`Cache::irradiance_near_far`](crate::cache::Cache::irradiance_near_far).
    pub near_field: NearFieldSettings,
    /// How far the cache reads records, in multiples of their radii (default 1; in
    /// [1, [`LOOKUP_RADIUS_SCALE_MAX`](crate::cache::LOOKUP_RADIUS_SCALE_MAX)]):
    /// [`CacheConfig::lookup_radius_scale`]. Records are made
    /// where they would be at 1; each value blends more of them. The cache's to choose, like
    /// its interpolation: [`IrradianceSettings::check_cache`] does not compare it.
    pub lookup_radius_scale: f64,
    /// How the gather's strata are smoothed before its derivatives are taken (default
    /// [`StrataSmoothing::OFF`]; [`GatherEvaluation::with_smoothing`](super::GatherEvaluation::with_smoothing)):
    /// the records' gradients and radii from the smoothed strata, their values from the strata
    /// as traced. For noisy hit radiance (a few shadow rays or paths per gather ray); on
    /// noise-free radiance it only blurs. On the real-scene benchmark 2 azimuthal passes and 1
    /// polar pass lowered every metric's error by 2-10% (`docs/real-scenes.md`).
    pub derivative_smoothing: StrataSmoothing,
}

impl Default for IrradianceSettings {
    /// [`IrradianceSettings::new`] with 3 channels (RGB).
    fn default() -> Self {
        IrradianceSettings::new(3)
    }
}

impl IrradianceSettings {
    /// The defaults for `channels` values per record.
    pub fn new(channels: usize) -> Self {
        IrradianceSettings {
            metric: Metric::HessianAnisotropic,
            accuracy: 1e-3,
            channels,
            channel_weights: None,
            gather_kind: LayoutKind::CosinePolar,
            gather_m: 32,
            gather_n: 128,
            seed: SeedPolicy::default(),
            radius_bounds: RadiusBounds::default(),
            max_anisotropy: MAX_ANISOTROPY_DEFAULT,
            curvature_floor: CURVATURE_FLOOR_WEIGHT,
            gradient_limit: GRADIENT_LIMIT_DEFAULT,
            leak_guard: LeakGuard::OFF,
            near_field: NearFieldSettings::default(),
            lookup_radius_scale: 1.0,
            derivative_smoothing: StrataSmoothing::OFF,
        }
    }

    /// The channel weights in use: [`IrradianceSettings::channel_weights`] or its default.
    pub fn weights(&self) -> Vec<f64> {
        match &self.channel_weights {
            Some(w) => w.clone(),
            None if self.channels == 3 => LUMINANCE_WEIGHTS.to_vec(),
            None => vec![1.0 / self.channels.max(1) as f64; self.channels],
        }
    }

    /// The Hessians the metric needs, and no other.
    pub fn hessians(&self) -> Hessians {
        Hessians::for_metrics(&[self.metric])
    }

    /// The gather layout for a record whose seed is `seed`.
    pub fn layout(&self, seed: u64) -> Result<Layout> {
        Layout::new(self.gather_kind, self.gather_m, self.gather_n, seed)
    }

    /// `InvalidArgument` naming the first field out of its domain (see each field).
    pub fn validate(&self) -> Result<()> {
        let invalid = |what: String| Err(Error::InvalidArgument(what));
        if !(self.accuracy > 0.0 && self.accuracy.is_finite()) {
            return invalid(format!(
                "accuracy must be finite and > 0, got {}",
                self.accuracy
            ));
        }
        if self.channels == 0 || self.channels > MAX_CHANNELS {
            return invalid(format!(
                "channels must be in 1..={MAX_CHANNELS}, got {}",
                self.channels
            ));
        }
        check_weights(&self.weights(), self.channels)?;
        if !self.gather_kind.is_hemisphere() {
            return invalid("irradiance gathers need a hemisphere layout".into());
        }
        self.layout(0)?;
        self.radius_bounds.validate()?;
        if !(self.max_anisotropy >= 1.0 && self.max_anisotropy.is_finite()) {
            return invalid(format!(
                "max_anisotropy must be finite and >= 1, got {}",
                self.max_anisotropy
            ));
        }
        if !(self.curvature_floor >= 0.0 && self.curvature_floor.is_finite()) {
            return invalid(format!(
                "curvature_floor must be finite and >= 0, got {}",
                self.curvature_floor
            ));
        }
        check_gradient_limit(self.gradient_limit)?;
        self.leak_guard.validate()?;
        self.near_field.reach.validate()?;
        self.near_field.open_fraction_test.validate()?;
        check_lookup_radius_scale(self.lookup_radius_scale)?;
        self.derivative_smoothing.validate()?;
        if self.near_field.reach.is_on() {
            Layout::new(self.gather_kind, self.near_field.m, self.near_field.n, 0)
                .map_err(|e| Error::InvalidArgument(format!("the near-field rays: {e}")))?;
        }
        Ok(())
    }

    /// The configuration of a cache for these records: surface domain, the settings' channels,
    /// the metric's interpolation ([`Metric::interpolation`]), gradient limit, leak guard,
    /// far-field reach, open-fraction test and lookup radius scale, extrapolation clamped at zero
    /// (irradiance is never negative), maximum normal deviation 0.2 rad.
    pub fn cache_config(&self) -> CacheConfig {
        CacheConfig::surface(self.channels)
            .with_interpolation(self.metric.interpolation())
            .with_non_negative(true)
            .with_gradient_limit(self.gradient_limit)
            .with_leak_guard(self.leak_guard)
            .with_far_field(self.near_field.reach)
            .with_open_fraction_test(self.near_field.open_fraction_test)
            .with_lookup_radius_scale(self.lookup_radius_scale)
    }

    /// `InvalidArgument` unless a cache configured as `config` stores what these settings make:
    /// the same channel count, the surface domain, the same gradient limit, leak guard,
    /// far-field reach and open-fraction tolerance (cache state the records are inserted and
    /// looked up under). The interpolation, the normal deviation and the test's coverage
    /// tolerance ([`OpenFractionTest::coverage_tolerance`]) are the cache's to choose.
    pub fn check_cache(&self, config: &CacheConfig) -> Result<()> {
        let disagree = |what: &str, cache: String, settings: String| {
            Err(Error::InvalidArgument(format!(
                "the cache's {what} ({cache}) differs from the irradiance settings' ({settings}): \
                 create the cache from the settings (IrradianceSettings::cache_config, \
                 raddiff_irradiance_cache_new)"
            )))
        };
        if config.channels != self.channels {
            return disagree(
                "channel count",
                config.channels.to_string(),
                self.channels.to_string(),
            );
        }
        if config.domain != Domain::Surface {
            return disagree("domain", "volume".into(), "surface".into());
        }
        if config.gradient_limit != self.gradient_limit {
            return disagree(
                "gradient limit",
                config.gradient_limit.to_string(),
                self.gradient_limit.to_string(),
            );
        }
        let (ours, theirs) = (self.leak_guard, config.leak_guard);
        if (ours.is_on() || theirs.is_on()) && ours != theirs {
            return disagree(
                "leak guard",
                format!("{:?}", config.leak_guard),
                format!("{:?}", self.leak_guard),
            );
        }
        if config.far_field != self.near_field.reach {
            return disagree(
                "far-field reach",
                format!("{:?}", config.far_field),
                format!("{:?}", self.near_field.reach),
            );
        }
        let (ours, theirs) = (
            self.near_field.open_fraction_test,
            config.open_fraction_test,
        );
        if (ours.is_on() || theirs.is_on()) && ours.tolerance != theirs.tolerance {
            return disagree(
                "open-fraction test",
                format!("{theirs:?}"),
                format!("{ours:?}"),
            );
        }
        Ok(())
    }
}
