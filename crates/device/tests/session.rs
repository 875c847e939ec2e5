//! The device side of a link ([`device::session::Session`]): what each accepted frame asks of
//! the device, what is answered, and what a board's session refuses.

#![allow(clippy::unwrap_used)]

use device::protocol::{ErrorCode, Frame, Hello, MAX_PAYLOAD, Message, Nack, SceneError, Status};
use device::session::{Command, DeviceState, Event, Session};
use friction::FrictionMaterial;
use nurbs::Vec2;

fn frame(seq: u16, message: Message) -> Vec<u8> {
    let (report, n) = Frame { seq, message }.to_report();
    report[..n].to_vec()
}

fn never(_: &[u8]) -> Result<(), SceneError> {
    panic!("no commit in these tests")
}

const STATE: DeviceState = DeviceState {
    software: [3, 1, 4],
    forces_enabled: true,
    calibrated: false,
    faults: 0b1000,
};

/// Handles `message` as frame `seq`; returns the event and the replies.
fn handle(session: &mut Session<1024>, seq: u16, message: Message) -> (Event, Vec<Message>) {
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
    let mut s = Session::<1024>::new(true);
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
    assert_eq!(event, Event::Command(Command::Heartbeat));
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
        (9, Message::EnableForces, Command::Forces(true)),
        (10, Message::DisableForces, Command::Forces(false)),
        (11, Message::Calibrate, Command::Calibrate),
        (12, Message::ClearFaults { mask: 1 }, Command::ClearFaults),
        (
            13,
            Message::SetMaterial {
                object: 0,
                material,
            },
            Command::SetMaterial(material),
        ),
    ] {
        let (event, replies) = handle(&mut s, seq, message);
        assert_eq!(event, Event::Command(command), "{message:?}");
        assert_eq!(replies, [Message::Ack { seq }]);
    }
    let target = Vec2::new(0.01, 0.08);
    let (event, _) = handle(&mut s, 14, Message::HandTarget { target_m: target });
    assert_eq!(event, Event::HandTarget(target));
}

#[test]
fn refusals_are_nacked_and_noted_for_the_status() {
    // A board's session: a hand target is refused with its own code, and the next status says
    // so; a material for another object than the rendered one is noted as a bad field.
    let mut s = Session::<1024>::new(false);
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
