//! `cargo xtask qemu`: the firmware's QEMU binary on the thesis-2d scenario, its instruction
//! counts per tick and the ELF's flash and RAM.
//!
//! 1. converts `scenes/thesis-2d.json` into the device's wire scene (`protocol`) and
//!    the trajectory plus the run's setup into the firmware's scenario table
//!    (`firmware/src/scenario.rs`), with the same host code `viewer sim --device` runs;
//! 2. builds `firmware/` (release, LTO) at each requested opt-level;
//! 3. runs it on QEMU's `netduinoplus2` with `-icount shift=5` and a timeout, checks its exit
//!    status and prints its result lines;
//! 4. prints text / data / bss of the ELF, read from its section headers.

use std::fs;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use device::simulator::SimParams;
use device::spec::DeviceSpec;
use host::closed_loop::{run_device, validate_device};
use host::tick::{DEVICE_RAMP_TIME_S, end_stop_counts};
use host::trajectory::Trajectory;
use protocol::host_side::cobs;
use protocol::{Frame, Message, Telemetry, WireObject, WirePatch, encode_scene};
use scene::Scene;

use crate::{EMBEDDED_TARGET, ensure_toolchain, output, run_in};

/// The scenario: its name, scene and trajectory under `scenes/`, object 0 at the board's
/// 10 kHz (the host's run is given the rate explicitly; `viewer sim --device` defaults to
/// 1 kHz). Telemetry is decimated to 1 kHz on both sides (`device::telemetry`).
const SCENE_NAME: &str = "thesis-2d";
const RATE_HZ: f64 = 10_000.0;
const OBJECT: usize = 0;

/// The bicubic surface's HIP path is sampled at 1 kHz (at 10 kHz its table would not fit
/// the 512 KiB flash beside the scenario's); the firmware runs the renderer at [`RATE_HZ`]
/// along the straight lines between the samples.
const SURFACE_PATH_RATE_HZ: f64 = 1000.0;

/// The board's system clock (Hz): the STM32F411CE at 96 MHz (firmware/README.md).
const BOARD_CLOCK_HZ: f64 = 96e6;

/// Instruction budgets per tick, enforced: every tick of the 2-D scenario (inlined or not),
/// and the bicubic surface's mean.
const BUDGET_2D_MAX: f64 = 4000.0;
const BUDGET_SURFACE_MEAN: f64 = 6000.0;
const SURFACE_NAME: &str = "bump";
/// The control-point run of the firmware (`points_run` in `firmware/src/bin/qemu/points.rs`): a
/// 100 Hz stream of shapes under the held hand, through the board's session, double buffer
/// and tick. Its ticks are held to [`BUDGET_2D_MAX`]; an update's tick boundary plus the tick
/// after it to one period's cycles at one instruction per cycle (the update is applied in the
/// tick's interrupt, before its tick).
const POINTS_NAME: &str = "thesis-2d-points";

/// Generous for the whole scenario (about half a minute on a loaded 2-core machine); a run
/// that takes longer is stuck (e.g. waiting on an unemulated peripheral).
const QEMU_TIMEOUT: Duration = Duration::from_secs(600);

/// Lines of the firmware's output that are results (printed, and some required).
const RESULT_KEYS: &[&str] = &[
    "bracket_check",
    "scene",
    "instructions_per_tick",
    "instructions_first_tick",
    "instructions_first_rendered_tick",
    "instructions_acquisition",
    "instructions_per_tick_after_first",
    "instructions_per_tick_after_update",
    "instructions_points_apply",
    "instructions_points_validate",
    "instructions_points_period",
    "points",
    "instructions_by_mode",
    "instructions_by_stage",
    "run",
    "stack",
];

/// Options of `cargo xtask qemu`.
#[derive(Debug)]
pub struct Options {
    /// Release opt-levels to build and run (`3`, `s`, …).
    pub opt_levels: Vec<String>,
    /// `--serve HOST:PORT`: boot `qemu-serve` with its UART on that TCP port and keep it
    /// running, instead of the session and the measurements.
    pub serve: Option<String>,
    /// `--session`: the host sessions against `qemu-serve` only, not the measurements.
    pub session_only: bool,
}

impl Default for Options {
    /// Opt-level 3 (the release profile).
    fn default() -> Self {
        Options {
            opt_levels: vec!["3".to_owned()],
            serve: None,
            session_only: false,
        }
    }
}

