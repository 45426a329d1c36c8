//! Neighbour clamping of record radii (thesis 3.5.4; Křivánek et al. 2006, "Making radiance and
//! irradiance caching practical"): a record's bounding radius may not exceed a neighbour's radius
//! plus their distance, Rᵢ ≤ Rⱼ + dᵢⱼ, so that a large record cannot reach far past a small
//! neighbour that the error metric found necessary.

use std::sync::atomic::AtomicUsize;

use glam::DVec3;

use super::record::{Channels, Domain, Extent, Head, RADIUS_MIN};
use super::{index, store, Cache, CacheValue, PRECISION_RATIO};
use crate::error::{ensure_finite, ensure_finite3, Error, Result};

/// The largest `f32` radius that is at most `bound`, raised if needed to the smallest radius
/// the cache accepts for a record at `position` ([`RADIUS_MIN`] and |position|·2⁻⁴⁰).
fn radius_at_most(bound: f64, position: DVec3) -> f32 {
    let mut r = bound as f32;
    if r as f64 > bound && r > 0.0 {
        r = f32::from_bits(r.to_bits() - 1);
    }
    let reach = position.abs().max_element() / PRECISION_RATIO;
    let mut floor = reach as f32;
    if (floor as f64) < reach {
        floor = f32::from_bits(floor.to_bits() + 1);
    }
    r.max(floor).max(RADIUS_MIN as f32)
}

/// `radii` (stored, `f32`) scaled uniformly so that the largest becomes `largest` (≤ the current
/// largest): the largest axis is set to `largest` exactly, the others scaled and kept within
/// [`RADIUS_MIN`, `largest`]; in the surface domain the normal radius stays min(radii[0], radii[1]).
fn scale_stored_radii(domain: Domain, radii: [f32; 3], largest: f32) -> [f32; 3] {
    let max = radii[0].max(radii[1]).max(radii[2]);
    let s = largest as f64 / max as f64;
    let mut out = radii.map(|r| {
        if r == max {
            largest
        } else {
            ((r as f64 * s) as f32).clamp(RADIUS_MIN as f32, largest)
        }
    });
    if domain == Domain::Surface {
        out[2] = out[0].min(out[1]);
    }
    out
}

/// The largest radius of an extent as the cache stores it (surface: `radii[2]` is ignored).
fn extent_max_radius(domain: Domain, extent: &Extent) -> f64 {
    match domain {
        Domain::Surface => extent.radii[0].max(extent.radii[1]),
        Domain::Volume => extent.max_radius(),
    }
}

impl<V: CacheValue> Cache<V> {
    /// Calls `f(id)` for every record whose bounding sphere may meet the ball (`position`,
    /// `reach`) — a superset of the records whose centre lies within `reach` — through the index's
    /// ball query, or through every record when that would probe more cells than there are
    /// records (a ball much larger than the finest records).
    fn for_each_near(&self, position: DVec3, reach: f64, mut f: impl FnMut(u32)) {
        let len = self.len();
        if self.index.ball_cells(position, reach) <= len as f64 {
            self.index.query_ball(position, reach, |id, _, _| f(id));
        } else {
            (0..len as u32).for_each(f);
        }
    }

    /// Neighbour clamping (thesis 3.5.4, Křivánek et al. 2006) for a record about to be inserted
    /// at `position` with `extent`: with R its largest radius (surface domain: of `radii[0..2]`),
    /// every stored record j at distance dⱼ = ‖position − xⱼ‖ < R bounds R by Rⱼ + dⱼ (Rⱼ its
    /// largest stored radius). Records farther away cannot bind (Rⱼ + dⱼ ≥ R), so this includes
    /// the previous rule's records whose sphere contains `position`. The extent is scaled
    /// uniformly (anisotropy and axes kept) so that its largest radius is the largest `f32` at
    /// most the tightest bound: inserted, the record's stored largest radius satisfies every
    /// bound exactly (smaller radii are raised to [`RADIUS_MIN`] and to
    /// |position|·2⁻⁴⁰, what [`Cache::insert`] accepts). Returns `extent` unchanged when no
    /// bound binds.
    ///
    /// One-sided: stored records are not shrunk towards the new one (their R ≤ R_new + d); run
    /// [`Cache::clamp_neighbours`] once the cache is filled for the two-sided fixed point.
    /// `InvalidArgument` for a non-finite position or radius, or a negative radius among those the
    /// domain uses. Thread-safe (it reads the records
    /// inserted before the call).
    pub fn clamp_to_neighbours(&self, position: DVec3, extent: &Extent) -> Result<Extent> {
        ensure_finite3(position, "position")?;
        for r in extent.radii {
            ensure_finite(r, "radius")?;
        }
        // A negative radius would be raised to RADIUS_MIN below and come back looking valid
        // (found by fuzzing, fuzz/regressions/cache_ops/); the surface domain ignores radii[2].
        let used = match self.config.domain {
            Domain::Surface => 2,
            Domain::Volume => 3,
        };
        if let Some((i, r)) = extent.radii[..used]
            .iter()
            .enumerate()
            .find(|(_, r)| **r < 0.0)
        {
            return Err(Error::InvalidArgument(format!(
                "radii[{i}] = {r} is negative"
            )));
        }
        let r = extent_max_radius(self.config.domain, extent);
        if r <= 0.0 {
            return Ok(*extent);
        }
        let mut limit = f64::INFINITY;
        self.for_each_near(position, r, |id| {
            let head = self.stored(id).0;
            let distance = (position - head.position()).length();
            if distance < r {
                limit = limit.min(head.max_radius() + distance);
            }
        });
        if r <= limit {
            return Ok(*extent);
        }
        let largest = radius_at_most(limit, position) as f64;
        if largest >= r {
            return Ok(*extent);
        }
        let s = largest / r;
        Ok(Extent {
            radii: extent.radii.map(|x| {
                if x >= r {
                    largest
                } else {
                    (x * s).clamp(RADIUS_MIN, largest)
                }
            }),
            axes: extent.axes,
        })
    }

