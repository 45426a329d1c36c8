//! The radiance cache through a sequence of calls: `raddiff_cache_new`, `_insert`, `_lookup`,
//! `_lookup_with`, `_clamp_record`, `_clamp_neighbours`, `_set_gradient_limit`,
//! `_get_gradient_limit`, `_compact`, `_merge`, a `_save` / `_load` round trip, and the
//! open-fraction test (`_set_open_fraction_tolerance`, records with an open fraction,
//! `_lookup_open`), and the lookup radius scale (`_set_lookup_radius_scale`: the other
//! operations then run on a cache read over scaled radii).
//!
//! Input: the configuration (1..=3 channels, sometimes 33..=40 or any u32; each domain,
//! interpolation and flag; the normal deviation), then up to 64 operations. Records are decoded
//! near stored ones half of the time, so lookups and clamping meet overlapping records.
//! Properties: no panic; every failure leaves a message and its outputs untouched (lookup values
//! and weight, clamped radii), and a refused insert stores nothing; a lookup that succeeds gives
//! finite values and a finite positive weight, the same bits through a cursor (with an open
//! fraction too, and with the test off the plain lookup's bits); an open fraction, tolerance or
//! lookup radius scale out of range is refused and changes nothing; clamping only
//! shrinks radii (but raises those below what an insert accepts); a saved cache loads back with
//! the same records and the same lookups.
use std::ffi::CString;

use raddiff::ffi::*;

use super::check::{self, sentinel, sentinel_f32};
use super::decode::{add_scaled, normalized, perpendicular, Input};
use super::Outcome;

/// Decodes and runs one sequence of cache calls.
pub fn run(data: &[u8]) -> Outcome {
    let mut input = Input::new(data);
    let config = config(&mut input);
    let cache = raddiff_cache_new(&config);
    if !check::constructed("raddiff_cache_new", cache) {
        return Outcome::Refused;
    }
    let mut state = State {
        cache,
        channels: config.channels as usize,
        volume: config.domain == RADDIFF_DOMAIN_VOLUME,
        stored: Vec::new(),
        any_ok: false,
    };
    for _ in 0..64 {
        if input.is_empty() {
            break;
        }
        state.step(&mut input);
    }
    raddiff_cache_free(cache);
    if state.any_ok {
        Outcome::Ok
    } else {
        Outcome::Refused
    }
}

fn config(input: &mut Input) -> raddiff_cache_config {
    let channels = match input.byte() {
        0..=247 => 1 + input.below(3),
        248..=251 => 33 + input.below(8),
        _ => input.u32(),
    };
    let domain = if input.byte() < 248 {
        input.below(2)
    } else {
        input.u32()
    };
    let interpolation = if input.byte() < 248 {
        input.below(6) | (input.below(4) << 8)
    } else {
        input.u32()
    };
    let max_normal_deviation = if input.byte() < 224 {
        input.unit() * std::f64::consts::PI
    } else {
        input.f64()
    };
    raddiff_cache_config {
        channels,
        domain,
        interpolation,
        max_normal_deviation,
    }
}

/// A decoded record and the arrays its pointers refer to.
struct Record {
    value: Vec<f32>,
    gradient: Option<Vec<f32>>,
    rotation: Option<Vec<f32>>,
    c: raddiff_cache_record,
}

struct State {
    cache: *mut raddiff_cache,
    channels: usize,
    volume: bool,
    /// Positions and normals of the records inserted so far.
    stored: Vec<(raddiff_vec3, raddiff_vec3)>,
    any_ok: bool,
}

impl State {
    fn step(&mut self, input: &mut Input) {
        match input.below(12) {
            0..=3 => self.insert(input),
            4 | 5 => self.lookup(input),
            6 => self.clamp_record(input),
            7 => self.gradient_limit(input),
            8 => self.clamp_neighbours(),
            9 => {
                let ok = check::status("raddiff_cache_compact", raddiff_cache_compact(self.cache));
                self.any_ok |= ok;
            }
            10 => self.merge_self(),
            _ => match input.below(5) {
                0 => self.round_trip(input),
                1 => self.open_fraction_tolerance(input),
                2 => self.insert_open(input),
                3 => self.lookup_radius_scale(input),
                _ => self.lookup_open(input),
            },
        }
    }

    fn len(&self) -> usize {
        raddiff_cache_len(self.cache)
    }

    /// A point near a stored record (half of the time) or anywhere.
    fn position(&self, input: &mut Input) -> (raddiff_vec3, raddiff_vec3) {
        if !self.stored.is_empty() && input.flag() {
            let (p, n) = self.stored[input.below(self.stored.len() as u32) as usize];
            let scale = 10f64.powi(input.below(8) as i32 - 6);
            (add_scaled(p, scale, input.unit3()), n)
        } else {
            (input.vec3(), input.unit3())
        }
    }

