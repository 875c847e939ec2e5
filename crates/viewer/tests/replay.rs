//! Replaying a run log in the app and saving a scene, through the app's state (no window).

use std::path::PathBuf;

use nurbs::Vec2;
use scene::{Scene, Space};
use viewer::gui::state::{AppState, HISTORY_S};

/// A fresh temporary directory for one test, removed on drop.
struct Temp(PathBuf);

impl Temp {
    fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("viewer-replay-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        Temp(dir)
    }
}

impl Drop for Temp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A stepped run of 3 s on thesis-2d (the hand pressed into the arch and held), written as
/// the run log `--record` writes; returns the app and the log's path.
fn recorded_run(dir: &Temp) -> (AppState, PathBuf) {
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    assert!(state.set_hand_target(Vec2::new(0.004, 0.09)));
    state.step(3000);
    let path = dir.0.join("run.csv");
    write_log(&state, &path, Space::Planar);
    (state, path)
}

/// Writes the app's history to `path` as the run log `--record` writes for `space` (the
/// planar one with the device's columns).
fn write_log(state: &AppState, path: &std::path::Path, space: Space) {
    let columns = host::runlog::Columns {
        device: space == Space::Planar,
        deform: false,
    };
    let mut out = Vec::new();
    host::runlog::write_csv_header(&mut out, space, columns).expect("header");
    for s in &state.telemetry.history {
        s.tick.write_csv_row(&mut out, space, columns).expect("row");
    }
    std::fs::write(path, out).expect("write");
}

/// The replay shows exactly the logged ticks: at every cursor the newest sample is the
/// last logged tick at or before it (the log's columns, written in shortest round-trip
/// form, read back bit for bit), and the plots' window is the [`HISTORY_S`] before it.
#[test]
fn scrubbing_shows_the_logged_ticks() {
    let dir = Temp::new("scrub");
    let (live, path) = recorded_run(&dir);
    let logged: Vec<_> = live.telemetry.history.iter().map(|s| s.tick).collect();
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    state.open_replay(&path);
    assert_eq!(state.replay_panel.error, None);
    let (start, end) = state.replay.as_ref().expect("replaying").span();
    assert_eq!((start, end), (logged[0].t_s, logged[logged.len() - 1].t_s));
    for k in [0, 1, 700, 1500, 2999] {
        state.seek_replay(logged[k].t_s);
        let shown = state.latest().expect("a tick").tick;
        assert_eq!(shown.t_s, logged[k].t_s);
        assert_eq!(shown.mode, logged[k].mode);
        assert_eq!(shown.cause, logged[k].cause);
        assert_eq!(shown.hip, logged[k].hip);
        assert_eq!(shown.normal_force_n, logged[k].normal_force_n);
        assert_eq!(shown.force, logged[k].force);
        let first = state.telemetry.history.front().expect("window").tick.t_s;
        assert!(logged[k].t_s - first <= HISTORY_S);
        assert_eq!(
            state.telemetry.history.len(),
            k + 1,
            "3 s < the 5 s window: all so far"
        );
    }
    // Between two ticks: the earlier one.
    state.seek_replay(0.5 * (logged[10].t_s + logged[11].t_s));
    assert_eq!(state.latest().expect("tick").tick.t_s, logged[10].t_s);
    // The live loop's hand does not move while replaying.
    assert!(!state.set_hand_target(Vec2::new(0.0, 0.1)));
    state.close_replay();
    assert!(state.replay.is_none() && state.telemetry.history.is_empty());
}

