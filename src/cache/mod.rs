//! The generic radiance cache: records, error metrics, spatial index, interpolation, persistence.
//!
//! A [`Cache<V>`] holds records of a value `V` ([`CacheValue`]: `f32`, `[f32; N]` or `Vec<f32>`
//! with the channel count chosen at run time) in one [`Domain`]: ellipses on surfaces or ellipsoids
//! in media. A renderer keeps one cache per quantity (irradiance, single and multiple scattering,
//! RGB or spherical-harmonic coefficients).
//!
//! ```
//! use glam::DVec3;
//! use raddiff::cache::{Cache, CacheConfig, Extent, Record, metric};
//!
//! let cache: Cache<[f32; 3]> = Cache::new(CacheConfig::surface(3))?;
//! let radius = metric::split_sphere(0.2, metric::harmonic_mean_distance(&[1.0, 2.0, 4.0])?)?;
//! let mut record = Record::new(DVec3::ZERO, DVec3::Z, [1.0, 0.5, 0.25], Extent::isotropic(radius));
//! record.gradient = Some([[0.1, 0.0, 0.0], [0.0; 3], [0.0; 3]]); // d/dx, d/dy, d/dz
//! cache.insert(&record)?;
//! let hit = cache.lookup(DVec3::new(0.05, 0.0, 0.0), DVec3::Z)?;
//! assert!((hit.value[0] - 1.005).abs() < 1e-6);
//! # Ok::<(), raddiff::Error>(())
//! ```
//!
//! # Concurrency and determinism
//! `Cache` is `Sync`: any number of threads call [`Cache::lookup`] and [`Cache::insert`] through a
//! shared reference. Lookups never lock and never wait for each other or for inserts; inserts are
//! serialized by one mutex (an insert is cheap next to the gather that produces its record, so
//! they rarely wait) and are visible to every lookup that starts after the insert returns. Records
//! are immutable once inserted and live in an append-only arena; the index is a hashed grid whose
//! table and entry lists are published with release/acquire atomics and never freed while readers
//! may hold them ([`Cache::compact`] reclaims the replaced ones under `&mut`).
//!
//! Lookups keep per-thread state only to go faster: each thread has a [`Cursor`] for each of the
//! last four caches it looked up in, which serves nearby successive queries from remembered
//! records (bit for bit what [`Cache::lookup_indexed`] computes through the index).
//!
//! The value returned for a query depends only on the set of records covering it: covering
//! records are summed in their content order (position bits, then the remaining stored bytes), so
//! neither insertion order nor thread timing changes a single bit. Inserting a record whose stored
//! bits equal an existing record's is a no-op (returns `false`), so the cache is a set.
//!
//! # Record identity
//! Two records are duplicates when their stored bytes (the record layout below) are equal, which
//! is exactly what inserting the same gather twice, on any machine, produces. [`Cache::keys`]
//! reports each record's identity key, the FNV-1a 64-bit hash of those bytes.
//!
//! # Memory
//! A record costs [`HEAD_BYTES`] (64) + [`CHANNEL_BYTES`] (16) per channel in the record arena, plus
//! one 20-byte index entry and its share of the index's hash table (about 25 bytes per record in
//! all after [`Cache::compact`] at typical overlaps; see [`Cache::memory`]).
//!
//! # Gradient limiting
//! First-order extrapolation E + Δx·∇E goes wrong where |∇E|·R ≫ E (a Ward-Heckbert gradient
//! estimated right at a wall junction can reach |∇E|·R/E ≈ 100). [`CacheConfig::gradient_limit`]
//! c (off by default) is a slope limiter applied when a record is inserted: for each channel k
//! with value Eₖ, with R the record's largest radius, sₜ = |∇ₜEₖ|·R and
//! sᵣ = |∇ᵣEₖ|·sin(min(Δn_max, π/2)) (surface domain; 0 in volumes), if sₜ + sᵣ > c·|Eₖ| both
//! gradients of channel k are scaled by c·|Eₖ|/(sₜ + sᵣ). Every lookup within the record's extent
//! then extrapolates channel k by at most c·|Eₖ| (up to binary16 rounding), so with c ≤ 1 it never
//! flips a value's sign. Records within the bound are stored bit for bit as without the limit;
//! [`Cache::merge`] and [`Cache::load`] take records as stored.
//!
//! # Neighbour clamping
//! Křivánek et al. 2006 bound a record's radius by each neighbour's radius plus their distance,
//! Rᵢ ≤ Rⱼ + dᵢⱼ, so that a large record does not reach far past a small one that the error
//! metric found necessary. [`Cache::clamp_to_neighbours`] applies it to a record before it is
//! inserted (one-sided: stored records are immutable while threads insert), and
//! [`Cache::clamp_neighbours`] applies it two-sided to every stored record under `&mut`: a single
//! pass over the current radii that is the constraints' fixed point, independent of record order
//! (proof in its documentation).
//!
//! # Leak guard
//! A record in front of the query point may see geometry the query does not (the riser of a
//! step). [`CacheConfig::leak_guard`] (off by default) applies the test of Ward's irradiance
//! cache, Radiance, pbrt-v2 and Mitsuba when records are weighed: record i is not used at x when
//! `(x − xᵢ)·(n + nᵢ)/2 < −(relative·Rᵢ + absolute)`, Rᵢ its radius along its normal. Zero on
//! planes and spheres, so curvature alone never trips it; the tolerance's derivation is in the
//! [`LeakGuard`] docs.
//!
//! # Open-fraction test
//! A far-field record's value is the mean over the directions its gather found open beyond the
//! reach; a query whose hemisphere is open elsewhere (under a ledge, at the foot of a step) takes
//! the wrong mean. [`CacheConfig::open_fraction_test`] (off by default) refuses record i at a
//! query of open fraction V when `|Vᵢ − V| > tolerance`, for records inserted with an open
//! fraction ([`Record::open_fraction`]) and lookups made with one ([`Cache::lookup_open`],
//! [`Cache::irradiance_near_far`]). The tolerance's choice is in the [`OpenFractionTest`] docs.
//!
//! # Lookup radius
//! A record's radii say where it must be made; reading it only that far leaves each value a
//! blend of few records, each with its gather's noise. [`CacheConfig::lookup_radius_scale`] k
//! (default 1) weighs records over k times their radii while a query still counts as covered
//! only where a record covers it at its own radii: misses, and so the records a renderer makes,
//! are those at k = 1. Why, cost and limits: [`CacheConfig::lookup_radius_scale`].
//!
//! # File format (version 9, little-endian)
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `RDFCACHE` |
//! | 8 | 4 | format version, u32 = 9 |
//! | 12 | 4 | channels, u32 ≥ 1 |
//! | 16 | 4 | domain, u32 (0 surface, 1 volume) |
//! | 20 | 4 | interpolation, u32 (`RADDIFF_INTERP_*`) |
//! | 24 | 8 | max normal deviation, f64 radians |
//! | 32 | 8 | record count N, u64 |
//! | 40 | 4 | record size S = 64 + 16·channels, u32 |
//! | 44 | 4 | flags, u32: bit 0 [`CacheConfig::non_negative`], bit 1 gradient limit on, bit 2 leak guard on, bit 3 far field on, bit 4 open-fraction test on, the other bits 0 |
//! | 48 | 8 | gradient limit c, f64: finite and > 0 if flag bit 1 is set, else 0.0 (all bits 0) |
//! | 56 | 8 | leak guard relative tolerance, f64: finite and ≥ 0 if flag bit 2 is set, else 0.0 (all bits 0) |
//! | 64 | 8 | leak guard absolute tolerance, f64: as the relative one |
//! | 72 | 8 | far-field reach in L ([`FarFieldReach::world`]), f64: finite and ≥ 0 if flag bit 3 is set (one of the two reaches > 0), else 0.0 (all bits 0) |
//! | 80 | 8 | far-field reach in pixels ([`FarFieldReach::pixels`]), f64: as the one in L |
//! | 88 | 8 | open-fraction tolerance ([`OpenFractionTest::tolerance`]), f64: finite and ≥ 0 if flag bit 4 is set, else 0.0 (all bits 0) |
//! | 96 | 8 | lookup radius scale ([`CacheConfig::lookup_radius_scale`]), f64 in [1, [`LOOKUP_RADIUS_SCALE_MAX`]] |
//! | 104 | 8 | open-fraction coverage tolerance ([`OpenFractionTest::coverage_tolerance`]), f64 ≥ 0 or +∞ (kept with the test off) |
//! | 112 | N·S | records, in strictly increasing content order |
//! | 112 + N·S | 8 | FNV-1a 64 checksum of every preceding byte |
//!
//! Older versions are still read. Version 8 (before the coverage tolerance) has the same header
//! up to offset 104 without it (records start at 104); its flag bit 5 (only with bit 4) means an
//! infinite coverage tolerance, its absence 0. Version 7 (before the test could keep coverage)
//! has the version 8 header; flag bit 5 must be 0. Version 6 (before the lookup radius scale)
//! has the same header up to offset 96 without the scale (records start at 96); its caches read
//! records over their own radii (scale 1). Version 5 (before the open-fraction test) has the
//! same header up to offset 88 without the tolerance (records start at 88), flag bit 4 must be
//! 0, and its records' open-fraction field (reserved then) must be 0: no record has an open
//! fraction.
//! Version 4 (before the far-field marker) has the same header up
//! to offset 72 without the reaches (records start at 72), flag bit 3 must be 0, and the cache's
//! records hold no far fields. Version 3 (before the leak guard) also lacks the leak-guard fields
//! (records start at 56), flag bit 2 must be 0, and the cache has no leak guard. Version 2 (before
//! the gradient limit) also lacks the gradient-limit field (records start at 48), flag bit 1 must
//! be 0, and the cache has no gradient limit. [`Cache::save`] always writes version 9.
//!
//! Record (S bytes): position 3×f64; frame as a unit quaternion 4×f32 (x, y, z, w with w ≥ 0,
//! rotating the world axes onto the frame: surface axis 0, axis 1 = n × axis 0, normal n; volume
//! axes 0-2); radii 3×f32 (surface: radius along axis 0, axis 1, and their minimum for the normal
//! direction); translational and rotational gradient scales 2×f32; open fraction u32 (0: none,
//! else `1 + round(V·2³⁰)`, at most `2³⁰ + 1`); then per
//! channel: value f32, translational gradient 3×binary16, rotational gradient 3×binary16, the
//! gradients relative to their scale. Content order: position bit patterns (x, then y, then z,
//! as u64), then the record's bytes compared lexicographically. Version 1 files (88-byte heads
//! with three `f32` axes and a stored key) are rejected with a message naming the version.
//!
//! [`Cache::save`] writes a temporary file in the same directory, `fsync`s it, renames it over the
//! target and `fsync`s the directory: a crash leaves either the old or the new file. [`Cache::load`]
//! checks the magic, version, header fields, exact length, checksum, every record (finite numbers,
//! radii in range, unit quaternion, open fractions in range) and the record order, and reports
//! [`Error::Corrupt`] (or [`Error::Io`]) with the reason; it never panics on any input.

