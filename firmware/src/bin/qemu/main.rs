//! The firmware under QEMU's `netduinoplus2` (STM32F405, Cortex-M4F): the thesis-2d scenario
//! run inside the emulated MCU through the same [`App`] as the board, the simulated pantograph
//! (`device::simulator`) as the plant, and every `Controller::tick` counted in instructions.
//!
//! QEMU runs it with `-icount shift=5`: every instruction takes 32 ns of virtual time and
//! SysTick, clocked by the emulated 168 MHz core, advances 168e6 · 32e-9 = 5.376 counts per
//! instruction, so a SysTick difference around one tick is an exact instruction count. The
//! count per instruction is checked at start with a loop of known length (it fails the run
//! otherwise, e.g. under another `-icount`), and the bracket's own cost is subtracted.
//!
//! No clock setup: QEMU does not emulate the RCC, and waiting on its ready flags hangs.
//! Output goes through semihosting; the run ends with a semihosting exit whose status is
//! QEMU's exit code.
#![no_std]
#![no_main]

mod points;
mod surface;

use points::points_run;
use surface::surface_run;

use core::sync::atomic::{Ordering, compiler_fence};

use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use device::simulator::{SimParams, SimulatedPantograph};
use device::spec::DeviceSpec;
#[cfg(feature = "stages")]
use device::{controller::TickOutput, kinematics::Pantograph, spec::Calibration};
use firmware::app::{App, Parked};
use firmware::board::Board;
use firmware::handover::{self, Incoming, Validator};
use firmware::netduino::SimulatedBoard;
use firmware::scenario::{HipPath, Scenario};
#[cfg(feature = "stages")]
use friction::FrictionMaterial;
use friction::FrictionRenderer;
use friction::Mode;
use nurbs::Vec2;
use protocol::device_side::session::{DeviceSession, DeviceState, Event};
use protocol::{Frame, MAX_FRAME as FRAME_BYTES, Message, SceneStore, points_update};
use protocol::{crc32, scene_upload, write_points};
use tracker::Chain;
#[cfg(feature = "stages")]
use tracker::{ChainTracker, Object};

/// The scene as the device's wire format (`protocol::scene`), written by
/// `cargo xtask qemu` from the scene JSON with the host crates; validated here as an upload.
static SCENE: &[u8] = include_bytes!(concat!(
    env!(
        "FIRMWARE_QEMU_DATA",
        "build the QEMU binary through `cargo xtask qemu`, which converts the scene and the \
         trajectory and sets FIRMWARE_QEMU_DATA to their folder"
    ),
    "/scene.bin"
));

/// The scenario table (`firmware::scenario`), written by `cargo xtask qemu`.
static SCENARIO: &[u8] = include_bytes!(concat!(
    env!(
        "FIRMWARE_QEMU_DATA",
        "build the QEMU binary through `cargo xtask qemu`"
    ),
    "/scenario.bin"
));

/// A surface scene (wire format) and the HIP's path over it (`firmware::scenario::HipPath`),
/// written by `cargo xtask qemu`: the friction renderer alone on a bicubic patch.
static SURFACE_SCENE: &[u8] = include_bytes!(concat!(
    env!(
        "FIRMWARE_QEMU_DATA",
        "build the QEMU binary through `cargo xtask qemu`"
    ),
    "/surface.bin"
));

/// The HIP's path over [`SURFACE_SCENE`].
static SURFACE_PATH: &[u8] = include_bytes!(concat!(
    env!(
        "FIRMWARE_QEMU_DATA",
        "build the QEMU binary through `cargo xtask qemu`"
    ),
    "/surface-path.bin"
));

/// The board's scene store (`firmware/src/bin/board.rs`): planar curves only.
type BoardStore = SceneStore<128, 96, 0>;
/// The app on a [`BoardStore`]'s object (its own copy of it, at the store's capacities).
type BoardApp<'a> = App<'a, 128, 96>;
/// The app's chain slot.
type BoardChain = Chain<128, 96>;

/// SysTick counts per instruction as a fraction: 168 MHz · 32 ns = 5.376 = 672 / 125.
const COUNTS_PER_INSTRUCTION: (u32, u32) = (672, 125);

/// SysTick's 24-bit range.
const SYST_MASK: u32 = 0x00FF_FFFF;

