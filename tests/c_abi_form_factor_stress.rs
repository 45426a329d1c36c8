//! Stress test of `raddiff_triangle_form_factor` / `raddiff_polygon_form_factor` through the C ABI:
//! random and adversarial inputs must give `RADDIFF_OK` with finite outputs (value in [0, 1]) or a
//! documented error (`INVALID_ARGUMENT`, `DEGENERATE`, `NULL_POINTER`) with the output untouched;
//! never a panic, NaN or Inf.
//!
//! ~1e5 calls by default; `RADDIFF_STRESS_CALLS=N` runs N calls (use millions in CI/nightly):
//! `RADDIFF_STRESS_CALLS=5000000 cargo test --release --test c_abi_form_factor_stress`.

use raddiff::ffi::*;

#[path = "common/splitmix.rs"]
mod splitmix;

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        splitmix::next_u64(&mut self.0)
    }
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    /// A number from a wide, adversarial distribution.
    fn number(&mut self) -> f64 {
        match self.below(20) {
            0 => 0.0,
            1 => f64::MIN_POSITIVE * self.uniform(),
            2 => f64::MAX * (2.0 * self.uniform() - 1.0),
            3 => {
                10f64.powf(300.0 * (2.0 * self.uniform() - 1.0))
                    * if self.below(2) == 0 { 1.0 } else { -1.0 }
            }
            4 => [f64::NAN, f64::INFINITY, f64::NEG_INFINITY][self.below(3) as usize],
            _ => 10f64.powf(6.0 * (2.0 * self.uniform() - 1.0)) * (2.0 * self.uniform() - 1.0),
        }
    }
    fn vec(&mut self) -> raddiff_vec3 {
        raddiff_vec3 {
            x: self.number(),
            y: self.number(),
            z: self.number(),
        }
    }
    fn tame(&mut self, scale: f64) -> raddiff_vec3 {
        raddiff_vec3 {
            x: scale * (2.0 * self.uniform() - 1.0),
            y: scale * (2.0 * self.uniform() - 1.0),
            z: scale * (2.0 * self.uniform() - 1.0),
        }
    }
    fn normal(&mut self) -> raddiff_vec3 {
        match self.below(8) {
            0 => self.vec(),
            1 => raddiff_vec3 {
                x: 0.0,
                y: 0.0,
                z: 0.0,
            },
            _ => loop {
                let v = self.tame(1.0);
                let l = (v.x * v.x + v.y * v.y + v.z * v.z).sqrt();
                if l > 1e-3 {
                    break raddiff_vec3 {
                        x: v.x / l,
                        y: v.y / l,
                        z: v.z / l,
                    };
                }
            },
        }
    }
}

fn lerp(a: raddiff_vec3, b: raddiff_vec3, t: f64) -> raddiff_vec3 {
    raddiff_vec3 {
        x: a.x + t * (b.x - a.x),
        y: a.y + t * (b.y - a.y),
        z: a.z + t * (b.z - a.z),
    }
}

fn calls() -> usize {
    std::env::var("RADDIFF_STRESS_CALLS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(100_000)
}

fn check(status: raddiff_status, out: &raddiff_deriv3, sentinel: &raddiff_deriv3, what: &str) {
    use raddiff_status::*;
    match status {
        RADDIFF_OK => {
            assert!(
                out.value.is_finite() && (0.0..=1.0).contains(&out.value),
                "{what}: value {}",
                out.value
            );
            assert!(
                out.gradient
                    .iter()
                    .chain(out.hessian.iter())
                    .all(|v| v.is_finite()),
                "{what}: {out:?}"
            );
        }
        RADDIFF_ERROR_INVALID_ARGUMENT | RADDIFF_ERROR_DEGENERATE | RADDIFF_ERROR_NULL_POINTER => {
            assert_eq!(out, sentinel, "{what}: output written on failure");
        }
        other => panic!("{what}: unexpected status {other:?}"),
    }
}

#[test]
fn random_and_adversarial_inputs_never_produce_nan_inf_or_panics() {
    let mut rng = Rng(0x5eed);
    let sentinel = raddiff_deriv3 {
        value: -7.0,
        gradient: [-7.0; 3],
        hessian: [-7.0; 9],
    };
    let mut ok = 0usize;
    for call in 0..calls() {
        let scale = 10f64.powf(rng.uniform() * 200.0 - 100.0);
        // vertices: tame (so that many calls succeed) or adversarial
        let count = match rng.below(10) {
            0 => rng.below(3) as usize,
            1..=5 => 3,
            _ => 3 + rng.below(6) as usize,
        };
        let mut verts: Vec<raddiff_vec3> = Vec::with_capacity(count);
        if rng.below(4) == 0 {
            for _ in 0..count {
                verts.push(rng.vec());
            }
        } else if count >= 3 {
            // planar polygon: a regular-ish polygon on a random plane, or degenerate variants
            let c = rng.tame(scale);
            let (u, v) = (rng.tame(scale), rng.tame(scale));
            for i in 0..count {
                let phi = std::f64::consts::TAU * i as f64 / count as f64;
                let (s, t) = (phi.cos(), phi.sin());
                verts.push(raddiff_vec3 {
                    x: c.x + s * u.x + t * v.x,
                    y: c.y + s * u.y + t * v.y,
                    z: c.z + s * u.z + t * v.z,
                });
            }
            match rng.below(6) {
                0 => verts[1] = verts[0],
                1 => verts[2] = lerp(verts[0], verts[1], rng.uniform()),
                _ => {}
            }
        } else {
            for _ in 0..count {
                verts.push(rng.tame(scale));
            }
        }
        let x = match (rng.below(8), verts.len()) {
            (0, _) => rng.vec(),
            (1, n) if n > 0 => verts[rng.below(n as u64) as usize],
            (2, n) if n > 1 => lerp(verts[0], verts[1], rng.uniform()),
            (3, n) if n > 2 => lerp(
                lerp(verts[0], verts[1], rng.uniform()),
                verts[2],
                rng.uniform(),
            ),
            (4, n) if n > 0 => {
                let near = scale * 10f64.powf(-15.0 * rng.uniform());
                let d = rng.tame(near);
                let v = verts[0];
                raddiff_vec3 {
                    x: v.x + d.x,
                    y: v.y + d.y,
                    z: v.z + d.z,
                }
            }
            _ => {
                let far = scale * 10f64.powf(6.0 * rng.uniform());
                rng.tame(far)
            }
        };
        let n = rng.normal();
        let order = match rng.below(20) {
            0 => rng.below(1000) as u32,
            k => (k % 3) as u32,
        };
        let mut out = sentinel;
        let status = if verts.len() == 3 && rng.below(2) == 0 {
            let out_ptr = if rng.below(200) == 0 {
                std::ptr::null_mut()
            } else {
                &mut out as *mut _
            };
            unsafe {
                raddiff_triangle_form_factor(x, n, verts[0], verts[1], verts[2], order, out_ptr)
            }
        } else {
            let vptr = if rng.below(200) == 0 {
                std::ptr::null()
            } else {
                verts.as_ptr()
            };
            unsafe { raddiff_polygon_form_factor(x, n, vptr, verts.len(), order, &mut out) }
        };
        check(
            status,
            &out,
            &sentinel,
            &format!("call {call}: x={x:?} n={n:?} verts={verts:?} order={order}"),
        );
        if status == raddiff_status::RADDIFF_OK {
            ok += 1;
        }
    }
    // the generator is meant to exercise the success path too
    assert!(ok * 5 > calls(), "only {ok} successful calls");
}