mod blend;
mod clamp;
mod config;
mod cursor;
mod far_field;
mod index;
pub mod interp;
pub mod irradiance;
mod leak_guard;
mod lookup_radius;
pub mod metric;
mod open_fraction;
mod persist;
mod record;
mod store;
mod thread_cursor;
mod value;
mod weigh;

use std::marker::PhantomData;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use glam::DVec3;
use smallvec::SmallVec;

pub use config::CacheConfig;
pub use cursor::Cursor;
pub use far_field::FarFieldReach;
pub use interp::Interpolation;
pub use leak_guard::LeakGuard;
pub(crate) use lookup_radius::check_scale as check_lookup_radius_scale;
pub use lookup_radius::LOOKUP_RADIUS_SCALE_MAX;
pub use open_fraction::OpenFractionTest;
pub use record::{
    Domain, Extent, Record, CHANNEL_BYTES, HEAD_BYTES, POSITION_MAX, RADIUS_MAX, RADIUS_MIN,
};
pub use value::CacheValue;

use crate::error::{ensure_finite3, Error, Result};
use interp::Kernel;
pub(crate) use record::{channel_major, RecordInput};
use record::{Channel, Head};

/// Largest channel count per record.
pub const MAX_CHANNELS: usize = 4096;

/// The result of a lookup.
#[derive(Debug, Clone, PartialEq)]
pub struct Lookup<V> {
    /// The interpolated value.
    pub value: V,
    /// Sum of the weights of the records used (scheme-dependent scale; see [`Interpolation`]).
    pub weight_sum: f64,
    /// How many records covered the query.
    pub records: usize,
}

