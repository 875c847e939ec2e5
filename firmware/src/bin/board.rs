//! The pantograph's board: STM32F411CE "Black Pill" (25 MHz crystal), RTIC 2.
//!
//! Tasks, highest priority first (nothing of a lower priority can delay a tick):
//!
//! 3. `tick` — TIM5's update interrupt, 10 kHz (features `tick-1khz`, `tick-2khz`,
//!    `tick-5khz` for slower ticks): feeds the watchdog, swaps in a committed scene (or gives
//!    the controller the object of a control-point update, keeping its renderer), applies
//!    the link's commands, runs one [`App::tick`] on the encoders and the clock, drives PWM,
//!    directions and driver enable, and queues one telemetry frame per millisecond for USB
//!    (the app folds the millisecond's ticks into it, `device::telemetry`). Never waits,
//!    allocates, logs or panics; it shares nothing with lower priorities but lock-free
//!    single-producer single-consumer queues and atomics.
//! 2. `usb` — the OTG_FS interrupt (and pended by the tick every millisecond): USB HID
//!    (`protocol::device_side::usb::HidPort`, usb-device + usbd-hid), one 64-byte protocol frame per report
//!    ([`Usb`]); host reports
//!    go to the protocol task; the tick's telemetry goes out on interface 0's IN endpoint and
//!    the protocol task's replies on interface 1's, each numbered on its own counter, so that
//!    a reply costs the 1 kHz telemetry nothing.
//! 0. `idle` — the lowest priority, the protocol task ([`Protocol`]): host frames through
//!    the session (which validates an upload into the staging store), commands to the tick,
//!    replies to USB; and the acquisition (the global closest-point search that starts the
//!    renderer after a swap, [`run_job`](firmware::app::run_job)), handed back to the tick.
//!    Sleeps (WFI) when there is nothing to do.
//!
//! This file is the glue: pins, clocks, timers, USB and the watchdog, and the RTIC tasks that
//! call the library (`firmware::{app, swap, protocol_task, usb}`, `device::board_io`).
//!
//! Pins (see the firmware README's table): encoders TIM3 PA6/PA7 and TIM4 PB6/PB7, PWM TIM1
//! CH1 PA8 and CH2 PA9 at 20 kHz, directions PB12/PB13, driver enable PB14 (high = enabled),
//! LED PC13 (active low), USB PA11/PA12, SWD PA13/PA14. The monotonic clock is TIM2, 32 bits
//! at 1 MHz, extended to 64 bits by the tick (it reads it every tick, far more often than
//! once per 71.6 min wrap).
#![no_std]
#![no_main]

use device::board_io::{Extend16, LedPattern, pwm_duty};
use firmware::app::{AcquisitionJob, App, JobDone, Parked, Slot};
use firmware::board::Board;
use firmware::handover;
use firmware::protocol_task::{
    COMMANDS, FRAMES, JOBS, Protocol, REPLIES, REPORTS, Report, STORES, Step, TickShared,
};
use firmware::usb::Usb;
use protocol::device_side::session::{DeviceCommand, DeviceSession, DeviceState};
use protocol::{MAX_FRAME, Message, SceneStore};
use stm32f4xx_hal::gpio::{Output, PB12, PB13, PB14, PC13};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::qei::Qei;
use stm32f4xx_hal::rcc::Rcc;
use stm32f4xx_hal::timer::{CounterHz, Event, Flag, PwmChannel};
use stm32f4xx_hal::watchdog::IndependentWatchdog;
use tracker::Chain;

#[cfg(any(
    all(feature = "tick-1khz", feature = "tick-2khz"),
    all(feature = "tick-1khz", feature = "tick-5khz"),
    all(feature = "tick-2khz", feature = "tick-5khz"),
))]
compile_error!("choose at most one of the features tick-1khz, tick-2khz, tick-5khz");

/// The haptic tick's rate (Hz): 10 kHz unless a feature asks for less.
const TICK_HZ: u32 = if cfg!(feature = "tick-1khz") {
    1_000
} else if cfg!(feature = "tick-2khz") {
    2_000
} else if cfg!(feature = "tick-5khz") {
    5_000
} else {
    10_000
};
/// Ticks per millisecond: the LED's clock (its patterns are in ms). Telemetry is one frame
/// per millisecond too, the app's decimator derives that from the period.
const TICKS_PER_MS: u32 = TICK_HZ / 1_000;
/// The safety layer's ramp-in after forces are enabled or a scene is swapped (s): the
/// safety layer's default, half a second on the hand. (The host's simulator and the QEMU
/// device ramp in over 0.02 s, to keep their runs short.)
const RAMP_TIME_S: f32 = 0.5;
/// The watchdog's timeout (ms, nominal: the LSI clock is 17–47 kHz, so 7–19 ms).
const WATCHDOG_MS: u32 = 10;
/// PWM frequency of the motor drivers' inputs (Hz), above hearing.
const PWM_HZ: u32 = 20_000;