impl Options {
    /// Parses the arguments after `qemu`.
    pub fn parse(args: &[String]) -> Result<Self, String> {
        let mut opt_levels = vec!["3".to_owned()];
        let mut serve = None;
        let mut session_only = false;
        let mut it = args.iter();
        while let Some(a) = it.next() {
            match a.as_str() {
                "--opt-level" => {
                    let v = it
                        .next()
                        .ok_or("--opt-level needs a value: 3, s, z, 2 or a list like 3,s")?;
                    opt_levels = v.split(',').map(str::to_owned).collect();
                    if let Some(bad) = opt_levels
                        .iter()
                        .find(|l| !["0", "1", "2", "3", "s", "z"].contains(&l.as_str()))
                    {
                        return Err(format!(
                            "--opt-level {bad}: not an opt-level (0, 1, 2, 3, s or z)"
                        ));
                    }
                }
                "--serve" => {
                    let v = it
                        .next()
                        .ok_or("--serve needs HOST:PORT, e.g. 127.0.0.1:4444")?;
                    match v.rsplit_once(':').map(|(_, p)| p.parse::<u16>()) {
                        Some(Ok(p)) if p > 0 => serve = Some(v.clone()),
                        _ => {
                            return Err(format!(
                                "--serve {v}: not HOST:PORT with a port 1..=65535"
                            ));
                        }
                    }
                }
                "--session" => session_only = true,
                other => return Err(format!("qemu: unknown argument {other}")),
            }
        }
        Ok(Options {
            opt_levels,
            serve,
            session_only,
        })
    }
}

/// Runs `cargo xtask qemu`.
pub fn qemu(options: &Options) -> Result<(), String> {
    ensure_toolchain()?;
    ensure_qemu()?;
    let root = workspace_root()?;
    let target_dir = firmware_target_dir(&root);
    let data_dir = target_dir.join("qemu-data");
    write_inputs(&root, &data_dir)?;
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let serve_elf = target_dir
        .join(EMBEDDED_TARGET)
        .join("release")
        .join("qemu-serve");
    {
        let data = data_dir.to_string_lossy().into_owned();
        let target = target_dir.to_string_lossy().into_owned();
        let env = [
            ("CARGO_TARGET_DIR", target.as_str()),
            ("FIRMWARE_QEMU_DATA", data.as_str()),
        ];
        run_in(
            &root.join("firmware"),
            &cargo,
            &[
                "build",
                "--release",
                "--bin",
                "qemu-serve",
                "--no-default-features",
                "--features",
                "qemu",
            ],
            &env,
        )?;
    }
    if let Some(address) = &options.serve {
        let args = crate::session::serve_args(address, false);
        println!(
            "xtask qemu: serving the emulated board's UART on tcp:{address} (talk to it with              `cargo run --release -p viewer -- device monitor --tcp {address}`); Ctrl-C stops"
        );
        return run_in(
            Path::new("."),
            "qemu-system-arm",
            &args
                .iter()
                .map(String::as_str)
                .chain(["-kernel", &serve_elf.to_string_lossy()])
                .collect::<Vec<_>>(),
            &[],
        );
    }
    let mut session = crate::session::run(&serve_elf, &root)?;
    session.extend(crate::session::app(&serve_elf, &root)?);
    if options.session_only {
        println!("\nxtask qemu: the host sessions against qemu-serve");
        for line in &session {
            println!("  {line}");
        }
        return Ok(());
    }
    for level in &options.opt_levels {
        let data = data_dir.to_string_lossy().into_owned();
        let target = target_dir.to_string_lossy().into_owned();
        let env = [
            ("CARGO_TARGET_DIR", target.as_str()),
            ("FIRMWARE_QEMU_DATA", data.as_str()),
            ("CARGO_PROFILE_RELEASE_OPT_LEVEL", level.as_str()),
        ];
        let elf = target_dir
            .join(EMBEDDED_TARGET)
            .join("release")
            .join("qemu");
        let firmware = root.join("firmware");
        let build = |features: &str| {
            run_in(
                &firmware,
                &cargo,
                &[
                    "build",
                    "--release",
                    "--bin",
                    "qemu",
                    "--no-default-features",
                    "--features",
                    features,
                ],
                &env,
            )
        };
        let serial = target_dir.join("qemu-uart.bin");
        // The stage split first (its build has extra code beside the tick), then the tick as
        // an ordinary function (`tick-not-inlined`), then the plain build, whose counts and
        // sizes are the headline and whose ELF stays in place.
        build("stages")?;
        let stage_lines = run_qemu(&elf, &serial)?;
        build("tick-not-inlined")?;
        let not_inlined_lines = run_qemu(&elf, &serial)?;
        let not_inlined_comparison = compare_with_host(&root, &serial)?;
        build("qemu")?;
        let lines = run_qemu(&elf, &serial)?;
        let comparison = compare_with_host(&root, &serial)?;
        let budgets = check_budgets(&lines, "inlined")
            .and_then(|mut b| {
                b.extend(check_budgets(&not_inlined_lines, "not_inlined")?);
                Ok(b)
            })
            .map_err(|e| format!("{e}\n{}", lines.join("\n")))?;
        println!("\nxtask qemu: opt-level={level}, lto=fat, codegen-units=1");
        for line in lines
            .iter()
            .chain(&comparison)
            .chain(&budgets)
            .chain(&session)
        {
            println!("  {line}");
        }
        println!(
            "  (Controller::tick_into as an ordinary function, the build with --features \
             tick-not-inlined:)"
        );
        for line in not_inlined_lines.iter().filter(|l| {
            l.starts_with("instructions_per_tick ")
                || l.starts_with("instructions_by_mode ")
                || l.starts_with("instructions_first")
        }) {
            println!("  not_inlined {line}");
        }
        if let Some(line) = not_inlined_comparison.first() {
            println!("  not_inlined {line}");
        }
        println!("  (the stage split, from the build with --features stages, whose own tick is:)");
        for key in ["instructions_per_tick ", "instructions_by_stage "] {
            for line in stage_lines.iter().filter(|l| l.starts_with(key)) {
                println!("  {line}");
            }
        }
        let sizes = elf_sizes(&elf)?;
        println!(
            "  size elf=qemu opt-level={level} text={} data={} bss={} flash={} ram_static={}",
            sizes.text,
            sizes.data,
            sizes.bss,
            sizes.text + sizes.data,
            sizes.data + sizes.bss
        );
    }
    Ok(())
}