    fn record(&self, input: &mut Input) -> Record {
        let (position, near_normal) = self.position(input);
        let normal = match input.below(8) {
            0 => input.vec3(),
            1 => input.unit3(),
            _ => near_normal,
        };
        let ch = self.channels;
        let value: Vec<f32> = (0..ch).map(|_| value(input)).collect();
        let gradient = input
            .flag()
            .then(|| (0..3 * ch).map(|_| input.f32()).collect::<Vec<f32>>());
        let rotation = input
            .flag()
            .then(|| (0..3 * ch).map(|_| input.f32()).collect::<Vec<f32>>());
        let radii = std::array::from_fn(|_| {
            if input.byte() < 32 {
                input.f64()
            } else {
                0.01 + input.magnitude().min(1e3)
            }
        });
        let axes = if input.byte() < 32 {
            std::array::from_fn(|_| input.vec3())
        } else {
            let a = perpendicular(normalized(normal), input.f64());
            let b = super::decode::cross(normalized(normal), a);
            [a, b, normalized(normal)]
        };
        let mut r = Record {
            value,
            gradient,
            rotation,
            c: raddiff_cache_record {
                position,
                normal,
                value: std::ptr::null(),
                gradient: std::ptr::null(),
                rotation_gradient: std::ptr::null(),
                radii,
                axes,
                open_fraction: std::ptr::null(),
            },
        };
        r.c.value = r.value.as_ptr();
        r.c.gradient = r.gradient.as_ref().map_or(std::ptr::null(), |g| g.as_ptr());
        r.c.rotation_gradient = r.rotation.as_ref().map_or(std::ptr::null(), |g| g.as_ptr());
        r
    }

    fn insert(&mut self, input: &mut Input) {
        let record = self.record(input);
        self.insert_record(&record);
    }

    /// A record with an open fraction (sometimes out of [0, 1]: refused).
    fn insert_open(&mut self, input: &mut Input) {
        let mut record = self.record(input);
        let open = open_fraction(input);
        record.c.open_fraction = &open;
        let refused = !(0.0..=1.0).contains(&open);
        let before = self.len();
        self.insert_record(&record);
        if refused {
            assert_eq!(self.len(), before, "an open fraction of {open} was stored");
        }
    }

    /// Sets a tolerance (sometimes invalid: refused, the old one kept) and reads it back.
    fn open_fraction_tolerance(&mut self, input: &mut Input) {
        let tolerance = if input.byte() < 32 {
            input.f64()
        } else {
            input.unit() * 0.5
        };
        let mut before = sentinel();
        let name = "raddiff_cache_get_open_fraction_tolerance";
        assert!(check::status(
            name,
            raddiff_cache_get_open_fraction_tolerance(self.cache, &mut before)
        ));
        let ok = check::status(
            "raddiff_cache_set_open_fraction_tolerance",
            raddiff_cache_set_open_fraction_tolerance(self.cache, tolerance),
        );
        assert_eq!(ok, tolerance >= 0.0, "tolerance {tolerance}");
        let mut after = sentinel();
        assert!(check::status(
            name,
            raddiff_cache_get_open_fraction_tolerance(self.cache, &mut after)
        ));
        let want = if ok { tolerance } else { before };
        assert_eq!(after.to_bits(), want.to_bits(), "tolerance read back");
        self.any_ok |= ok;
    }

    /// Sets a lookup radius scale (sometimes out of [1, 8]: refused, the old one kept) and reads
    /// it back.
    fn lookup_radius_scale(&mut self, input: &mut Input) {
        let scale = if input.byte() < 32 {
            input.f64()
        } else {
            1.0 + input.unit() * 3.0
        };
        let name = "raddiff_cache_get_lookup_radius_scale";
        let mut before = sentinel();
        assert!(check::status(
            name,
            raddiff_cache_get_lookup_radius_scale(self.cache, &mut before)
        ));
        let ok = check::status(
            "raddiff_cache_set_lookup_radius_scale",
            raddiff_cache_set_lookup_radius_scale(self.cache, scale),
        );
        assert_eq!(
            ok,
            (1.0..=RADDIFF_LOOKUP_RADIUS_SCALE_MAX).contains(&scale),
            "scale {scale}"
        );
        let mut after = sentinel();
        assert!(check::status(
            name,
            raddiff_cache_get_lookup_radius_scale(self.cache, &mut after)
        ));
        let want = if ok { scale } else { before };
        assert_eq!(after.to_bits(), want.to_bits(), "scale read back");
        self.any_ok |= ok;
    }