/// The board's scene store: planar curves only (the pantograph renders chains of them; a
/// scene with a surface is refused as `SceneCapacity`, which also keeps the shell's
/// validation, 10 KiB of stack, out of the link task). About 3 KiB.
type BoardStore = SceneStore<128, 96, 0>;
/// The app on a [`BoardStore`]'s object (its own copy of it, at the store's capacities).
type BoardApp = App<'static, 128, 96>;
/// The app's chain slot.
type BoardChain = Chain<128, 96>;
/// The slot as the app and the acquisition job hold it.
type BoardSlot = Slot<'static, 128, 96>;
/// The largest wire scene the board receives (bytes); the receiver holds two.
const SCENE_CAPACITY: usize = 1792;
type Link = DeviceSession<SCENE_CAPACITY>;

/// The tick's state, "a commit is pending" and the last refused command, for the protocol
/// task.
static SHARED: TickShared = TickShared::new();

/// The monotonic clock: TIM2 counting microseconds, 32 bits, extended to 64 by adding the
/// wrapping difference of successive readings (correct while read at least every 71.6 min).
struct Clock {
    tim: pac::TIM2,
    last: u32,
    now_us: u64,
}

impl Clock {
    /// Starts TIM2 at 1 MHz from its kernel clock `tim_hz`, free-running over 32 bits.
    fn start(tim: pac::TIM2, rcc: &mut Rcc, tim_hz: u32) -> Self {
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

/// The motor drivers' inputs: PWM (duty = |I| / full scale), direction pins (high = negative
/// current) and the shared enable pin (high = enabled).
struct Motors {
    pwm_left: PwmChannel<pac::TIM1, 0>,
    pwm_right: PwmChannel<pac::TIM1, 1>,
    max_duty: u16,
    dir_left: PB12<Output>,
    dir_right: PB13<Output>,
    enable: PB14<Output>,
}

/// The tick's board: the peripherals the `App` drives.
struct Hw {
    encoder_left: Qei<pac::TIM3>,
    encoder_right: Qei<pac::TIM4>,
    counts: [Extend16; 2],
    motors: Motors,
    /// The current at full duty (A): the drivers' full scale, set to the device's current
    /// limit (`DeviceSpec::current_limit_a`).
    full_scale_a: [f32; 2],
    clock: Clock,
    faults: u16,
    tick_start: u32,
    last_tick_us: u16,
    frames: heapless::spsc::Producer<'static, Report, FRAMES>,
    /// Frames dropped because USB had not taken the previous ones.
    frames_dropped: u32,
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
        let m = &mut self.motors;
        // Direction first, then the magnitude.
        m.dir_left.set_state((left < 0.0).into());
        m.dir_right.set_state((right < 0.0).into());
        m.pwm_left
            .set_duty(pwm_duty(left, self.full_scale_a[0], m.max_duty));
        m.pwm_right
            .set_duty(pwm_duty(right, self.full_scale_a[1], m.max_duty));
    }

    fn set_faults(&mut self, faults: u16) {
        self.faults = faults;
    }

    fn set_driver_enabled(&mut self, enabled: bool) {
        if enabled && self.faults == 0 {
            self.motors.enable.set_high();
        } else {
            self.motors.enable.set_low();
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

/// The status LED (PC13, active low), lit by [`LedPattern`] (the README's table).
struct Led {
    pin: PC13<Output>,
    ticks: u32,
}

impl Led {
    fn update(&mut self, pattern: LedPattern) {
        self.ticks = self.ticks.wrapping_add(1);
        let on = pattern.lit(self.ticks / TICKS_PER_MS);
        // Active low.
        self.pin.set_state((!on).into());
    }
}

/// The motor outputs, off: the driver enable pin driven low before anything else, the
/// directions low, both PWM channels at zero duty and running at [`PWM_HZ`].
fn motors_start(
    tim1: pac::TIM1,
    (pa8, pa9): (stm32f4xx_hal::gpio::PA8, stm32f4xx_hal::gpio::PA9),
    (pb12, pb13, pb14): (PB12, PB13, PB14),
    rcc: &mut Rcc,
) -> Motors {
    let enable = pb14.into_push_pull_output_in_state(false.into());
    let dir_left = pb12.into_push_pull_output_in_state(false.into());
    let dir_right = pb13.into_push_pull_output_in_state(false.into());
    let (_pwm, (ch1, ch2, ..)) = tim1.pwm_hz(PWM_HZ.Hz(), rcc);
    let mut pwm_left = ch1.with(pa8);
    let mut pwm_right = ch2.with(pa9);
    pwm_left.set_duty(0);
    pwm_right.set_duty(0);
    pwm_left.enable();
    pwm_right.enable();
    let max_duty = pwm_left.get_max_duty();
    Motors {
        pwm_left,
        pwm_right,
        max_duty,
        dir_left,
        dir_right,
        enable,
    }
}

/// The tick's timer (TIM5 at [`TICK_HZ`], its update interrupt the tick), then the watchdog
/// it feeds, stopped while a debugger halts the core.
fn tick_and_watchdog_start(
    tim5: pac::TIM5,
    iwdg: pac::IWDG,
    dbgmcu: &pac::DBGMCU,
    rcc: &mut Rcc,
) -> (CounterHz<pac::TIM5>, IndependentWatchdog) {
    let mut tick_timer = tim5.counter_hz(rcc);
    tick_timer
        .start(TICK_HZ.Hz())
        .expect("the tick rate is within TIM5's range");
    tick_timer.listen(Event::Update);
    let mut watchdog = IndependentWatchdog::new(iwdg);
    watchdog.stop_on_debug(dbgmcu, true);
    // Keep the debug port clocked in `wfi`, so that a probe (probe-rs RTT) stays attached.
    dbgmcu.cr().modify(|_, w| w.dbg_sleep().set_bit());
    watchdog.start(WATCHDOG_MS.millis());
    (tick_timer, watchdog)
}

/// The tick's ends of the queues to and from the protocol task.
struct TickQueues {
    commands: heapless::spsc::Consumer<'static, DeviceCommand, COMMANDS>,
    commits: heapless::spsc::Consumer<'static, &'static mut BoardStore, STORES>,
    freed: heapless::spsc::Producer<'static, &'static mut BoardStore, STORES>,
    jobs: heapless::spsc::Producer<'static, AcquisitionJob<BoardSlot>, JOBS>,
    results: heapless::spsc::Consumer<'static, JobDone<BoardSlot>, JOBS>,
}

/// The queues between the tasks, `'static` in `init`'s locals.
struct Queues {
    command: &'static mut heapless::spsc::Queue<DeviceCommand, COMMANDS>,
    frame: &'static mut heapless::spsc::Queue<Report, FRAMES>,
    report: &'static mut heapless::spsc::Queue<Report, REPORTS>,
    reply: &'static mut heapless::spsc::Queue<Message, REPLIES>,
    commit: &'static mut heapless::spsc::Queue<&'static mut BoardStore, STORES>,
    free: &'static mut heapless::spsc::Queue<&'static mut BoardStore, STORES>,
    job: &'static mut heapless::spsc::Queue<AcquisitionJob<BoardSlot>, JOBS>,
    result: &'static mut heapless::spsc::Queue<JobDone<BoardSlot>, JOBS>,
}

#[rtic::app(device = stm32f4xx_hal::pac, peripherals = true)]
mod app {
    use super::*;
    use heapless::spsc::Queue;
    use protocol::device_side::usb::HidPort;
    use stm32f4xx_hal::otg_fs::{USB, UsbBusType};
    use usb_device::class_prelude::UsbBusAllocator;

    #[shared]
    struct Shared {}

    #[local]
    struct Local {
        tick_timer: CounterHz<pac::TIM5>,
        watchdog: IndependentWatchdog,
        hw: Hw,
        led: Led,
        app: BoardApp,
        tick: TickQueues,
        port: HidPort<'static, UsbBusType>,
        usb: Usb,
        protocol: Protocol<SCENE_CAPACITY, BoardStore, 128, 96>,
    }

    /// Splits the queues between the tick, USB and the protocol task, and hands the scene
    /// store to the protocol task to validate into.
    fn wire_tasks(
        q: Queues,
        session: &'static mut Link,
        store: &'static mut BoardStore,
    ) -> (
        TickQueues,
        heapless::spsc::Producer<'static, Report, FRAMES>,
        Usb,
        Protocol<SCENE_CAPACITY, BoardStore, 128, 96>,
    ) {
        let (command_tx, command_rx) = q.command.split();
        let (frame_tx, frame_rx) = q.frame.split();
        let (report_tx, report_rx) = q.report.split();
        let (reply_tx, reply_rx) = q.reply.split();
        let (commit_tx, commit_rx) = q.commit.split();
        let (free_tx, free_rx) = q.free.split();
        let (job_tx, job_rx) = q.job.split();
        let (result_tx, result_rx) = q.result.split();
        let tick = TickQueues {
            commands: command_rx,
            commits: commit_rx,
            freed: free_tx,
            jobs: job_tx,
            results: result_rx,
        };
        let usb = Usb {
            reports: report_tx,
            replies: reply_rx,
            frames: frame_rx,
        };
        let protocol = Protocol {
            session,
            shared: &SHARED,
            store: Some(store),
            reports: report_rx,
            replies: reply_tx,
            commands: command_tx,
            commits: commit_tx,
            freed: free_rx,
            jobs: job_rx,
            results: result_tx,
        };
        (tick, frame_tx, usb, protocol)
    }

    /// USB (OTG_FS, 48 MHz from the PLL's Q output): the board's HID device
    /// (`protocol::device_side::usb::HidPort`: the protocol's report descriptor, the ids and strings).
    fn usb_start(
        usb: USB,
        usb_bus: &'static mut Option<UsbBusAllocator<UsbBusType>>,
        ep_memory: &'static mut [u32; 64],
    ) -> HidPort<'static, UsbBusType> {
        let usb_bus: &'static UsbBusAllocator<UsbBusType> =
            usb_bus.insert(UsbBusType::new(usb, ep_memory));
        HidPort::new(usb_bus, "0001").expect("the bus holds two HID interfaces and its strings")
    }

    #[init(local = [
        ep_memory: [u32; 64] = [0; 64],
        usb_bus: Option<UsbBusAllocator<UsbBusType>> = None,
        session: Link = DeviceSession::new(false),
        command_queue: Queue<DeviceCommand, COMMANDS> = Queue::new(),
        frame_queue: Queue<Report, FRAMES> = Queue::new(),
        report_queue: Queue<Report, REPORTS> = Queue::new(),
        reply_queue: Queue<Message, REPLIES> = Queue::new(),
        commit_queue: Queue<&'static mut BoardStore, STORES> = Queue::new(),
        free_queue: Queue<&'static mut BoardStore, STORES> = Queue::new(),
        job_queue: Queue<AcquisitionJob<BoardSlot>, JOBS> = Queue::new(),
        result_queue: Queue<JobDone<BoardSlot>, JOBS> = Queue::new(),
        // The one scene store (the link decodes into it, the tick rebuilds its chain from it)
        // and the app's chain slot: all zero bits, so in `.bss`.
        store: BoardStore = BoardStore::empty(),
        chain: BoardChain = BoardChain::EMPTY,
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
        // Motors off before anything else.
        let motors = motors_start(
            dp.TIM1,
            (gpioa.pa8, gpioa.pa9),
            (gpiob.pb12, gpiob.pb13, gpiob.pb14),
            &mut rcc,
        );
        let led = gpioc.pc13.into_push_pull_output_in_state(true.into());

        let encoder_left = Qei::new(dp.TIM3, (gpioa.pa6, gpioa.pa7), &mut rcc);
        let encoder_right = Qei::new(dp.TIM4, (gpiob.pb6, gpiob.pb7), &mut rcc);
        let counts = [
            Extend16::new(encoder_left.count()),
            Extend16::new(encoder_right.count()),
        ];
        let tim_hz = rcc.clocks.timclk1().raw();
        let clock = Clock::start(dp.TIM2, &mut rcc, tim_hz);

        let l = cx.local;
        let (tick, frames, usb, protocol) = wire_tasks(
            Queues {
                command: l.command_queue,
                frame: l.frame_queue,
                report: l.report_queue,
                reply: l.reply_queue,
                commit: l.commit_queue,
                free: l.free_queue,
                job: l.job_queue,
                result: l.result_queue,
            },
            l.session,
            l.store,
        );

        let app = match Parked::new(l.chain, 1.0 / TICK_HZ as f32, RAMP_TIME_S) {
            Ok(parked) => parked.unloaded(),
            Err(e) => panic!("controller: {e}"),
        };
        let full_scale_a = app.controller().spec().current_limit_a;
        // An identification run beyond the app's motors is nacked before it is acked.
        protocol.session.set_motor_limits(app.controller().spec());

        assert!(rcc.clocks.is_pll48clk_valid(), "USB needs a 48 MHz clock");
        let port = usb_start(
            USB::new(
                (dp.OTG_FS_GLOBAL, dp.OTG_FS_DEVICE, dp.OTG_FS_PWRCLK),
                (gpioa.pa11, gpioa.pa12),
                &rcc.clocks,
            ),
            l.usb_bus,
            l.ep_memory,
        );
        let (tick_timer, watchdog) =
            tick_and_watchdog_start(dp.TIM5, dp.IWDG, &dp.DBGMCU, &mut rcc);

        let hw = Hw {
            encoder_left,
            encoder_right,
            counts,
            motors,
            full_scale_a,
            clock,
            faults: 0,
            tick_start: 0,
            last_tick_us: 0,
            frames,
            frames_dropped: 0,
        };
        (
            Shared {},
            Local {
                tick_timer,
                watchdog,
                hw,
                led: Led { pin: led, ticks: 0 },
                app,
                tick,
                port,
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
            match cx.local.protocol.step() {
                Step::Received => rtic::pend(pac::Interrupt::OTG_FS),
                Step::Acquired => {}
                Step::Idle => cortex_m::asm::wfi(),
            }
        }
    }

    /// The haptic tick.
    #[task(binds = TIM5, priority = 3, local = [tick_timer, watchdog, hw, led, app, tick])]
    fn tick(cx: tick::Context) {
        let l = cx.local;
        l.tick_timer.clear_flags(Flag::Update);
        l.watchdog.feed();

        // The acquisition's result with the object it searched: the renderer starts (refused
        // if it is for an older scene or material).
        if let Some(done) = l.tick.results.dequeue() {
            let _ = l.app.job_done(done);
        }
        // A committed scene (or the scene with control points moved: the controller's object
        // moves in place, its renderer carries on), taken in at this tick boundary once the
        // object is back from its acquisition; the store goes back to the protocol task.
        if let Some(incoming) = SHARED.pending()
            && !l.app.job_out()
            && let Some(store) = l.tick.commits.dequeue()
        {
            let taken = handover::take_in(l.app, incoming, store);
            let _ = l.tick.freed.enqueue(store);
            // Accepted on the link but not rendered: the next status says why.
            if let Some(Err(e)) = taken {
                SHARED.command_refused(e.code());
            }
            SHARED.commit_done();
        }

        while let Some(command) = l.tick.commands.dequeue() {
            // A calibration records the counts now: the user holds the joints on their stops.
            let home = l.hw.encoder_counts();
            if let Err(code) = l.app.apply(command, home) {
                SHARED.command_refused(code);
            }
        }

        let faults = run_tick(l.app, l.hw);
        // The renderer waits for its acquisition: the object goes to the protocol task (one
        // job at a time: none is lent while one is out).
        if let Some(job) = l.app.lend_job()
            && let Err(job) = l.tick.jobs.enqueue(job)
        {
            let _ = l.app.job_done(job.refused());
        }
        let controller = l.app.controller();
        let state = DeviceState {
            software: [0; 3],
            forces_enabled: controller.forces_enabled(),
            calibrated: controller.is_calibrated(),
            faults,
        };
        SHARED.set_state(&state);
        let driving = state.forces_enabled && state.faults == 0;
        l.led
            .update(LedPattern::of(state.faults, state.calibrated, driving));
    }

    /// USB: enumeration, host reports in (to the protocol task), replies and telemetry out.
    #[task(binds = OTG_FS, priority = 2, local = [port, usb])]
    fn usb(cx: usb::Context) {
        // Unconfigured (no host): telemetry is dropped, not queued.
        cx.local.port.poll(cx.local.usb);
    }
}

/// One [`App::tick`], returning the tick's latched faults; not inlined, so that its frame and
/// a scene load's (`handover::load`, which rebuilds the chain in its slot) do not add up on
/// the stack.
#[inline(never)]
fn run_tick(app: &mut BoardApp, hw: &mut Hw) -> u16 {
    app.tick(hw).telemetry.faults
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