/// Memory held by a cache.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MemoryUsage {
    /// Bytes per stored record: `HEAD_BYTES + CHANNEL_BYTES * channels`.
    pub bytes_per_record: usize,
    /// Address space reserved for records (the arena grows in doubling chunks of zeroed pages,
    /// so the unused tail of the last chunk is not resident).
    pub record_bytes: usize,
    /// Bytes held by the spatial index (hash table and entry lists, including those retired
    /// while filling, which [`Cache::compact`] frees).
    pub index_bytes: usize,
    /// Index entries (one per record).
    pub index_entries: usize,
}

/// A thread-safe radiance cache (see the [module docs](self)).
pub struct Cache<V: CacheValue> {
    config: CacheConfig,
    kernel: Kernel,
    records: store::Chunks<u64>,
    len: AtomicUsize,
    index: index::Grid,
    writer: Mutex<()>,
    /// Process-unique identity and compaction count: what a [`Cursor`] was filled from.
    identity: u64,
    generation: u64,
    _value: PhantomData<fn() -> V>,
}

impl<V: CacheValue> std::fmt::Debug for Cache<V> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cache")
            .field("config", &self.config)
            .field("len", &self.len())
            .finish()
    }
}

static NEXT_IDENTITY: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

/// The index places records exactly only while |x| / radius stays below this (2^40: a record
/// 10⁶ units from the origin may be as small as 10⁻⁶).
const PRECISION_RATIO: f64 = (1u64 << 40) as f64;

