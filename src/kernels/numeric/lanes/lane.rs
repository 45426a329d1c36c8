//! [`Lane`]: a number per lane, and [`Lanes`]: lanes loaded from a group of four nodes.

use std::ops::{Add, Mul, Neg, Sub};

/// A number per lane: `f64` (one edge) or [`Pair`](super::Pair) (two edges).
pub(crate) trait Lane:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Neg<Output = Self>
{
    fn splat(x: f64) -> Self;
    /// `|self|` per lane.
    fn abs(self) -> Self;
    /// `1 / self` per lane.
    fn recip(self) -> Self;
    /// `self / d` per lane.
    fn div(self, d: Self) -> Self;
}

impl Lane for f64 {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn abs(self) -> Self {
        f64::abs(self)
    }
    #[inline(always)]
    fn recip(self) -> Self {
        1.0 / self
    }
    #[inline(always)]
    fn div(self, d: Self) -> Self {
        self / d
    }
}

/// A few `f64` lanes operated on lane by lane, loaded from a group of four nodes.
pub(crate) trait Lanes: Lane {
    /// The lanes `group[first..]` (two or four of them).
    fn load(group: &[f64; 4], first: usize) -> Self;
    /// The sum of the lanes: `l0 + l1`, or `(l0 + l1) + (l2 + l3)`.
    fn total(self) -> f64;
}
