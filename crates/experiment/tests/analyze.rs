//! The analysis of a run folder against references it did not produce: Fisher's exact test
//! against textbook values and exact integer arithmetic, a confusion matrix counted by hand,
//! staircase reversals read by hand, a simulated observer's Weber fraction recovered within
//! its asymptotic standard error, and bad inputs refused with the line and column.
#![allow(clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use experiment::analyze::{
    AnalyzeError, AnalyzeOptions, Summary, TRIALS_COLUMNS, analyze, fisher_exact_two_sided,
    summarize,
};
use experiment::fit::{Model, Prng};
use experiment::plan::Plan;
use experiment::runner::staircase_summaries;
use experiment::session::{Response, Session, TrialRecord};
use serde_json::{Value, json};

const HEADER: &str = "participant,session,block,trial,practice,design,stimulus,condition,\
staircase,level,reference,comparison_interval,response,correct,response_time_s,trace,t_start_s";

const SHAPES: [&str; 5] = [
    "convex-strong",
    "convex-mild",
    "straight",
    "concave-mild",
    "concave-strong",
];

fn shapes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../experiments/shapes")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("experiment-analyze-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write_run(name: &str, plan: &Value, trials: &str) -> PathBuf {
    let dir = temp_dir(name);
    std::fs::write(
        dir.join("plan.json"),
        serde_json::to_string_pretty(plan).unwrap(),
    )
    .unwrap();
    std::fs::write(dir.join("trials.csv"), trials).unwrap();
    dir
}

fn identification_plan() -> Value {
    let stimuli: Vec<Value> = SHAPES
        .iter()
        .map(|s| {
            let scene = shapes_dir().join(format!("shapes-{s}.json"));
            json!({ "name": s, "scene": scene.to_str().unwrap(), "object": 0 })
        })
        .collect();
    json!({
        "format": "experiment/1",
        "name": "shapes by hand",
        "seed": 11,
        "design": "identification",
        "stimuli": stimuli,
        "conditions": [
            { "name": "friction", "material": {} },
            { "name": "frictionless", "material": { "mu_static": 0.0, "mu_dynamic": 0.0 } }
        ],
        "repetitions": 2,
        "practice_trials": 1
    })
}

fn straight() -> Value {
    let scene = shapes_dir().join("shapes-straight.json");
    json!([{ "name": "straight", "scene": scene.to_str().unwrap(), "object": 0 }])
}

fn constant_plan(levels: &[f64]) -> Value {
    json!({
        "format": "experiment/1",
        "name": "stiffness by constant stimuli",
        "seed": 5,
        "design": "constant-stimuli",
        "stimuli": straight(),
        "reference": { "field": "stiffness_n_per_m", "value": 500.0 },
        "levels": levels,
    })
}

fn staircase_plan() -> Value {
    json!({
        "format": "experiment/1",
        "name": "stiffness by staircases",
        "seed": 9,
        "design": "2afc-staircase",
        "stimuli": straight(),
        "reference": { "field": "stiffness_n_per_m", "value": 500.0 },
        "staircases": [
            { "name": "from above", "start": 800.0, "step": { "size": 100.0 },
              "stop": { "trials": 20 }, "bounds": [525.0, 1000.0] },
            { "name": "from below", "start": 300.0, "step": { "size": 1.25, "kind": "multiplicative" },
              "stop": { "trials": 20 }, "bounds": [200.0, 476.19] }
        ]
    })
}

fn error_text(e: &AnalyzeError) -> String {
    e.to_string()
}

// ---------------------------------------------------------------------------------------
// Fisher's exact test

#[test]
fn fisher_matches_the_textbook_values() {
    // Fisher's lady tasting tea, R's `fisher.test(matrix(c(3,1,1,3),2))`: p = 0.4857. The
    // tables with margins 4/4 have top-left cell x = 0..4 with C(4,x)C(4,4−x) = 1, 16, 36, 16,
    // 1 out of C(8,4) = 70; x = 3 (16) and the tables at most as likely: (1+16+16+1)/70.
    let p = fisher_exact_two_sided([[3, 1], [1, 3]]);
    assert!((p - 34.0 / 70.0).abs() < 1e-12, "{p}");
    assert!((p - 0.4857).abs() < 5e-5);
    // A perfect 5/5 split: only x = 5 and x = 0 have C(5,x)C(5,5−x) = 1 of C(10,5) = 252.
    let p = fisher_exact_two_sided([[5, 0], [0, 5]]);
    assert!((p - 2.0 / 252.0).abs() < 1e-14, "{p}");
    // Rows 2 and 5, first column 3: x = 0, 1, 2 with C(3,x)C(4,2−x) = 6, 12, 3 of C(7,2) =
    // 21. Not symmetric: x = 2 gives 3/21, x = 0 gives (6+3)/21.
    let p = fisher_exact_two_sided([[2, 0], [1, 4]]);
    assert!((p - 3.0 / 21.0).abs() < 1e-14, "{p}");
    let p = fisher_exact_two_sided([[0, 2], [3, 2]]);
    assert!((p - 9.0 / 21.0).abs() < 1e-14, "{p}");
    // The most likely table: p = 1.
    assert!((fisher_exact_two_sided([[2, 2], [2, 2]]) - 1.0).abs() < 1e-14);
    // Wikipedia's "Fisher's exact test" example (men/women studying): p = 0.002759.
    let p = fisher_exact_two_sided([[1, 9], [11, 3]]);
    assert!((p - 0.002759).abs() < 5e-7, "{p}");
}

