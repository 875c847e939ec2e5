//! PNG plots of a [`Run`], in the layout of the thesis's Fig. 3.2.2 and 3.2.4: forces against
//! time over coloured bands of the friction mode, and below them the parameters of the
//! closest point (CP) and of the god-object (GO).
//!
//! Text is drawn with a font this program ships (Hack, from `epaint_default_fonts`), so the
//! plot looks the same on every machine and needs no system fonts.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use friction::Mode;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

use host::sim::Run;
use host::tick::Tick;
use scene::Space;

/// Default image size (pixels).
pub const DEFAULT_SIZE: (u32, u32) = (1400, 900);

/// The font family name the plots use; registered on first use.
pub(crate) const FONT: &str = "sans-serif";

/// Why a plot could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Drawing or writing the file failed.
    #[error("cannot write plot {}: {message}", path.display())]
    Draw {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The run has no ticks.
    #[error("cannot plot {}: the run has no ticks", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// The shipped font could not be loaded (a build problem, not a user's).
    #[error("cannot plot: the embedded font is invalid")]
    Font,
}

/// The colour of a mode's band (and its legend entry).
pub fn mode_colour(mode: Mode) -> RGBColor {
    match mode {
        Mode::Free => RGBColor(225, 225, 225),
        Mode::Stuck => RGBColor(244, 170, 170),
        Mode::Transition => RGBColor(250, 215, 120),
        Mode::Slip => RGBColor(160, 205, 240),
    }
}

const MODES: [Mode; 4] = [Mode::Free, Mode::Stuck, Mode::Transition, Mode::Slip];

pub(crate) fn load_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        register_font(FONT, FontStyle::Normal, epaint_default_fonts::HACK_REGULAR).is_ok()
    });
    if ok { Ok(()) } else { Err(PlotError::Font) }
}

/// Writes the plot of `run` to a PNG file of `size` pixels.
pub fn write_png(run: &Run, path: impl AsRef<Path>, size: (u32, u32)) -> Result<(), PlotError> {
    write_png_as(run, path.as_ref(), path.as_ref(), size)
}

/// [`write_png`] into the file `file` (a temporary file, say), with errors naming `path`, the
/// file the user asked for.
pub fn write_png_as(
    run: &Run,
    file: &Path,
    path: &Path,
    size: (u32, u32),
) -> Result<(), PlotError> {
    write_png_panels(run, file, path, size, true)
}

/// [`write_png_as`], with the panel of CP and GO parameters only when `parameters` (a run
/// log read back has none: `viewer plot`).
pub fn write_png_panels(
    run: &Run,
    file: &Path,
    path: &Path,
    size: (u32, u32),
    parameters: bool,
) -> Result<(), PlotError> {
    load_font()?;
    if run.ticks.is_empty() {
        return Err(PlotError::Empty {
            path: path.to_owned(),
        });
    }
    let draw_error = |e: &dyn std::fmt::Display| PlotError::Draw {
        path: path.to_owned(),
        message: e.to_string(),
    };
    let root = BitMapBackend::new(file, size).into_drawing_area();
    draw(run, &root, parameters).map_err(|e| draw_error(&e))?;
    root.present().map_err(|e| draw_error(&e))?;
    Ok(())
}

type DrawResult<T> = Result<T, Box<dyn std::error::Error>>;

fn draw(
    run: &Run,
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    with_parameters: bool,
) -> DrawResult<()> {
    root.fill(&WHITE)?;
    // A run log read back knows neither the object nor the material.
    let title = if with_parameters {
        format!(
            "object {} ({:?}), {} Hz, K = {} N/m, \u{3bc}s = {}, \u{3bc}d = {}",
            run.object,
            run.object_name,
            run.rate_hz,
            run.material.stiffness_n_per_m,
            run.material.mu_static,
            run.material.mu_dynamic
        )
    } else {
        format!("run log {}, {} Hz", run.object_name, run.rate_hz)
    };
    let root = root.titled(&title, (FONT, 22))?;
    let height = root.dim_in_pixel().1;
    match (run.is_device_run(), with_parameters) {
        (true, true) => {
            let (top, rest) = root.split_vertically(height * 44 / 100);
            let (middle, bottom) = rest.split_vertically(height * 28 / 100);
            forces(run, &top)?;
            parameters(run, &middle)?;
            torques(run, &bottom)?;
        }
        (false, true) => {
            let (top, bottom) = root.split_vertically(height * 58 / 100);
            forces(run, &top)?;
            parameters(run, &bottom)?;
        }
        (true, false) => {
            let (top, bottom) = root.split_vertically(height * 62 / 100);
            forces(run, &top)?;
            torques(run, &bottom)?;
        }
        (false, false) => forces(run, &root)?,
    }
    Ok(())
}