/// The instruction counter: SysTick counting down from 2²⁴ − 1 on the core clock.
struct Meter {
    syst: SYST,
    /// Instructions of an empty bracket.
    overhead: u32,
}

/// Why a measurement failed.
#[derive(Debug)]
enum Overflow {
    /// SysTick wrapped inside the bracket: more than 2²⁴ counts (3.1 M instructions).
    Wrapped,
}

impl Meter {
    fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(SYST_MASK);
        syst.clear_current();
        syst.enable_counter();
        Meter { syst, overhead: 0 }
    }

    /// Runs `f` and returns its result with the SysTick counts it took (bracket included).
    fn counts<R>(&mut self, f: impl FnOnce() -> R) -> (R, Result<u32, Overflow>) {
        // A write to the current value restarts the count from the reload value and clears
        // COUNTFLAG, so COUNTFLAG after the bracket means it wrapped inside it.
        self.syst.clear_current();
        let _ = self.syst.has_wrapped();
        compiler_fence(Ordering::SeqCst);
        let start = SYST::get_current();
        compiler_fence(Ordering::SeqCst);
        let r = f();
        compiler_fence(Ordering::SeqCst);
        let end = SYST::get_current();
        compiler_fence(Ordering::SeqCst);
        let counts = start.wrapping_sub(end) & SYST_MASK;
        if self.syst.has_wrapped() {
            return (r, Err(Overflow::Wrapped));
        }
        (r, Ok(counts))
    }

    /// Runs `f` and returns its result with the instructions it took, bracket included.
    /// A SysTick reading is the virtual time's count rounded down, so a difference is
    /// within one count of 5.376 per instruction: rounding to the nearest whole instruction
    /// (half an instruction is 2.688 counts) gives the exact count.
    fn instructions<R>(&mut self, f: impl FnOnce() -> R) -> (R, Result<u32, Overflow>) {
        let (r, counts) = self.counts(f);
        let (num, den) = COUNTS_PER_INSTRUCTION;
        let instructions = counts.map(|c| {
            let scaled = u64::from(c) * u64::from(den) + u64::from(num / 2);
            (scaled / u64::from(num)) as u32
        });
        (r, instructions)
    }
}

/// `n` (≥ 1) iterations of a two-instruction loop (`subs`, `bne`): 2n instructions.
#[inline(never)]
fn spin(n: u32) {
    #[allow(unsafe_code)]
    // SAFETY: the loop only counts a register down to zero; it touches no memory, no stack
    // and no flags the compiler relies on across asm.
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {0}, {0}, #1",
            "bne 2b",
            inout(reg) n.max(1) => _,
            options(nomem, nostack),
        );
    }
}

/// The paint of the free stack: a word a program is unlikely to leave behind.
const PAINT: u32 = 0x5AFE_C0DE;

// cortex-m-rt's linker script: the end of the statics (`.bss`, `.uninit`) and the top of RAM,
// where the stack starts and grows down towards them.
#[allow(unsafe_code)]
unsafe extern "C" {
    static __sheap: u32;
    static _stack_start: u32;
}

/// The bottom (end of the statics) and top of the stack region (only the symbols' addresses
/// are taken, which is safe).
fn stack_region() -> (usize, usize) {
    (
        &raw const __sheap as usize,
        &raw const _stack_start as usize,
    )
}

/// Paints the free stack, from the end of the statics to 64 bytes below this function's own
/// stack pointer, with [`PAINT`]; returns the painted bytes.
#[inline(never)]
fn paint_stack() -> usize {
    let (bottom, _) = stack_region();
    let sp = cortex_m::register::msp::read() as usize;
    let end = sp.saturating_sub(64);
    let mut p = bottom;
    while p < end {
        #[allow(unsafe_code)]
        // SAFETY: [bottom, sp − 64) is RAM between the statics and the live stack: nothing
        // owns it (no heap), and the writes are aligned words.
        unsafe {
            core::ptr::write_volatile(p as *mut u32, PAINT)
        };
        p += 4;
    }
    end.saturating_sub(bottom)
}

