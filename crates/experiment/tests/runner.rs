//! The shipped stiffness-JND plan run with a simulated participant: the files a run writes
//! and the thresholds against the participant's own psychometric function.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};

use experiment::analyze::{AnalyzeOptions, summarize};
use experiment::error::RunError;
use experiment::plan::Plan;
use experiment::runner::{TRIALS_HEADER, run};
use experiment::sim_participant::SimParticipant;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("experiment-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Φ⁻¹(0.75) and Φ⁻¹(2^-½) from Python's `statistics.NormalDist().inv_cdf` (Wichura's
/// AS241, an implementation independent of the crate's quantile).
const Z_75: f64 = 0.674_489_750_196_081_7;
const Z_707: f64 = 0.544_952_135_617_360_3;

#[test]
fn the_stiffness_plan_runs_to_thresholds_at_the_participants_70_7_percent_points() {
    let plan = Plan::load(root().join("experiments/stiffness-jnd.json")).unwrap();
    let participant = SimParticipant::parse("sim:1:weber=0.2").unwrap().unwrap();
    let out = temp_dir("run");
    let summary = run(&plan, &participant, &out).unwrap();

    // Files: the header, one row per trial, both traces of every trial as run logs.
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    let mut lines = trials.lines();
    assert_eq!(lines.next(), Some(TRIALS_HEADER));
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), summary.trials);
    let columns = TRIALS_HEADER.split(',').count();
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), columns, "row {}: {row:?}", i + 1);
        assert_eq!(row[3], (i + 1).to_string());
        // The plan's 4 practice trials come first, in block 0.
        assert_eq!(row[4], if i < 4 { "1" } else { "0" });
        assert_eq!(row[2], if i < 4 { "0" } else { "1" });
        assert_eq!(row[5], "2afc-staircase");
        assert_eq!(row[14], "0.000");
        for trace in row[15].split(';') {
            let log = std::fs::read_to_string(out.join(trace))
                .unwrap_or_else(|e| panic!("trial {}: {trace}: {e}", i + 1));
            assert!(log.starts_with("t_s,"), "{trace} is not a run log");
            // The real-time check: an unbroken 1 kHz loop.
            let timing = experiment::trace::check(&log, 1000.0).unwrap();
            assert_eq!((timing.dropped, timing.irregular), (0, 0), "{trace}");
            // 0.7 s at 1 kHz, plus the header.
            assert!(
                log.lines().count() > 700,
                "{trace}: {} lines",
                log.lines().count()
            );
        }
    }
    let plan_json = std::fs::read_to_string(out.join("plan.json")).unwrap();
    assert!(plan_json.contains("2afc-staircase"));

    // The staircases finished: 12 reversals each, as the plan says, and the analysis of the
    // folder lists the same 12 (it listed 11: it read them from the levels presented, which
    // never show the move the last answer makes, and the 12th reversal is that move).
    assert_eq!(summary.staircases.len(), 2);
    let analysis = summarize(&out, &AnalyzeOptions::default()).unwrap();
    let tracks = &analysis.two_afc.as_ref().unwrap().cells[0].staircases;
    for (s, track) in summary.staircases.iter().zip(tracks) {
        assert!(s.finished, "{s:?}");
        assert_eq!(s.reversal_levels.len(), 12, "{s:?}");
        assert_eq!(s.trials, rows.iter().filter(|r| r[8] == s.name).count());
        let listed: Vec<f64> = track.reversals.iter().map(|r| r.level).collect();
        assert_eq!(listed, s.reversal_levels, "{}", s.name);
    }
    assert_eq!(summary.practice, 4);
    assert_eq!(
        summary.trials,
        summary.practice + summary.staircases.iter().map(|s| s.trials).sum::<usize>()
    );

    // The participant's model (participant.rs): a comparison x against the reference r is
    // called stiffer with probability ψ(x) = Φ(ln(x/r) / (σ√2)), σ = ln(1 + W) / (√2 Φ⁻¹(0.75)),
    // so 2-down/1-up's 70.7 % point is x = r exp(ln(1 + W) Φ⁻¹(0.707) / Φ⁻¹(0.75)), and its
    // mirror r²/x below. The felt stiffness is proportional to the rendered one (the same
    // press on the same shape), so the ratio carries over.
    let r = summary.reference.unwrap();
    let log_offset = 1.2f64.ln() * Z_707 / Z_75;
    let (upper_model, lower_model) = (r * log_offset.exp(), r / log_offset.exp());
    let upper = &summary.staircases[0];
    let lower = &summary.staircases[1];
    assert!(!upper.below && lower.below);
    let (tu, tl) = (upper.threshold.unwrap(), lower.threshold.unwrap());
    eprintln!(
        "thresholds: upper {tu:.1} (model {upper_model:.1}), lower {tl:.1} (model {lower_model:.1})"
    );
    assert!(tu > r && tl < r, "upper {tu}, lower {tl}");
    // Tolerance: in log units the psychometric function's spread is σ√2 = 0.27 (W = 0.2);
    // the mean of a track's last 8 reversals (4 up/down pairs, each pair's midpoint
    // scattering by about that spread) has a standard error of about 0.27/√4 = 0.135; three
    // of those, 0.40, bound one run's estimate. Staircases of small steps also sit off
    // their nominal target by a fraction of the spread (García-Pérez 1998), inside that.
    // (Seeds 1–12 gave ln(threshold/model) of +0.03 ± 0.08 above and −0.06 ± 0.07 below,
    // mean ± SD: the bound is loose, not tuned to this seed.)
    let tolerance = 3.0 * (2.0f64.sqrt() * 1.2f64.ln() / (2.0f64.sqrt() * Z_75)) / 2.0;
    for (t, model) in [(tu, upper_model), (tl, lower_model)] {
        assert!(
            (t / model).ln().abs() < tolerance,
            "threshold {t} vs the model's {model}: |ln ratio| >= {tolerance}"
        );
    }
    if std::env::var_os("KEEP").is_none() {
        std::fs::remove_dir_all(&out).unwrap();
    }
}

