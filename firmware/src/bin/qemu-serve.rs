//! The firmware under QEMU's `netduinoplus2` as a device the host talks to: the same [`App`]
//! as the board, the simulated pantograph (`device::simulator`) as the plant, held by a
//! virtual hand whose target the host sets ([`Message::HandTarget`]), and the protocol on the
//! emulated UART (USART1), COBS-framed like the host's serial link. `cargo xtask qemu --serve
//! 127.0.0.1:PORT` boots it with the UART on that TCP port; `cargo xtask qemu` runs a whole
//! host session against it.
//!
//! The device starts uncalibrated, forces off, with no scene, exactly as a board after reset.
//! One cooperative loop: it reads the link until no byte waits (every frame through
//! [`DeviceSession`], the device side of the link the host's simulator uses too), then runs the tick
//! when SysTick marks the next millisecond (1 kHz of the emulated 168 MHz core), then the
//! acquisition a scene load asks for (between ticks, as the board's lowest-priority task). One
//! scene store, as the board's (here at the host's full capacity, in `main`'s frame): a commit
//! is validated into it and the app's chain rebuilt from it at once, between two ticks
//! (`firmware::handover::take_in`); a control-point update ([`Message::ScenePoints`]) is
//! validated into it too and moves the app's chain onto the new points there (the renderer
//! carries on, no acquisition, no ramp-in).
//!
//! [`Message::ScenePoints`]: protocol::Message::ScenePoints
//!
//! [`Message::HandTarget`]: protocol::Message::HandTarget
//! [`App`]: firmware::app::App
#![no_std]
#![no_main]

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use device::safety::SafetyConfig;
use device::simulator::{SimParams, SimulatedPantograph, VirtualHand};
use device::spec::DeviceSpec;
use firmware::app::Parked;
use firmware::board::Board;
use firmware::handover::{self, Incoming, Validator};
use firmware::netduino::{Clock, SimulatedBoard};
use nurbs::Vec2;
use protocol::device_side::session::{DeviceSession, DeviceState, Event};
use protocol::{MAX_FRAME, Message, SceneStore};
use tracker::Chain;

/// The tick period.
const PERIOD_US: u64 = 1000;
/// SysTick's reload: 0.1 ms of the emulated 168 MHz core. Its interrupt only wakes the loop
/// from `wfi`; the ticks follow the clock (TIM2). The loop sleeps rather than polls because
/// every peripheral access of the emulated core takes QEMU's global lock, which its main loop
/// (the one that moves the host's bytes into the USART, one per turn) then rarely gets: a
/// polling loop left the link towards the device at a few hundred bytes a second.
const SYSTICK_RELOAD: u32 = 16_800 - 1;
/// The ramp-in of forces (s), as the host's simulator.
const RAMP_TIME_S: f32 = 0.02;
/// The watchdog's heartbeat timeout (s): 250 ms rather than a board's 100 ms, because QEMU on a
/// shared, loaded host is not real time: its process may stall for tens of milliseconds, and
/// the bytes of a heartbeat wait for it (measured: a 75 ms stall now and then on a 2-core
/// machine running builds beside it).
const HEARTBEAT_TIMEOUT_S: f32 = 0.25;
/// The scene receiver's capacity (bytes).
const SCENE_CAPACITY: usize = 4096;
/// Where the handle starts (m): as the host's simulator, `protocol::host_side::SimConfig`.
const START_M: Vec2 = Vec2::new(0.0, 0.09);

/// The bytes of one COBS packet as they arrive, up to its `0x00` delimiter.
struct Packet {
    bytes: [u8; cobs::max_encoding_length(MAX_FRAME) + 1],
    len: usize,
    overflow: bool,
}

impl Packet {
    /// Adds `byte`; at a delimiter returns the decoded frame bytes (empty when the packet is
    /// not COBS or too long, which the session then refuses as a bad frame).
    fn push(&mut self, byte: u8, frame: &mut [u8; MAX_FRAME]) -> Option<usize> {
        if byte != 0 {
            match self.bytes.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => self.overflow = true,
            }
            return None;
        }
        let packet = self.bytes.get(..self.len).unwrap_or(&[]);
        let n = if self.overflow || packet.is_empty() {
            None
        } else {
            cobs::decode(packet, frame).ok().map(|r| r.frame_size())
        };
        let empty = packet.is_empty() && !self.overflow;
        self.len = 0;
        self.overflow = false;
        // Back-to-back delimiters are line idle, not frames.
        if empty { None } else { Some(n.unwrap_or(0)) }
    }
}

