//! Which vector code paths may run: the CPU's features, capped by the `RADDIFF_SIMD` environment
//! variable (read once per process).
//!
//! `RADDIFF_SIMD=portable` runs the portable code everywhere (the reference every vector path is
//! tested against), `RADDIFF_SIMD=avx2` allows AVX, F16C and AVX2 + FMA but not AVX-512; unset (or
//! any other value) lets every path the CPU supports run. Results do not depend on the choice
//! except where a path's documentation says so (the Hessian's edge batches use FMA: their sums
//! differ in the last bits).

/// The vector paths this process may take.
#[derive(Debug, Clone, Copy)]
struct Allowed {
    avx: bool,
    avx_f16c: bool,
    avx2: bool,
    avx2_fma: bool,
    avx512: bool,
}

fn allowed() -> Allowed {
    static ALLOWED: std::sync::OnceLock<Allowed> = std::sync::OnceLock::new();
    *ALLOWED.get_or_init(|| {
        let cap = std::env::var("RADDIFF_SIMD").unwrap_or_default();
        let none = Allowed {
            avx: false,
            avx_f16c: false,
            avx2: false,
            avx2_fma: false,
            avx512: false,
        };
        if cap == "portable" {
            return none;
        }
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            let avx = has!("avx");
            let avx2 = avx && has!("avx2");
            let avx2_fma = avx2 && has!("fma");
            Allowed {
                avx,
                avx_f16c: avx && has!("f16c"),
                avx2,
                avx2_fma,
                avx512: avx2_fma
                    && has!("avx512f")
                    && has!("avx512vl")
                    && has!("avx512dq")
                    && cap != "avx2",
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        none
    })
}

/// AVX may run (the CPU has it and `RADDIFF_SIMD` allows it).
#[inline]
pub(crate) fn avx() -> bool {
    allowed().avx
}

/// AVX and F16C may run.
#[inline]
pub(crate) fn avx_f16c() -> bool {
    allowed().avx_f16c
}

/// AVX2 may run.
#[inline]
pub(crate) fn avx2() -> bool {
    allowed().avx2
}

/// AVX2 and FMA may run.
#[inline]
#[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
pub(crate) fn avx2_fma() -> bool {
    allowed().avx2_fma
}

/// AVX-512 (F, VL, DQ) with AVX2 and FMA may run.
#[inline]
#[cfg_attr(not(raddiff_avx512), allow(dead_code))]
pub(crate) fn avx512() -> bool {
    allowed().avx512
}

/// The instruction sets the kernels' vectorized loops are compiled for: each such loop has a
/// portable copy and copies compiled with these target features, chosen once per call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    /// Baseline code (SSE2 on x86-64): what `RADDIFF_SIMD=portable` runs everywhere.
    Portable,
    /// AVX2 with FMA.
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// AVX-512 (F, VL, DQ) with FMA, when the build enables it (`raddiff_avx512`).
    #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
    Avx512,
}

/// The best [`Isa`] this CPU runs and `RADDIFF_SIMD` allows.
pub(crate) fn best_isa() -> Isa {
    #[cfg(all(target_arch = "x86_64", raddiff_avx512))]
    if avx512() {
        return Isa::Avx512;
    }
    #[cfg(target_arch = "x86_64")]
    if avx2_fma() {
        return Isa::Avx2;
    }
    Isa::Portable
}