    /// Looks up one point with an open fraction, with and without a cursor (the same bits); with
    /// the test off, the plain lookup's bits; an open fraction out of [0, 1] is refused.
    fn lookup_open(&mut self, input: &mut Input) {
        let (position, normal) = self.position(input);
        let open = open_fraction(input);
        let plain = lookup_open(self.cache, None, position, normal, open, self.channels);
        let cursor = raddiff_cache_cursor_new();
        assert!(check::constructed("raddiff_cache_cursor_new", cursor));
        let with = lookup_open(
            self.cache,
            Some(cursor),
            position,
            normal,
            open,
            self.channels,
        );
        raddiff_cache_cursor_free(cursor);
        assert_eq!(
            plain, with,
            "raddiff_cache_lookup_open with and without a cursor"
        );
        if !(0.0..=1.0).contains(&open) {
            assert!(!plain.0, "an open fraction of {open} was accepted");
            return;
        }
        let mut tolerance = 0.0;
        raddiff_cache_get_open_fraction_tolerance(self.cache, &mut tolerance);
        if tolerance.is_infinite() {
            let untested = lookup(self.cache, None, position, normal, self.channels);
            assert_eq!(plain, untested, "with the test off, lookup_open is lookup");
        }
        self.any_ok |= plain.0;
    }

    /// Inserts a decoded record and checks the count.
    fn insert_record(&mut self, record: &Record) {
        let before = self.len();
        let ok = check::status(
            "raddiff_cache_insert",
            raddiff_cache_insert(self.cache, &record.c),
        );
        let after = self.len();
        if ok {
            assert!(
                after == before || after == before + 1,
                "raddiff_cache_insert: {before} records became {after}"
            );
            self.stored.push((record.c.position, record.c.normal));
            self.any_ok = true;
        } else {
            assert_eq!(
                after, before,
                "raddiff_cache_insert failed but stored a record"
            );
        }
    }

    /// Looks up one point plainly and through a fresh cursor; both must agree bit for bit.
    fn lookup(&mut self, input: &mut Input) {
        let (position, normal) = self.position(input);
        let normal = if input.byte() < 32 {
            input.vec3()
        } else {
            normal
        };
        let plain = lookup(self.cache, None, position, normal, self.channels);
        let cursor = raddiff_cache_cursor_new();
        assert!(check::constructed("raddiff_cache_cursor_new", cursor));
        let with = lookup(self.cache, Some(cursor), position, normal, self.channels);
        raddiff_cache_cursor_free(cursor);
        assert_eq!(
            plain, with,
            "raddiff_cache_lookup and raddiff_cache_lookup_with disagree at {position:?}"
        );
        self.any_ok |= plain.0;
    }

    fn clamp_record(&mut self, input: &mut Input) {
        let mut record = self.record(input);
        let before = record.c.radii;
        let name = "raddiff_cache_clamp_record";
        let ok = check::status(name, raddiff_cache_clamp_record(self.cache, &mut record.c));
        let after = record.c.radii;
        if ok {
            // The surface domain ignores radii[2]. Radii below what an insert accepts
            // (1e-30 and |position| 2^-40) are raised to it: documented, not a growth.
            let used = if self.volume { 3 } else { 2 };
            let p = record.c.position;
            let norm = p.x.abs().max(p.y.abs()).max(p.z.abs()) * 3f64.sqrt();
            let floor = 1e-30f64.max(norm * 2f64.powi(-40)) * (1.0 + 1e-6);
            for (b, a) in before[..used].iter().zip(&after[..used]) {
                assert!(
                    a.is_finite() && (*a <= b.max(floor) || a.to_bits() == b.to_bits()),
                    "{name}: radius {b} became {a}"
                );
            }
            self.any_ok = true;
        } else {
            assert_eq!(
                before.map(f64::to_bits),
                after.map(f64::to_bits),
                "{name}: failed but changed the radii"
            );
        }
    }

    fn gradient_limit(&mut self, input: &mut Input) {
        let c = match input.below(4) {
            0 => f64::INFINITY,
            1 => input.f64(),
            _ => input.magnitude(),
        };
        let mut previous = sentinel();
        let get = "raddiff_cache_get_gradient_limit";
        assert!(check::status(
            get,
            raddiff_cache_get_gradient_limit(self.cache, &mut previous)
        ));
        let ok = check::status(
            "raddiff_cache_set_gradient_limit",
            raddiff_cache_set_gradient_limit(self.cache, c),
        );
        let mut now = sentinel();
        assert!(check::status(
            get,
            raddiff_cache_get_gradient_limit(self.cache, &mut now)
        ));
        let expected = if ok { c } else { previous };
        assert_eq!(
            now, expected,
            "gradient limit {now} after setting {c} (ok: {ok})"
        );
        self.any_ok |= ok;
    }

