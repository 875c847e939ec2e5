//! Telemetry at the link's rate from a faster tick: [`TelemetryDecimator`] folds the frames of
//! `N` consecutive ticks into one, so that a board ticking at 10 kHz sends one frame per
//! millisecond (USB HID's report rate, [`TELEMETRY_HZ`]) without hiding what happened in
//! between. The frame has no room for more fields (its 57-byte payload fills a 64-byte frame),
//! so the window is folded into the existing ones.
//!
//! # The rule
//!
//! For a window of `N` ticks, the frame is:
//!
//! - **the frame of the tick with the largest |F|** (`force_n`, the force after the safety
//!   layer, compared as the squared length), ties going to the latest tick: its time, HIP, CP,
//!   GO, forces, Ψ, μ and feature, all of one tick, so they stay consistent with each other;
//! - **faults**: the OR of the window's fault bits, so a fault that latched and was cleared
//!   inside the window still shows;
//! - **tick duration**: the window's largest `tick_us`;
//! - **mode and cause** (the friction state): the (mode, cause) of the window's latest tick
//!   whose (mode, cause) differs from the one the previous frame reported; the previous
//!   frame's when no tick of the window differs from it. Usually that is the window's last
//!   tick's (the state now). But a change that went and came back inside the window (stick →
//!   slip → stick within 1 ms, which leaves the same mode and cause as before) would vanish
//!   if the frame carried only the end state: instead it carries the last state the window
//!   passed through that the host has not been told, and the next frame brings the end
//!   state. So every window with a mode switch gives a frame whose (mode, cause) differs from
//!   the previous frame's, one frame late at worst. (The cause is the renderer's "why the mode
//!   last changed", which stays until the next switch, so (mode, cause) changes exactly when
//!   the renderer switches.) The mode and cause may therefore belong to another tick of the
//!   window than the force fields.
//!
//! With `N = 1` every frame is its tick's, unchanged. The decimator runs on the device (the
//! firmware's app) and in the host's run of the device (`host::closed_loop::run_device`) alike, so
//! the emulated board's frames can be compared with the host's bit for bit.
//!
//! No allocation, no panic; a push costs a comparison of |F|² and at most one copy of a frame.

use friction::{Mode, SwitchCause};

use nurbs::Vec2;
use tracker::Feature;

/// The telemetry rate a board's link carries (Hz): one 64-byte frame per millisecond.
pub const TELEMETRY_HZ: u32 = 1_000;

/// One haptic tick, as the device reports it (planar: the pantograph's plane).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Telemetry {
    /// Device time at the start of the tick (µs, wraps after 71 min).
    pub time_us: u32,
    /// Haptic interface point (m, device frame).
    pub hip_m: Vec2,
    /// Closest point on the active feature (m).
    pub cp_m: Vec2,
    /// God-object (m).
    pub go_m: Vec2,
    /// Normal force magnitude (N).
    pub force_normal_n: f32,
    /// The GO's parameter `u` on its patch (the parameter of the scene's patch, which the
    /// pieces it is split into share): where the force acts, for a host that deforms the
    /// object; 0 when nothing renders. (The friction force that had this slot follows from
    /// the total and normal forces.)
    pub go_param: f32,
    /// Total force commanded (N, device frame).
    pub force_n: Vec2,
    /// Projection error Ψ of the tracker (first parameter).
    pub psi: f32,
    /// Friction coefficient in use, in units of 1e-4 ([`Telemetry::mu`]).
    pub mu_e4: u16,
    /// Duration of the tick's computation (µs, saturated).
    pub tick_us: u16,
    /// Latched fault flags.
    pub faults: u16,
    /// Feature the closest point lies on; `None` out of contact or before tracking.
    pub feature: Option<Feature>,
    /// Friction mode.
    pub mode: Mode,
    /// Why the friction mode last changed (carried in the mode byte's high nibble).
    pub cause: SwitchCause,
}