/// The deepest the stack has been since [`paint_stack`]: the top minus the lowest word that
/// no longer holds the paint.
fn stack_peak() -> usize {
    let (bottom, top) = stack_region();
    let mut p = bottom;
    #[allow(unsafe_code)]
    // SAFETY: aligned reads of RAM inside the stack region.
    while p < top && unsafe { core::ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    top - p
}

/// The emulated board with the instruction counter around the tick.
struct QemuBoard {
    sim: SimulatedBoard,
    meter: Meter,
    /// Instructions of the last `Controller::tick`, bracket subtracted.
    last: Result<u32, Overflow>,
    /// Sends nothing on the link (a run whose telemetry the host does not compare).
    mute: bool,
}

impl Board for QemuBoard {
    fn encoder_counts(&mut self) -> [i32; 2] {
        self.sim.encoder_counts()
    }

    fn set_motor_currents(&mut self, currents_a: [f32; 2]) {
        self.sim.set_motor_currents(currents_a);
    }

    fn set_driver_enabled(&mut self, enabled: bool) {
        self.sim.set_driver_enabled(enabled);
    }

    fn now_us(&mut self) -> u64 {
        self.sim.now_us()
    }

    fn link_send(&mut self, frame: &[u8]) {
        if !self.mute {
            self.sim.link_send(frame);
        }
    }

    fn link_receive(&mut self, buf: &mut [u8]) -> usize {
        self.sim.link_receive(buf)
    }

    fn around_tick<R>(&mut self, tick: impl FnOnce() -> R) -> R {
        let (r, n) = self.meter.instructions(tick);
        let overhead = self.meter.overhead;
        self.last = n.map(|n| n.saturating_sub(overhead));
        r
    }
}

/// The tick's stages run again, each bracketed alone, on the tick's own inputs: the same
/// functions `Controller::tick` calls (kinematics, the renderer — tracker and friction —, Jᵀ F
/// and currents) plus the app's telemetry frame, so their counts are the stages' without any
/// hook inside the device crate. The renderer is a second one fed the same poses; it stays in
/// lockstep with the controller's (same code, same inputs), which every tick checks: its
/// output and the currents must equal the tick's, or the split is not reported.
///
/// Only in the `stages` build: its extra code changes what LTO inlines into the tick, which
/// moves the tick's own count (by about 2 %), so the headline counts come from the build
/// without it.
#[cfg(feature = "stages")]
struct Shadow {
    spec: DeviceSpec,
    arm: Pantograph,
    calibration: Calibration,
    object: Chain<128, 96>,
    material: FrictionMaterial,
    period_s: f32,
    renderer: Option<FrictionRenderer<Chain<128, 96>>>,
    /// A third CP tracker, started where the renderer's is and fed the same HIPs: the tracker's
    /// share of the renderer's tick.
    cp: Option<ChainTracker>,
    previous_hip: Option<Vec2>,
    /// Kinematics, tracker, friction (the renderer minus its tracker), Jᵀ F + currents,
    /// telemetry frame, the rest of the tick (safety and glue).
    stats: [Stats; 6],
    mismatches: u32,
}

#[cfg(feature = "stages")]
const STAGE_NAMES: [&str; 6] = [
    "kinematics",
    "tracker",
    "friction",
    "jt_f+currents",
    "telemetry_frame",
    "safety+rest",
];

#[cfg(feature = "stages")]
impl Shadow {
    /// One tick's stages; `tick` is the tick's own count (bracket subtracted).
    fn stages(
        &mut self,
        meter: &mut Meter,
        counts: [i32; 2],
        out: &TickOutput,
        tick: u32,
        index: usize,
    ) {
        let overhead = meter.overhead;
        let count = |r: Result<u32, Overflow>| r.map_or(u32::MAX, |n| n.saturating_sub(overhead));
        let (spec, arm, calibration) = (&self.spec, &self.arm, &self.calibration);
        let (state, kinematics) = meter.instructions(|| {
            let theta = calibration.joint_angles(spec, counts).ok()?;
            arm.forward(theta).ok().map(|hip| (theta, hip))
        });
        let kinematics = count(kinematics);
        let mut render = 0;
        let mut tracking = 0;
        let mut currents = 0;
        if let Some((theta, hip)) = state {
            let t = self.period_s;
            let velocity = self
                .previous_hip
                .map_or(Vec2::ZERO, |prev| (hip - prev) * (1.0 / t));
            // The controller's renderer starts on the tick after the one whose HIP its
            // acquisition searched from (`App::acquire` between ticks): the same here.
            if self.renderer.is_none() && out.render.is_some() {
                let from = self.previous_hip.unwrap_or(hip);
                self.renderer = Some(FrictionRenderer::new(&self.object, self.material, from));
                self.cp = Some(self.object.start(from, friction::cp_config()));
            }
            self.previous_hip = Some(hip);
            let (object, renderer) = (&self.object, &mut self.renderer);
            if let (Some(renderer), Some(cp)) = (renderer.as_mut(), self.cp.as_mut()) {
                let (contact, n) = meter.instructions(|| object.track(cp, hip, t, true));
                tracking = count(n);
                let (output, n) = meter.instructions(|| renderer.tick(object, hip, velocity, t));
                render = count(n);
                if Some(output) != out.render || Some(contact) != out.render.map(|r| r.contact) {
                    self.mismatches += 1;
                }
            } else if out.render.is_some() {
                self.mismatches += 1;
            }
            let force = out.telemetry.force_n;
            let (command, n) = meter.instructions(|| {
                let tau = arm.joint_torques(theta, force).ok()?;
                spec.motor_command(calibration, tau).ok()
            });
            currents = count(n);
            if command.map(|c| c.current_a) != Some(out.currents_a) {
                self.mismatches += 1;
            }
        }
        let frame = Frame {
            seq: 0,
            message: Message::Telemetry(out.telemetry),
        };
        let mut bytes = [0u8; FRAME_BYTES];
        let (_, telemetry) = meter.instructions(|| frame.encode(&mut bytes));
        let telemetry = count(telemetry);
        let rest = tick.saturating_sub(kinematics.saturating_add(render).saturating_add(currents));
        for (stats, n) in self.stats.iter_mut().zip([
            kinematics,
            tracking,
            render.saturating_sub(tracking),
            currents,
            telemetry,
            rest,
        ]) {
            stats.add(n, index);
        }
    }
}

/// The shadow of the tick's stages on the app's object.
#[cfg(feature = "stages")]
fn shadow(app: &BoardApp, store: &BoardStore, scenario: &Scenario<'_>, period_s: f32) -> Shadow {
    let Some(object) = app.controller().object().map(|chain| **chain) else {
        fail(format_args!("scene {}: no object loaded", scenario.name));
    };
    let Some(material) = store.material(0) else {
        fail(format_args!("scene {}: no material", scenario.name));
    };
    let mut calibration = Calibration::new();
    if let Err(e) = calibration.record_home(&DeviceSpec::default(), scenario.end_stop_counts) {
        fail(format_args!("calibration: {e}"));
    }
    match DeviceSpec::default().validate() {
        Ok(arm) => Shadow {
            spec: DeviceSpec::default(),
            arm,
            calibration,
            object,
            material,
            period_s,
            renderer: None,
            cp: None,
            previous_hip: None,
            stats: [Stats::default(); 6],
            mismatches: 0,
        },
        Err(e) => fail(format_args!("device description: {e}")),
    }
}

/// Mean and maximum of instruction counts.
#[derive(Clone, Copy, Default)]
struct Stats {
    n: u64,
    sum: u64,
    max: u32,
    /// The tick of the maximum (the first, of equal ones).
    max_at: usize,
}

impl Stats {
    fn add(&mut self, v: u32, tick: usize) {
        self.n += 1;
        self.sum += u64::from(v);
        if v > self.max || self.n == 1 {
            self.max = v;
            self.max_at = tick;
        }
    }

    /// Mean in tenths, rounded.
    fn mean_tenths(&self) -> u64 {
        (self.sum * 10 + self.n / 2) / self.n.max(1)
    }
}

impl core::fmt::Display for Stats {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let m = self.mean_tenths();
        write!(
            f,
            "mean={}.{} max={} at_tick={} ticks={}",
            m / 10,
            m % 10,
            self.max,
            self.max_at,
            self.n
        )
    }
}

