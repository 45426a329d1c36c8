//! What the tests read of this thread's cursors.

use super::CURSORS;

/// How many lookups this thread's cursor for `identity` served by each plan (remembered,
/// anchored, plain), if it has one.
pub(in crate::cache) fn served(identity: u64) -> Option<[usize; 3]> {
    CURSORS.with(|cell| {
        let cursors = cell.borrow();
        let slot = cursors.slots.iter().find(|s| s.identity == identity)?;
        Some(slot.cursor.served)
    })
}
