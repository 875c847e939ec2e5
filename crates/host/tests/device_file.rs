//! The `device/1` file: the default round-trips bit for bit, a hand-written file reads as the
//! default, and each class of bad input is refused naming its field.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use device::spec::{DeviceSpec, Direction, SpecError};
use host::device_file::{DeviceFileError, parse, to_json_string};
use serde_json::{Value, json};

/// The default pantograph written out by hand from its documentation (`DeviceSpec::default`):
/// not produced by the writer under test.
fn default_by_hand() -> Value {
    json!({
        "format": "device/1",
        "base_separation_m": 0.05,
        "proximal_m": [0.08, 0.08],
        "distal_m": [0.1, 0.1],
        "max_condition_number": 100.0,
        "encoder_counts_per_rev": [4096, 4096],
        "encoder_direction": ["positive", "positive"],
        "encoder_offset_counts": [0, 0],
        "transmission_ratio": [10.0, 10.0],
        "motor_direction": ["positive", "positive"],
        "torque_constant_nm_per_a": [0.0234, 0.0234],
        "current_limit_a": [2.0, 2.0],
        "max_force_n": 3.0,
        "max_velocity_m_per_s": 1.0,
        "workspace": {
            "min_in_device": {"x": -0.05, "y": 0.05},
            "max_in_device": {"x": 0.05, "y": 0.13}
        },
        "joint_damping_nms_per_rad": [1e-4, 1e-4],
        "joint_coulomb_nm": [3e-3, 3e-3],
        // Computed in f32, as the documented default is.
        "end_stop_rad": [1.25 * std::f32::consts::PI, -0.25 * std::f32::consts::PI]
    })
}