fn mode_index(mode: Mode) -> usize {
    match mode {
        Mode::Free => 0,
        Mode::Stuck => 1,
        Mode::Transition => 2,
        Mode::Slip => 3,
    }
}

const MODE_NAMES: [&str; 4] = ["free", "stuck", "transition", "slip"];

/// One `instructions_by_mode` line per friction mode the run ticked in.
fn print_by_mode(name: &str, by_mode: &[Stats; 4]) {
    for (mode, stats) in MODE_NAMES.iter().zip(by_mode) {
        if stats.n > 0 {
            hprintln!(
                "instructions_by_mode scene={} mode={} {}",
                name,
                mode,
                stats
            );
        }
    }
}

fn fail(what: core::fmt::Arguments<'_>) -> ! {
    hprintln!("qemu: FAILED: {}", what);
    debug::exit(debug::EXIT_FAILURE);
    #[allow(clippy::empty_loop)]
    loop {}
}

/// The instructions of `spin(n)` with the bracket. Not inlined, so that every `n` runs the
/// same machine code and two lengths differ by exactly 2 Δn instructions.
#[inline(never)]
fn measure_spin(meter: &mut Meter, n: u32) -> Result<u32, Overflow> {
    meter.instructions(|| spin(n)).1
}

/// Checks SysTick counts instructions (5.376 counts each) and measures the bracket: an empty
/// bracket, then two loops whose lengths differ by a known number of instructions.
fn calibrate(meter: &mut Meter) -> u32 {
    let ((), empty) = meter.instructions(|| ());
    let overhead = match empty {
        Ok(n) => n,
        Err(e) => fail(format_args!(
            "empty bracket: {e:?} (run QEMU with -icount shift=5)"
        )),
    };
    const SHORT: u32 = 1_000;
    const LONG: u32 = 11_000;
    let short = measure_spin(meter, core::hint::black_box(SHORT));
    let long = measure_spin(meter, core::hint::black_box(LONG));
    let (short, long) = match (short, long) {
        (Ok(s), Ok(l)) => (s, l),
        (s, l) => fail(format_args!(
            "loop check: {s:?} / {l:?} (run QEMU with -icount shift=5)"
        )),
    };
    let expected = 2 * (LONG - SHORT);
    hprintln!(
        "bracket_check overhead={} loop{}={} loop{}={} difference={} expected={}",
        overhead,
        SHORT,
        short,
        LONG,
        long,
        long - short,
        expected
    );
    if long.wrapping_sub(short) != expected {
        fail(format_args!(
            "loop check: {} instructions between the two loops, expected {expected}; SysTick \
             does not count 5.376 per instruction (QEMU needs -icount shift=5)",
            long.wrapping_sub(short)
        ));
    }
    overhead
}