impl<V: CacheValue> Cache<V> {
    /// An empty cache. `InvalidArgument` for 0 or more than [`MAX_CHANNELS`] channels, a channel
    /// count that disagrees with `V`, a maximum normal deviation outside (0, π] (surfaces), a
    /// gradient limit that is not > 0 (NaN, 0, negative), a far-field reach that is negative
    /// or not finite, or a leak-guard or open-fraction tolerance that is negative or NaN.
    pub fn new(config: CacheConfig) -> Result<Self> {
        check_gradient_limit(config.gradient_limit)?;
        config.leak_guard.validate()?;
        config.far_field.validate()?;
        config.open_fraction_test.validate()?;
        lookup_radius::check_scale(config.lookup_radius_scale)?;
        if config.channels == 0 || config.channels > MAX_CHANNELS {
            return Err(Error::InvalidArgument(format!(
                "channels must be in 1..={MAX_CHANNELS} (got {})",
                config.channels
            )));
        }
        if let Some(n) = V::FIXED_CHANNELS {
            if n != config.channels {
                return Err(Error::InvalidArgument(format!(
                    "the value type has {n} channels but the configuration asks for {}",
                    config.channels
                )));
            }
        }
        let kernel = Kernel::new(
            config.interpolation,
            config.domain,
            config.max_normal_deviation,
        )?
        .with_leak_guard(config.leak_guard)
        .with_open_fraction_test(config.open_fraction_test)
        .with_lookup_radius_scale(config.lookup_radius_scale);
        let words = (HEAD_BYTES + CHANNEL_BYTES * config.channels).div_ceil(8);
        Ok(Cache {
            config,
            kernel,
            records: store::Chunks::new(words),
            len: AtomicUsize::new(0),
            index: index::Grid::new(),
            writer: Mutex::new(()),
            identity: NEXT_IDENTITY.fetch_add(1, Ordering::Relaxed),
            generation: 0,
            _value: PhantomData,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &CacheConfig {
        &self.config
    }

    /// Sets [`CacheConfig::gradient_limit`] to `c` for the records inserted from now on (stored
    /// records keep their gradients); `f64::INFINITY` turns the limit off. `InvalidArgument` (and
    /// no change) for `c <= 0` or NaN.
    pub fn set_gradient_limit(&mut self, c: f64) -> Result<()> {
        check_gradient_limit(c)?;
        self.config.gradient_limit = c;
        Ok(())
    }

    /// Sets [`CacheConfig::leak_guard`] for every lookup from now on (stored records are not
    /// changed: the guard acts when records are weighed). `InvalidArgument` (and no change) for
    /// a NaN or negative tolerance.
    pub fn set_leak_guard(&mut self, guard: LeakGuard) -> Result<()> {
        guard.validate()?;
        self.config.leak_guard = guard;
        self.kernel = self.kernel.with_leak_guard(guard);
        Ok(())
    }

    /// Sets [`CacheConfig::open_fraction_test`] for every lookup from now on (it acts when
    /// records are weighed; stored records keep their open fractions). `InvalidArgument` (and no
    /// change) for a NaN or negative tolerance.
    pub fn set_open_fraction_test(&mut self, test: OpenFractionTest) -> Result<()> {
        test.validate()?;
        self.config.open_fraction_test = test;
        self.kernel = self.kernel.with_open_fraction_test(test);
        Ok(())
    }

    /// Sets [`CacheConfig::lookup_radius_scale`] for every lookup from now on: the index is
    /// rebuilt for the new reach (stored records are not changed). Needs exclusive access.
    /// `InvalidArgument` (and no change) unless `scale` is finite and in
    /// [1, [`LOOKUP_RADIUS_SCALE_MAX`]].
    pub fn set_lookup_radius_scale(&mut self, scale: f64) -> Result<()> {
        lookup_radius::check_scale(scale)?;
        if scale == self.config.lookup_radius_scale {
            return Ok(());
        }
        self.config.lookup_radius_scale = scale;
        self.kernel = self.kernel.with_lookup_radius_scale(scale);
        self.index = index::Grid::new();
        for id in 0..self.len() as u32 {
            let head = *self.stored(id).0;
            self.index
                .insert(id, head.position(), self.read_radius(&head));
        }
        // compacting also moves the cache to a new generation, so cursors re-anchor
        self.compact();
        Ok(())
    }

    /// Number of records.
    pub fn len(&self) -> usize {
        self.len.load(Ordering::Acquire)
    }

    /// Whether the cache has no records.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Memory held by the cache.
    pub fn memory(&self) -> MemoryUsage {
        MemoryUsage {
            bytes_per_record: HEAD_BYTES + CHANNEL_BYTES * self.config.channels,
            record_bytes: self.records.allocated_bytes(),
            index_bytes: self.index.bytes(),
            index_entries: self.index.entries(),
        }
    }

    /// Prepares the cache for a lookup-heavy phase: releases index memory kept only for
    /// concurrent readers (entry lists replaced while growing, kept so that lookups never wait,
    /// and growth slack) and stores the records in index order, so that the records a lookup
    /// meets lie together in memory instead of in insertion order. Needs exclusive access;
    /// [`Cache::load`] and [`Cache::from_bytes`] return compacted caches. Changes no result.
    pub fn compact(&mut self) {
        let order = self.index.ids_in_cell_order();
        debug_assert_eq!(order.len(), self.len());
        let words = self.records.slot_len();
        let fresh = store::Chunks::new(words);
        let mut new_id = vec![0u32; order.len()];
        for (new, &old) in order.iter().enumerate() {
            fresh.ensure(new);
            // SAFETY: distinct allocations; both slots hold `words` u64s; exclusive access.
            unsafe {
                std::ptr::copy_nonoverlapping(
                    self.records.slot_ptr(old as usize),
                    fresh.slot_ptr(new),
                    words,
                )
            };
            new_id[old as usize] = new as u32;
        }
        self.records = fresh;
        self.index.compact(&new_id);
        self.generation += 1;
    }

    /// Record `id` (< len, published).
    #[inline]
    fn stored(&self, id: u32) -> (&Head, &[Channel]) {
        // SAFETY: the slot of a published id.
        unsafe { self.stored_at(self.records.slot_ptr(id as usize) as usize) }
    }

    /// The record in the slot at address `slot`.
    ///
    /// # Safety
    /// `slot` is the [`store::Chunks::slot_ptr`] of a published record of this cache, taken
    /// since its last [`Cache::compact`].
    #[inline(always)]
    unsafe fn stored_at(&self, slot: usize) -> (&Head, &[Channel]) {
        let ptr = slot as *const u8;
        // SAFETY: a slot is `words` u64s (8-aligned) holding a `Head` followed by `channels`
        // `Channel`s (4-aligned, at byte HEAD_BYTES), written before the id was published.
        unsafe {
            let head = &*(ptr as *const Head);
            let chans = std::slice::from_raw_parts(
                ptr.add(HEAD_BYTES) as *const Channel,
                self.config.channels,
            );
            (head, chans)
        }
    }

    /// Inserts a record, its gradients limited by [`CacheConfig::gradient_limit`] (if set).
    /// Returns `false` (and changes nothing) if an identical record is already stored. `InvalidArgument` for non-finite or out-of-range input, a zero surface normal,
    /// degenerate axes with anisotropic radii, a largest radius below |position|·2⁻⁴⁰ (beyond
    /// the index's resolution), or an open fraction outside [0, 1].
    pub fn insert(&self, record: &Record<V>) -> Result<bool> {
        let g = record.gradient.as_ref().map(record::channel_major);
        let r = record.rotation_gradient.as_ref().map(record::channel_major);
        self.insert_flat(&RecordInput {
            position: record.position,
            normal: record.normal,
            value: record.value.as_channels(),
            gradient: g.as_deref(),
            rotation: r.as_deref(),
            extent: record.extent,
            open_fraction: record.open_fraction,
        })
    }

    pub(crate) fn insert_flat(&self, input: &RecordInput<'_>) -> Result<bool> {
        let (head, chans) = record::encode(
            self.config.domain,
            self.config.channels,
            input,
            self.config.slope_limit(),
        )?;
        self.insert_stored(&head, &chans)
    }

    fn insert_stored(&self, head: &Head, chans: &[Channel]) -> Result<bool> {
        let position = head.position();
        let radius = head.max_radius();
        if position.abs().max_element() > radius * PRECISION_RATIO {
            return Err(Error::InvalidArgument(format!(
                "record radius {radius:e} is below 2^-40 of its position {position}: \
                 beyond the index's resolution"
            )));
        }
        let _guard = self.writer.lock().unwrap_or_else(|e| e.into_inner());
        if self.holds(head, chans) {
            return Ok(false);
        }
        if self.len.load(Ordering::Relaxed) >= u32::MAX as usize {
            return Err(Error::InvalidArgument(
                "cache is full (2^32 - 1 records)".into(),
            ));
        }
        self.append(head, chans);
        Ok(true)
    }

    /// Whether a record with exactly these stored bytes is stored.
    fn holds(&self, head: &Head, chans: &[Channel]) -> bool {
        let mut duplicate = false;
        self.index.query(head.position(), |id| {
            let (h, c) = self.stored(id);
            duplicate |= h == head && c == chans;
        });
        duplicate
    }

    /// The radius of the sphere a record is read over: its largest radius times the lookup radius
    /// scale (what the index holds).
    fn read_radius(&self, head: &Head) -> f64 {
        head.max_radius() * self.kernel.lookup_scale
    }

    /// Writes a record into the next slot, indexes it and publishes it.
    ///
    /// # Contract
    /// The caller holds the writer lock (or `&mut self`), and the cache holds fewer than
    /// 2³² − 1 records.
    fn append(&self, head: &Head, chans: &[Channel]) {
        let id = self.len.load(Ordering::Relaxed);
        self.records.ensure(id);
        let ptr = self.records.slot_ptr(id) as *mut u8;
        // SAFETY: slot `id` is unpublished, sized for the head and the channels, and 8-aligned.
        unsafe {
            (ptr as *mut Head).write(*head);
            std::ptr::copy_nonoverlapping(
                chans.as_ptr(),
                ptr.add(HEAD_BYTES) as *mut Channel,
                chans.len(),
            );
        }
        self.index
            .insert(id as u32, head.position(), self.read_radius(head));
        self.len.store(id + 1, Ordering::Release);
    }

    /// [`Cache::check_query`] plus the output length.
    fn check_lookup(&self, position: DVec3, normal: DVec3, out_len: usize) -> Result<DVec3> {
        if out_len != self.config.channels {
            return Err(Error::InvalidArgument(format!(
                "output has {out_len} floats, the cache has {} channels",
                self.config.channels
            )));
        }
        self.check_query(position, normal)
    }

    fn check_query(&self, position: DVec3, normal: DVec3) -> Result<DVec3> {
        ensure_finite3(position, "query position")?;
        if self.config.domain == Domain::Volume {
            return Ok(DVec3::ZERO);
        }
        ensure_finite3(normal, "query normal")?;
        let l = normal.length();
        if !(l > 0.0 && l.is_finite()) {
            return Err(Error::InvalidArgument(
                "query normal must be non-zero in the surface domain".into(),
            ));
        }
        Ok(normal / l)
    }

    /// Interpolates at `position` with surface normal `normal` (ignored in volumes) into `out`
    /// (exactly `channels` floats), returning the weight sum and the number of records used.
    /// `NotFound` when no record covers the point; `out` is written only on success.
    ///
    /// Each thread keeps a [`Cursor`] for each of the last four caches it looked up in, so that successive nearby queries (a tile's pixels, a ray's steps) skip
    /// the index as [`Cache::lookup_into_with`] does; the result is bit for bit that of
    /// [`Cache::lookup_into_indexed`].
    pub fn lookup_into(
        &self,
        position: DVec3,
        normal: DVec3,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        self.lookup_into_query(position, normal, None, out)
    }

    /// [`Cache::lookup_into`] for a query whose open fraction is `open_fraction` (in [0, 1]): the
    /// cache's [open-fraction test](OpenFractionTest) refuses the records whose open fraction
    /// differs from it by more than the tolerance (with the test off, the result of
    /// [`Cache::lookup_into`] bit for bit; where it refuses every covering record and
    /// [keeps all coverage](OpenFractionTest::keeping_coverage), too; where it keeps coverage
    /// within a [coverage tolerance](OpenFractionTest::coverage_tolerance), that of the test at
    /// it). `InvalidArgument` for an open fraction outside [0, 1].
    pub fn lookup_into_open(
        &self,
        position: DVec3,
        normal: DVec3,
        open_fraction: f64,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        open_fraction::check_query_open_fraction(open_fraction)?;
        self.lookup_into_query(position, normal, Some(open_fraction), out)
    }

    /// [`Cache::lookup_into`] with the query's open fraction, if any, through this thread's
    /// cursor.
    fn lookup_into_query(
        &self,
        position: DVec3,
        normal: DVec3,
        open: Option<f64>,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        let mut result = None;
        thread_cursor::with(self.identity, |cursor| {
            result = Some(self.lookup_into_cursor(cursor, position, normal, open, out));
        });
        result.unwrap_or_else(|| self.lookup_into_indexed_query(position, normal, open, out))
    }

    /// [`Cache::lookup_into`] through the index alone, with no per-thread state: the reference
    /// that the cursor paths are tested and benchmarked against (same results, bit for bit).
    pub fn lookup_into_indexed(
        &self,
        position: DVec3,
        normal: DVec3,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        self.lookup_into_indexed_query(position, normal, None, out)
    }

    /// [`Cache::lookup_into_open`] through the index alone (the reference of its cursor paths).
    pub fn lookup_into_indexed_open(
        &self,
        position: DVec3,
        normal: DVec3,
        open_fraction: f64,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        open_fraction::check_query_open_fraction(open_fraction)?;
        self.lookup_into_indexed_query(position, normal, Some(open_fraction), out)
    }

    /// The index path of every lookup, with the query's open fraction if any.
    fn lookup_into_indexed_query(
        &self,
        position: DVec3,
        normal: DVec3,
        open: Option<f64>,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        let n = self.check_lookup(position, normal, out.len())?;
        let slots = self.candidate_slots(position);
        // the same candidates serve the read of the refused records, when the test keeps coverage
        match self.interpolate(&self.kernel.for_query(open), position, n, &slots, out) {
            Err(Error::NotFound(_)) if self.config.open_fraction_test.reads_refused(open) => {
                let kernel = self.kernel.for_coverage_query(open);
                self.interpolate(&kernel, position, n, &slots, out)
            }
            found => found,
        }
    }

    /// The index path of a query already validated (`n` the unit normal) with the query's
    /// `kernel`.
    fn lookup_checked_indexed(
        &self,
        kernel: &Kernel,
        position: DVec3,
        n: DVec3,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        self.interpolate(kernel, position, n, &self.candidate_slots(position), out)
    }

    /// The slot addresses of the index's candidates at `position`, their records prefetched (the
    /// candidates first, then the records: their misses overlap).
    #[inline(always)]
    fn candidate_slots(&self, position: DVec3) -> SmallVec<[usize; 32]> {
        let mut slots: SmallVec<[usize; 32]> = SmallVec::new();
        self.index.query(position, |id| {
            slots.push(self.prefetch_record(self.records.slot_ptr(id as usize) as usize));
        });
        slots
    }

    /// [`Cache::lookup_into`] for spatially coherent queries: `cursor` (one per thread, see
    /// [`Cursor`]) remembers the records around recent queries so that nearby queries skip the
    /// index. Results are bit for bit those of [`Cache::lookup_into`].
    pub fn lookup_into_with(
        &self,
        cursor: &mut Cursor,
        position: DVec3,
        normal: DVec3,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        self.lookup_into_cursor(cursor, position, normal, None, out)
    }

    /// [`Cache::lookup_into_open`] through `cursor` (see [`Cache::lookup_into_with`]): results
    /// bit for bit those of [`Cache::lookup_into_indexed_open`].
    pub fn lookup_into_with_open(
        &self,
        cursor: &mut Cursor,
        position: DVec3,
        normal: DVec3,
        open_fraction: f64,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        open_fraction::check_query_open_fraction(open_fraction)?;
        self.lookup_into_cursor(cursor, position, normal, Some(open_fraction), out)
    }

    /// The cursor path of every lookup, with the query's open fraction if any (and, when the
    /// open-fraction test keeps coverage, without it where no record passes the test).
    fn lookup_into_cursor(
        &self,
        cursor: &mut Cursor,
        position: DVec3,
        normal: DVec3,
        open: Option<f64>,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        let kernel = self.kernel.for_query(open);
        match self.lookup_cursor_once(cursor, &kernel, position, normal, out) {
            Err(Error::NotFound(_)) if self.config.open_fraction_test.reads_refused(open) => {
                let kernel = self.kernel.for_coverage_query(open);
                self.lookup_cursor_once(cursor, &kernel, position, normal, out)
            }
            found => found,
        }
    }

    /// One cursor lookup with the query's `kernel` (its open-fraction window, if any).
    fn lookup_cursor_once(
        &self,
        cursor: &mut Cursor,
        kernel: &Kernel,
        position: DVec3,
        normal: DVec3,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        let n = self.check_lookup(position, normal, out.len())?;
        let Some(finest) = self.index.finest_side() else {
            return Err(Error::NotFound(format!(
                "no cache record covers {position}"
            )));
        };
        let source = (self.identity, self.generation, self.len());
        match cursor.plan(source, position, finest) {
            cursor::Plan::Plain => return self.lookup_checked_indexed(kernel, position, n, out),
            cursor::Plan::Anchor(reach) => {
                // remembered in content order, so that the records of later lookups arrive
                // sorted and their sort below is a single check
                let mut found: SmallVec<[(u64, u32); 64]> = SmallVec::new();
                self.index.query_ball(position, reach, |id, _, _| {
                    found.push((self.stored(id).0.position[0].to_bits(), id))
                });
                found.sort_unstable_by(|a, b| match a.0.cmp(&b.0) {
                    std::cmp::Ordering::Equal => {
                        record::content_order(self.stored(a.1), self.stored(b.1))
                    }
                    unequal => unequal,
                });
                cursor.reset(source, position, reach);
                for (_, id) in found {
                    let slot = self.records.slot_ptr(id as usize) as usize;
                    cursor.push(
                        self.config.domain,
                        self.kernel.lookup_scale,
                        self.stored(id).0,
                        slot,
                    );
                }
                cursor.seal();
            }
            cursor::Plan::Remembered => {}
        }
        // SAFETY: the cursor's source (identity, generation, length) matches this cache, so its
        // slot addresses are this cache's current ones.
        let stored = |slot: usize| unsafe { self.stored_at(slot) };
        if self.kernel.interpolation == Interpolation::Log || self.kernel.is_scaled() {
            let mut used = weigh::UsedRecords::new();
            cursor.weigh(kernel, position, n, stored, &mut used);
            return self.blend_used(kernel, position, n, &mut used, out);
        }
        // the records come in content order: straight into the blend's lanes
        let mut covering = blend::Covering::new(self.config.channels);
        cursor.weigh_covering(kernel, position, n, stored, &mut covering);
        self.blend_covering(position, n, &covering, out)
    }

    /// [`Cache::lookup`] for spatially coherent queries (see [`Cache::lookup_into_with`]).
    pub fn lookup_with(
        &self,
        cursor: &mut Cursor,
        position: DVec3,
        normal: DVec3,
    ) -> Result<Lookup<V>> {
        self.lookup_via(|out| self.lookup_into_with(cursor, position, normal, out))
    }

    /// Prefetches the record in the slot at address `slot`, and returns `slot`.
    #[inline(always)]
    fn prefetch_record(&self, slot: usize) -> usize {
        let ptr = slot as *const u8;
        index::prefetch(ptr);
        index::prefetch(ptr.wrapping_add(HEAD_BYTES)); // the first channels
        slot
    }

    /// The weighted extrapolation of the records in `slots` (slot addresses of records that are a
    /// superset of those covering `position`; `n` the unit query normal) into `out`.
    fn interpolate(
        &self,
        kernel: &Kernel,
        position: DVec3,
        n: DVec3,
        slots: &[usize],
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        let mut used = weigh::UsedRecords::new();
        // SAFETY: every slot was taken from this cache's storage during this lookup.
        let stored = |slot: usize| unsafe { self.stored_at(slot) };
        weigh::weigh(kernel, position, n, slots, stored, &mut used);
        self.blend_used(kernel, position, n, &mut used, out)
    }

    /// The weighted extrapolation of the records `used` (any order), weighed with the query's
    /// `kernel`, into `out`; `NotFound` unless one of them covers the query at its own radii.
    fn blend_used(
        &self,
        kernel: &Kernel,
        position: DVec3,
        n: DVec3,
        used: &mut weigh::UsedRecords<'_>,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        if used.is_empty() || !lookup_radius::covered(kernel, used, position, n) {
            return Err(Error::NotFound(format!(
                "no cache record covers {position}"
            )));
        }
        // the content order makes the sum independent of insertion order and thread timing
        // (through a cursor the records already arrive in it: one pass checks that)
        if !used.windows(2).all(|w| w[0].order < w[1].order) {
            used.sort_unstable_by(|a, b| match a.order.cmp(&b.order) {
                std::cmp::Ordering::Equal => {
                    record::content_order((a.head, a.channels), (b.head, b.channels))
                }
                unequal => unequal,
            });
        }
        let weight_sum: f64 = used.iter().map(|u| u.weight).sum();
        check_weight_sum(weight_sum, position)?;
        if self.kernel.interpolation == Interpolation::Log {
            interp::blend_log(&self.kernel, used, weight_sum, position, n, out);
            return Ok((weight_sum, used.len()));
        }
        let surface = self.config.domain == Domain::Surface;
        let floor = self.config.extrapolation_floor();
        blend::blend_linear_used(surface, used, weight_sum, position, n, floor, out);
        Ok((weight_sum, used.len()))
    }

    /// The weighted extrapolation of the covering records (in content order) into `out`, for the
    /// linear-space schemes.
    fn blend_covering(
        &self,
        position: DVec3,
        n: DVec3,
        covering: &blend::Covering<'_>,
        out: &mut [f32],
    ) -> Result<(f64, usize)> {
        if covering.len() == 0 {
            return Err(Error::NotFound(format!(
                "no cache record covers {position}"
            )));
        }
        check_weight_sum(covering.weight_sum(), position)?;
        blend::blend_linear(
            self.config.domain == Domain::Surface,
            covering,
            position,
            n,
            self.config.extrapolation_floor(),
            out,
        );
        Ok((covering.weight_sum(), covering.len()))
    }

    /// Interpolates at `position` with surface normal `normal` (ignored in volumes).
    /// `NotFound` when no record covers the point. Nearby successive queries on a thread are
    /// served from its cursor (see [`Cache::lookup_into`]).
    pub fn lookup(&self, position: DVec3, normal: DVec3) -> Result<Lookup<V>> {
        self.lookup_via(|out| self.lookup_into(position, normal, out))
    }

    /// [`Cache::lookup`] for a query whose open fraction is `open_fraction` (in [0, 1]; see
    /// [`Cache::lookup_into_open`]).
    pub fn lookup_open(
        &self,
        position: DVec3,
        normal: DVec3,
        open_fraction: f64,
    ) -> Result<Lookup<V>> {
        self.lookup_via(|out| self.lookup_into_open(position, normal, open_fraction, out))
    }

    /// [`Cache::lookup`] through the index alone (see [`Cache::lookup_into_indexed`]).
    pub fn lookup_indexed(&self, position: DVec3, normal: DVec3) -> Result<Lookup<V>> {
        self.lookup_via(|out| self.lookup_into_indexed(position, normal, out))
    }

    /// Runs a `lookup_into` variant on a stack buffer and wraps the result.
    fn lookup_via(
        &self,
        into: impl FnOnce(&mut [f32]) -> Result<(f64, usize)>,
    ) -> Result<Lookup<V>> {
        let mut buf = [0.0f32; 32];
        let mut heap = Vec::new();
        let out: &mut [f32] = if self.config.channels <= buf.len() {
            &mut buf[..self.config.channels]
        } else {
            heap.resize(self.config.channels, 0.0);
            &mut heap
        };
        let (weight_sum, records) = into(out)?;
        Ok(Lookup {
            value: V::from_channels(out),
            weight_sum,
            records,
        })
    }

    /// Identity keys of all records, sorted (equal for two caches holding the same records).
    pub fn keys(&self) -> Vec<u64> {
        let mut keys: Vec<u64> = (0..self.len() as u32)
            .map(|i| {
                let (h, c) = self.stored(i);
                record::identity(h, c)
            })
            .collect();
        keys.sort_unstable();
        keys
    }

    /// Every stored record, decoded (values as stored; gradients as stored in binary16), in no
    /// particular order.
    pub fn records(&self) -> Vec<Record<V>> {
        (0..self.len() as u32)
            .map(|i| {
                let (h, ch) = self.stored(i);
                let values: SmallVec<[f32; 32]> = ch.iter().map(|c| c.value).collect();
                let axis = |k: usize, rot: bool| {
                    let v: SmallVec<[f32; 32]> = ch
                        .iter()
                        .map(|c| {
                            let g = if rot {
                                c.rotation(h.rotation_scale)
                            } else {
                                c.gradient(h.gradient_scale)
                            };
                            g[k] as f32
                        })
                        .collect();
                    V::from_channels(&v)
                };
                let surface = self.config.domain == Domain::Surface;
                let frame = h.frame();
                Record {
                    position: h.position(),
                    normal: if surface { frame.0[2] } else { DVec3::ZERO },
                    value: V::from_channels(&values),
                    gradient: Some(std::array::from_fn(|k| axis(k, false))),
                    rotation_gradient: surface.then(|| std::array::from_fn(|k| axis(k, true))),
                    extent: Extent {
                        radii: h.radii.map(|r| r as f64),
                        axes: frame.0,
                    },
                    open_fraction: open_fraction::decode(h.open_fraction),
                }
            })
            .collect()
    }

    /// Adds every record of `other` that `self` does not already hold (duplicates, i.e. records
    /// with identical stored bytes, are skipped). Returns how many were added. Both caches must
    /// have the same channel count and domain; `self` keeps its interpolation settings.
    /// Records are copied as stored in `other`: `self`'s [`CacheConfig::gradient_limit`] is not
    /// applied to them. `other` may be `self` (a no-op).
    pub fn merge(&self, other: &Cache<V>) -> Result<usize> {
        if other.config.channels != self.config.channels
            || other.config.domain != self.config.domain
        {
            return Err(Error::InvalidArgument(format!(
                "cannot merge a cache of {} channels ({:?}) into one of {} channels ({:?})",
                other.config.channels,
                other.config.domain,
                self.config.channels,
                self.config.domain
            )));
        }
        let mut added = 0;
        for id in 0..other.len() as u32 {
            let (head, chans) = other.stored(id);
            if self.insert_stored(head, chans)? {
                added += 1;
            }
        }
        Ok(added)
    }
}

/// `InvalidArgument` unless `c` is a valid [`CacheConfig::gradient_limit`] (> 0 or +∞).
pub(crate) fn check_gradient_limit(c: f64) -> Result<()> {
    if c > 0.0 {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "gradient limit must be > 0 (or infinite: off), got {c}"
        )))
    }
}

/// `NotFound` unless the covering records' weights sum to a positive finite number.
fn check_weight_sum(weight_sum: f64, position: DVec3) -> Result<()> {
    if weight_sum > 0.0 && weight_sum.is_finite() {
        Ok(())
    } else {
        Err(Error::NotFound(format!(
            "the records covering {position} have zero total weight"
        )))
    }
}

#[cfg(test)]
mod leak_guard_tests;
#[cfg(test)]
mod safeguard_tests;
#[cfg(test)]
mod tests;
