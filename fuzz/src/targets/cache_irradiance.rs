//! Irradiance in one call per shading point: `raddiff_irradiance_cache_new`,
//! `raddiff_cache_irradiance`, `raddiff_cache_irradiance_near_far` and (every other near/far
//! query) `raddiff_cache_irradiance_near_far_parts`, with the renderer's callback answering from
//! the fuzzer's bytes.
//!
//! Input: the settings (each metric or an unknown one, the threshold, 1..=3 channels, small gathers
//! of each hemisphere kind or out of range, the seed policy, radius bounds, anisotropy, curvature
//! floor, gradient limit, leak guard, a near-field reach in L and in pixels or none, the near rays),
//! then up to 8 queries: the point, normal and footprint, which of the two calls, and how the
//! callback answers (hit distances and radiance decoded per ray as the gather target does, rays
//! beyond the maximum distance reported as misses or not, or a failing return).
//! Properties: no panic; each failure leaves a message, `out` untouched and no record inserted
//! (but for the documented overflow of a near/far sum after its record was made);
//! with `RADDIFF_OK` `out` is finite; the callback runs at most once per call, for the gather's or
//! the near rays' count, with a maximum distance that is INFINITY or finite and > 0; a cache made
//! with a near-field reach reads that reach back (`raddiff_cache_get_far_field`) and refuses the
//! plain call, a cache without one refuses the near/far call; the parts, written only on success,
//! are a finite near irradiance and an open fraction in [0, 1] that give `out` with the far field
//! the cache's plain lookup returns after the call.
use std::ffi::{c_int, c_void};

use raddiff::ffi::*;

use super::check::{self, sentinel_f32};
use super::decode::Input;
use super::Outcome;

/// What the callback reads and records: the fuzzer's bytes for its answers, and what it was asked.
struct Callback<'a, 'b> {
    input: &'b mut Input<'a>,
    channels: usize,
    calls: usize,
    count: usize,
    max_distance: f64,
}

/// Decodes the settings, makes the cache and runs the queries.
pub fn run(data: &[u8]) -> Outcome {
    let mut input = Input::new(data);
    let settings = settings(&mut input);
    let cache = raddiff_irradiance_cache_new(&settings);
    if !check::constructed("raddiff_irradiance_cache_new", cache) {
        return Outcome::Refused;
    }
    let near_far = settings.near_field_reach_world > 0.0 || settings.near_field_reach_pixels > 0.0;
    let (mut world, mut pixels) = (-1.0, -1.0);
    assert!(check::status(
        "raddiff_cache_get_far_field",
        raddiff_cache_get_far_field(cache, &mut world, &mut pixels)
    ));
    assert!(
        world == settings.near_field_reach_world && pixels == settings.near_field_reach_pixels,
        "raddiff_cache_get_far_field: ({world}, {pixels}) for settings ({}, {})",
        settings.near_field_reach_world,
        settings.near_field_reach_pixels
    );
    let channels = settings.channels as usize;
    let mut outcome = Outcome::Refused;
    for query in 0..1 + input.below(8) {
        let x = input.vec3();
        let n = input.vec3();
        let footprint = if input.flag() { 0.0 } else { input.f64() };
        let use_near_far = input.flag();
        let mut callback = Callback {
            input: &mut input,
            channels,
            calls: 0,
            count: 0,
            max_distance: 0.0,
        };
        let user = (&mut callback as *mut Callback).cast::<c_void>();
        let mut out = vec![sentinel_f32(); channels];
        let before = raddiff_cache_len(cache);
        let with_parts = use_near_far && query % 2 == 1;
        let mut near = vec![check::sentinel(); channels];
        let mut open = check::sentinel();
        let (name, status) = if with_parts {
            let status = raddiff_cache_irradiance_near_far_parts(
                cache,
                &settings,
                x,
                n,
                footprint,
                Some(trace_bounded),
                user,
                out.as_mut_ptr(),
                near.as_mut_ptr(),
                &mut open,
            );
            ("raddiff_cache_irradiance_near_far_parts", status)
        } else if use_near_far {
            let status = raddiff_cache_irradiance_near_far(
                cache,
                &settings,
                x,
                n,
                footprint,
                Some(trace_bounded),
                user,
                out.as_mut_ptr(),
            );
            ("raddiff_cache_irradiance_near_far", status)
        } else {
            let status = raddiff_cache_irradiance(
                cache,
                &settings,
                x,
                n,
                footprint,
                Some(trace),
                user,
                out.as_mut_ptr(),
            );
            ("raddiff_cache_irradiance", status)
        };
        assert!(
            callback.calls <= 1,
            "{name}: the callback ran {} times",
            callback.calls
        );
        if callback.calls == 1 {
            let gather = settings.gather_m as usize * settings.gather_n as usize;
            let near = settings.near_field_m as usize * settings.near_field_n as usize;
            assert!(
                callback.count == gather || (use_near_far && callback.count == near),
                "{name}: the callback was asked for {} rays",
                callback.count
            );
            let d = callback.max_distance;
            assert!(
                d == f64::INFINITY || (use_near_far && d.is_finite() && d > 0.0),
                "{name}: maximum distance {d}"
            );
        }
        if check::status(name, status) {
            assert!(
                use_near_far == near_far,
                "{name} succeeded on a cache whose far-field reach is ({world}, {pixels})"
            );
            check::finite_f32(name, "out", &out);
            if with_parts {
                parts_give_out(cache, x, n, &out, &near, open);
            }
            outcome = Outcome::Ok;
        } else {
            check::untouched_f32(name, "out", &out);
            if with_parts {
                check::untouched(name, "near_irradiance", &near);
                check::untouched(name, "open_fraction", &[open]);
            }
            // the one documented exception: a near/far sum that overflows only once the new
            // record's far field is blended with others
            let kept = use_near_far && status == raddiff_status::RADDIFF_ERROR_DEGENERATE;
            let after = raddiff_cache_len(cache);
            assert!(
                after == before || (kept && after == before + 1),
                "{name} failed ({status:?}) but inserted {} records",
                after - before
            );
        }
    }
    raddiff_cache_free(cache);
    outcome
}

