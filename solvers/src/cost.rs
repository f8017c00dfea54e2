//! Cost / capacity scalar types.
//!
//! Every solver in this crate is generic over [`Cost`], implemented for `i32`, `i64`, `f32`
//! and `f64`. The type is used both for the energy terms handed in by the caller and for the
//! residual capacities inside max-flow.
//!
//! * **Integers are exact.** Max-flow terminates with the exact minimum cut, the energy an
//!   α-expansion reports equals an independent evaluation bit for bit, and results do not
//!   depend on summation order. `i32` is the fastest choice (half the memory traffic of
//!   `i64`/`f64`); energies are always accumulated in `i64` ([`Cost::Acc`]), so only a single
//!   capacity (one data cost plus the pairwise terms folded into one node, or one edge) must
//!   fit in `i32`. Real-valued costs should be pre-scaled: multiply by a scale such as
//!   `1000.0`, round, and divide reported energies by the same scale.
//! * **Floats need a tolerance.** Max-flow still terminates (every augmentation saturates the
//!   bottleneck arc exactly, since `x - x == 0`), but capacities that should cancel may leave
//!   residues of the order of the rounding error, so the computed cut is minimal only up to
//!   roughly `n_arcs * eps * max_capacity`. Energies are accumulated in `f64`.
use std::fmt::Debug;
use std::ops::{Add, AddAssign, Mul, Neg, Sub, SubAssign};

/// A scalar usable as an energy term and as a max-flow capacity.
pub trait Cost:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + AddAssign
    + SubAssign
    + Neg<Output = Self>
    + Default
    + Debug
    + Send
    + Sync
    + 'static
{
    /// Wide accumulator for energies (sums over all sites and edges): `i64` for the integer
    /// types, `f64` for the float types.
    type Acc: Copy
        + PartialOrd
        + Add<Output = Self::Acc>
        + Sub<Output = Self::Acc>
        + AddAssign
        + SubAssign
        + Default
        + Debug
        + Send
        + Sync
        + 'static;
    /// The additive identity.
    const ZERO: Self;
    /// Whether the type is exact (integer). Exact types make energies order-independent.
    const EXACT: bool;
    /// Widens one term into the accumulator type.
    fn widen(self) -> Self::Acc;
    /// Converts an accumulated energy into `f64` for reporting.
    fn acc_to_f64(acc: Self::Acc) -> f64;
    /// Converts an `f64` into this type (rounding to nearest for integers, saturating).
    fn from_f64(v: f64) -> Self;
    /// Converts to `f64`.
    fn to_f64(self) -> f64;
    /// The smaller of two values.
    #[inline(always)]
    fn min_of(self, other: Self) -> Self {
        if other < self {
            other
        } else {
            self
        }
    }
    /// Whether the value is strictly positive.
    #[inline(always)]
    fn is_pos(self) -> bool {
        self > Self::ZERO
    }
}

macro_rules! impl_int {
    ($t:ty) => {
        impl Cost for $t {
            type Acc = i64;
            const ZERO: Self = 0;
            const EXACT: bool = true;
            #[inline(always)]
            fn widen(self) -> i64 {
                self as i64
            }
            #[inline(always)]
            fn acc_to_f64(acc: i64) -> f64 {
                acc as f64
            }
            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                // Round half away from zero, saturating, as `v.round() as $t`, but without
                // the libm call `f64::round` is on baseline x86-64: below 2^52 truncation
                // and the remainder are exact.
                if v.abs() < 4_503_599_627_370_496.0 {
                    let t = v as i64;
                    let r = v - t as f64;
                    let t = t + (r >= 0.5) as i64 - (r <= -0.5) as i64;
                    t.clamp(<$t>::MIN as i64, <$t>::MAX as i64) as $t
                } else {
                    v.round() as $t
                }
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    };
}
macro_rules! impl_float {
    ($t:ty) => {
        impl Cost for $t {
            type Acc = f64;
            const ZERO: Self = 0.0;
            const EXACT: bool = false;
            #[inline(always)]
            fn widen(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn acc_to_f64(acc: f64) -> f64 {
                acc
            }
            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
        }
    };
}
impl_int!(i32);
impl_int!(i64);
impl_float!(f32);
impl_float!(f64);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widen_and_round() {
        assert_eq!(i32::from_f64(2.5), 3);
        assert_eq!(i32::from_f64(-2.4), -2);
        for v in [
            -2.5,
            0.49999999999999994,
            -0.5,
            1.5,
            2.4999,
            1e20,
            -1e20,
            3e9,
            f64::NAN,
            4503599627370497.0,
            -7.0e15 - 0.5,
        ] {
            assert_eq!(i32::from_f64(v), v.round() as i32, "{v}");
            assert_eq!(i64::from_f64(v), v.round() as i64, "{v}");
        }
        assert_eq!(i32::MAX.widen() + 1, 2_147_483_648i64);
        assert_eq!(3i32.min_of(-4), -4);
        assert!(1e-30f32.is_pos());
        assert!(!0i64.is_pos());
        assert_eq!(f32::acc_to_f64(0.25f32.widen()), 0.25);
    }
}
