//! The per-thread cursors behind [`Cache::lookup`](super::Cache::lookup).
//!
//! Plain lookups get a [`Cursor`]'s speed on coherent queries without the caller keeping one:
//! each thread keeps a cursor for each of the last [`CACHES`] caches it looked up in (a renderer
//! interleaves a few: surface irradiance, single and multiple scattering), replacing the least
//! recently used one. A cursor holds no reference to its cache, only slot addresses that it
//! dereferences while the cache's (identity, generation, length) is the one it anchored on, and
//! cache identities are never reused, so a cursor outliving its cache is harmless: it is replaced
//! or re-anchors. Incoherent queries cost about a plain index lookup (the cursor's cool-down).

use std::cell::RefCell;

use super::cursor::Cursor;

/// Caches per thread that keep a cursor.
pub(super) const CACHES: usize = 4;

#[derive(Default)]
struct Slot {
    /// The cache's identity (0: empty; identities start at 1).
    identity: u64,
    /// When the slot was last used, in lookups of this thread.
    used: u64,
    cursor: Cursor,
}

#[derive(Default)]
struct ThreadCursors {
    slots: [Slot; CACHES],
    clock: u64,
}

impl ThreadCursors {
    fn cursor(&mut self, identity: u64) -> &mut Cursor {
        self.clock += 1;
        let k = match self.slots.iter().position(|s| s.identity == identity) {
            Some(k) => k,
            None => {
                let k = (0..CACHES).min_by_key(|&k| self.slots[k].used).unwrap_or(0);
                self.slots[k] = Slot {
                    identity,
                    used: 0,
                    cursor: Cursor::new(),
                };
                k
            }
        };
        let slot = &mut self.slots[k];
        slot.used = self.clock;
        &mut slot.cursor
    }
}

thread_local! {
    static CURSORS: RefCell<ThreadCursors> = RefCell::new(ThreadCursors::default());
}

/// Runs `f` with this thread's cursor for the cache `identity`. `f` is not run when the thread's
/// cursors cannot be reached (while the thread's locals are being destroyed, or if a lookup were
/// ever re-entered): the caller then takes the index path.
pub(super) fn with(identity: u64, f: impl FnOnce(&mut Cursor)) {
    let _ = CURSORS.try_with(|cell| {
        if let Ok(mut cursors) = cell.try_borrow_mut() {
            f(cursors.cursor(identity));
        }
    });
}

#[cfg(test)]
pub(super) mod tests;
