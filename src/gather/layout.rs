//! Stratified direction layouts for hemisphere and sphere gathers (the conventions of `LAYOUTS.md`).
//!
//! A [`Layout`] is an M×N grid of strata; stratum `(j, k)` has index `j*N + k` and holds one
//! direction, placed at the stratum's centre (seed 0) or at a deterministic jitter (any other seed).
//! A [`Frame`] turns local directions `(lx, ly, lz)` into world directions `lx*t + ly*b + lz*n`.
//!
//! * [`LayoutKind::CosinePolar`]: `θ_j = asin(sqrt((j+u)/M))`, `φ_k = 2π(k+v)/N`. Ring 0 is at the
//!   pole, ring M−1 at the horizon. Cosine-weighted: pdf `cosθ/π`, every stratum has probability
//!   `1/(MN)`.
//! * [`LayoutKind::Concentric`]: grid point `s = (2(j+u)/M − 1, 2(k+v)/N − 1)` through the
//!   Shirley-Chiu concentric map to the unit disk, lifted to the hemisphere (Malley). Cosine-weighted,
//!   every stratum has probability `1/(MN)`. Grid neighbours are angular neighbours; the square's
//!   boundary is the horizon and its centre the pole.
//! * [`LayoutKind::Sphere`]: `cosθ_j = 1 − 2(j+u)/M`, `φ_k = 2π(k+v)/N`. Uniform on the whole
//!   sphere: pdf `1/(4π)`, every stratum has solid angle `4π/(MN)`.

use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, TAU};

use glam::{DVec2, DVec3};

use crate::error::{ensure_finite3, Error, Result};

/// Which stratification a gather uses. The discriminants are the C constants
/// `RADDIFF_LAYOUT_COSINE_POLAR`, `RADDIFF_LAYOUT_CONCENTRIC` and `RADDIFF_LAYOUT_SPHERE`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum LayoutKind {
    /// Ward-Heckbert cosine-weighted polar strata over the hemisphere around the normal.
    CosinePolar = 0,
    /// Cosine-weighted strata from the Shirley-Chiu concentric map of an M×N grid.
    Concentric = 1,
    /// Equal solid-angle strata over the whole sphere (points inside a medium).
    Sphere = 2,
}

impl LayoutKind {
    /// Whether the layout covers only the hemisphere around the frame's normal.
    pub fn is_hemisphere(self) -> bool {
        !matches!(self, LayoutKind::Sphere)
    }

    /// The measure every stratum carries an equal share of: π for the cosine-weighted hemisphere
    /// (`∫ n·ω dω`), 4π sr for the sphere.
    pub fn measure(self) -> f64 {
        if self.is_hemisphere() {
            std::f64::consts::PI
        } else {
            4.0 * std::f64::consts::PI
        }
    }
}

impl TryFrom<u32> for LayoutKind {
    type Error = Error;
    fn try_from(v: u32) -> Result<Self> {
        match v {
            0 => Ok(LayoutKind::CosinePolar),
            1 => Ok(LayoutKind::Concentric),
            2 => Ok(LayoutKind::Sphere),
            _ => Err(Error::InvalidArgument(format!(
                "layout kind {v} is not RADDIFF_LAYOUT_COSINE_POLAR (0), _CONCENTRIC (1) or _SPHERE (2)"
            ))),
        }
    }
}

/// An orthonormal frame at the gather point: `position` x, unit `normal` n, unit `tangent` t
/// perpendicular to n; the bitangent is `b = n × t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// The gather point x (length unit L).
    pub position: DVec3,
    /// Unit normal n: the pole of the layout.
    pub normal: DVec3,
    /// Unit tangent t, perpendicular to n: the direction of azimuth φ = 0.
    pub tangent: DVec3,
}

impl Frame {
    /// How far a frame may be from orthonormal: `| |n|² − 1 |`, `| |t|² − 1 |` and `|n·t|` must
    /// each be at most this. Within it, the frame is re-orthonormalized (Gram-Schmidt, keeping `n`).
    ///
    /// cbindgen:ignore
    pub const TOLERANCE: f64 = 1e-6;

