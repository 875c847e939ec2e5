//! The `device/1` file: a [`DeviceSpec`] as JSON, every field by its Rust name and with its
//! unit in the name, read strictly and validated with [`DeviceSpec::validate`].
//!
//! ```json
//! {
//!   "format": "device/1",
//!   "base_separation_m": 0.05,
//!   "proximal_m": [0.08, 0.08],
//!   "distal_m": [0.1, 0.1],
//!   "max_condition_number": 100.0,
//!   "encoder_counts_per_rev": [4096, 4096],
//!   "encoder_direction": ["positive", "positive"],
//!   "encoder_offset_counts": [0, 0],
//!   "transmission_ratio": [10.0, 10.0],
//!   "motor_direction": ["positive", "positive"],
//!   "torque_constant_nm_per_a": [0.0234, 0.0234],
//!   "current_limit_a": [2.0, 2.0],
//!   "max_force_n": 3.0,
//!   "max_velocity_m_per_s": 1.0,
//!   "workspace": {
//!     "min_in_device": { "x": -0.05, "y": 0.05 },
//!     "max_in_device": { "x": 0.05, "y": 0.13 }
//!   },
//!   "joint_damping_nms_per_rad": [0.0001, 0.0001],
//!   "joint_coulomb_nm": [0.003, 0.003],
//!   "end_stop_rad": [3.9269907, -0.7853982]
//! }
//! ```
//!
//! Every field is required: a device description is safety-relevant, and a file that leaves a
//! field out would silently take the default pantograph's value. Pairs are `[joint 1, joint
//! 2]` (left, right); directions are `"positive"` or `"negative"`; points are `{"x", "y"}`
//! so that the field paths of the file are those [`DeviceSpec::validate`] names
//! (`workspace.max_in_device.x`). Numbers are read as the loop's `f32` (a value outside its
//! range is refused, [`scene::json::F32`]), counts as `u32` and offsets as `i32`.
//!
//! A file is refused, with the field named, when it is not JSON, has a field of the wrong
//! type, an unknown or a missing one, or when [`DeviceSpec::validate`] refuses the values: a
//! length, ratio, constant or limit not finite and positive, zero encoder counts, damping or
//! friction negative, or a workspace box not reached well-conditioned by the geometry or
//! needing a joint beyond its end stop. (A current limit checked against the force limit is
//! not among the rules yet.)
//!
//! [`to_json_string`] writes a spec back, `format` first, with the shortest decimals that
//! read back as the same `f32`: [`parse`] of it gives the spec bit for bit.

use std::path::{Path, PathBuf};

use device::spec::{DeviceSpec, Direction, SpecError, WorkspaceBox};
use nurbs::Vec2;
use scene::json::F32;
use serde::{Deserialize, Serialize};

/// The `format` of a device file.
pub const FORMAT: &str = "device/1";

/// Why a device file was refused. Every message names the field (or says the document is not
/// JSON, with the line and column).
#[derive(Debug, thiserror::Error)]
pub enum DeviceFileError {
    /// The file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        error: std::io::Error,
    },
    /// An error in the named file.
    #[error("{}: {error}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// The error in it.
        error: Box<DeviceFileError>,
    },
    /// Not JSON, a wrong type, a missing or unknown field; serde_json's message ends with
    /// the line and column.
    #[error("{FORMAT}: {}{error}", if location.is_empty() || location == "." { String::new() } else { format!("{location}: ") })]
    Json {
        /// The field path (`workspace.min_in_device.x`); empty at the top level.
        location: String,
        /// serde_json's error.
        error: serde_json::Error,
    },
    /// `format` is missing or not `device/1`.
    #[error("format: {}, expected \"{FORMAT}\"", match found { Some(f) => format!("unsupported format {f}"), None => "missing".to_owned() })]
    Format {
        /// What the file has instead, as JSON.
        found: Option<String>,
    },
    /// The values describe no device the loop can run safely ([`DeviceSpec::validate`]'s
    /// error, which names the field).
    #[error("{FORMAT}: {error}{}", geometry_hint(error))]
    Invalid {
        /// Why.
        error: SpecError,
    },
}

/// A workspace point out of reach is the geometry's fault as much as the box's: say which
/// fields make it.
fn geometry_hint(error: &SpecError) -> &'static str {
    match error {
        SpecError::UnreachableWorkspace { .. } => {
            " (the geometry base_separation_m, proximal_m, distal_m with max_condition_number \
             does not reach the workspace box well-conditioned)"
        }
        _ => "",
    }
}

/// Parses and validates a `device/1` document.
pub fn parse(text: &str) -> Result<DeviceSpec, DeviceFileError> {
    let json = |e: scene::json::JsonError| DeviceFileError::Json {
        location: e.path.map_or_else(String::new, |p| p.to_string()),
        error: e.error,
    };
    // The format first, so that a file of another version is reported as such, not as a list
    // of unknown fields; read as a map, which serde would not confuse with an array.
    let header: serde_json::Map<String, serde_json::Value> =
        scene::json::parse_at(text).map_err(json)?;
    match header.get("format") {
        Some(serde_json::Value::String(f)) if f == FORMAT => {}
        found => {
            return Err(DeviceFileError::Format {
                found: found.map(serde_json::Value::to_string),
            });
        }
    }
    let raw: RawDevice = scene::json::parse_at(text).map_err(json)?;
    let spec = raw.spec();
    spec.validate()
        .map_err(|error| DeviceFileError::Invalid { error })?;
    Ok(spec)
}

