//! A cache's configuration: what its records hold, how they are weighed and blended, and the
//! safeguards applied at insert and lookup. Every field is saved with the cache.

// Sibling modules only: `mod.rs` re-exports this module's type, so naming it would be a cycle
// (the documentation links to `Cache` by path for the same reason).
use super::far_field::FarFieldReach;
use super::interp::Interpolation;
use super::leak_guard::LeakGuard;
use super::open_fraction::OpenFractionTest;
use super::record::{self, Domain};

/// Configuration of a cache.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CacheConfig {
    /// Floats per record value (must match a fixed-size `V`).
    pub channels: usize,
    /// Surfaces or media.
    pub domain: Domain,
    /// How records are weighted and extrapolated.
    pub interpolation: Interpolation,
    /// Largest angle (radians, in (0, π]) between a record's normal and a query normal for the
    /// record to be used (surface domain; ignored in volumes).
    pub max_normal_deviation: f64,
    /// Clamp each record's extrapolated value at 0, per channel, before blending (default
    /// `false`). First-order extrapolation of a steep gradient can go below zero in dark corners;
    /// with non-negative weights (every scheme's) the blend of clamped values is never negative,
    /// which irradiance and radiance require. Leave it off for signed quantities. `Log`
    /// interpolation is positive by construction and ignores it.
    pub non_negative: bool,
    /// Slope limit c applied to every record when it is inserted (default `f64::INFINITY`: off;
    /// must be > 0, [`Cache::new`] rejects 0, negative values and NaN). The rule: for each
    /// channel k with value Eₖ, let R be the record's largest radius (as stored, `f32`),
    /// sₜ = |∇ₜEₖ|·R and sᵣ = |∇ᵣEₖ|·sin(min(Δn_max, π/2)) (surface domain, Δn_max =
    /// [`CacheConfig::max_normal_deviation`]; sᵣ = 0 in volumes, which have no rotational
    /// gradient). If sₜ + sᵣ > c·|Eₖ|, both gradients of channel k are multiplied by
    /// c·|Eₖ|/(sₜ + sᵣ); a channel with Eₖ = 0 loses its gradients.
    ///
    /// Consequence: a lookup within the record's extent (|Δx| ≤ R, |nᵢ × n| ≤ sin(min(Δn_max,
    /// π/2))) extrapolates channel k by |Δx·∇ₜEₖ + (nᵢ×n)·∇ᵣEₖ| ≤ c·|Eₖ|, up to the binary16
    /// rounding of the stored gradients (2⁻¹¹ of the record's largest gradient component); with
    /// c ≤ 1 extrapolation never flips a value's sign. In [`Interpolation::Log`] the same bound
    /// holds for the exponent: a record's factor lies in [e^−c, e^c]. Use it against outlier
    /// gradients, e.g. Ward-Heckbert gradients estimated a hair's breadth from a wall junction
    /// (|∇E|·R/E up to ~100). Records that satisfy the bound are stored bit for bit as without
    /// the limit. [`Cache::merge`] and [`Cache::load`] take records as stored (no limit is
    /// re-applied). Saved with the cache (file format version 3).
    ///
    /// [`Cache::new`]: super::Cache::new
    /// [`Cache::merge`]: super::Cache::merge
    /// [`Cache::load`]: super::Cache::load
    pub gradient_limit: f64,
    /// The "record in front of the query" test (default [`LeakGuard::OFF`]; surface domain
    /// only): a record i is not used at a query x with normal n when
    /// `(x − xᵢ)·(n + nᵢ)/2 < −(relative·Rᵢ + absolute)`, Rᵢ the record's radius along its
    /// normal (see [`LeakGuard`]). Both tolerances must be ≥ 0; [`Cache::new`] rejects NaN and
    /// negative ones. Saved with the cache (file format version 4; older files load with it off).
    ///
    /// [`Cache::new`]: super::Cache::new
    pub leak_guard: LeakGuard,
    /// Whether records hold far fields of the near/far decomposition, and at which reach
    /// (default [`FarFieldReach::OFF`]: records hold what their gathers saw). The cache itself
    /// stores and interpolates far fields as any value; the marker tells irradiance queries
    /// ([`Cache::irradiance_near_far`]) that the near field is theirs to add, and keeps such a
    /// cache from being filled or read as one of irradiance. Saved with the cache (file format
    /// version 5; older files load with it off).
    ///
    /// [`Cache::irradiance_near_far`]: super::Cache::irradiance_near_far
    pub far_field: FarFieldReach,
    /// The open-fraction test of far-field caches (default [`OpenFractionTest::OFF`]): a record
    /// i with an open fraction Vᵢ is not used at a query of open fraction V
    /// ([`Cache::lookup_open`], [`Cache::irradiance_near_far`]) when `|Vᵢ − V| > tolerance` (see
    /// [`OpenFractionTest`]). The tolerance must be ≥ 0; [`Cache::new`] rejects NaN and negative
    /// ones. Saved with the cache (file format version 6; older files load with it off).
    ///
    /// [`Cache::lookup_open`]: super::Cache::lookup_open
    /// [`Cache::irradiance_near_far`]: super::Cache::irradiance_near_far
    /// [`Cache::new`]: super::Cache::new
    pub open_fraction_test: OpenFractionTest,
    /// How far records are read: the lookup radius scale k, in multiples of their radii
    /// (default 1; in [1, [`LOOKUP_RADIUS_SCALE_MAX`]], [`Cache::new`] rejects anything else).
    ///
    /// A record's radii say how far its value is accurate enough (the error metric's answer),
    /// and so where a renderer must make a new record: at a query that no record covers at its
    /// own radii. Reading records only that far also makes each value a blend of few records, so
    /// the noise of each record's gather shows undiluted. With k > 1 a lookup weighs every record
    /// over k times its radii (the kernel, the normal term, the leak guard's radius; the
    /// open-fraction test is not about distance and is unchanged), while whether the query is
    /// covered is still decided at the records' own radii:
    ///
    /// ```text
    ///   weight of record i at x:  wᵢ(t/k, n·nᵢ)     t: its normalized distance at its own radii
    ///   x is covered           ⇔  some record i has wᵢ(t, n·nᵢ) > 0 (guards included)
    /// ```
    ///
    /// A query that is not covered is `NotFound` exactly as at k = 1, so the records a renderer
    /// makes on misses ([`Cache::irradiance`] and the like) are those it makes at k = 1; only the
    /// blend at covered queries changes. On surfaces each value then blends about k² times the
    /// records: the gathers' noise falls, and bias grows where the value curves within kR. The
    /// real-scene benchmark measured k = 1.5 (`docs/real-scenes.md`: every error metric's error
    /// 3-13% lower at equal records at one record per 32 pixels). The best k grows with the
    /// record budget: with few, large records bias decides (there, at one record per 60-70
    /// pixels, 1.41 gave the anisotropic Hessian 0.78x-0.86x the error of 2). Cost: about k² (k³
    /// in media) times the records weighed and blended per lookup, plus the coverage test. k = 1
    /// gives the results without the scale bit for bit. Saved with the cache (file format version
    /// 7; older files load with 1); changed on a filled cache by
    /// [`Cache::set_lookup_radius_scale`].
    ///
    /// [`LOOKUP_RADIUS_SCALE_MAX`]: super::LOOKUP_RADIUS_SCALE_MAX
    /// [`Cache::new`]: super::Cache::new
    /// [`Cache::irradiance`]: super::Cache::irradiance
    /// [`Cache::set_lookup_radius_scale`]: super::Cache::set_lookup_radius_scale
    pub lookup_radius_scale: f64,
}

