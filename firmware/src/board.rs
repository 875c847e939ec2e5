//! What the app needs from a board. The pantograph's board implements it with timers in
//! encoder mode, PWM, a driver-enable pin and USB; the QEMU binary with the simulated
//! pantograph ([`device::simulator`]) and an emulated clock. Both run the same [`App`].
//!
//! [`App`]: crate::app::App

/// The board's side of the haptic loop. Every method is called from the tick and must be
/// bounded and non-blocking: no waiting on a peripheral, no allocation, no panic.
pub trait Board {
    /// Raw counts of the two joint encoders (wrapping, as the hardware counters give them).
    fn encoder_counts(&mut self) -> [i32; 2];

    /// Commands the two motor currents (A), already within the device's limits.
    fn set_motor_currents(&mut self, currents_a: [f32; 2]);

    /// Drives the motor drivers' enable line: low (`false`) unless forces are on. A board
    /// also keeps it low while faults are latched ([`Board::set_faults`]).
    fn set_driver_enabled(&mut self, enabled: bool);

    /// The tick's latched fault flags (`device::safety::Faults` bits), given before
    /// [`Board::set_driver_enabled`] on every tick. The default ignores them (the safety layer
    /// already cuts the currents; the board's own enable line adds a second cut).
    fn set_faults(&mut self, faults: u16) {
        let _ = faults;
    }

    /// The monotonic clock, integer microseconds (see `device::controller`, "Time").
    fn now_us(&mut self) -> u64;

    /// Queues link bytes (one protocol frame) for the host; drops them when the queue is full
    /// (the tick never waits for the link).
    fn link_send(&mut self, frame: &[u8]);

    /// Takes received link bytes into `buf`, returns how many (0 when none are waiting).
    fn link_receive(&mut self, buf: &mut [u8]) -> usize;

    /// The duration of the last [`Board::around_tick`] in µs, for the telemetry's
    /// `tick_us`, when the board measures it; the default `None` leaves the field 0.
    fn last_tick_us(&mut self) -> Option<u16> {
        None
    }

    /// Runs `tick` (one `Controller::tick`, nothing else). A board that measures the tick's
    /// cost brackets it here; the default just runs it.
    fn around_tick<R>(&mut self, tick: impl FnOnce() -> R) -> R {
        tick()
    }
}
