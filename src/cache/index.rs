//! The spatial index: a loose hashed grid over record bounding spheres, with lock-free reads and
//! a single writer.
//!
//! Levels have cell sides 2^l. A record is listed exactly once: in the cell
//! of the level whose side is the smallest at least twice its (inflated) bounding radius, the cell
//! containing its centre. A sphere of radius r ≤ side/2 that contains a point p has its centre
//! within half a cell of p, so along each axis it lies in p's cell or in the neighbour on the side
//! of p's nearer cell face: a query visits the 2×2×2 cells nearest to p on each occupied level
//! (usually one or two levels) and tests the spheres listed there. Cells are found through an
//! open-addressing hash table keyed by a 64-bit hash of (level, cell coordinates); two cells with
//! equal hashes would share a list, which costs time but never correctness, since every listed
//! sphere is tested against the query point.
//!
//! Spheres are stored relative to their cell, in cell units, as `f32` (centre offset and squared
//! radius), structure-of-arrays so that eight are tested at once: the precision of the test does
//! not depend on how far the scene is from the origin, and nothing under- or overflows at any
//! scale. The stored radius is inflated by 4·10⁻⁶ relative (far more than the `f32` rounding of
//! the offsets) and rounded up, so the test is conservative: it may report a record whose exact
//! bounding sphere just misses the point (callers test records exactly), never miss one.
//!
//! Why this and not the octree of the first version: the octree listed each record in ~12 cubes
//! (~300 bytes per record after compaction) and a query walked 8 or more dependent nodes; here a
//! record costs one 20-byte entry plus its share of the table, and a query makes eight
//! independent table probes per level, which the memory system overlaps.
//!
//! Concurrency: each cell's entries are one allocation (header, then the arrays) published through
//! an `AtomicPtr` in its table slot; the writer fills a slot past the published length, then
//! publishes the new length (`Release`). A full list is copied into one twice as large, published,
//! and the old one retired; a full table is rehashed into one twice as large, published, and the
//! old one retired. Retired memory is kept until [`Grid::compact`] (exclusive access) or drop, so a
//! reader holding an old pointer stays valid without any reclamation scheme; it costs at most as
//! much again as the live lists while a cache is being filled. Readers never lock and never write,
//! and see every insert that completed before they started.