/// Installs `qemu-system-arm` with apt-get when it is missing.
/// The firmware workspace's checks in `cargo xtask ci`: formatted, and its library (the
/// board-independent app and `Board` trait) and the board binary clean under clippy for the
/// board's target. The QEMU binary needs the host's inputs and QEMU itself, so
/// `cargo xtask qemu` builds and runs it.
pub fn check_firmware(cargo: &str) -> Result<(), String> {
    let root = workspace_root()?;
    let firmware = root.join("firmware");
    let target = firmware_target_dir(&root).to_string_lossy().into_owned();
    run_in(&firmware, cargo, &["fmt", "--all", "--check"], &[])?;
    run_in(
        &firmware,
        cargo,
        &["clippy", "--bins", "--lib", "--", "-D", "warnings"],
        &[crate::CI_ENV, &[("CARGO_TARGET_DIR", target.as_str())]].concat(),
    )
}

fn ensure_qemu() -> Result<(), String> {
    if output("qemu-system-arm", &["--version"]).is_ok() {
        return Ok(());
    }
    println!(
        "xtask: qemu-system-arm is missing; installing it: apt-get install -y qemu-system-arm"
    );
    let install = || {
        run_in(
            Path::new("."),
            "apt-get",
            &[
                "install",
                "-y",
                "--no-install-recommends",
                "qemu-system-arm",
            ],
            &[("DEBIAN_FRONTEND", "noninteractive")],
        )
    };
    if install().is_err() {
        println!("xtask: apt-get install failed; updating the package lists and trying again");
        run_in(Path::new("."), "apt-get", &["update"], &[])
            .and_then(|()| install())
            .map_err(|e| {
                format!(
                    "could not install qemu-system-arm ({e}); install it by hand \
                     (Debian/Ubuntu: apt-get install qemu-system-arm)"
                )
            })?;
    }
    output("qemu-system-arm", &["--version"])
        .map(|_| ())
        .map_err(|e| format!("qemu-system-arm was installed but does not run: {e}"))
}

pub(crate) fn workspace_root() -> Result<PathBuf, String> {
    // xtask's manifest is <root>/xtask/Cargo.toml.
    let manifest = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest
        .parent()
        .map(Path::to_path_buf)
        .ok_or_else(|| format!("xtask's folder {} has no parent", manifest.display()))
}

/// The firmware's own target folder: `$CARGO_TARGET_DIR/fw` when that is set, else
/// `firmware/target`.
pub(crate) fn firmware_target_dir(root: &Path) -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(dir) if !dir.is_empty() => {
            let dir = PathBuf::from(dir);
            let dir = if dir.is_absolute() {
                dir
            } else {
                root.join(dir)
            };
            dir.join("fw")
        }
        _ => root.join("firmware").join("target"),
    }
}

