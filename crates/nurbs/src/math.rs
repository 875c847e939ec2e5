//! The few elementary functions the tick needs, in plain `f32` arithmetic: no `libm` call,
//! no double precision, no table. They live in `nurbs`, the lowest crate on the tick path,
//! so `tracker`, `friction` and `device` (which re-exports this module) share them.
//!
//! On the Cortex-M4F `libm`'s `sincosf` runs in software double precision (about 2,000
//! instructions a call) and its `sqrtf` is a software routine; these take a few dozen
//! single-precision instructions, branch-free on the common path. [`min`] and [`max`] are a
//! compare and a select where `f32::min`/`f32::max` compile to calls of `fminf`/`fmaxf`
//! (ARMv7-M has no `VMINNM`), with `f32::min`'s answer whenever the first operand is not NaN.
//!
//! # Error bounds (checked in `tests/math.rs` against `f64`)
//!
//! - [`sin_cos`]: absolute error at most [`SIN_COS_MAX_ERROR`] `= 4 ε32 = 8 u` (ε32 = 2⁻²³,
//!   u = 2⁻²⁴, half an ulp of 1) for `|x| ≤` [`SIN_COS_MAX_ANGLE_RAD`]. The budget:
//!   - reduction `r = x − k π/2`, Cody–Waite with π/2 = C1 + C2 + C3: C1 and C2 have 8 and 11
//!     significant bits, so `k C1` and `k C2` are exact for `|k| < 2¹³` (which `|x| ≤ 8192`
//!     guarantees), and `x − k C1` is exact (below 3.3, on the grid of the coarser of
//!     `ulp(x)` and 2⁻⁷, so it fits 24 bits);
//!     the subtractions of `k C2` and `k C3` round once each (u/2 each, `|r| < 1`), `k C3`
//!     (below 4e-4) and the part of π/2 beyond C3 (1.8e-15 k) add less than 1e-11: ≤ u;
//!   - Cephes' `sinf`/`cosf` minimax polynomials on `[−π/4, π/4]`: approximation error
//!     below u/2;
//!   - Horner evaluation: the correction terms are below 0.09 (sin) and 0.32 (cos) of the
//!     result, so their roundings cost under u/4; the last additions round once (sin) or
//!     twice (cos) at magnitude ≤ 1: ≤ 1.25 u;
//!   - total ≤ 2.75 u, which the bound covers three times over (measured: 1.3 u).
//!
//!   Since `sin`/`cos` have slope at most 1 this is also an angle error, far below the
//!   physical resolution: one encoder count is `1 / counts_per_joint_rad` = 1.5e-4 rad on the
//!   default device, 320 times the bound.
//! - [`sqrt`]: relative error at most [`SQRT_MAX_REL_ERROR`] `= 4 ε32 = 8 u` for every
//!   non-negative finite `x`. The exponent-halving bit trick (Lomont's constant `0x5f375a86`:
//!   relative error of `1/√x` at most 3.5e-2) and three Newton steps `y ← y (3 − x y²)/2`
//!   (error e → 3e²/2: 1.8e-3, 4.8e-6, 3.5e-11) leave the roundings of the last step (`y²`,
//!   `x y²`, `1.5 − ½ x y²`, the product with `y`: ≤ 4 u) and of `x y` (u): ≤ 5 u
//!   (measured: 3.1 u).

use core::f32::consts::FRAC_2_PI;

/// Largest `|x|` (rad) for which [`sin_cos`] keeps its error bound (`|k| < 2¹³` in the range
/// reduction). Every pose of the pantograph is within a revolution of zero.
pub const SIN_COS_MAX_ANGLE_RAD: f32 = 8192.0;

/// Bound on the absolute error of [`sin_cos`] for `|x| ≤` [`SIN_COS_MAX_ANGLE_RAD`]:
/// `4 ε32` (see the module docs).
pub const SIN_COS_MAX_ERROR: f32 = 4.0 * f32::EPSILON;

/// Bound on the relative error of [`sqrt`]: `4 ε32` (see the module docs).
pub const SQRT_MAX_REL_ERROR: f32 = 4.0 * f32::EPSILON;

/// π/2 = C1 + C2 + C3: C1 = 201 · 2⁻⁷ and C2 = 2029 · 2⁻²² (8 and 11 significant bits),
/// C3 the rest rounded to f32 (the remainder, 1.8e-15, is below 2⁻⁴⁸).
const PIO2_C1: f32 = 201.0 / 128.0;
const PIO2_C2: f32 = 2029.0 / 4_194_304.0;
const PIO2_C3: f32 = 7.549_79e-8;

/// `(sin x, cos x)` for `|x| ≤` [`SIN_COS_MAX_ANGLE_RAD`], within [`SIN_COS_MAX_ERROR`];
/// `None` for larger or non-finite `x`. No `libm` call.
pub fn sin_cos(x: f32) -> Option<(f32, f32)> {
    if x.is_nan() || x.abs() > SIN_COS_MAX_ANGLE_RAD {
        return None;
    }
    let t = x * FRAC_2_PI;
    // Round to nearest (half away from zero); the cast cannot saturate within the range.
    let k = (t + if t < 0.0 { -0.5 } else { 0.5 }) as i32;
    let kf = k as f32;
    let r = ((x - kf * PIO2_C1) - kf * PIO2_C2) - kf * PIO2_C3;
    let z = r * r;
    // Cephes sinf.c / cosf.c minimax polynomials on [−π/4, π/4].
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    // sin(r + k π/2), cos(r + k π/2) by quadrant.
    Some(match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    })
}

/// `√x` within [`SQRT_MAX_REL_ERROR`] for finite `x ≥ 0` (subnormals included); `+∞` for
/// `+∞`, NaN for negative or NaN `x`. No `libm` call.
pub fn sqrt(x: f32) -> f32 {
    if (f32::MIN_POSITIVE..f32::INFINITY).contains(&x) {
        sqrt_normal(x)
    } else if x == 0.0 || x == f32::INFINITY {
        x
    } else if x > 0.0 {
        // Subnormal: √(x 2⁴⁸) 2⁻²⁴, both powers of two exact.
        sqrt_normal(x * 281_474_976_710_656.0) * (1.0 / 16_777_216.0)
    } else {
        f32::NAN
    }
}

fn sqrt_normal(x: f32) -> f32 {
    // Lomont's constant: 1/√x to 3.4e-2 from halving the biased exponent.
    let mut y = f32::from_bits(0x5f37_5a86 - (x.to_bits() >> 1));
    let half_x = 0.5 * x;
    for _ in 0..3 {
        y *= 1.5 - half_x * y * y;
    }
    x * y
}

/// The smaller of `a` and `b`: one comparison, no `fminf` call. Equal to `a.min(b)` when `a`
/// is not NaN (a NaN `b` gives `a`, as `f32::min` does), so pass first the operand that
/// cannot be NaN (a limit, a constant); a NaN `a` gives NaN.
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// The larger of `a` and `b`: one comparison, no `fmaxf` call. Equal to `a.max(b)` when `a`
/// is not NaN (a NaN `b` gives `a`, as `f32::max` does), so pass first the operand that
/// cannot be NaN (a limit, a constant); a NaN `a` gives NaN.
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}
