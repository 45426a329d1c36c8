//! Gathers: `raddiff_gather_directions`, `raddiff_gather_evaluate`, and the near/far split of the
//! same rays (`raddiff_gather_near_field`, `raddiff_gather_far_field_radiance`,
//! `raddiff_gather_far_field`).
//!
//! Input: the layout (each kind, m and n in 1..=16 or out of range, a seed), the frame (unit normal
//! and tangent built from decoded angles, or raw vectors), how the directions are made (the
//! layout's own, or with two swapped, one replaced, one nudged; raw when the layout is refused), the
//! hit distances (misses, tiny, wide, zero or negative ones), radiance (1..=3 channels), the
//! extinction, the optional media march (steps, step length, in-scattered radiance and its
//! gradient) and which outputs are wanted.
//! Properties: no panic; `raddiff_gather_directions` writes finite unit vectors or nothing; with
//! `RADDIFF_OK` every wanted output is finite, `harmonic_mean_distance` and `min_distance` too
//! unless every ray missed (then both are `INFINITY`); on failure nothing is written (arrays and
//! the two distances keep their sentinels) and a message is set. The near/far split at a decoded
//! reach (any f64): both calls accept or refuse together; on success the open fractions agree and
//! lie in [0, 1], the near irradiance and the far-field radiance are finite and open directions keep
//! their radiance; on failure nothing is written.
use raddiff::ffi::*;

use super::check::{self, sentinel, sentinel3};
use super::decode::{add_scaled, finite3, normalized, perpendicular, Input};
use super::Outcome;

/// Decodes and runs one gather.
pub fn run(data: &[u8]) -> Outcome {
    let mut input = Input::new(data);
    let layout = layout(&mut input);
    let frame = frame(&mut input);
    let directions = directions(&mut input, &layout, &frame);
    let cells = directions.len();
    let channels = 1 + input.below(3) as usize;
    let distance: Vec<f64> = (0..cells).map(|_| distance(&mut input)).collect();
    let radiance: Vec<f32> = (0..cells * channels)
        .map(|_| radiance(&mut input))
        .collect();
    let sigma_t = match input.below(4) {
        0 | 1 => 0.0,
        2 => input.f64(),
        _ => input.magnitude(),
    };
    let media = input
        .flag()
        .then(|| Media::decode(&mut input, cells, channels));
    let wanted: [bool; 5] = std::array::from_fn(|_| input.byte() < 200);

    let mut outputs: [Vec<f64>; 5] =
        [1, 3, 3, 3, 9].map(|per_channel| vec![sentinel(); per_channel * channels]);
    let pointer = |v: &mut Vec<f64>, want: bool| {
        if want {
            v.as_mut_ptr()
        } else {
            std::ptr::null_mut()
        }
    };
    let [irradiance, gradient, rotation, occlusion, hessian] = &mut outputs;
    let mut output = raddiff_gather_output {
        irradiance: pointer(irradiance, wanted[0]),
        gradient: pointer(gradient, wanted[1]),
        rotation_gradient: pointer(rotation, wanted[2]),
        occlusion_gradient: pointer(occlusion, wanted[3]),
        hessian: pointer(hessian, wanted[4]),
        harmonic_mean_distance: sentinel(),
        min_distance: sentinel(),
    };
    let gather = raddiff_gather_input {
        directions: directions.as_ptr(),
        distance: distance.as_ptr(),
        radiance: radiance.as_ptr(),
        channels: channels as u32,
        sigma_t,
        media_radiance: media
            .as_ref()
            .map_or(std::ptr::null(), |m| m.radiance.as_ptr()),
        media_radiance_gradient: media
            .as_ref()
            .and_then(|m| m.gradient.as_ref())
            .map_or(std::ptr::null(), |g| g.as_ptr()),
        steps: media.as_ref().map_or(0, |m| m.steps),
        step: media.as_ref().map_or(0.0, |m| m.step),
    };
    let name = "raddiff_gather_evaluate";
    let status = raddiff_gather_evaluate(&layout, &frame, &gather, &mut output);
    let reach = match input.below(4) {
        0 => input.f64(),
        1 => input.magnitude(),
        _ => 0.01 + input.magnitude().min(1e3),
    };
    near_far(&layout, &distance, &radiance, channels, reach);
    let names = [
        "irradiance",
        "gradient",
        "rotation_gradient",
        "occlusion_gradient",
        "hessian",
    ];
    if !check::status(name, status) {
        for (values, what) in outputs.iter().zip(names) {
            check::untouched(name, what, values);
        }
        let distances = [output.harmonic_mean_distance, output.min_distance];
        check::untouched(name, "harmonic_mean_distance, min_distance", &distances);
        return Outcome::Refused;
    }
    for ((values, what), want) in outputs.iter().zip(names).zip(wanted) {
        if want {
            check::finite(name, what, values);
        } else {
            check::untouched(name, what, values);
        }
    }
    let all_missed = distance.iter().all(|d| *d == f64::INFINITY);
    for (what, d) in [
        ("harmonic_mean_distance", output.harmonic_mean_distance),
        ("min_distance", output.min_distance),
    ] {
        if all_missed {
            assert_eq!(
                d,
                f64::INFINITY,
                "{name}: every ray missed but {what} = {d}"
            );
        } else {
            check::finite(name, what, &[d]);
        }
    }
    Outcome::Ok
}