/// `C(n, k)` in exact integers.
fn choose(n: u64, k: u64) -> u128 {
    let mut c: u128 = 1;
    for i in 0..k {
        c = c * u128::from(n - i) / u128::from(i + 1);
    }
    c
}

#[test]
fn fisher_agrees_with_exact_integer_counting_on_every_small_table() {
    // The reference counts tables in integers (probabilities C(c,x)C(N−c,r−x) / C(N,r) share
    // the denominator, so "at most as likely" is an exact integer comparison, ties included).
    for a in 0..7u64 {
        for b in 0..7u64 {
            for c in 0..7u64 {
                for d in 0..7u64 {
                    let (row1, col1, n) = (a + b, a + c, a + b + c + d);
                    let weight = |x: u64| choose(col1, x) * choose(n - col1, row1 - x);
                    let lo = col1.saturating_sub(c + d);
                    let hi = col1.min(row1);
                    let observed = weight(a);
                    let tail: u128 = (lo..=hi).map(weight).filter(|&w| w <= observed).sum();
                    let exact = tail as f64 / choose(n, row1) as f64;
                    let p = fisher_exact_two_sided([[a, b], [c, d]]);
                    assert!(
                        (p - exact).abs() <= 1e-12 * exact.max(1e-300) + 1e-15,
                        "[[{a},{b}],[{c},{d}]]: {p} vs {exact}"
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------
// Identification

/// A practice row, then friction 3 of 4 correct and frictionless 1 of 4, the latter in a
/// resumed session 2, the rows out of trial order, a participant label that needs quoting.
const ID_TRIALS: &str = "\
\"P \"\"01\"\", left\",1,0,1,1,identification,convex-strong,friction,,,,,concave-strong,0,3.1,,0
\"P \"\"01\"\", left\",1,1,2,0,identification,convex-strong,friction,,,,,convex-strong,1,2.0,,10
\"P \"\"01\"\", left\",1,1,4,0,identification,straight,friction,,,,,straight,1,2.0,,30
\"P \"\"01\"\", left\",1,1,3,0,identification,convex-mild,friction,,,,,convex-mild,1,2.0,,20
\"P \"\"01\"\", left\",1,1,5,0,identification,concave-mild,friction,,,,,straight,0,2.0,,40
\"P \"\"01\"\", left\",2,2,6,0,identification,convex-strong,frictionless,,,,,convex-mild,0,2.0,,0
\"P \"\"01\"\", left\",2,2,7,0,identification,concave-strong,frictionless,,,,,concave-strong,1,2.0,,10
\"P \"\"01\"\", left\",2,2,8,0,identification,straight,frictionless,,,,,concave-mild,0,2.0,,20
\"P \"\"01\"\", left\",2,2,9,0,identification,straight,frictionless,,,,,convex-mild,0,2.0,\"a,b\",30
";

#[test]
fn identification_counts_the_confusion_matrix_by_hand() {
    let dir = write_run(
        "identification",
        &identification_plan(),
        &format!("{HEADER}\r\n{ID_TRIALS}"),
    );
    let summary = analyze(&dir, &AnalyzeOptions::default()).unwrap();
    assert_eq!(summary.trials, 8);
    assert_eq!(summary.practice_trials, 1);
    assert_eq!(summary.participants, vec!["P \"01\", left".to_owned()]);
    assert_eq!(summary.sessions, vec![1, 2]);
    let id = summary.identification.as_ref().unwrap();
    assert_eq!(id.stimuli, SHAPES);
    let (f, fl) = (&id.conditions[0], &id.conditions[1]);
    assert_eq!((f.name.as_str(), f.trials, f.correct), ("friction", 4, 3));
    assert_eq!(
        (fl.name.as_str(), fl.trials, fl.correct),
        ("frictionless", 4, 1)
    );
    assert_eq!(f.accuracy, Some(0.75));
    assert_eq!(fl.accuracy, Some(0.25));
    // Rows presented, columns answered, by hand from the rows above (the practice row, which
    // would add convex-strong → concave-strong, is left out).
    let friction = vec![
        vec![1, 0, 0, 0, 0],
        vec![0, 1, 0, 0, 0],
        vec![0, 0, 1, 0, 0],
        vec![0, 0, 1, 0, 0],
        vec![0, 0, 0, 0, 0],
    ];
    let frictionless = vec![
        vec![0, 1, 0, 0, 0],
        vec![0, 0, 0, 0, 0],
        vec![0, 1, 0, 1, 0],
        vec![0, 0, 0, 0, 0],
        vec![0, 0, 0, 0, 1],
    ];
    assert_eq!(f.confusion, friction);
    assert_eq!(fl.confusion, frictionless);
    let acc: Vec<Option<f64>> = fl.per_stimulus.iter().map(|s| s.accuracy).collect();
    assert_eq!(acc, vec![Some(0.0), None, Some(0.0), None, Some(1.0)]);
    assert_eq!(fl.per_stimulus[2].trials, 2);
    // 3/4 against 1/4 is the tea-tasting table: p = 34/70.
    let effect = id.condition_effect.as_ref().unwrap();
    assert!((effect.p_value - 34.0 / 70.0).abs() < 1e-12);
    assert_eq!(effect.accuracy, [Some(0.75), Some(0.25)]);
    // summary.json is written, and reads back with the documented fields.
    let json: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json["format"], "experiment-summary/1");
    assert_eq!(
        json["identification"]["conditions"][1]["confusion"][2][3],
        1
    );
    assert_eq!(
        json["identification"]["condition_effect"]["conditions"][1],
        "frictionless"
    );
    assert!(json.get("two_afc").is_none());
    let line = summary.to_string();
    assert!(
        line.contains("\"friction\": 3 correct of 4 (75.0 %)"),
        "{line}"
    );
    assert!(line.contains("p = 0.4857"), "{line}");
    std::fs::remove_dir_all(&dir).unwrap();
}

// ---------------------------------------------------------------------------------------
// 2AFC

/// A 2AFC row: correct as given; the response follows from it and the interval.
fn afc_row(
    design: &str,
    trial: u64,
    staircase: &str,
    level: f64,
    correct: bool,
    comparison_first: bool,
) -> String {
    let comparison = if comparison_first { 1 } else { 2 };
    // Above the reference the right answer is the comparison, below it the reference.
    let chose_comparison = if level >= 500.0 { correct } else { !correct };
    let response = if chose_comparison {
        comparison
    } else {
        3 - comparison
    };
    format!(
        "sim,1,1,{trial},0,{design},straight,scene,{staircase},{level:?},500.0,{comparison},{response},{},0,,0\n",
        u8::from(correct)
    )
}

/// A folded Weibull observer (the analysis's default model, written out here):
/// `ψ = ½ + (½ − λ)(1 − exp(−(d/α)^β))` of `d = |ln(x/r)|`, `r = 500`.
#[derive(Clone, Copy)]
struct FoldedWeibull {
    alpha: f64,
    beta: f64,
    lapse: f64,
}

impl FoldedWeibull {
    /// The observer whose 75 % point is the Weber fraction `w`: `F = ¼ / (½ − λ)` there, so
    /// `d₇₅ = α (−ln(1 − F))^{1/β}` with `d₇₅ = ln(1 + w)`.
    fn with_weber(w: f64, beta: f64, lapse: f64) -> Self {
        let f = 0.25 / (0.5 - lapse);
        let alpha = (1.0 + w).ln() / (-(1.0 - f).ln()).powf(1.0 / beta);
        Self { alpha, beta, lapse }
    }

    fn psi(&self, x: f64) -> f64 {
        let d = (x / 500.0).ln().abs();
        0.5 + (0.5 - self.lapse) * (1.0 - (-(d / self.alpha).powf(self.beta)).exp())
    }

    /// `∂ψ/∂(α, β, λ)` at `x`, with `t = (d/α)^β`: `∂ψ/∂α = −(½ − λ) e^{−t} t β/α`,
    /// `∂ψ/∂β = (½ − λ) e^{−t} t ln(d/α)`, `∂ψ/∂λ = −(1 − e^{−t})`.
    fn gradient(&self, x: f64) -> [f64; 3] {
        let d = (x / 500.0).ln().abs();
        if d == 0.0 {
            return [0.0; 3];
        }
        let t = (d / self.alpha).powf(self.beta);
        let e = (-t).exp();
        let a = 0.5 - self.lapse;
        [
            -a * e * t * self.beta / self.alpha,
            a * e * t * (d / self.alpha).ln(),
            -(1.0 - e),
        ]
    }

    /// `W = e^{d₇₅} − 1` and `∂W/∂(α, β, λ)`: with `F = ¼/(½ − λ)` and `q = −ln(1 − F)`,
    /// `d₇₅ = α q^{1/β}`, `∂d₇₅/∂α = d₇₅/α`, `∂d₇₅/∂β = −d₇₅ ln q / β²`,
    /// `∂d₇₅/∂λ = d₇₅ / (β q (1 − F)) · ¼/(½ − λ)²`; `∂W = e^{d₇₅} ∂d₇₅`.
    fn weber_and_gradient(&self) -> (f64, [f64; 3]) {
        let f = 0.25 / (0.5 - self.lapse);
        let q = -(1.0 - f).ln();
        let d75 = self.alpha * q.powf(1.0 / self.beta);
        let g = d75.exp();
        let dd = [
            d75 / self.alpha,
            -d75 * q.ln() / self.beta.powi(2),
            d75 / (self.beta * q * (1.0 - f)) * 0.25 / (0.5 - self.lapse).powi(2),
        ];
        (g - 1.0, dd.map(|x| g * x))
    }
}

/// The asymptotic standard error of the ML Weber fraction with `n` trials at each of
/// `levels`: the binomial variance `ψ(1 − ψ)/n` of every level's proportion, propagated by the
/// Fisher information `I = Σ n ∇ψ ∇ψᵀ / (ψ(1 − ψ))` over `(α, β, λ)` and the delta method.
fn weber_se(o: &FoldedWeibull, levels: &[f64], n: f64) -> f64 {
    let mut info = [[0.0; 3]; 3];
    for &x in levels {
        let psi = o.psi(x);
        let g = o.gradient(x);
        for i in 0..3 {
            for j in 0..3 {
                info[i][j] += n * g[i] * g[j] / (psi * (1.0 - psi));
            }
        }
    }
    let (_, grad) = o.weber_and_gradient();
    // grad · I⁻¹ · grad, with I⁻¹ by Gaussian elimination on [I | grad].
    let mut m = info;
    let mut v = grad;
    for k in 0..3 {
        for i in k + 1..3 {
            let r = m[i][k] / m[k][k];
            for j in k..3 {
                m[i][j] -= r * m[k][j];
            }
            v[i] -= r * v[k];
        }
    }
    let mut y = [0.0; 3];
    for i in (0..3).rev() {
        let s: f64 = (i + 1..3).map(|j| m[i][j] * y[j]).sum();
        y[i] = (v[i] - s) / m[i][i];
    }
    grad.iter().zip(&y).map(|(g, y)| g * y).sum::<f64>().sqrt()
}

/// Recovery against a known truth: trials drawn from a folded Weibull observer (the model
/// the analysis fits) with W = 0.2, written as `trials.csv`, come back from the analysis
/// within the binomial noise of their counts.
#[test]
fn constant_stimuli_recover_a_known_observers_weber_fraction() {
    let observer = FoldedWeibull::with_weber(0.2, 2.0, 0.04);
    let (w_true, _) = observer.weber_and_gradient();
    assert!((w_true - 0.2).abs() < 1e-12);
    assert!((observer.psi(600.0) - 0.75).abs() < 1e-12);
    // Comparisons on both sides of the reference; 400 and 312.5 fold exactly onto 625 and
    // 800 (500²/400, 500²/312.5), where they pool with the comparisons above. The reference
    // itself is answered at chance and carries no information.
    let presented = [
        500.0, 525.0, 550.0, 575.0, 600.0, 625.0, 650.0, 700.0, 800.0, 400.0, 312.5,
    ];
    let per_level = 300;
    let mut rng = Prng::new(2024);
    let mut text = format!("{HEADER}\n");
    let mut trial = 0;
    for _ in 0..per_level {
        for &x in &presented {
            trial += 1;
            let correct = rng.bernoulli(observer.psi(x));
            let first = rng.bernoulli(0.5);
            text.push_str(&afc_row("constant-stimuli", trial, "", x, correct, first));
        }
    }
    let dir = write_run("constant", &constant_plan(&presented), &text);
    let summary = analyze(&dir, &AnalyzeOptions::default()).unwrap();
    assert_eq!(summary.trials, trial as usize);
    let afc = summary.two_afc.as_ref().unwrap();
    assert_eq!(afc.model, "weibull");
    let cell = &afc.cells[0];
    let levels: Vec<f64> = cell.points.iter().map(|p| p.level).collect();
    assert_eq!(
        levels,
        vec![
            500.0, 525.0, 550.0, 575.0, 600.0, 625.0, 650.0, 700.0, 800.0
        ]
    );
    let counts: Vec<u32> = cell.points.iter().map(|p| p.trials).collect();
    assert_eq!(counts, vec![300, 300, 300, 300, 300, 600, 300, 300, 600]);
    let fit = cell.fit.as_ref().unwrap();
    // The analysis fits the observer's own family, so the ML Weber fraction is asymptotically
    // normal around the true one with the standard error of `weber_se`: the binomial noise of
    // 300 trials a level (600 where two levels fold together: those enter twice). 4 standard
    // errors: a deviation this large has probability 6·10⁻⁵ under that normal law.
    let info_levels: Vec<f64> = cell
        .points
        .iter()
        .flat_map(|p| std::iter::repeat_n(p.level, (p.trials / per_level) as usize))
        .collect();
    let se_weber = weber_se(&observer, &info_levels, f64::from(per_level));
    eprintln!(
        "weber {} (true 0.2, se {se_weber}), ci {:?}, lapse {}",
        fit.weber_75, fit.ci95_weber, fit.lapse
    );
    assert!(
        (fit.weber_75 - 0.2).abs() < 4.0 * se_weber,
        "weber {} vs 0.2 ± 4 × {se_weber}",
        fit.weber_75
    );
    assert!(
        se_weber < 0.01,
        "the design pins the threshold: se {se_weber}"
    );
    let [lo, hi] = fit.ci95_weber.unwrap();
    assert!(
        0.0 < lo && lo < fit.weber_75 && fit.weber_75 < hi,
        "[{lo}, {hi}]"
    );
    // 3,300 trials: the posterior is nearly normal around the estimate (Bernstein–von Mises),
    // its 95 % half-width 1.96 standard errors. Its width follows the sample's own
    // information (the lapse rate it finds, bounded at 0.1, moves it most), not the expected
    // information above: over seeds 1–8 of this design the ratio ran from 0.91 to 1.10, and
    // 2024 gives 1.05. Bounds a fifth either side of 1.
    let ratio = 0.5 * (hi - lo) / (1.96 * se_weber);
    assert!(
        (0.8..1.25).contains(&ratio),
        "half-width {} against 1.96 se {}",
        0.5 * (hi - lo),
        1.96 * se_weber
    );
    assert!(cell.staircases.is_empty());
    let line = summary.to_string();
    assert!(line.contains("Weber fraction at 75 %"), "{line}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn staircase_tracks_and_reversals_read_by_hand() {
    // "from above": 800 800 700 700 800 800 700 700 600 700: down after trial 2, up after 4
    // (reversal at 700), down after 6 (reversal at 800), down after 8, up after 9 (reversal
    // at 600). Interleaved with "from below" (trials 3, 6, 9, …).
    let above = [
        (800.0, true),
        (800.0, true),
        (700.0, true),
        (700.0, false),
        (800.0, true),
        (800.0, true),
        (700.0, true),
        (700.0, true),
        (600.0, false),
        (700.0, true),
    ];
    let below = [(300.0, true), (300.0, true), (375.0, false), (300.0, true)];
    let mut text = format!("{HEADER}\n");
    text.push_str(
        "sim,1,0,100,1,2afc-staircase,straight,scene,from above,900.0,500.0,1,1,1,0,,0\n",
    );
    let mut trial = 0;
    let (mut a, mut b) = (above.iter(), below.iter());
    let mut above_trials = Vec::new();
    loop {
        trial += 1;
        let next = if trial % 3 == 0 {
            b.next().map(|x| ("from below", x))
        } else {
            a.next().map(|x| ("from above", x))
        };
        let Some((name, &(level, correct))) = next else {
            break;
        };
        if name == "from above" {
            above_trials.push(trial);
        }
        text.push_str(&afc_row(
            "2afc-staircase",
            trial,
            name,
            level,
            correct,
            trial % 2 == 0,
        ));
    }
    let dir = write_run("staircase", &staircase_plan(), &text);
    let summary = summarize(&dir, &AnalyzeOptions::default()).unwrap();
    assert_eq!(summary.practice_trials, 1);
    let cell = &summary.two_afc.as_ref().unwrap().cells[0];
    let stairs = &cell.staircases;
    assert_eq!(stairs.len(), 2);
    assert_eq!(stairs[0].name, "from above");
    let levels: Vec<f64> = stairs[0].track.iter().map(|t| t.level).collect();
    assert_eq!(levels, above.iter().map(|x| x.0).collect::<Vec<_>>());
    let rev: Vec<(u64, f64)> = stairs[0]
        .reversals
        .iter()
        .map(|r| (r.trial, r.level))
        .collect();
    assert_eq!(
        rev,
        vec![
            (above_trials[3], 700.0),
            (above_trials[5], 800.0),
            (above_trials[8], 600.0)
        ]
    );
    // "from below": 300 300 375 300: up after its 2nd trial, down after its 3rd (reversal at
    // 375, its trial 9).
    let rev: Vec<(u64, f64)> = stairs[1]
        .reversals
        .iter()
        .map(|r| (r.trial, r.level))
        .collect();
    assert_eq!(rev, vec![(9, 375.0)]);
    // Folded: 300 → 833.33…, 375 → 666.66…; pooled with nothing else.
    assert!(
        cell.points
            .iter()
            .any(|p| p.level == 250_000.0 / 300.0 && p.trials == 3)
    );
    assert!(
        !dir.join("summary.json").exists(),
        "summarize writes nothing"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// One definition of a reversal, read the same by the runner's summary and the analysis: a
/// session of two staircases answered by hand through [`Session`] (the runner's and the
/// app's path), then [`staircase_summaries`] of it and the analysis of its folder.
///
/// "from above", 2-down/1-up, ±100 within [600, 1000], starting on its upper bound, stopping
/// at 3 reversals; its trials (level, answer) and what each answer does:
///
/// ```text
///  1 1000 ✗  up, but 1000 is the bound: no move, no direction
///  2 1000 ✓
///  3 1000 ✓  down to 900: the first move, nothing to reverse
///  4  900 ✓
///  5  900 ✓  down to 800
///  6  800 ✗  up to 900: reversal 1, at 800
///  7  900 ✓
///  8  900 ✓  down to 800: reversal 2, at 900
///  9  800 ✓
/// 10  800 ✓  down to 700
/// 11  700 ✓
/// 12  700 ✓  down to 600
/// 13  600 ✓
/// 14  600 ✓  down, but 600 is the bound: no move
/// 15  600 ✗  up to 700: reversal 3, at 600; the stopping rule is met, 700 never presented
/// ```
///
/// "from below", ×1.25 within [200, 400] below the reference 500 (run mirrored: harder is
/// higher), stopping at 2 reversals: 300 ✓, 300 ✓ up to 375 (the first move); 375 ✗ down to
/// 300 (reversal 1, at 375); 300 ✗ down to 240; 240 ✓, 240 ✓ up to 300 (reversal 2, at 240,
/// its last trial).
///
/// Before this definition the staircase counted the clamped "up" of trial 1 as a direction,
/// so trial 3 was a reversal (at 1000) and "from above" stopped after 8 trials; and the
/// analysis, reading the reversals from the levels presented, could not see the last move
/// and listed one reversal fewer than the run (11 of the shipped plan's 12).
#[test]
fn the_runner_and_the_analysis_list_the_same_reversals_of_a_hand_answered_session() {
    let mut plan = staircase_plan();
    plan["staircases"] = json!([
        { "name": "from above", "start": 1000.0, "step": { "size": 100.0 },
          "stop": { "reversals": 3 }, "bounds": [600.0, 1000.0] },
        { "name": "from below", "start": 300.0, "step": { "size": 1.25, "kind": "multiplicative" },
          "stop": { "reversals": 2 }, "bounds": [200.0, 400.0] }
    ]);
    let above = [
        (1000.0, false),
        (1000.0, true),
        (1000.0, true),
        (900.0, true),
        (900.0, true),
        (800.0, false),
        (900.0, true),
        (900.0, true),
        (800.0, true),
        (800.0, true),
        (700.0, true),
        (700.0, true),
        (600.0, true),
        (600.0, true),
        (600.0, false),
    ];
    let below = [
        (300.0, true),
        (300.0, true),
        (375.0, false),
        (300.0, false),
        (240.0, true),
        (240.0, true),
    ];
    let expected: [&[(usize, f64)]; 2] = [
        &[(6, 800.0), (8, 900.0), (15, 600.0)],
        &[(3, 375.0), (6, 240.0)],
    ];
    let dir = temp_dir("reversals-by-hand");
    let plan_path = dir.join("plan-by-hand.json");
    std::fs::write(&plan_path, plan.to_string()).unwrap();
    let run_dir = dir.join("run");
    let mut session = Session::open(Plan::load(&plan_path).unwrap(), "P01", &run_dir).unwrap();
    let answers: [&[(f64, bool)]; 2] = [&above, &below];
    let mut next = [0, 0];
    // The session's trial numbers of each staircase's trials.
    let mut numbers: [Vec<u64>; 2] = [Vec::new(), Vec::new()];
    while let Some(trial) = session.next_trial().unwrap() {
        let k = trial.staircase.unwrap();
        let (level, correct) = answers[k][next[k]];
        next[k] += 1;
        // The mirrored staircase's levels are r²/(r²/x · 1.25ᵏ): 375 within rounding.
        let presented = trial.level.unwrap();
        assert!(
            (presented - level).abs() < 1e-9 * level,
            "staircase {k}, its trial {}: {presented}",
            next[k]
        );
        numbers[k].push(trial.number as u64);
        // The comparison is the right answer at or above the reference, the reference below.
        let chose_comparison = (level >= 500.0) == correct;
        let first = trial.comparison_first.unwrap();
        let interval = if chose_comparison == first { 1 } else { 2 };
        let right = session
            .respond(Response::Interval(interval), &TrialRecord::default())
            .unwrap();
        assert_eq!(right, correct);
    }
    assert_eq!(
        next,
        [above.len(), below.len()],
        "every answer given, no more"
    );

    let runner = staircase_summaries(&session);
    let analysis = summarize(&run_dir, &AnalyzeOptions::default()).unwrap();
    let tracks = &analysis.two_afc.as_ref().unwrap().cells[0].staircases;
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9 * y)
    };
    for k in 0..2 {
        let levels: Vec<f64> = expected[k].iter().map(|&(_, level)| level).collect();
        assert!(runner[k].finished, "{:?}", runner[k]);
        assert!(
            same(&runner[k].reversal_levels, &levels),
            "runner, {}: {:?}",
            runner[k].name,
            runner[k].reversal_levels
        );
        let listed = &tracks[k].reversals;
        let trials: Vec<u64> = listed.iter().map(|r| r.trial).collect();
        let by_hand: Vec<u64> = expected[k]
            .iter()
            .map(|&(i, _)| numbers[k][i - 1])
            .collect();
        assert_eq!(trials, by_hand, "analysis, {}", tracks[k].name);
        let listed: Vec<f64> = listed.iter().map(|r| r.level).collect();
        assert!(
            same(&listed, &levels),
            "analysis, {}: {listed:?}",
            tracks[k].name
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

// ---------------------------------------------------------------------------------------
// Bad input

fn expect_error(name: &str, plan: &Value, trials: &str) -> String {
    let dir = write_run(name, plan, trials);
    let e = analyze(&dir, &AnalyzeOptions::default()).unwrap_err();
    assert!(e.is_bad_input());
    assert!(!dir.join("summary.json").exists());
    std::fs::remove_dir_all(&dir).unwrap();
    error_text(&e)
}

const GOOD_ID_ROW: &str = "P,1,1,1,0,identification,straight,friction,,,,,straight,1,2.0,,0\n";

#[test]
fn bad_inputs_are_refused_naming_the_line_and_column() {
    let plan = identification_plan();
    let e = expect_error("empty", &plan, "");
    assert!(e.contains("trials.csv:1:") && e.contains("empty"), "{e}");
    // The runner's old header, without `practice`.
    let old = "participant,session,block,trial,design,stimulus,condition,staircase,level,\
reference,comparison_interval,response,correct,response_time_s,trace,t_start_s\n";
    let e = expect_error("old-header", &plan, &format!("{old}{GOOD_ID_ROW}"));
    assert!(
        e.contains("trials.csv:1: column 5: the header has \"design\", expected \"practice\""),
        "{e}"
    );
    let ok = format!("{HEADER}\n{GOOD_ID_ROW}");
    let e = expect_error(
        "unknown-stimulus",
        &plan,
        &format!("{ok}P,1,1,2,0,identification,wavy,friction,,,,,straight,0,2.0,,0\n"),
    );
    assert!(
        e.contains("trials.csv:3: column 7 (stimulus): \"wavy\" is not a stimulus of the plan"),
        "{e}"
    );
    let e = expect_error(
        "unknown-answer",
        &plan,
        &format!("{ok}P,1,1,2,0,identification,straight,friction,,,,,flat,0,2.0,,0\n"),
    );
    assert!(
        e.contains("trials.csv:3: column 13 (response): \"flat\""),
        "{e}"
    );
    let e = expect_error(
        "duplicate",
        &plan,
        &format!("{ok}P,2,1,1,0,identification,straight,friction,,,,,straight,1,2.0,,0\n"),
    );
    assert!(
        e.contains("trials.csv:3: column 4 (trial): trial 1 appears again (first on line 2)"),
        "{e}"
    );
    let e = expect_error(
        "design",
        &plan,
        &format!("{HEADER}\nP,1,1,1,0,constant-stimuli,straight,friction,,,,,straight,1,2.0,,0\n"),
    );
    assert!(
        e.contains("trials.csv:2: column 6 (design): \"constant-stimuli\" does not match the plan's design \"identification\""),
        "{e}"
    );
    let e = expect_error(
        "fields",
        &plan,
        &format!("{ok}P,1,1,2,0,identification,straight\n"),
    );
    assert!(
        e.contains("trials.csv:3: 7 fields, the header has 17"),
        "{e}"
    );
    let e = expect_error(
        "quote",
        &plan,
        &format!("{ok}\"P,1,1,2,0,identification,straight\n"),
    );
    assert!(
        e.contains("trials.csv:3: column 1 (participant): a quoted field is not closed"),
        "{e}"
    );
    let e = expect_error(
        "correct",
        &plan,
        &format!("{ok}P,1,1,2,0,identification,straight,friction,,,,,straight,0,2.0,,0\n"),
    );
    assert!(e.contains("trials.csv:3: column 14 (correct)"), "{e}");
    let e = expect_error(
        "practice-only",
        &plan,
        &format!("{HEADER}\nP,1,0,1,1,identification,straight,friction,,,,,straight,1,2.0,,0\n"),
    );
    assert!(e.contains("no trials to analyse"), "{e}");

    let afc = constant_plan(&[550.0, 600.0]);
    let e = expect_error(
        "level",
        &afc,
        &format!("{HEADER}\nsim,1,1,1,0,constant-stimuli,straight,scene,,55O,500.0,1,1,1,0,,0\n"),
    );
    assert!(
        e.contains("trials.csv:2: column 10 (level): \"55O\" is not a finite number"),
        "{e}"
    );
    let e = expect_error(
        "reference",
        &afc,
        &format!("{HEADER}\nsim,1,1,1,0,constant-stimuli,straight,scene,,550,400,1,1,1,0,,0\n"),
    );
    assert!(
        e.contains("column 11 (reference): 400 is not the plan's reference value 500"),
        "{e}"
    );
    let e = expect_error(
        "interval",
        &afc,
        &format!("{HEADER}\nsim,1,1,1,0,constant-stimuli,straight,scene,,550,500,3,1,1,0,,0\n"),
    );
    assert!(e.contains("column 12 (comparison_interval)"), "{e}");
    // Level above the reference, the reference chosen (interval 2 while the comparison was
    // in 1): wrong, yet marked correct.
    let e = expect_error(
        "afc-correct",
        &afc,
        &format!("{HEADER}\nsim,1,1,1,0,constant-stimuli,straight,scene,,550,500,1,2,1,0,,0\n"),
    );
    assert!(e.contains("trials.csv:2: column 14 (correct)"), "{e}");
    let e = expect_error(
        "staircase-name",
        &staircase_plan(),
        &format!(
            "{HEADER}\nsim,1,1,1,0,2afc-staircase,straight,scene,sideways,550,500,1,1,1,0,,0\n"
        ),
    );
    assert!(
        e.contains("column 9 (staircase): \"sideways\" is not a staircase"),
        "{e}"
    );
    // A track that is not the plan's staircase: "from above" starts at 800 and stays there
    // after one right answer.
    let e = expect_error(
        "staircase-track",
        &staircase_plan(),
        &format!(
            "{HEADER}\n{}{}",
            afc_row("2afc-staircase", 1, "from above", 800.0, true, true),
            afc_row("2afc-staircase", 2, "from above", 700.0, true, true)
        ),
    );
    assert!(
        e.contains("trials.csv:3: column 10 (level): 700.0 is not the level staircase \"from above\" gives at its trial 2 (800.0)"),
        "{e}"
    );
    // Another model than a folded one is refused.
    let dir = write_run(
        "unfolded",
        &staircase_plan(),
        &format!(
            "{HEADER}\n{}",
            afc_row("2afc-staircase", 1, "from above", 800.0, true, true)
        ),
    );
    let options = AnalyzeOptions {
        model: Model::LogGaussian,
    };
    let e = summarize(&dir, &options).unwrap_err();
    assert!(e.to_string().contains("not a folded one"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
    // A missing plan names plan.json.
    let dir = temp_dir("no-plan");
    std::fs::write(dir.join("trials.csv"), &ok).unwrap();
    let e = summarize(&dir, &AnalyzeOptions::default()).unwrap_err();
    assert!(e.to_string().contains("plan.json"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_documented_columns_are_the_header() {
    assert_eq!(TRIALS_COLUMNS.join(","), HEADER);
    let _: fn(&Path, &AnalyzeOptions) -> Result<Summary, AnalyzeError> = analyze;
}