    /// Two-sided neighbour clamping of every stored record; returns how many records shrank.
    ///
    /// With Rᵢ the records' current largest radii and dᵢⱼ = ‖xᵢ − xⱼ‖, the new radius is
    /// Rᵢ' = min(Rᵢ, minⱼ (Rⱼ + dᵢⱼ)) over all records j with dᵢⱼ < Rᵢ (the others cannot bind);
    /// each shrinking record's radii are all scaled by Rᵢ'/Rᵢ (anisotropy and frame kept).
    ///
    /// Why one pass over the *original* radii suffices: R' satisfies every pairwise constraint
    /// Rᵢ' ≤ Rⱼ' + dᵢⱼ. If Rⱼ' = Rⱼ this is Rᵢ' ≤ Rⱼ + dᵢⱼ, true by definition; otherwise
    /// Rⱼ' = Rₖ + dⱼₖ for some k, and Rᵢ' ≤ Rₖ + dᵢₖ ≤ Rₖ + dⱼₖ + dᵢⱼ = Rⱼ' + dᵢⱼ by the triangle
    /// inequality (for k = i, Rᵢ' ≤ Rᵢ ≤ Rⱼ' + dᵢⱼ since Rⱼ' = Rᵢ + dᵢⱼ). Conversely every S ≤ R
    /// that satisfies the constraints has Sᵢ ≤ Sⱼ + dᵢⱼ ≤ Rⱼ + dᵢⱼ, so Sᵢ ≤ Rᵢ'. R' is therefore
    /// the largest fixed point of the constraints below R: a distance transform in which every
    /// path j → k → i is at least as long as the direct edge j → i, so relaxing along longer paths
    /// never tightens anything. It is a function of the record set alone — independent of record
    /// order and thread timing — and idempotent (R' already satisfies every constraint).
    ///
    /// Storage: radii are `f32`. A shrinking record's largest radius becomes the largest `f32` at
    /// most its bound (raised only to what [`Cache::insert`] accepts: [`RADIUS_MIN`]
    /// and |position|·2⁻⁴⁰); because rounding a neighbour down can leave a constraint violated by
    /// an ulp, the pass is repeated (each round computed from the previous round's radii, so still
    /// order-independent) until no stored radius changes; in exact arithmetic the repeats change
    /// nothing. Afterwards every stored pair satisfies Rᵢ ≤ Rⱼ + dᵢⱼ as evaluated in `f64`, and a
    /// second call returns 0.
    ///
    /// Records that become byte-identical to another (e.g. two records at one position differing
    /// only in radius) are then stored once, so [`Cache::len`] may drop. The spatial index is
    /// rebuilt and the cache compacted (as [`Cache::compact`]); lookups keep summing covering
    /// records in content order. Cost: one index query per record plus the rebuild. Needs
    /// exclusive access.
    pub fn clamp_neighbours(&mut self) -> usize {
        let n = self.len();
        if n < 2 {
            return 0;
        }
        let heads: Vec<Head> = (0..n as u32).map(|i| *self.stored(i).0).collect();
        let original: Vec<f64> = heads.iter().map(Head::max_radius).collect();
        // (i, j, dᵢⱼ) for dᵢⱼ < Rᵢ: the records i whose sphere contains xⱼ (radii only shrink,
        // so no other pair can bind in any round)
        let mut pairs: Vec<(u32, u32, f64)> = Vec::new();
        for j in 0..n as u32 {
            let xj = heads[j as usize].position();
            self.index.query(xj, |i| {
                let d = (heads[i as usize].position() - xj).length();
                if i != j && d < original[i as usize] {
                    pairs.push((i, j, d));
                }
            });
        }
        let mut radius = original.clone();
        loop {
            let mut bound = vec![f64::INFINITY; n];
            for &(i, j, d) in &pairs {
                let b = &mut bound[i as usize];
                *b = b.min(radius[j as usize] + d);
            }
            let mut changed = false;
            for (i, b) in bound.into_iter().enumerate() {
                if radius[i] > b {
                    let r = radius_at_most(b, heads[i].position()) as f64;
                    if r < radius[i] {
                        radius[i] = r;
                        changed = true;
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let shrunk = (0..n).filter(|&i| radius[i] < original[i]).count();
        if shrunk == 0 {
            return 0;
        }
        let records: Vec<(Head, Channels)> = (0..n)
            .map(|i| {
                let mut head = heads[i];
                if radius[i] < original[i] {
                    head.radii =
                        scale_stored_radii(self.config.domain, head.radii, radius[i] as f32);
                }
                (head, self.stored(i as u32).1.iter().copied().collect())
            })
            .collect();
        self.records = store::Chunks::new(self.records.slot_len());
        self.index = index::Grid::new();
        self.len = AtomicUsize::new(0);
        for (head, chans) in &records {
            if !self.holds(head, chans) {
                self.append(head, chans);
            }
        }
        self.generation += 1;
        self.compact();
        shrunk
    }
}