/// Time axis of the run (never empty).
fn time_range(ticks: &[Tick]) -> std::ops::Range<f64> {
    let t0 = ticks.first().map_or(0.0, |k| k.t_s);
    let t1 = ticks.last().map_or(1.0, |k| k.t_s);
    if t1 > t0 { t0..t1 } else { t0..t0 + 1e-3 }
}

/// Consecutive ticks of one mode: `(mode, from, to)` in seconds, each span running to the
/// start of the next.
fn mode_spans(ticks: &[Tick]) -> Vec<(Mode, f64, f64)> {
    let mut spans: Vec<(Mode, f64, f64)> = Vec::new();
    for k in ticks {
        match spans.last_mut() {
            Some((mode, _, to)) if *mode == k.mode => *to = k.t_s,
            Some((_, _, to)) => {
                *to = k.t_s;
                spans.push((k.mode, k.t_s, k.t_s));
            }
            None => spans.push((k.mode, k.t_s, k.t_s)),
        }
    }
    spans
}

/// At most about `2 · columns` points of a series: the minimum and maximum of each pixel
/// column, so spikes survive and long runs draw quickly.
fn decimate(points: &[(f64, f64)], columns: usize) -> Vec<(f64, f64)> {
    let per = points.len() / columns.max(1);
    if per < 3 {
        return points.to_vec();
    }
    let mut out = Vec::with_capacity(2 * columns + 2);
    for chunk in points.chunks(per) {
        let (mut lo, mut hi) = (chunk[0], chunk[0]);
        let (mut lo_i, mut hi_i) = (0, 0);
        for (i, &p) in chunk.iter().enumerate() {
            if p.1 < lo.1 {
                (lo, lo_i) = (p, i);
            }
            if p.1 > hi.1 {
                (hi, hi_i) = (p, i);
            }
        }
        if lo_i <= hi_i {
            out.extend([lo, hi]);
        } else {
            out.extend([hi, lo]);
        }
    }
    out
}

fn forces(run: &Run, area: &DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult<()> {
    let ticks = &run.ticks;
    let times = time_range(ticks);
    let columns = area.dim_in_pixel().0 as usize;
    let series = |f: fn(&Tick) -> f32| -> Vec<(f64, f64)> {
        let all: Vec<(f64, f64)> = ticks.iter().map(|k| (k.t_s, f(k) as f64)).collect();
        decimate(&all, columns)
    };
    let normal = series(|k| k.normal_force_n);
    let friction = series(|k| k.friction_force_n.abs());
    let total = series(|k| k.force.length());
    let peak = ticks
        .iter()
        .map(|k| {
            k.normal_force_n
                .max(k.friction_force_n.abs())
                .max(k.force.length())
        })
        .filter(|f| f.is_finite())
        .fold(0.0f32, f32::max) as f64;
    // Headroom above the curves for the legend.
    let top = if peak > 0.0 { peak * 1.6 } else { 1.0 };

    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .margin_right(24)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .caption("forces and friction mode", (FONT, 18))
        .build_cartesian_2d(times.clone(), 0.0..top)?;
    // Bands first, the grid over them, the curves on top.
    for (mode, colour) in MODES.map(|m| (m, mode_colour(m))) {
        chart
            .draw_series(
                mode_spans(ticks)
                    .into_iter()
                    .filter(|s| s.0 == mode)
                    .map(|(_, from, to)| Rectangle::new([(from, 0.0), (to, top)], colour.filled())),
            )?
            .label(format!("mode: {}", mode.name()))
            .legend(move |(x, y)| Rectangle::new([(x, y - 6), (x + 18, y + 6)], colour.filled()));
    }
    mesh(&mut chart, "force (N)")?;

    let lines = [
        ("normal force", normal, RGBColor(30, 80, 200)),
        (
            "friction force (magnitude)",
            friction,
            RGBColor(200, 30, 30),
        ),
        ("total force (magnitude)", total, RGBColor(20, 20, 20)),
    ];
    for (label, points, colour) in lines {
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(2)))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)
}

type Chart<'a> = ChartContext<'a, BitMapBackend<'a>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// The legend box of a panel.
fn legend(chart: &mut Chart<'_>, position: SeriesLabelPosition) -> DrawResult<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.5))
        .label_font((FONT, 14))
        .draw()?;
    Ok(())
}

