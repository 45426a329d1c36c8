//! Replays the fuzz corpora (`fuzz/corpus/<target>/`) and every fuzzing finding
//! (`fuzz/regressions/<target>/`) through the fuzz targets' own property checks, on stable Rust
//! without AFL++ (docs/fuzzing.md). The checks panic on a failed property: a caught panic
//! (`RADDIFF_ERROR_PANIC`), a non-finite output with `RADDIFF_OK`, an output written on failure, an
//! error without a message.

// The targets are the fuzz crate's own module, compiled here as well.
#[path = "../fuzz/src/targets/mod.rs"]
mod targets;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

use targets::Outcome;

fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// Runs every file of `dir` through `target`; returns the outcomes and the failures (file and
/// panic message).
fn replay(target: &str, dir: &Path) -> (Vec<Outcome>, Vec<String>) {
    let run = targets::by_name(target).expect("a known target");
    let mut outcomes = Vec::new();
    let mut failures = Vec::new();
    for file in files(dir) {
        let data = std::fs::read(&file).expect("reading a fuzz input");
        match catch_unwind(AssertUnwindSafe(|| run(&data))) {
            Ok(outcome) => outcomes.push(outcome),
            Err(payload) => {
                let message = payload
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                failures.push(format!("{}: {message}", file.display()));
            }
        }
    }
    (outcomes, failures)
}

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz")
}

/// Every corpus input keeps every property, and each corpus still reaches both the success and
/// the refusal paths of its entry point (a decoder change that made a corpus useless fails here).
#[test]
fn corpora_keep_every_property() {
    let mut failures = Vec::new();
    for target in targets::NAMES {
        let (outcomes, failed) = replay(target, &fuzz_dir().join("corpus").join(target));
        failures.extend(failed);
        assert!(
            outcomes.contains(&Outcome::Ok) && outcomes.contains(&Outcome::Refused),
            "fuzz/corpus/{target}: {} inputs replayed, {} accepted: the corpus must reach both \
             the accepted and the refused paths",
            outcomes.len(),
            outcomes.iter().filter(|o| **o == Outcome::Ok).count()
        );
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every input that fuzzing found failing, now fixed, keeps every property.
#[test]
fn fuzzing_findings_stay_fixed() {
    let mut replayed = 0;
    let mut failures = Vec::new();
    for target in targets::NAMES {
        let (outcomes, failed) = replay(target, &fuzz_dir().join("regressions").join(target));
        replayed += outcomes.len() + failed.len();
        failures.extend(failed);
    }
    assert!(replayed > 0, "no findings under fuzz/regressions/");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The harness itself detects what it is meant to: an output written on failure, a non-finite
/// output with RADDIFF_OK, a caught panic.
#[test]
fn the_property_checks_catch_violations() {
    use targets::check;
    let wrote = catch_unwind(|| check::untouched("call", "out", &[check::sentinel(), 0.0]));
    assert!(wrote.is_err());
    check::untouched("call", "out", &[check::sentinel(); 3]);
    let nan = catch_unwind(|| check::finite("call", "out", &[1.0, f64::NAN]));
    assert!(nan.is_err());
    let inf = catch_unwind(|| check::finite_f32("call", "out", &[f32::INFINITY]));
    assert!(inf.is_err());
    let panicked =
        catch_unwind(|| check::status("call", raddiff::ffi::raddiff_status::RADDIFF_ERROR_PANIC));
    assert!(panicked.is_err());
}
