//! Writes the seed corpora into `fuzz/corpus/<target>/` (run from `fuzz/`:
//! `cargo run --release --bin seeds`). For every target but `cache_load`: pseudo-random byte
//! strings (fixed seed), the first few that the target accepts and the first few it refuses. For
//! `cache_load`: real caches saved by `raddiff_cache_save` (format version 9) and their version
//! 8, 7, 6, 5, 4, 3 and 2 forms, each behind the option byte 0, and two refused files (truncated, damaged).
use std::ffi::CString;
use std::path::Path;

use raddiff::ffi::*;
use raddiff_fuzz::targets::{self, cache_load::fnv1a, Outcome};

fn main() {
    let root = Path::new("corpus");
    for name in targets::NAMES.iter().filter(|n| **n != "cache_load") {
        let run = targets::by_name(name).expect("a target");
        let dir = root.join(name);
        std::fs::create_dir_all(&dir).expect("corpus directory");
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let (mut ok, mut refused) = (0, 0);
        for attempt in 0..20_000 {
            let len = 16 << (attempt % 6);
            let data: Vec<u8> = (0..len).map(|_| lcg(&mut state)).collect();
            let wanted = match run(&data) {
                Outcome::Ok if ok < 6 => {
                    ok += 1;
                    true
                }
                Outcome::Refused if refused < 2 => {
                    refused += 1;
                    true
                }
                _ => false,
            };
            if wanted {
                std::fs::write(dir.join(format!("seed-{:02}", ok + refused)), &data)
                    .expect("writing a seed");
            }
            if ok == 6 && refused == 2 {
                break;
            }
        }
        println!("{name}: {ok} accepted and {refused} refused seeds");
    }
    let dir = root.join("cache_load");
    std::fs::create_dir_all(&dir).expect("corpus directory");
    let caches = saved_caches();
    // Two refused files: truncated, and a record byte changed under the old checksum.
    let first = &caches[0];
    let mut truncated = vec![0u8];
    truncated.extend(&first[..first.len() - 9]);
    std::fs::write(dir.join("truncated"), truncated).expect("writing");
    let mut damaged = vec![0u8];
    damaged.extend(first);
    damaged[1 + 60] ^= 0x40;
    std::fs::write(dir.join("damaged"), damaged).expect("writing");
    for (i, v9) in caches.iter().enumerate() {
        let v8 = &as_version_8(v9);
        let v7 = &as_version_7(v8);
        let v6 = &as_version_6(v7);
        let v5 = as_version_5(v6);
        let v4 = as_version_4(&v5);
        let v3 = as_version_3(&v4);
        let v2 = as_version_2(&v3);
        // the older forms a cache has (no version 8 with a finite coverage tolerance, no version 7
        // keeping coverage, no version 6 with a lookup
        // radius scale, no version 5 with an open-fraction test, no version 4 with a far field,
        // no version 3 with a leak guard, no version 2 with a gradient limit)
        for (version, file) in [
            (9, v9),
            (8, v8),
            (7, v7),
            (6, v6),
            (5, &v5),
            (4, &v4),
            (3, &v3),
            (2, &v2),
        ] {
            if u32::from_le_bytes(file[8..12].try_into().expect("4 bytes")) != version {
                continue;
            }
            let mut data = vec![0u8];
            data.extend(file);
            std::fs::write(dir.join(format!("cache-{i}-v{version}")), data).expect("writing");
        }
    }
}

fn lcg(state: &mut u64) -> u8 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 56) as u8
}