/// Reads, parses and validates a `device/1` file; errors name the file.
pub fn load(path: impl AsRef<Path>) -> Result<DeviceSpec, DeviceFileError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|error| DeviceFileError::Read {
        path: path.to_owned(),
        error,
    })?;
    parse(&text).map_err(|error| DeviceFileError::File {
        path: path.to_owned(),
        error: Box::new(error),
    })
}

/// The spec in the file at `path`, or the default pantograph without one.
pub fn load_or_default(path: Option<&Path>) -> Result<DeviceSpec, DeviceFileError> {
    path.map_or_else(|| Ok(DeviceSpec::default()), load)
}

/// `spec` as a `device/1` document (pretty-printed, `format` first, a final newline).
pub fn to_json_string(spec: &DeviceSpec) -> String {
    let raw = RawDevice::from_spec(spec);
    // Serialising a struct of numbers, strings and arrays cannot fail; a non-finite number
    // (a spec that did not pass `validate`) is written `null`, which `parse` refuses.
    let mut text = serde_json::to_string_pretty(&raw).unwrap_or_default();
    text.push('\n');
    text
}

// ---------------------------------------------------------------------------------------------
// The file as written: the fields of `DeviceSpec` in its order, `format` first.

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields, rename = "Device")]
struct RawDevice {
    format: String,
    base_separation_m: F32,
    proximal_m: [F32; 2],
    distal_m: [F32; 2],
    max_condition_number: F32,
    encoder_counts_per_rev: [u32; 2],
    encoder_direction: [RawDirection; 2],
    encoder_offset_counts: [i32; 2],
    transmission_ratio: [F32; 2],
    motor_direction: [RawDirection; 2],
    torque_constant_nm_per_a: [F32; 2],
    current_limit_a: [F32; 2],
    max_force_n: F32,
    max_velocity_m_per_s: F32,
    workspace: RawWorkspace,
    joint_damping_nms_per_rad: [F32; 2],
    joint_coulomb_nm: [F32; 2],
    end_stop_rad: [F32; 2],
}

#[derive(Clone, Copy, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
enum RawDirection {
    Positive,
    Negative,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawWorkspace {
    min_in_device: RawPoint,
    max_in_device: RawPoint,
}

#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct RawPoint {
    x: F32,
    y: F32,
}

fn pair(p: [F32; 2]) -> [f32; 2] {
    p.map(|v| v.0)
}

fn direction(d: RawDirection) -> Direction {
    match d {
        RawDirection::Positive => Direction::Positive,
        RawDirection::Negative => Direction::Negative,
    }
}

fn raw_direction(d: Direction) -> RawDirection {
    match d {
        Direction::Positive => RawDirection::Positive,
        Direction::Negative => RawDirection::Negative,
    }
}

impl RawPoint {
    fn of(p: Vec2) -> Self {
        RawPoint {
            x: F32(p.x),
            y: F32(p.y),
        }
    }

    fn vec2(&self) -> Vec2 {
        Vec2::new(self.x.0, self.y.0)
    }
}

impl RawDevice {
    fn spec(&self) -> DeviceSpec {
        DeviceSpec {
            base_separation_m: self.base_separation_m.0,
            proximal_m: pair(self.proximal_m),
            distal_m: pair(self.distal_m),
            max_condition_number: self.max_condition_number.0,
            encoder_counts_per_rev: self.encoder_counts_per_rev,
            encoder_direction: self.encoder_direction.map(direction),
            encoder_offset_counts: self.encoder_offset_counts,
            transmission_ratio: pair(self.transmission_ratio),
            motor_direction: self.motor_direction.map(direction),
            torque_constant_nm_per_a: pair(self.torque_constant_nm_per_a),
            current_limit_a: pair(self.current_limit_a),
            max_force_n: self.max_force_n.0,
            max_velocity_m_per_s: self.max_velocity_m_per_s.0,
            workspace: WorkspaceBox {
                min_in_device: self.workspace.min_in_device.vec2(),
                max_in_device: self.workspace.max_in_device.vec2(),
            },
            joint_damping_nms_per_rad: pair(self.joint_damping_nms_per_rad),
            joint_coulomb_nm: pair(self.joint_coulomb_nm),
            end_stop_rad: pair(self.end_stop_rad),
        }
    }

    fn from_spec(s: &DeviceSpec) -> Self {
        let f = |p: [f32; 2]| p.map(F32);
        RawDevice {
            format: FORMAT.to_owned(),
            base_separation_m: F32(s.base_separation_m),
            proximal_m: f(s.proximal_m),
            distal_m: f(s.distal_m),
            max_condition_number: F32(s.max_condition_number),
            encoder_counts_per_rev: s.encoder_counts_per_rev,
            encoder_direction: s.encoder_direction.map(raw_direction),
            encoder_offset_counts: s.encoder_offset_counts,
            transmission_ratio: f(s.transmission_ratio),
            motor_direction: s.motor_direction.map(raw_direction),
            torque_constant_nm_per_a: f(s.torque_constant_nm_per_a),
            current_limit_a: f(s.current_limit_a),
            max_force_n: F32(s.max_force_n),
            max_velocity_m_per_s: F32(s.max_velocity_m_per_s),
            workspace: RawWorkspace {
                min_in_device: RawPoint::of(s.workspace.min_in_device),
                max_in_device: RawPoint::of(s.workspace.max_in_device),
            },
            joint_damping_nms_per_rad: f(s.joint_damping_nms_per_rad),
            joint_coulomb_nm: f(s.joint_coulomb_nm),
            end_stop_rad: f(s.end_stop_rad),
        }
    }
}