    /// A validated frame. `normal` and `tangent` must be unit and perpendicular within
    /// [`Frame::TOLERANCE`]; they are re-orthonormalized (so directions are unit to rounding).
    pub fn new(position: DVec3, normal: DVec3, tangent: DVec3) -> Result<Frame> {
        Frame {
            position,
            normal,
            tangent,
        }
        .orthonormalized()
    }

    /// Checks this frame against [`Frame::TOLERANCE`] and returns it with `normal` normalized and
    /// `tangent` made exactly perpendicular to it.
    pub fn orthonormalized(&self) -> Result<Frame> {
        ensure_finite3(self.position, "frame position")?;
        ensure_finite3(self.normal, "frame normal")?;
        ensure_finite3(self.tangent, "frame tangent")?;
        let nn = self.normal.length_squared();
        let tt = self.tangent.length_squared();
        if (nn - 1.0).abs() > Frame::TOLERANCE {
            return Err(Error::InvalidArgument(format!(
                "frame normal is not unit (|n|^2 = {nn})"
            )));
        }
        if (tt - 1.0).abs() > Frame::TOLERANCE {
            return Err(Error::InvalidArgument(format!(
                "frame tangent is not unit (|t|^2 = {tt})"
            )));
        }
        let nt = self.normal.dot(self.tangent);
        if nt.abs() > Frame::TOLERANCE {
            return Err(Error::InvalidArgument(format!(
                "frame tangent is not perpendicular to the normal (n.t = {nt})"
            )));
        }
        let normal = self.normal / nn.sqrt();
        let tangent = (self.tangent - normal * self.tangent.dot(normal)).normalize();
        Ok(Frame {
            position: self.position,
            normal,
            tangent,
        })
    }

    /// The bitangent `n × t`.
    #[inline]
    pub fn bitangent(&self) -> DVec3 {
        self.normal.cross(self.tangent)
    }

    /// World vector `l.x*t + l.y*b + l.z*n` of a local vector.
    #[inline]
    pub fn to_world(&self, l: DVec3) -> DVec3 {
        self.tangent * l.x + self.bitangent() * l.y + self.normal * l.z
    }

    /// Local coordinates `(w·t, w·b, w·n)` of a world vector.
    #[inline]
    pub fn to_local(&self, w: DVec3) -> DVec3 {
        DVec3::new(
            w.dot(self.tangent),
            w.dot(self.bitangent()),
            w.dot(self.normal),
        )
    }
}

/// The boundaries of one stratum, for triangulating hit points with the grid connectivity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StratumBounds {
    /// Polar and sphere layouts: the stratum is `θ ∈ [theta.0, theta.1]`, `φ ∈ [phi.0, phi.1]`
    /// (radians; θ from the normal, φ from the tangent towards the bitangent).
    Polar {
        /// `(θ−, θ+)`.
        theta: (f64, f64),
        /// `(φ−, φ+)`.
        phi: (f64, f64),
    },
    /// Concentric layout: the stratum is the image of the square cell `[min, max]` of `[−1, 1]²`
    /// under [`concentric_to_local`]. Its walls are curves, not θ/φ lines.
    Square {
        /// Lower corner `(2j/M − 1, 2k/N − 1)`.
        min: DVec2,
        /// Upper corner `(2(j+1)/M − 1, 2(k+1)/N − 1)`.
        max: DVec2,
    },
}

/// An M×N stratified layout. Construct with [`Layout::new`] (validating) or fill the fields and
/// call [`Layout::validate`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Layout {
    /// The stratification.
    pub kind: LayoutKind,
    /// Strata along θ (polar, sphere) or along the first square axis (concentric), 1..=[`Layout::MAX_STRATA_PER_AXIS`].
    pub m: u32,
    /// Strata along φ (polar, sphere) or along the second square axis (concentric), 1..=[`Layout::MAX_STRATA_PER_AXIS`].
    pub n: u32,
    /// 0: stratum centres; anything else: deterministic per-stratum jitter.
    pub seed: u64,
}

