//! The Stribeck effect the stick–slip renderer actually produces: how long μ takes to fall from
//! μ_s to μ_d after breakaway against the hand's speed, and μ over time after breakaway,
//! measured by sliding a HIP over a flat floor at a range of hand speeds, and its plot
//! (`docs/figures/stribeck.png`, written by `cargo run -p viewer --example stribeck`).

use std::path::Path;

use friction::{FrictionMaterial, FrictionRenderer, Mode};
use nurbs::{Vec2, construct};
use plotters::prelude::*;
use tracker::Chain;

use crate::plot::PlotError;

/// One slide: the hand's speed and, for every tick from breakaway on, the time since
/// breakaway (s), the slip speed (m/s) and μ.
#[derive(Clone, Debug, PartialEq)]
pub struct Slide {
    /// The hand's speed along the floor (m/s).
    pub hand_speed_m_per_s: f32,
    /// `(t since breakaway, slip speed, μ)`, one per tick while not stuck.
    pub samples: Vec<(f32, f32, f32)>,
    /// Time from breakaway to slip (s), if the slide got there.
    pub transition_s: Option<f32>,
}

/// Presses 2 mm into a flat floor and slides along it at each of `speeds` (m/s) for 0.8 s
/// after breakaway, at 1 kHz, with `material`.
pub fn sweep(material: FrictionMaterial, speeds: &[f32]) -> Vec<Slide> {
    let t = 1e-3f32;
    let Ok(floor) = construct::line(Vec2::new(0.2, 0.08), Vec2::new(-0.2, 0.08)) else {
        return Vec::new();
    };
    let views = [floor.view()];
    let Ok(chain) = Chain::new(&views) else {
        return Vec::new();
    };
    speeds
        .iter()
        .map(|&v| {
            let press = (0..100).map(|k| Vec2::new(0.0, 0.085 - 0.007 * k as f32 / 100.0));
            // Breakaway needs μ_s × 2 mm of slide; then 0.8 s more.
            let slide_ticks = (material.mu_static * 0.002 / (v * t)) as usize + 800;
            let slide = (0..slide_ticks).map(|k| Vec2::new(v * t * k as f32, 0.078));
            let mut r = FrictionRenderer::new(&chain, material, Vec2::new(0.0, 0.085));
            let mut prev = Vec2::new(0.0, 0.085);
            let mut breakaway: Option<usize> = None;
            let mut samples = Vec::new();
            let mut transition_s = None;
            for (k, x) in press.chain(slide).enumerate() {
                let o = r.tick(&chain, x, (x - prev) / t, t);
                prev = x;
                if breakaway.is_none() && o.mode == Mode::Transition {
                    breakaway = Some(k);
                }
                if let Some(b) =
                    breakaway.filter(|_| transition_s.is_none() && o.mode == Mode::Slip)
                {
                    transition_s = Some((k - b) as f32 * t);
                }
                if let Some(b) = breakaway.filter(|_| o.mode != Mode::Stuck) {
                    samples.push(((k - b) as f32 * t, o.slip_speed_m_per_s, o.mu));
                }
            }
            Slide {
                hand_speed_m_per_s: v,
                samples,
                transition_s,
            }
        })
        .collect()
}

/// Writes the sweep as a PNG: the transition's duration against the hand's speed (left) over
/// the material's `τ · max(1, v_s / v)`, and μ against time since breakaway (right).
pub fn write_png(
    path: impl AsRef<Path>,
    material: &FrictionMaterial,
    slides: &[Slide],
) -> Result<(), PlotError> {
    let path = path.as_ref();
    crate::plot::load_font()?;
    let draw_error = |e: &dyn std::fmt::Display| PlotError::Draw {
        path: path.to_owned(),
        message: e.to_string(),
    };
    let root = BitMapBackend::new(path, (1400, 600)).into_drawing_area();
    draw(&root, material, slides).map_err(|e| draw_error(&e))?;
    root.present().map_err(|e| draw_error(&e))?;
    Ok(())
}

type DrawResult<T> = Result<T, Box<dyn std::error::Error>>;