impl Telemetry {
    /// The frame of a tick that rendered nothing, at time 0.
    pub const IDLE: Telemetry = Telemetry {
        time_us: 0,
        hip_m: Vec2::ZERO,
        cp_m: Vec2::ZERO,
        go_m: Vec2::ZERO,
        force_normal_n: 0.0,
        go_param: 0.0,
        force_n: Vec2::ZERO,
        psi: 0.0,
        mu_e4: 0,
        tick_us: 0,
        faults: 0,
        feature: None,
        mode: Mode::Free,
        cause: SwitchCause::None,
    };

    /// The friction coefficient.
    pub fn mu(&self) -> f32 {
        f32::from(self.mu_e4) * 1e-4
    }

    /// `mu` quantised for [`Telemetry::mu_e4`] (saturating, NaN → 0).
    pub fn quantize_mu(mu: f32) -> u16 {
        let q = mu * 1e4 + 0.5;
        if q.is_nan() || q <= 0.0 {
            0
        } else if q >= 65535.0 {
            u16::MAX
        } else {
            q as u16
        }
    }
}

/// Folds the telemetry of `N` ticks into one frame (rule in the module docs).
#[derive(Clone, Copy, Debug)]
pub struct TelemetryDecimator {
    ticks_per_frame: u32,
    /// Ticks pushed in the current window.
    count: u32,
    /// The window's frame so far: the tick with the largest |F|.
    frame: Telemetry,
    peak_force_sq: f32,
    faults: u16,
    tick_us: u16,
    /// The (mode, cause) the last frame carried.
    reported: (Mode, SwitchCause),
    /// The latest (mode, cause) of the window that differs from `reported`.
    changed: Option<(Mode, SwitchCause)>,
}

impl TelemetryDecimator {
    /// One frame per `ticks_per_frame` ticks (0 counts as 1). The first frame reports its
    /// friction state against free with no switch (the renderer's state before any tick).
    pub const fn new(ticks_per_frame: u32) -> Self {
        TelemetryDecimator {
            ticks_per_frame: if ticks_per_frame == 0 {
                1
            } else {
                ticks_per_frame
            },
            count: 0,
            frame: Telemetry::IDLE,
            peak_force_sq: 0.0,
            faults: 0,
            tick_us: 0,
            reported: (Mode::Free, SwitchCause::None),
            changed: None,
        }
    }

    /// The decimator for a tick of period `period_s`: [`Self::ticks_per_frame_at`] ticks per
    /// frame.
    pub fn for_period_s(period_s: f32) -> Self {
        Self::new(Self::ticks_per_frame_at(period_s))
    }

    /// Ticks per frame for a tick of period `period_s` and frames at [`TELEMETRY_HZ`]: the
    /// nearest whole number to the ratio of the periods, at least 1 (a tick slower than the
    /// link sends every frame; NaN, zero or negative periods give 1).
    pub fn ticks_per_frame_at(period_s: f32) -> u32 {
        if period_s.is_nan() || period_s <= 0.0 {
            return 1;
        }
        let ratio = 1.0 / (TELEMETRY_HZ as f32 * period_s);
        // `as` saturates (a tiny period's huge ratio gives u32::MAX ticks per frame).
        ((ratio + 0.5) as u32).max(1)
    }

    /// Ticks per frame.
    pub fn ticks_per_frame(&self) -> u32 {
        self.ticks_per_frame
    }