use std::alloc::Layout;
use std::sync::atomic::{AtomicI64, AtomicPtr, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;

use glam::DVec3;

/// Levels are indexed `l + LEVEL_BIAS` for cell side 2^l; radii in [1e-30, 1e30] need l in about
/// [-98, 102]. (Half-octave levels were measured too: fewer spheres tested per covering record,
/// but twice the levels, and each occupied level costs eight table probes.)
const LEVEL_BIAS: i32 = 128;
const LEVEL_WORDS: usize = 4;
const LEVELS: usize = 64 * LEVEL_WORDS;

/// Relative inflation of stored radii (covers the `f32` offsets and the f64 cell arithmetic).
const RADIUS_INFLATION: f64 = 4e-6;

/// Cell side over bounding diameter is at least `1 / (1 - SIDE_MARGIN)`: the slack that keeps the
/// 2×2×2 neighbourhood exact despite rounding in `p / side` (at most 2^-12 cell for coordinates
/// below [`MAX_CELL_COORDINATE`]).
const SIDE_MARGIN: f64 = 1.0 / 256.0;

/// Largest |position| / side the index handles exactly (records are rejected above
/// 2^-1 of this by the cache's precision check; queries beyond it cannot meet any record).
const MAX_CELL_COORDINATE: f64 = (1u64 << 41) as f64;

/// Initial table capacity (slots; a power of two).
const FIRST_TABLE: usize = 64;

#[inline]
fn exp2i(e: i32) -> f64 {
    f64::from_bits(((e + 1023) as u64) << 52)
}

/// Cell side of level index `level` (biased): a power of two, so `p / side` is exact.
#[inline]
fn cell_side(level: usize) -> f64 {
    exp2i(level as i32 - LEVEL_BIAS)
}

/// The biased level whose cells hold a sphere of inflated radius `r` (the smallest side ≥ 2r with
/// margin).
fn level_for(r: f64) -> usize {
    let need = 2.0 * r / (1.0 - SIDE_MARGIN);
    let mut level = (need.log2().ceil() as i32 + LEVEL_BIAS).clamp(1, LEVELS as i32 - 2) as usize;
    while level + 1 < LEVELS && cell_side(level) < need {
        level += 1;
    }
    while level > 0 && cell_side(level - 1) >= need {
        level -= 1;
    }
    level
}

/// Per-axis hash terms: the key of cell (x, y, z) on a level is `finish(level_term ^ tx ^ ty ^ tz)`,
/// so a query computes the eight keys of its 2×2×2 neighbourhood from six axis terms.
#[inline]
fn axis_term(v: i64, axis: u64) -> u64 {
    const MUL: [u64; 3] = [
        0x9e37_79b9_7f4a_7c15,
        0xc2b2_ae3d_27d4_eb4f,
        0x1656_67b1_9e37_79f9,
    ];
    (v as u64)
        .wrapping_mul(MUL[axis as usize])
        .rotate_left(17 + 13 * axis as u32)
}

#[inline]
fn level_term(level: usize) -> u64 {
    (level as u64).wrapping_mul(0xd6e8_feb8_6659_fd93)
}

#[inline]
fn finish(mut h: u64) -> u64 {
    h ^= h >> 32;
    h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
    h ^= h >> 29;
    h.max(1) // 0 marks an empty slot
}

#[inline]
fn cell_key(level: usize, c: [i64; 3]) -> u64 {
    finish(level_term(level) ^ axis_term(c[0], 0) ^ axis_term(c[1], 1) ^ axis_term(c[2], 2))
}

/// A cell's entry list: header followed by `cap` x, y, z offsets, squared radii (cell units,
/// `f32`) and record ids (`u32`), each array contiguous.
#[repr(C)]
struct Block {
    len: AtomicU32,
    cap: u32,
}

const BLOCK_HEADER: usize = std::mem::size_of::<Block>();

impl Block {
    fn layout(cap: u32) -> Layout {
        Layout::from_size_align(BLOCK_HEADER + 20 * cap as usize, 8).expect("block layout")
    }

    fn new(cap: u32) -> *mut Block {
        let layout = Self::layout(cap);
        // SAFETY: the layout has non-zero size; zeroed memory is a valid header and arrays.
        let ptr = unsafe { std::alloc::alloc_zeroed(layout) } as *mut Block;
        if ptr.is_null() {
            std::alloc::handle_alloc_error(layout);
        }
        // SAFETY: freshly allocated, large enough for the header.
        unsafe { (*ptr).cap = cap };
        ptr
    }

    /// A new block of capacity `cap` holding the entries of `from` (unpublished; `cap` at least
    /// its length).
    ///
    /// # Safety
    /// `from` must be a live block that only the calling writer modifies.
    unsafe fn copy(from: *const Block, cap: u32) -> *mut Block {
        let len = (*from).len.load(Ordering::Relaxed);
        let to = Self::new(cap);
        for k in 0..5 {
            std::ptr::copy_nonoverlapping(Self::array(from, k), Self::array(to, k), len as usize);
        }
        (*to).len.store(len, Ordering::Relaxed);
        to
    }

    /// Frees a block allocated by [`Block::new`].
    ///
    /// # Safety
    /// `b` must come from `Block::new` and be unreachable by any reader.
    unsafe fn free(b: *mut Block) {
        let layout = Self::layout((*b).cap);
        std::alloc::dealloc(b as *mut u8, layout);
    }

    fn bytes(&self) -> usize {
        BLOCK_HEADER + 20 * self.cap as usize
    }

    /// The published entries of a live block: x, y, z offsets, squared radii, ids.
    #[inline]
    #[allow(clippy::type_complexity)]
    fn entries<'a>(this: *const Block) -> (&'a [f32], &'a [f32], &'a [f32], &'a [f32], &'a [u32]) {
        // SAFETY: the first `len` entries were written before `len` was published (Release), and
        // a block lives until compact/drop, which need exclusive access.
        unsafe {
            let len = (*this).len.load(Ordering::Acquire) as usize;
            let arr =
                |k: usize| std::slice::from_raw_parts(Self::array(this, k) as *const f32, len);
            (
                arr(0),
                arr(1),
                arr(2),
                arr(3),
                std::slice::from_raw_parts(Self::array(this, 4) as *const u32, len),
            )
        }
    }

    /// Pointer to array `k` (0-2 offsets, 3 squared radius, 4 id) of the block at `this`.
    #[inline]
    fn array(this: *const Block, k: usize) -> *mut u32 {
        // SAFETY (for callers): stays inside the allocation for k < 5.
        let cap = unsafe { (*this).cap } as usize;
        unsafe { (this as *mut u8).add(BLOCK_HEADER + 4 * k * cap) as *mut u32 }
    }
}

