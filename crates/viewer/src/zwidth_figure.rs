//! `viewer zwidth`: the Z-width sweep of the simulated pantograph ([`host::zwidth`]) as a CSV
//! and a figure: stable and unstable (K, B) cells without and with the passivity controller,
//! with the device's own bounds drawn over them.

use std::path::Path;

use device::safety::SafetyConfig;
use device::wall::{PassivityConfig, WallLimits};
use host::zwidth::Cell;
use plotters::prelude::*;

use crate::plot::{FONT, PlotError, load_font};

/// The wall stiffnesses of the sweep (N/m), log-spaced from 100 to 10,000.
pub const STIFFNESSES: [f32; 13] = [
    100.0, 150.0, 220.0, 330.0, 470.0, 680.0, 1000.0, 1500.0, 2200.0, 3300.0, 4700.0, 6800.0,
    10000.0,
];
/// The wall dampings of the sweep (N·s/m).
pub const DAMPINGS: [f32; 6] = [0.0, 0.1, 0.25, 0.5, 1.0, 2.0];

/// Draws `cells` (one sweep with the controller off, one with it on, at `rate_hz` for one
/// hand) to `path`: a panel each, green dots stable, red crosses not, and the device's
/// passivity bound `K = 2 (b + f_c/v − B) / T` and quantisation bound `2 f_c / Δ`.
pub fn write_png(cells: &[Cell], rate_hz: f64, hand: &str, path: &Path) -> Result<(), PlotError> {
    load_font()?;
    let draw_error = |e: &dyn std::fmt::Display| PlotError::Draw {
        path: path.to_owned(),
        message: e.to_string(),
    };
    let root = BitMapBackend::new(path, (1400, 700)).into_drawing_area();
    draw(cells, rate_hz, hand, &root).map_err(|e| draw_error(&e))?;
    root.present().map_err(|e| draw_error(&e))?;
    Ok(())
}

fn draw(
    cells: &[Cell],
    rate_hz: f64,
    hand: &str,
    root: &DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>,
) -> Result<(), Box<dyn std::error::Error>> {
    root.fill(&WHITE)?;
    let passivity: PassivityConfig = SafetyConfig::default().passivity;
    let period_s = (1.0 / rate_hz) as f32;
    let panels = root.split_evenly((1, 2));
    let b_max = DAMPINGS.iter().copied().fold(0.0, f32::max) as f64 * 1.05;
    let speed = cells.first().map_or(0.0, |c| c.impact.speed_m_per_s);
    for (panel, controller) in panels.iter().zip([false, true]) {
        let title = format!(
            "{rate_hz} Hz, {hand} handle, impact {speed} m/s, passivity controller {}",
            if controller { "on" } else { "off" }
        );
        let mut chart = ChartBuilder::on(panel)
            .caption(title, (FONT, 18))
            .margin(16)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..b_max, (80.0f64..12000.0).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("wall damping B (N·s/m)")
            .y_desc("wall stiffness K (N/m)")
            .label_style((FONT, 15))
            .draw()?;
        let bound: Vec<(f64, f64)> = (0..=200)
            .map(|i| {
                let b = b_max * f64::from(i) / 200.0;
                let k = WallLimits::new(&passivity, b as f32, period_s).passive_n_per_m;
                (b, f64::from(k).max(80.0))
            })
            .collect();
        chart
            .draw_series(LineSeries::new(bound, BLUE.stroke_width(2)))?
            .label("passivity bound 2(b + f_c/v - B)/T (device's own)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE.stroke_width(2)));
        let q = f64::from(WallLimits::new(&passivity, 0.0, period_s).quantisation_n_per_m);
        chart
            .draw_series(LineSeries::new(
                vec![(0.0, q), (b_max, q)],
                MAGENTA.stroke_width(2),
            ))?
            .label("quantisation bound 2 f_c / Δ")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], MAGENTA.stroke_width(2)));
        let mine = cells
            .iter()
            .filter(|c| c.impact.passivity_control == controller);
        let at = |c: &&Cell| {
            (
                f64::from(c.impact.damping_ns_per_m),
                f64::from(c.impact.stiffness_n_per_m),
            )
        };
        let (stable, unstable): (Vec<&Cell>, Vec<&Cell>) = mine.partition(|c| c.outcome.stable);
        chart
            .draw_series(stable.iter().map(|c| Circle::new(at(c), 6, GREEN.filled())))?
            .label("stable")
            .legend(|(x, y)| Circle::new((x + 10, y), 6, GREEN.filled()));
        chart
            .draw_series(
                unstable
                    .iter()
                    .map(|c| Cross::new(at(c), 6, RED.stroke_width(2))),
            )?
            .label("unstable")
            .legend(|(x, y)| Cross::new((x + 10, y), 6, RED.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FONT, 14))
            .draw()?;
    }
    Ok(())
}
