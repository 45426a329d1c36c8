//! [`V3`]: a 3-vector per lane.

use std::ops::{Add, Sub};

use glam::DVec3;

use super::lane::Lane;
use super::pair::Pair;

/// A 3-vector per lane, with glam's operation order (so `V3<f64>` rounds as `DVec3` does).
#[derive(Clone, Copy, Debug)]
pub(crate) struct V3<L> {
    pub x: L,
    pub y: L,
    pub z: L,
}

impl<L: Lane> V3<L> {
    #[inline(always)]
    pub(crate) fn splat(v: DVec3) -> Self {
        V3 {
            x: L::splat(v.x),
            y: L::splat(v.y),
            z: L::splat(v.z),
        }
    }
    #[inline(always)]
    pub(crate) fn dot(self, o: Self) -> L {
        (self.x * o.x) + (self.y * o.y) + (self.z * o.z)
    }
    #[inline(always)]
    pub(crate) fn cross(self, o: Self) -> Self {
        V3 {
            x: self.y * o.z - o.y * self.z,
            y: self.z * o.x - o.z * self.x,
            z: self.x * o.y - o.x * self.y,
        }
    }
    #[inline(always)]
    pub(crate) fn scale(self, s: L) -> Self {
        V3 {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
}

impl V3<f64> {
    #[inline(always)]
    pub(crate) fn from_dvec(v: DVec3) -> Self {
        V3 {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
    #[inline(always)]
    pub(crate) fn to_dvec(self) -> DVec3 {
        DVec3::new(self.x, self.y, self.z)
    }
}

impl V3<Pair> {
    /// `a` in lane 0, `b` in lane 1.
    #[inline(always)]
    pub(crate) fn pair(a: DVec3, b: DVec3) -> Self {
        V3 {
            x: Pair::new(a.x, b.x),
            y: Pair::new(a.y, b.y),
            z: Pair::new(a.z, b.z),
        }
    }
    /// Lane `l` (0 or 1).
    #[inline(always)]
    pub(crate) fn lane(self, l: usize) -> DVec3 {
        DVec3::new(self.x.get(l), self.y.get(l), self.z.get(l))
    }
}

impl<L: Lane> Add for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V3 {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }
}

impl<L: Lane> Sub for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V3 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }
}
