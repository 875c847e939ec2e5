//! Levitt staircases: convergence to their target proportion correct with a simulated
//! observer, the track's bookkeeping, bounds, step reduction, stopping and interleaving.

use experiment::fit::{Observer, Prng};
use experiment::staircase::{Interleaved, Staircase, StaircaseConfig, StaircaseError, Step, Stop};

/// The level where the observer's ψ equals `p`, by bisection on its ψ (independent of the
/// crate's quantile function).
fn level_at(o: &Observer, p: f64) -> f64 {
    let (mut lo, mut hi) = (o.reference, o.reference * 3.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if o.psi(mid) < p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

fn config(n_down: u32) -> StaircaseConfig {
    StaircaseConfig {
        start: 1.5,
        n_down,
        n_up: 1,
        step: Step::Additive(0.05),
        reduced_step: Some((4, Step::Additive(0.02))),
        min: 1.0,
        max: 2.0,
        stop: Stop {
            reversals: Some(40),
            trials: None,
        },
    }
}

/// Runs `runs` staircases against the observer; the mean and sd of their estimates: the mean
/// of the last 20 of 40 reversals. The first 4 reversals use the large step, and the
/// small-step walk that follows needs further reversals to forget its start above the target:
/// averaged over 2000 runs, the valley levels kept falling until about the 20th reversal and
/// were flat after it, so the first 20 are left out. An even count holds as many peaks as
/// valleys.
fn run_many(n_down: u32, o: &Observer, runs: u64) -> (f64, f64) {
    let estimates: Vec<f64> = (0..runs)
        .map(|seed| {
            let mut rng = Prng::new(seed);
            let mut s = Staircase::new(config(n_down)).expect("valid config");
            while !s.is_finished() {
                let x = s.level();
                assert!((1.0..=2.0).contains(&x));
                s.respond(o.respond(x, &mut rng)).expect("not finished");
            }
            s.threshold(20).expect("40 reversals")
        })
        .collect();
    let n = estimates.len() as f64;
    let mean = estimates.iter().sum::<f64>() / n;
    let sd = (estimates.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    (mean, sd)
}

/// (c) n-down/1-up converges to ψ = 0.5^(1/n): 70.7 % for 2-down, 79.4 % for 3-down.
///
/// Tolerance: the mean of 400 runs has a standard error sd/√400, allowed 4 times (6e-5 to
/// fail by chance); on top, half the final step (0.01): after the reduction the levels lie on
/// a grid of spacing 0.02 and the target generally falls between two grid levels, so a
/// procedure confined to the grid can be off by that much even with unlimited trials
/// (Levitt's convergence is exact only in the limit of small steps). The final step is a
/// fifth of the observer's σ, small enough for the 2AFC bias of up/down rules
/// (García-Pérez 1998) to stay inside that allowance.
#[test]
fn transformed_up_down_converges_to_its_target() {
    let o = Observer {
        weber: 0.2,
        reference: 1.0,
        sigma: 0.1,
        lapse: 0.0,
    };
    let runs = 400;
    for n_down in [2, 3] {
        let p = 0.5f64.powf(1.0 / f64::from(n_down));
        let target = level_at(&o, p);
        let (mean, sd) = run_many(n_down, &o, runs);
        let tol = 4.0 * sd / (runs as f64).sqrt() + 0.01;
        println!(
            "{n_down}-down/1-up: target ψ = {p:.4} at {target:.4}; mean estimate {mean:.4} (ψ = {:.4}), sd {sd:.4}, offset {:.4}, tolerance {tol:.4}",
            o.psi(mean),
            mean - target
        );
        assert!((mean - target).abs() < tol);
    }
}

/// A hand-worked 2-down/1-up track with multiplicative steps, a step reduction after the
/// second reversal, and the upper bound.
#[test]
fn track_bookkeeping_by_hand() {
    let mut s = Staircase::new(StaircaseConfig {
        start: 4.0,
        n_down: 2,
        n_up: 1,
        step: Step::Multiplicative(2.0),
        reduced_step: Some((2, Step::Multiplicative(1.25))),
        min: 0.5,
        max: 8.0,
        stop: Stop {
            reversals: None,
            trials: Some(8),
        },
    })
    .expect("valid config");
    // Responses and the levels they were given at, worked by hand:
    // 4 ✓, 4 ✓ → down to 2; 2 ✗ → up to 4 (reversal 1, at 2); 4 ✗ → 8;
    // 8 ✓, 8 ✓ → down (reversal 2, at 8), step now ×1.25: 6.4; 6.4 ✗ → up (reversal 3): 8;
    // 8 ✗ → 10 clamped to 8.
    let responses = [true, true, false, false, true, true, false, false];
    for &r in &responses {
        s.respond(r).expect("not finished");
    }
    let levels: Vec<f64> = s.track().iter().map(|t| t.level).collect();
    assert_eq!(levels, [4.0, 4.0, 2.0, 4.0, 8.0, 8.0, 6.4, 8.0]);
    let reversals: Vec<bool> = s.track().iter().map(|t| t.reversal).collect();
    assert_eq!(
        reversals,
        [false, false, true, false, false, true, true, false]
    );
    assert_eq!(s.reversal_levels(), &[2.0, 8.0, 6.4]);
    assert_eq!(s.level(), 8.0);
    assert!(s.is_finished());
    assert_eq!(s.respond(true), Err(StaircaseError::Finished));
    assert!((s.threshold(2).expect("reversals") - 7.2).abs() < 1e-12);
    assert!((s.threshold(10).expect("reversals") - 16.4 / 3.0).abs() < 1e-12);
    assert_eq!(s.threshold(0), None);
}

/// A reversal is a change of direction of the level (module docs): a step clamped at the
/// bound the level is on is no move and sets no direction, and the first move reverses
/// nothing. Started on its upper bound, 2-down/1-up, ×2 within [1, 8]:
/// 8 ✗ (up, clamped: no move); 8 ✓, 8 ✓ → 4 (first move, down); 4 ✗ → 8 (reversal 1, at 4);
/// 8 ✗ (clamped: no move); 8 ✓, 8 ✓ → 4 (reversal 2, at 8); 4 ✓, 4 ✓ → 2; 2 ✓, 2 ✓ → 1;
/// 1 ✓, 1 ✓ (down, clamped: no move); 1 ✗ → 2 (reversal 3, at 1, the last trial).
#[test]
fn clamped_steps_are_no_moves_and_the_last_answer_can_reverse() {
    let mut s = Staircase::new(StaircaseConfig {
        start: 8.0,
        n_down: 2,
        n_up: 1,
        step: Step::Multiplicative(2.0),
        reduced_step: None,
        min: 1.0,
        max: 8.0,
        stop: Stop {
            reversals: Some(3),
            trials: None,
        },
    })
    .expect("valid config");
    let responses = [
        false, true, true, false, false, true, true, true, true, true, true, true, true, false,
    ];
    for &r in &responses {
        s.respond(r).expect("not finished");
    }
    let levels: Vec<f64> = s.track().iter().map(|t| t.level).collect();
    assert_eq!(
        levels,
        [
            8.0, 8.0, 8.0, 4.0, 8.0, 8.0, 8.0, 4.0, 4.0, 2.0, 2.0, 1.0, 1.0, 1.0
        ]
    );
    let reversals: Vec<usize> = (0..levels.len())
        .filter(|&i| s.track()[i].reversal)
        .collect();
    assert_eq!(reversals, [3, 6, 13]);
    assert_eq!(s.reversal_levels(), &[4.0, 8.0, 1.0]);
    assert!(s.is_finished());
    assert_eq!(s.level(), 2.0);
}

#[test]
fn configuration_errors() {
    let good = config(2);
    assert!(matches!(
        Staircase::new(StaircaseConfig { n_down: 0, ..good }),
        Err(StaircaseError::BadRule { .. })
    ));
    assert!(matches!(
        Staircase::new(StaircaseConfig {
            step: Step::Additive(0.0),
            ..good
        }),
        Err(StaircaseError::BadStep(_))
    ));
    assert!(matches!(
        Staircase::new(StaircaseConfig {
            step: Step::Multiplicative(0.9),
            ..good
        }),
        Err(StaircaseError::BadStep(_))
    ));
    assert!(matches!(
        Staircase::new(StaircaseConfig { start: 3.0, ..good }),
        Err(StaircaseError::BadBounds { .. })
    ));
    assert!(matches!(
        Staircase::new(StaircaseConfig {
            min: 0.0,
            step: Step::Multiplicative(2.0),
            ..good
        }),
        Err(StaircaseError::NonPositiveLevels(_))
    ));
    assert_eq!(
        Staircase::new(StaircaseConfig {
            stop: Stop {
                reversals: None,
                trials: None
            },
            ..good
        }),
        Err(StaircaseError::NoStop)
    );
}

/// Interleaving: every trial goes to an unfinished staircase, each staircase's track is what
/// it would have been run alone on the same responses, the choice is reproducible from the
/// seed and both staircases get trials early on.
#[test]
fn interleaving_is_seeded_and_runs_every_staircase_to_its_end() {
    let o = Observer {
        weber: 0.2,
        reference: 1.0,
        sigma: 0.1,
        lapse: 0.0,
    };
    let run = |seed: u64| {
        let a = Staircase::new(config(2)).expect("valid config");
        let b = Staircase::new(StaircaseConfig {
            start: 1.1,
            stop: Stop {
                reversals: None,
                trials: Some(30),
            },
            ..config(3)
        })
        .expect("valid config");
        let mut il = Interleaved::new(vec![a, b], seed);
        let mut rng = Prng::new(77);
        let mut order = Vec::new();
        assert_eq!(il.respond(true), Err(StaircaseError::NoPendingTrial));
        while let Some((i, x)) = il.next_trial() {
            assert_eq!(il.next_trial(), Some((i, x)));
            assert!(!il.stairs()[i].is_finished());
            order.push(i);
            il.respond(o.respond(x, &mut rng)).expect("pending");
        }
        assert!(il.is_finished());
        (order, il)
    };
    let (order, il) = run(5);
    let (again, _) = run(5);
    assert_eq!(order, again);
    let (other, _) = run(6);
    assert_ne!(order, other);
    assert_eq!(il.stairs()[1].track().len(), 30);
    assert_eq!(order.iter().filter(|&&i| i == 1).count(), 30);
    assert!(order[..10].contains(&0) && order[..10].contains(&1));
    // Replaying each staircase alone on its own responses gives the same track.
    for s in il.stairs() {
        let mut alone = Staircase::new(*s.config()).expect("valid config");
        for t in s.track() {
            alone.respond(t.correct).expect("not finished");
        }
        assert_eq!(alone.track(), s.track());
    }
}
