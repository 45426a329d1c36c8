//! Cache files: `raddiff_cache_load` on arbitrary bytes.
//!
//! Input: one option byte, then the file. When the option byte is odd, the file's last 8 bytes are
//! replaced by the FNV-1a checksum of the rest (as `raddiff_cache_save` writes it), so that mutated
//! headers and records get past the checksum and reach the record validation. The seed corpus is
//! real saved caches of format versions 2 to 9 (surface and volume, 1 and 3 channels, with and
//! without gradients, a gradient limit, a leak guard, a far-field marker, an open-fraction test
//! (keeping no coverage, all of it, and that within a coverage tolerance), records' open
//! fractions and a lookup radius scale).
//! Properties: no panic; NULL comes with a message; a loaded cache holds at most the file's record
//! count, looks up finite values at its records' positions (with and without an open fraction),
//! and saving it reproduces a version 9 file byte for byte (an older file: the same records once
//! loaded again).
use std::ffi::CString;

use raddiff::ffi::*;

use super::cache_ops::{lookup, lookup_open};
use super::check;
use super::scratch::scratch_path;
use super::Outcome;

/// Loads the decoded file and checks what came back.
pub fn run(data: &[u8]) -> Outcome {
    let (option, file) = match data.split_first() {
        Some((&o, f)) => (o, f.to_vec()),
        None => (0, Vec::new()),
    };
    let mut file = file;
    if option & 1 == 1 && file.len() >= 8 {
        let body = file.len() - 8;
        let sum = fnv1a(&file[..body]);
        file[body..].copy_from_slice(&sum.to_le_bytes());
    }
    let path = scratch_path("load");
    std::fs::write(&path, &file).expect("writing a scratch file");
    let c_path = CString::new(path.to_string_lossy().as_bytes()).expect("no NUL in path");
    let cache = raddiff_cache_load(c_path.as_ptr());
    let _ = std::fs::remove_file(&path);
    if !check::constructed("raddiff_cache_load", cache) {
        return Outcome::Refused;
    }
    let header = Header::read(&file);
    let len = raddiff_cache_len(cache);
    assert!(
        len as u64 <= header.count,
        "raddiff_cache_load: {len} records from a file of {}",
        header.count
    );
    for i in 0..len.min(4) {
        let at = header.bytes + i * header.stride;
        let position = raddiff_vec3 {
            x: f64_at(&file, at),
            y: f64_at(&file, at + 8),
            z: f64_at(&file, at + 16),
        };
        for normal in AXES {
            lookup(cache, None, position, normal, header.channels);
            lookup_open(cache, None, position, normal, 0.5, header.channels);
        }
    }
    resave(cache, &file, header.version);
    raddiff_cache_free(cache);
    Outcome::Ok
}

/// Saves the loaded cache: a version 9 file comes back byte for byte, an older file as a version 9
/// file that loads with as many records.
fn resave(cache: *const raddiff_cache, file: &[u8], version: u32) {
    let path = scratch_path("resave");
    let c_path = CString::new(path.to_string_lossy().as_bytes()).expect("no NUL in path");
    let ok = check::status(
        "raddiff_cache_save",
        raddiff_cache_save(cache, c_path.as_ptr()),
    );
    assert!(ok, "raddiff_cache_save failed on a scratch path");
    let saved = std::fs::read(&path).expect("reading the saved cache");
    let again = raddiff_cache_load(c_path.as_ptr());
    let _ = std::fs::remove_file(&path);
    assert!(
        check::constructed("raddiff_cache_load", again),
        "a re-saved cache does not load: {}",
        check::last_error()
    );
    assert_eq!(raddiff_cache_len(again), raddiff_cache_len(cache));
    raddiff_cache_free(again);
    if version == 9 {
        assert!(
            saved == file,
            "saving a loaded version 9 file changed its bytes"
        );
    }
}

/// The unit axes, both ways: lookup normals for surface records of unknown orientation.
const AXES: [raddiff_vec3; 6] = [
    raddiff_vec3 {
        x: 1.0,
        y: 0.0,
        z: 0.0,
    },
    raddiff_vec3 {
        x: -1.0,
        y: 0.0,
        z: 0.0,
    },
    raddiff_vec3 {
        x: 0.0,
        y: 1.0,
        z: 0.0,
    },
    raddiff_vec3 {
        x: 0.0,
        y: -1.0,
        z: 0.0,
    },
    raddiff_vec3 {
        x: 0.0,
        y: 0.0,
        z: 1.0,
    },
    raddiff_vec3 {
        x: 0.0,
        y: 0.0,
        z: -1.0,
    },
];

/// The header fields of a file that loaded (so they are valid).
struct Header {
    version: u32,
    channels: usize,
    count: u64,
    stride: usize,
    /// Header size: where the records start.
    bytes: usize,
}

impl Header {
    fn read(file: &[u8]) -> Header {
        let u32_at = |o: usize| u32::from_le_bytes(file[o..o + 4].try_into().expect("4 bytes"));
        let version = u32_at(8);
        Header {
            version,
            channels: u32_at(12) as usize,
            count: u64::from_le_bytes(file[32..40].try_into().expect("8 bytes")),
            stride: u32_at(40) as usize,
            bytes: match version {
                2 => 48,
                3 => 56,
                4 => 72,
                5 => 88,
                6 => 96,
                7 | 8 => 104,
                _ => 112,
            },
        }
    }
}

fn f64_at(file: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(file[at..at + 8].try_into().expect("8 bytes"))
}

/// FNV-1a 64, the cache files' checksum (documented in the file format).
pub fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}
