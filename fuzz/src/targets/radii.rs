//! Record radii from Hessians: `raddiff_surface_radii`, `raddiff_surface_radii_floored`,
//! `raddiff_volume_radii`.
//!
//! Input: a selector byte, a Hessian (symmetric from six values, raw nine values, zero, or a
//! symmetric one scaled by up to 1e300), the normal (unit or raw), value, error, mode, anisotropy
//! cap and the floor's distance and weight.
//! Properties: no panic; with `RADDIFF_OK` radii finite, in [0, `RADDIFF_MAX_RADIUS`] (0 for a zero
//! tolerance), ascending, their ratio at most `max_anisotropy`, axes finite unit vectors; on failure radii and axes
//! untouched and a message set.
use raddiff::ffi::*;

use super::check::{self, sentinel, sentinel3};
use super::decode::Input;
use super::Outcome;

/// Decodes and runs one radii call.
pub fn run(data: &[u8]) -> Outcome {
    let mut input = Input::new(data);
    let which = input.below(3);
    let hessian = hessian(&mut input);
    let normal = if input.byte() < 224 {
        input.unit3()
    } else {
        input.vec3()
    };
    let (value, error) = (input.f64(), input.f64());
    let mode = if input.byte() < 240 {
        input.below(2)
    } else {
        input.u32()
    };
    let max_anisotropy = match input.below(4) {
        0 => input.f64(),
        1 => 1.0,
        _ => 1.0 + input.magnitude(),
    };
    let (floor_distance, floor_weight) = (input.f64(), input.f64());
    let mut radii = [sentinel(); 3];
    let mut axes = [sentinel3(); 3];
    let (name, status, dims) = match which {
        // SAFETY (all three): `hessian` holds 9 doubles, `radii` and `axes` 3 elements each.
        0 => (
            "raddiff_surface_radii",
            unsafe {
                raddiff_surface_radii(
                    hessian.as_ptr(),
                    normal,
                    value,
                    error,
                    mode,
                    max_anisotropy,
                    radii.as_mut_ptr(),
                    axes.as_mut_ptr(),
                )
            },
            2,
        ),
        1 => (
            "raddiff_surface_radii_floored",
            unsafe {
                raddiff_surface_radii_floored(
                    hessian.as_ptr(),
                    normal,
                    value,
                    error,
                    mode,
                    max_anisotropy,
                    floor_distance,
                    floor_weight,
                    radii.as_mut_ptr(),
                    axes.as_mut_ptr(),
                )
            },
            2,
        ),
        _ => (
            "raddiff_volume_radii",
            unsafe {
                raddiff_volume_radii(
                    hessian.as_ptr(),
                    value,
                    error,
                    mode,
                    max_anisotropy,
                    radii.as_mut_ptr(),
                    axes.as_mut_ptr(),
                )
            },
            3,
        ),
    };
    let name = &format!(
        "{name}(hessian {hessian:?}, normal {normal:?}, value {value:e}, error {error:e}, mode \
         {mode}, max_anisotropy {max_anisotropy:e}, floor {floor_distance:e} {floor_weight:e})"
    );
    // Elements past `dims` are never the function's to write.
    check::untouched(name, "radii (past the end)", &radii[dims..]);
    check::untouched(name, "axes (past the end)", &check::flat(&axes[dims..]));
    if !check::status(name, status) {
        check::untouched(name, "radii", &radii[..dims]);
        check::untouched(name, "axes", &check::flat(&axes[..dims]));
        return Outcome::Refused;
    }
    let (radii, axes) = (&radii[..dims], &axes[..dims]);
    check::finite(name, "radii", radii);
    check::finite(name, "axes", &check::flat(axes));
    for (i, &r) in radii.iter().enumerate() {
        assert!(
            (0.0..=RADDIFF_MAX_RADIUS).contains(&r),
            "{name}: radius {i} = {r} outside [0, RADDIFF_MAX_RADIUS]"
        );
    }
    assert!(
        radii.windows(2).all(|w| w[0] <= w[1]),
        "{name}: radii not ascending: {radii:?}"
    );
    // Zero radii (a zero tolerance) have no ratio to check.
    let ratio = radii[dims - 1] / radii[0];
    assert!(
        radii[0] == 0.0 || ratio <= max_anisotropy * (1.0 + 1e-12),
        "{name}: anisotropy {ratio} above the cap {max_anisotropy} ({radii:?})"
    );
    for (i, a) in axes.iter().enumerate() {
        let len = (a.x * a.x + a.y * a.y + a.z * a.z).sqrt();
        assert!(
            (len - 1.0).abs() < 1e-9,
            "{name}: axis {i} has length {len}"
        );
    }
    Outcome::Ok
}

fn hessian(input: &mut Input) -> [f64; 9] {
    match input.below(8) {
        0 => std::array::from_fn(|_| input.f64()),
        1 => [0.0; 9],
        2 => {
            let scale = 10f64.powi(input.below(301) as i32);
            symmetric(input).map(|h| h * scale)
        }
        _ => symmetric(input),
    }
}

fn symmetric(input: &mut Input) -> [f64; 9] {
    let [a, b, c, d, e, f] = std::array::from_fn(|_| input.f64());
    [a, b, c, b, d, e, c, e, f]
}