impl CacheConfig {
    /// Surface irradiance: Ward-Heckbert interpolation, maximum normal deviation 0.2 rad (the
    /// thesis' default).
    pub fn surface(channels: usize) -> Self {
        CacheConfig {
            channels,
            domain: Domain::Surface,
            interpolation: Interpolation::Ward,
            max_normal_deviation: 0.2,
            non_negative: false,
            gradient_limit: f64::INFINITY,
            leak_guard: LeakGuard::OFF,
            far_field: FarFieldReach::OFF,
            open_fraction_test: OpenFractionTest::OFF,
            lookup_radius_scale: 1.0,
        }
    }

    /// Media radiance: the cubic kernel of Marco et al. (eq. 23); otherwise as
    /// [`CacheConfig::surface`].
    pub fn volume(channels: usize) -> Self {
        CacheConfig {
            domain: Domain::Volume,
            interpolation: Interpolation::Cubic,
            ..Self::surface(channels)
        }
    }

    /// The same configuration with another interpolation scheme.
    pub fn with_interpolation(mut self, interpolation: Interpolation) -> Self {
        self.interpolation = interpolation;
        self
    }

    /// The same configuration with [`CacheConfig::non_negative`] set to `non_negative`.
    pub fn with_non_negative(mut self, non_negative: bool) -> Self {
        self.non_negative = non_negative;
        self
    }

    /// The same configuration with [`CacheConfig::gradient_limit`] set to `c` (`f64::INFINITY`
    /// turns the limit off; [`Cache::new`] rejects `c <= 0` and NaN).
    ///
    /// [`Cache::new`]: super::Cache::new
    pub fn with_gradient_limit(mut self, c: f64) -> Self {
        self.gradient_limit = c;
        self
    }

    /// The same configuration with [`CacheConfig::leak_guard`] set to `guard`.
    pub fn with_leak_guard(mut self, guard: LeakGuard) -> Self {
        self.leak_guard = guard;
        self
    }

    /// The same configuration with [`CacheConfig::far_field`] set to `reach`.
    pub fn with_far_field(mut self, reach: FarFieldReach) -> Self {
        self.far_field = reach;
        self
    }

    /// The same configuration with [`CacheConfig::open_fraction_test`] set to `test`.
    pub fn with_open_fraction_test(mut self, test: OpenFractionTest) -> Self {
        self.open_fraction_test = test;
        self
    }

    /// The same configuration with [`CacheConfig::lookup_radius_scale`] set to `scale`.
    pub fn with_lookup_radius_scale(mut self, scale: f64) -> Self {
        self.lookup_radius_scale = scale;
        self
    }

    /// The slope limiter the encoder applies, `None` when off.
    pub(crate) fn slope_limit(&self) -> Option<record::SlopeLimit> {
        (self.gradient_limit < f64::INFINITY).then(|| record::SlopeLimit {
            c: self.gradient_limit,
            sin_deviation: self
                .max_normal_deviation
                .min(std::f64::consts::FRAC_PI_2)
                .sin(),
        })
    }

    /// The lowest value a record's extrapolation may take: 0 with
    /// [`CacheConfig::non_negative`], else −∞ (`max(v, −∞)` is `v` bit for bit).
    pub(crate) fn extrapolation_floor(&self) -> f64 {
        if self.non_negative {
            0.0
        } else {
            f64::NEG_INFINITY
        }
    }
}