fn layout(input: &mut Input) -> raddiff_gather_layout {
    let kind = if input.byte() < 248 {
        input.below(3)
    } else {
        input.u32()
    };
    let mut side = || match input.byte() {
        // Out of range: 0, or above the per-axis limit.
        0 => 0,
        1 => RADDIFF_GATHER_MAX_STRATA_PER_AXIS + 1 + input.below(1000),
        b => 1 + (b as u32) % 16,
    };
    let (m, n) = (side(), side());
    let seed = if input.flag() { 0 } else { input.u64() };
    raddiff_gather_layout { kind, m, n, seed }
}

fn frame(input: &mut Input) -> raddiff_frame {
    let position = input.vec3();
    if input.byte() < 232 {
        let normal = input.unit3();
        let tangent = perpendicular(normal, input.f64());
        raddiff_frame {
            position,
            normal,
            tangent,
        }
    } else {
        raddiff_frame {
            position,
            normal: input.vec3(),
            tangent: input.vec3(),
        }
    }
}

/// The layout's directions, perhaps disturbed; raw vectors (m*n of them when the layout's sides are
/// small, else none) when `raddiff_gather_directions` refuses the layout.
fn directions(
    input: &mut Input,
    layout: &raddiff_gather_layout,
    frame: &raddiff_frame,
) -> Vec<raddiff_vec3> {
    let cells = if layout.m <= 16 && layout.n <= 16 {
        (layout.m * layout.n) as usize
    } else {
        0
    };
    let mut dirs = vec![sentinel3(); cells];
    let name = "raddiff_gather_directions";
    let status = if cells == 0 {
        raddiff_gather_directions(layout, frame, std::ptr::null_mut())
    } else {
        raddiff_gather_directions(layout, frame, dirs.as_mut_ptr())
    };
    if !check::status(name, status) {
        check::untouched(name, "directions", &check::flat(&dirs));
        return dirs.iter().map(|_| input.unit3()).collect();
    }
    for (i, d) in dirs.iter().enumerate() {
        let len = (d.x * d.x + d.y * d.y + d.z * d.z).sqrt();
        assert!(
            finite3(d) && (len - 1.0).abs() < 1e-9,
            "{name}: direction {i} = {d:?} is not a unit vector"
        );
    }
    let pick = |input: &mut Input| input.below(cells as u32) as usize;
    match input.below(16) {
        0 => {
            let (i, j) = (pick(input), pick(input));
            dirs.swap(i, j);
        }
        1 => {
            let i = pick(input);
            dirs[i] = input.unit3();
        }
        2 => {
            let i = pick(input);
            let scale = 10f64.powi(-(input.below(16) as i32));
            dirs[i] = normalized(add_scaled(dirs[i], scale, input.unit3()));
        }
        _ => {}
    }
    dirs
}