/// Small caches of each kind, saved through the C API.
fn saved_caches() -> Vec<Vec<u8>> {
    let kinds = [
        (1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD),
        (
            3,
            RADDIFF_DOMAIN_SURFACE,
            RADDIFF_INTERP_CUBIC | RADDIFF_INTERP_NON_NEGATIVE | RADDIFF_INTERP_GRADIENT_LIMIT,
        ),
        (3, RADDIFF_DOMAIN_VOLUME, RADDIFF_INTERP_TENT),
        (
            2,
            RADDIFF_DOMAIN_VOLUME,
            RADDIFF_INTERP_LOG | RADDIFF_INTERP_NON_NEGATIVE,
        ),
        // with a leak guard (below)
        (1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT),
        // irradiance far fields (below: the interpolation is the settings' metric's)
        (3, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT),
        // far fields with the open-fraction test, records with open fractions
        (3, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT),
        // read over 1.5 times the radii (below)
        (1, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_WARD),
        // the open-fraction test keeping coverage (below)
        (3, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT),
        // the open-fraction test keeping the coverage within 0.3 (below)
        (3, RADDIFF_DOMAIN_SURFACE, RADDIFF_INTERP_TENT),
    ];
    kinds
        .iter()
        .enumerate()
        .map(|(kind, &(channels, domain, interpolation))| {
            let config = raddiff_cache_config {
                channels,
                domain,
                interpolation,
                max_normal_deviation: 0.3,
            };
            let tested = kind == 6 || kind >= 8;
            let cache = if (5..=6).contains(&kind) || kind >= 8 {
                let mut settings = raddiff_irradiance_settings_default();
                settings.channels = channels;
                settings.near_field_reach_pixels = 8.0;
                if tested {
                    settings.near_field_open_fraction_tolerance = 0.15;
                }
                raddiff_irradiance_cache_new(&settings)
            } else {
                raddiff_cache_new(&config)
            };
            assert!(!cache.is_null());
            if kind == 4 {
                assert_eq!(
                    raddiff_cache_set_leak_guard(cache, 0.1, 0.001),
                    raddiff_status::RADDIFF_OK
                );
            }
            if kind == 8 {
                assert_eq!(
                    raddiff_cache_set_open_fraction_keeps_coverage(cache, 1),
                    raddiff_status::RADDIFF_OK
                );
            }
            if kind == 9 {
                assert_eq!(
                    raddiff_cache_set_open_fraction_coverage_tolerance(cache, 0.3),
                    raddiff_status::RADDIFF_OK
                );
            }
            if kind == 7 {
                assert_eq!(
                    raddiff_cache_set_lookup_radius_scale(cache, 1.5),
                    raddiff_status::RADDIFF_OK
                );
            }
            for i in 0..5 {
                let t = i as f64;
                let open = 0.2 * t;
                let value: Vec<f32> = (0..channels).map(|c| 1.0 + t as f32 + c as f32).collect();
                let gradient: Vec<f32> = (0..3 * channels)
                    .map(|k| 0.1 * k as f32 - t as f32)
                    .collect();
                let record = raddiff_cache_record {
                    position: raddiff_vec3 {
                        x: 0.3 * t,
                        y: 0.1 * t * t,
                        z: 0.0,
                    },
                    normal: raddiff_vec3 {
                        x: 0.0,
                        y: 0.0,
                        z: 1.0,
                    },
                    value: value.as_ptr(),
                    gradient: if i % 2 == 0 {
                        gradient.as_ptr()
                    } else {
                        std::ptr::null()
                    },
                    rotation_gradient: if i == 3 {
                        gradient.as_ptr()
                    } else {
                        std::ptr::null()
                    },
                    radii: [0.5, 0.5 + 0.2 * t, 0.6],
                    axes: [
                        raddiff_vec3 {
                            x: 1.0,
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
                            y: 0.0,
                            z: 1.0,
                        },
                    ],
                    open_fraction: if tested { &open } else { std::ptr::null() },
                };
                assert_eq!(
                    raddiff_cache_insert(cache, &record),
                    raddiff_status::RADDIFF_OK
                );
            }
            let path =
                std::env::temp_dir().join(format!("raddiff-seed-{}.cache", std::process::id()));
            let c_path = CString::new(path.to_string_lossy().as_bytes()).expect("path");
            assert_eq!(
                raddiff_cache_save(cache, c_path.as_ptr()),
                raddiff_status::RADDIFF_OK
            );
            raddiff_cache_free(cache);
            let bytes = std::fs::read(&path).expect("reading the saved cache");
            let _ = std::fs::remove_file(&path);
            bytes
        })
        .collect()
}

/// The version 8 form of a version 9 file: no coverage tolerance (bytes 104..112), flag bit 5
/// set for an infinite one, resealed. Only for caches whose coverage tolerance is 0 or infinite
/// (version 8 cannot hold another): others are returned as is.
fn as_version_8(v9: &[u8]) -> Vec<u8> {
    let coverage = f64::from_le_bytes(v9[104..112].try_into().expect("8 bytes"));
    if coverage != 0.0 && coverage != f64::INFINITY {
        return v9.to_vec();
    }
    let mut v8 = v9[..104].to_vec();
    v8[8..12].copy_from_slice(&8u32.to_le_bytes());
    if coverage == f64::INFINITY {
        v8[44] |= 32;
    }
    v8.extend_from_slice(&v9[112..v9.len() - 8]);
    let sum = fnv1a(&v8);
    v8.extend_from_slice(&sum.to_le_bytes());
    v8
}