/// The Weber fraction's interval stays above 0 (issue 31 item 11). Ordinary runs of the
/// shipped plan by the default simulated participant (W = 0.15), analysed as `viewer
/// experiment analyze` does: the unfolded log-Gaussian fitted before let the psychometric
/// function stand above chance at the reference itself, and its 95 % intervals reached below
/// 0 on 33 of 200 such runs. On these seeds it gave [−0.0257, 0.2836] (seed 4), [−0.0586,
/// 0.2310] (10), [−0.0527, 0.2566] (29) and, with the estimate itself at 0.0016,
/// [−0.0687, 0.1199] (41). The folded model is ½ at the reference, so no threshold at or
/// below it can come out: now [0.0591, 0.2458], [0.0445, 0.2102], [0.0424, 0.2245] and
/// [0.0322, 0.1103] (estimates 0.1206, 0.0795, 0.0815, 0.0373).
#[test]
fn the_weber_fractions_interval_of_staircase_runs_stays_above_zero() {
    let plan = Plan::load(root().join("experiments/stiffness-jnd.json")).unwrap();
    for seed in [4, 10, 29, 41] {
        let participant = SimParticipant::parse(&format!("sim:{seed}"))
            .unwrap()
            .unwrap();
        let out = temp_dir(&format!("weber-{seed}"));
        run(&plan, &participant, &out).unwrap();
        let analysis = summarize(&out, &AnalyzeOptions::default()).unwrap();
        let fit = analysis.two_afc.as_ref().unwrap().cells[0]
            .fit
            .clone()
            .unwrap();
        let [lo, hi] = fit.ci95_weber.unwrap();
        let [t_lo, _] = fit.ci95_threshold.unwrap();
        eprintln!("seed {seed}: weber {:.4}, [{lo:.4}, {hi:.4}]", fit.weber_75);
        assert!(
            0.0 < lo && lo < fit.weber_75 && fit.weber_75 < hi,
            "seed {seed}: weber {} in [{lo}, {hi}]",
            fit.weber_75
        );
        assert!(
            t_lo > 500.0 && fit.threshold_75 > 500.0,
            "seed {seed}: {fit:?}"
        );
        std::fs::remove_dir_all(&out).unwrap();
    }
}

