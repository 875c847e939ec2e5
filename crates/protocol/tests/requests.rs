//! The host's request/ack engine against the protocol's rules for answers: an ack of a
//! request's last frame applies it, a nack of any of its frames refuses it whole, sequence
//! numbers wrap from 0xFFFE to 0 (the host never sends 0xFFFF), a nack of an unreadable frame
//! answers nothing, and unanswered requests expire.

use std::time::{Duration, Instant};

use nurbs::Vec2;
use protocol::host_side::{Answer, Link, LinkError, Requests};
use protocol::{ErrorCode, Frame, Message, NO_INDEX, Nack, UNKNOWN_SEQ, next_seq, points_update};

/// A link that numbers what it sends as a host does, from `next`, and receives nothing.
#[derive(Debug)]
struct Numbering {
    next: u16,
    sent: Vec<(u16, Message)>,
    /// Sends before the link fails.
    fail_after: usize,
}

impl Numbering {
    fn from(next: u16) -> Self {
        Numbering {
            next,
            sent: Vec::new(),
            fail_after: usize::MAX,
        }
    }
}

impl Link for Numbering {
    fn send(&mut self, message: &Message) -> Result<u16, LinkError> {
        if self.sent.len() >= self.fail_after {
            return Err(LinkError::Timeout(Duration::ZERO));
        }
        let seq = self.next;
        self.next = next_seq(seq);
        self.sent.push((seq, *message));
        Ok(seq)
    }

    fn recv(&mut self, _: Duration) -> Result<Option<Frame>, LinkError> {
        Ok(None)
    }
}

fn nack(seq: u16, code: ErrorCode) -> Message {
    Message::Nack(Nack {
        seq,
        code,
        object: NO_INDEX,
        patch: NO_INDEX,
        expected_seq: 0,
    })
}

/// An update of `n` planar points: `n / 6` frames rounded up (six points a frame).
fn update(n: usize) -> impl Iterator<Item = Message> {
    let points: Vec<Vec2> = (0..n).map(|i| Vec2::new(i as f32 * 1e-3, 0.0)).collect();
    points_update(0, &[(0, 0, &points[..])])
        .collect::<Vec<_>>()
        .into_iter()
}

#[test]
fn an_update_across_the_wrap_is_applied_by_the_ack_of_its_last_frame() {
    // Three frames numbered 0xFFFD, 0xFFFE, 0 (the host skips 0xFFFF).
    let mut link = Numbering::from(0xFFFD);
    let mut requests = Requests::new();
    requests
        .send(&mut link, update(13), 'u', Instant::now())
        .expect("sent");
    let seqs: Vec<u16> = link.sent.iter().map(|(s, _)| *s).collect();
    assert_eq!(seqs, [0xFFFD, 0xFFFE, 0]);
    // The acks of its first frames answer nothing: it is applied on its last.
    assert_eq!(requests.answer(&Message::Ack { seq: 0xFFFD }), None);
    assert_eq!(requests.answer(&Message::Ack { seq: 0xFFFE }), None);
    assert_eq!(requests.len(), 1);
    assert_eq!(
        requests.answer(&Message::Ack { seq: 0 }),
        Some(Answer::Acked('u'))
    );
    assert!(requests.is_empty());
    // A repeated ack finds nothing.
    assert_eq!(requests.answer(&Message::Ack { seq: 0 }), None);
}

#[test]
fn a_nack_of_any_frame_refuses_the_whole_request_once() {
    let mut link = Numbering::from(0xFFFE);
    let mut requests = Requests::new();
    let now = Instant::now();
    requests
        .send(&mut link, update(12), 'a', now)
        .expect("sent");
    requests
        .send(&mut link, [Message::EnableForces], 'b', now)
        .expect("sent");
    // 'a' is frames 0xFFFE and 0; 'b' is frame 1.
    let refused = requests.answer(&nack(0xFFFE, ErrorCode::NoSuchPatch));
    assert!(matches!(
        refused,
        Some(Answer::Refused('a', n)) if n.code == ErrorCode::NoSuchPatch
    ));
    // Its later frame's nack (UpdateAborted) finds it gone, and does not touch 'b'.
    assert_eq!(requests.answer(&nack(0, ErrorCode::UpdateAborted)), None);
    assert_eq!(
        requests.answer(&Message::Ack { seq: 1 }),
        Some(Answer::Acked('b'))
    );
}

#[test]
fn a_nack_of_an_unreadable_frame_or_other_frames_answer_nothing() {
    let mut link = Numbering::from(5);
    let mut requests = Requests::new();
    requests
        .send(&mut link, [Message::Calibrate], (), Instant::now())
        .expect("sent");
    assert_eq!(requests.answer(&nack(UNKNOWN_SEQ, ErrorCode::BadCrc)), None);
    assert_eq!(requests.answer(&nack(4, ErrorCode::SequenceGap)), None);
    assert_eq!(requests.answer(&Message::Ack { seq: 6 }), None);
    assert_eq!(requests.answer(&Message::EnableForces), None);
    assert_eq!(requests.len(), 1);
    assert_eq!(
        requests.answer(&Message::Ack { seq: 5 }),
        Some(Answer::Acked(()))
    );
}

#[test]
fn requests_unanswered_past_the_timeout_expire_oldest_first() {
    let mut link = Numbering::from(0);
    let mut requests = Requests::new();
    let t0 = Instant::now();
    let timeout = Duration::from_secs(2);
    requests
        .send(&mut link, [Message::Calibrate], 1, t0)
        .expect("sent");
    requests
        .send(
            &mut link,
            [Message::EnableForces],
            2,
            t0 + Duration::from_secs(1),
        )
        .expect("sent");
    // At the timeout exactly nothing expires; just past it the first does.
    assert!(requests.expire(t0 + timeout, timeout).is_empty());
    let later = t0 + timeout + Duration::from_millis(1);
    assert_eq!(requests.expire(later, timeout), [1]);
    assert_eq!(
        requests.expire(later + Duration::from_secs(1), timeout),
        [2]
    );
    assert!(requests.is_empty());
}

#[test]
fn a_request_cut_by_a_link_failure_is_not_awaited() {
    let mut link = Numbering::from(0);
    link.fail_after = 1;
    let mut requests = Requests::new();
    let e = requests.send(&mut link, update(12), 'p', Instant::now());
    assert!(e.is_err());
    // Its first frame went, its apply frame did not: the ack of the first is no answer.
    assert_eq!(link.sent.len(), 1);
    assert!(requests.is_empty());
    assert_eq!(requests.answer(&Message::Ack { seq: 0 }), None);
}
