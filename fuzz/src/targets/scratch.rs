//! Scratch cache files for the targets that save and load (`cache_load`, `cache_ops`).
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

/// A file name in the temporary directory unique to this process and call (the counter is shared
/// by every thread, so concurrent targets never collide).
pub fn scratch_path(tag: &str) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    std::env::temp_dir().join(format!(
        "raddiff-fuzz-{}-{tag}-{n}.cache",
        std::process::id()
    ))
}
