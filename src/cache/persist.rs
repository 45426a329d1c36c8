//! Saving and loading caches (format documented in the [module docs](super)).

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::lookup_radius::check_scale;
use super::record::{self, Domain, CHANNEL_BYTES, FNV_OFFSET, HEAD_BYTES};
use super::{
    Cache, CacheConfig, CacheValue, FarFieldReach, Interpolation, LeakGuard, OpenFractionTest,
    LOOKUP_RADIUS_SCALE_MAX, MAX_CHANNELS,
};
use crate::error::{Error, Result};

/// File magic.
pub const MAGIC: [u8; 8] = *b"RDFCACHE";
/// Format version written by [`Cache::to_bytes`] (versions 2 to 9 are read).
pub const FORMAT_VERSION: u32 = 9;
/// Version 8: no coverage tolerance field (records at [`HEADER_BYTES_V8`]); flag bit 5 says the
/// open-fraction test keeps all coverage (an infinite coverage tolerance), else it keeps none.
const FORMAT_VERSION_8: u32 = 8;
/// Version 7: the version 8 header, but the open-fraction test never keeps coverage (flag bit 5
/// unknown).
const FORMAT_VERSION_7: u32 = 7;
/// Version 6: no lookup radius scale (it is 1), records at [`HEADER_BYTES_V6`].
const FORMAT_VERSION_6: u32 = 6;
/// Version 5: no open-fraction test, records at [`HEADER_BYTES_V5`] without open fractions.
const FORMAT_VERSION_5: u32 = 5;
/// Version 4: no far-field fields, records at [`HEADER_BYTES_V4`].
const FORMAT_VERSION_4: u32 = 4;
/// Version 3: no leak-guard fields either, records at [`HEADER_BYTES_V3`].
const FORMAT_VERSION_3: u32 = 3;
/// The oldest version read: no gradient-limit field either, records at [`HEADER_BYTES_V2`].
const FORMAT_VERSION_2: u32 = 2;
/// Header size of version 9: the version 8 header plus the open-fraction coverage tolerance
/// (f64 at offset 104).
const HEADER_BYTES: usize = 112;
/// Header size of versions 7 and 8: the version 6 header plus the lookup radius scale (f64 at
/// offset 96).
const HEADER_BYTES_V8: usize = 104;
/// Header size of version 6: the version 5 header plus the open-fraction tolerance (f64 at
/// offset 88).
const HEADER_BYTES_V6: usize = 96;
/// Header size of version 5: the version 4 header plus the far field's two reaches (f64 at
/// offsets 72 and 80).
const HEADER_BYTES_V5: usize = 88;
/// Header size of version 4: the version 3 header plus the leak guard's two tolerances (f64 at
/// offsets 56 and 64).
const HEADER_BYTES_V4: usize = 72;
/// Header size of version 3: the version 2 header plus the gradient limit (f64 at offset 48).
const HEADER_BYTES_V3: usize = 56;
const HEADER_BYTES_V2: usize = 48;
const CHECKSUM_BYTES: usize = 8;
/// Header flag (offset 44): [`CacheConfig::non_negative`].
const FLAG_NON_NEGATIVE: u32 = 1;
/// Header flag (offset 44, version 3): [`CacheConfig::gradient_limit`] is set (its value at
/// offset 48).
const FLAG_GRADIENT_LIMIT: u32 = 2;
/// Header flag (offset 44, version 4): [`CacheConfig::leak_guard`] is on (its tolerances at
/// offsets 56 and 64).
const FLAG_LEAK_GUARD: u32 = 4;
/// Header flag (offset 44, version 5): [`CacheConfig::far_field`] is on (its reaches at offsets
/// 72 and 80).
const FLAG_FAR_FIELD: u32 = 8;
/// Header flag (offset 44, version 6): [`CacheConfig::open_fraction_test`] is on (its tolerance
/// at offset 88).
const FLAG_OPEN_FRACTION: u32 = 16;
/// Header flag (offset 44, version 8 only; only with [`FLAG_OPEN_FRACTION`]): the open-fraction
/// test keeps all coverage (an infinite [`OpenFractionTest::coverage_tolerance`]); version 9
/// stores the coverage tolerance instead.
const FLAG_OPEN_FRACTION_KEEPS_COVERAGE: u32 = 32;

