//! One call per shading point: look up, and on a miss trace, evaluate, insert and look up again.

use std::fmt::Display;

use glam::DVec3;

use super::bounds::check_footprint;
use super::evaluation::GatherEvaluation;
use super::settings::IrradianceSettings;
use super::traced::TracedGather;
use crate::cache::{Cache, CacheValue, Lookup};
use crate::error::{ensure_finite3, Error, Result};
use crate::gather::radii::tangent_basis;
use crate::gather::{Frame, Layout};

impl<V: CacheValue> Cache<V> {
    /// The irradiance at the shading point `x` with normal `n`, from the cache, or from a new
    /// record traced through `trace` when no record covers `x`.
    ///
    /// * `x`: the gather point (L), pulled back from the surface as the renderer's rays need it
    ///   (e.g. by 1e-4 of the camera ray's hit distance towards the camera, so that no ray
    ///   starts below the surface or on a seam); lookups and the record use the same point.
    /// * `n`: the surface normal (any non-zero length; normalized here).
    /// * `footprint`: the world-space size of one pixel at `x` (L), for the pixel radius bounds
    ///   of the settings; 0 when unknown (world bounds only, one of which must then be finite).
    /// * `trace(origin, directions, distance, radiance)`: trace every one of `directions` (unit,
    ///   world space, `gather_m·gather_n` of them) from `origin` (= `x`) in one batch, writing
    ///   each ray's hit distance (`f64::INFINITY` for a miss) and the radiance arriving at
    ///   `origin` along it, `channels` values per ray (interleaved: `radiance[i·channels + c]`).
    ///   An `Err` abandons the request: nothing is inserted and the error comes back as
    ///   [`Error::Callback`] with its message. The closure runs at most once per call, on the
    ///   calling thread.
    ///
    /// On a miss the gather's layout is seeded by [`IrradianceSettings::seed`] (from `x` and `n`,
    /// never from the order of calls), evaluated with exactly the Hessian the metric needs, and
    /// its record ([`IrradianceSettings::record`]) inserted; the value returned is then the
    /// cache's interpolation at `x`, as every later lookup there sees it. Thread-safe: any number
    /// of threads may call this on one cache; two threads that miss at the same point trace the
    /// same gather and insert its record once.
    ///
    /// Errors: `InvalidArgument` for non-finite `x` or `n`, a zero `n`, a footprint that is
    /// negative or not finite, settings with a near-field reach or a cache of far fields (both
    /// need [`Cache::irradiance_near_far`]), and, on a miss (a covered point needs none of the settings),
    /// settings that are invalid or disagree with the cache
    /// ([`IrradianceSettings::check_cache`]), no finite maximum radius, a metric that needs hit
    /// normals (the occlusion-unaware Hessians: use [`GatherEvaluation`] and
    /// [`IrradianceSettings::record`]), or traced values the gather refuses (a non-positive or
    /// NaN distance, non-finite radiance); [`Error::Callback`] when `trace` fails; `Degenerate`
    /// when the evaluation overflows. On any error nothing is inserted.
    pub fn irradiance<E: Display>(
        &self,
        settings: &IrradianceSettings,
        x: DVec3,
        n: DVec3,
        footprint: f64,
        trace: impl FnOnce(DVec3, &[DVec3], &mut [f64], &mut [f32]) -> std::result::Result<(), E>,
    ) -> Result<Lookup<V>> {
        check_query(x, n, footprint)?;
        if settings.near_field.reach.is_on() || self.config().far_field.is_on() {
            return Err(Error::InvalidArgument(
                "with a near-field reach the records hold far fields: query with \
                 Cache::irradiance_near_far (raddiff_cache_irradiance_near_far)"
                    .into(),
            ));
        }
        match self.lookup(x, n) {
            Err(Error::NotFound(_)) => {}
            found => return found,
        }
        let ((), evaluation) = self.evaluate_traced(
            settings,
            x,
            n,
            footprint,
            |directions, distance, radiance| trace(x, directions, distance, radiance),
            |_, _, _| Ok(()),
        )?;
        self.insert(&settings.record(&evaluation, footprint)?)?;
        self.lookup(x, n)
    }

    /// The miss path shared by the one-call queries, up to the record: validates the settings
    /// against the cache, lays out and traces the record's gather at `x`, lets `prepare` read
    /// and rewrite what the rays found (the far-field split), and evaluates it. Returns what
    /// `prepare` returned and the evaluation.
    pub(super) fn evaluate_traced<T, E: Display>(
        &self,
        settings: &IrradianceSettings,
        x: DVec3,
        n: DVec3,
        footprint: f64,
        trace: impl FnOnce(&[DVec3], &mut [f64], &mut [f32]) -> std::result::Result<(), E>,
        prepare: impl FnOnce(&Layout, &mut [f64], &mut [f32]) -> Result<T>,
    ) -> Result<(T, GatherEvaluation)> {
        settings.validate()?;
        settings.check_cache(self.config())?;
        if settings.metric.needs_hit_normals() {
            return Err(Error::InvalidArgument(format!(
                "the {} metric needs the hits' normals, which a tracing callback does not \
                 report: evaluate the gather with GatherEvaluation and build its record with \
                 IrradianceSettings::record",
                settings.metric.name()
            )));
        }
        // fail before tracing when no bound can hold an unbounded radius
        settings.radius_bounds.resolve(footprint)?;
        let frame = query_frame(x, n)?;
        let layout = settings.layout(settings.seed.seed(x, n))?;
        let directions = layout.directions(&frame)?;
        let mut distance = vec![0.0; directions.len()];
        let mut radiance = vec![0.0f32; directions.len() * settings.channels];
        trace(&directions, &mut distance, &mut radiance)
            .map_err(|e| Error::Callback(e.to_string()))?;
        let prepared =
            prepare(&layout, &mut distance, &mut radiance).map_err(refusing(TRACED_GATHER))?;
        let mut traced = TracedGather::new(
            layout,
            frame,
            &directions,
            &distance,
            &radiance,
            settings.channels,
        );
        // the record keeps the bits of the normalized query normal (the frame re-normalizes)
        traced.normal = n / n.length();
        let evaluation = GatherEvaluation::with_smoothing(
            &traced,
            &settings.weights(),
            settings.hessians(),
            settings.derivative_smoothing,
        )
        .map_err(refusing(TRACED_GATHER))?;
        Ok((prepared, evaluation))
    }
}

/// What refused values of a record's gather are called in errors.
const TRACED_GATHER: &str = "the traced gather";

/// `InvalidArgument` for a non-finite point or normal, a zero normal, or a footprint that is
/// negative or not finite.
pub(super) fn check_query(x: DVec3, n: DVec3, footprint: f64) -> Result<()> {
    ensure_finite3(x, "query position")?;
    ensure_finite3(n, "query normal")?;
    check_footprint(footprint)
}

/// The gather frame at a query: at `x`, about the unit normal of `n`.
pub(super) fn query_frame(x: DVec3, n: DVec3) -> Result<Frame> {
    let unit = n / n.length();
    Frame::new(x, unit, tangent_basis(unit).0)
}

/// Names `what` as the source of an `InvalidArgument` (its message prefixed); other errors pass
/// unchanged.
pub(super) fn refusing(what: &'static str) -> impl Fn(Error) -> Error {
    move |e| match e {
        Error::InvalidArgument(m) => Error::InvalidArgument(format!("{what}: {m}")),
        other => other,
    }
}