struct Slot {
    key: AtomicU64,
    block: AtomicPtr<Block>,
}

struct Table {
    mask: usize,
    slots: Box<[Slot]>,
}

impl Table {
    fn new(capacity: usize) -> Box<Table> {
        Box::new(Table {
            mask: capacity - 1,
            slots: (0..capacity)
                .map(|_| Slot {
                    key: AtomicU64::new(0),
                    block: AtomicPtr::new(std::ptr::null_mut()),
                })
                .collect(),
        })
    }

    /// The slot where the probe for `key` starts.
    #[inline]
    fn home(&self, key: u64) -> *const u8 {
        &self.slots[key as usize & self.mask] as *const Slot as *const u8
    }

    /// The block of the cell with `key`, or null. Lock-free.
    #[inline]
    fn find(&self, key: u64) -> *const Block {
        let mut i = key as usize & self.mask;
        loop {
            let slot = &self.slots[i];
            let k = slot.key.load(Ordering::Acquire);
            if k == key {
                return slot.block.load(Ordering::Acquire);
            }
            if k == 0 {
                return std::ptr::null();
            }
            i = (i + 1) & self.mask;
        }
    }

    /// The slot of `key`: existing, or the empty one where it would go (writer only).
    fn slot_for(&self, key: u64) -> &Slot {
        let mut i = key as usize & self.mask;
        loop {
            let k = self.slots[i].key.load(Ordering::Relaxed);
            if k == key || k == 0 {
                return &self.slots[i];
            }
            i = (i + 1) & self.mask;
        }
    }
}

/// Writer-only bookkeeping: memory readers may still hold, freed by `compact` or drop.
#[derive(Default)]
struct Retired {
    blocks: Vec<usize>,
    tables: Vec<usize>,
}

pub(crate) struct Grid {
    table: AtomicPtr<Table>,
    levels: [AtomicU64; LEVEL_WORDS],
    /// Per level and axis, the smallest and largest cell coordinate holding a record: probes
    /// outside skip the table (on an axis-aligned floor, half the eight cells).
    bounds: Box<[[[AtomicI64; 2]; 3]]>,
    cells: AtomicUsize,
    block_bytes: AtomicUsize,
    entry_count: AtomicUsize,
    retired: Mutex<Retired>,
}

/// Where a sphere goes: biased level, cell coordinates, centre offset and squared radius in cell
/// units.
struct Placement {
    level: usize,
    cell: [i64; 3],
    offset: [f32; 3],
    radius2: f32,
}

