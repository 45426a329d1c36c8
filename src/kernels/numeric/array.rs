//! Filling a fixed-size array by a loop.

/// `std::array::from_fn(f)` as a loop filling an initialized array: in the near-plane routes' large
/// functions LLVM left `from_fn` out of line.
#[inline(always)]
pub(crate) fn array_from<T: Copy + Default, const M: usize>(f: impl Fn(usize) -> T) -> [T; M] {
    let mut a = [T::default(); M];
    for (k, x) in a.iter_mut().enumerate() {
        *x = f(k);
    }
    a
}