/// The near/far split of the gather's rays at `reach`, and its properties.
fn near_far(
    layout: &raddiff_gather_layout,
    distance: &[f64],
    radiance: &[f32],
    channels: usize,
    reach: f64,
) {
    let mut near = vec![sentinel(); channels];
    let mut open = sentinel();
    let near_name = "raddiff_gather_near_field";
    let near_status = raddiff_gather_near_field(
        layout,
        distance.as_ptr(),
        radiance.as_ptr(),
        channels as u32,
        reach,
        near.as_mut_ptr(),
        &mut open,
    );
    let mut far = radiance.to_vec();
    let mut far_open = sentinel();
    let far_name = "raddiff_gather_far_field_radiance";
    let far_status = raddiff_gather_far_field_radiance(
        layout,
        distance.as_ptr(),
        far.as_mut_ptr(),
        channels as u32,
        reach,
        &mut far_open,
    );
    let mut moved = distance.to_vec();
    let mut moved_radiance = radiance.to_vec();
    let mut moved_open = sentinel();
    let gather_name = "raddiff_gather_far_field";
    let gather_status = raddiff_gather_far_field(
        layout,
        moved.as_mut_ptr(),
        moved_radiance.as_mut_ptr(),
        channels as u32,
        reach,
        &mut moved_open,
    );
    let near_ok = check::status(near_name, near_status);
    assert_eq!(
        near_ok,
        check::status(gather_name, gather_status),
        "{near_name} and {gather_name} disagree on reach {reach}"
    );
    if near_ok {
        assert!(
            moved_open == open && moved_radiance == far,
            "{gather_name}: not the far-field radiance"
        );
        for (&before, &after) in distance.iter().zip(&moved) {
            let want = if before < reach { reach } else { before };
            assert_eq!(
                after.to_bits(),
                want.to_bits(),
                "{gather_name}: distance {before} -> {after}"
            );
        }
    } else {
        check::untouched(gather_name, "open_fraction", &[moved_open]);
        assert!(
            moved
                .iter()
                .zip(distance)
                .all(|(a, b)| a.to_bits() == b.to_bits())
                && moved_radiance
                    .iter()
                    .zip(radiance)
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{gather_name}: written on failure"
        );
    }
    assert_eq!(
        near_ok,
        check::status(far_name, far_status),
        "{near_name} and {far_name} disagree on reach {reach}"
    );
    if !near_ok {
        check::untouched(near_name, "near_irradiance", &near);
        check::untouched(near_name, "open_fraction", &[open]);
        check::untouched(far_name, "open_fraction", &[far_open]);
        assert!(
            far.iter()
                .zip(radiance)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "{far_name}: radiance written on failure"
        );
        return;
    }
    check::finite(near_name, "near_irradiance", &near);
    assert!(
        (0.0..=1.0).contains(&open) && open == far_open,
        "open fractions {open} and {far_open}"
    );
    check::finite_f32(far_name, "radiance", &far);
    for (i, &d) in distance.iter().enumerate() {
        if d >= reach {
            let (a, b) = (i * channels, (i + 1) * channels);
            assert_eq!(
                far[a..b],
                radiance[a..b],
                "{far_name}: open direction {i} changed"
            );
        }
    }
}

pub(super) fn distance(input: &mut Input) -> f64 {
    match input.below(16) {
        0 | 1 => f64::INFINITY,
        2 => input.f64(),
        3 => 10f64.powi(-(input.below(300) as i32)),
        4 => input.magnitude(),
        _ => 0.01 + input.magnitude().min(1e3),
    }
}

pub(super) fn radiance(input: &mut Input) -> f32 {
    if input.byte() < 16 {
        input.f32()
    } else {
        input.byte() as f32 / 16.0
    }
}

/// The optional media march of a gather.
struct Media {
    radiance: Vec<f32>,
    gradient: Option<Vec<f32>>,
    steps: u32,
    step: f64,
}

impl Media {
    fn decode(input: &mut Input, cells: usize, channels: usize) -> Media {
        let steps = input.below(5);
        let step = if input.byte() < 32 {
            input.f64()
        } else {
            0.01 + input.magnitude().min(1e3)
        };
        let samples = cells * steps as usize * channels;
        let radiance = (0..samples).map(|_| radiance(input)).collect();
        let gradient = input
            .flag()
            .then(|| (0..3 * samples).map(|_| input.f32()).collect());
        Media {
            radiance,
            gradient,
            steps,
            step,
        }
    }
}
