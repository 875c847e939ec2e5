//! The pantograph's board: STM32F411CE "Black Pill" (25 MHz crystal), RTIC 2.
//!
//! Tasks, highest priority first (nothing of a lower priority can delay a tick):
//!
//! 3. `tick` — TIM5's update interrupt, 1 kHz (features `tick-2khz`, `tick-5khz`,
//!    `tick-10khz`): feeds the watchdog, swaps in a committed scene, applies the link's
//!    commands, runs one [`App::tick`] on the encoders and the clock, drives PWM, directions
//!    and driver enable, and queues one telemetry frame per millisecond for USB. Never waits,
//!    allocates, logs or panics; it shares nothing with lower priorities but lock-free
//!    single-producer single-consumer queues and atomics.
//! 2. `usb` — the OTG_FS interrupt (and pended by the tick every millisecond): USB HID
//!    (usb-device + usbd-hid), one 64-byte protocol frame per report; host reports go to the
//!    protocol task, its replies and the tick's telemetry go out as IN reports, one device
//!    sequence number over all of them.
//! 0. `idle` — the lowest priority, the protocol task: host frames through
//!    [`SceneReceiver`] (which validates an upload into the staging store), commands to the
//!    tick, replies to USB; and the acquisition (the global closest-point search that starts
//!    the renderer after a swap, `device::controller::acquire`), handed back to the tick.
//!    Sleeps (WFI) when there is nothing to do.
//!
//! Pins (see the firmware README's table): encoders TIM3 PA6/PA7 and TIM4 PB6/PB7, PWM TIM1
//! CH1 PA8 and CH2 PA9 at 20 kHz, directions PB12/PB13, driver enable PB14 (high = enabled),
//! LED PC13 (active low), USB PA11/PA12, SWD PA13/PA14. The monotonic clock is TIM2, 32 bits
//! at 1 MHz, extended to 64 bits by the tick (it reads it every tick, far more often than
//! once per 71.6 min wrap).
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicBool, AtomicU8, AtomicU32, Ordering};

use device::controller::{Acquisition, AcquisitionRequest, TickOutput, acquire};
use device::protocol::{ErrorCode, Frame, MAX_FRAME, Message, SceneError, SceneFault, SceneStore};
use device::session::{Command, DeviceState, Event as LinkEvent, Session};
use firmware::app::{App, AppError, Parked};
use firmware::board::Board;
use firmware::swap::{Published, SceneBuffers, Staging};
use stm32f4xx_hal::gpio::{Output, PB12, PB13, PB14, PC13};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::timer::{CounterHz, Event, Flag, PwmChannel};
use stm32f4xx_hal::watchdog::IndependentWatchdog;
use tracker::{Chain, Object};

#[cfg(any(
    all(feature = "tick-2khz", feature = "tick-5khz"),
    all(feature = "tick-2khz", feature = "tick-10khz"),
    all(feature = "tick-5khz", feature = "tick-10khz"),
))]
compile_error!("choose at most one of the features tick-2khz, tick-5khz, tick-10khz");

/// The haptic tick's rate (Hz).
const TICK_HZ: u32 = if cfg!(feature = "tick-10khz") {
    10_000
} else if cfg!(feature = "tick-5khz") {
    5_000
} else if cfg!(feature = "tick-2khz") {
    2_000
} else {
    1_000
};
/// Ticks per telemetry frame: one frame per millisecond, USB HID's IN report rate.
const TICKS_PER_FRAME: u32 = TICK_HZ / 1_000;
/// The safety layer's ramp-in after forces are enabled or a scene is swapped (s), as the
/// host's `viewer sim --device`.
const RAMP_TIME_S: f32 = 0.5;
/// The watchdog's timeout (ms, nominal: the LSI clock is 17–47 kHz, so 7–19 ms).
const WATCHDOG_MS: u32 = 10;
/// PWM frequency of the motor drivers' inputs (Hz), above hearing.
const PWM_HZ: u32 = 20_000;

/// The board's scene store: planar curves only (the pantograph renders chains of them; a
/// scene with a surface is refused as `SceneCapacity`, which also keeps the shell's
/// validation, 10 KiB of stack, out of the link task). About 3 KiB.
type BoardStore = SceneStore<128, 96, 0>;
/// The largest wire scene the board receives (bytes); the receiver holds two.
const SCENE_CAPACITY: usize = 1792;
type Link = Session<SCENE_CAPACITY>;

