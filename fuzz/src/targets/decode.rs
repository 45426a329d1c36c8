//! Turns fuzzer bytes into call arguments. Reading past the end yields zeros, so every byte string
//! decodes; the encodings favour finite values over a wide dynamic range (1e-308 .. 1e308, zeros,
//! subnormals, exact small integers) because non-finite input is refused up front and so covers
//! little code.
use raddiff::ffi::raddiff_vec3;

/// A cursor over the fuzzer's bytes.
pub struct Input<'a> {
    data: &'a [u8],
}

/// Special values that matter to floating-point code: signed zeros, the extremes, subnormals.
const SPECIALS: [f64; 16] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    2.0,
    1e-300,
    1e300,
    f64::MIN_POSITIVE,
    5e-324,
    f64::MAX,
    -f64::MAX,
    f64::EPSILON,
    1e-8,
    1e8,
    std::f64::consts::PI,
];

impl<'a> Input<'a> {
    /// A decoder over `data`.
    pub fn new(data: &'a [u8]) -> Self {
        Input { data }
    }

    /// Whether every byte has been read.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The next byte, 0 past the end.
    pub fn byte(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }

    /// The next `N` bytes, zero-padded past the end.
    pub fn array<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0; N];
        for b in &mut out {
            *b = self.byte();
        }
        out
    }

    /// A little-endian u32.
    pub fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.array())
    }

    /// A little-endian u64.
    pub fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.array())
    }

    /// A value in `0..n` (`n >= 1`); one byte when `n <= 256`.
    pub fn below(&mut self, n: u32) -> u32 {
        if n <= 256 {
            self.byte() as u32 % n
        } else {
            self.u32() % n
        }
    }

    /// A boolean from one byte.
    pub fn flag(&mut self) -> bool {
        self.byte() & 1 == 1
    }

    /// A finite f64. Half of the tags give moderate values (multiples of 1/256 within +-128), the
    /// rest raw bit patterns, decimal mantissas with exponents from -308 to 308, small integers and
    /// special values.
    pub fn f64(&mut self) -> f64 {
        let tag = self.byte();
        match tag % 8 {
            0 => (self.byte() as i8) as f64,
            1 => SPECIALS[(tag >> 3) as usize % SPECIALS.len()],
            2 => {
                let bits = self.u64();
                let x = f64::from_bits(bits);
                if x.is_finite() {
                    x
                } else {
                    // Exponent all ones: drop its top bit, keeping sign and mantissa.
                    f64::from_bits(bits & !(1 << 62))
                }
            }
            3 => {
                let mantissa = i16::from_le_bytes(self.array()) as f64 / 4096.0;
                let exponent = (self.byte() as i8 as i32 * 617 / 256).clamp(-308, 308);
                let x = mantissa * 10f64.powi(exponent);
                if x.is_finite() {
                    x
                } else {
                    f64::MAX.copysign(mantissa)
                }
            }
            _ => i16::from_le_bytes(self.array()) as f64 / 256.0,
        }
    }

    /// `|f64()|`.
    pub fn magnitude(&mut self) -> f64 {
        self.f64().abs()
    }

    /// A finite f32: the f64 encodings, saturated to the f32 range.
    pub fn f32(&mut self) -> f32 {
        let x = self.f64();
        (x as f32).clamp(f32::MIN, f32::MAX)
    }

    /// A value in [0, 1] with 1/255 steps (fractions, barycentrics).
    pub fn unit(&mut self) -> f64 {
        self.byte() as f64 / 255.0
    }

    /// Three `f64()`.
    pub fn vec3(&mut self) -> raddiff_vec3 {
        raddiff_vec3 {
            x: self.f64(),
            y: self.f64(),
            z: self.f64(),
        }
    }

    /// A unit vector from a decoded direction (the z axis when it cannot be normalized).
    pub fn unit3(&mut self) -> raddiff_vec3 {
        normalized(self.vec3())
    }
}

/// `v / |v|`, or the z axis when `|v|` is 0 or overflows.
pub fn normalized(v: raddiff_vec3) -> raddiff_vec3 {
    // Scaling by the largest component first keeps |v| finite for components near f64::MAX.
    let s = v.x.abs().max(v.y.abs()).max(v.z.abs());
    if s == 0.0 || !s.is_finite() {
        return raddiff_vec3 {
            x: 0.0,
            y: 0.0,
            z: 1.0,
        };
    }
    let (x, y, z) = (v.x / s, v.y / s, v.z / s);
    let len = (x * x + y * y + z * z).sqrt();
    raddiff_vec3 {
        x: x / len,
        y: y / len,
        z: z / len,
    }
}

/// `a x b`.
pub fn cross(a: raddiff_vec3, b: raddiff_vec3) -> raddiff_vec3 {
    raddiff_vec3 {
        x: a.y * b.z - a.z * b.y,
        y: a.z * b.x - a.x * b.z,
        z: a.x * b.y - a.y * b.x,
    }
}

/// `a + s b`.
pub fn add_scaled(a: raddiff_vec3, s: f64, b: raddiff_vec3) -> raddiff_vec3 {
    raddiff_vec3 {
        x: a.x + s * b.x,
        y: a.y + s * b.y,
        z: a.z + s * b.z,
    }
}

/// A unit vector perpendicular to the unit `n`, turned by `angle` about it.
pub fn perpendicular(n: raddiff_vec3, angle: f64) -> raddiff_vec3 {
    let helper = if n.x.abs() < 0.9 {
        raddiff_vec3 {
            x: 1.0,
            y: 0.0,
            z: 0.0,
        }
    } else {
        raddiff_vec3 {
            x: 0.0,
            y: 1.0,
            z: 0.0,
        }
    };
    let t = normalized(cross(n, helper));
    let b = cross(n, t);
    let (s, c) = angle.sin_cos();
    normalized(add_scaled(
        raddiff_vec3 {
            x: c * t.x,
            y: c * t.y,
            z: c * t.z,
        },
        s,
        b,
    ))
}

/// Whether every component of `v` is finite.
pub fn finite3(v: &raddiff_vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}