/// Axes, labels and a light grid (major lines only).
fn mesh(chart: &mut Chart<'_>, y_desc: &str) -> DrawResult<()> {
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(y_desc)
        .light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.15))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()?;
    Ok(())
}

fn parameters(run: &Run, area: &DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult<()> {
    let ticks = &run.ticks;
    let times = time_range(ticks);
    let columns = area.dim_in_pixel().0 as usize;
    let series = |f: &dyn Fn(&Tick) -> f32| -> Vec<(f64, f64)> {
        let all: Vec<(f64, f64)> = ticks.iter().map(|k| (k.t_s, f(k) as f64)).collect();
        decimate(&all, columns)
    };
    type Getter = fn(&Tick) -> f32;
    let mut lines: Vec<(&str, Getter, ShapeStyle)> = vec![
        (
            "CP u",
            |k| k.cp_params[0],
            RGBColor(20, 140, 60).stroke_width(2),
        ),
        (
            "GO u",
            |k| k.go_params[0],
            RGBColor(150, 40, 160).stroke_width(1),
        ),
    ];
    if run.space == Space::Spatial {
        lines.push((
            "CP v",
            |k| k.cp_params[1],
            RGBColor(20, 140, 60).mix(0.5).stroke_width(2),
        ));
        lines.push((
            "GO v",
            |k| k.go_params[1],
            RGBColor(150, 40, 160).mix(0.5).stroke_width(1),
        ));
    }
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in ticks {
        for (_, get, _) in &lines {
            let v = get(k) as f64;
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    // Also when no value was finite (lo = ∞, hi = −∞).
    if lo >= hi {
        let mid = if lo.is_finite() { lo } else { 0.0 };
        (lo, hi) = (mid - 0.5, mid + 0.5);
    }
    let pad = 0.08 * (hi - lo);
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .margin_right(24)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .caption(
            "parameters of the closest point (CP) and god-object (GO) on their patch",
            (FONT, 18),
        )
        .build_cartesian_2d(times, (lo - pad)..(hi + pad))?;
    mesh(&mut chart, "parameter")?;
    for (label, get, style) in lines {
        let points = series(&get);
        chart
            .draw_series(LineSeries::new(points, style))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], style));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft)
}

/// The joint torques of a device run.
fn torques(run: &Run, area: &DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult<()> {
    let ticks = &run.ticks;
    let columns = area.dim_in_pixel().0 as usize;
    let tau = |k: &Tick, joint: usize| k.device.map_or(0.0, |d| d.tau_nm[joint]) as f64;
    let peak = ticks
        .iter()
        .flat_map(|k| [tau(k, 0).abs(), tau(k, 1).abs()])
        .filter(|t| t.is_finite())
        .fold(0.0f64, f64::max);
    let top = if peak > 0.0 { peak * 1.15 } else { 1.0 };
    let mut chart = ChartBuilder::on(area)
        .margin(12)
        .margin_right(24)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .caption(
            "joint torques J^T F of the force after the safety layer",
            (FONT, 18),
        )
        .build_cartesian_2d(time_range(ticks), -top..top)?;
    mesh(&mut chart, "torque (N\u{b7}m)")?;
    let lines = [
        ("\u{3c4}1", 0, RGBColor(200, 110, 20)),
        ("\u{3c4}2", 1, RGBColor(20, 120, 160)),
    ];
    for (label, joint, colour) in lines {
        let all: Vec<(f64, f64)> = ticks.iter().map(|k| (k.t_s, tau(k, joint))).collect();
        chart
            .draw_series(LineSeries::new(
                decimate(&all, columns),
                colour.stroke_width(2),
            ))?
            .label(label)
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], colour.stroke_width(2)));
    }
    legend(&mut chart, SeriesLabelPosition::UpperLeft)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_the_extremes() {
        let points: Vec<(f64, f64)> = (0..10_000)
            .map(|i| (i as f64, if i == 4321 { 50.0 } else { (i % 7) as f64 }))
            .collect();
        let out = decimate(&points, 100);
        assert!(out.len() <= 2 * 101, "{}", out.len());
        assert!(out.contains(&(4321.0, 50.0)));
        assert!(out.windows(2).all(|w| w[0].0 <= w[1].0), "time order");
        let few = &points[..150];
        assert_eq!(decimate(few, 100), few);
    }
}