/// The two scene stores: one rendered by the tick, one the link decodes uploads into.
/// All zero bits when empty, so in `.bss`.
static SCENES: SceneBuffers<BoardStore> =
    SceneBuffers::new(BoardStore::empty(), BoardStore::empty());

/// The tick's state for the link task's status replies: fault bits 0–15, forces enabled
/// bit 16, calibrated bit 17 (written by the tick every tick, read by USB).
static TICK_STATUS: AtomicU32 = AtomicU32::new(0);

/// A committed scene waits for the tick (set by the link before it queues the commit, cleared
/// by the tick once it swapped it in or refused it). The link validates no other upload
/// meanwhile, so the tick's swap (which builds the chain) and the link's validation (which
/// builds one too) never preempt each other: their stack frames do not add up.
static COMMIT_PENDING: AtomicBool = AtomicBool::new(false);

/// Why the tick refused the link's last command (an `ErrorCode`, 0 for none): written by the
/// tick, read into the status by the link task.
static COMMAND_ERROR: AtomicU8 = AtomicU8::new(0);

/// Queue lengths (heapless' spsc holds one less than its size).
const COMMANDS: usize = 8;
const FRAMES: usize = 4;
/// Host reports waiting for the protocol task, and its replies waiting for USB.
const REPORTS: usize = 4;
const REPLIES: usize = 4;
/// Both stores can be in flight at once, so neither hand-over queue can overflow.
const STORES: usize = 3;

type Report = [u8; MAX_FRAME];

/// The monotonic clock: TIM2 counting microseconds, 32 bits, extended to 64 by adding the
/// wrapping difference of successive readings (correct while read at least every 71.6 min).
struct Clock {
    tim: pac::TIM2,
    last: u32,
    now_us: u64,
}

impl Clock {
    /// Starts TIM2 at 1 MHz from its kernel clock `tim_hz`, free-running over 32 bits.
    fn start(tim: pac::TIM2, rcc: &mut stm32f4xx_hal::rcc::Rcc, tim_hz: u32) -> Self {
        use stm32f4xx_hal::rcc::{Enable, Reset};
        pac::TIM2::enable(rcc);
        pac::TIM2::reset(rcc);
        let prescaler = (tim_hz / 1_000_000).saturating_sub(1) as u16;
        tim.psc().write(|w| w.psc().set(prescaler));
        tim.arr().write(|w| w.arr().set(u32::MAX));
        // Load the prescaler now (an update event), then count.
        tim.egr().write(|w| w.ug().set_bit());
        tim.cr1().modify(|_, w| w.cen().set_bit());
        let last = tim.cnt().read().bits();
        Clock {
            tim,
            last,
            now_us: 0,
        }
    }

    fn now_us(&mut self) -> u64 {
        let count = self.tim.cnt().read().bits();
        self.now_us = self
            .now_us
            .wrapping_add(u64::from(count.wrapping_sub(self.last)));
        self.last = count;
        self.now_us
    }

    /// The 32-bit count, for durations within a tick.
    fn raw(&self) -> u32 {
        self.tim.cnt().read().bits()
    }
}

/// A 16-bit hardware encoder counter extended to the 32-bit count the controller takes, by
/// the wrapping difference of successive readings (read every tick: at most a few hundred
/// counts apart, far from the 32,768 that would alias).
#[derive(Clone, Copy)]
struct Extend16 {
    last: u16,
    count: i32,
}

impl Extend16 {
    fn update(&mut self, raw: u16) -> i32 {
        self.count = self
            .count
            .wrapping_add(i32::from(raw.wrapping_sub(self.last) as i16));
        self.last = raw;
        self.count
    }
}

/// The tick's board: the peripherals the `App` drives.
struct Hw {
    encoder_left: Qei<pac::TIM3>,
    encoder_right: Qei<pac::TIM4>,
    counts: [Extend16; 2],
    pwm_left: PwmChannel<pac::TIM1, 0>,
    pwm_right: PwmChannel<pac::TIM1, 1>,
    max_duty: u16,
    /// The current at full duty (A): the drivers' full scale, set to the device's current
    /// limit (`DeviceSpec::current_limit_a`).
    full_scale_a: [f32; 2],
    dir_left: PB12<Output>,
    dir_right: PB13<Output>,
    enable: PB14<Output>,
    clock: Clock,
    faults: u16,
    tick_start: u32,
    last_tick_us: u16,
    /// Ticks since the last telemetry frame.
    since_frame: u32,
    frames: heapless::spsc::Producer<'static, Report, FRAMES>,
    /// Frames dropped because USB had not taken the previous ones.
    frames_dropped: u32,
}

