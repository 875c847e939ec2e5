//! The participant screen of `viewer experiment run PLAN --participant P01`: its state machine
//! ([`ParticipantRun`]) driven headless on the app's stepped loop with an explicit clock, and
//! the screen itself through egui_kittest (not rendered: its shapes and its buttons).
#![cfg(feature = "gui")]
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use eframe::egui;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use experiment::plan::Plan;
use experiment::session::Response;
use nurbs::Vec2;
use viewer::gui::participant::{ParticipantRun, ParticipantUi, Phase};
use viewer::gui::state::AppState;
use viewer::gui::{ViewerUi, view};

const SHAPES: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../experiments/thesis-shapes.json"
);
const JND: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../experiments/stiffness-jnd.json"
);

/// An empty folder of its own under the temporary directory.
fn temp_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("viewer-participant-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The plan's run by P01 in `dir`, and the app stepped in place on its first stimulus.
fn open(plan: &str, dir: &Path) -> (ParticipantRun, AppState) {
    let plan = Plan::load(plan).unwrap();
    let scene = plan.scene(0).unwrap().clone();
    let run = ParticipantRun::open(plan, "P01", dir).unwrap();
    let state = AppState::new("participant", scene, false, None).unwrap();
    (run, state)
}

/// The rows of `trials.csv` (header left out), each split on commas (no field here has one).
fn rows(dir: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(dir.join("trials.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_owned).collect())
        .collect()
}

fn column(name: &str) -> usize {
    experiment::session::TRIALS_HEADER
        .split(',')
        .position(|c| c == name)
        .unwrap()
}

/// The hand comes down from above onto the roof's vertex, 10 mm past it, over `ms` ticks.
fn press_down(state: &mut AppState, ms: usize) {
    let (from, to) = (Vec2::new(0.0, 0.11), Vec2::new(0.0, 0.085));
    for i in 1..=ms {
        assert!(state.set_hand_target(from + (to - from) * (i as f32 / ms as f32)));
        state.step(1);
    }
}

/// The hand goes back up from the vertex to where `press_down` started, over `ms` ticks.
fn lift(state: &mut AppState, ms: usize) {
    let (from, to) = (Vec2::new(0.0, 0.085), Vec2::new(0.0, 0.11));
    for i in 1..=ms {
        assert!(state.set_hand_target(from + (to - from) * (i as f32 / ms as f32)));
        state.step(1);
    }
}

/// A wrong answer to an identification trial.
fn wrong(stimulus: usize) -> Response {
    Response::Stimulus((stimulus + 1) % 5)
}

#[test]
fn an_answer_writes_a_row_and_its_trace_and_practice_says_whether_it_was_right() {
    let dir = temp_dir("answer");
    let (mut run, mut state) = open(SHAPES, &dir);
    assert_eq!(run.phase(), &Phase::Paused);
    assert!(!run.started());
    assert_eq!(run.session().planned(), 45);
    // Start: the first trial's scene is in the loop (the stepped loop took it at once) and
    // its forces are on.
    run.resume(&mut state, 0.0);
    assert_eq!(run.phase(), &Phase::Exploring);
    let trial = run.trial().unwrap().clone();
    assert_eq!((trial.number, trial.practice), (1, true));
    assert!(run.stimulus_on());
    assert!(state.forces_requested);
    assert_eq!(state.scene.rendered, Some(trial.object));
    assert_eq!(state.scene.model, trial.intervals[0]);
    assert_eq!(run.progress(), "Practice · Trial 1 of 45");
    press_down(&mut state, 300);
    run.tick(&mut state, 4.0);
    let pressed = state.latest().unwrap().tick;
    assert!(pressed.normal_force_n > 0.5, "{pressed:?}");
    // Enter: the stimulus goes, the answer is asked; nothing is written yet.
    run.end_exploration(&mut state, 5.0);
    assert_eq!(run.phase(), &Phase::Answering);
    assert!(!state.forces_requested);
    assert!(!run.stimulus_on());
    assert!(rows(&dir).is_empty());
    state.step(50);
    let right = run
        .answer(&mut state, Response::Stimulus(trial.stimulus), 6.5)
        .unwrap();
    assert!(right);
    assert_eq!(
        run.phase(),
        &Phase::Feedback {
            correct: true,
            message: "correct".into()
        }
    );
    let r = rows(&dir);
    assert_eq!(r.len(), 1);
    assert_eq!(r[0][column("participant")], "P01");
    assert_eq!(r[0][column("trial")], "1");
    assert_eq!(r[0][column("practice")], "1");
    assert_eq!(r[0][column("correct")], "1");
    assert_eq!(r[0][column("response_time_s")], "1.500");
    assert_eq!(r[0][column("trace")], "traces/trial-0001-a.csv");
    assert_eq!(r[0][column("t_start_s")], "0.000");
    // The trace: the run log of the ticks felt while the stimulus was on (the 300 of the
    // press; not the 50 after it went), read back as any run log is.
    let log = host::runlog::read(&dir.join("traces/trial-0001-a.csv")).unwrap();
    assert_eq!(log.run.ticks.len(), 300);
    assert!(log.run.ticks.iter().any(|k| k.normal_force_n > 0.5));
    // The next trial, answered wrong: the feedback names the stimulus.
    run.next(&mut state, 8.0);
    let second = run.trial().unwrap().clone();
    assert_eq!((second.number, run.phase()), (2, &Phase::Exploring));
    run.end_exploration(&mut state, 9.0);
    assert!(
        !run.answer(&mut state, wrong(second.stimulus), 9.25)
            .unwrap()
    );
    let names: Vec<String> = run.answers().into_iter().map(|(n, _)| n).collect();
    assert_eq!(
        names,
        [
            "convex-strong",
            "convex-mild",
            "straight",
            "concave-mild",
            "concave-strong"
        ]
    );
    assert_eq!(
        run.phase(),
        &Phase::Feedback {
            correct: false,
            message: format!("wrong, it was {}", names[second.stimulus])
        }
    );
    let r = rows(&dir);
    assert_eq!(r[1][column("t_start_s")], "8.000");
    assert_eq!(r[1][column("response_time_s")], "0.250");
    assert_eq!(r[1][column("correct")], "0");
    // Through the practice; a test trial's answer goes straight on to the next trial.
    run.next(&mut state, 10.0);
    while run.trial().unwrap().practice {
        run.end_exploration(&mut state, 10.0);
        let s = run.trial().unwrap().stimulus;
        run.answer(&mut state, Response::Stimulus(s), 10.0).unwrap();
        run.next(&mut state, 10.0);
    }
    let test = run.trial().unwrap().clone();
    assert_eq!(test.number, 6);
    run.end_exploration(&mut state, 11.0);
    run.answer(&mut state, wrong(test.stimulus), 12.0).unwrap();
    assert_eq!(
        run.phase(),
        &Phase::Exploring,
        "no feedback on a test trial"
    );
    assert_eq!(run.trial().unwrap().number, 7);
    assert_eq!(rows(&dir).len(), 6);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_timer_ends_the_exploration_and_the_response_time_runs_from_there() {
    let dir = temp_dir("timer");
    let (mut run, mut state) = open(SHAPES, &dir);
    run.resume(&mut state, 100.0);
    assert_eq!(run.time_left(100.0), Some(30.0));
    run.tick(&mut state, 129.5);
    assert_eq!(run.phase(), &Phase::Exploring);
    assert_eq!(run.time_left(129.5), Some(0.5));
    run.tick(&mut state, 130.0);
    assert_eq!(run.phase(), &Phase::Answering);
    assert!(!state.forces_requested, "the stimulus is gone");
    let s = run.trial().unwrap().stimulus;
    run.answer(&mut state, Response::Stimulus(s), 132.0)
        .unwrap();
    assert_eq!(rows(&dir)[0][column("response_time_s")], "2.000");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_answer_out_of_turn_is_refused_and_writes_nothing() {
    let dir = temp_dir("out-of-turn");
    let (mut run, mut state) = open(SHAPES, &dir);
    assert!(run.answer(&mut state, Response::Stimulus(0), 0.0).is_err());
    run.resume(&mut state, 0.0);
    assert!(run.answer(&mut state, Response::Stimulus(0), 1.0).is_err());
    assert!(run.error.is_some());
    run.end_exploration(&mut state, 2.0);
    // A 2AFC answer to an identification trial.
    assert!(run.answer(&mut state, Response::Interval(1), 3.0).is_err());
    assert!(rows(&dir).is_empty());
    assert_eq!(run.phase(), &Phase::Answering);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_pause_removes_the_stimulus_and_stops_the_clocks() {
    let dir = temp_dir("pause");
    let (mut run, mut state) = open(SHAPES, &dir);
    run.resume(&mut state, 0.0);
    run.pause(&mut state, 10.0);
    assert_eq!(run.phase(), &Phase::Paused);
    assert!(run.started());
    assert!(!run.stimulus_on());
    assert!(!state.forces_requested);
    // The exploration's clock stood still through the pause.
    run.tick(&mut state, 100.0);
    assert_eq!(run.phase(), &Phase::Paused);
    assert_eq!(run.time_left(100.0), Some(20.0));
    run.toggle_pause(&mut state, 100.0);
    assert_eq!(run.phase(), &Phase::Exploring);
    assert!(run.stimulus_on() && state.forces_requested);
    assert_eq!(run.trial().unwrap().number, 1, "the same trial");
    run.tick(&mut state, 119.0);
    assert_eq!(run.phase(), &Phase::Exploring);
    run.tick(&mut state, 120.0);
    assert_eq!(run.phase(), &Phase::Answering);
    // Paused while answering: the response time leaves the pause out.
    run.pause(&mut state, 121.0);
    run.resume(&mut state, 200.0);
    assert_eq!(run.phase(), &Phase::Answering);
    let s = run.trial().unwrap().stimulus;
    run.answer(&mut state, Response::Stimulus(s), 201.5)
        .unwrap();
    assert_eq!(rows(&dir)[0][column("response_time_s")], "2.500");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn reopening_the_folder_resumes_at_the_next_trial() {
    let dir = temp_dir("resume");
    let (mut run, mut state) = open(SHAPES, &dir);
    run.resume(&mut state, 0.0);
    let mut order = Vec::new();
    for k in 0..3 {
        let t = run.trial().unwrap().clone();
        order.push(t.stimulus);
        run.end_exploration(&mut state, f64::from(k));
        run.answer(&mut state, Response::Stimulus(t.stimulus), f64::from(k))
            .unwrap();
        run.next(&mut state, f64::from(k));
    }
    // Quit in the middle of trial 4: it was never answered.
    assert_eq!(run.trial().unwrap().number, 4);
    let fourth = run.trial().unwrap().stimulus;
    run.pause(&mut state, 5.0);
    drop(run);
    let (mut run, mut state) = open(SHAPES, &dir);
    assert_eq!(run.session().resumed(), 3);
    assert_eq!(run.session().number(), 2);
    assert_eq!(run.phase(), &Phase::Paused);
    run.resume(&mut state, 0.0);
    let t = run.trial().unwrap().clone();
    assert_eq!((t.number, t.stimulus), (4, fourth));
    run.end_exploration(&mut state, 1.0);
    run.answer(&mut state, Response::Stimulus(t.stimulus), 1.0)
        .unwrap();
    let r = rows(&dir);
    assert_eq!(r.len(), 4);
    assert_eq!(r[3][column("trial")], "4");
    assert_eq!(r[3][column("session")], "2");
    assert_eq!(r[2][column("session")], "1");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_2afc_trial_switches_between_its_intervals_and_writes_a_trace_of_each() {
    let dir = temp_dir("2afc");
    let (mut run, mut state) = open(JND, &dir);
    assert!(run.is_two_interval());
    let answers: Vec<String> = run.answers().into_iter().map(|(n, _)| n).collect();
    assert_eq!(answers, ["first was stiffer", "second was stiffer"]);
    run.resume(&mut state, 0.0);
    assert_eq!(run.progress(), "Practice · Trial 1 of 4");
    let trial = run.trial().unwrap().clone();
    assert_eq!(trial.intervals.len(), 2);
    let stiffness = |state: &AppState| state.running_material.unwrap().stiffness_n_per_m;
    let felt = |k: usize| {
        trial.intervals[k].objects()[trial.object]
            .material()
            .friction_material()
            .stiffness_n_per_m
    };
    assert_ne!(felt(0), felt(1));
    assert_eq!((run.interval(), stiffness(&state)), (0, felt(0)));
    press_down(&mut state, 100);
    run.tick(&mut state, 1.0);
    run.feel(&mut state, 1, 1.0);
    assert_eq!((run.interval(), stiffness(&state)), (1, felt(1)));
    // Pressed into the shape, the other interval waits for the handle to come out.
    assert!(!run.stimulus_on() && run.awaiting_lift(&state));
    assert!(!state.forces_requested);
    lift(&mut state, 100);
    run.tick(&mut state, 1.5);
    assert!(run.stimulus_on() && !run.awaiting_lift(&state));
    press_down(&mut state, 40);
    run.tick(&mut state, 2.0);
    run.feel(&mut state, 0, 2.0);
    assert_eq!(stiffness(&state), felt(0));
    state.step(10);
    run.tick(&mut state, 3.0);
    // Stiffer: the comparison when it is above the reference.
    let comparison_stiffer = trial.level >= trial.reference;
    let first_stiffer = trial.comparison_first == Some(comparison_stiffer);
    run.end_exploration(&mut state, 4.0);
    let right = run
        .answer(
            &mut state,
            Response::Interval(if first_stiffer { 1 } else { 2 }),
            4.5,
        )
        .unwrap();
    assert!(right);
    assert_eq!(
        run.phase(),
        &Phase::Feedback {
            correct: true,
            message: "correct".into()
        }
    );
    let r = rows(&dir);
    assert_eq!(
        r[0][column("trace")],
        "traces/trial-0001-a.csv;traces/trial-0001-b.csv"
    );
    let ticks = |name: &str| {
        host::runlog::read(&dir.join("traces").join(name))
            .unwrap()
            .run
            .ticks
            .len()
    };
    assert_eq!(ticks("trial-0001-a.csv"), 110);
    assert_eq!(ticks("trial-0001-b.csv"), 40);
    // A wrong answer is told which was stiffer.
    run.next(&mut state, 5.0);
    let trial = run.trial().unwrap().clone();
    let first_stiffer = trial.comparison_first == Some(trial.level >= trial.reference);
    run.end_exploration(&mut state, 6.0);
    run.answer(
        &mut state,
        Response::Interval(if first_stiffer { 2 } else { 1 }),
        7.0,
    )
    .unwrap();
    let which = if first_stiffer { "first" } else { "second" };
    assert_eq!(
        run.phase(),
        &Phase::Feedback {
            correct: false,
            message: format!("wrong, the {which} was stiffer")
        }
    );
    // Past the practice the staircases set the trials: their number is not known.
    loop {
        run.next(&mut state, 8.0);
        if !run.trial().unwrap().practice {
            break;
        }
        run.end_exploration(&mut state, 8.0);
        run.answer(&mut state, Response::Interval(1), 8.0).unwrap();
    }
    assert_eq!(run.phase(), &Phase::Exploring);
    assert_eq!(
        run.progress(),
        "Trial 5 (staircase: until the staircases end)"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The longest polyline among the shapes egui was asked to paint (the scene's curves are
/// drawn as 257-point lines; nothing on the participant's screen has more than a few).
fn longest_path(output: &egui::FullOutput) -> usize {
    fn walk(shape: &egui::Shape, longest: &mut usize) {
        match shape {
            egui::Shape::Vec(shapes) => shapes.iter().for_each(|s| walk(s, longest)),
            egui::Shape::Path(p) => *longest = (*longest).max(p.points.len()),
            _ => {}
        }
    }
    let mut longest = 0;
    for s in &output.shapes {
        walk(&s.shape, &mut longest);
    }
    longest
}

fn participant_harness<'a>(ui: ParticipantUi) -> Harness<'a, ParticipantUi> {
    Harness::builder()
        .with_size(egui::Vec2::new(1200.0, 800.0))
        .build_ui_state(
            |ui, p: &mut ParticipantUi| {
                p.ui(ui);
            },
            ui,
        )
}

#[test]
fn the_screen_hides_the_object_and_its_buttons_answer() {
    let dir = temp_dir("screen");
    let (run, state) = open(SHAPES, &dir);
    let mut p = ParticipantUi::new(state, run);
    p.frozen_s = Some(0.0);
    let mut h = participant_harness(p);
    h.run_steps(2);
    h.get_by_label("Start (Enter)").click();
    h.run_steps(2);
    assert_eq!(h.state().run.phase(), &Phase::Exploring);
    press_down(&mut h.state_mut().state, 300);
    h.run_steps(2);
    // In contact, and nothing of the object is drawn: no curve, and no text naming it.
    let p = h.state();
    let touching = p.state.latest().unwrap().tick;
    assert!(touching.normal_force_n > 0.5, "{touching:?}");
    assert!(
        longest_path(h.output()) < 20,
        "{} points",
        longest_path(h.output())
    );
    let trial = p.run.trial().unwrap().clone();
    assert!(h.query_by_label_contains("convex").is_none());
    assert!(h.query_by_label_contains("straight").is_none());
    h.get_by_label("Practice · Trial 1 of 45");
    h.get_by_label("Time left: 30 s");
    // The app's own 2-D view on the same state draws the curves (what the check above would
    // have caught).
    let (_, state) = open(SHAPES, &temp_dir("screen-view"));
    let mut v = Harness::builder()
        .with_size(egui::Vec2::new(800.0, 600.0))
        .build_ui_state(
            |ui, v: &mut ViewerUi| view::view_2d_ui(ui, &mut v.state, &mut v.view),
            ViewerUi::new(state),
        );
    v.run_steps(2);
    assert!(longest_path(v.output()) > 200);
    // Answer, then the stimulus's button: its row is written, and the practice feedback
    // shows.
    h.get_by_label("Answer (Enter)").click();
    h.run_steps(2);
    assert_eq!(h.state().run.phase(), &Phase::Answering);
    let names = [
        "convex-strong",
        "convex-mild",
        "straight",
        "concave-mild",
        "concave-strong",
    ];
    let label = format!("{} {}", trial.stimulus + 1, names[trial.stimulus]);
    h.get_by_label(&label).click();
    h.run_steps(2);
    let r = rows(&dir);
    assert_eq!(r.len(), 1);
    assert_eq!(r[0][column("response")], names[trial.stimulus]);
    h.get_by_label("correct");
    // The keys: Enter for the next trial, Enter to end its exploration, a digit to answer.
    h.key_press(egui::Key::Enter);
    h.run_steps(2);
    assert_eq!(h.state().run.trial().unwrap().number, 2);
    h.key_press(egui::Key::Enter);
    h.run_steps(2);
    assert_eq!(h.state().run.phase(), &Phase::Answering);
    h.key_press(egui::Key::Num3);
    h.run_steps(2);
    let r = rows(&dir);
    assert_eq!(r.len(), 2);
    assert_eq!(r[1][column("response")], "straight");
    // P pauses (the forces go off), and P resumes.
    h.key_press(egui::Key::Enter);
    h.run_steps(2);
    h.key_press(egui::Key::P);
    h.run_steps(2);
    assert_eq!(h.state().run.phase(), &Phase::Paused);
    assert!(!h.state().state.forces_requested);
    h.get_by_label("Resume (Enter)");
    h.key_press(egui::Key::P);
    h.run_steps(2);
    assert_eq!(h.state().run.phase(), &Phase::Exploring);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_last_answer_ends_the_run_with_thanks() {
    let dir = temp_dir("done");
    let (mut run, mut state) = open(SHAPES, &dir);
    run.resume(&mut state, 0.0);
    let mut n = 0;
    while let Some(t) = run.trial().cloned() {
        run.end_exploration(&mut state, 0.0);
        run.answer(&mut state, Response::Stimulus(t.stimulus), 0.0)
            .unwrap();
        run.next(&mut state, 0.0);
        n += 1;
    }
    assert_eq!(n, 45);
    assert_eq!(run.phase(), &Phase::Done);
    // Reopened, the folder has nothing left to run.
    let (again, _) = open(SHAPES, &dir);
    assert_eq!(again.phase(), &Phase::Done);
    assert_eq!(again.session().resumed(), 45);
    let mut p = ParticipantUi::new(state, run);
    p.frozen_s = Some(0.0);
    let mut h = participant_harness(p);
    h.run_steps(2);
    h.get_by_label("Done: 45 trials. Thank you.");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The app's own set-up: the loop on its thread, whose scene swaps are taken a little later
/// (the participant's window runs so, and a device's upload is taken later still).
#[test]
fn with_the_loop_on_its_thread_the_stimulus_comes_on_once_the_loop_took_the_scene() {
    use std::time::{Duration, Instant};
    let dir = temp_dir("threaded");
    let plan = Plan::load(SHAPES).unwrap();
    let scene = plan.scene(0).unwrap().clone();
    let mut run = ParticipantRun::open(plan, "P01", &dir).unwrap();
    let mut state = AppState::new("participant", scene, true, None).unwrap();
    run.resume(&mut state, 0.0);
    let trial = run.trial().unwrap().clone();
    let begun = Instant::now();
    while !run.stimulus_on() && begun.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(5));
        state.poll();
        run.tick(&mut state, 0.0);
    }
    assert!(run.stimulus_on());
    assert!(state.forces_requested);
    assert_eq!(state.scene.model, trial.intervals[0]);
    std::thread::sleep(Duration::from_millis(200));
    state.poll();
    run.tick(&mut state, 1.0);
    run.end_exploration(&mut state, 1.0);
    run.answer(&mut state, Response::Stimulus(trial.stimulus), 2.0)
        .unwrap();
    state.shutdown();
    let log = host::runlog::read(&dir.join("traces/trial-0001-a.csv")).unwrap();
    assert!(log.run.ticks.len() > 20, "{} ticks", log.run.ticks.len());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The participant's window on a device behind a link (here the host's simulated device,
/// the protocol a board speaks): each trial's scene is uploaded as the app uploads any scene,
/// the forces come on once the device has it, and go off when the exploration ends.
#[test]
fn on_a_linked_device_the_trial_is_uploaded_and_its_forces_follow_the_phase() {
    use std::time::{Duration, Instant};
    let dir = temp_dir("linked");
    let plan = Plan::load(SHAPES).unwrap();
    let mut state = viewer::gui::participant::participant_state(
        &plan,
        Some(host::devices::Target::Sim),
        device::spec::DeviceSpec::default(),
    )
    .unwrap();
    let mut run = ParticipantRun::open(plan, "P01", &dir).unwrap();
    let wait = |state: &mut AppState,
                run: &mut ParticipantRun,
                what: &str,
                done: &dyn Fn(&AppState, &ParticipantRun) -> bool| {
        let begun = Instant::now();
        while !done(state, run) {
            assert!(
                begun.elapsed() < Duration::from_secs(20),
                "waited for {what}; link {:?}",
                state.link
            );
            std::thread::sleep(Duration::from_millis(5));
            state.poll();
            run.tick(state, 0.0);
        }
    };
    // The device's set-up (calibration, then the forces) ends with the forces off.
    wait(&mut state, &mut run, "the calibrated device", &|s, _| {
        s.link.status.is_some_and(|st| st.calibrated)
    });
    run.resume(&mut state, 0.0);
    let trial = run.trial().unwrap().clone();
    let wire = host::upload::wire_scene(&trial.intervals[0], trial.object).unwrap();
    wait(
        &mut state,
        &mut run,
        "the trial's scene on the device, forces on",
        &|s, r| {
            r.stimulus_on()
                && s.link
                    .status
                    .is_some_and(|st| st.scene_crc32 == protocol::crc32(&wire) && st.forces_enabled)
        },
    );
    run.end_exploration(&mut state, 1.0);
    wait(&mut state, &mut run, "the forces off", &|s, _| {
        s.link.status.is_some_and(|st| !st.forces_enabled)
    });
    assert_eq!(run.phase(), &Phase::Answering);
    run.answer(&mut state, Response::Stimulus(trial.stimulus), 2.0)
        .unwrap();
    state.shutdown();
    let log = host::runlog::read(&dir.join("traces/trial-0001-a.csv")).unwrap();
    assert!(!log.run.ticks.is_empty());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 31, item 2: a trial that begins with the handle still pressed into the shape (the
/// previous trial's press: 9–16 N in the first row of its trace, and on a board a jolt)
/// waits, forces off and its clock stopped, until the handle is out of every object; the
/// screen says so; then the stimulus comes on and its trace starts at no force.
#[test]
fn a_trial_begun_with_the_handle_inside_waits_for_it_to_come_out() {
    let dir = temp_dir("lift");
    let (mut run, mut state) = open(SHAPES, &dir);
    run.resume(&mut state, 0.0);
    assert!(run.stimulus_on() && !run.awaiting_lift(&state));
    press_down(&mut state, 300);
    run.tick(&mut state, 1.0);
    assert!(
        state.latest().unwrap().tick.normal_force_n > 0.5,
        "pressed in"
    );
    run.end_exploration(&mut state, 2.0);
    let first = run.trial().unwrap().stimulus;
    run.answer(&mut state, Response::Stimulus(first), 2.5)
        .unwrap();
    // The next trial: the hand is still 10 mm into where every stimulus has its vertex.
    run.next(&mut state, 3.0);
    assert_eq!(run.trial().unwrap().number, 2);
    state.step(20);
    run.tick(&mut state, 3.1);
    assert!(run.awaiting_lift(&state), "the handle is inside");
    assert!(!run.stimulus_on() && !state.forces_requested);
    // Its clock has not started: a 30 s exploration still has 30 s after 10 s of waiting.
    run.tick(&mut state, 13.0);
    assert_eq!(run.time_left(13.0), Some(30.0));
    assert_eq!(run.phase(), &Phase::Exploring);
    // Out: the stimulus comes on, its clock runs from then.
    lift(&mut state, 300);
    run.tick(&mut state, 14.0);
    assert!(run.stimulus_on() && state.forces_requested);
    assert!(!run.awaiting_lift(&state));
    assert_eq!(run.time_left(15.0), Some(29.0));
    // Felt again, answered: the trace's first row is at no force (the handle out, the
    // forces ramping in from zero), and it holds the new press.
    press_down(&mut state, 300);
    run.tick(&mut state, 16.0);
    run.end_exploration(&mut state, 17.0);
    let second = run.trial().unwrap().stimulus;
    run.answer(&mut state, Response::Stimulus(second), 17.5)
        .unwrap();
    let log = host::runlog::read(&dir.join("traces/trial-0002-a.csv")).unwrap();
    let ticks = &log.run.ticks;
    assert_eq!(ticks[0].normal_force_n, 0.0, "{:?}", ticks[0]);
    assert!(ticks.iter().any(|k| k.normal_force_n > 0.5));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Issue 31, item 5: Quit sits next to Pause, so during a run it asks first; "Keep going"
/// goes back to the trial, "Quit now" quits. After the last trial it quits at once.
#[test]
fn quit_during_a_run_asks_first() {
    let dir = temp_dir("quit");
    let (run, state) = open(SHAPES, &dir);
    let mut p = ParticipantUi::new(state, run);
    p.frozen_s = Some(0.0);
    let quit = std::rc::Rc::new(std::cell::Cell::new(false));
    let asked = quit.clone();
    let mut h = Harness::builder()
        .with_size(egui::Vec2::new(1200.0, 800.0))
        .build_ui_state(
            move |ui, p: &mut ParticipantUi| {
                if p.ui(ui) {
                    asked.set(true);
                }
            },
            p,
        );
    h.run_steps(2);
    h.get_by_label("Start (Enter)").click();
    h.run_steps(2);
    h.get_by_label("Quit").click();
    h.run_steps(2);
    assert!(!quit.get(), "one click does not quit");
    assert_eq!(
        h.state().run.phase(),
        &Phase::Exploring,
        "the trial goes on"
    );
    h.get_by_label("Keep going").click();
    h.run_steps(2);
    assert!(h.query_by_label("Quit now").is_none());
    h.get_by_label("Quit").click();
    h.run_steps(2);
    h.get_by_label("Quit now").click();
    h.run_steps(2);
    assert!(quit.get(), "confirmed");
    std::fs::remove_dir_all(&dir).unwrap();
}