fn place(c: DVec3, r: f64) -> Placement {
    let r = r * (1.0 + RADIUS_INFLATION);
    let level = level_for(r);
    let side = cell_side(level);
    let inv = 1.0 / side;
    let u = c * inv;
    let cell = u.floor();
    let offset = (c - cell * side) * inv;
    let ru = r * inv;
    let mut radius2 = (ru * ru) as f32;
    if (radius2 as f64) < ru * ru {
        radius2 = f32::from_bits(radius2.to_bits() + 1);
    }
    Placement {
        level,
        cell: [cell.x as i64, cell.y as i64, cell.z as i64],
        offset: offset.as_vec3().to_array(),
        radius2,
    }
}

impl Grid {
    pub(crate) fn new() -> Self {
        Grid {
            table: AtomicPtr::new(std::ptr::null_mut()),
            levels: std::array::from_fn(|_| AtomicU64::new(0)),
            bounds: (0..LEVELS)
                .map(|_| {
                    std::array::from_fn(|_| [AtomicI64::new(i64::MAX), AtomicI64::new(i64::MIN)])
                })
                .collect(),
            cells: AtomicUsize::new(0),
            block_bytes: AtomicUsize::new(0),
            entry_count: AtomicUsize::new(0),
            retired: Mutex::new(Retired::default()),
        }
    }

    /// Calls `f(id)` for every record whose (conservative) bounding sphere contains `p`, each once.
    /// Lock-free.
    #[inline]
    pub(crate) fn query(&self, p: DVec3, mut f: impl FnMut(u32)) {
        self.each_level(|table, level| self.query_level(table, level, p, &mut f));
    }

    /// Calls `f(table, level)` for the current table and every occupied level, finest first.
    #[inline]
    fn each_level(&self, mut f: impl FnMut(&Table, usize)) {
        let table = self.table.load(Ordering::Acquire);
        if table.is_null() {
            return;
        }
        // SAFETY: published tables are freed only under exclusive access.
        let table = unsafe { &*table };
        for (w, word) in self.levels.iter().enumerate() {
            let mut bits = word.load(Ordering::Acquire);
            while bits != 0 {
                f(table, 64 * w + bits.trailing_zeros() as usize);
                bits &= bits - 1;
            }
        }
    }

    #[inline]
    fn query_level(&self, table: &Table, level: usize, p: DVec3, f: &mut impl FnMut(u32)) {
        let side = cell_side(level);
        let inv = 1.0 / side;
        let u = p * inv;
        // (p is finite: callers validate it) no record's cell is this far out
        if u.abs().max_element() >= MAX_CELL_COORDINATE {
            return;
        }
        let i = u.floor();
        let frac = u - i;
        // along each axis: p's cell and the neighbour on the side of p's nearer face
        let lo = [
            i.x as i64 - (frac.x < 0.5) as i64,
            i.y as i64 - (frac.y < 0.5) as i64,
            i.z as i64 - (frac.z < 0.5) as i64,
        ];
        let lt = level_term(level);
        let tx = [axis_term(lo[0], 0), axis_term(lo[0] + 1, 0)];
        let ty = [axis_term(lo[1], 1), axis_term(lo[1] + 1, 1)];
        let tz = [axis_term(lo[2], 2), axis_term(lo[2] + 1, 2)];
        // which of the two cells per axis can hold records at all (bounds are widened before an
        // entry is published, and the level bit after: a reader that sees the level sees them)
        let live: [[bool; 2]; 3] = std::array::from_fn(|axis| {
            let b = &self.bounds[level][axis];
            let (min, max) = (b[0].load(Ordering::Relaxed), b[1].load(Ordering::Relaxed));
            [
                (min..=max).contains(&lo[axis]),
                (min..=max).contains(&(lo[axis] + 1)),
            ]
        });
        // All live probes first, then all lists: the memory system overlaps the misses of the
        // independent cells instead of serving one cell's chain (slot, list) after the other.
        let mut blocks: [*const Block; 8] = [std::ptr::null(); 8];
        let mut keys = [0u64; 8];
        for (corner, key) in keys.iter_mut().enumerate() {
            let (a, b, c) = (corner & 1, (corner >> 1) & 1, corner >> 2);
            if live[0][a] && live[1][b] && live[2][c] {
                *key = finish(lt ^ tx[a] ^ ty[b] ^ tz[c]);
                prefetch(table.home(*key));
            }
        }
        for (block, &key) in blocks.iter_mut().zip(&keys) {
            if key != 0 {
                *block = table.find(key);
                prefetch(*block as *const u8);
            }
        }
        for (corner, &block) in blocks.iter().enumerate() {
            if block.is_null() {
                continue;
            }
            let (a, b, c) = (corner & 1, (corner >> 1) & 1, corner >> 2);
            let cell = [lo[0] + a as i64, lo[1] + b as i64, lo[2] + c as i64];
            let origin = DVec3::new(cell[0] as f64, cell[1] as f64, cell[2] as f64) * side;
            let q = ((p - origin) * inv).as_vec3();
            scan(block, [q.x, q.y, q.z], f);
        }
    }

