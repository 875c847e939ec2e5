//! The tick's elementary functions against `f64` (`std`'s correctly rounded-enough `sin`,
//! `cos`, `sqrt` of the same f32 input), to the bounds the module derives.

use nurbs::math::{self, SIN_COS_MAX_ANGLE_RAD, SIN_COS_MAX_ERROR, SQRT_MAX_REL_ERROR};
use proptest::prelude::*;

fn sin_cos_error(x: f32) -> f64 {
    let (s, c) = math::sin_cos(x).expect("in range");
    let x64 = f64::from(x);
    (f64::from(s) - x64.sin())
        .abs()
        .max((f64::from(c) - x64.cos()).abs())
}

/// Every f32 step of 2⁻¹⁶ rad over the joints' whole physical range (a revolution either
/// side of zero covers every pose and both end stops of the default device), the quadrant
/// boundaries k π/4 and the ends of the accepted range.
#[test]
fn sin_cos_is_within_its_bound_over_the_joint_range() {
    let mut worst = 0.0f64;
    let mut samples = 0usize;
    let step = 1.0 / 65_536.0;
    let mut x = -core::f32::consts::TAU;
    while x <= core::f32::consts::TAU {
        worst = worst.max(sin_cos_error(x));
        samples += 1;
        x += step;
    }
    for k in -16..=16 {
        let b = k as f32 * core::f32::consts::FRAC_PI_4;
        for x in [
            b,
            f32::from_bits(b.to_bits() + 1),
            f32::from_bits(b.to_bits().saturating_sub(1)),
        ] {
            worst = worst.max(sin_cos_error(x));
        }
    }
    for x in [
        SIN_COS_MAX_ANGLE_RAD,
        -SIN_COS_MAX_ANGLE_RAD,
        8191.3,
        -5000.7,
        1e-30,
        0.0,
        -0.0,
    ] {
        worst = worst.max(sin_cos_error(x));
    }
    eprintln!("sin_cos: {samples} samples, largest error {worst:e}");
    assert!(samples > 800_000, "{samples}");
    assert!(
        worst <= f64::from(SIN_COS_MAX_ERROR),
        "largest error {worst:e} > {SIN_COS_MAX_ERROR:e}"
    );
    // The reference is independent: the polynomial is not libm's, so it differs somewhere
    // by at least one rounding of a value near 1 (u = 2⁻²⁴).
    assert!(worst >= f64::from(f32::EPSILON) / 2.0, "{worst:e}");
}

#[test]
fn sin_cos_refuses_what_it_cannot_reduce() {
    for x in [
        f32::NAN,
        f32::INFINITY,
        -f32::INFINITY,
        f32::MAX,
        8192.001,
        -1e5,
    ] {
        assert_eq!(math::sin_cos(x), None, "{x}");
    }
}

#[test]
fn sqrt_special_values() {
    assert_eq!(math::sqrt(0.0), 0.0);
    assert_eq!(math::sqrt(f32::INFINITY), f32::INFINITY);
    assert!(math::sqrt(-1.0).is_nan());
    assert!(math::sqrt(-f32::MIN_POSITIVE).is_nan());
    assert!(math::sqrt(f32::NAN).is_nan());
    // Perfect squares of powers of two come out exact (exponent arithmetic only).
    for e in -60..60 {
        let x = 2.0f32.powi(2 * e);
        let r = math::sqrt(x);
        assert!(
            (f64::from(r) / f64::from(2.0f32.powi(e)) - 1.0).abs() <= f64::from(SQRT_MAX_REL_ERROR)
        );
    }
}

fn sqrt_rel_error(x: f32) -> f64 {
    let r = f64::from(math::sqrt(x));
    let exact = f64::from(x).sqrt();
    (r - exact).abs() / exact
}

/// Every mantissa of two binades (the bit trick's error depends on the mantissa and the
/// exponent's parity only), plus the extremes.
#[test]
fn sqrt_is_within_its_bound_on_every_mantissa() {
    let mut worst = 0.0f64;
    for bits in 1.0f32.to_bits()..4.0f32.to_bits() {
        worst = worst.max(sqrt_rel_error(f32::from_bits(bits)));
    }
    for x in [f32::MIN_POSITIVE, f32::MAX, 1e-40, 1e-45, f32::from_bits(1)] {
        worst = worst.max(sqrt_rel_error(x));
    }
    eprintln!("sqrt: largest relative error {worst:e}");
    assert!(worst <= f64::from(SQRT_MAX_REL_ERROR), "{worst:e}");
    assert!(worst >= f64::from(f32::EPSILON) / 4.0, "{worst:e}");
}

