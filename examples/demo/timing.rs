//! CPU time of the calling thread: what a piece of work cost, unaffected by other processes
//! competing for the cores (wall-clock intervals on a shared machine are not).

/// A running per-thread CPU clock.
pub struct ThreadTimer(f64);

#[cfg(unix)]
fn thread_cpu_seconds() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
    if ok {
        ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
    } else {
        wall_seconds()
    }
}

#[cfg(not(unix))]
fn thread_cpu_seconds() -> f64 {
    wall_seconds()
}

fn wall_seconds() -> f64 {
    static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
    START
        .get_or_init(std::time::Instant::now)
        .elapsed()
        .as_secs_f64()
}

impl ThreadTimer {
    pub fn start() -> Self {
        ThreadTimer(thread_cpu_seconds())
    }

    /// CPU seconds this thread spent since `start`.
    pub fn seconds(&self) -> f64 {
        thread_cpu_seconds() - self.0
    }
}
