//! The control-point run: a stream of updates under the held hand through the board's
//! session, stores and double buffer, every tick and each update's link and tick parts
//! counted.

use super::*;

/// The board's scene receiver capacity (bytes).
const BOARD_SCENE_CAPACITY: usize = 1792;

/// The points run: where the hand goes (m): from outside the right arc to 4 mm inside it at
/// 30°, over [`POINTS_APPROACH_S`], then held.
const POINTS_FROM_M: Vec2 = Vec2::new(0.03, 0.075);
const POINTS_APPROACH_S: f64 = 0.2;
const POINTS_HOLD_S: f64 = 0.1;
/// Then one update every [`POINTS_EVERY_S`] for [`POINTS_STREAM_S`]: the right arc's middle
/// control point 1 mm out and back at 2 Hz, along the line from the arc's centre through it.
const POINTS_EVERY_S: f64 = 0.01;
const POINTS_STREAM_S: f64 = 1.0;
const POINTS_AMPLITUDE_M: f32 = 1e-3;
const POINTS_FREQUENCY_HZ: f32 = 2.0;

/// A host frame: `message` numbered `seq`, encoded into `buf`; its bytes. Numbered as a
/// host numbers (`next_seq`: skipping 0xFFFF), which the board's receiver expects.
fn host_frame(buf: &mut [u8; FRAME_BYTES], seq: &mut u16, message: Message) -> usize {
    let n = Frame { seq: *seq, message }.encode(buf);
    *seq = protocol::next_seq(*seq);
    n
}

