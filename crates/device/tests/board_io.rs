//! The board's glue arithmetic against references that do not come from it: the true
//! encoder count of a simulated shaft, the driver's scaling written out (duty = |I| / full
//! scale), and the LED table of the firmware README.

use device::board_io::{Extend16, LedPattern, pwm_duty};
use proptest::prelude::*;

/// The 16-bit counter of a shaft at true count `count` whose counter read `offset` at 0.
fn counter(offset: u16, count: i64) -> u16 {
    (i64::from(offset) + count).rem_euclid(1 << 16) as u16
}

/// A shaft turning up across several wraps of the 16-bit counter and back down past zero
/// into negative counts across as many: the extended count is the true count at every read.
#[test]
fn extend16_follows_the_true_count_across_wraps_both_ways() {
    for offset in [0u16, 1, 32_767, 32_768, 65_530, u16::MAX] {
        let mut extended = Extend16::new(counter(offset, 0));
        let mut count = 0i64;
        let mut wraps = 0;
        for step in core::iter::repeat_n(300i64, 1000).chain(core::iter::repeat_n(-257, 2500)) {
            let before = counter(offset, count);
            count += step;
            let raw = counter(offset, count);
            if (step > 0 && raw < before) || (step < 0 && raw > before) {
                wraps += 1;
            }
            assert_eq!(
                i64::from(extended.update(raw)),
                count,
                "offset {offset}, true count {count}"
            );
        }
        assert_eq!(count, 300_000 - 642_500);
        assert!(wraps >= 14, "{wraps} wraps");
    }
}

/// The largest steps either way that the extension takes: ±32,767 counts between reads; one
/// more (32,768) is indistinguishable from −32,768 on a 16-bit counter.
#[test]
fn extend16_takes_steps_up_to_half_the_counter_range() {
    let mut e = Extend16::new(100);
    assert_eq!(e.update(counter(100, 32_767)), 32_767);
    assert_eq!(e.update(counter(100, 0)), 0);
    assert_eq!(e.update(counter(100, -32_767)), -32_767);
    assert_eq!(e.count(), -32_767);
    let mut e = Extend16::new(0);
    assert_eq!(e.update(counter(0, 32_768)), -32_768);
}

proptest! {
    /// Any walk whose steps stay within ±32,767: the extension is the sum of the steps (the
    /// true count), wrapping as an `i32` as the controller's counts do.
    #[test]
    fn extend16_is_the_sum_of_the_steps(
        offset in any::<u16>(),
        steps in prop::collection::vec(-32_767i64..=32_767, 1..200),
    ) {
        let mut e = Extend16::new(offset);
        let mut count = 0i64;
        for step in steps {
            count += step;
            prop_assert_eq!(e.update(counter(offset, count)), count as i32);
        }
    }
}

/// TIM1 at 96 MHz and 20 kHz counts to 4800: the duty at a few currents, worked out as
/// 4800 · |I| / 2 A by hand.
#[test]
fn pwm_duty_is_the_current_over_full_scale_and_saturates() {
    let (full_scale_a, max) = (2.0, 4800);
    for (current_a, duty) in [
        (0.0, 0),
        (-0.0, 0),
        (0.5, 1200),
        (-0.5, 1200),
        (1.0, 2400),
        (-1.5, 3600),
        (2.0, 4800),
        (-2.0, 4800),
        // Beyond the full scale: saturated, not wrapped.
        (2.5, 4800),
        (-3.0, 4800),
        (1e30, 4800),
        (f32::INFINITY, 4800),
        (f32::NEG_INFINITY, 4800),
        // No number: motor off.
        (f32::NAN, 0),
    ] {
        assert_eq!(
            pwm_duty(current_a, full_scale_a, max),
            duty,
            "{current_a} A"
        );
    }
    // The smallest step: one count is 2 A / 4800.
    assert_eq!(pwm_duty(2.0 / 4800.0 * 1.01, full_scale_a, max), 1);
    assert_eq!(pwm_duty(2.0 / 4800.0 * 0.99, full_scale_a, max), 0);
}

proptest! {
    /// Within one count of the exact (f64) |I| / full scale · max, clamped; the same for ±I;
    /// never above `max`.
    #[test]
    fn pwm_duty_is_within_one_count_of_the_exact_scaling(
        current_a in -10.0f32..10.0,
        full_scale_a in 0.1f32..5.0,
        max in 1u16..=u16::MAX,
    ) {
        let duty = pwm_duty(current_a, full_scale_a, max);
        let exact = (f64::from(current_a.abs()) / f64::from(full_scale_a)).min(1.0)
            * f64::from(max);
        prop_assert!(duty <= max);
        prop_assert!((f64::from(duty) - exact.floor()).abs() <= 1.0, "{duty} vs {exact}");
        prop_assert_eq!(duty, pwm_duty(-current_a, full_scale_a, max));
    }
}

/// The README's LED table: the lit milliseconds of each second, per state.
#[test]
fn led_patterns_are_the_readme_table() {
    let lit_ms = |pattern: LedPattern| -> Vec<(u32, u32)> {
        // The lit intervals [start, end) over one second.
        let mut intervals = Vec::new();
        let mut start = None;
        for ms in 0..=1000 {
            match (ms < 1000 && pattern.lit(ms), start) {
                (true, None) => start = Some(ms),
                (false, Some(s)) => {
                    intervals.push((s, ms));
                    start = None;
                }
                _ => {}
            }
        }
        intervals
    };
    // 5 Hz blink: 100 ms on, 100 ms off.
    assert_eq!(
        lit_ms(LedPattern::Fault),
        [(0, 100), (200, 300), (400, 500), (600, 700), (800, 900)]
    );
    assert_eq!(lit_ms(LedPattern::Driving), [(0, 1000)]);
    // A 100 ms blip every second.
    assert_eq!(lit_ms(LedPattern::Calibrated), [(0, 100)]);
    // 1 Hz blink, 500 ms on.
    assert_eq!(lit_ms(LedPattern::Uncalibrated), [(0, 500)]);
    // Every second the same.
    for pattern in [
        LedPattern::Fault,
        LedPattern::Driving,
        LedPattern::Calibrated,
        LedPattern::Uncalibrated,
    ] {
        for ms in (0..5000).step_by(7) {
            assert_eq!(pattern.lit(ms), pattern.lit(ms % 1000), "{pattern:?} {ms}");
        }
    }
}

/// A fault wins over everything, then the drivers enabled, then calibration.
#[test]
fn led_pattern_precedence() {
    for calibrated in [false, true] {
        for driving in [false, true] {
            assert_eq!(
                LedPattern::of(1 << 3, calibrated, driving),
                LedPattern::Fault
            );
            assert_eq!(
                LedPattern::of(0xFFFF, calibrated, driving),
                LedPattern::Fault
            );
        }
        assert_eq!(LedPattern::of(0, calibrated, true), LedPattern::Driving);
    }
    assert_eq!(LedPattern::of(0, true, false), LedPattern::Calibrated);
    assert_eq!(LedPattern::of(0, false, false), LedPattern::Uncalibrated);
}
