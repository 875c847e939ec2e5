//! The device side of a link ([`protocol::device_side::session::DeviceSession`]): what each accepted frame asks of
//! the device, what is answered, and what a board's session refuses.

#![allow(clippy::unwrap_used)]

use friction::FrictionMaterial;
use nurbs::Vec2;
use protocol::device_side::session::{DeviceCommand, DeviceSession, DeviceState, Event};
use protocol::{ErrorCode, Frame, Hello, MAX_PAYLOAD, Message, Nack, Status, WireSceneError};

fn frame(seq: u16, message: Message) -> Vec<u8> {
    let (report, n) = Frame { seq, message }.to_report();
    report[..n].to_vec()
}

fn never(_: &[u8]) -> Result<(), WireSceneError> {
    panic!("no commit in these tests")
}

const STATE: DeviceState = DeviceState {
    software: [3, 1, 4],
    forces_enabled: true,
    calibrated: false,
    faults: 0b1000,
};

/// Handles `message` as frame `seq`; returns the event and the replies.
fn handle(session: &mut DeviceSession<1024>, seq: u16, message: Message) -> (Event, Vec<Message>) {
    let mut replies = Vec::new();
    let event = session.handle(
        &frame(seq, message),
        &mut never,
        STATE,
        &mut |m: &Message| replies.push(*m),
    );
    (event, replies)
}

#[test]
fn each_accepted_frame_is_acked_and_asks_the_device_for_what_it_says() {
    let mut s = DeviceSession::<1024>::new(true);
    let host = Hello {
        software: [0, 1, 0],
        scene_capacity: 0,
        max_payload: MAX_PAYLOAD as u8,
    };
    // A hello is answered with the device's own, the version the caller passed.
    let (event, replies) = handle(&mut s, 7, Message::Hello(host));
    assert_eq!(event, Event::None);
    assert_eq!(
        replies,
        [
            Message::Ack { seq: 7 },
            Message::Hello(Hello {
                software: [3, 1, 4],
                scene_capacity: 1024,
                max_payload: MAX_PAYLOAD as u8,
            })
        ]
    );
    // A heartbeat: the status made of the caller's state, and the heartbeat for the controller.
    let (event, replies) = handle(&mut s, 8, Message::Heartbeat { uptime_ms: 5 });
    assert_eq!(event, Event::DeviceCommand(DeviceCommand::Heartbeat));
    assert_eq!(replies[0], Message::Ack { seq: 8 });
    let Message::Status(Status {
        forces_enabled,
        calibrated,
        faults,
        expected_seq,
        last_error,
        ..
    }) = replies[1]
    else {
        panic!("{replies:?}")
    };
    assert_eq!(
        (forces_enabled, calibrated, faults, expected_seq, last_error),
        (true, false, 0b1000, 9, 0)
    );
    let material = FrictionMaterial::default();
    for (seq, message, command) in [
        (9, Message::EnableForces, DeviceCommand::Forces(true)),
        (10, Message::DisableForces, DeviceCommand::Forces(false)),
        (11, Message::Calibrate, DeviceCommand::Calibrate),
        (
            12,
            Message::ClearFaults { mask: 1 },
            DeviceCommand::ClearFaults,
        ),
        (
            13,
            Message::SetMaterial {
                object: 0,
                material,
            },
            DeviceCommand::SetMaterial(material),
        ),
    ] {
        let (event, replies) = handle(&mut s, seq, message);
        assert_eq!(event, Event::DeviceCommand(command), "{message:?}");
        assert_eq!(replies, [Message::Ack { seq }]);
    }
    let target = Vec2::new(0.01, 0.08);
    let (event, _) = handle(&mut s, 14, Message::HandTarget { target_m: target });
    assert_eq!(event, Event::HandTarget(target));
    // An identification run: milliseconds on the wire, microseconds for the controller (a
    // calibrated device whose motors give the torques).
    s.set_motor_limits(&device::spec::DeviceSpec::default());
    let mut replies = Vec::new();
    let event = s.handle(
        &frame(
            15,
            Message::Excite {
                torque_nm: [0.008, -0.007],
                half_period_ms: [150, 210],
                duration_ms: 6000,
            },
        ),
        &mut never,
        DeviceState {
            calibrated: true,
            ..STATE
        },
        &mut |m: &Message| replies.push(*m),
    );
    assert_eq!(replies, [Message::Ack { seq: 15 }]);
    assert_eq!(
        event,
        Event::DeviceCommand(DeviceCommand::Excite(device::controller::Excitation {
            torque_nm: [0.008, -0.007],
            half_period_us: [150_000, 210_000],
            duration_us: 6_000_000,
        }))
    );
}

