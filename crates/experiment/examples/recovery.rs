//! How well a run recovers a participant's Weber fraction: runs a 2AFC plan with simulated
//! participants of a known W (seeds 1..=N) through the haptic loop, analyses each run as
//! `viewer experiment analyze` does (the folded Weibull with a lapse, the credible interval), and
//! reports the bias of the fitted `weber_75` and the coverage of its 95 % interval.
//!
//! ```text
//! cargo run --release -p experiment --example recovery -- [RUNS] [W] [PLAN] [MODEL]
//! ```
//! Defaults: 100 runs, W = 0.2, `experiments/stiffness-jnd.json`, `weibull`.

use std::path::PathBuf;

use experiment::analyze::{AnalyzeOptions, summarize};
use experiment::plan::Plan;
use experiment::runner::run;
use experiment::sim_participant::SimParticipant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let runs: u64 = args.first().map_or(Ok(100), |a| a.parse())?;
    let weber: f64 = args.get(1).map_or(Ok(0.2), |a| a.parse())?;
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    let plan_path = args.get(2).map_or_else(
        || root.join("experiments/stiffness-jnd.json"),
        PathBuf::from,
    );
    let plan = Plan::load(&plan_path)?;
    let model = match args.get(3).map(String::as_str) {
        None => AnalyzeOptions::default().model,
        Some(name) => experiment::analyze::parse_model(name).ok_or("model")?,
    };
    let options = AnalyzeOptions { model };
    let (mut estimates, mut covered, mut intervals, mut trials) = (Vec::new(), 0, 0, 0);
    for seed in 1..=runs {
        let participant =
            SimParticipant::parse(&format!("sim:{seed}:weber={weber}")).ok_or("participant")??;
        let dir = std::env::temp_dir().join(format!("recovery-{}-{seed}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let summary = run(&plan, &participant, &dir)?;
        trials += summary.trials;
        let analysis = summarize(&dir, &options)?;
        std::fs::remove_dir_all(&dir)?;
        let cell = analysis
            .two_afc
            .as_ref()
            .and_then(|t| t.cells.first())
            .ok_or("no 2AFC cell")?;
        let Some(fit) = &cell.fit else {
            println!("seed {seed}: no fit ({:?})", cell.fit_error);
            continue;
        };
        estimates.push(fit.weber_75);
        if let Some([lo, hi]) = fit.ci95_weber {
            intervals += 1;
            if lo <= weber && weber <= hi {
                covered += 1;
            }
        }
        println!(
            "seed {seed}: {} trials, weber_75 {:.4}, ci95 {:?}",
            summary.trials, fit.weber_75, fit.ci95_weber
        );
    }
    let n = estimates.len() as f64;
    let mean = estimates.iter().sum::<f64>() / n;
    let sd = (estimates.iter().map(|w| (w - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let mut sorted = estimates.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let coverage = covered as f64 / intervals as f64;
    let se_cov = (coverage * (1.0 - coverage) / intervals as f64).sqrt();
    println!(
        "\n{} runs of {} ({} trials in all), true W = {weber}: fitted weber_75 mean {mean:.4} \
         (bias {:+.4}, {:+.1} %), median {median:.4}, SD {sd:.4}, SE of the mean {:.4}; \
         95 % intervals cover W in {covered} of {intervals} runs ({:.1} % ± {:.1} %)",
        estimates.len(),
        plan_path.display(),
        trials,
        mean - weber,
        100.0 * (mean - weber) / weber,
        sd / n.sqrt(),
        100.0 * coverage,
        100.0 * se_cov
    );
    Ok(())
}