    /// Adds one tick's frame; returns the window's frame after its last tick, `None` before.
    pub fn push(&mut self, tick: &Telemetry) -> Option<&Telemetry> {
        let f = tick.force_n;
        let force_sq = f.x * f.x + f.y * f.y;
        if self.count == 0 {
            self.frame = *tick;
            self.peak_force_sq = force_sq;
            self.faults = tick.faults;
            self.tick_us = tick.tick_us;
            self.changed = None;
        } else {
            // Ties to the latest; a NaN peak (never from the controller) is replaced.
            if force_sq >= self.peak_force_sq || self.peak_force_sq.is_nan() {
                self.frame = *tick;
                self.peak_force_sq = force_sq;
            }
            self.faults |= tick.faults;
            self.tick_us = self.tick_us.max(tick.tick_us);
        }
        let state = (tick.mode, tick.cause);
        if state != self.reported {
            self.changed = Some(state);
        }
        self.count += 1;
        if self.count < self.ticks_per_frame {
            return None;
        }
        self.count = 0;
        let (mode, cause) = self.changed.unwrap_or(self.reported);
        self.reported = (mode, cause);
        let frame = &mut self.frame;
        frame.faults = self.faults;
        frame.tick_us = self.tick_us;
        frame.mode = mode;
        frame.cause = cause;
        Some(frame)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nurbs::Vec2;
    use tracker::Feature;

    /// A stuck tick at `time_us` with force `(fx, 0)` and `faults`; every other field derived
    /// from the time, so that the chosen tick is recognisable by any of its fields.
    fn tick(time_us: u32, fx: f32) -> Telemetry {
        let k = time_us as f32;
        Telemetry {
            time_us,
            hip_m: Vec2::new(k, -k),
            cp_m: Vec2::new(2.0 * k, 0.0),
            go_m: Vec2::new(3.0 * k, 0.0),
            force_normal_n: fx,
            go_param: 0.5 * fx,
            force_n: Vec2::new(fx, 0.0),
            psi: k,
            mu_e4: time_us as u16,
            tick_us: 30,
            faults: 0,
            feature: Some(Feature::Patch(time_us as u16 % 3)),
            mode: Mode::Stuck,
            cause: SwitchCause::Contact,
        }
    }

    /// Pushes `ticks` and returns the frames it gave.
    fn frames(d: &mut TelemetryDecimator, ticks: &[Telemetry]) -> Vec<Telemetry> {
        ticks.iter().filter_map(|t| d.push(t).copied()).collect()
    }

    #[test]
    fn one_tick_per_frame_passes_every_frame_unchanged() {
        let mut d = TelemetryDecimator::new(1);
        let mut ticks: Vec<_> = (0..6).map(|k| tick(k, k as f32)).collect();
        ticks[1].mode = Mode::Free;
        ticks[1].cause = SwitchCause::None;
        ticks[3].faults = 0x4;
        ticks[4].mode = Mode::Slip;
        ticks[4].cause = SwitchCause::Converged;
        assert_eq!(frames(&mut d, &ticks), ticks);
    }

    #[test]
    fn a_spike_in_the_middle_is_the_frame() {
        let mut d = TelemetryDecimator::new(10);
        // 1 N everywhere but 5 N at tick 14 (time 114), in the middle of the second window.
        let mut ticks: Vec<_> = (100..120).map(|k| tick(k, 1.0)).collect();
        ticks[14] = tick(114, -5.0);
        let out = frames(&mut d, &ticks);
        assert_eq!(out.len(), 2, "20 ticks, 10 per frame");
        // The first window is all ties: the latest tick's frame.
        assert_eq!(out[0], ticks[9]);
        // The spike's whole frame, negative x included (|F|, not F).
        assert_eq!(out[1], ticks[14]);
        assert_eq!(out[1].force_n, Vec2::new(-5.0, 0.0));
    }

    #[test]
    fn windows_start_afresh() {
        // A big force in one window does not win the next one.
        let mut d = TelemetryDecimator::new(3);
        let ticks = [
            tick(0, 9.0),
            tick(1, 1.0),
            tick(2, 1.0),
            tick(3, 2.0),
            tick(4, 1.0),
            tick(5, 0.5),
        ];
        let out = frames(&mut d, &ticks);
        assert_eq!(out, [ticks[0], ticks[3]]);
    }

    #[test]
    fn a_fault_seen_inside_a_window_is_reported_even_if_cleared() {
        let mut d = TelemetryDecimator::new(10);
        let mut ticks: Vec<_> = (0..20).map(|k| tick(k, 1.0)).collect();
        // Bit 0x1 on ticks 2..5 (then cleared), bit 0x8 on tick 7 only.
        for t in &mut ticks[2..5] {
            t.faults = 0x1;
        }
        ticks[7].faults = 0x8;
        let out = frames(&mut d, &ticks);
        assert_eq!(out[0].faults, 0x9);
        // Its other fields are the last (tied) tick's, whose own faults were clear.
        assert_eq!(out[0].time_us, 9);
        assert_eq!(out[1].faults, 0, "the next window has none");
    }

    #[test]
    fn the_longest_tick_is_reported() {
        let mut d = TelemetryDecimator::new(4);
        let mut ticks: Vec<_> = (0..4).map(|k| tick(k, 1.0)).collect();
        ticks[1].tick_us = 77;
        let out = frames(&mut d, &ticks);
        assert_eq!(out[0].tick_us, 77);
        assert_eq!(out[0].time_us, 3);
    }

    #[test]
    fn a_switch_and_back_inside_a_window_still_shows() {
        let mut d = TelemetryDecimator::new(10);
        let stuck = (Mode::Stuck, SwitchCause::Stopped);
        let set = |t: &mut Telemetry, (mode, cause): (Mode, SwitchCause)| {
            t.mode = mode;
            t.cause = cause;
        };
        let mut ticks: Vec<_> = (0..40).map(|k| tick(k, 1.0)).collect();
        for t in &mut ticks {
            set(t, stuck);
        }
        // Window 1: stuck → transition → slip → stuck again, all inside it.
        set(&mut ticks[12], (Mode::Transition, SwitchCause::Breakaway));
        set(&mut ticks[13], (Mode::Slip, SwitchCause::Converged));
        set(&mut ticks[14], (Mode::Slip, SwitchCause::Converged));
        // Window 3: a switch that stays (slip from tick 35 on).
        for t in &mut ticks[35..] {
            set(t, (Mode::Slip, SwitchCause::Breakaway));
        }
        let out = frames(&mut d, &ticks);
        let states: Vec<_> = out.iter().map(|f| (f.mode, f.cause)).collect();
        assert_eq!(
            states,
            [
                // Window 0: the first state differs from the initial free one.
                stuck,
                // Window 1 ends where it began; its last state the host was not told is slip.
                (Mode::Slip, SwitchCause::Converged),
                // Window 2, no switch: the state now, a change from the frame before.
                stuck,
                (Mode::Slip, SwitchCause::Breakaway),
            ]
        );
        // The force fields stay the latest tick's (all tied): only mode and cause moved.
        assert_eq!(out[1].time_us, 19);
    }

    #[test]
    fn without_a_switch_the_state_is_the_ticks() {
        let mut d = TelemetryDecimator::new(5);
        let out = frames(&mut d, &(0..15).map(|k| tick(k, 1.0)).collect::<Vec<_>>());
        for f in &out {
            assert_eq!((f.mode, f.cause), (Mode::Stuck, SwitchCause::Contact));
        }
        // A window of free ticks after contact reports free (a change from the frame before).
        let free = Telemetry {
            mode: Mode::Free,
            cause: SwitchCause::Released,
            feature: None,
            ..tick(20, 0.0)
        };
        let out = frames(&mut d, &[free; 5]);
        assert_eq!(out, [free]);
    }

    #[test]
    fn ticks_per_frame_follows_the_period() {
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(1e-3), 1);
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(5e-4), 2);
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(2e-4), 5);
        // 1/10 kHz is not exact in f32: the nearest whole ratio.
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(1.0 / 10_000.0), 10);
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(0.01), 1);
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(f32::NAN), 1);
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(-1.0), 1);
        assert_eq!(TelemetryDecimator::ticks_per_frame_at(0.0), 1);
        assert_eq!(TelemetryDecimator::new(0).ticks_per_frame(), 1);
    }
}
