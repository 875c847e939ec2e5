//! The host's one request/ack engine: requests sent and not yet answered, matched with the
//! device's acks and nacks as they arrive among its other frames.
//!
//! A request is one frame (a command) or several sent back to back (a scene upload's step, a
//! control-point update of many frames, applied together on its last). The device acks every
//! accepted frame and nacks every refused one; a request is answered by the ack of its last
//! frame, or refused by a nack of any of its frames (the device drops the whole of an update
//! it refused, and nacks its later frames too: those nacks find the request gone). Frames
//! that answer nothing here (telemetry, a status, an ack of a frame sent without a request)
//! are the caller's.
//!
//! [`Link::request`](super::Link::request) waits on it for one request at a time; the app's
//! link thread (`host::remote`) keeps its commands, heartbeats and streamed control-point
//! updates in one; xtask's emulated-board sessions too.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use super::{Link, LinkError};
use crate::{Message, Nack, UNKNOWN_SEQ};

/// What became of a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Answer<P> {
    /// The device acked its last frame: applied.
    Acked(P),
    /// The device nacked one of its frames: refused whole, for the nack's reason.
    Refused(P, Nack),
}

/// One request in flight: the sequence numbers of its first and last frames.
#[derive(Clone, Copy, Debug)]
struct InFlight<P> {
    first: u16,
    last: u16,
    purpose: P,
    sent: Instant,
}

impl<P> InFlight<P> {
    /// Whether frame `seq` is one of this request's (numbers wrap).
    fn holds(&self, seq: u16) -> bool {
        seq.wrapping_sub(self.first) <= self.last.wrapping_sub(self.first)
    }
}

/// Requests in flight, oldest first, each tagged with what the caller sent it for (`P`).
#[derive(Clone, Debug)]
pub struct Requests<P> {
    in_flight: VecDeque<InFlight<P>>,
}

impl<P> Default for Requests<P> {
    fn default() -> Self {
        Requests {
            in_flight: VecDeque::new(),
        }
    }
}

impl<P: Copy> Requests<P> {
    /// None in flight.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sends `messages` on `link` as one request for `purpose`, sent at `now`. A request of
    /// no message records nothing. On a link error nothing is recorded (the frames sent
    /// before it are not the whole request: the ack of the last of them would not mean it
    /// applied), and the error is returned.
    pub fn send<L: Link + ?Sized>(
        &mut self,
        link: &mut L,
        messages: impl IntoIterator<Item = Message>,
        purpose: P,
        now: Instant,
    ) -> Result<(), LinkError> {
        let mut span: Option<(u16, u16)> = None;
        for message in messages {
            let seq = link.send(&message)?;
            span = Some((span.map_or(seq, |(first, _)| first), seq));
        }
        if let Some((first, last)) = span {
            self.in_flight.push_back(InFlight {
                first,
                last,
                purpose,
                sent: now,
            });
        }
        Ok(())
    }

    /// What `message`, received from the device, answers: the request whose last frame it
    /// acks, or one of whose frames it nacks (the request is then done). Anything else
    /// answers nothing (`None`), a nack of an unreadable frame ([`UNKNOWN_SEQ`]) too: which
    /// frame it was is unknown, and the request's own answer or [`Requests::expire`] settles
    /// it.
    pub fn answer(&mut self, message: &Message) -> Option<Answer<P>> {
        match *message {
            Message::Ack { seq } => {
                let i = self.in_flight.iter().position(|r| r.last == seq)?;
                self.in_flight.remove(i).map(|r| Answer::Acked(r.purpose))
            }
            Message::Nack(n) if n.seq != UNKNOWN_SEQ => {
                let i = self.in_flight.iter().position(|r| r.holds(n.seq))?;
                self.in_flight
                    .remove(i)
                    .map(|r| Answer::Refused(r.purpose, n))
            }
            _ => None,
        }
    }

    /// Removes the requests sent more than `timeout` before `now`, and returns what they were
    /// for, oldest first.
    pub fn expire(&mut self, now: Instant, timeout: Duration) -> Vec<P> {
        let mut expired = Vec::new();
        self.in_flight.retain(|r| {
            let keep = now.saturating_duration_since(r.sent) <= timeout;
            if !keep {
                expired.push(r.purpose);
            }
            keep
        });
        expired
    }

    /// Whether any request in flight is for a purpose `which` picks.
    pub fn any(&self, mut which: impl FnMut(&P) -> bool) -> bool {
        self.in_flight.iter().any(|r| which(&r.purpose))
    }

    /// Requests in flight.
    pub fn len(&self) -> usize {
        self.in_flight.len()
    }

    /// Whether none is in flight.
    pub fn is_empty(&self) -> bool {
        self.in_flight.is_empty()
    }

    /// Forgets every request in flight (their answers will then answer nothing).
    pub fn clear(&mut self) {
        self.in_flight.clear();
    }
}