    /// Side of the finest occupied level's cells (None when the index is empty).
    pub(crate) fn finest_side(&self) -> Option<f64> {
        for (w, word) in self.levels.iter().enumerate() {
            let bits = word.load(Ordering::Acquire);
            if bits != 0 {
                return Some(cell_side(64 * w + bits.trailing_zeros() as usize));
            }
        }
        None
    }

    /// Calls `f(id, center, radius)` for every record whose (conservative) bounding sphere meets
    /// the ball (a, delta), with its listed centre and radius (within 10⁻⁵ relative of the
    /// record's). With `delta` at most half of [`Grid::finest_side`] at most three cells per axis
    /// and level are visited; a larger `delta` is correct but visits [`Grid::ball_cells`] cells.
    /// Lock-free.
    pub(crate) fn query_ball(&self, a: DVec3, delta: f64, mut f: impl FnMut(u32, DVec3, f64)) {
        self.each_level(|table, level| self.ball_level(table, level, a, delta, &mut f));
    }

    /// How many cells [`Grid::query_ball`] probes for the ball (a, delta), over every occupied
    /// level (no limit on `delta`): callers compare it with a linear scan's cost.
    pub(crate) fn ball_cells(&self, a: DVec3, delta: f64) -> f64 {
        let mut cells = 0.0;
        self.each_level(|_, level| {
            if let Some(r) = self.ball_ranges(level, a, delta) {
                cells += r
                    .iter()
                    .map(|r| {
                        if r.is_empty() {
                            0.0
                        } else {
                            (r.end() - r.start()) as f64 + 1.0
                        }
                    })
                    .product::<f64>();
            }
        });
        cells
    }

    /// The cell coordinates, per axis, whose records may meet the ball (a, delta) at `level`
    /// (clipped to the occupied cells); `None` for a NaN ball.
    fn ball_ranges(
        &self,
        level: usize,
        a: DVec3,
        delta: f64,
    ) -> Option<[std::ops::RangeInclusive<i64>; 3]> {
        let side = cell_side(level);
        let inv = 1.0 / side;
        let reach = 0.5 * side + delta;
        let lo = ((a - DVec3::splat(reach)) * inv).floor();
        let hi = ((a + DVec3::splat(reach)) * inv).floor();
        if lo.is_nan() || hi.is_nan() {
            return None;
        }
        // clipped to the occupied cells (real cell coordinates), so a ball reaching beyond the
        // coordinate range still finds every record of the level (`as` saturates)
        let b = &self.bounds[level];
        let range = |k: usize, l: f64, h: f64| {
            let min = b[k][0].load(Ordering::Relaxed);
            let max = b[k][1].load(Ordering::Relaxed);
            (l as i64).max(min)..=(h as i64).min(max)
        };
        Some([
            range(0, lo.x, hi.x),
            range(1, lo.y, hi.y),
            range(2, lo.z, hi.z),
        ])
    }