proptest! {
    #[test]
    fn sin_cos_anywhere_in_range(x in -SIN_COS_MAX_ANGLE_RAD..=SIN_COS_MAX_ANGLE_RAD) {
        prop_assert!(sin_cos_error(x) <= f64::from(SIN_COS_MAX_ERROR));
    }

    #[test]
    fn sqrt_any_positive(bits in 0u32..0x7f80_0000) {
        let x = f32::from_bits(bits);
        if x > 0.0 {
            prop_assert!(sqrt_rel_error(x) <= f64::from(SQRT_MAX_REL_ERROR), "{x:e}");
        }
    }
}

/// `min`/`max` give `f32::min`/`f32::max`'s answer whenever the first operand is not NaN,
/// signed zeros and infinities included (the sign of a zero result may differ only when
/// both are zeros, which no caller distinguishes: compared as values).
#[test]
fn min_max_agree_with_core_when_the_first_operand_is_a_number() {
    let values = [
        f32::NEG_INFINITY,
        -f32::MAX,
        -1.5,
        -f32::MIN_POSITIVE,
        -0.0,
        0.0,
        f32::from_bits(1),
        0.25,
        3.0,
        f32::MAX,
        f32::INFINITY,
        f32::NAN,
    ];
    for a in values.into_iter().filter(|a| !a.is_nan()) {
        for b in values {
            assert_eq!(math::min(a, b), a.min(b), "min({a}, {b})");
            assert_eq!(math::max(a, b), a.max(b), "max({a}, {b})");
        }
    }
    assert!(math::min(f32::NAN, 1.0).is_nan() && math::max(f32::NAN, 1.0).is_nan());
}

/// Length of `v` in `f64`, independent of the crate's arithmetic.
fn length64(v: &[f32]) -> f64 {
    v.iter()
        .map(|&c| f64::from(c) * f64::from(c))
        .sum::<f64>()
        .sqrt()
}

/// Normalisation through [`math::sqrt`] keeps its derived bound: `|v|²` is `n` rounded
/// squares and `n − 1` rounded additions of non-negative terms (at most `(2n − 1) u` relative,
/// half that after the root), the root errs by at most `SQRT_MAX_REL_ERROR`, the reciprocal
/// and each component's product round once more (`2 u`); the f64 check is exact to far below
/// u. So `| |v / |v|| − 1 | ≤ 4 ε + ((2n − 1)/2 + 2) u`.
fn unit_length_bound(n: usize) -> f64 {
    let u = f64::from(f32::EPSILON) / 2.0;
    f64::from(SQRT_MAX_REL_ERROR) + ((2 * n - 1) as f64 / 2.0 + 2.0) * u
}

proptest! {
    #[test]
    fn try_normalize_gives_unit_vectors(
        x in -1e3f32..1e3, y in -1e3f32..1e3, z in -1e3f32..1e3, e in -40i32..40,
    ) {
        use nurbs::{Point, Vec2, Vec3};
        let s = 2.0f32.powi(e);
        let v3 = Vec3::new(x, y, z) * s;
        let v2 = Vec2::new(x, y) * s;
        if let Some(n) = Point::try_normalize(v3) {
            let err = (length64(&n.to_array()) - 1.0).abs();
            prop_assert!(err <= unit_length_bound(3), "{v3:?}: {err:e}");
            // Same direction: the normalised vector is a positive multiple of v.
            prop_assert!(n.dot(v3) > 0.0);
        } else {
            prop_assert!(v3.length_squared() <= f32::MIN_POSITIVE);
        }
        if let Some(n) = Point::try_normalize(v2) {
            let err = (length64(&n.to_array()) - 1.0).abs();
            prop_assert!(err <= unit_length_bound(2), "{v2:?}: {err:e}");
        } else {
            prop_assert!(v2.length_squared() <= f32::MIN_POSITIVE);
        }
    }
}