/// Playing advances the cursor by the real time times the speed, and pauses at the end.
#[test]
fn playing_advances_at_its_speed_and_stops_at_the_end() {
    let dir = Temp::new("play");
    let (_, path) = recorded_run(&dir);
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    state.open_replay(&path);
    let r = state.replay.as_mut().expect("replaying");
    let (start, end) = r.span();
    r.speed = 0.5;
    r.playing = true;
    state.advance_replay(1.0);
    let cursor = state.replay.as_ref().expect("replaying").cursor();
    assert!((cursor - (start + 0.5)).abs() < 1e-12, "{cursor}");
    let shown = state.latest().expect("tick").tick.t_s;
    // The newest tick at or before the cursor: within one 1 ms tick of it.
    assert!(
        shown <= cursor && cursor - shown < 1e-3 + 1e-9,
        "{shown} {cursor}"
    );
    state.advance_replay(100.0);
    let r = state.replay.as_ref().expect("replaying");
    assert_eq!(r.cursor(), end);
    assert!(!r.playing);
}

/// A file that is not a run log is refused naming the file and the line, and the app is as
/// it was (the live loop's views, no replay).
#[test]
fn a_bad_run_log_is_refused_and_changes_nothing() {
    let dir = Temp::new("bad");
    let (_, path) = recorded_run(&dir);
    let text = std::fs::read_to_string(&path).expect("read");
    let mut lines: Vec<&str> = text.lines().collect();
    lines[3] = "0.003,not-a-number";
    let bad = dir.0.join("bad.csv");
    std::fs::write(&bad, lines.join("\n")).expect("write");
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    state.step(10);
    let before = state.telemetry.history.len();
    state.open_replay(&bad);
    let e = state.replay_panel.error.clone().expect("an error");
    assert!(e.contains("bad.csv") && e.contains("line 4"), "{e}");
    assert!(state.replay.is_none());
    assert_eq!(state.telemetry.history.len(), before);
}

/// Save writes the running scene, with the running material, as a scene file that opens
/// again to the same scene.
#[test]
fn a_saved_scene_opens_again() {
    let dir = Temp::new("save");
    let mut state = AppState::stepped("thesis-2d").unwrap_or_else(|e| panic!("{e:#}"));
    state.materials.edited.stiffness_n_per_m = 800.0;
    state.apply_material();
    state.step(1);
    let path = dir.0.join("saved.json");
    state.save_scene(&path);
    assert_eq!(state.files.error, None);
    let saved = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(saved.objects().len(), state.scene.model.objects().len());
    assert_eq!(
        saved.objects()[0].material().stiffness_n_per_m(),
        800.0,
        "the running material is saved"
    );
    assert_eq!(saved.objects()[0].patches().len(), 2);
    // An unwritable path is an error naming it; nothing else changes.
    state.save_scene(&dir.0.join("no-such-dir").join("x.json"));
    let e = state.files.error.clone().expect("an error");
    assert!(e.contains("no-such-dir"), "{e}");
}

/// A 3-D run (the torus pressed, as `--record` writes the 3-D view's ticks) replays in the
/// 3-D view with its own space, the HIP read back bit for bit; a planar log keeps its space.
#[test]
fn a_3d_log_replays_as_3d() {
    let dir = Temp::new("3d");
    let mut live = AppState::stepped("torus").unwrap_or_else(|e| panic!("{e:#}"));
    let spatial = live.spatial.as_mut().expect("3-D");
    spatial.set_target(spatial.target + nurbs::Vec3::new(0.0, 0.0, -0.002));
    live.step(300);
    let path = dir.0.join("run.3d.csv");
    write_log(&live, &path, Space::Spatial);
    let mut state = AppState::stepped("torus").unwrap_or_else(|e| panic!("{e:#}"));
    state.open_replay(&path);
    assert_eq!(state.replay_panel.error, None);
    assert_eq!(state.replay.as_ref().map(|r| r.space), Some(Space::Spatial));
    let last = live.telemetry.history.back().expect("ticks").tick;
    state.seek_replay(last.t_s);
    assert_eq!(state.latest().expect("a tick").tick.hip, last.hip);
    let (_, planar) = recorded_run(&dir);
    state.open_replay(&planar);
    assert_eq!(state.replay.as_ref().map(|r| r.space), Some(Space::Planar));
}