/// The thesis's shape experiment with a simulated participant: every trial of the plan ran,
/// in the plan's balanced order, each answered with one of the five shapes; the participant
/// identifies the shapes far above chance (1/5) from what the taps rendered. Rerun into the
/// same folder, the finished run resumes with nothing left to do, its rows untouched.
#[test]
fn the_thesis_shapes_run_identifies_above_chance_and_resumes() {
    let plan = Plan::load(root().join("experiments/thesis-shapes.json")).unwrap();
    let participant = SimParticipant::parse("sim:5").unwrap().unwrap();
    let out = temp_dir("shapes");
    let summary = run(&plan, &participant, &out).unwrap();
    // The order is the participant's (the plan's seed and the participant's ID, as the
    // trials' participant column gives it).
    let planned = plan
        .trials_for(&experiment::runner::participant_label(&participant))
        .expect("mixed blocks: any ID");
    // 5 practice, then 5 shapes × 2 conditions × 4 repetitions in 2 blocks.
    assert_eq!(summary.trials, planned.len());
    assert_eq!(summary.trials, 5 + 40);
    assert_eq!(summary.practice, 5);
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    let rows: Vec<Vec<String>> = experiment::csv::records(&trials)
        .unwrap()
        .into_iter()
        .skip(1)
        .map(|r| r.fields)
        .collect();
    let names: Vec<&str> = plan
        .spec()
        .stimuli
        .iter()
        .map(|s| s.name.as_str())
        .collect();
    for (row, t) in rows.iter().zip(&planned) {
        assert_eq!(row[6], names[t.stimulus]);
        assert_eq!(row[7], plan.spec().conditions[t.condition].name);
        assert!(names.contains(&row[12].as_str()), "{row:?}");
        assert_eq!(row[13], u8::from(row[12] == row[6]).to_string());
        // One trace per trial, a tap run log of an unbroken 1 kHz loop that ended within the
        // plan's exploration time (30 s).
        let log = std::fs::read_to_string(out.join(&row[15])).unwrap();
        let timing = experiment::trace::check(&log, 1000.0).unwrap();
        assert_eq!((timing.dropped, timing.irregular), (0, 0), "{row:?}");
        assert!(
            timing.duration_s > 1.0 && timing.duration_s < 30.0,
            "{timing:?}"
        );
    }
    // Chance is 8 of 40; a participant that felt nothing of the shape would exceed 16 (the
    // binomial's 0.999 quantile at n = 40, p = 0.2 is 16) with probability < 0.001.
    eprintln!("thesis shapes: {summary}");
    assert!(summary.correct > 16, "{summary}");

    let again = run(&plan, &participant, &out).unwrap();
    assert_eq!(again.trials, 0, "{again}");
    // It says the run was complete (it said "0 trials (0 practice), 0 of 0 correct").
    assert_eq!(again.resumed, 45, "{again}");
    assert!(
        again
            .to_string()
            .starts_with("the run was complete already (45 trials answered)"),
        "{again}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("trials.csv")).unwrap(),
        trials
    );
    if std::env::var_os("KEEP").is_none() {
        std::fs::remove_dir_all(&out).unwrap();
    }
}