impl Layout {
    /// Largest number of strata along either axis (M or N).
    ///
    /// cbindgen:ignore
    pub const MAX_STRATA_PER_AXIS: u32 = 1 << 16;

    /// Largest total number of strata M·N (16 Mi rays).
    ///
    /// cbindgen:ignore
    pub const MAX_STRATA: u64 = 1 << 24;

    /// A validated layout (see [`Layout::validate`]).
    pub fn new(kind: LayoutKind, m: u32, n: u32, seed: u64) -> Result<Layout> {
        let layout = Layout { kind, m, n, seed };
        layout.validate()?;
        Ok(layout)
    }

    /// `InvalidArgument` unless `1 ≤ m, n ≤ Layout::MAX_STRATA_PER_AXIS` and `m·n ≤ Layout::MAX_STRATA`.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [("m", self.m), ("n", self.n)] {
            if v == 0 || v > Layout::MAX_STRATA_PER_AXIS {
                return Err(Error::InvalidArgument(format!(
                    "layout {name} = {v} is outside 1..={}",
                    Layout::MAX_STRATA_PER_AXIS
                )));
            }
        }
        if self.len() as u64 > Layout::MAX_STRATA {
            return Err(Error::InvalidArgument(format!(
                "layout m*n = {} exceeds the maximum {}",
                self.len(),
                Layout::MAX_STRATA
            )));
        }
        Ok(())
    }

    /// Number of strata (and directions) M·N.
    #[inline]
    pub fn len(&self) -> usize {
        self.m as usize * self.n as usize
    }

    /// Whether the layout has no strata (never true for a validated layout).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index `j*N + k` of stratum `(j, k)`.
    #[inline]
    pub fn index(&self, j: u32, k: u32) -> usize {
        j as usize * self.n as usize + k as usize
    }

    /// Jitter `(u, v) ∈ [0, 1)²` of stratum `(j, k)`: `(0.5, 0.5)` for seed 0, otherwise from an
    /// integer hash (splitmix64) of `(seed, j, k)`, identical on every platform.
    #[inline]
    pub fn jitter(&self, j: u32, k: u32) -> DVec2 {
        if self.seed == 0 {
            return DVec2::splat(0.5);
        }
        let h = splitmix64(self.seed ^ splitmix64(((j as u64) << 32) | k as u64));
        let h2 = splitmix64(h);
        DVec2::new(unit_f64(h), unit_f64(h2))
    }

    /// Local direction of stratum `(j, k)` (its jittered sample), unit length.
    #[inline]
    pub fn local_direction(&self, j: u32, k: u32) -> DVec3 {
        let uv = self.jitter(j, k);
        self.grid_to_local(j as f64 + uv.x, k as f64 + uv.y)
    }

    /// World direction of stratum `(j, k)` in `frame` (which must be orthonormal: see
    /// [`Frame::orthonormalized`]).
    #[inline]
    pub fn world_direction(&self, frame: &Frame, j: u32, k: u32) -> DVec3 {
        frame.to_world(self.local_direction(j, k))
    }

    /// Local direction of the continuous grid point `(a, b)`, `a ∈ [0, M]`, `b ∈ [0, N]`: stratum
    /// `(j, k)` is the image of `[j, j+1] × [k, k+1]`, so integer points give the strata corners.
    /// Inputs are clamped to the grid.
    pub fn grid_to_local(&self, a: f64, b: f64) -> DVec3 {
        let m = self.m as f64;
        let n = self.n as f64;
        let a = a.clamp(0.0, m);
        let b = b.clamp(0.0, n);
        match self.kind {
            LayoutKind::CosinePolar => {
                let s2 = a / m;
                let sin_t = s2.sqrt();
                let cos_t = (1.0 - s2).max(0.0).sqrt();
                let (sp, cp) = (TAU * b / n).sin_cos();
                DVec3::new(sin_t * cp, sin_t * sp, cos_t)
            }
            LayoutKind::Sphere => {
                let cos_t = 1.0 - 2.0 * a / m;
                // (1 − c)(1 + c) keeps precision near both poles.
                let sin_t = ((1.0 - cos_t) * (1.0 + cos_t)).max(0.0).sqrt();
                let (sp, cp) = (TAU * b / n).sin_cos();
                DVec3::new(sin_t * cp, sin_t * sp, cos_t)
            }
            LayoutKind::Concentric => {
                concentric_to_local(DVec2::new(2.0 * a / m - 1.0, 2.0 * b / n - 1.0))
            }
        }
    }

    /// The walls of stratum `(j, k)`.
    pub fn stratum_bounds(&self, j: u32, k: u32) -> StratumBounds {
        let m = self.m as f64;
        let n = self.n as f64;
        let (j, k) = (j as f64, k as f64);
        match self.kind {
            LayoutKind::CosinePolar => StratumBounds::Polar {
                theta: (
                    (j / m).sqrt().asin(),
                    ((j + 1.0) / m).min(1.0).sqrt().asin(),
                ),
                phi: (TAU * k / n, TAU * (k + 1.0) / n),
            },
            LayoutKind::Sphere => StratumBounds::Polar {
                theta: (
                    (1.0 - 2.0 * j / m).clamp(-1.0, 1.0).acos(),
                    (1.0 - 2.0 * (j + 1.0) / m).clamp(-1.0, 1.0).acos(),
                ),
                phi: (TAU * k / n, TAU * (k + 1.0) / n),
            },
            LayoutKind::Concentric => StratumBounds::Square {
                min: DVec2::new(2.0 * j / m - 1.0, 2.0 * k / n - 1.0),
                max: DVec2::new(2.0 * (j + 1.0) / m - 1.0, 2.0 * (k + 1.0) / n - 1.0),
            },
        }
    }

    /// Writes the world directions of every stratum (index `j*N + k`) into `out`.
    ///
    /// `InvalidArgument` if the layout or frame is invalid or `out.len() != M·N`; nothing is
    /// written then.
    pub fn directions_into(&self, frame: &Frame, out: &mut [DVec3]) -> Result<()> {
        self.validate()?;
        let frame = frame.orthonormalized()?;
        if out.len() != self.len() {
            return Err(Error::InvalidArgument(format!(
                "directions buffer holds {} entries, the layout has m*n = {}",
                out.len(),
                self.len()
            )));
        }
        let b = frame.bitangent();
        for j in 0..self.m {
            for k in 0..self.n {
                let l = self.local_direction(j, k);
                out[self.index(j, k)] = frame.tangent * l.x + b * l.y + frame.normal * l.z;
            }
        }
        Ok(())
    }

    /// The world directions of every stratum, index `j*N + k`.
    pub fn directions(&self, frame: &Frame) -> Result<Vec<DVec3>> {
        self.validate()?;
        let mut out = vec![DVec3::ZERO; self.len()];
        self.directions_into(frame, &mut out)?;
        Ok(out)
    }
}