impl Hw {
    /// PWM duty for a current: its magnitude over the full scale, clamped (NaN: zero).
    fn duty(&self, current_a: f32, full_scale_a: f32) -> u16 {
        let fraction = current_a.abs() / full_scale_a;
        let fraction = if fraction.is_nan() || fraction <= 0.0 {
            0.0
        } else if fraction >= 1.0 {
            1.0
        } else {
            fraction
        };
        (fraction * f32::from(self.max_duty)) as u16
    }
}

impl Board for Hw {
    fn encoder_counts(&mut self) -> [i32; 2] {
        [
            self.counts[0].update(self.encoder_left.count()),
            self.counts[1].update(self.encoder_right.count()),
        ]
    }

    fn set_motor_currents(&mut self, currents_a: [f32; 2]) {
        let [left, right] = currents_a;
        // Direction first, then the magnitude.
        self.dir_left.set_state((left < 0.0).into());
        self.dir_right.set_state((right < 0.0).into());
        let duty = [
            self.duty(left, self.full_scale_a[0]),
            self.duty(right, self.full_scale_a[1]),
        ];
        self.pwm_left.set_duty(duty[0]);
        self.pwm_right.set_duty(duty[1]);
    }

    fn set_faults(&mut self, faults: u16) {
        self.faults = faults;
    }

    fn set_driver_enabled(&mut self, enabled: bool) {
        if enabled && self.faults == 0 {
            self.enable.set_high();
        } else {
            self.enable.set_low();
        }
    }

    fn now_us(&mut self) -> u64 {
        self.clock.now_us()
    }

    fn link_send(&mut self, frame: &[u8]) {
        let mut report = [0u8; MAX_FRAME];
        if let Some(dst) = report.get_mut(..frame.len()) {
            dst.copy_from_slice(frame);
        }
        if self.frames.enqueue(report).is_err() {
            self.frames_dropped = self.frames_dropped.wrapping_add(1);
        }
        rtic::pend(pac::Interrupt::OTG_FS);
    }

    fn link_receive(&mut self, _buf: &mut [u8]) -> usize {
        // Host frames arrive in the USB task, which hands the tick commands instead.
        0
    }

    fn wants_frame(&mut self) -> bool {
        self.since_frame += 1;
        if self.since_frame >= TICKS_PER_FRAME {
            self.since_frame = 0;
            true
        } else {
            false
        }
    }

    fn last_tick_us(&mut self) -> Option<u16> {
        Some(self.last_tick_us)
    }

    fn around_tick<R>(&mut self, tick: impl FnOnce() -> R) -> R {
        self.tick_start = self.clock.raw();
        let r = tick();
        let us = self.clock.raw().wrapping_sub(self.tick_start);
        self.last_tick_us = u16::try_from(us).unwrap_or(u16::MAX);
        r
    }
}

/// The status LED (PC13, active low): its pattern from the tick's state, see the README.
struct Led {
    pin: PC13<Output>,
    ticks: u32,
}

impl Led {
    fn update(&mut self, faults: u16, calibrated: bool, driving: bool) {
        self.ticks = self.ticks.wrapping_add(1);
        let ms = (self.ticks / TICKS_PER_FRAME) % 1000;
        let on = if faults != 0 {
            // 5 Hz blink: a fault is latched, forces cut.
            ms % 200 < 100
        } else if driving {
            // Steady: the drivers are enabled.
            true
        } else if calibrated {
            // A 100 ms blip every second: calibrated, forces off.
            ms < 100
        } else {
            // 1 Hz blink: not calibrated yet.
            ms < 500
        };
        // Active low.
        self.pin.set_state((!on).into());
    }
}

/// USB HID report descriptor: one vendor-defined collection with a 64-byte input and a
/// 64-byte output report, no report ids (what `device::host::HidLink` reads and writes).
#[rustfmt::skip]
const REPORT_DESCRIPTOR: &[u8] = &[
    0x06, 0x00, 0xFF, // Usage Page (vendor defined 0xFF00)
    0x09, 0x01,       // Usage (1)
    0xA1, 0x01,       // Collection (application)
    0x09, 0x02,       //   Usage (2)
    0x15, 0x00,       //   Logical minimum (0)
    0x26, 0xFF, 0x00, //   Logical maximum (255)
    0x75, 0x08,       //   Report size (8 bits)
    0x95, 0x40,       //   Report count (64)
    0x81, 0x02,       //   Input (data, variable, absolute)
    0x09, 0x03,       //   Usage (3)
    0x15, 0x00,       //   Logical minimum (0)
    0x26, 0xFF, 0x00, //   Logical maximum (255)
    0x75, 0x08,       //   Report size (8 bits)
    0x95, 0x40,       //   Report count (64)
    0x91, 0x02,       //   Output (data, variable, absolute)
    0xC0,             // End collection
];

