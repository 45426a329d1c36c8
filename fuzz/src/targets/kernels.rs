//! The closed-form kernels: `raddiff_transmittance`, `raddiff_transmittance_marched`,
//! `raddiff_triangle_solid_angle`, `raddiff_triangle_form_factor`, `raddiff_polygon_form_factor`,
//! `raddiff_segment_form_factor_2d`.
//!
//! Input: a selector byte, the order (0..2 mostly, sometimes any u32), then the kernel's arguments.
//! Polygons are mostly planar (2D points placed on a decoded plane), sometimes raw points.
//! Properties: no panic; with `RADDIFF_OK` every output finite and the parts above the requested
//! order exactly 0; on failure the output untouched and a message set.
use raddiff::ffi::*;

use super::check::{self, sentinel};
use super::decode::{add_scaled, cross, normalized, perpendicular, Input};
use super::Outcome;

/// Decodes and runs one kernel call.
pub fn run(data: &[u8]) -> Outcome {
    let mut input = Input::new(data);
    let kernel = input.below(6);
    let order = if input.byte() < 240 {
        input.below(3)
    } else {
        input.u32()
    };
    let ok = if kernel == 5 {
        segment_2d(&mut input, order)
    } else {
        let mut out = raddiff_deriv3 {
            value: sentinel(),
            gradient: [sentinel(); 3],
            hessian: [sentinel(); 9],
        };
        let (name, status) = call3(kernel, &mut input, order, &mut out);
        let ok = check::status(name, status);
        let all = deriv3_values(&out);
        if ok {
            check::finite(name, "out", &all);
            above_order_zero(name, order, &out.gradient, &out.hessian);
        } else {
            check::untouched(name, "out", &all);
        }
        ok
    };
    if ok {
        Outcome::Ok
    } else {
        Outcome::Refused
    }
}

fn call3(
    kernel: u32,
    input: &mut Input,
    order: u32,
    out: &mut raddiff_deriv3,
) -> (&'static str, raddiff_status) {
    match kernel {
        0 => {
            let (x, y, sigma_t) = (input.vec3(), input.vec3(), input.f64());
            let s = raddiff_transmittance(x, y, sigma_t, order, out);
            ("raddiff_transmittance", s)
        }
        1 => {
            let (x, y) = (input.vec3(), input.vec3());
            let count = input.below(17) as usize;
            let sigma: Vec<f64> = (0..count)
                .map(|_| {
                    if input.byte() < 32 {
                        input.f64()
                    } else {
                        input.magnitude()
                    }
                })
                .collect();
            let gradient: Option<Vec<raddiff_vec3>> = input
                .flag()
                .then(|| (0..count).map(|_| input.vec3()).collect());
            let gradient_ptr = gradient.as_ref().map_or(std::ptr::null(), |g| g.as_ptr());
            let s = raddiff_transmittance_marched(
                x,
                y,
                sigma.as_ptr(),
                gradient_ptr,
                count,
                order,
                out,
            );
            ("raddiff_transmittance_marched", s)
        }
        2 => {
            let (x, a, b, c) = (input.vec3(), input.vec3(), input.vec3(), input.vec3());
            let s = raddiff_triangle_solid_angle(x, a, b, c, order, out);
            ("raddiff_triangle_solid_angle", s)
        }
        3 => {
            let x = input.vec3();
            let n = normal(input);
            let (a, b, c) = (input.vec3(), input.vec3(), input.vec3());
            // SAFETY: `out` is a valid deriv3.
            let s = unsafe { raddiff_triangle_form_factor(x, n, a, b, c, order, out) };
            ("raddiff_triangle_form_factor", s)
        }
        _ => {
            let x = input.vec3();
            let n = normal(input);
            let vertices = polygon(input);
            // SAFETY: `vertices` holds `len` vectors; `out` is a valid deriv3.
            let s = unsafe {
                raddiff_polygon_form_factor(x, n, vertices.as_ptr(), vertices.len(), order, out)
            };
            ("raddiff_polygon_form_factor", s)
        }
    }
}

/// The receiver normal: unit most of the time (anything else is refused), raw otherwise.
fn normal(input: &mut Input) -> raddiff_vec3 {
    if input.byte() < 224 {
        input.unit3()
    } else {
        input.vec3()
    }
}

/// 0..10 vertices: planar (2D points on a decoded plane) or raw 3D points.
fn polygon(input: &mut Input) -> Vec<raddiff_vec3> {
    let count = input.below(11) as usize;
    if input.byte() < 48 {
        return (0..count).map(|_| input.vec3()).collect();
    }
    let origin = input.vec3();
    let plane_normal = input.unit3();
    let u = perpendicular(plane_normal, input.f64());
    let v = normalized(cross(plane_normal, u));
    (0..count)
        .map(|_| {
            let (s, t) = (input.f64(), input.f64());
            add_scaled(add_scaled(origin, s, u), t, v)
        })
        .collect()
}

fn segment_2d(input: &mut Input, order: u32) -> bool {
    let mut point = || raddiff_vec2 {
        x: input.f64(),
        y: input.f64(),
    };
    let (x, a, b) = (point(), point(), point());
    let mut out = raddiff_deriv2 {
        value: sentinel(),
        gradient: [sentinel(); 2],
        hessian: [sentinel(); 4],
    };
    let name = "raddiff_segment_form_factor_2d";
    let ok = check::status(
        name,
        raddiff_segment_form_factor_2d(x, a, b, order, &mut out),
    );
    let mut all = vec![out.value];
    all.extend(out.gradient);
    all.extend(out.hessian);
    if ok {
        check::finite(name, "out", &all);
        above_order_zero(name, order, &out.gradient, &out.hessian);
    } else {
        check::untouched(name, "out", &all);
    }
    ok
}

fn deriv3_values(d: &raddiff_deriv3) -> Vec<f64> {
    let mut all = vec![d.value];
    all.extend(d.gradient);
    all.extend(d.hessian);
    all
}

/// The documented contract: parts above the requested order are written as 0.
fn above_order_zero(name: &str, order: u32, gradient: &[f64], hessian: &[f64]) {
    if order < RADDIFF_ORDER_GRADIENT {
        assert!(
            gradient.iter().all(|&g| g == 0.0),
            "{name}: order {order} wrote a gradient {gradient:?}"
        );
    }
    if order < RADDIFF_ORDER_HESSIAN {
        assert!(
            hessian.iter().all(|&h| h == 0.0),
            "{name}: order {order} wrote a Hessian {hessian:?}"
        );
    }
}
