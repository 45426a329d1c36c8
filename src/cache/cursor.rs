//! Per-thread lookup state for spatially coherent queries.
//!
//! A renderer's successive lookups are close to each other (pixels of a tile, steps along a ray).
//! A [`Cursor`] remembers the records whose bounding spheres meet a small ball around an anchor
//! point, already decoded (position, radii, frame); while queries stay in that ball and the cache
//! is unchanged, a lookup weighs those few records (four at a time) instead of probing the index
//! and decoding each candidate. The records used, their order and so every result are exactly
//! those of [`Cache::lookup`](super::Cache::lookup): a record that covers a query point in the ball
//! is always among the remembered ones, and its weight is computed with the same operations.
//!
//! The cursor re-anchors when a query leaves the ball, the cache has grown since it anchored, or
//! it is used with another cache (or after [`Cache::compact`](super::Cache::compact)). While a
//! cache grows between successive lookups (the fill phase of a render), anchoring would be wasted
//! work, so those lookups take the plain path; so do the lookups after an anchor that served
//! almost none (incoherent queries), for a cool-down that doubles with every further wasted anchor
//! and ends early when two successive queries are close again.

use glam::DVec3;

use super::blend::Covering;
use super::interp::Kernel;
use super::record::{Channel, Domain, Head};
use super::weigh::{push, record_weight, UsedRecords};

/// Records per group (the lanes of the vector code).
const GROUP: usize = 4;

/// Up to [`GROUP`] remembered records, decoded, one lane each (structure of arrays).
#[derive(Debug, Clone, Copy, Default)]
struct Group {
    position: [[f64; GROUP]; 3],
    /// Isotropic records: the radius.
    radius: [f64; GROUP],
    /// The square of a radius slightly larger than the bounding radius: a lane whose squared
    /// distance exceeds it cannot cover the query (lets a group skip its square roots and
    /// divisions).
    reach2: [f64; GROUP],
    /// The normal the weight uses (the frame's third axis; zero for isotropic volume records).
    normal: [[f64; GROUP]; 3],
    /// Anisotropic records: the first two frame axes and the three radii.
    axes: [[[f64; GROUP]; 3]; 2],
    radii: [[f64; GROUP]; 3],
    /// The radius along the normal (the stored third radius), for the leak guard.
    normal_radius: [f64; GROUP],
    /// The records' coded open fractions, for the open-fraction test.
    open_code: [u32; GROUP],
    /// The records' gradient scales (translational, rotational), for the blend.
    gradient_scale: [f32; GROUP],
    rotation_scale: [f32; GROUP],
    /// Bit k: lane k holds an anisotropic record.
    anisotropic: u8,
    slots: [usize; GROUP],
    len: u8,
}

/// Per-thread state that makes coherent lookups cheaper: it remembers, decoded, the records whose
/// bounding spheres meet a small ball around an anchor point, and serves queries inside the ball
/// from them while the cache is unchanged (re-anchoring when a query leaves the ball, the cache
/// grows or is compacted, or it is used with another cache; after anchors that served almost no
/// lookups it falls back to the index for a while). The results are bit for bit those of
/// [`Cache::lookup_indexed`](super::Cache::lookup_indexed).
/// Create one per thread with [`Cursor::new`] and pass it to
/// [`Cache::lookup_with`](super::Cache::lookup_with); it holds no reference to any cache.
#[derive(Debug, Clone, Default)]
pub struct Cursor {
    /// (cache identity, compaction generation, record count) the candidates were taken from.
    source: Option<(u64, u64, usize)>,
    /// Record count seen by the previous lookup (anchoring waits until it stops changing).
    last_len: usize,
    anchor: DVec3,
    pub(crate) reach: f64,
    /// The remembered records in content order, decoded; their slot addresses stay valid while
    /// `source` matches the cache (records move only in `Cache::compact`, which changes the
    /// generation).
    groups: Vec<Group>,
    /// Lookups the current anchor has served (the anchoring one included).
    uses: usize,
    /// Whether the current anchor's usefulness has been judged (at the first query outside it).
    judged: bool,
    /// The previous query (a query close to it ends a cool-down: coherence is back).
    last_query: DVec3,
    /// Plain lookups still to make before anchoring again (after an anchor that served too few).
    cool_down: usize,
    /// The next cool-down: doubles after each wasted anchor (up to [`MAX_COOL_DOWN`]), back to
    /// [`COOL_DOWN`] after a useful one.
    backoff: usize,
    /// How many lookups each plan served (remembered, anchored, plain): for tests and tuning.
    pub(crate) served: [usize; 3],
}