/// A control-point stream under a held hand through the board's code, counted: the scene
/// uploaded through a board's [`DeviceSession`] (its receiver, the board's capacities) into the
/// board's one store and loaded into the app's chain slot (`firmware::handover`), the hand
/// pressed into the right arc,
/// then 100 updates a second, each through the session (the link task's part: staging, CRC,
/// the validation and topology check, counted alone) and applied at the next tick boundary
/// (`handover::take_in`: the tick's part, counted alone), every tick counted. The
/// telemetry stays off the UART (the host compares the scenario's frames only); the run
/// fails if the stream loses contact, switches feature or faults, or an update is refused.
#[inline(never)]
pub(crate) fn points_run(board: &mut QemuBoard, scenario: &Scenario<'_>) {
    let name = "thesis-2d-points";
    let rate_hz = scenario.rate_hz;
    let period_s = (1.0 / rate_hz) as f32;
    let fail_at = |what: &str| -> ! { fail(format_args!("scene {name}: {what}")) };
    // The board's one store and the app's chain slot, in this run's frame (it never returns
    // before the run ends).
    let mut scene_store = BoardStore::empty();
    let mut chain = BoardChain::EMPTY;
    let mut store = Some(&mut scene_store);
    let mut app: BoardApp<'_> = match Parked::new(&mut chain, period_s, scenario.ramp_time_s) {
        Ok(p) => p.unloaded(),
        Err(e) => fail(format_args!("scene {name}: {e}")),
    };
    let mut session: DeviceSession<BOARD_SCENE_CAPACITY> = DeviceSession::new(false);
    let mut seq = 0u16;
    let mut buf = [0u8; FRAME_BYTES];
    let state = DeviceState::default();
    // What a frame does: its event (a refusal fails the run).
    let handle = |session: &mut DeviceSession<BOARD_SCENE_CAPACITY>,
                  store: &mut Option<&mut BoardStore>,
                  bytes: &[u8]|
     -> Event {
        let mut refused = None;
        let event = session.handle(
            bytes,
            &mut Validator::new(store, false),
            state,
            &mut |m: &Message| {
                if let Message::Nack(n) = m {
                    refused = Some(n.code);
                }
            },
        );
        if let Some(code) = refused {
            fail(format_args!("scene {name}: a frame was refused: {code}"));
        }
        event
    };
    // Loads or reshapes at a tick boundary, as the board's tick (the object is never lent
    // here: the search runs in place between ticks).
    let take_in = |app: &mut BoardApp<'_>, store: &Option<&mut BoardStore>, incoming: Incoming| {
        let Some(committed) = store.as_deref() else {
            fail_at("no store");
        };
        match handover::take_in(app, incoming, committed) {
            Some(Ok(())) => {}
            Some(Err(e)) => fail(format_args!("scene {name}: {e}")),
            None => fail_at("the object is lent"),
        }
    };
    for m in scene_upload(SCENE) {
        let n = host_frame(&mut buf, &mut seq, m);
        if handle(&mut session, &mut store, &buf[..n]) == Event::SceneCommitted {
            take_in(&mut app, &store, Incoming::Scene);
        }
    }
    if let Err(e) = app.controller_mut().calibrate(scenario.end_stop_counts) {
        fail(format_args!("calibration: {e}"));
    }
    app.controller_mut().set_forces_enabled(true);
    let arm = match SimulatedPantograph::new(
        DeviceSpec::default(),
        SimParams::default(),
        POINTS_FROM_M,
    ) {
        Ok(arm) => arm,
        Err(e) => fail(format_args!("simulated pantograph: {e}")),
    };
    board.sim.arm = arm;
    // The host's copy of the scene, kept with `write_points` (the device's CRC must be its).
    let mut image = [0u8; BOARD_SCENE_CAPACITY];
    let Some(image) = image.get_mut(..SCENE.len()) else {
        fail_at("the scene is larger than the board's receiver");
    };
    image.copy_from_slice(SCENE);
    let centre = Vec2::new(-0.02, 0.06);
    let a = 30.0f32.to_radians();
    let inside = centre + Vec2::new(libm::cosf(a), libm::sinf(a)) * 0.036;
    let Some(p1) = app
        .controller()
        .object()
        .and_then(|c| c.curve(0).control_point(1))
        .map(|(p, _)| p)
    else {
        fail_at("no right arc");
    };
    let out = (p1 - centre).normalize();
    let ticks = |s: f64| libm::round(s * rate_hz) as usize;
    let (approach, hold, every) = (
        ticks(POINTS_APPROACH_S),
        ticks(POINTS_HOLD_S),
        ticks(POINTS_EVERY_S).max(1),
    );
    let stream_from = approach + hold;
    let total = stream_from + ticks(POINTS_STREAM_S);
    let overhead = board.meter.overhead;
    let count = |r: Result<u32, Overflow>, what: &str| match r {
        Ok(n) => n.saturating_sub(overhead),
        Err(e) => fail(format_args!("scene {name}: {what}: {e:?}")),
    };
    let (mut ticks_all, mut ticks_after, mut apply, mut validate, mut period) = (
        Stats::default(),
        Stats::default(),
        Stats::default(),
        Stats::default(),
        Stats::default(),
    );
    let mut updates = 0u32;
    for i in 0..total {
        board.sim.now_us = libm::round(i as f64 * 1e6 / rate_hz) as u64;
        let mut applied = None;
        if i >= stream_from && (i - stream_from).is_multiple_of(every) {
            // The host's shape for this update, through the link task's code...
            let t = ((i - stream_from) as f64 / rate_hz) as f32;
            let d = POINTS_AMPLITUDE_M
                * libm::sinf(2.0 * core::f32::consts::PI * POINTS_FREQUENCY_HZ * t);
            let to = [p1 + out * d];
            let mut event = Event::None;
            for m in points_update(0, &[(0, 1, &to[..])]) {
                if let Message::ScenePoints(p) = m
                    && write_points(image, &p).is_err()
                {
                    fail_at("the host's copy refused the update");
                }
                let n = host_frame(&mut buf, &mut seq, m);
                let (e, c) = board
                    .meter
                    .instructions(|| handle(&mut session, &mut store, &buf[..n]));
                validate.add(count(c, "validation"), i);
                event = e;
            }
            if event != (Event::ScenePointsUpdated { object: 0 }) {
                fail_at("an update was not applied on the link");
            }
            // ...and the tick's, at this tick boundary.
            let ((), c) = board
                .meter
                .instructions(|| take_in(&mut app, &store, Incoming::Points));
            let c = count(c, "apply");
            apply.add(c, i);
            applied = Some(c);
            updates += 1;
        }
        app.controller_mut().heartbeat();
        let out = app.tick(board);
        let n = count(core::mem::replace(&mut board.last, Ok(0)), "tick");
        let tm = out.telemetry;
        if i >= stream_from {
            ticks_all.add(n, i);
            if let Some(c) = applied {
                ticks_after.add(n, i);
                period.add(c + n, i);
            }
            if tm.mode == Mode::Free
                || tm.faults != 0
                || tm.feature != Some(tracker::Feature::Patch(0))
            {
                fail(format_args!(
                    "scene {name}: tick {i} under the stream: mode {:?}, feature {:?}, faults \
                     {:#x}",
                    tm.mode, tm.feature, tm.faults
                ));
            }
        }
        app.acquire();
        let target = if i < approach {
            POINTS_FROM_M + (inside - POINTS_FROM_M) * (i as f32 / approach as f32)
        } else {
            inside
        };
        if let Err(e) = board.sim.step_plant(target, period_s) {
            fail(format_args!("tick {i}: simulated arm: {e}"));
        }
    }
    let crc = session.receiver().active_crc32();
    if crc != crc32(image) {
        fail(format_args!(
            "scene {name}: the device's CRC {crc:#x} is not the host's {:#x}",
            crc32(image)
        ));
    }
    hprintln!(
        "points scene={} rate_hz={} updates={} update_rate_hz={} ticks={} crc={:#x} \
         host_crc={:#x}",
        name,
        rate_hz,
        updates,
        1.0 / POINTS_EVERY_S,
        ticks_all.n,
        crc,
        crc32(image)
    );
    hprintln!("instructions_per_tick scene={} {}", name, ticks_all);
    hprintln!(
        "instructions_per_tick_after_update scene={} {}",
        name,
        ticks_after
    );
    hprintln!("instructions_points_apply scene={} {}", name, apply);
    hprintln!("instructions_points_validate scene={} {}", name, validate);
    hprintln!("instructions_points_period scene={} {}", name, period);
}
