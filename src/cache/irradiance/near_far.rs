//! One call per shading point with the near/far decomposition: every query traces its own short
//! rays for the near field, and the cache holds far fields.

use std::fmt::Display;

use glam::DVec3;

use super::query::{check_query, query_frame, refusing};
use super::settings::IrradianceSettings;
use crate::cache::{Cache, CacheValue, Lookup};
use crate::error::{Error, Result};
use crate::gather::{far_field_gather, near_field, Layout, NearField};

/// What [`Cache::irradiance_near_far`] found at a shading point.
#[derive(Debug, Clone)]
pub struct NearFarLookup<V> {
    /// The irradiance `E_near + V·F`, per channel.
    pub value: V,
    /// The query's near field: the irradiance of hits closer than the reach and the open
    /// fraction V.
    pub near: NearField,
    /// The far field F interpolated from the cache, with its weights and record count.
    pub far: Lookup<V>,
    /// The reach ρ at this query (L).
    pub reach: f64,
}

impl<V: CacheValue> Cache<V> {
    /// The irradiance at the shading point `x` with normal `n` as the near/far decomposition
    /// gives it, `E_near + V·F`: the near field `E_near` and open fraction `V` from the query's
    /// own short rays, the far field `F` from the cache, or from a new record when none covers
    /// `x`. The settings' [`IrradianceSettings::near_field`] must have a reach, and the cache
    /// must hold far fields at that reach (made from [`IrradianceSettings::cache_config`]).
    ///
    /// * `x`, `n`, `footprint`: as [`Cache::irradiance`]; the reach at this query is
    ///   `ρ = max(reach.world, reach.pixels·footprint)`.
    /// * `trace(origin, directions, max_distance, distance, radiance)`: trace every one of the
    ///   unit `directions` from `origin` (= `x`) in one batch, writing each ray's hit distance
    ///   and the radiance arriving along it (`channels` per ray, interleaved). Rays need go no
    ///   farther than `max_distance`: for one that finds nothing closer, write
    ///   `f64::INFINITY` (or any distance ≥ `max_distance`) and leave its radiance (it is not
    ///   read; the buffer holds zeros). Called on the calling thread, once per call that passes
    ///   the argument checks when the open-fraction test is off:
    ///   when a record covers `x`, with the `near_field.m·near_field.n` near rays and
    ///   `max_distance = ρ`; on a miss, with the record's `gather_m·gather_n` gather and
    ///   `max_distance = f64::INFINITY`, whose rays give both the near field and, split at ρ
    ///   ([`far_field_gather`]: near hits moved to the reach with the far field's mean
    ///   radiance), the new record. With the settings'
    ///   [`open_fraction_test`](super::NearFieldSettings::open_fraction_test) on, the near rays
    ///   come first (the lookup needs their open fraction), and a miss then traces the gather
    ///   too: once on a hit, twice on a miss. An `Err` abandons the request
    ///   ([`Error::Callback`]; nothing inserted).
    ///
    /// Errors: as [`Cache::irradiance`], and `InvalidArgument` when the settings have no
    /// near-field reach, the cache holds no far fields or holds them at another reach, the reach
    /// comes out 0 at this query (a reach in pixels with footprint 0), the near-ray layout is
    /// invalid, or the near rays' values are refused (a non-positive or NaN distance,
    /// non-finite radiance); `Degenerate` when `E_near + V·F` overflows an `f32`. On any error
    /// nothing is inserted, with one exception: on a miss whose own gather's sum fits an `f32`
    /// but whose interpolated far field (blended with other records) makes it overflow, the new
    /// record stays.
    ///
    /// ```
    /// use raddiff::cache::irradiance::{IrradianceSettings, RadiusBounds};
    /// use raddiff::cache::{Cache, FarFieldReach};
    /// use raddiff::glam::DVec3;
    ///
    /// let mut settings = IrradianceSettings::new(1);
    /// (settings.gather_m, settings.gather_n) = (8, 24);
    /// settings.radius_bounds = RadiusBounds::world(0.01, 1.0);
    /// settings.near_field.reach = FarFieldReach::world(1.0);
    /// let cache: Cache<f32> = Cache::new(settings.cache_config())?;
    /// // a floor under a ceiling of radiance 1 at height 0.5; rays stop at `max_distance`
    /// let trace = |_o: DVec3, dirs: &[DVec3], max_distance: f64, t: &mut [f64], l: &mut [f32]| {
    ///     for (i, w) in dirs.iter().enumerate() {
    ///         let hit = 0.5 / w.z.max(1e-9);
    ///         (t[i], l[i]) = if hit < max_distance { (hit, 1.0) } else { (f64::INFINITY, 0.0) };
    ///     }
    ///     Ok::<(), String>(())
    /// };
    /// let e = cache.irradiance_near_far(&settings, DVec3::ZERO, DVec3::Z, 0.0, trace)?;
    /// assert!((e.value - std::f32::consts::PI).abs() < 1e-4);
    /// // the ceiling is nearer than the reach where cos θ > 1/2: three quarters of the measure
    /// assert!((e.near.open_fraction - 0.25).abs() < 1e-12);
    /// # Ok::<(), raddiff::Error>(())
    /// ```
    pub fn irradiance_near_far<E: Display>(
        &self,
        settings: &IrradianceSettings,
        x: DVec3,
        n: DVec3,
        footprint: f64,
        mut trace: impl FnMut(
            DVec3,
            &[DVec3],
            f64,
            &mut [f64],
            &mut [f32],
        ) -> std::result::Result<(), E>,
    ) -> Result<NearFarLookup<V>> {
        check_query(x, n, footprint)?;
        if !settings.near_field.reach.is_on() {
            return Err(Error::InvalidArgument(
                "the settings have no near-field reach: query with Cache::irradiance \
                 (raddiff_cache_irradiance)"
                    .into(),
            ));
        }
        settings.check_cache(self.config())?;
        let reach = settings.near_field.reach.resolve(footprint)?;
        let channels = settings.channels;
        let test = settings.near_field.open_fraction_test.is_on();
        let mut near_rays = || -> Result<NearField> {
            let layout = Layout::new(
                settings.gather_kind,
                settings.near_field.m,
                settings.near_field.n,
                settings.seed.seed(x, n),
            )
            .map_err(refusing("the near-field rays"))?;
            let directions = layout.directions(&query_frame(x, n)?)?;
            let mut distance = vec![0.0; directions.len()];
            let mut radiance = vec![0.0f32; directions.len() * channels];
            trace(x, &directions, reach, &mut distance, &mut radiance)
                .map_err(|e| Error::Callback(e.to_string()))?;
            near_field(&layout, &distance, &radiance, channels, reach)
                .map_err(refusing("the traced near-field rays"))
        };
        // with the open-fraction test the lookup needs the query's open fraction first
        let (queried, found) = if test {
            let near = near_rays()?;
            let found = self.lookup_open(x, n, near.open_fraction);
            (Some(near), found)
        } else {
            (None, self.lookup(x, n))
        };
        let (near, far) = match found {
            Ok(far) => match queried {
                Some(near) => (near, far),
                None => (near_rays()?, far),
            },
            Err(Error::NotFound(_)) => {
                let (near, evaluation) = self.evaluate_traced(
                    settings,
                    x,
                    n,
                    footprint,
                    |directions, distance, radiance| {
                        trace(x, directions, f64::INFINITY, distance, radiance)
                    },
                    |layout, distance, radiance| {
                        let near = near_field(layout, distance, radiance, channels, reach)?;
                        far_field_gather(layout, distance, radiance, channels, reach)?;
                        Ok(near)
                    },
                )?;
                // a record whose own point's sum overflows is not inserted
                sum_f32(&near, &evaluation.irradiance)?;
                let mut record = settings.record(&evaluation, footprint)?;
                // the gather's own open fraction: the new record covers its own point
                let far = if test {
                    record.open_fraction = Some(near.open_fraction);
                    self.insert(&record)?;
                    self.lookup_open(x, n, near.open_fraction)?
                } else {
                    self.insert(&record)?;
                    self.lookup(x, n)?
                };
                (near, far)
            }
            Err(other) => return Err(other),
        };
        let far_field: Vec<f64> = far.value.as_channels().iter().map(|&f| f.into()).collect();
        let value = sum_f32(&near, &far_field)?;
        Ok(NearFarLookup {
            value: V::from_channels(&value),
            near,
            far,
            reach,
        })
    }
}

/// `E_near + V·F` per channel as `f32`; `Degenerate` when a channel overflows.
fn sum_f32(near: &NearField, far_field: &[f64]) -> Result<Vec<f32>> {
    near.irradiance_with(far_field)?
        .into_iter()
        .map(|e| {
            let e32 = e as f32;
            if e32.is_finite() {
                Ok(e32)
            } else {
                Err(Error::Degenerate(format!(
                    "the irradiance {e} (near field plus far field) overflows an f32"
                )))
            }
        })
        .collect()
}
