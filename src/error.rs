//! The crate's error type, shared by every module and mapped one-to-one onto `raddiff_status` codes.

/// Why a raddiff call could not produce a result.
///
/// Each variant corresponds to one `RADDIFF_ERROR_*` status of the C ABI; the message is what
/// `raddiff_last_error` returns.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum Error {
    /// An argument is out of its domain: non-finite number, bad size, bad enum value, non-unit vector.
    #[error("invalid argument: {0}")]
    InvalidArgument(String),
    /// The requested quantity is undefined for this configuration (for example the gradient of a
    /// solid angle at a point on the triangle's edge, or a zero-area triangle).
    #[error("degenerate configuration: {0}")]
    Degenerate(String),
    /// Nothing matched (for example no cache record covers the query point).
    #[error("not found: {0}")]
    NotFound(String),
    /// The operating system refused a file operation.
    #[error("i/o error: {0}")]
    Io(String),
    /// A file or buffer failed validation (bad magic, version, checksum, truncation).
    #[error("corrupt data: {0}")]
    Corrupt(String),
    /// A caller's callback (the tracing function of
    /// [`Cache::irradiance`](crate::cache::Cache::irradiance)) reported a failure; the message is
    /// the callback's.
    #[error("callback failed: {0}")]
    Callback(String),
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Io(e.to_string())
    }
}

/// Result alias used across the crate.
pub type Result<T> = std::result::Result<T, Error>;

/// Returns `InvalidArgument` naming `what` unless `v` is finite.
pub(crate) fn ensure_finite(v: f64, what: &str) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "{what} is not finite ({v})"
        )))
    }
}

/// Returns `InvalidArgument` naming `what` unless every component of `v` is finite.
#[inline]
pub(crate) fn ensure_finite3(v: glam::DVec3, what: &str) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(not_finite3(v, what))
    }
}

// Out of line: the check above sits on hot paths (cache lookups), the message never does.
#[cold]
#[inline(never)]
fn not_finite3(v: glam::DVec3, what: &str) -> Error {
    Error::InvalidArgument(format!("{what} is not finite ({v})"))
}

/// Returns `InvalidArgument` naming `what` unless every component of `v` is finite.
pub(crate) fn ensure_finite2(v: glam::DVec2, what: &str) -> Result<()> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(Error::InvalidArgument(format!(
            "{what} is not finite ({v})"
        )))
    }
}
