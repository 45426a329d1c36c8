//! Fuzz targets for raddiff's C entry points: byte decoders and property checks.
//!
//! Every target is a `run(data: &[u8]) -> Outcome` function in [`targets`] that decodes the bytes into
//! a call (or a sequence of calls) through `raddiff::ffi`, and panics when a property fails: a
//! `RADDIFF_ERROR_PANIC`, a non-finite output with `RADDIFF_OK`, an output written on failure, an
//! error without a message. The AFL++ binaries in `src/bin/` call them; the root crate's
//! `tests/fuzz_regressions.rs` compiles the same module and replays the corpora and every finding.
pub mod targets;