    fn clamp_neighbours(&mut self) {
        let before = self.len();
        let mut shrunk = usize::MAX;
        let ok = check::status(
            "raddiff_cache_clamp_neighbours",
            raddiff_cache_clamp_neighbours(self.cache, &mut shrunk),
        );
        assert!(ok, "raddiff_cache_clamp_neighbours refused a valid cache");
        assert!(
            shrunk <= before && self.len() <= before,
            "clamp_neighbours: {shrunk} shrunk, {before} -> {} records",
            self.len()
        );
    }

    fn merge_self(&mut self) {
        let before = self.len();
        let ok = check::status(
            "raddiff_cache_merge",
            raddiff_cache_merge(self.cache, self.cache),
        );
        assert!(ok, "raddiff_cache_merge of a cache into itself was refused");
        assert_eq!(
            self.len(),
            before,
            "merging a cache into itself added records"
        );
    }

    /// Saves, loads back, and compares the two caches' sizes and one lookup.
    fn round_trip(&mut self, input: &mut Input) {
        let path = super::scratch::scratch_path("ops");
        let c_path = CString::new(path.to_string_lossy().as_bytes()).expect("no NUL in path");
        let ok = check::status(
            "raddiff_cache_save",
            raddiff_cache_save(self.cache, c_path.as_ptr()),
        );
        assert!(ok, "raddiff_cache_save failed on a scratch path");
        let loaded = raddiff_cache_load(c_path.as_ptr());
        let _ = std::fs::remove_file(&path);
        assert!(
            check::constructed("raddiff_cache_load", loaded),
            "a saved cache did not load back: {}",
            check::last_error()
        );
        assert_eq!(
            raddiff_cache_len(loaded),
            self.len(),
            "saved and loaded sizes differ"
        );
        let (position, normal) = self.position(input);
        let here = lookup(self.cache, None, position, normal, self.channels);
        let there = lookup(loaded, None, position, normal, self.channels);
        raddiff_cache_free(loaded);
        assert_eq!(
            here, there,
            "saved and loaded caches disagree at {position:?}"
        );
    }
}

fn value(input: &mut Input) -> f32 {
    if input.byte() < 32 {
        input.f32()
    } else {
        input.byte() as f32 / 16.0
    }
}

/// One lookup with the property checks: (succeeded, value bits, weight bits).
pub fn lookup(
    cache: *const raddiff_cache,
    cursor: Option<*mut raddiff_cache_cursor>,
    position: raddiff_vec3,
    normal: raddiff_vec3,
    channels: usize,
) -> (bool, Vec<u32>, u64) {
    checked_lookup(channels, |value, weight| match cursor {
        None => (
            "raddiff_cache_lookup",
            raddiff_cache_lookup(cache, position, normal, value, weight),
        ),
        Some(c) => (
            "raddiff_cache_lookup_with",
            raddiff_cache_lookup_with(cache, c, position, normal, value, weight),
        ),
    })
}

/// [`lookup`] with the query's open fraction (`raddiff_cache_lookup_open`).
pub fn lookup_open(
    cache: *const raddiff_cache,
    cursor: Option<*mut raddiff_cache_cursor>,
    position: raddiff_vec3,
    normal: raddiff_vec3,
    open: f64,
    channels: usize,
) -> (bool, Vec<u32>, u64) {
    let cursor = cursor.unwrap_or(std::ptr::null_mut());
    checked_lookup(channels, |value, weight| {
        (
            "raddiff_cache_lookup_open",
            raddiff_cache_lookup_open(cache, cursor, position, normal, open, value, weight),
        )
    })
}

/// An open fraction: in [0, 1] mostly, anything sometimes.
fn open_fraction(input: &mut Input) -> f64 {
    if input.byte() < 32 {
        input.f64()
    } else {
        input.unit()
    }
}

/// Runs one lookup call (`call(value, weight_sum)` returns its name and status) with the
/// property checks.
fn checked_lookup(
    channels: usize,
    call: impl FnOnce(*mut f32, *mut f64) -> (&'static str, raddiff_status),
) -> (bool, Vec<u32>, u64) {
    let mut value = vec![sentinel_f32(); channels];
    let mut weight = sentinel();
    let (name, status) = call(value.as_mut_ptr(), &mut weight);
    let ok = check::status(name, status);
    if ok {
        check::finite_f32(name, "value", &value);
        assert!(
            weight.is_finite() && weight > 0.0,
            "{name}: RADDIFF_OK with weight sum {weight}"
        );
    } else {
        check::untouched_f32(name, "value", &value);
        check::untouched(name, "weight_sum", &[weight]);
    }
    (
        ok,
        value.iter().map(|v| v.to_bits()).collect(),
        weight.to_bits(),
    )
}