/// What the tick asks the acquisition for: the global closest-point search on object 0 of
/// the store it renders, from the request's HIP.
#[derive(Clone, Copy, Debug)]
struct AcquisitionJob {
    store: &'static BoardStore,
    request: AcquisitionRequest,
}

/// The acquisition's answer: the search's result, or `None` when the store's object could not
/// be built (not expected: the tick loaded it); either way the job is over.
type ChainAcquisition = Acquisition<<Chain<'static> as Object>::State>;

/// The acquisition of one job: the job's object rebuilt from its store (the same chain as
/// the controller's) and the global search on it.
#[inline(never)]
fn run_job(job: AcquisitionJob) -> Option<ChainAcquisition> {
    let (curves, n) = firmware::app::curves(job.store, 0).ok()?;
    // Borrowed in place: no copy of the chain on the stack.
    match &Chain::new(curves.get(..n)?) {
        Ok(chain) => Some(acquire(chain, job.request)),
        Err(_) => None,
    }
}

/// The protocol side, in the lowest-priority task: host frames through the receiver (which
/// validates an upload into the staging store), commands to the tick, replies to USB; and the
/// acquisition. Both build chains (the validation, the search's object), so they run in one
/// task, one after the other, and their stack frames never add up.
struct Protocol {
    session: &'static mut Link,
    /// The store the next commit is validated into; `None` while both are with the tick.
    staging: Option<Staging<BoardStore>>,
    reports: heapless::spsc::Consumer<'static, Report, REPORTS>,
    replies: heapless::spsc::Producer<'static, Message, REPLIES>,
    commands: heapless::spsc::Producer<'static, Command, COMMANDS>,
    commits: heapless::spsc::Producer<'static, Published<BoardStore>, STORES>,
    freed: heapless::spsc::Consumer<'static, Staging<BoardStore>, STORES>,
    jobs: heapless::spsc::Consumer<'static, AcquisitionJob, 2>,
    results: heapless::spsc::Producer<'static, Option<ChainAcquisition>, 2>,
}

impl Protocol {
    /// Handles what is waiting; `false` when nothing was.
    fn step(&mut self) -> bool {
        if let Some(job) = self.jobs.dequeue() {
            // Room is certain: one job at a time.
            let _ = self.results.enqueue(run_job(job));
            return true;
        }
        if let Some(report) = self.reports.dequeue() {
            self.receive(&report);
            rtic::pend(pac::Interrupt::OTG_FS);
            return true;
        }
        false
    }

    /// Handles one host report. Not inlined (nor is [`run_job`]), so that the task's own
    /// frame stays small and the big frames (the validation's, the search's) exist only while
    /// they run: the tick's swap never stacks on them (see `COMMIT_PENDING`, `in_flight`).
    #[inline(never)]
    fn receive(&mut self, bytes: &[u8]) {
        if self.staging.is_none() {
            self.staging = self.freed.dequeue();
        }
        let staging = &mut self.staging;
        let pending = COMMIT_PENDING.load(Ordering::Acquire);
        let mut validate = |scene: &[u8]| match staging.as_mut() {
            Some(store) if !pending => store.get_mut().decode(scene),
            // The previous commit is not swapped in yet (both stores are with the tick, or
            // the tick is about to swap): refused for now, the upload stays and its commit
            // may be sent again.
            _ => Err(SceneError {
                object: None,
                patch: None,
                fault: SceneFault::Capacity,
            }),
        };
        if let Some(code) = ErrorCode::from_u8(COMMAND_ERROR.swap(0, Ordering::AcqRel)) {
            self.session.note_error(code);
        }
        let tick = TICK_STATUS.load(Ordering::Acquire);
        let state = DeviceState {
            software: firmware::software_version(),
            forces_enabled: tick & (1 << 16) != 0,
            calibrated: tick & (1 << 17) != 0,
            faults: tick as u16,
        };
        let replies = &mut self.replies;
        let event = self
            .session
            .handle(bytes, &mut validate, state, &mut |m: &Message| {
                // Dropped when the replies queue is full (the host sends faster than it reads):
                // it sees the missing acks.
                let _ = replies.enqueue(*m);
            });
        match event {
            LinkEvent::SceneCommitted => {
                // The queue has room for both stores, so it is always ready here.
                if self.commits.ready()
                    && let Some(store) = self.staging.take()
                {
                    COMMIT_PENDING.store(true, Ordering::Release);
                    let _ = self.commits.enqueue(store.publish());
                }
            }
            // A board's session refuses hand targets (no virtual hand here).
            LinkEvent::HandTarget(_) | LinkEvent::None => {}
            LinkEvent::Command(command) => {
                if self.commands.enqueue(command).is_err() {
                    // The tick takes every command each tick; a full queue means a flood.
                    self.session.note_error(ErrorCode::UnexpectedMessage);
                }
            }
        }
    }
}

