//! The models of a user's hand that hold the simulated pantograph's handle: [`Hand`] (a grip,
//! a fingertip, a handle let go) and the hand of a closed-loop run, [`DeviceHand`] (its spring
//! and damper, and when it lets go).

use device::simulator::SimParams;

/// Who holds the simulated pantograph's handle: the models of a user's hand.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hand {
    /// A relaxed grip (the simulator's default hand: 300 N/m, 2 N·s/m).
    Grip,
    /// A light fingertip ([`SimParams::fingertip`]: 100 N/m, 0.1 N·s/m).
    Finger,
    /// A grip that lets go ([`DeviceHand::release_at_s`]; in a Z-width cell just before the
    /// impact): from then on nobody holds the handle (its own mass, the device's own friction
    /// and damping).
    Released,
}

impl Hand {
    /// The plant's parameters for this hand (a released handle starts gripped).
    pub fn params(self) -> SimParams {
        match self {
            Hand::Grip | Hand::Released => SimParams::default(),
            Hand::Finger => SimParams::fingertip(),
        }
    }

    /// `grip`, `finger` or `released`.
    pub fn name(self) -> &'static str {
        match self {
            Hand::Grip => "grip",
            Hand::Finger => "finger",
            Hand::Released => "released",
        }
    }
}

impl std::str::FromStr for Hand {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "grip" => Ok(Hand::Grip),
            "finger" => Ok(Hand::Finger),
            "released" => Ok(Hand::Released),
            other => Err(format!(
                "unknown hand {other:?}: expected grip, finger or released"
            )),
        }
    }
}

/// The hand of a closed-loop run: the plant's parameters (the hand's spring and damper) and
/// when, if ever, it lets go.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceHand {
    /// The simulated plant's parameters, with the hand's stiffness and damping.
    pub params: SimParams,
    /// When the hand lets go (s, trajectory time); `None`: it holds to the end.
    pub release_at_s: Option<f64>,
}

impl From<SimParams> for DeviceHand {
    /// A hand of these parameters that never lets go.
    fn from(params: SimParams) -> Self {
        DeviceHand {
            params,
            release_at_s: None,
        }
    }
}

impl DeviceHand {
    /// `grip`, `finger` or `released:T` (a grip that lets go at T seconds, finite, ≥ 0).
    pub fn parse(text: &str) -> Result<Self, String> {
        if let Some(at) = text.strip_prefix("released:") {
            let at_s: f64 = at
                .trim()
                .parse()
                .map_err(|_| format!("released:{at}: {at:?} is not a time in seconds"))?;
            if !(at_s.is_finite() && at_s >= 0.0) {
                return Err(format!("released:{at}: the time must be finite and >= 0 s"));
            }
            return Ok(DeviceHand {
                params: Hand::Released.params(),
                release_at_s: Some(at_s),
            });
        }
        match text.parse::<Hand>()? {
            Hand::Released => {
                Err("released needs the time the hand lets go: released:T (seconds)".to_owned())
            }
            hand => Ok(hand.params().into()),
        }
    }
}
