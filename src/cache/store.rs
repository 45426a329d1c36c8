//! An append-only array in geometrically growing chunks: elements never move, so readers hold
//! plain pointers into it while one writer appends.

use std::sync::atomic::{AtomicPtr, Ordering};

/// Items in the first chunk; chunk `k` holds `FIRST << k` items.
const FIRST_LOG2: u32 = 8;
const MAX_CHUNKS: usize = 40;

/// Append-only storage of `slot` consecutive `T`s per item, in chunks of doubling size.
///
/// Concurrency contract (upheld by the cache): only one thread at a time calls [`Chunks::ensure`]
/// and writes through [`Chunks::slot_ptr`] to items that are not yet published; readers only touch
/// items whose publication they observed through an `Acquire` load that pairs with the writer's
/// `Release` store made after the item was written.
pub(crate) struct Chunks<T> {
    slot: usize,
    chunks: [AtomicPtr<T>; MAX_CHUNKS],
}

// SAFETY: the chunk memory is owned by this struct, and access follows the publication contract
// above (items are written before they are published and never written after).
unsafe impl<T: Send + Sync> Send for Chunks<T> {}
unsafe impl<T: Send + Sync> Sync for Chunks<T> {}

fn locate(index: usize) -> (usize, usize) {
    let j = index + (1usize << FIRST_LOG2);
    let k = (usize::BITS - 1 - j.leading_zeros() - FIRST_LOG2) as usize;
    (k, j - ((1usize << FIRST_LOG2) << k))
}

fn chunk_items(k: usize) -> usize {
    (1usize << FIRST_LOG2) << k
}

/// Element types whose all-zero bit pattern is a valid value, so chunks come from `alloc_zeroed`:
/// the operating system maps such pages lazily, so a chunk's unused tail costs address space,
/// not memory.
pub(crate) trait Zeroable: Copy {}
impl Zeroable for u64 {}

impl<T: Zeroable> Chunks<T> {
    /// Storage for items of `slot` values of `T` each.
    pub(crate) fn new(slot: usize) -> Self {
        Chunks {
            slot: slot.max(1),
            chunks: std::array::from_fn(|_| AtomicPtr::new(std::ptr::null_mut())),
        }
    }

    /// Values of `T` per item.
    pub(crate) fn slot_len(&self) -> usize {
        self.slot
    }

    /// Makes sure item `index` has memory (writer only). Items start as all-zero bytes.
    pub(crate) fn ensure(&self, index: usize) {
        let (k, _) = locate(index);
        assert!(k < MAX_CHUNKS, "cache storage exhausted");
        if self.chunks[k].load(Ordering::Acquire).is_null() {
            let len = chunk_items(k) * self.slot;
            let layout = std::alloc::Layout::array::<T>(len).expect("chunk size");
            // SAFETY: non-zero size; all-zero bytes are a valid `T` (`Zeroable`).
            let ptr = unsafe { std::alloc::alloc_zeroed(layout) } as *mut T;
            if ptr.is_null() {
                std::alloc::handle_alloc_error(layout);
            }
            self.chunks[k].store(ptr, Ordering::Release);
        }
    }

    /// Pointer to the first `T` of item `index`, whose chunk must exist.
    #[inline]
    pub(crate) fn slot_ptr(&self, index: usize) -> *mut T {
        let (k, off) = locate(index);
        let base = self.chunks[k].load(Ordering::Acquire);
        debug_assert!(!base.is_null());
        // SAFETY: `off < chunk_items(k)`, so the offset stays inside the chunk allocation.
        unsafe { base.add(off * self.slot) }
    }

    /// Bytes allocated so far.
    pub(crate) fn allocated_bytes(&self) -> usize {
        (0..MAX_CHUNKS)
            .filter(|&k| !self.chunks[k].load(Ordering::Relaxed).is_null())
            .map(|k| chunk_items(k) * self.slot * std::mem::size_of::<T>())
            .sum()
    }
}

impl<T> Drop for Chunks<T> {
    // Frees with the layout `ensure` allocated with.
    fn drop(&mut self) {
        for (k, chunk) in self.chunks.iter().enumerate() {
            let ptr = chunk.load(Ordering::Relaxed);
            if !ptr.is_null() {
                let len = chunk_items(k) * self.slot;
                let layout = std::alloc::Layout::array::<T>(len).expect("chunk size");
                // SAFETY: allocated in `ensure` with exactly this layout.
                unsafe { std::alloc::dealloc(ptr as *mut u8, layout) };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locate_covers_every_index_once() {
        let mut expected = (0usize, 0usize);
        for i in 0..100_000 {
            assert_eq!(locate(i), expected, "index {i}");
            expected.1 += 1;
            if expected.1 == chunk_items(expected.0) {
                expected = (expected.0 + 1, 0);
            }
        }
    }

    #[test]
    fn items_keep_their_values_across_growth() {
        let c: Chunks<u64> = Chunks::new(3);
        for i in 0..5000usize {
            c.ensure(i);
            for w in 0..3 {
                unsafe { *c.slot_ptr(i).add(w) = (i * 3 + w) as u64 };
            }
        }
        for i in 0..5000usize {
            // SAFETY: item i has 3 initialized u64s.
            let slot = unsafe { std::slice::from_raw_parts(c.slot_ptr(i), 3) };
            assert_eq!(
                slot,
                &[(i * 3) as u64, (i * 3 + 1) as u64, (i * 3 + 2) as u64]
            );
        }
        assert!(c.allocated_bytes() >= 5000 * 24);
    }
}