/// The USB side: reports in to the protocol, replies and telemetry out as IN reports.
struct Usb {
    reports: heapless::spsc::Producer<'static, Report, REPORTS>,
    replies: heapless::spsc::Consumer<'static, Message, REPLIES>,
    frames: heapless::spsc::Consumer<'static, Report, FRAMES>,
    /// Device sequence number, over every frame sent (the host counts gaps in it).
    seq: u16,
}

impl Usb {
    /// The next report to send: a reply first, else the oldest telemetry frame; numbered
    /// with the device's sequence. `None` when nothing is waiting.
    fn next_report(&mut self) -> Option<Report> {
        let message = match self.replies.peek() {
            Some(m) => *m,
            None => match self.frames.peek().map(|r| Frame::decode(r)) {
                Some(Ok(frame)) => frame.message,
                Some(Err(_)) => {
                    // Unreachable (the tick encodes them); dropped rather than sent.
                    let _ = self.frames.dequeue();
                    return None;
                }
                None => return None,
            },
        };
        Some(
            Frame {
                seq: self.seq,
                message,
            }
            .to_report()
            .0,
        )
    }

    /// The report of [`Usb::next_report`] was sent.
    fn sent(&mut self) {
        if self.replies.dequeue().is_none() {
            let _ = self.frames.dequeue();
        }
        self.seq = self.seq.wrapping_add(1);
    }
}

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true)]
mod app {
    use super::*;
    use stm32f4xx_hal::otg_fs::{USB, UsbBusType};
    use usb_device::class_prelude::UsbBusAllocator;
    use usb_device::prelude::*;
    use usbd_hid::hid_class::HIDClass;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        tick_timer: CounterHz<pac::TIM5>,
        watchdog: IndependentWatchdog,
        hw: Hw,
        led: Led,
        app: App<'static>,
        /// The store the tick renders, and the one it rendered before the last swap until
        /// it can be handed back.
        active: Option<Published<BoardStore>>,
        retired: Option<Published<BoardStore>>,
        /// An acquisition job is with the protocol task (its result not back yet).
        in_flight: bool,
        commands: heapless::spsc::Consumer<'static, Command, COMMANDS>,
        commits: heapless::spsc::Consumer<'static, Published<BoardStore>, STORES>,
        freed: heapless::spsc::Producer<'static, Staging<BoardStore>, STORES>,
        jobs: heapless::spsc::Producer<'static, AcquisitionJob, 2>,
        results: heapless::spsc::Consumer<'static, Option<ChainAcquisition>, 2>,
        usb_device: UsbDevice<'static, UsbBusType>,
        hid: HIDClass<'static, UsbBusType>,
        usb: Usb,
        protocol: Protocol,
    }

    #[init(local = [
        ep_memory: [u32; 64] = [0; 64],
        usb_bus: Option<UsbBusAllocator<UsbBusType>> = None,
        session: Link = Session::new(false),
        command_queue: heapless::spsc::Queue<Command, COMMANDS> = heapless::spsc::Queue::new(),
        frame_queue: heapless::spsc::Queue<Report, FRAMES> = heapless::spsc::Queue::new(),
        report_queue: heapless::spsc::Queue<Report, REPORTS> = heapless::spsc::Queue::new(),
        reply_queue: heapless::spsc::Queue<Message, REPLIES> = heapless::spsc::Queue::new(),
        commit_queue: heapless::spsc::Queue<Published<BoardStore>, STORES> = heapless::spsc::Queue::new(),
        free_queue: heapless::spsc::Queue<Staging<BoardStore>, STORES> = heapless::spsc::Queue::new(),
        job_queue: heapless::spsc::Queue<AcquisitionJob, 2> = heapless::spsc::Queue::new(),
        result_queue: heapless::spsc::Queue<Option<ChainAcquisition>, 2> = heapless::spsc::Queue::new(),
    ])]
    fn init(cx: init::Context) -> (Shared, Local) {
        let dp = cx.device;
        let mut rcc = dp.RCC.freeze(
            stm32f4xx_hal::rcc::Config::hse(25.MHz())
                .sysclk(96.MHz())
                .require_pll48clk(),
        );
        let gpioa = dp.GPIOA.split(&mut rcc);
        let gpiob = dp.GPIOB.split(&mut rcc);
        let gpioc = dp.GPIOC.split(&mut rcc);
        // Motors off before anything else: the driver enable pin driven low.
        let enable = gpiob.pb14.into_push_pull_output_in_state(false.into());
        let dir_left = gpiob.pb12.into_push_pull_output_in_state(false.into());
        let dir_right = gpiob.pb13.into_push_pull_output_in_state(false.into());
        let led = gpioc.pc13.into_push_pull_output_in_state(true.into());

        let (_pwm, (ch1, ch2, ..)) = dp.TIM1.pwm_hz(PWM_HZ.Hz(), &mut rcc);
        let mut pwm_left = ch1.with(gpioa.pa8);
        let mut pwm_right = ch2.with(gpioa.pa9);
        pwm_left.set_duty(0);
        pwm_right.set_duty(0);
        pwm_left.enable();
        pwm_right.enable();
        let max_duty = pwm_left.get_max_duty();

        let encoder_left = Qei::new(dp.TIM3, (gpioa.pa6, gpioa.pa7), &mut rcc);
        let encoder_right = Qei::new(dp.TIM4, (gpiob.pb6, gpiob.pb7), &mut rcc);
        let counts = [
            Extend16 {
                last: encoder_left.count(),
                count: 0,
            },
            Extend16 {
                last: encoder_right.count(),
                count: 0,
            },
        ];
        let tim_hz = rcc.clocks.timclk1().raw();
        let clock = Clock::start(dp.TIM2, &mut rcc, tim_hz);

        // Queues and the scene stores.
        let (command_tx, command_rx) = cx.local.command_queue.split();
        let (frame_tx, frame_rx) = cx.local.frame_queue.split();
        let (report_tx, report_rx) = cx.local.report_queue.split();
        let (reply_tx, reply_rx) = cx.local.reply_queue.split();
        let (commit_tx, commit_rx) = cx.local.commit_queue.split();
        let (mut free_tx, free_rx) = cx.local.free_queue.split();
        let (job_tx, job_rx) = cx.local.job_queue.split();
        let (result_tx, result_rx) = cx.local.result_queue.split();
        let Some([first, second]) = SCENES.split() else {
            panic!("the scene stores are split once, here");
        };
        let _ = free_tx.enqueue(second);

        let app = match Parked::new(1.0 / TICK_HZ as f32, RAMP_TIME_S) {
            Ok(parked) => parked.unloaded(),
            Err(e) => panic!("controller: {e}"),
        };
        let full_scale_a = app.controller().spec().current_limit_a;

        // USB: 48 MHz from the PLL's Q output.
        assert!(rcc.clocks.is_pll48clk_valid(), "USB needs a 48 MHz clock");
        let usb = USB::new(
            (dp.OTG_FS_GLOBAL, dp.OTG_FS_DEVICE, dp.OTG_FS_PWRCLK),
            (gpioa.pa11, gpioa.pa12),
            &rcc.clocks,
        );
        let usb_bus: &'static UsbBusAllocator<UsbBusType> = cx
            .local
            .usb_bus
            .insert(UsbBusType::new(usb, cx.local.ep_memory));
        let hid = HIDClass::new(usb_bus, REPORT_DESCRIPTOR, 1);
        let usb_device = UsbDeviceBuilder::new(
            usb_bus,
            UsbVidPid(device::protocol::USB_VID, device::protocol::USB_PID),
        )
        .strings(&[StringDescriptors::default()
            .manufacturer("nurbs-haptics")
            .product("NURBS haptic pantograph")
            .serial_number("0001")])
        .expect("one language of strings")
        .max_packet_size_0(64)
        .expect("64 is a valid control packet size")
        .build();

        // The tick, then the watchdog it feeds.
        let mut tick_timer = dp.TIM5.counter_hz(&mut rcc);
        tick_timer
            .start(TICK_HZ.Hz())
            .expect("the tick rate is within TIM5's range");
        tick_timer.listen(Event::Update);
        let mut watchdog = IndependentWatchdog::new(dp.IWDG);
        watchdog.stop_on_debug(&dp.DBGMCU, true);
        // Keep the debug port clocked in `wfi`, so that a probe (probe-rs RTT) stays attached.
        dp.DBGMCU.cr().modify(|_, w| w.dbg_sleep().set_bit());
        watchdog.start(WATCHDOG_MS.millis());

        let hw = Hw {
            encoder_left,
            encoder_right,
            counts,
            pwm_left,
            pwm_right,
            max_duty,
            full_scale_a,
            dir_left,
            dir_right,
            enable,
            clock,
            faults: 0,
            tick_start: 0,
            last_tick_us: 0,
            since_frame: 0,
            frames: frame_tx,
            frames_dropped: 0,
        };
        let protocol = Protocol {
            session: cx.local.session,
            staging: Some(first),
            reports: report_rx,
            replies: reply_tx,
            commands: command_tx,
            commits: commit_tx,
            freed: free_rx,
            jobs: job_rx,
            results: result_tx,
        };
        let usb = Usb {
            reports: report_tx,
            replies: reply_rx,
            frames: frame_rx,
            seq: 0,
        };
        (
            Shared {},
            Local {
                tick_timer,
                watchdog,
                hw,
                led: Led { pin: led, ticks: 0 },
                app,
                active: None,
                retired: None,
                in_flight: false,
                commands: command_rx,
                commits: commit_rx,
                freed: free_tx,
                jobs: job_tx,
                results: result_rx,
                usb_device,
                hid,
                usb,
                protocol,
            },
        )
    }

    /// The lowest priority: host frames and acquisitions, sleeping when there are none (any
    /// interrupt wakes it; the tick does every period at the latest).
    #[idle(local = [protocol])]
    fn idle(cx: idle::Context) -> ! {
        loop {
            if !cx.local.protocol.step() {
                cortex_m::asm::wfi();
            }
        }
    }

    /// The haptic tick.
    #[task(binds = TIM5, priority = 3, local = [
        tick_timer, watchdog, hw, led, app, active, retired, in_flight, commands, commits,
        freed, jobs, results,
    ])]
    fn tick(cx: tick::Context) {
        let l = cx.local;
        l.tick_timer.clear_flags(Flag::Update);
        l.watchdog.feed();

        // The acquisition's result: the renderer starts (refused if it is for an older scene).
        if let Some(result) = l.results.dequeue() {
            *l.in_flight = false;
            if let Some(acquisition) = result {
                let _ = l.app.controller_mut().complete_acquisition(acquisition);
            }
        }
        // A committed scene, swapped in at this tick boundary, once no acquisition reads a
        // store (so the swap's frame never stacks on the acquisition's either).
        if !*l.in_flight
            && let Some(new) = l.commits.dequeue()
        {
            match load(l.app, &new) {
                Ok(()) => {
                    // The controller dropped its views of the old store.
                    if let Some(old) = l.active.replace(new) {
                        *l.retired = Some(old);
                    }
                }
                Err(_) => {
                    // Not renderable here (beyond the device, not a chain): the current scene
                    // stays; the new store goes back to the protocol task.
                    #[allow(unsafe_code)]
                    // SAFETY: the failed load dropped every view it built of `new`'s store
                    // and no other task was given it.
                    let staging = unsafe { new.reclaim() };
                    let _ = l.freed.enqueue(staging);
                }
            }
            COMMIT_PENDING.store(false, Ordering::Release);
        }
        // The old store goes back to the protocol task once nothing reads it.
        if !*l.in_flight
            && let Some(old) = l.retired.take()
        {
            #[allow(unsafe_code)]
            // SAFETY: the controller holds views of the active store only (it loaded that one
            // in place of this one), and no acquisition job is out, so the protocol task
            // holds no chain of it either.
            let staging = unsafe { old.reclaim() };
            let _ = l.freed.enqueue(staging);
        }

        while let Some(command) = l.commands.dequeue() {
            // A calibration records the counts now: the user holds the joints on their stops.
            let home = l.hw.encoder_counts();
            if let Err(code) = l.app.apply(command, home) {
                COMMAND_ERROR.store(code as u8, Ordering::Release);
            }
        }

        let out = run_tick(l.app, l.hw);
        let controller = l.app.controller();
        // The renderer waits for its acquisition: one job at a time to the protocol task.
        if !*l.in_flight
            && let (Some(request), Some(active)) =
                (controller.acquisition_request(), l.active.as_ref())
            && l.jobs
                .enqueue(AcquisitionJob {
                    store: active.get(),
                    request,
                })
                .is_ok()
        {
            *l.in_flight = true;
        }
        let faults = out.telemetry.faults;
        let driving = controller.forces_enabled() && faults == 0;
        let calibrated = controller.is_calibrated();
        TICK_STATUS.store(
            u32::from(faults)
                | (u32::from(controller.forces_enabled()) << 16)
                | (u32::from(calibrated) << 17),
            Ordering::Release,
        );
        l.led.update(faults, calibrated, driving);
    }

    /// USB: enumeration, host reports in (to the protocol task), replies and telemetry out.
    #[task(binds = OTG_FS, priority = 2, local = [usb_device, hid, usb])]
    fn usb(cx: usb::Context) {
        let l = cx.local;
        if l.usb_device.poll(&mut [l.hid]) {
            let mut buf = [0u8; MAX_FRAME];
            while let Ok(n) = l.hid.pull_raw_output(&mut buf) {
                if n == 0 {
                    break;
                }
                let mut report = [0u8; MAX_FRAME];
                if let (Some(dst), Some(src)) = (report.get_mut(..n), buf.get(..n)) {
                    dst.copy_from_slice(src);
                }
                // A full queue drops the report: the host sees no ack and resends.
                let _ = l.usb.reports.enqueue(report);
            }
        }
        if l.usb_device.state() != UsbDeviceState::Configured {
            // Nothing to send to: telemetry is dropped, not queued.
            while l.usb.frames.dequeue().is_some() {}
            return;
        }
        if let Some(report) = l.usb.next_report()
            && l.hid.push_raw_input(&report).is_ok()
        {
            l.usb.sent();
        }
    }
}