#[entry]
fn main() -> ! {
    let painted = paint_stack();
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        fail(format_args!("core peripherals already taken"));
    };
    let mut meter = Meter::new(peripherals.SYST);
    meter.overhead = calibrate(&mut meter);

    let scenario = match Scenario::parse(SCENARIO) {
        Ok(s) => s,
        Err(e) => fail(format_args!("{e}")),
    };
    // The scene store lives in main's frame, which never returns (no `.data` image of it), at
    // the board's capacities, so the app holds the board's chain.
    let mut store = BoardStore::empty();
    let (result, decode) = meter.instructions(|| store.decode(SCENE));
    if let Err(e) = result {
        fail(format_args!("scene {}: {e}", scenario.name));
    }
    let period_s = (1.0 / scenario.rate_hz) as f32;
    // The app's chain slot, in main's frame too.
    let mut chain = BoardChain::EMPTY;
    let mut app = match App::new(&mut chain, &store, 0, period_s, scenario.ramp_time_s) {
        Ok(app) => app,
        Err(e) => fail(format_args!("scene {}: {e}", scenario.name)),
    };
    if let Err(e) = app.controller_mut().calibrate(scenario.end_stop_counts) {
        fail(format_args!("calibration: {e}"));
    }
    app.controller_mut().set_forces_enabled(true);
    let hand = SimParams::default();
    let arm = match SimulatedPantograph::new(DeviceSpec::default(), hand, scenario.start_m) {
        Ok(arm) => arm,
        Err(e) => fail(format_args!("simulated pantograph: {e}")),
    };
    hprintln!(
        "scene name={} bytes={} objects={} patches={} validated_instructions={:?} \
         passivity_control={}",
        scenario.name,
        SCENE.len(),
        store.object_count(),
        store.patch_count(0).unwrap_or(0),
        decode.ok(),
        app.passivity_control()
    );

    #[cfg(feature = "stages")]
    let mut shadow = shadow(&app, &store, &scenario, period_s);
    let mut board = QemuBoard {
        sim: SimulatedBoard::new(arm),
        meter,
        last: Ok(0),
        mute: false,
    };
    let mut all = Stats::default();
    let mut after_first = Stats::default();
    let mut by_mode = [Stats::default(); 4];
    let mut first = 0;
    let mut first_rendered = None;
    let mut acquisition = Stats::default();
    let mut fault_ticks = 0u32;
    // The handle's true HIP at the last tick (the host's run log's `hip_x,hip_y`).
    let mut last_hip = Vec2::ZERO;
    for i in 0..scenario.ticks() {
        // The device clock: integer microseconds since the start, as the host's run.
        board.sim.now_us = libm::round(i as f64 * 1e6 / scenario.rate_hz) as u64;
        match board.sim.arm.hip() {
            Ok((hip, _)) => last_hip = hip,
            Err(e) => fail(format_args!("tick {i}: simulated arm: {e}")),
        }
        app.controller_mut().heartbeat();
        #[cfg(feature = "stages")]
        let counts = board.sim.arm.encoder_counts();
        let out = app.tick(&mut board);
        let n = match board.last {
            Ok(n) => n,
            Err(ref e) => fail(format_args!("tick {i}: instruction count: {e:?}")),
        };
        #[cfg(feature = "stages")]
        shadow.stages(&mut board.meter, counts, out, n, i);
        let (rendered, mode, faults) = (
            out.render.is_some(),
            out.telemetry.mode,
            out.telemetry.faults,
        );
        all.add(n, i);
        if i == 0 {
            first = n;
        } else {
            after_first.add(n, i);
        }
        if rendered && first_rendered.is_none() {
            first_rendered = Some(n);
        }
        // The global search that starts the renderer, between ticks (the board runs it in its
        // lowest-priority task): counted alone, never in a tick.
        let (started, searched) = board.meter.instructions(|| app.acquire());
        if started {
            match searched {
                Ok(c) => acquisition.add(c.saturating_sub(board.meter.overhead), i),
                Err(e) => fail(format_args!("tick {i}: acquisition count: {e:?}")),
            }
        }
        by_mode[mode_index(mode)].add(n, i);
        if faults != 0 {
            fault_ticks += 1;
        }
        let target = match scenario.target(i) {
            Ok(t) => t,
            Err(e) => fail(format_args!("{e}")),
        };
        // A disabled driver puts no current through the motors.
        if let Err(e) = board.sim.step_plant(target, period_s) {
            fail(format_args!("tick {i}: simulated arm: {e}"));
        }
    }
    let name = scenario.name;
    hprintln!("instructions_per_tick scene={} {}", name, all);
    hprintln!("instructions_first_tick scene={} count={}", name, first);
    hprintln!(
        "instructions_first_rendered_tick scene={} count={}",
        name,
        first_rendered.unwrap_or(0)
    );
    hprintln!("instructions_acquisition scene={} {}", name, acquisition);
    hprintln!(
        "instructions_per_tick_after_first scene={} {}",
        name,
        after_first
    );
    print_by_mode(name, &by_mode);
    #[cfg(feature = "stages")]
    if shadow.mismatches == 0 {
        for (stage, stats) in STAGE_NAMES.iter().zip(shadow.stats) {
            hprintln!(
                "instructions_by_stage scene={} stage={} {}",
                name,
                stage,
                stats
            );
        }
    } else {
        hprintln!(
            "instructions_by_stage scene={} not reported: the shadow left lockstep on {} \
             ticks",
            name,
            shadow.mismatches
        );
    }
    hprintln!(
        "run scene={} rate_hz={} ticks={} ticks_per_frame={} fault_ticks={} frames_sent={} \
         last_hip_m={},{}",
        name,
        scenario.rate_hz,
        all.n,
        app.ticks_per_frame(),
        fault_ticks,
        board.sim.frames_sent,
        last_hip.x,
        last_hip.y
    );
    let QemuBoard { sim, meter, .. } = board;
    let mut board = QemuBoard {
        sim,
        meter,
        last: Ok(0),
        mute: true,
    };
    points_run(&mut board, &scenario);
    surface_run(&mut board.meter, scenario.rate_hz);
    let (bottom, top) = stack_region();
    hprintln!(
        "stack peak_bytes={} region_bytes={} painted_bytes={}",
        stack_peak(),
        top - bottom,
        painted
    );
    debug::exit(debug::EXIT_SUCCESS);
    #[allow(clippy::empty_loop)]
    loop {}
}

#[exception]
#[allow(unsafe_code)]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    // No motors here; the board's handler puts them off first with raw register writes.
    fail(format_args!("HardFault at pc={:#010x}", frame.pc()))
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo<'_>) -> ! {
    fail(format_args!("panic: {info}"))
}
