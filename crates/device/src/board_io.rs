//! A board's inputs and outputs as pure functions, so that the arithmetic of the firmware's
//! glue is tested on the host: the 16-bit encoder counters extended to the controller's
//! 32-bit counts ([`Extend16`]), a motor current as a PWM duty ([`pwm_duty`]) and the status
//! LED's pattern ([`LedPattern`]). The firmware (`firmware/src/bin/board.rs`) reads the
//! timers, writes the compare registers and the pin with them.

/// A 16-bit hardware encoder counter extended to the 32-bit count the controller takes
/// (wrapping, as `i32`), by adding the wrapping difference of successive readings as a
/// signed 16-bit step. Correct while the counter moves less than 32,768 counts between two
/// readings in either direction (the board reads it every tick: a few hundred counts at
/// most); a step of exactly 32,768 reads as −32,768.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Extend16 {
    last: u16,
    count: i32,
}

impl Extend16 {
    /// Starts at count 0 with the counter reading `raw`.
    pub const fn new(raw: u16) -> Self {
        Extend16 {
            last: raw,
            count: 0,
        }
    }

    /// The count after the counter read `raw`: the previous count plus the signed step.
    pub fn update(&mut self, raw: u16) -> i32 {
        self.count = self
            .count
            .wrapping_add(i32::from(raw.wrapping_sub(self.last) as i16));
        self.last = raw;
        self.count
    }

    /// The count of the last [`Extend16::update`] (0 before any).
    pub fn count(&self) -> i32 {
        self.count
    }
}

/// The PWM compare value for a motor current `current_a` (A) on a driver whose full scale
/// (100 % duty) is `full_scale_a`: `|I| / full scale` of `max_duty`, rounded down, clamped to
/// `0 ..= max_duty`; a NaN gives 0 (motor off). The sign is the direction pin's, not the
/// duty's.
pub fn pwm_duty(current_a: f32, full_scale_a: f32, max_duty: u16) -> u16 {
    let fraction = current_a.abs() / full_scale_a;
    let fraction = if fraction.is_nan() || fraction <= 0.0 {
        0.0
    } else if fraction >= 1.0 {
        1.0
    } else {
        fraction
    };
    (fraction * f32::from(max_duty)) as u16
}

/// What the status LED shows, from the tick's state (the firmware README's table), in this
/// order of precedence: a latched fault, then the drivers enabled, then calibration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LedPattern {
    /// A fault is latched (forces cut): 5 Hz blink, 100 ms on, 100 ms off.
    Fault,
    /// The drivers are enabled, no fault: steady on.
    Driving,
    /// Calibrated, forces off: a 100 ms blip at the start of every second.
    Calibrated,
    /// Not calibrated yet: 1 Hz blink, on for the first 500 ms of every second.
    Uncalibrated,
}

impl LedPattern {
    /// The pattern for latched `faults` (bits), calibration and whether the drivers are
    /// enabled.
    pub fn of(faults: u16, calibrated: bool, driving: bool) -> Self {
        if faults != 0 {
            LedPattern::Fault
        } else if driving {
            LedPattern::Driving
        } else if calibrated {
            LedPattern::Calibrated
        } else {
            LedPattern::Uncalibrated
        }
    }

    /// Whether the LED is lit `ms` milliseconds after any whole second of the board's time
    /// (only `ms` modulo 1000 matters).
    pub fn lit(self, ms: u32) -> bool {
        let ms = ms % 1000;
        match self {
            LedPattern::Fault => ms % 200 < 100,
            LedPattern::Driving => true,
            LedPattern::Calibrated => ms < 100,
            LedPattern::Uncalibrated => ms < 500,
        }
    }
}