/// An anchor that served fewer lookups than this was wasted work (anchoring costs about one and a
/// half plain lookups): the queries are not coherent at the cursor's scale.
const MIN_USES: usize = 3;

/// Plain lookups made after a wasted anchor before the cursor tries anchoring again (doubling
/// after each further wasted anchor, up to [`MAX_COOL_DOWN`]), so that incoherent queries cost
/// about a plain lookup each, and coherence that comes back is used again.
const COOL_DOWN: usize = 4;

/// Upper bound of the cool-down.
const MAX_COOL_DOWN: usize = 256;

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
        let step2 = (p - self.last_query).length_squared();
        self.last_query = p;
        let current = self.source == Some(source);
        if current && (p - self.anchor).length_squared() <= self.reach * self.reach {
            self.uses += 1;
            self.served[0] += 1;
            return Plan::Remembered;
        }
        if !stable {
            self.source = None;
            self.served[2] += 1;
            return Plan::Plain;
        }
        if current && !self.judged {
            self.judged = true;
            if self.uses < MIN_USES {
                self.backoff = self.backoff.clamp(COOL_DOWN / 2, MAX_COOL_DOWN / 2) * 2;
                self.cool_down = self.backoff;
            } else {
                self.backoff = COOL_DOWN;
            }
        }
        if self.cool_down > 0 && step2 < 0.0625 * self.reach * self.reach {
            self.cool_down = 0;
        }
        if self.cool_down > 0 {
            self.cool_down -= 1;
            self.served[2] += 1;
            return Plan::Plain;
        }
        self.uses = 1;
        self.judged = false;
        self.served[1] += 1;
        // 0.3 of the finest cell side: the ball query visits at most 3 cells per axis and level,
        // the ball stays smaller than the smallest record's bounding sphere, and fewer remembered
        // records outweigh the more frequent anchoring (the coherent lookups of the cache bench
        // are cheaper than at half the side)
        Plan::Anchor(0.3 * finest_side)
    }

    /// Starts a new candidate set around `anchor` (queries up to `reach` away will use it).
    pub(crate) fn reset(&mut self, source: (u64, u64, usize), anchor: DVec3, reach: f64) {
        self.source = Some(source);
        self.anchor = anchor;
        self.reach = reach;
        self.groups.clear();
    }

    /// Remembers `head`, the record at slot address `slot` (records must come in content order),
    /// for a cache that weighs records over `lookup_scale` times their radii.
    pub(crate) fn push(&mut self, domain: Domain, lookup_scale: f64, head: &Head, slot: usize) {
        if !matches!(self.groups.last(), Some(g) if (g.len as usize) < GROUP) {
            self.groups.push(Group::default());
        }
        let Some(g) = self.groups.last_mut() else {
            return;
        };
        let k = g.len as usize;
        g.len += 1;
        g.slots[k] = slot;
        for i in 0..3 {
            g.position[i][k] = head.position[i];
        }
        g.reach2[k] = (head.max_radius() * lookup_scale * (1.0 + 1e-9)).powi(2);
        g.normal_radius[k] = head.radii[2] as f64 * lookup_scale;
        g.open_code[k] = head.open_fraction;
        g.gradient_scale[k] = head.gradient_scale;
        g.rotation_scale[k] = head.rotation_scale;
        // exactly what `record_weight` computes from the stored record (radii read over the scale)
        let normal = if head.is_isotropic() {
            g.radius[k] = head.radii[0] as f64 * lookup_scale;
            if domain == Domain::Surface {
                head.axis2()
            } else {
                DVec3::ZERO
            }
        } else {
            g.anisotropic |= 1 << k;
            let frame = head.frame();
            for i in 0..3 {
                g.axes[0][i][k] = frame.0[0][i];
                g.axes[1][i][k] = frame.0[1][i];
                g.radii[i][k] = head.radii[i] as f64 * lookup_scale;
            }
            frame.0[2]
        };
        for i in 0..3 {
            g.normal[i][k] = normal[i];
        }
    }

    /// Fills the unused lanes of the last group with records that cover nothing.
    pub(crate) fn seal(&mut self) {
        if let Some(g) = self.groups.last_mut() {
            for k in g.len as usize..GROUP {
                // far away with a tiny radius: t is infinite, the weight 0
                g.position[0][k] = f64::MAX;
                g.radius[k] = f64::MIN_POSITIVE;
                g.reach2[k] = -1.0;
                g.slots[k] = g.slots[0];
            }
        }
    }

    /// Appends to `used`, in content order, every remembered record with a positive weight at
    /// (`x`, `n`); `stored` resolves a slot address.
    #[inline]
    pub(crate) fn weigh<'a>(
        &self,
        kernel: &Kernel,
        x: DVec3,
        n: DVec3,
        stored: impl Fn(usize) -> (&'a Head, &'a [Channel]),
        used: &mut UsedRecords<'a>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx() {
            // SAFETY: the CPU has AVX (checked just above).
            return unsafe {
                self.covering_avx(kernel, x, n, |g, k, weight| {
                    let (head, channels) = stored(g.slots[k]);
                    super::index::prefetch(channels.as_ptr() as *const u8);
                    push(used, (weight, g.normal(k)), head, channels);
                })
            };
        }
        self.weigh_portable(kernel, x, n, stored, used)
    }

    /// [`Cursor::weigh`] straight into the blend's lanes (no per-record list to sort: the
    /// remembered records are in content order).
    #[inline]
    pub(crate) fn weigh_covering<'a>(
        &self,
        kernel: &Kernel,
        x: DVec3,
        n: DVec3,
        stored: impl Fn(usize) -> (&'a Head, &'a [Channel]),
        covering: &mut Covering<'a>,
    ) {
        #[cfg(target_arch = "x86_64")]
        if crate::simd::avx() {
            // SAFETY: the CPU has AVX (checked just above).
            return unsafe {
                self.covering_avx(kernel, x, n, |g, k, weight| {
                    let (_, channels) = stored(g.slots[k]);
                    super::index::prefetch(channels.as_ptr() as *const u8);
                    covering.push(
                        weight,
                        [g.position[0][k], g.position[1][k], g.position[2][k]],
                        g.normal(k).to_array(),
                        (g.gradient_scale[k], g.rotation_scale[k]),
                        channels,
                    );
                })
            };
        }
        let mut used = UsedRecords::new();
        self.weigh_portable(kernel, x, n, stored, &mut used);
        covering.extend_from_used(&used);
    }

    /// [`Cursor::weigh`] one record at a time, from the stored records (the reference for the
    /// vector code and the path of CPUs without AVX).
    pub(crate) fn weigh_portable<'a>(
        &self,
        kernel: &Kernel,
        x: DVec3,
        n: DVec3,
        stored: impl Fn(usize) -> (&'a Head, &'a [Channel]),
        used: &mut UsedRecords<'a>,
    ) {
        for g in &self.groups {
            for &slot in &g.slots[..g.len as usize] {
                let (head, channels) = stored(slot);
                push(used, record_weight(kernel, head, x, n), head, channels);
            }
        }
    }

    /// Calls `take(group, lane, weight)` for every remembered record with a positive weight at
    /// (`x`, `n`), in content order, weighing four records at a time with the operations of
    /// [`record_weight`] lane by lane.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    fn covering_avx(
        &self,
        kernel: &Kernel,
        x: DVec3,
        n: DVec3,
        mut take: impl FnMut(&Group, usize, f64),
    ) {
        use std::arch::x86_64::*;
        let surface = kernel.domain == Domain::Surface;
        let load = |a: &[f64; GROUP]| {
            // SAFETY: four f64 (unaligned load).
            unsafe { _mm256_loadu_pd(a.as_ptr()) }
        };
        let (qx, qy, qz) = (
            _mm256_set1_pd(x.x),
            _mm256_set1_pd(x.y),
            _mm256_set1_pd(x.z),
        );
        let (nx, ny, nz) = (
            _mm256_set1_pd(n.x),
            _mm256_set1_pd(n.y),
            _mm256_set1_pd(n.z),
        );
        for g in &self.groups {
            let dx = _mm256_sub_pd(qx, load(&g.position[0]));
            let dy = _mm256_sub_pd(qy, load(&g.position[1]));
            let dz = _mm256_sub_pd(qz, load(&g.position[2]));
            let dot = |a: [__m256d; 3]| {
                _mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(dx, a[0]), _mm256_mul_pd(dy, a[1])),
                    _mm256_mul_pd(dz, a[2]),
                )
            };
            let d2 = dot([dx, dy, dz]);
            if _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(d2, load(&g.reach2))) == 0 {
                continue;
            }
            let mut t = _mm256_div_pd(_mm256_sqrt_pd(d2), load(&g.radius));
            let normal = g.normal.each_ref().map(load);
            if g.anisotropic != 0 {
                let u = |a: [__m256d; 3], r: &[f64; GROUP]| _mm256_div_pd(dot(a), load(r));
                let u0 = u(g.axes[0].each_ref().map(load), &g.radii[0]);
                let u1 = u(g.axes[1].each_ref().map(load), &g.radii[1]);
                let u2 = u(normal, &g.radii[2]);
                let ta = _mm256_sqrt_pd(_mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(u0, u0), _mm256_mul_pd(u1, u1)),
                    _mm256_mul_pd(u2, u2),
                ));
                let bit = |k: u8| -(((g.anisotropic >> k) & 1) as i64);
                let lanes = _mm256_castsi256_pd(_mm256_setr_epi64x(bit(0), bit(1), bit(2), bit(3)));
                t = _mm256_blendv_pd(t, ta, lanes);
            }
            let cos_n = if surface {
                _mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(normal[0], nx), _mm256_mul_pd(normal[1], ny)),
                    _mm256_mul_pd(normal[2], nz),
                )
            } else {
                _mm256_set1_pd(1.0)
            };
            let w = super::weigh::kernel_weights(kernel, surface, t, cos_n);
            let mut hits = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(w, _mm256_setzero_pd()))
                as u32
                & ((1u32 << g.len) - 1);
            if hits == 0 {
                continue;
            }
            let mut weights = [0.0f64; GROUP];
            // SAFETY: four f64.
            unsafe { _mm256_storeu_pd(weights.as_mut_ptr(), w) };
            while hits != 0 {
                let k = hits.trailing_zeros() as usize;
                hits &= hits - 1;
                // the same test, on the same values, as `weigh::guarded`
                let (position, normal) = (g.position(k), g.normal(k));
                if kernel.refuses(x, n, position, normal, g.normal_radius[k], g.open_code[k]) {
                    continue;
                }
                take(g, k, weights[k]);
            }
        }
    }
}

impl Group {
    /// The position of lane `k`.
    #[inline(always)]
    fn position(&self, k: usize) -> DVec3 {
        DVec3::new(
            self.position[0][k],
            self.position[1][k],
            self.position[2][k],
        )
    }

    /// The normal of lane `k`.
    #[inline(always)]
    fn normal(&self, k: usize) -> DVec3 {
        DVec3::new(self.normal[0][k], self.normal[1][k], self.normal[2][k])
    }
}