/// Loads object 0 of a committed store. Not inlined, so that its frame (the chain it builds)
/// and the tick's do not add up on the stack.
#[inline(never)]
fn load(app: &mut App<'static>, store: &Published<BoardStore>) -> Result<(), AppError> {
    app.load(store.get(), 0)
}

/// One [`App::tick`]; not inlined (see [`load`]).
#[inline(never)]
fn run_tick(app: &mut App<'static>, hw: &mut Hw) -> TickOutput {
    app.tick(hw)
}

/// Puts the motors off with raw register writes that cannot fail: the driver enable pin
/// (PB14) low through GPIOB's BSRR, both PWM outputs forced inactive (TIM1 CCMR1 OCxM = 100,
/// immediate) and their compare values zero.
#[inline(always)]
fn motors_off() {
    const GPIOB_BSRR: usize = 0x4002_0418;
    const TIM1_CCMR1: usize = 0x4001_0018;
    const TIM1_CCR1: usize = 0x4001_0034;
    const TIM1_CCR2: usize = 0x4001_0038;
    // BR14: reset PB14. OC1M = OC2M = 0b100 (force inactive) with the preload bits kept.
    const PB14_LOW: u32 = 1 << (16 + 14);
    const FORCE_INACTIVE: u32 = (0b100 << 4) | (1 << 3) | (0b100 << 12) | (1 << 11);
    #[allow(unsafe_code)]
    // SAFETY: fixed, aligned addresses of memory-mapped registers of this MCU (RM0383):
    // GPIOB_BSRR (0x4002_0400 + 0x18), TIM1_CCMR1 (0x4001_0000 + 0x18), TIM1_CCR1/CCR2
    // (+0x34/+0x38). Volatile word writes; BSRR is write-only and atomic, so this races
    // with nothing; the timer writes only stop outputs. Nothing is read, so nothing can
    // fault or fail, even with the peripherals in any state.
    unsafe {
        core::ptr::write_volatile(GPIOB_BSRR as *mut u32, PB14_LOW);
        core::ptr::write_volatile(TIM1_CCMR1 as *mut u32, FORCE_INACTIVE);
        core::ptr::write_volatile(TIM1_CCR1 as *mut u32, 0);
        core::ptr::write_volatile(TIM1_CCR2 as *mut u32, 0);
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    motors_off();
    // The watchdog is no longer fed: it resets the board (motors stay off through reset:
    // the enable line's pull-down, see the README).
    loop {
        cortex_m::asm::nop();
    }
}

#[cortex_m_rt::exception]
#[allow(unsafe_code)]
unsafe fn HardFault(_: &cortex_m_rt::ExceptionFrame) -> ! {
    motors_off();
    loop {
        cortex_m::asm::nop();
    }
}
