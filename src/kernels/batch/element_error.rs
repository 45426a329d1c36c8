//! The error of one element of a batch call: the single kernel's error, its message prefixed
//! with the element's kind and index ("triangle 12: ..."), so that the caller knows which one.

use crate::error::Error;

/// `e` with its message prefixed by the element it concerns.
pub(crate) fn label(e: Error, what: &str, index: usize) -> Error {
    match e {
        Error::InvalidArgument(m) => Error::InvalidArgument(format!("{what} {index}: {m}")),
        Error::Degenerate(m) => Error::Degenerate(format!("{what} {index}: {m}")),
        other => other,
    }
}