/// Every f32 of a spec by its bits, so that `-0.0` and `0.0` differ.
fn bits(s: &DeviceSpec) -> Vec<u32> {
    let mut v: Vec<f32> = vec![s.base_separation_m, s.max_condition_number, s.max_force_n];
    v.push(s.max_velocity_m_per_s);
    for pair in [
        s.proximal_m,
        s.distal_m,
        s.transmission_ratio,
        s.torque_constant_nm_per_a,
        s.current_limit_a,
        s.joint_damping_nms_per_rad,
        s.joint_coulomb_nm,
        s.end_stop_rad,
    ] {
        v.extend(pair);
    }
    let w = s.workspace;
    v.extend([
        w.min_in_device.x,
        w.min_in_device.y,
        w.max_in_device.x,
        w.max_in_device.y,
    ]);
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_default_round_trips_bit_for_bit() {
    let default = DeviceSpec::default();
    let text = to_json_string(&default);
    assert!(text.starts_with("{\n  \"format\": \"device/1\","), "{text}");
    let back = parse(&text).unwrap();
    assert_eq!(back, default);
    assert_eq!(bits(&back), bits(&default));
    assert_eq!(to_json_string(&back), text);
}

#[test]
fn a_hand_written_file_reads_as_the_default() {
    let spec = parse(&default_by_hand().to_string()).unwrap();
    assert_eq!(spec, DeviceSpec::default());
    assert_eq!(bits(&spec), bits(&DeviceSpec::default()));
}

#[test]
fn other_values_are_read_into_their_fields() {
    let mut v = default_by_hand();
    v["distal_m"] = json!([0.11, 0.105]);
    v["encoder_direction"] = json!(["negative", "positive"]);
    v["encoder_offset_counts"] = json!([-12, 7]);
    let spec = parse(&v.to_string()).unwrap();
    assert_eq!(spec.distal_m, [0.11, 0.105]);
    assert_eq!(
        spec.encoder_direction,
        [Direction::Negative, Direction::Positive]
    );
    assert_eq!(spec.encoder_offset_counts, [-12, 7]);
}

/// A change to the hand-written default.
type Edit = Box<dyn FnOnce(&mut Value)>;

/// The message of the error `edit` makes in the hand-written default.
fn refused(edit: impl FnOnce(&mut Value)) -> (DeviceFileError, String) {
    let mut v = default_by_hand();
    edit(&mut v);
    let e = parse(&v.to_string()).expect_err("refused");
    let message = e.to_string();
    (e, message)
}

#[test]
fn bad_input_is_refused_naming_the_field() {
    let not_json = parse("{\"format\": \"device/1\", ")
        .unwrap_err()
        .to_string();
    assert!(not_json.contains("line 1"), "{not_json}");
    let cases: Vec<(Edit, &str, &str)> = vec![
        (
            Box::new(|v| v["proximal_m_typo"] = json!(1.0)),
            "unknown field `proximal_m_typo`",
            "",
        ),
        (
            Box::new(|v| v["max_force_n"] = json!("3 N")),
            "max_force_n: ",
            "invalid type",
        ),
        (
            Box::new(|v| {
                v.as_object_mut().unwrap().remove("max_velocity_m_per_s");
            }),
            "missing field `max_velocity_m_per_s`",
            "",
        ),
        // Infinite in f32 (the loop's type), though finite in f64.
        (
            Box::new(|v| v["distal_m"] = json!([0.1, 1e39])),
            "distal_m[1]: ",
            "outside the range of f32",
        ),
        (
            Box::new(|v| v["proximal_m"] = json!([0.08, -0.08])),
            "proximal_m[1] = -0.08",
            "positive",
        ),
        (
            Box::new(|v| v["encoder_counts_per_rev"] = json!([4096, 0])),
            "encoder_counts_per_rev[1]",
            "positive",
        ),
        (
            Box::new(|v| v["encoder_counts_per_rev"] = json!([4096, -1])),
            "encoder_counts_per_rev[1]: ",
            "invalid value",
        ),
        (
            Box::new(|v| v["encoder_direction"] = json!(["positive", "up"])),
            "encoder_direction[1]: ",
            "unknown variant",
        ),
        (
            Box::new(|v| v["workspace"]["max_in_device"]["x"] = json!(-0.06)),
            "workspace.max_in_device.x",
            "greater than",
        ),
        // Short distal links: the box lies out of reach of the geometry.
        (
            Box::new(|v| v["distal_m"] = json!([0.03, 0.03])),
            "workspace: point",
            "distal_m",
        ),
        (
            Box::new(|v| v["current_limit_a"] = json!([0.0, 2.0])),
            "current_limit_a[0]",
            "positive",
        ),
        (
            Box::new(|v| v["joint_coulomb_nm"] = json!([-1e-3, 3e-3])),
            "joint_coulomb_nm[0]",
            "non-negative",
        ),
        (
            Box::new(|v| v["format"] = json!("device/2")),
            "format: unsupported format \"device/2\"",
            "",
        ),
    ];
    for (edit, field, what) in cases {
        let (_, message) = refused(edit);
        assert!(
            message.contains(field) && message.contains(what),
            "expected {field:?} and {what:?} in {message:?}"
        );
    }
    let (e, _) = refused(|v| v["distal_m"] = json!([0.03, 0.03]));
    assert!(matches!(
        e,
        DeviceFileError::Invalid {
            error: SpecError::UnreachableWorkspace { .. }
        }
    ));
}

#[test]
fn a_file_is_named_in_its_errors() {
    let dir = std::env::temp_dir().join(format!("device-file-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bad.json");
    std::fs::write(&path, "[]").unwrap();
    let message = host::device_file::load(&path).unwrap_err().to_string();
    assert!(
        message.starts_with(&path.display().to_string()),
        "{message}"
    );
    let missing = host::device_file::load(dir.join("none.json")).unwrap_err();
    assert!(matches!(missing, DeviceFileError::Read { .. }));
    assert_eq!(
        host::device_file::load_or_default(None).unwrap(),
        DeviceSpec::default()
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
