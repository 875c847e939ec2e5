//! Devices behind links: find the boards that speak the protocol, open a link to one (a
//! board, the emulated board over TCP, or the simulated pantograph in this process).

use std::time::Duration;

use protocol::host_side::{
    HidLink, Link, LinkError, SerialLink, SimConfig, SimHand, SimLink, TcpLink, list_hid,
    list_serial,
};
use protocol::{Hello, Message};

/// How long a candidate has to answer a hello in `device list`.
pub const PROBE_TIMEOUT: Duration = Duration::from_millis(200);
/// The monitor's heartbeat period: half the device's default watchdog timeout.
pub const HEARTBEAT_PERIOD: Duration = Duration::from_millis(50);

/// A device that answered a hello.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Found {
    /// `hid` or `serial`.
    pub kind: &'static str,
    /// The OS path to open it with.
    pub path: String,
    /// Its hello.
    pub hello: Hello,
    /// Its product string, if it reports one.
    pub product: Option<String>,
}

/// Enumerates HID boards and USB serial ports and keeps those that answer a hello within
/// [`PROBE_TIMEOUT`]. Backends that are unavailable are reported in the second list (as
/// messages) rather than failing the whole search.
pub fn find_devices() -> (Vec<Found>, Vec<String>) {
    let mut found = Vec::new();
    let mut problems = Vec::new();
    match list_hid() {
        Ok(devices) => {
            for d in devices {
                match HidLink::open(&d.path).and_then(|mut l| l.hello(PROBE_TIMEOUT)) {
                    Ok(hello) => found.push(Found {
                        kind: "hid",
                        path: d.path,
                        hello,
                        product: d.product,
                    }),
                    Err(e) => problems.push(format!("{}: {e}", d.path)),
                }
            }
        }
        Err(e) => problems.push(format!("HID enumeration unavailable: {e}")),
    }
    match list_serial() {
        // Only USB ports: probing every legacy UART node costs a timeout each and writes
        // bytes to whatever is attached.
        Ok(ports) => {
            for p in ports.into_iter().filter(|p| p.usb_id.is_some()) {
                if let Ok(hello) =
                    SerialLink::open(&p.path).and_then(|mut l| l.hello(PROBE_TIMEOUT))
                {
                    found.push(Found {
                        kind: "serial",
                        path: p.path,
                        hello,
                        product: p.product,
                    });
                }
            }
        }
        Err(e) => problems.push(format!("serial port enumeration unavailable: {e}")),
    }
    (found, problems)
}

/// Which device `device monitor` talks to.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Target {
    /// A serial port.
    Serial(String),
    /// A board over TCP (`HOST:PORT`), the firmware under QEMU.
    Tcp(String),
    /// The first HID board.
    Hid,
    /// The simulated pantograph in this process.
    Sim,
}

/// An open link, with the simulated hand when the device is the simulator.
#[derive(Debug)]
pub struct Opened {
    /// The link.
    pub link: Box<dyn Link>,
    /// The device's hello.
    pub hello: Hello,
    /// The simulated hand, for [`Target::Sim`].
    pub hand: Option<SimHand>,
}

/// Opens the link to `target` and says hello.
pub fn open(target: &Target) -> Result<Opened, LinkError> {
    open_with(target, &device::spec::DeviceSpec::default())
}

/// [`open`], the simulated device ([`Target::Sim`]) described by `spec` (a `device/1`
/// file's); a board runs its own description.
pub fn open_with(target: &Target, spec: &device::spec::DeviceSpec) -> Result<Opened, LinkError> {
    let mut link: Box<dyn Link> = match target {
        Target::Serial(path) => Box::new(SerialLink::open(path)?),
        Target::Tcp(address) => Box::new(TcpLink::connect(address, Duration::from_secs(2))?),
        Target::Hid => Box::new(HidLink::open_first()?),
        Target::Sim => {
            return open_sim(SimConfig {
                spec: *spec,
                ..SimConfig::default()
            });
        }
    };
    let hello = link.hello(Duration::from_secs(1))?;
    Ok(Opened {
        link,
        hello,
        hand: None,
    })
}

/// Starts the simulated pantograph of `config` in this process, says hello and calibrates it
/// (homing is instant in simulation; without it the telemetry has no HIP).
pub fn open_sim(config: SimConfig) -> Result<Opened, LinkError> {
    let mut sim = SimLink::spawn(config)?;
    let hand = sim.hand()?;
    let hello = sim.hello(Duration::from_secs(1))?;
    sim.request(&Message::Calibrate, Duration::from_secs(1))?;
    Ok(Opened {
        link: Box::new(sim),
        hello,
        hand: Some(hand),
    })
}