    fn ball_level(
        &self,
        table: &Table,
        level: usize,
        a: DVec3,
        delta: f64,
        f: &mut impl FnMut(u32, DVec3, f64),
    ) {
        let side = cell_side(level);
        let Some([rx, ry, rz]) = self.ball_ranges(level, a, delta) else {
            return;
        };
        for cz in rz {
            for cy in ry.clone() {
                for cx in rx.clone() {
                    let block = table.find(cell_key(level, [cx, cy, cz]));
                    if block.is_null() {
                        continue;
                    }
                    let origin = DVec3::new(cx as f64, cy as f64, cz as f64) * side;
                    let (xs, ys, zs, r2s, ids) = Block::entries(block);
                    for j in 0..ids.len() {
                        let off = DVec3::new(xs[j] as f64, ys[j] as f64, zs[j] as f64);
                        let c = origin + off * side;
                        let r = (r2s[j] as f64).sqrt() * side;
                        if (c - a).length() <= (r + delta) * (1.0 + 1e-6) {
                            f(ids[j], c, r);
                        }
                    }
                }
            }
        }
    }

    /// Adds record `id` with bounding sphere (center, radius).
    ///
    /// # Contract
    /// Only one thread may call this at a time (the cache's writer lock); the record behind `id`
    /// must be readable by other threads once they see it here; |center| ≤ 2^39·radius.
    pub(crate) fn insert(&self, id: u32, center: DVec3, radius: f64) {
        let at = place(center, radius);
        let key = cell_key(at.level, at.cell);
        let mut table = self.table.load(Ordering::Acquire);
        if table.is_null() {
            table = Box::into_raw(Table::new(FIRST_TABLE));
            self.table.store(table, Ordering::Release);
        }
        // SAFETY: only this (single) writer replaces or frees tables.
        let mut t = unsafe { &*table };
        let mut slot = t.slot_for(key);
        if slot.key.load(Ordering::Relaxed) == 0 {
            let cells = self.cells.load(Ordering::Relaxed) + 1;
            if 2 * cells > t.slots.len() {
                t = self.grow_table(t);
                slot = t.slot_for(key);
            }
            let b = Block::new(4);
            // SAFETY: just allocated.
            self.block_bytes
                .fetch_add(unsafe { &*b }.bytes(), Ordering::Relaxed);
            slot.block.store(b, Ordering::Relaxed);
            slot.key.store(key, Ordering::Release);
            self.cells.store(cells, Ordering::Relaxed);
        }
        for (axis, b) in self.bounds[at.level].iter().enumerate() {
            b[0].fetch_min(at.cell[axis], Ordering::Relaxed);
            b[1].fetch_max(at.cell[axis], Ordering::Relaxed);
        }
        self.push(slot, &at, id);
        self.levels[at.level / 64].fetch_or(1 << (at.level % 64), Ordering::Release);
        self.entry_count.fetch_add(1, Ordering::Relaxed);
    }

    fn grow_table(&self, old: &Table) -> &Table {
        let fresh = Table::new(old.slots.len() * 2);
        for s in old.slots.iter() {
            let k = s.key.load(Ordering::Relaxed);
            if k != 0 {
                let d = fresh.slot_for(k);
                d.block
                    .store(s.block.load(Ordering::Relaxed), Ordering::Relaxed);
                d.key.store(k, Ordering::Relaxed);
            }
        }
        let ptr = Box::into_raw(fresh);
        self.table.store(ptr, Ordering::Release);
        self.retired
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .tables
            .push(old as *const Table as usize);
        // SAFETY: just published; freed only under exclusive access.
        unsafe { &*ptr }
    }