type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn legend<'a>(chart: &mut Chart<'a, 'a>) -> DrawResult<()> {
    chart
        .configure_series_labels()
        .label_font((crate::plot::FONT, 14))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

fn draw(
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
    m: &FrictionMaterial,
    slides: &[Slide],
) -> DrawResult<()> {
    let font = crate::plot::FONT;
    root.fill(&WHITE)?;
    let title = format!(
        "stick-slip transition: \u{3bc}s = {}, \u{3bc}d = {}, Stribeck speed {} mm/s, memory \u{3c4} = {} ms, depth 2 mm",
        m.mu_static,
        m.mu_dynamic,
        m.stribeck_speed_m_per_s * 1e3,
        m.transition_time_s * 1e3
    );
    let root = root.titled(&title, (font, 20))?;
    let (left, right) = root.split_horizontally(700);
    let v_max = slides
        .iter()
        .map(|s| f64::from(s.hand_speed_m_per_s) * 1e3)
        .fold(2.0 * f64::from(m.stribeck_speed_m_per_s) * 1e3, f64::max);
    let mu_range = f64::from(m.mu_dynamic) - 0.02..f64::from(m.mu_static) + 0.02;
    let colour = |i: usize| Palette99::pick(i).to_rgba();

    let duration_ms =
        |v_mm_s: f64| f64::from(m.transition_duration_s((v_mm_s * 1e-3) as f32)) * 1e3;
    let d_max = slides
        .iter()
        .filter_map(|s| s.transition_s.map(|t| f64::from(t) * 1e3))
        .fold(2.0 * f64::from(m.transition_time_s) * 1e3, f64::max)
        * 1.1;
    let mut chart = ChartBuilder::on(&left)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .caption(
            "the transition's duration against the hand's speed",
            (font, 18),
        )
        .build_cartesian_2d(0.0..v_max, 0.0..d_max)?;
    chart
        .configure_mesh()
        .x_desc("hand speed (mm/s)")
        .y_desc("breakaway to slip (ms)")
        .label_style((font, 14))
        .draw()?;
    let nominal: Vec<(f64, f64)> = (1..=400)
        .map(|i| v_max * f64::from(i) / 400.0)
        .map(|v| (v, duration_ms(v)))
        .filter(|p| p.1 <= d_max)
        .collect();
    chart
        .draw_series(LineSeries::new(nominal, BLACK.stroke_width(2)))?
        .label("the material's \u{3c4} max(1, vs / v)")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.stroke_width(2)));
    for (i, s) in slides.iter().enumerate() {
        let Some(d) = s.transition_s else { continue };
        let c = colour(i);
        let p = (f64::from(s.hand_speed_m_per_s) * 1e3, f64::from(d) * 1e3);
        chart
            .draw_series(std::iter::once(Circle::new(p, 5, c.filled())))?
            .label(format!("hand at {} mm/s", s.hand_speed_m_per_s * 1e3))
            .legend(move |(x, y)| Circle::new((x + 10, y), 4, c.filled()));
    }
    legend(&mut chart)?;

    let t_max = slides
        .iter()
        .flat_map(|s| s.samples.iter().map(|p| f64::from(p.0)))
        .fold(0.1, f64::max)
        .min(0.25);
    let mut chart = ChartBuilder::on(&right)
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .caption("\u{3bc} after breakaway", (font, 18))
        .build_cartesian_2d(0.0..t_max * 1e3, mu_range)?;
    chart
        .configure_mesh()
        .x_desc("time since breakaway (ms)")
        .y_desc("\u{3bc}")
        .label_style((font, 14))
        .draw()?;
    for (i, s) in slides.iter().enumerate() {
        let pts: Vec<(f64, f64)> = s
            .samples
            .iter()
            .map(|&(t, _, mu)| (f64::from(t) * 1e3, f64::from(mu)))
            .filter(|p| p.0 <= t_max * 1e3)
            .collect();
        chart
            .draw_series(LineSeries::new(pts, colour(i).stroke_width(2)))?
            .label(format!("hand at {} mm/s", s.hand_speed_m_per_s * 1e3))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], colour(i)));
    }
    legend(&mut chart)?;
    Ok(())
}
