//! Per-thread lookup state for spatially coherent queries.
//!
//! A renderer's successive lookups are close to each other (pixels of a tile, steps along a ray).
//! A [`Cursor`] remembers the records whose bounding spheres meet a small ball around an anchor
//! point; while queries stay in that ball and the cache is unchanged, a lookup tests those few
//! spheres (eight at a time) instead of probing the index. The records found, their order and so
//! every result are exactly those of [`Cache::lookup`](super::Cache::lookup): a record that covers
//! a query point in the ball is always among the remembered ones.
//!
//! The cursor re-anchors when a query leaves the ball, the cache has grown since it anchored, or
//! it is used with another cache (or after [`Cache::compact`](super::Cache::compact)). While a
//! cache grows between successive lookups (the fill phase of a render), anchoring would be wasted
//! work, so those lookups take the plain path.

use glam::DVec3;

use super::index::{hits, LANES};

/// Per-thread state that makes coherent lookups cheaper (see the [module docs](self)).
/// Create one per thread with [`Cursor::new`] and pass it to
/// [`Cache::lookup_with`](super::Cache::lookup_with); it holds no reference to any cache.
#[derive(Debug, Clone, Default)]
pub struct Cursor {
    /// (cache identity, compaction generation, record count) the candidates were taken from.
    source: Option<(u64, u64, usize)>,
    /// Record count seen by the previous lookup (anchoring waits until it stops changing).
    last_len: usize,
    anchor: DVec3,
    reach: f64,
    /// Candidate spheres relative to the anchor, `f32`, padded to whole lanes with empty spheres.
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    radius2: Vec<f32>,
    /// The remembered records' slot addresses (valid while `source` matches the cache: records
    /// move only in `Cache::compact`, which changes the generation).
    slots: Vec<usize>,
    /// How many lookups each plan served (remembered, anchored, plain): for tests and tuning.
    pub(crate) served: [usize; 3],
}

/// What a lookup should do with its cursor.
pub(crate) enum Plan {
    /// The remembered candidates serve this query.
    Remembered,
    /// Anchor at the query (ball radius given), then use the candidates.
    Anchor(f64),
    /// Use the index directly.
    Plain,
}

impl Cursor {
    /// An empty cursor (it anchors on first use).
    pub fn new() -> Self {
        Self::default()
    }

    /// Decides how a query at `p` is served for a cache in state `source` whose finest index
    /// level has cells of side `finest_side`.
    pub(crate) fn plan(&mut self, source: (u64, u64, usize), p: DVec3, finest_side: f64) -> Plan {
        let len = source.2;
        let stable = len == self.last_len;
        self.last_len = len;
        if self.source == Some(source)
            && (p - self.anchor).length_squared() <= self.reach * self.reach
        {
            self.served[0] += 1;
            return Plan::Remembered;
        }
        if !stable {
            self.source = None;
            self.served[2] += 1;
            return Plan::Plain;
        }
        self.served[1] += 1;
        // half the finest cell side: the ball query then visits at most 3 cells per axis and
        // level, and the ball stays smaller than the smallest record's bounding sphere
        Plan::Anchor(0.5 * finest_side)
    }

    /// Starts a new candidate set around `anchor` (queries up to `reach` away will use it).
    pub(crate) fn reset(&mut self, source: (u64, u64, usize), anchor: DVec3, reach: f64) {
        self.source = Some(source);
        self.anchor = anchor;
        self.reach = reach;
        self.x.clear();
        self.y.clear();
        self.z.clear();
        self.radius2.clear();
        self.slots.clear();
    }

    /// Remembers the record at slot address `slot` with listed bounding sphere (center, radius).
    pub(crate) fn push(&mut self, slot: usize, center: DVec3, radius: f64) {
        let off = center - self.anchor;
        // conservative in f32: covers the rounding of the offsets, of the query and of the test
        let r = radius * (1.0 + 1e-5) + 1e-6 * (off.length() + self.reach);
        let mut r2 = (r * r) as f32;
        if (r2 as f64) < r * r {
            r2 = f32::from_bits(r2.to_bits() + 1);
        }
        self.x.push(off.x as f32);
        self.y.push(off.y as f32);
        self.z.push(off.z as f32);
        self.radius2.push(r2);
        self.slots.push(slot);
    }

    /// Pads the candidate arrays to whole lanes with spheres that contain nothing.
    pub(crate) fn seal(&mut self) {
        while self.slots.len() % LANES != 0 {
            self.x.push(0.0);
            self.y.push(0.0);
            self.z.push(0.0);
            self.radius2.push(-1.0);
            self.slots.push(0);
        }
    }

    /// Calls `f(slot)` for every remembered record whose sphere contains `p`.
    #[inline]
    pub(crate) fn candidates(&self, p: DVec3, mut f: impl FnMut(usize)) {
        let q = (p - self.anchor).as_vec3();
        let q = [q.x, q.y, q.z];
        let lane = |a: &[f32], base: usize| -> [f32; LANES] {
            a[base..base + LANES].try_into().unwrap_or([0.0; LANES])
        };
        for base in (0..self.slots.len()).step_by(LANES) {
            let mut mask = hits(
                lane(&self.x, base),
                lane(&self.y, base),
                lane(&self.z, base),
                lane(&self.radius2, base),
                q,
            );
            while mask != 0 {
                f(self.slots[base + mask.trailing_zeros() as usize]);
                mask &= mask - 1;
            }
        }
    }
}