    fn push(&self, slot: &Slot, at: &Placement, id: u32) {
        let mut block = slot.block.load(Ordering::Relaxed);
        // SAFETY: blocks are written only by this writer, below their capacity, past `len`.
        unsafe {
            let len = (*block).len.load(Ordering::Relaxed);
            if len == (*block).cap {
                let grown = Block::copy(block, len * 2);
                self.block_bytes
                    .fetch_add((*grown).bytes(), Ordering::Relaxed);
                slot.block.store(grown, Ordering::Release);
                self.retired
                    .lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .blocks
                    .push(block as usize);
                block = grown;
            }
            let i = len as usize;
            for k in 0..3 {
                *Block::array(block, k).add(i) = at.offset[k].to_bits();
            }
            *Block::array(block, 3).add(i) = at.radius2.to_bits();
            *Block::array(block, 4).add(i) = id;
            (*block).len.store(len + 1, Ordering::Release);
        }
    }

    /// Every listed id, cell by cell (in table order).
    pub(crate) fn ids_in_cell_order(&mut self) -> Vec<u32> {
        let mut ids = Vec::with_capacity(*self.entry_count.get_mut());
        let table = *self.table.get_mut();
        if !table.is_null() {
            // SAFETY: exclusive access; the current table owns its blocks.
            for s in unsafe { &*table }.slots.iter() {
                let b = s.block.load(Ordering::Relaxed);
                if !b.is_null() {
                    unsafe {
                        let len = (*b).len.load(Ordering::Relaxed) as usize;
                        ids.extend_from_slice(std::slice::from_raw_parts(Block::array(b, 4), len));
                    }
                }
            }
        }
        ids
    }

    /// Renumbers every id through `new_id` (indexed by old id), trims every entry list to its
    /// length and frees retired lists and tables. Exclusive access guarantees that no reader
    /// holds any of them.
    pub(crate) fn compact(&mut self, new_id: &[u32]) {
        let table = *self.table.get_mut();
        let mut bytes = 0;
        if !table.is_null() {
            // SAFETY: exclusive access; the current table and its blocks are owned here.
            for s in unsafe { &*table }.slots.iter() {
                let b = s.block.load(Ordering::Relaxed);
                if b.is_null() {
                    continue;
                }
                unsafe {
                    let len = (*b).len.load(Ordering::Relaxed);
                    for id in std::slice::from_raw_parts_mut(Block::array(b, 4), len as usize) {
                        *id = new_id[*id as usize];
                    }
                    if len < (*b).cap {
                        let fresh = Block::copy(b, len.max(1));
                        s.block.store(fresh, Ordering::Relaxed);
                        Block::free(b);
                    }
                    bytes += (*s.block.load(Ordering::Relaxed)).bytes();
                }
            }
        }
        let retired = std::mem::take(self.retired.get_mut().unwrap_or_else(|e| e.into_inner()));
        free_retired(retired);
        *self.block_bytes.get_mut() = bytes;
    }

    /// Bytes held by the index (table, entry lists, retired memory).
    pub(crate) fn bytes(&self) -> usize {
        let table = self.table.load(Ordering::Acquire);
        let table_bytes = if table.is_null() {
            0
        } else {
            // SAFETY: published tables live until compact/drop.
            unsafe { &*table }.slots.len() * std::mem::size_of::<Slot>()
        };
        let retired = self.retired.lock().unwrap_or_else(|e| e.into_inner());
        let retired_tables: usize = retired
            .tables
            .iter()
            // SAFETY: retired tables live until compact/drop.
            .map(|&t| unsafe { &*(t as *const Table) }.slots.len() * std::mem::size_of::<Slot>())
            .sum();
        table_bytes + retired_tables + self.block_bytes.load(Ordering::Relaxed)
    }

    /// Entries stored (one per record).
    pub(crate) fn entries(&self) -> usize {
        self.entry_count.load(Ordering::Relaxed)
    }
}

