//! The leak guard: the "record in front of the query" test, its tolerance and why (documented
//! on [`LeakGuard`], where users see it).

use glam::DVec3;

use crate::error::{Error, Result};

/// The "record in front of the query" test of Ward's irradiance cache (also in Radiance, pbrt-v2
/// and Mitsuba): a surface record that lies in front of the query point may see geometry the
/// query point does not (the riser of a step, the far side of a concave junction), so its value
/// must not be extrapolated there.
///
/// # The test
/// With the query at x (unit normal n) and record i at xᵢ (unit normal nᵢ), the query's height
/// over the record along the mean normal is
///
/// ```text
///   h = (x − xᵢ)·(n + nᵢ)/2
/// ```
///
/// and the record is rejected when `h < −(relative·Rᵢ + absolute)`, with Rᵢ the record's radius
/// along its normal (the third radius of a surface record, the smaller of its two tangent radii).
///
/// # Why this tolerance
/// * On a plane h = 0, and on a sphere h = 0 exactly (the chord between two points is
///   perpendicular to the sum of their normals), so curvature alone does not trigger the test: for
///   a smooth surface h is of third order in the distance. What remains are steps, creases and the
///   small offsets renderers give their gather points (the pull-back from the surface).
/// * `relative` is scale-free: h/Rᵢ is the query's height below the record in the record's own
///   normalized coordinates, the same coordinate the ellipsoid distance of
///   [`interp`](super::interp) uses along the normal. A step much lower than the record's radius
///   changes what the record sees by little (it fills a thin band near the horizon); one of a
///   sizable fraction of the radius hides part of the record's hemisphere from the query.
/// * `absolute` (length unit L) covers offsets that do not scale with records: the renderer's
///   ray epsilon or pull-back distance (Radiance uses `minarad·ambacc + 0.001`, pbrt-v2 an
///   absolute 0.01).
///
/// The guard is off when the tolerance is infinite ([`LeakGuard::OFF`], the default) and applies
/// in the surface domain only (volume records have no normal).
///
/// In short: a record i is not used at a query whose height over it, `(x − xᵢ)·(n + nᵢ)/2`, is
/// below `−(relative·Rᵢ + absolute)`, Rᵢ the record's radius along its normal. Infinite tolerance
/// turns the guard off.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeakGuard {
    /// Tolerance in units of the record's radius along its normal (dimensionless, ≥ 0, may be
    /// `f64::INFINITY`).
    pub relative: f64,
    /// Tolerance in the length unit L (≥ 0, may be `f64::INFINITY`).
    pub absolute: f64,
}

impl Default for LeakGuard {
    /// [`LeakGuard::OFF`].
    fn default() -> Self {
        LeakGuard::OFF
    }
}

impl LeakGuard {
    /// The guard switched off (infinite relative tolerance): every record passes.
    pub const OFF: LeakGuard = LeakGuard {
        relative: f64::INFINITY,
        absolute: 0.0,
    };

    /// A guard whose tolerance is `relative` times the record's radius along its normal.
    pub fn relative(relative: f64) -> Self {
        LeakGuard {
            relative,
            absolute: 0.0,
        }
    }

    /// Whether the guard rejects anything: both tolerances finite (an absolute tolerance alone
    /// needs `relative` 0).
    pub fn is_on(&self) -> bool {
        (self.relative + self.absolute).is_finite()
    }

    /// `InvalidArgument` unless both tolerances are ≥ 0 (NaN and negative values are refused).
    pub fn validate(&self) -> Result<()> {
        if self.relative >= 0.0 && self.absolute >= 0.0 {
            Ok(())
        } else {
            Err(Error::InvalidArgument(format!(
                "leak guard tolerances must be >= 0 (or infinite: off), got relative {} and \
                 absolute {}",
                self.relative, self.absolute
            )))
        }
    }

    /// Whether a record at `position` with unit `normal` and radius `normal_radius` along it may
    /// be used at the query `x` with unit normal `n` (always, when the guard is off).
    #[inline]
    pub(crate) fn admits(
        &self,
        x: DVec3,
        n: DVec3,
        position: DVec3,
        normal: DVec3,
        normal_radius: f64,
    ) -> bool {
        let height = (x - position).dot(n + normal) * 0.5;
        height >= -(self.relative * normal_radius + self.absolute)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heights_below_the_tolerance_are_refused() {
        let guard = LeakGuard {
            relative: 0.1,
            absolute: 0.01,
        };
        // record at the origin facing +z, radius 1 along its normal: tolerance 0.1 + 0.01
        let at = |z: f64| {
            guard.admits(
                DVec3::new(0.3, 0.0, z),
                DVec3::Z,
                DVec3::ZERO,
                DVec3::Z,
                1.0,
            )
        };
        assert!(at(0.0) && at(1.0) && at(-0.11));
        assert!(!at(-0.111) && !at(-5.0));
        // the off guard admits anything, even far below
        assert!(LeakGuard::OFF.admits(
            DVec3::new(0.0, 0.0, -1e300),
            DVec3::Z,
            DVec3::ZERO,
            DVec3::Z,
            1e-30
        ));
        assert!(!LeakGuard::OFF.is_on() && guard.is_on());
        assert!(LeakGuard::relative(0.0).is_on());
    }

    /// Two points of a sphere have zero height over each other whatever their distance (the chord
    /// is perpendicular to the sum of the normals), so a zero tolerance admits them all.
    #[test]
    fn a_sphere_never_trips_the_guard() {
        let centre = DVec3::new(0.2, -0.4, 1.0);
        let guard = LeakGuard {
            relative: 0.0,
            absolute: 1e-12,
        };
        for k in 0..50 {
            let a = DVec3::new(
                (k as f64 * 0.37).cos(),
                (k as f64 * 0.37).sin(),
                0.3 * (k as f64 - 25.0) / 25.0,
            )
            .normalize();
            let b = DVec3::new((k as f64 * 1.3).sin(), 0.5, (k as f64 * 0.7).cos()).normalize();
            let (p, q) = (centre + 3.0 * a, centre + 3.0 * b);
            assert!(
                guard.admits(p, a, q, b, 1.0) && guard.admits(q, b, p, a, 1.0),
                "{k}"
            );
            // the same points seen from inside (normals flipped: a concave bowl) also pass
            assert!(guard.admits(p, -a, q, -b, 1.0), "{k}");
        }
    }

    #[test]
    fn validation_refuses_nan_and_negative() {
        assert!(LeakGuard::OFF.validate().is_ok());
        assert!(LeakGuard::relative(0.1).validate().is_ok());
        for bad in [f64::NAN, -1.0, f64::NEG_INFINITY] {
            assert!(LeakGuard::relative(bad).validate().is_err());
            assert!(LeakGuard {
                relative: 0.1,
                absolute: bad
            }
            .validate()
            .is_err());
        }
    }
}