/// A folder holding another plan's run is refused, naming the file, and left untouched.
#[test]
fn a_folder_of_another_plan_is_refused_and_untouched() {
    let shapes = Plan::load(root().join("experiments/thesis-shapes.json")).unwrap();
    let jnd = Plan::load(root().join("experiments/stiffness-jnd.json")).unwrap();
    let participant = SimParticipant::parse("sim:2").unwrap().unwrap();
    let out = temp_dir("other-plan");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(
        out.join("plan.json"),
        shapes.to_json_string_resolved().unwrap() + "\n",
    )
    .unwrap();
    std::fs::write(out.join("trials.csv"), format!("{TRIALS_HEADER}\n")).unwrap();
    let err = run(&jnd, &participant, &out).unwrap_err();
    assert!(matches!(err, RunError::Resume { .. }), "{err}");
    assert!(err.to_string().contains("plan.json"), "{err}");
    assert_eq!(
        std::fs::read_to_string(out.join("trials.csv")).unwrap(),
        format!("{TRIALS_HEADER}\n")
    );
    std::fs::remove_dir_all(&out).unwrap();
}

/// The constant-stimuli plan with a simulated participant of W = 0.15: every level runs its
/// 20 repetitions, the comparison first in exactly half of them (the design alternates it
/// within each block's 10), and the proportion correct at each of the three folded distances
/// (40 trials: ×1.1 with ÷1.1, …) is the participant's ψ there, within 4 binomial standard
/// errors √(ψ(1 − ψ)/40) (the felt stiffness is proportional to the rendered one for the same
/// press, so ratios carry over; see the staircase test).
#[test]
fn constant_stimuli_run_balanced_and_follow_the_participants_psychometric_function() {
    let plan = Plan::load(root().join("experiments/stiffness-constant.json")).unwrap();
    let participant = SimParticipant::parse("sim:9:weber=0.15").unwrap().unwrap();
    let out = temp_dir("constant");
    let summary = run(&plan, &participant, &out).unwrap();
    assert_eq!(summary.trials, 4 + 6 * 20);
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    let rows: Vec<Vec<&str>> = trials
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let tests: Vec<&Vec<&str>> = rows.iter().filter(|r| r[4] == "0").collect();
    let r = 500.0f64;
    let sigma_sqrt2 = 1.15f64.ln() / Z_75;
    // Φ(z) = erfc(−z/√2)/2, computed here independently of the crate's own Φ.
    let psi = |ratio: f64| 0.5 * erfc(-(ratio.ln() / sigma_sqrt2) / std::f64::consts::SQRT_2);
    for ratio in [1.1, 1.25, 1.5] {
        let at: Vec<&&Vec<&str>> = tests
            .iter()
            .filter(|row| {
                let level: f64 = row[9].parse().unwrap();
                ((level / r).ln().abs() - f64::ln(ratio)).abs() < 1e-9
            })
            .collect();
        assert_eq!(at.len(), 40, "ratio {ratio}");
        for sign in [true, false] {
            let side: Vec<_> = at
                .iter()
                .filter(|row| (row[9].parse::<f64>().unwrap() > r) == sign)
                .collect();
            assert_eq!(side.len(), 20);
            assert_eq!(side.iter().filter(|row| row[11] == "1").count(), 10);
        }
        let p = at.iter().filter(|row| row[13] == "1").count() as f64 / 40.0;
        let expected = psi(ratio);
        let se = (expected * (1.0 - expected) / 40.0).sqrt();
        eprintln!("ratio {ratio}: {p:.3} correct, model {expected:.3} ± {se:.3}");
        assert!(
            (p - expected).abs() < 4.0 * se.max(0.025),
            "ratio {ratio}: {p} vs {expected}"
        );
    }
    std::fs::remove_dir_all(&out).unwrap();
}

/// erfc(x) = 1 − erf(x), erf by Simpson's rule on [0, |x|] with 2,000 panels (for |x| ≤ 3
/// the rule's error bound h⁴ max|f⁗|/180 · |x| is below 1e-12).
fn erfc(x: f64) -> f64 {
    let n = 2000;
    let h = x.abs() / n as f64;
    let f = |t: f64| (-t * t).exp();
    let mut s = f(0.0) + f(x.abs());
    for i in 1..n {
        s += if i % 2 == 1 { 4.0 } else { 2.0 } * f(i as f64 * h);
    }
    let erf = 2.0 / std::f64::consts::PI.sqrt() * s * h / 3.0;
    1.0 - erf.copysign(x)
}