/// A hint to bring the cache line at `p` closer (no effect on results; null is fine).
#[inline(always)]
pub(crate) fn prefetch(p: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: prefetching never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch(p as *const i8, std::arch::x86_64::_MM_HINT_T0)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

fn free_retired(retired: Retired) {
    for b in retired.blocks {
        // SAFETY: retired blocks are no longer referenced by any slot and no reader exists.
        unsafe { Block::free(b as *mut Block) };
    }
    for t in retired.tables {
        // SAFETY: allocated by `Box::into_raw`; their blocks are owned by the current table.
        drop(unsafe { Box::from_raw(t as *mut Table) });
    }
}

/// Calls `f(id)` for every sphere of `block` containing the point `q` (cell units).
#[inline]
fn scan(block: *const Block, q: [f32; 3], f: &mut impl FnMut(u32)) {
    let (xs, ys, zs, r2s, ids) = Block::entries(block);
    let full = xs.len() / LANES * LANES;
    let mut base = 0;
    while base < full {
        let lane = |a: &[f32]| -> [f32; LANES] {
            a[base..base + LANES].try_into().unwrap_or([0.0; LANES])
        };
        let mask = hits(lane(xs), lane(ys), lane(zs), lane(r2s), q);
        report(mask, &ids[base..], f);
        base += LANES;
    }
    if full < xs.len() {
        // the tail, padded with spheres that contain nothing (squared radius -1)
        let tail = |a: &[f32], pad: f32| -> [f32; LANES] {
            let mut t = [pad; LANES];
            for (t, a) in t.iter_mut().zip(&a[full..]) {
                *t = *a;
            }
            t
        };
        let mask = hits(
            tail(xs, 0.0),
            tail(ys, 0.0),
            tail(zs, 0.0),
            tail(r2s, -1.0),
            q,
        );
        report(mask, &ids[full..], f);
    }
}

pub(crate) const LANES: usize = 8;

/// Bit j set when sphere j contains q.
#[inline(always)]
pub(crate) fn hits(
    x: [f32; LANES],
    y: [f32; LANES],
    z: [f32; LANES],
    r2: [f32; LANES],
    q: [f32; 3],
) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        // SSE2 is part of the x86_64 baseline: two four-lane halves, a movemask each.
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is always available on x86_64; the loads read 4 floats from 8-float arrays.
        unsafe {
            let half = |o: usize| {
                let dx = _mm_sub_ps(_mm_loadu_ps(x.as_ptr().add(o)), _mm_set1_ps(q[0]));
                let dy = _mm_sub_ps(_mm_loadu_ps(y.as_ptr().add(o)), _mm_set1_ps(q[1]));
                let dz = _mm_sub_ps(_mm_loadu_ps(z.as_ptr().add(o)), _mm_set1_ps(q[2]));
                let d2 = _mm_add_ps(
                    _mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                    _mm_mul_ps(dz, dz),
                );
                _mm_movemask_ps(_mm_cmple_ps(d2, _mm_loadu_ps(r2.as_ptr().add(o)))) as u32
            };
            half(0) | half(4) << 4
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut mask = 0u32;
        for j in 0..LANES {
            let (dx, dy, dz) = (x[j] - q[0], y[j] - q[1], z[j] - q[2]);
            mask |= ((dx * dx + dy * dy + dz * dz <= r2[j]) as u32) << j;
        }
        mask
    }
}

#[inline(always)]
fn report(mut mask: u32, ids: &[u32], f: &mut impl FnMut(u32)) {
    while mask != 0 {
        f(ids[mask.trailing_zeros() as usize]);
        mask &= mask - 1;
    }
}

impl Drop for Grid {
    fn drop(&mut self) {
        let table = *self.table.get_mut();
        if !table.is_null() {
            // SAFETY: exclusive; the current table owns its blocks.
            let t = unsafe { Box::from_raw(table) };
            for s in t.slots.iter() {
                let b = s.block.load(Ordering::Relaxed);
                if !b.is_null() {
                    unsafe { Block::free(b) };
                }
            }
        }
        let retired = std::mem::take(self.retired.get_mut().unwrap_or_else(|e| e.into_inner()));
        free_retired(retired);
    }
}

#[cfg(test)]
mod tests;