fn fail(what: core::fmt::Arguments<'_>) -> ! {
    hprintln!("qemu-serve: FAILED: {}", what);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

#[entry]
fn main() -> ! {
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        fail(format_args!("core peripherals already taken"));
    };
    let mut syst = peripherals.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYSTICK_RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();

    let spec = DeviceSpec::default();
    // A firm hand, as the host's simulator (`protocol::host_side::SimConfig::default`).
    let hand = SimParams {
        hand_stiffness_n_per_m: 2000.0,
        hand_damping_ns_per_m: 5.0,
        ..SimParams::default()
    };
    let arm = match SimulatedPantograph::new(spec, hand, START_M) {
        Ok(arm) => arm,
        Err(e) => fail(format_args!("simulated pantograph: {e}")),
    };
    let mut board = SimulatedBoard::new(arm);
    let period_s = PERIOD_US as f32 * 1e-6;
    // The store and the app's chain slot live in `main`'s frame, which never returns.
    let mut scene_store: SceneStore = SceneStore::empty();
    let mut chain: Chain = Chain::EMPTY;
    let parked = match Parked::with_safety(
        &mut chain,
        SafetyConfig {
            period_s,
            ramp_time_s: RAMP_TIME_S,
            heartbeat_timeout_s: HEARTBEAT_TIMEOUT_S,
            ..SafetyConfig::default()
        },
    ) {
        Ok(p) => p,
        Err(e) => fail(format_args!("{e}")),
    };
    let mut session: DeviceSession<SCENE_CAPACITY> = DeviceSession::new(true);
    let mut store = Some(&mut scene_store);
    // No scene before the first upload: the app runs without force.
    let mut app = parked.unloaded();
    // An identification run beyond the app's motors is nacked before it is acked.
    session.set_motor_limits(app.controller().spec());
    let mut hand = VirtualHand::at(START_M);
    let mut packet = Packet {
        bytes: [0; cobs::max_encoding_length(MAX_FRAME) + 1],
        len: 0,
        overflow: false,
    };
    let mut clock = Clock::start();
    let mut due_us = 0u64;
    hprintln!("qemu-serve: ready");
    loop {
        let mut byte = [0u8; 1];
        while board.link_receive(&mut byte) == 1 {
            let mut frame = [0u8; MAX_FRAME];
            let Some(n) = packet.push(byte[0], &mut frame) else {
                continue;
            };
            let state = DeviceState::of(firmware::software_version(), app.controller());
            let event = session.handle(
                frame.get(..n).unwrap_or(&[]),
                &mut Validator::new(&mut store, false),
                state,
                &mut |m: &Message| app.send(&mut board, m),
            );
            let incoming = match event {
                Event::SceneCommitted => Some(Incoming::Scene),
                // The pantograph renders object 0; the others' points change nothing here.
                Event::ScenePointsUpdated { object: 0 } => Some(Incoming::Points),
                Event::ScenePointsUpdated { .. } | Event::None => None,
                Event::HandTarget(t) => {
                    hand.command(t);
                    None
                }
                Event::DeviceCommand(command) => {
                    // The simulated joints "rest on their end stops": the counts read there.
                    if let Err(code) = app.apply(command, spec.end_stop_counts()) {
                        session.note_error(code);
                    }
                    None
                }
            };
            // Between two ticks: the loop ticks below, after the link.
            // (The search runs in place, between ticks: the object is never lent here.)
            if let Some(incoming) = incoming
                && let Some(committed) = store.as_deref()
                && let Some(Err(e)) = handover::take_in(&mut app, incoming, committed)
            {
                session.note_error(e.code());
            }
        }
        let now_us = clock.now_us();
        if now_us >= due_us {
            // Ticks on the period's grid; after a stall (the host stopped QEMU) the grid
            // restarts rather than racing through the missed ticks.
            due_us = if now_us - due_us > 100 * PERIOD_US {
                now_us + PERIOD_US
            } else {
                due_us + PERIOD_US
            };
            board.now_us = now_us;
            app.tick(&mut board);
            // An arm driven into a singular pose stays there, as a real one on its stops.
            let _ = board.step_plant(hand.step(period_s), period_s);
            app.acquire();
        }
        cortex_m::asm::wfi();
    }
}

/// Only wakes the loop from `wfi`.
#[exception]
fn SysTick() {}

#[exception]
#[allow(unsafe_code)]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    fail(format_args!("HardFault at pc={:#010x}", frame.pc()))
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    fail(format_args!("panic: {info}"))
}
