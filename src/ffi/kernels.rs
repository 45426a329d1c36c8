//! C wrappers for the closed-form derivative kernels.

use super::common::*;
use crate::kernels;

/// `exp(-sigma_t |x - y|)` and its derivatives with respect to `x` (see the Rust
/// `kernels::transmittance`). `RADDIFF_ERROR_DEGENERATE` for a gradient at `x == y`.
#[no_mangle]
pub extern "C" fn raddiff_transmittance(
    x: raddiff_vec3,
    y: raddiff_vec3,
    sigma_t: f64,
    order: u32,
    out: *mut raddiff_deriv3,
) -> raddiff_status {
    guard(|| {
        let out = unsafe { out_ref(out, "out")? };
        let order = order_from_c(order)?;
        *out = kernels::transmittance(x.into(), y.into(), sigma_t, order)?.into();
        Ok(())
    })
}
