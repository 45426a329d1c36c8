//! Value, gradient and Hessian bundles returned by the kernels, and the order that selects them.

use glam::{DMat2, DMat3, DVec2, DVec3};

use crate::error::{Error, Result};

/// How many derivatives a kernel computes. Parts above the requested order are returned as zero
/// and cost nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u32)]
pub enum Order {
    /// The value only.
    Value = 0,
    /// The value and the gradient.
    Gradient = 1,
    /// The value, the gradient and the Hessian.
    Hessian = 2,
}

impl Order {
    /// Whether the gradient is wanted.
    #[inline]
    pub fn gradient(self) -> bool {
        self >= Order::Gradient
    }

    /// Whether the Hessian is wanted.
    #[inline]
    pub fn hessian(self) -> bool {
        self >= Order::Hessian
    }
}

impl TryFrom<u32> for Order {
    type Error = Error;
    fn try_from(v: u32) -> Result<Self> {
        match v {
            0 => Ok(Order::Value),
            1 => Ok(Order::Gradient),
            2 => Ok(Order::Hessian),
            _ => Err(Error::InvalidArgument(format!(
                "order {v} is not RADDIFF_ORDER_VALUE (0), _GRADIENT (1) or _HESSIAN (2)"
            ))),
        }
    }
}

/// A scalar function of a 3D point with its gradient and (symmetric) Hessian at that point.
///
/// Units: if the value has unit U and positions unit L, the gradient has U/L and the Hessian U/L².
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deriv3 {
    /// The function value.
    pub value: f64,
    /// ∂f/∂x_i (zero when not requested).
    pub gradient: DVec3,
    /// ∂²f/∂x_i∂x_j (zero when not requested). Symmetric, so row- and column-major agree.
    pub hessian: DMat3,
}

/// All zero. (Not derived: glam's default matrix is the identity, which would make a zero-initialized
/// accumulator carry a spurious identity Hessian.)
impl Default for Deriv3 {
    fn default() -> Self {
        Deriv3::constant(0.0)
    }
}

impl Deriv3 {
    /// A constant: the given value with zero derivatives.
    pub fn constant(value: f64) -> Self {
        Deriv3 {
            value,
            gradient: DVec3::ZERO,
            hessian: DMat3::ZERO,
        }
    }

    /// Whether every component is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.value.is_finite() && self.gradient.is_finite() && self.hessian.is_finite()
    }
}

/// A scalar function of a 2D point with its gradient and (symmetric) Hessian at that point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deriv2 {
    /// The function value.
    pub value: f64,
    /// ∂f/∂x_i (zero when not requested).
    pub gradient: DVec2,
    /// ∂²f/∂x_i∂x_j (zero when not requested). Symmetric.
    pub hessian: DMat2,
}

/// All zero (see [`Deriv3`]'s `Default`).
impl Default for Deriv2 {
    fn default() -> Self {
        Deriv2::constant(0.0)
    }
}

impl Deriv2 {
    /// A constant: the given value with zero derivatives.
    pub fn constant(value: f64) -> Self {
        Deriv2 {
            value,
            gradient: DVec2::ZERO,
            hessian: DMat2::ZERO,
        }
    }

    /// Whether every component is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.value.is_finite() && self.gradient.is_finite() && self.hessian.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_all_zero() {
        let d = Deriv3::default();
        assert_eq!(d.value, 0.0);
        assert_eq!(d.gradient, DVec3::ZERO);
        assert_eq!(d.hessian, DMat3::ZERO);
        let d = Deriv2::default();
        assert_eq!(d.hessian, DMat2::ZERO);
    }

    #[test]
    fn order_parses_and_rejects() {
        assert_eq!(Order::try_from(2).unwrap(), Order::Hessian);
        assert!(Order::try_from(3).is_err());
        assert!(Order::Hessian.gradient() && !Order::Value.gradient());
    }
}