/// The version 7 form of a version 8 file: the same bytes with version 7, resealed. Only for
/// caches whose open-fraction test does not keep coverage (version 7 cannot hold it) and version 8
/// files: others are returned as is.
fn as_version_7(v8: &[u8]) -> Vec<u8> {
    let version = u32::from_le_bytes(v8[8..12].try_into().expect("4 bytes"));
    let flags = u32::from_le_bytes(v8[44..48].try_into().expect("4 bytes"));
    if flags & 32 != 0 || version != 8 {
        return v8.to_vec();
    }
    let mut v7 = v8[..v8.len() - 8].to_vec();
    v7[8..12].copy_from_slice(&7u32.to_le_bytes());
    let sum = fnv1a(&v7);
    v7.extend_from_slice(&sum.to_le_bytes());
    v7
}

/// The version 6 form of a version 7 file: no lookup radius scale (bytes 96..104), resealed.
/// Only for caches read over their own radii (scale 1; version 6 cannot hold another): others
/// are returned as is.
fn as_version_6(v7: &[u8]) -> Vec<u8> {
    let version = u32::from_le_bytes(v7[8..12].try_into().expect("4 bytes"));
    if f64::from_le_bytes(v7[96..104].try_into().expect("8 bytes")) != 1.0 || version != 7 {
        return v7.to_vec();
    }
    let mut v6 = v7[..96].to_vec();
    v6[8..12].copy_from_slice(&6u32.to_le_bytes());
    v6.extend_from_slice(&v7[104..v7.len() - 8]);
    let sum = fnv1a(&v6);
    v6.extend_from_slice(&sum.to_le_bytes());
    v6
}

/// The version 5 form of a version 6 file: no open-fraction field (bytes 88..96), resealed. Only
/// for caches without an open-fraction test (the seeds' only records with open fractions are in
/// such a cache): others are returned as is.
fn as_version_5(v6: &[u8]) -> Vec<u8> {
    let flags = u32::from_le_bytes(v6[44..48].try_into().expect("4 bytes"));
    let version = u32::from_le_bytes(v6[8..12].try_into().expect("4 bytes"));
    if flags & 16 != 0 || version != 6 {
        return v6.to_vec();
    }
    let mut v5 = v6[..88].to_vec();
    v5[8..12].copy_from_slice(&5u32.to_le_bytes());
    v5.extend_from_slice(&v6[96..v6.len() - 8]);
    let sum = fnv1a(&v5);
    v5.extend_from_slice(&sum.to_le_bytes());
    v5
}

/// The version 4 form of a version 5 file: no far-field fields (bytes 72..88), resealed. Only for
/// caches without a far field (version 4 cannot hold one): others are returned as is.
fn as_version_4(v5: &[u8]) -> Vec<u8> {
    let flags = u32::from_le_bytes(v5[44..48].try_into().expect("4 bytes"));
    let version = u32::from_le_bytes(v5[8..12].try_into().expect("4 bytes"));
    if flags & 8 != 0 || version != 5 {
        return v5.to_vec();
    }
    let mut v4 = v5[..72].to_vec();
    v4[8..12].copy_from_slice(&4u32.to_le_bytes());
    v4.extend_from_slice(&v5[88..v5.len() - 8]);
    let sum = fnv1a(&v4);
    v4.extend_from_slice(&sum.to_le_bytes());
    v4
}

/// The version 3 form of a version 4 file: no leak-guard fields (bytes 56..72), resealed. Only for
/// caches without a leak guard (version 3 cannot hold one): others are returned as is.
fn as_version_3(v4: &[u8]) -> Vec<u8> {
    let flags = u32::from_le_bytes(v4[44..48].try_into().expect("4 bytes"));
    let version = u32::from_le_bytes(v4[8..12].try_into().expect("4 bytes"));
    if flags & 4 != 0 || version != 4 {
        return v4.to_vec();
    }
    let mut v3 = v4[..56].to_vec();
    v3[8..12].copy_from_slice(&3u32.to_le_bytes());
    v3.extend_from_slice(&v4[72..v4.len() - 8]);
    let sum = fnv1a(&v3);
    v3.extend_from_slice(&sum.to_le_bytes());
    v3
}

/// The version 2 form of a version 3 file: no gradient-limit field (bytes 48..56), resealed. Only
/// for caches without a gradient limit (version 2 cannot hold one): others are returned as is.
fn as_version_2(v3: &[u8]) -> Vec<u8> {
    let flags = u32::from_le_bytes(v3[44..48].try_into().expect("4 bytes"));
    let version = u32::from_le_bytes(v3[8..12].try_into().expect("4 bytes"));
    if flags & 2 != 0 || version != 3 {
        return v3.to_vec();
    }
    let mut v2 = v3[..48].to_vec();
    v2[8..12].copy_from_slice(&2u32.to_le_bytes());
    v2.extend_from_slice(&v3[56..v3.len() - 8]);
    let sum = fnv1a(&v2);
    v2.extend_from_slice(&sum.to_le_bytes());
    v2
}