/// The parts of a successful near/far query: a finite near irradiance and an open fraction in
/// [0, 1] whose `E_near + V·F`, with `F` the cache's plain lookup now, is `out` (up to the rounding
/// of the sum to `f32`).
fn parts_give_out(
    cache: *mut raddiff_cache,
    x: raddiff_vec3,
    n: raddiff_vec3,
    out: &[f32],
    near: &[f64],
    open: f64,
) {
    let name = "raddiff_cache_irradiance_near_far_parts";
    check::finite(name, "near_irradiance", near);
    assert!((0.0..=1.0).contains(&open), "{name}: open fraction {open}");
    let mut far = vec![sentinel_f32(); out.len()];
    assert_eq!(
        raddiff_cache_lookup(cache, x, n, far.as_mut_ptr(), std::ptr::null_mut()),
        raddiff_status::RADDIFF_OK,
        "{name} succeeded but the plain lookup at its point failed"
    );
    for ((&o, &e), &f) in out.iter().zip(near).zip(&far) {
        let sum = e + open * f as f64;
        let scale = e.abs() + open * (f as f64).abs();
        assert!(
            (o as f64 - sum).abs() <= 1e-5 * scale + f64::from(f32::MIN_POSITIVE),
            "{name}: out {o} but E_near + V·F = {e} + {open}·{f} = {sum}"
        );
    }
}

fn settings(input: &mut Input) -> raddiff_irradiance_settings {
    let mut s = raddiff_irradiance_settings_default();
    s.metric = if input.below(16) == 0 {
        input.u32()
    } else {
        input.below(7)
    };
    s.accuracy = if input.flag() {
        input.f64()
    } else {
        [0.1, 0.3, 1e-3, 1e-2][input.below(4) as usize]
    };
    s.channels = 1 + input.below(3);
    s.gather_kind = input.below(3);
    s.gather_m = input.below(9);
    s.gather_n = input.below(13);
    s.seed_policy = input.below(3);
    s.seed_salt = input.u64();
    if input.flag() {
        s.world_radius_min = input.magnitude();
        s.world_radius_max = input.f64();
    }
    if input.flag() {
        s.pixel_radius_min = input.f64();
        s.pixel_radius_max = input.magnitude();
    }
    if input.flag() {
        s.max_anisotropy = input.f64();
        s.curvature_floor = input.f64();
        s.gradient_limit = input.f64();
    }
    if input.flag() {
        s.leak_guard_relative = input.magnitude();
        s.leak_guard_absolute = input.magnitude();
    }
    match input.below(4) {
        0 => {}
        1 => s.near_field_reach_pixels = input.f64(),
        2 => s.near_field_reach_world = input.f64(),
        _ => {
            s.near_field_reach_world = input.magnitude();
            s.near_field_reach_pixels = input.magnitude();
        }
    }
    s.near_field_m = input.below(6);
    s.near_field_n = input.below(6);
    // off, typical, the largest allowed and one too many
    let passes = [0, 1, 2, 64, 65];
    s.derivative_smoothing_azimuthal = passes[input.below(5) as usize];
    s.derivative_smoothing_polar = passes[input.below(5) as usize];
    s
}

/// `raddiff_trace_fn`: the rays as far as they go.
unsafe extern "C" fn trace(
    user: *mut c_void,
    origin: raddiff_vec3,
    directions: *const raddiff_vec3,
    count: usize,
    distance: *mut f64,
    radiance: *mut f32,
) -> c_int {
    trace_bounded(
        user,
        origin,
        directions,
        count,
        f64::INFINITY,
        distance,
        radiance,
    )
}

/// `raddiff_trace_bounded_fn`: every ray's distance and radiance from the fuzzer's bytes; rays at
/// or beyond the maximum distance may be reported as misses with their radiance left; one byte
/// may make the call fail.
unsafe extern "C" fn trace_bounded(
    user: *mut c_void,
    _origin: raddiff_vec3,
    _directions: *const raddiff_vec3,
    count: usize,
    max_distance: f64,
    distance: *mut f64,
    radiance: *mut f32,
) -> c_int {
    // SAFETY: `user` is the `Callback` of the call in `run`, alive and not otherwise borrowed
    // during it; the arrays hold `count` and `count * channels` values (the callback's contract).
    let callback = unsafe { &mut *user.cast::<Callback>() };
    callback.calls += 1;
    callback.count = count;
    callback.max_distance = max_distance;
    if callback.input.below(32) == 0 {
        return 1;
    }
    let channels = callback.channels;
    let distance = unsafe { std::slice::from_raw_parts_mut(distance, count) };
    let radiance = unsafe { std::slice::from_raw_parts_mut(radiance, count * channels) };
    let cut = callback.input.flag();
    for (d, l) in distance.iter_mut().zip(radiance.chunks_exact_mut(channels)) {
        *d = super::gather_evaluate::distance(callback.input);
        if cut && *d >= max_distance {
            *d = f64::INFINITY;
            continue;
        }
        for v in l {
            *v = super::gather_evaluate::radiance(callback.input);
        }
    }
    0
}