/// Shirley-Chiu concentric map of `s ∈ [−1, 1]²` to the unit disk, lifted to the upper unit
/// hemisphere: `(dx, dy, sqrt(max(0, 1 − dx² − dy²)))`. Area-preserving up to a constant, so
/// uniform `s` gives cosine-weighted directions.
pub fn concentric_to_local(s: DVec2) -> DVec3 {
    let (a, b) = (s.x, s.y);
    let d = if a == 0.0 && b == 0.0 {
        DVec2::ZERO
    } else if a.abs() > b.abs() {
        let (sp, cp) = (FRAC_PI_4 * (b / a)).sin_cos();
        DVec2::new(a * cp, a * sp)
    } else {
        let (sp, cp) = (FRAC_PI_2 - FRAC_PI_4 * (a / b)).sin_cos();
        DVec2::new(b * cp, b * sp)
    };
    DVec3::new(d.x, d.y, (1.0 - d.length_squared()).max(0.0).sqrt())
}

/// splitmix64 (Steele, Lea, Flood 2014): a bijective 64-bit mixer, integer operations only.
#[inline]
fn splitmix64(x: u64) -> u64 {
    let mut z = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The top 53 bits as a double in `[0, 1)` (exact conversion).
#[inline]
fn unit_f64(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

#[cfg(test)]
mod tests;