impl<V: CacheValue> Cache<V> {
    /// The cache in the documented binary format (records in content order, so equal record
    /// sets give byte-identical output whatever the insertion order).
    pub fn to_bytes(&self) -> Vec<u8> {
        let count = self.len();
        let mut ids: Vec<u32> = (0..count as u32).collect();
        ids.sort_unstable_by(|&a, &b| record::content_order(self.stored(a), self.stored(b)));
        let stride = HEAD_BYTES + CHANNEL_BYTES * self.config.channels;
        let mut out = Vec::with_capacity(HEADER_BYTES + count * stride + CHECKSUM_BYTES);
        out.extend_from_slice(&MAGIC);
        out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        out.extend_from_slice(&(self.config.channels as u32).to_le_bytes());
        out.extend_from_slice(&(self.config.domain as u32).to_le_bytes());
        out.extend_from_slice(&(self.config.interpolation as u32).to_le_bytes());
        out.extend_from_slice(&self.config.max_normal_deviation.to_le_bytes());
        out.extend_from_slice(&(count as u64).to_le_bytes());
        out.extend_from_slice(&(stride as u32).to_le_bytes());
        let limited = self.config.gradient_limit < f64::INFINITY;
        let mut flags = 0;
        if self.config.non_negative {
            flags |= FLAG_NON_NEGATIVE;
        }
        if limited {
            flags |= FLAG_GRADIENT_LIMIT;
        }
        let guard = self.config.leak_guard;
        if guard.is_on() {
            flags |= FLAG_LEAK_GUARD;
        }
        let far = self.config.far_field;
        if far.is_on() {
            flags |= FLAG_FAR_FIELD;
        }
        let open = self.config.open_fraction_test;
        if open.is_on() {
            flags |= FLAG_OPEN_FRACTION;
        }
        out.extend_from_slice(&flags.to_le_bytes());
        let limit = if limited {
            self.config.gradient_limit
        } else {
            0.0
        };
        out.extend_from_slice(&limit.to_le_bytes());
        let (relative, absolute) = if guard.is_on() {
            (guard.relative, guard.absolute)
        } else {
            (0.0, 0.0)
        };
        out.extend_from_slice(&relative.to_le_bytes());
        out.extend_from_slice(&absolute.to_le_bytes());
        let far = if far.is_on() { far } else { FarFieldReach::OFF };
        out.extend_from_slice(&far.world.to_le_bytes());
        out.extend_from_slice(&far.pixels.to_le_bytes());
        let tolerance = if open.is_on() { open.tolerance } else { 0.0 };
        out.extend_from_slice(&tolerance.to_le_bytes());
        out.extend_from_slice(&self.config.lookup_radius_scale.to_le_bytes());
        out.extend_from_slice(&open.coverage_tolerance.to_le_bytes());
        for id in ids {
            let (head, chans) = self.stored(id);
            record::serialize(head, chans, &mut out);
        }
        let sum = record::fnv1a(FNV_OFFSET, &out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// Parses and validates a cache in the documented binary format. `Corrupt` with the reason
    /// for anything that [`Cache::to_bytes`] could not have written, including a channel count
    /// that disagrees with `V`. Never panics.
    ///
    /// Version 8 files (the open-fraction test keeps all coverage or none), version 7 files (the
    /// test, if on, keeps none), version 6 files (no lookup radius scale either: it is 1),
    /// version 5 files (no open-fraction test either: it is off, and records have no open
    /// fraction), version 4 files (no far-field marker either: records hold no far fields),
    /// version 3 files (no leak guard either: it is off) and version 2 files (no gradient limit
    /// either) are read as well.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self> {
        let corrupt = |m: String| Err(Error::Corrupt(m));
        if bytes.len() < HEADER_BYTES_V2 + CHECKSUM_BYTES {
            return corrupt(format!(
                "truncated: {} bytes, a cache file has at least {}",
                bytes.len(),
                HEADER_BYTES_V2 + CHECKSUM_BYTES
            ));
        }
        if bytes[..8] != MAGIC {
            return corrupt("bad magic: not a raddiff cache file".into());
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap_or([0; 4]));
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().unwrap_or([0; 8]));
        let version = u32_at(8);
        let header_bytes = match version {
            FORMAT_VERSION => HEADER_BYTES,
            FORMAT_VERSION_8 | FORMAT_VERSION_7 => HEADER_BYTES_V8,
            FORMAT_VERSION_6 => HEADER_BYTES_V6,
            FORMAT_VERSION_5 => HEADER_BYTES_V5,
            FORMAT_VERSION_4 => HEADER_BYTES_V4,
            FORMAT_VERSION_3 => HEADER_BYTES_V3,
            FORMAT_VERSION_2 => HEADER_BYTES_V2,
            _ => {
                return corrupt(format!(
                    "unsupported format version {version} (this library reads versions \
                     {FORMAT_VERSION_2} to {FORMAT_VERSION})"
                ))
            }
        };
        if bytes.len() < header_bytes + CHECKSUM_BYTES {
            return corrupt(format!(
                "truncated: {} bytes, a version {version} cache file has at least {}",
                bytes.len(),
                header_bytes + CHECKSUM_BYTES
            ));
        }
        let channels = u32_at(12) as usize;
        if channels == 0 || channels > MAX_CHANNELS {
            return corrupt(format!("channel count {channels} out of range"));
        }
        if let Some(n) = V::FIXED_CHANNELS {
            if n != channels {
                return corrupt(format!(
                    "the file holds {channels}-channel records, this cache type has {n} channels"
                ));
            }
        }
        let domain = Domain::try_from(u32_at(16)).map_err(|e| Error::Corrupt(e.to_string()))?;
        let interpolation =
            Interpolation::try_from(u32_at(20)).map_err(|e| Error::Corrupt(e.to_string()))?;
        let max_normal_deviation = f64::from_le_bytes(bytes[24..32].try_into().unwrap_or([0; 8]));
        let count = u64_at(32);
        let stride = u32_at(40) as usize;
        if stride != HEAD_BYTES + CHANNEL_BYTES * channels {
            return corrupt(format!(
                "record size {stride} does not match {channels} channels"
            ));
        }
        let flags = u32_at(44);
        let known = match version {
            FORMAT_VERSION_2 => FLAG_NON_NEGATIVE,
            FORMAT_VERSION_3 => FLAG_NON_NEGATIVE | FLAG_GRADIENT_LIMIT,
            FORMAT_VERSION_4 => FLAG_NON_NEGATIVE | FLAG_GRADIENT_LIMIT | FLAG_LEAK_GUARD,
            FORMAT_VERSION_5 => {
                FLAG_NON_NEGATIVE | FLAG_GRADIENT_LIMIT | FLAG_LEAK_GUARD | FLAG_FAR_FIELD
            }
            FORMAT_VERSION_6 | FORMAT_VERSION_7 | FORMAT_VERSION => {
                FLAG_NON_NEGATIVE
                    | FLAG_GRADIENT_LIMIT
                    | FLAG_LEAK_GUARD
                    | FLAG_FAR_FIELD
                    | FLAG_OPEN_FRACTION
            }
            _ => {
                FLAG_NON_NEGATIVE
                    | FLAG_GRADIENT_LIMIT
                    | FLAG_LEAK_GUARD
                    | FLAG_FAR_FIELD
                    | FLAG_OPEN_FRACTION
                    | FLAG_OPEN_FRACTION_KEEPS_COVERAGE
            }
        };
        let f64_at = |o: usize| f64::from_le_bytes(bytes[o..o + 8].try_into().unwrap_or([0; 8]));
        if flags & !known != 0 {
            return corrupt(format!("unknown header flags {flags:#x}"));
        }
        let gradient_limit = if version == FORMAT_VERSION_2 {
            f64::INFINITY
        } else {
            let c = f64::from_le_bytes(bytes[48..56].try_into().unwrap_or([0; 8]));
            if flags & FLAG_GRADIENT_LIMIT != 0 {
                if !(c.is_finite() && c > 0.0) {
                    return corrupt(format!("gradient limit {c} is not finite and positive"));
                }
                c
            } else {
                if c.to_bits() != 0 {
                    return corrupt(format!(
                        "gradient limit field is {c} but the limit flag is not set"
                    ));
                }
                f64::INFINITY
            }
        };
        // fields of versions that have them only: older headers are shorter
        let field_pair = |present: bool, flag: u32, at: usize, what: &str| {
            let values = if present {
                (f64_at(at), f64_at(at + 8))
            } else {
                (0.0, 0.0)
            };
            flagged_pair(present, flags & flag != 0, values, what)
        };
        let leak_guard = match field_pair(
            version >= FORMAT_VERSION_4,
            FLAG_LEAK_GUARD,
            56,
            "leak guard",
        )? {
            Some((relative, absolute)) => {
                let guard = LeakGuard { relative, absolute };
                if guard.validate().is_err() || !guard.is_on() {
                    return corrupt(format!(
                        "leak guard tolerances {relative} and {absolute} are not finite and >= 0"
                    ));
                }
                guard
            }
            None => LeakGuard::OFF,
        };
        let far_field = match field_pair(
            version >= FORMAT_VERSION_5,
            FLAG_FAR_FIELD,
            72,
            "far-field",
        )? {
            Some((world, pixels)) => {
                let reach = FarFieldReach { world, pixels };
                if reach.validate().is_err() || !reach.is_on() {
                    return corrupt(format!(
                        "far-field reaches {world} and {pixels} are not finite and >= 0 with one > 0"
                    ));
                }
                reach
            }
            None => FarFieldReach::OFF,
        };
        let open_fraction_test = if version < FORMAT_VERSION_6 {
            OpenFractionTest::OFF
        } else {
            let tolerance = f64_at(88);
            let keeps_coverage = flags & FLAG_OPEN_FRACTION_KEEPS_COVERAGE != 0;
            let coverage_tolerance = match version {
                FORMAT_VERSION => f64_at(104),
                _ if keeps_coverage => f64::INFINITY,
                _ => 0.0,
            };
            let coverage = OpenFractionTest::OFF.with_coverage_tolerance(coverage_tolerance);
            if coverage.validate().is_err() {
                return corrupt(format!(
                    "open-fraction coverage tolerance {coverage_tolerance} is not >= 0"
                ));
            }
            if flags & FLAG_OPEN_FRACTION != 0 {
                let test = OpenFractionTest {
                    tolerance,
                    ..coverage
                };
                if test.validate().is_err() || !test.is_on() {
                    return corrupt(format!(
                        "open-fraction tolerance {tolerance} is not finite and >= 0"
                    ));
                }
                test
            } else if tolerance.to_bits() != 0 {
                return corrupt(
                    "open-fraction field is set but the open-fraction flag is not".into(),
                );
            } else if keeps_coverage {
                return corrupt(
                    "the keep-coverage flag is set but the open-fraction flag is not".into(),
                );
            } else {
                coverage
            }
        };
        let lookup_radius_scale = if version < FORMAT_VERSION_7 {
            1.0
        } else {
            let scale = f64_at(96);
            if check_scale(scale).is_err() {
                return corrupt(format!(
                    "lookup radius scale {scale} is not in [1, {LOOKUP_RADIUS_SCALE_MAX}]"
                ));
            }
            scale
        };
        let expected = usize::try_from(count)
            .ok()
            .and_then(|c| c.checked_mul(stride))
            .and_then(|b| b.checked_add(header_bytes + CHECKSUM_BYTES));
        match expected {
            Some(e) if e == bytes.len() => {}
            Some(e) if e > bytes.len() => {
                return corrupt(format!(
                    "truncated: {count} records need {e} bytes, the file has {}",
                    bytes.len()
                ))
            }
            _ => {
                return corrupt(format!(
                    "length {} does not match {count} records of {stride} bytes",
                    bytes.len()
                ))
            }
        }
        let body = bytes.len() - CHECKSUM_BYTES;
        if record::fnv1a(FNV_OFFSET, &bytes[..body]) != u64_at(body) {
            return corrupt("checksum mismatch: the file is damaged".into());
        }
        let config = CacheConfig {
            channels,
            domain,
            interpolation,
            max_normal_deviation,
            non_negative: flags & FLAG_NON_NEGATIVE != 0,
            gradient_limit,
            leak_guard,
            far_field,
            open_fraction_test,
            lookup_radius_scale,
        };
        let mut cache = Cache::new(config).map_err(|e| Error::Corrupt(format!("header: {e}")))?;
        let mut previous: Option<(record::Head, record::Channels)> = None;
        for i in 0..count as usize {
            let at = header_bytes + i * stride;
            let (head, chans) = record::deserialize(domain, &bytes[at..at + stride])
                .map_err(|e| Error::Corrupt(format!("record {i}: {e}")))?;
            if version < FORMAT_VERSION_6 && head.open_fraction != 0 {
                return corrupt(format!(
                    "record {i}: reserved field is not 0 (version {version} records have no open \
                     fraction)"
                ));
            }
            if let Some((h, c)) = &previous {
                if record::content_order((h, c), (&head, &chans)).is_ge() {
                    return corrupt(format!(
                        "record {i}: records not in strictly increasing content order"
                    ));
                }
            }
            cache
                .insert_stored(&head, &chans)
                .map_err(|e| Error::Corrupt(format!("record {i}: {e}")))?;
            previous = Some((head, chans));
        }
        cache.compact();
        Ok(cache)
    }