/// Writes `scene.bin` (the wire scene of the scenario's object) and `scenario.bin` (the
/// firmware's scenario table) into `dir`.
fn write_inputs(root: &Path, dir: &Path) -> Result<(), String> {
    let scene_path = root.join("scenes").join(format!("{SCENE_NAME}.json"));
    let trajectory_path = root.join("scenes").join(format!("{SCENE_NAME}.csv"));
    let scene = Scene::load(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let trajectory = Trajectory::load(&trajectory_path)
        .map_err(|e| format!("{}: {e}", trajectory_path.display()))?;
    // The host run's own checks (object, space, rate, tick count, the controller's setup).
    let ticks = validate_device(&scene, OBJECT, &trajectory, RATE_HZ)
        .map_err(|e| format!("{}: {e}", scene_path.display()))?;

    let wire = host::upload::wire_scene(&scene, OBJECT)
        .map_err(|e| format!("{}: as a wire scene: {e}", scene_path.display()))?;

    let table = scenario_table(&trajectory, ticks)?;
    let (surface, path) = surface_inputs(root)?;
    fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    for (name, bytes) in [
        ("scene.bin", &wire),
        ("scenario.bin", &table),
        ("surface.bin", &surface),
        ("surface-path.bin", &path),
    ] {
        let path = dir.join(name);
        fs::write(&path, bytes).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    println!(
        "xtask qemu: {SCENE_NAME}: wire scene {} bytes, scenario table {} bytes ({ticks} ticks) \
         in {}",
        wire.len(),
        table.len(),
        dir.display()
    );
    Ok(())
}

/// The bicubic scenario: the `bump` of `scenes/examples.json` (one bicubic Bézier patch) as a
/// wire scene, and the HIP's path over it as a `firmware::scenario::HipPath` table: 5 mm above
/// the point (u, v) = (0.5, 0.3) down to 2 mm inside it over 0.3 s, held 0.3 s (stuck), slid at
/// 2 mm depth to v = 0.7 over 0.8 s (slip), held 0.1 s; sampled at 1 kHz, 1500 points (the
/// firmware ticks at [`RATE_HZ`] between them).
fn surface_inputs(root: &Path) -> Result<(Vec<u8>, Vec<u8>), String> {
    const NAME: &str = SURFACE_NAME;
    let scene_path = root.join("scenes").join("examples.json");
    let scene = Scene::load(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let object = scene
        .objects()
        .iter()
        .find(|o| o.name() == NAME)
        .ok_or_else(|| format!("{}: no object named {NAME}", scene_path.display()))?;
    let surfaces = object
        .surface_views()
        .ok_or_else(|| format!("{}: {NAME} is not made of surfaces", scene_path.display()))?;
    let s = *surfaces
        .first()
        .ok_or_else(|| format!("{}: {NAME} has no patch", scene_path.display()))?;
    let patches: Vec<WirePatch<'_>> = surfaces.iter().copied().map(WirePatch::Surface).collect();
    let wire = encode_scene(&[WireObject {
        material: object.material().friction_material(),
        patches: &patches,
    }])
    .map_err(|e| format!("{}: {NAME} as a wire scene: {e}", scene_path.display()))?;
    let ((u0, u1), (v0, v1)) = s.domain();
    let at = |u: f32, v: f32, height_m: f32| {
        let (u, v) = (u0 + u * (u1 - u0), v0 + v * (v1 - v0));
        s.point(u, v) + s.normal(u, v) * height_m
    };
    let mut points = Vec::with_capacity(1500);
    for k in 0..1500 {
        let p = match k {
            0..300 => at(0.5, 0.3, 0.005 - 0.007 * k as f32 / 299.0),
            300..600 => at(0.5, 0.3, -0.002),
            600..1400 => at(0.5, 0.3 + 0.4 * (k - 600) as f32 / 799.0, -0.002),
            _ => at(0.5, 0.7, -0.002),
        };
        points.push(p);
    }
    let mut out = Vec::with_capacity(32 + 12 * points.len());
    out.extend_from_slice(b"HPTH");
    out.push(1);
    out.push(NAME.len() as u8);
    out.extend_from_slice(NAME.as_bytes());
    out.extend_from_slice(&SURFACE_PATH_RATE_HZ.to_le_bytes());
    out.extend_from_slice(&(points.len() as u32).to_le_bytes());
    for p in &points {
        for v in [p.x, p.y, p.z] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok((wire, out))
}

/// The firmware's scenario table (layout in `firmware/src/scenario.rs`): the setup and the
/// per-tick hand targets `host::closed_loop::run_device` uses, as the f32 values its loop takes.
fn scenario_table(trajectory: &Trajectory, ticks: usize) -> Result<Vec<u8>, String> {
    let xy = |p: [f64; 3]| [p[0] as f32, p[1] as f32];
    let mut out = Vec::with_capacity(64 + 8 * ticks);
    out.extend_from_slice(b"HSCN");
    out.push(1);
    out.push(SCENE_NAME.len() as u8);
    out.extend_from_slice(SCENE_NAME.as_bytes());
    out.extend_from_slice(&RATE_HZ.to_le_bytes());
    out.extend_from_slice(&DEVICE_RAMP_TIME_S.to_le_bytes());
    for c in end_stop_counts(&DeviceSpec::default()) {
        out.extend_from_slice(&c.to_le_bytes());
    }
    for v in xy(trajectory.at(trajectory.start_s())) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let n = u32::try_from(ticks).map_err(|_| format!("{ticks} ticks do not fit the table"))?;
    out.extend_from_slice(&n.to_le_bytes());
    for i in 0..ticks {
        for v in xy(trajectory.at(trajectory.tick_time_s(i, RATE_HZ))) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}

/// The telemetry frames of a COBS byte stream (each frame encoded, then `0x00`), in order; an
/// error names the first packet that is not a telemetry frame.
fn telemetry_frames(stream: &[u8]) -> Result<Vec<Telemetry>, String> {
    let mut out = Vec::new();
    let mut packets = stream.split(|&b| b == 0).peekable();
    let mut k = 0;
    while let Some(packet) = packets.next() {
        if packets.peek().is_none() {
            // What follows the last delimiter: empty unless the stream was cut.
            if !packet.is_empty() {
                return Err(format!("the UART stream ends inside frame {k}"));
            }
            break;
        }
        let bytes = cobs::decode(packet).map_err(|e| format!("UART frame {k}: {e}"))?;
        let frame = Frame::decode(&bytes).map_err(|e| format!("UART frame {k}: {}", e.code))?;
        match frame.message {
            Message::Telemetry(t) => out.push(t),
            other => {
                return Err(format!(
                    "UART frame {k}: {:?}, not telemetry",
                    other.message_type()
                ));
            }
        }
        k += 1;
    }
    Ok(out)
}

/// The value of `key=` in a result line (`instructions_per_tick scene=… mean=2209.7 max=…`).
fn stat(line: &str, key: &str) -> Option<f64> {
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(key)?.strip_prefix('='))
        .and_then(|v| v.parse().ok())
}

/// The `instructions_per_tick` line of `scene` in `lines`.
fn per_tick_line<'a>(lines: &'a [String], scene: &str) -> Option<&'a String> {
    let prefix = format!("instructions_per_tick scene={scene} ");
    lines.iter().find(|l| l.starts_with(&prefix))
}

/// Checks the instruction budgets on the result lines of one build (`build` names it in the
/// output): every tick of the 2-D scenario within [`BUDGET_2D_MAX`], the bicubic surface's
/// mean within [`BUDGET_SURFACE_MEAN`]. Returns the budget lines and the CPU load of the
/// 2-D tick at [`RATE_HZ`] on the board's clock; an error names the budget broken or the line
/// missing.
fn check_budgets(lines: &[String], build: &str) -> Result<Vec<String>, String> {
    let get = |scene: &str, key: &str| {
        per_tick_line(lines, scene)
            .and_then(|l| stat(l, key))
            .ok_or_else(|| format!("{build}: no `instructions_per_tick scene={scene}` {key}"))
    };
    let points = |what: &str, key: &str| {
        let prefix = format!("instructions_points_{what} scene={POINTS_NAME} ");
        lines
            .iter()
            .find(|l| l.starts_with(&prefix))
            .and_then(|l| stat(l, key))
            .ok_or_else(|| format!("{build}: no `{prefix}` {key}"))
    };
    let (mean_2d, max_2d) = (get(SCENE_NAME, "mean")?, get(SCENE_NAME, "max")?);
    let surface_mean = get(SURFACE_NAME, "mean")?;
    let points_max = get(POINTS_NAME, "max")?;
    let cycles = BOARD_CLOCK_HZ / RATE_HZ;
    let period_max = points("period", "max")?;
    let mut out = Vec::new();
    for (scene, what, value, limit) in [
        (SCENE_NAME, "max", max_2d, BUDGET_2D_MAX),
        (SURFACE_NAME, "mean", surface_mean, BUDGET_SURFACE_MEAN),
        (POINTS_NAME, "max", points_max, BUDGET_2D_MAX),
        (POINTS_NAME, "update_and_tick_max", period_max, cycles),
    ] {
        if value > limit {
            return Err(format!(
                "{build}: scene {scene}: {what} {value} instructions per tick, over the budget \
                 of {limit}"
            ));
        }
        out.push(format!(
            "budget build={build} scene={scene} {what}={value} limit={limit} ok"
        ));
    }
    // One period's cycles at the board's clock; the load assumes one instruction per cycle
    // (the Cortex-M4's single-cycle ALU and FPU ops; loads, taken branches, flash wait
    // states past the ART accelerator and VDIV/VSQRT cost more, so the real load is higher:
    // the board's `tick_us` telemetry measures it).
    let (apply, validate) = (points("apply", "max")?, points("validate", "max")?);
    // The firmware's stream: one update every 10 ms.
    let updates_hz = 100.0;
    out.push(format!(
        "points_budget build={build} scene={POINTS_NAME} apply_max={apply} \
         tick_max={points_max} update_and_tick_max={period_max} cycles_per_period={cycles} \
         update_and_tick={:.1}%_of_a_period validate_max={validate} \
         link_load_at_{updates_hz}_hz={:.1}%",
        100.0 * period_max / cycles,
        100.0 * validate * updates_hz / BOARD_CLOCK_HZ
    ));
    out.push(format!(
        "cpu_load build={build} scene={SCENE_NAME} clock_hz={BOARD_CLOCK_HZ} rate_hz={RATE_HZ} \
         cycles_per_period={cycles} at_1_instruction_per_cycle mean={:.1}% max={:.1}%",
        100.0 * mean_2d / cycles,
        100.0 * max_2d / cycles
    ));
    Ok(out)
}

/// Compares the firmware's telemetry (the frames its UART sent, in `serial`) frame by frame
/// with the host's run of the same scenario at the same [`RATE_HZ`] (`host::closed_loop::run_device`,
/// the code behind `viewer sim --device`, whose frames are decimated to 1 kHz as the
/// firmware's): the same code on the same f32 inputs, so the goal is identical frames. Returns the result lines: the number of identical frames and, per field, the
/// largest difference; fails when a frame is missing or a discrete field (mode, cause,
/// feature, faults, clock) differs on any tick.
fn compare_with_host(root: &Path, serial: &Path) -> Result<Vec<String>, String> {
    let stream = fs::read(serial).map_err(|e| format!("cannot read {}: {e}", serial.display()))?;
    let mcu = telemetry_frames(&stream)?;
    let scene_path = root.join("scenes").join(format!("{SCENE_NAME}.json"));
    let trajectory_path = root.join("scenes").join(format!("{SCENE_NAME}.csv"));
    let scene = Scene::load(&scene_path).map_err(|e| format!("{}: {e}", scene_path.display()))?;
    let trajectory = Trajectory::load(&trajectory_path)
        .map_err(|e| format!("{}: {e}", trajectory_path.display()))?;
    let host = run_device(
        &scene,
        OBJECT,
        &trajectory,
        RATE_HZ,
        SimParams::default(),
        |_, _| {},
    )
    .map_err(|e| format!("the host run of {SCENE_NAME}: {e}"))?
    .telemetry;
    if mcu.len() != host.len() {
        return Err(format!(
            "the firmware sent {} telemetry frames, the host run has {}",
            mcu.len(),
            host.len()
        ));
    }
    type Field = (&'static str, fn(&Telemetry) -> f32);
    const FIELDS: [Field; 11] = [
        ("hip_x", |t| t.hip_m.x),
        ("hip_y", |t| t.hip_m.y),
        ("cp_x", |t| t.cp_m.x),
        ("cp_y", |t| t.cp_m.y),
        ("go_x", |t| t.go_m.x),
        ("go_y", |t| t.go_m.y),
        ("force_normal", |t| t.force_normal_n),
        ("go_param", |t| t.go_param),
        ("force_x", |t| t.force_n.x),
        ("force_y", |t| t.force_n.y),
        ("psi", |t| t.psi),
    ];
    let mut largest = [(0.0f32, 0usize); FIELDS.len()];
    let mut mu_largest = (0u16, 0usize);
    let mut identical = 0;
    let mut discrete = Vec::new();
    for (k, (m, h)) in mcu.iter().zip(&host).enumerate() {
        if m == h {
            identical += 1;
        }
        for ((_, get), worst) in FIELDS.iter().zip(largest.iter_mut()) {
            // NaN on either side counts as the largest difference.
            let d = (get(m) - get(h)).abs();
            let d = if d.is_nan() { f32::INFINITY } else { d };
            if d > worst.0 {
                *worst = (d, k);
            }
        }
        let dmu = m.mu_e4.abs_diff(h.mu_e4);
        if dmu > mu_largest.0 {
            mu_largest = (dmu, k);
        }
        if (m.mode, m.cause, m.feature, m.faults, m.time_us)
            != (h.mode, h.cause, h.feature, h.faults, h.time_us)
            && discrete.len() < 5
        {
            discrete.push(format!(
                "tick {k}: firmware {:?}/{:?}/{:?}/faults {:#x}/{} µs, host {:?}/{:?}/{:?}/faults                  {:#x}/{} µs",
                m.mode, m.cause, m.feature, m.faults, m.time_us, h.mode, h.cause, h.feature,
                h.faults, h.time_us
            ));
        }
    }
    let mut lines = vec![format!(
        "telemetry_vs_host scene={SCENE_NAME} frames={} identical_frames={identical}",
        mcu.len()
    )];
    for ((name, _), (d, k)) in FIELDS.iter().zip(largest) {
        lines.push(format!(
            "telemetry_vs_host scene={SCENE_NAME} field={name} largest_difference={d:e} tick={k}"
        ));
    }
    lines.push(format!(
        "telemetry_vs_host scene={SCENE_NAME} field=mu_e4 largest_difference={} tick={}",
        mu_largest.0, mu_largest.1
    ));
    if !discrete.is_empty() {
        return Err(format!(
            "the firmware's mode, cause, feature, faults or clock differ from the host run's              (first {}):\n{}\n{}",
            discrete.len(),
            discrete.join("\n"),
            lines.join("\n")
        ));
    }
    Ok(lines)
}

/// Boots `elf` on QEMU with its UART (USART1) written to `serial`, waits at most
/// [`QEMU_TIMEOUT`], and returns its result lines; an error names what went wrong (exit
/// status, timeout, missing lines) with the output.
fn run_qemu(elf: &Path, serial: &Path) -> Result<Vec<String>, String> {
    let args = [
        "-machine",
        "netduinoplus2",
        "-nographic",
        "-monitor",
        "none",
        "-semihosting-config",
        "enable=on,target=native",
        "-icount",
        "shift=5",
        "-serial",
    ];
    let serial_arg = format!("file:{}", serial.display());
    println!(
        "\n==> qemu-system-arm {} {serial_arg} -kernel {} (timeout {} s)",
        args.join(" "),
        elf.display(),
        QEMU_TIMEOUT.as_secs()
    );
    let started = Instant::now();
    let mut child = Command::new("qemu-system-arm")
        .args(args)
        .arg(&serial_arg)
        .arg("-kernel")
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot start qemu-system-arm: {e}"))?;
    let collect = |pipe: Option<Box<dyn Read + Send>>| {
        thread::spawn(move || {
            let mut text = String::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_string(&mut text);
            }
            text
        })
    };
    let stdout = collect(
        child
            .stdout
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let stderr = collect(
        child
            .stderr
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break Some(status),
            Ok(None) if started.elapsed() > QEMU_TIMEOUT => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
            Ok(None) => thread::sleep(Duration::from_millis(50)),
            Err(e) => return Err(format!("waiting for qemu-system-arm: {e}")),
        }
    };
    let out = stdout.join().unwrap_or_default();
    let err = stderr.join().unwrap_or_default();
    let shown = || format!("\n--- qemu stdout ---\n{out}--- qemu stderr ---\n{err}");
    let Some(status) = status else {
        return Err(format!(
            "qemu-system-arm did not finish within {} s{}",
            QEMU_TIMEOUT.as_secs(),
            shown()
        ));
    };
    if !status.success() {
        return Err(format!(
            "the firmware under QEMU exited with {status} (semihosting exit failure or a QEMU \
             error){}",
            shown()
        ));
    }
    let lines: Vec<String> = out
        .lines()
        .filter(|l| {
            RESULT_KEYS
                .iter()
                .any(|k| l.strip_prefix(k).is_some_and(|r| r.starts_with(' ')))
        })
        .map(str::to_owned)
        .collect();
    for required in ["instructions_per_tick", "instructions_first_tick"] {
        let prefix = format!("{required} scene={SCENE_NAME} ");
        if !lines.iter().any(|l| l.starts_with(&prefix)) {
            return Err(format!(
                "the firmware's output has no `{prefix}…` line{}",
                shown()
            ));
        }
    }
    println!(
        "qemu: finished in {:.1} s (host time)",
        started.elapsed().as_secs_f64()
    );
    Ok(lines)
}

/// Berkeley-style sizes of an ELF: `text` the allocated read-only sections (code, vector
/// table, constants), `data` the allocated writable sections with an image in flash, `bss`
/// the allocated writable sections without one.
#[derive(Debug, Default, PartialEq)]
pub(crate) struct Sizes {
    pub(crate) text: u64,
    pub(crate) data: u64,
    pub(crate) bss: u64,
}

const SHF_WRITE: u32 = 0x1;
const SHF_ALLOC: u32 = 0x2;
const SHT_NOBITS: u32 = 8;

pub(crate) fn elf_sizes(path: &Path) -> Result<Sizes, String> {
    let bytes = fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    parse_elf_sizes(&bytes).map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads the section headers of a 32-bit little-endian ELF (what thumbv7em links to).
fn parse_elf_sizes(bytes: &[u8]) -> Result<Sizes, String> {
    let u16_at = |at: usize| -> Result<u16, String> {
        bytes
            .get(at..at + 2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
            .ok_or_else(|| format!("truncated ELF at byte {at}"))
    };
    let u32_at = |at: usize| -> Result<u32, String> {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .ok_or_else(|| format!("truncated ELF at byte {at}"))
    };
    if bytes.get(..4) != Some(b"\x7fELF".as_slice()) {
        return Err("not an ELF file".into());
    }
    if bytes.get(4) != Some(&1) || bytes.get(5) != Some(&1) {
        return Err("not a 32-bit little-endian ELF".into());
    }
    let shoff = u32_at(0x20)? as usize;
    let shentsize = usize::from(u16_at(0x2E)?);
    let shnum = usize::from(u16_at(0x30)?);
    if shentsize < 40 {
        return Err(format!("section header size {shentsize} < 40"));
    }
    let table_end = shnum
        .checked_mul(shentsize)
        .and_then(|n| n.checked_add(shoff));
    if table_end.is_none_or(|end| end > bytes.len()) {
        return Err(format!(
            "{shnum} section headers of {shentsize} bytes at byte {shoff} run past the file's \
             end ({} bytes)",
            bytes.len()
        ));
    }
    let mut sizes = Sizes::default();
    for i in 0..shnum {
        let h = shoff + i * shentsize;
        let (kind, flags, size) = (u32_at(h + 4)?, u32_at(h + 8)?, u64::from(u32_at(h + 20)?));
        if flags & SHF_ALLOC == 0 {
            continue;
        }
        if flags & SHF_WRITE == 0 {
            sizes.text += size;
        } else if kind == SHT_NOBITS {
            sizes.bss += size;
        } else {
            sizes.data += size;
        }
    }
    Ok(sizes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One section header (40 bytes) of an ELF32.
    fn header(kind: u32, flags: u32, size: u32) -> Vec<u8> {
        let mut h = vec![0u8; 40];
        h[4..8].copy_from_slice(&kind.to_le_bytes());
        h[8..12].copy_from_slice(&flags.to_le_bytes());
        h[20..24].copy_from_slice(&size.to_le_bytes());
        h
    }

    /// A hand-built ELF32 with a null section, code, constants, initialised data, zeroed data
    /// and a non-allocated debug section: the sums are those of `size`'s Berkeley format.
    #[test]
    fn sizes_sum_sections_by_their_flags() {
        const PROGBITS: u32 = 1;
        const EXEC: u32 = 0x4;
        let sections = [
            header(0, 0, 0),
            header(PROGBITS, SHF_ALLOC | EXEC, 1000),
            header(PROGBITS, SHF_ALLOC, 200),
            header(PROGBITS, SHF_ALLOC | SHF_WRITE, 30),
            header(SHT_NOBITS, SHF_ALLOC | SHF_WRITE, 4000),
            header(PROGBITS, 0, 123_456),
        ];
        let mut elf = vec![0u8; 52];
        elf[..4].copy_from_slice(b"\x7fELF");
        elf[4] = 1;
        elf[5] = 1;
        elf[0x20..0x24].copy_from_slice(&52u32.to_le_bytes());
        elf[0x2E..0x30].copy_from_slice(&40u16.to_le_bytes());
        elf[0x30..0x32].copy_from_slice(&(sections.len() as u16).to_le_bytes());
        for s in &sections {
            elf.extend_from_slice(s);
        }
        assert_eq!(
            parse_elf_sizes(&elf),
            Ok(Sizes {
                text: 1200,
                data: 30,
                bss: 4000
            })
        );
        // Cut inside the last header: an error, not a panic.
        assert!(parse_elf_sizes(&elf[..elf.len() - 1]).is_err());
        assert!(parse_elf_sizes(b"MZ").is_err());
    }

    #[test]
    fn budgets_pass_within_and_fail_beyond_or_without_their_lines() {
        let lines = |max_2d: u32, surface_mean: f64| {
            vec![
                format!(
                    "instructions_per_tick scene={SCENE_NAME} mean=1920.0 max={max_2d} \
                     at_tick=7 ticks=100"
                ),
                format!(
                    "instructions_per_tick scene={SURFACE_NAME} mean={surface_mean} max=9999 \
                     at_tick=3 ticks=100"
                ),
                format!(
                    "instructions_per_tick scene={POINTS_NAME} mean=1900.0 max=2500 at_tick=3 \
                     ticks=100"
                ),
                format!(
                    "instructions_points_apply scene={POINTS_NAME} mean=6000.0 max=6000 \
                     at_tick=3 ticks=100"
                ),
                format!(
                    "instructions_points_validate scene={POINTS_NAME} mean=70000.0 max=70000 \
                     at_tick=3 ticks=100"
                ),
                format!(
                    "instructions_points_period scene={POINTS_NAME} mean=8000.0 max=8500 \
                     at_tick=3 ticks=100"
                ),
            ]
        };
        let ok = check_budgets(&lines(4000, 6000.0), "x").expect("at the budgets");
        assert!(ok.iter().any(|l| l.contains("max=4000 limit=4000 ok")));
        // 1920 instructions of 9600 cycles (96 MHz / 10 kHz) = 20 %.
        assert!(ok.iter().any(|l| l.contains("mean=20.0%")), "{ok:?}");
        assert!(check_budgets(&lines(4001, 6000.0), "x").is_err());
        assert!(check_budgets(&lines(4000, 6000.1), "x").is_err());
        assert!(check_budgets(&lines(4000, 10.0)[..1], "x").is_err());
        // An update and its tick over one period, or the points run's lines missing.
        let mut over = lines(4000, 6000.0);
        over[5] = over[5].replace("max=8500", "max=9601");
        assert!(check_budgets(&over, "x").is_err());
        assert!(check_budgets(&lines(4000, 6000.0)[..4], "x").is_err());
        // 70,000 instructions 100 times a second on 96 MHz: 7.3 % of the link task's core.
        assert!(
            ok.iter().any(|l| l.contains("link_load_at_100_hz=7.3%")),
            "{ok:?}"
        );
        assert_eq!(stat("a mean=12.5 max=3", "max"), Some(3.0));
        assert_eq!(stat("a mean=12.5 max=3", "ax"), None);
    }

    #[test]
    fn options() {
        let args = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(
            Options::parse(&[]).map(|o| o.opt_levels),
            Ok(vec!["3".into()])
        );
        assert_eq!(
            Options::parse(&args(&["--opt-level", "3,s"])).map(|o| o.opt_levels),
            Ok(vec!["3".into(), "s".into()])
        );
        assert!(Options::parse(&args(&["--opt-level", "fast"])).is_err());
        assert!(Options::parse(&args(&["--opt-level"])).is_err());
        assert!(Options::parse(&args(&["--serve"])).is_err());
        assert_eq!(
            Options::parse(&args(&["--session"])).map(|o| o.session_only),
            Ok(true)
        );
        assert_eq!(
            Options::parse(&args(&["--serve", "127.0.0.1:4444"])).map(|o| o.serve),
            Ok(Some("127.0.0.1:4444".into()))
        );
        for bad in ["127.0.0.1", "127.0.0.1:0", "127.0.0.1:70000", "host:port"] {
            assert!(Options::parse(&args(&["--serve", bad])).is_err(), "{bad}");
        }
    }
}