#[test]
fn refusals_are_nacked_and_noted_for_the_status() {
    // A board's session: a hand target is refused with its own code, and the next status says
    // so; a material for another object than the rendered one is noted as a bad field.
    let mut s = DeviceSession::<1024>::new(false);
    let (event, replies) = handle(
        &mut s,
        1,
        Message::HandTarget {
            target_m: Vec2::ZERO,
        },
    );
    assert_eq!(event, Event::None);
    assert!(matches!(
        replies[..],
        [Message::Nack(Nack {
            seq: 1,
            code: ErrorCode::NotSimulated,
            ..
        })]
    ));
    assert_eq!(s.status(STATE).last_error, ErrorCode::NotSimulated as u8);
    let (event, _) = handle(
        &mut s,
        2,
        Message::SetMaterial {
            object: 1,
            material: FrictionMaterial::default(),
        },
    );
    assert_eq!(event, Event::None);
    assert_eq!(s.status(STATE).last_error, ErrorCode::BadField as u8);
    // A command the device refused later (a calibration that failed) is noted by the caller.
    s.note_error(ErrorCode::BadMaterial);
    assert_eq!(s.status(STATE).last_error, ErrorCode::BadMaterial as u8);
}

/// A board's tick hands its state to the link task as one word: every state survives the
/// trip (all 2¹⁶ fault patterns with each pair of flags), and the layout is the documented
/// one (faults in bits 0–15, forces enabled bit 16, calibrated bit 17), written out by hand.
#[test]
fn device_state_survives_its_word_and_the_word_has_the_documented_layout() {
    let software = [1, 2, 3];
    for faults in 0..=u16::MAX {
        for (forces_enabled, calibrated) in
            [(false, false), (true, false), (false, true), (true, true)]
        {
            let state = DeviceState {
                software,
                forces_enabled,
                calibrated,
                faults,
            };
            assert_eq!(DeviceState::from_word(software, state.to_word()), state);
        }
    }
    let state = |forces_enabled, calibrated, faults| DeviceState {
        software,
        forces_enabled,
        calibrated,
        faults,
    };
    assert_eq!(state(false, false, 0).to_word(), 0);
    assert_eq!(state(true, false, 0xA5A5).to_word(), 0x0001_A5A5);
    assert_eq!(state(false, true, 0x0008).to_word(), 0x0002_0008);
    assert_eq!(state(true, true, 0xFFFF).to_word(), 0x0003_FFFF);
    // Bits above 17 carry nothing.
    assert_eq!(
        DeviceState::from_word(software, 0xFFFC_0000),
        state(false, false, 0)
    );
}