    /// Writes the cache to `path` atomically: a temporary file in the same directory is written,
    /// flushed to disk and renamed over `path`, then the directory is synced. `Io` on failure
    /// (the temporary file is removed; `path` is untouched).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let bytes = self.to_bytes();
        let tmp = temp_path(path)?;
        let result = (|| -> std::io::Result<()> {
            let mut f = File::create(&tmp)?;
            f.write_all(&bytes)?;
            f.sync_all()?;
            drop(f);
            std::fs::rename(&tmp, path)?;
            if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                // Directory fsync makes the rename durable; some platforms cannot open directories.
                if let Ok(d) = File::open(dir) {
                    let _ = d.sync_all();
                }
            }
            Ok(())
        })();
        if let Err(e) = result {
            let _ = std::fs::remove_file(&tmp);
            return Err(Error::Io(format!(
                "saving cache to {}: {e}",
                path.display()
            )));
        }
        Ok(())
    }

    /// Reads and validates a cache file written by [`Cache::save`]. `Io` if it cannot be read,
    /// `Corrupt` (with the reason) if it is not a valid cache for `V`.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let bytes = std::fs::read(path)
            .map_err(|e| Error::Io(format!("reading cache {}: {e}", path.display())))?;
        Self::from_bytes(&bytes).map_err(|e| match e {
            Error::Corrupt(m) => Error::Corrupt(format!("{}: {m}", path.display())),
            other => other,
        })
    }
}

fn temp_path(path: &Path) -> Result<PathBuf> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .ok_or_else(|| Error::Io(format!("{} is not a file path", path.display())))?;
    let mut tmp = name.to_os_string();
    tmp.push(format!(
        ".tmp-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    Ok(path.with_file_name(tmp))
}

/// A header's pair of f64 fields that hold values only when their flag is set: `Some(values)`
/// when the version has the fields (`present`) and the flag is set, `None` when it is clear (the
/// fields must then be 0.0, all bits 0) or the version predates them.
fn flagged_pair(
    present: bool,
    flag: bool,
    values: (f64, f64),
    what: &str,
) -> Result<Option<(f64, f64)>> {
    if !present {
        return Ok(None);
    }
    if flag {
        return Ok(Some(values));
    }
    if values.0.to_bits() != 0 || values.1.to_bits() != 0 {
        return Err(Error::Corrupt(format!(
            "{what} fields are set but the {what} flag is not"
        )));
    }
    Ok(None)
}