/// An identification run the device would refuse is nacked with the reason's code, not acked
/// (before, it was acked and the refusal showed only in a `last_error` that never cleared), and
/// `last_error` clears once a status has carried it or a later request was accepted. The
/// board's session runs this code (`firmware::protocol_task`), so its path is this one.
#[test]
fn a_refused_excitation_is_nacked_with_its_reason_and_the_reason_clears() {
    use device::controller::Excitation;
    use device::spec::DeviceSpec;
    let spec = DeviceSpec::default();
    // The motors' torque at their current limit, from the description's own numbers:
    // 2 A × 23.4 mN·m/A × 10 = 0.468 N·m.
    assert_eq!(
        (
            spec.current_limit_a,
            spec.torque_constant_nm_per_a,
            spec.transmission_ratio
        ),
        ([2.0; 2], [0.0234; 2], [10.0; 2])
    );
    let calibrated = DeviceState {
        calibrated: true,
        ..STATE
    };
    let excite = |torque_nm: [f32; 2]| Message::Excite {
        torque_nm,
        half_period_ms: [150, 210],
        duration_ms: 6000,
    };
    let handle_in = |s: &mut DeviceSession<1024>, state: DeviceState, seq: u16, m: Message| {
        let mut replies = Vec::new();
        let event = s.handle(&frame(seq, m), &mut never, state, &mut |r: &Message| {
            replies.push(*r)
        });
        (event, replies)
    };
    let nack = |replies: &[Message]| match replies {
        [Message::Nack(n)] => *n,
        other => panic!("not one nack: {other:?}"),
    };
    for simulated_plant in [true, false] {
        let mut s = DeviceSession::<1024>::new(simulated_plant);
        s.set_motor_limits(&spec);
        // (torque, state, code): 1e30 N·m; just past the limit on joint 1 (0.47 > 0.468);
        // a good torque on a device not calibrated.
        for (seq, torque, state, code) in [
            (1, [1e30, 0.0], calibrated, ErrorCode::TorqueBeyondMotor),
            (2, [0.0, 0.47], calibrated, ErrorCode::TorqueBeyondMotor),
            (3, [0.008, 0.007], STATE, ErrorCode::NotCalibrated),
        ] {
            let (event, replies) = handle_in(&mut s, state, seq, excite(torque));
            let n = nack(&replies);
            assert_eq!((n.seq, n.code, n.expected_seq), (seq, code, seq + 1));
            assert_eq!(event, Event::None, "{torque:?}");
            assert_eq!(s.status(state).last_error, code as u8);
        }
        // Read by a status: the heartbeat's carries it, the next one's is clear.
        let status_of = |replies: &[Message]| match replies {
            [Message::Ack { .. }, Message::Status(st)] => *st,
            other => panic!("{other:?}"),
        };
        let (_, replies) = handle_in(&mut s, calibrated, 4, Message::Heartbeat { uptime_ms: 0 });
        assert_eq!(
            status_of(&replies).last_error,
            ErrorCode::NotCalibrated as u8
        );
        let (_, replies) = handle_in(&mut s, calibrated, 5, Message::Heartbeat { uptime_ms: 0 });
        assert_eq!(status_of(&replies).last_error, 0);
        // Superseded: a refused run, then one the device takes, acked and passed on.
        handle_in(&mut s, calibrated, 6, excite([1e30, 0.0]));
        assert_eq!(
            s.status(calibrated).last_error,
            ErrorCode::TorqueBeyondMotor as u8
        );
        let (event, replies) = handle_in(&mut s, calibrated, 7, excite([0.468, -0.468]));
        assert_eq!(replies, [Message::Ack { seq: 7 }]);
        assert_eq!(
            event,
            Event::DeviceCommand(DeviceCommand::Excite(Excitation {
                torque_nm: [0.468, -0.468],
                half_period_us: [150_000, 210_000],
                duration_us: 6_000_000,
            }))
        );
        assert_eq!(s.status(calibrated).last_error, 0);
    }
}

/// The controller's own refusal (the tick's path on a board, `DeviceCommand::apply`) has the same
/// codes as the session's nack, not a generic bad field.
#[test]
fn the_controller_refuses_an_excitation_with_the_sessions_codes() {
    use device::controller::{Controller, Excitation};
    use device::safety::SafetyConfig;
    use device::spec::DeviceSpec;
    use tracker::Chain;
    let spec = DeviceSpec::default();
    let mut c: Controller<Chain> = Controller::new(spec, SafetyConfig::default()).unwrap();
    let run = |torque_nm| {
        DeviceCommand::Excite(Excitation {
            torque_nm,
            half_period_us: [150_000, 210_000],
            duration_us: 6_000_000,
        })
    };
    let home = spec.end_stop_counts();
    assert_eq!(
        run([0.008, 0.007]).apply(&mut c, home, true),
        Err(ErrorCode::NotCalibrated)
    );
    DeviceCommand::Calibrate.apply(&mut c, home, true).unwrap();
    assert_eq!(
        run([1e30, 0.0]).apply(&mut c, home, true),
        Err(ErrorCode::TorqueBeyondMotor)
    );
    assert_eq!(run([0.008, 0.007]).apply(&mut c, home, true), Ok(()));
    assert!(c.exciting());
}
