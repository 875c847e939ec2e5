//! The figure of an analysed run (`viewer experiment analyze DIR`, default `DIR/summary.png`):
//!
//! - identification: each condition's confusion matrix side by side, a heat map of the row
//!   proportions (rows: the stimulus presented, columns: the stimulus answered) with the counts
//!   written in the cells;
//! - 2AFC: on the left the staircases' tracks (level against trial; filled dots answered
//!   right, open dots wrong, red rings the reversals; the dashed line the reference), on the
//!   right the proportion correct against the folded level with the fitted psychometric
//!   function, its 75 % point and the point's 95 % credible interval. A constant-stimuli run
//!   has no tracks: the right panel takes the whole figure.

use std::path::Path;

use experiment::analyze::{Cell, Identification, Summary, TwoAfc};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::plot::{FONT, PlotError, load_font};

/// The figure's size (pixels).
pub const SIZE: (u32, u32) = (1600, 760);

type DrawResult<T> = Result<T, Box<dyn std::error::Error>>;
type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Series colours, in order.
const PALETTE: [RGBColor; 6] = [
    RGBColor(30, 80, 200),
    RGBColor(220, 120, 20),
    RGBColor(40, 150, 60),
    RGBColor(150, 50, 170),
    RGBColor(120, 120, 120),
    RGBColor(20, 160, 170),
];

fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Draws `summary` into the PNG `file`, errors naming `path` (the file the user asked for).
pub fn write_png(summary: &Summary, file: &Path, path: &Path) -> Result<(), PlotError> {
    load_font()?;
    let draw_error = |e: &dyn std::fmt::Display| PlotError::Draw {
        path: path.to_owned(),
        message: e.to_string(),
    };
    let root = BitMapBackend::new(file, SIZE).into_drawing_area();
    let result = (|| -> DrawResult<()> {
        root.fill(&WHITE)?;
        let title = format!(
            "{} ({}, {} trials)",
            summary.plan, summary.design, summary.trials
        );
        let root = root.titled(&shorten(&title, 120), (FONT, 22))?;
        if let Some(id) = &summary.identification {
            confusions(id, &root)?;
        } else if let Some(afc) = &summary.two_afc {
            two_afc(afc, &root)?;
        }
        Ok(())
    })();
    result.map_err(|e| draw_error(&e))?;
    root.present().map_err(|e| draw_error(&e))?;
    Ok(())
}

fn shorten(text: &str, max: usize) -> String {
    if text.chars().count() <= max {
        text.to_owned()
    } else {
        let mut s: String = text.chars().take(max - 1).collect();
        s.push('…');
        s
    }
}

fn confusions(id: &Identification, root: &Area<'_>) -> DrawResult<()> {
    let n = id.stimuli.len();
    // A segmented range a..b has a segment for each of a..=b: n segments end at n − 1.
    let last = (n as i32 - 1).max(1);
    let panels = root.split_evenly((1, id.conditions.len().max(1)));
    for (c, (cond, area)) in id.conditions.iter().zip(&panels).enumerate() {
        let accuracy = cond.accuracy.map_or("no trials".to_owned(), |a| {
            format!("{:.1} % correct", 100.0 * a)
        });
        let mut caption = format!(
            "{}: {} of {} ({accuracy})",
            cond.name, cond.correct, cond.trials
        );
        if c == 0
            && let Some(e) = &id.condition_effect
        {
            caption = format!("{caption}; Fisher p = {:.4}", e.p_value);
        }
        let names = id.stimuli.clone();
        let names_y = id.stimuli.clone();
        let mut chart = ChartBuilder::on(area)
            .margin(16)
            .margin_right(30)
            .caption(shorten(&caption, 60), (FONT, 17))
            .x_label_area_size(60)
            .y_label_area_size(130)
            .build_cartesian_2d((0..last).into_segmented(), (0..last).into_segmented())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(n)
            .y_labels(n)
            .x_desc("answered")
            .y_desc("presented")
            .label_style((FONT, 13))
            .axis_desc_style((FONT, 15))
            .x_label_formatter(&move |v| segment_name(v, &names, false))
            .y_label_formatter(&move |v| segment_name(v, &names_y, true))
            .draw()?;
        for (p, row) in cond.confusion.iter().enumerate() {
            let total: u64 = row.iter().sum();
            // Row p (presented) is drawn from the top.
            let y = (n - 1 - p) as i32;
            for (a, &count) in row.iter().enumerate() {
                let share = if total > 0 {
                    count as f64 / total as f64
                } else {
                    0.0
                };
                let fill = RGBColor(
                    (255.0 - 225.0 * share) as u8,
                    (255.0 - 175.0 * share) as u8,
                    (255.0 - 55.0 * share) as u8,
                );
                let x = a as i32;
                chart.draw_series(std::iter::once(Rectangle::new(
                    [
                        (SegmentValue::Exact(x), SegmentValue::Exact(y)),
                        (SegmentValue::Exact(x + 1), SegmentValue::Exact(y + 1)),
                    ],
                    fill.filled(),
                )))?;
                chart.draw_series(std::iter::once(Rectangle::new(
                    [
                        (SegmentValue::Exact(x), SegmentValue::Exact(y)),
                        (SegmentValue::Exact(x + 1), SegmentValue::Exact(y + 1)),
                    ],
                    if a == p {
                        BLACK.stroke_width(2)
                    } else {
                        BLACK.mix(0.2).stroke_width(1)
                    },
                )))?;
                let text_colour = if share > 0.55 { WHITE } else { BLACK };
                chart.draw_series(std::iter::once(Text::new(
                    count.to_string(),
                    (SegmentValue::CenterOf(x), SegmentValue::CenterOf(y)),
                    (FONT, 18).into_font().color(&text_colour).pos(
                        plotters::style::text_anchor::Pos::new(
                            plotters::style::text_anchor::HPos::Center,
                            plotters::style::text_anchor::VPos::Center,
                        ),
                    ),
                )))?;
            }
        }
    }
    Ok(())
}

/// The stimulus name at a segment's centre (`flipped`: rows counted from the top).
fn segment_name(v: &SegmentValue<i32>, names: &[String], flipped: bool) -> String {
    match v {
        SegmentValue::CenterOf(i) => {
            let i = *i as usize;
            let index = if flipped {
                names.len().checked_sub(1 + i)
            } else {
                Some(i)
            };
            index
                .and_then(|k| names.get(k))
                .cloned()
                .unwrap_or_default()
        }
        _ => String::new(),
    }
}

fn two_afc(afc: &TwoAfc, root: &Area<'_>) -> DrawResult<()> {
    let has_tracks = afc.cells.iter().any(|c| !c.staircases.is_empty());
    if has_tracks {
        let width = root.dim_in_pixel().0;
        let (left, right) = root.split_horizontally(width / 2);
        tracks(afc, &left)?;
        psychometric(afc, &right)
    } else {
        psychometric(afc, root)
    }
}

fn tracks(afc: &TwoAfc, area: &Area<'_>) -> DrawResult<()> {
    let mut t_max = 1.0f64;
    let (mut lo, mut hi) = (afc.reference, afc.reference);
    for cell in &afc.cells {
        for s in &cell.staircases {
            for t in &s.track {
                t_max = t_max.max(t.trial as f64);
                lo = lo.min(t.level);
                hi = hi.max(t.level);
            }
        }
    }
    let pad = 0.08 * (hi - lo).max(1e-9 * afc.reference.abs().max(1.0));
    let mut chart = ChartBuilder::on(area)
        .margin(16)
        .caption("staircase tracks", (FONT, 18))
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_max + 1.0, (lo - pad)..(hi + pad))?;
    chart
        .configure_mesh()
        .x_desc("trial")
        .y_desc(afc.field.as_str())
        .light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.12))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()?;
    chart
        .draw_series(DashedLineSeries::new(
            [(0.0, afc.reference), (t_max + 1.0, afc.reference)],
            8,
            6,
            BLACK.mix(0.6).stroke_width(1),
        ))?
        .label(format!("reference {}", afc.reference))
        .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], BLACK.mix(0.6)));
    let mut k = 0;
    let many_cells = afc.cells.len() > 1;
    for cell in &afc.cells {
        for s in &cell.staircases {
            let c = colour(k);
            k += 1;
            let points: Vec<(f64, f64)> =
                s.track.iter().map(|t| (t.trial as f64, t.level)).collect();
            let label = if many_cells {
                format!("{} ({} / {})", s.name, cell.stimulus, cell.condition)
            } else {
                s.name.clone()
            };
            chart
                .draw_series(LineSeries::new(points, c.stroke_width(2)))?
                .label(label)
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c.stroke_width(2)));
            chart.draw_series(s.track.iter().map(|t| {
                let style = if t.correct {
                    c.filled()
                } else {
                    WHITE.filled()
                };
                Circle::new((t.trial as f64, t.level), 4, style)
            }))?;
            chart.draw_series(
                s.track
                    .iter()
                    .filter(|t| !t.correct)
                    .map(|t| Circle::new((t.trial as f64, t.level), 4, c.stroke_width(1))),
            )?;
            chart.draw_series(
                s.reversals
                    .iter()
                    .map(|r| Circle::new((r.trial as f64, r.level), 8, RED.stroke_width(2))),
            )?;
        }
    }
    chart
        .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
        .label("reversal")
        .legend(|(x, y)| Circle::new((x + 9, y), 6, RED.stroke_width(2)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.5))
        .label_font((FONT, 14))
        .draw()?;
    Ok(())
}

fn psychometric(afc: &TwoAfc, area: &Area<'_>) -> DrawResult<()> {
    let r = afc.reference;
    let mut hi = r;
    for cell in &afc.cells {
        for p in &cell.points {
            hi = hi.max(p.level);
        }
        if let Some(f) = &cell.fit {
            hi = hi.max(f.threshold_75);
            if let Some([_, u]) = f.ci95_threshold {
                hi = hi.max(u);
            }
        }
    }
    // From just under the guess rate, lower when a level is answered worse than chance.
    let y_low = afc
        .cells
        .iter()
        .flat_map(|c| &c.points)
        .filter(|p| p.trials > 0)
        .map(|p| f64::from(p.correct) / f64::from(p.trials) - 0.04)
        .fold(0.4, f64::min);
    let x_range = r - 0.03 * (hi - r).max(1e-9)..hi + 0.06 * (hi - r).max(1e-9);
    let caption = match afc.cells.as_slice() {
        [cell] => match (&cell.fit, &cell.fit_error) {
            (Some(f), _) => match f.ci95_weber {
                Some([a, b]) => format!(
                    "proportion correct; Weber fraction {:.3} [{a:.3}, {b:.3}]",
                    f.weber_75
                ),
                None => format!("proportion correct; Weber fraction {:.3}", f.weber_75),
            },
            (None, e) => format!("proportion correct; no fit: {}", e.as_deref().unwrap_or("")),
        },
        _ => "proportion correct".to_owned(),
    };
    let mut chart = ChartBuilder::on(area)
        .margin(16)
        .margin_right(28)
        .caption(shorten(&caption, 70), (FONT, 18))
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(x_range.clone(), y_low..1.02)?;
    chart
        .configure_mesh()
        .x_desc(format!(
            "{} folded onto the upper side of the reference (x < r: r\u{b2}/x)",
            afc.field
        ))
        .y_desc("proportion correct")
        .light_line_style(TRANSPARENT)
        .bold_line_style(BLACK.mix(0.12))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 15))
        .draw()?;
    chart.draw_series(DashedLineSeries::new(
        [(x_range.start, 0.75), (x_range.end, 0.75)],
        6,
        6,
        BLACK.mix(0.35).stroke_width(1),
    ))?;
    chart.draw_series(DashedLineSeries::new(
        [(x_range.start, 0.5), (x_range.end, 0.5)],
        3,
        6,
        BLACK.mix(0.35).stroke_width(1),
    ))?;
    let many = afc.cells.len() > 1;
    for (i, cell) in afc.cells.iter().enumerate() {
        cell_series(&mut chart, cell, i, many, x_range.clone())?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.5))
        .label_font((FONT, 14))
        .draw()?;
    Ok(())
}

type Chart<'a> = ChartContext<
    'a,
    BitMapBackend<'a>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn cell_series(
    chart: &mut Chart<'_>,
    cell: &Cell,
    i: usize,
    many: bool,
    x_range: std::ops::Range<f64>,
) -> DrawResult<()> {
    let c = colour(i);
    let prefix = if many {
        format!("{} / {}: ", cell.stimulus, cell.condition)
    } else {
        String::new()
    };
    let largest = cell
        .points
        .iter()
        .map(|p| p.trials)
        .max()
        .unwrap_or(1)
        .max(1);
    chart
        .draw_series(cell.points.iter().filter(|p| p.trials > 0).map(|p| {
            // Area proportional to the trials at the level.
            let radius = 3.0 + 9.0 * (f64::from(p.trials) / f64::from(largest)).sqrt();
            Circle::new(
                (p.level, f64::from(p.correct) / f64::from(p.trials)),
                radius as i32,
                c.mix(0.55).filled(),
            )
        }))?
        .label(format!("{prefix}data (dot area: trials)"))
        .legend(move |(x, y)| Circle::new((x + 9, y), 5, c.mix(0.55).filled()));
    if let (Some(fitted), Some(f)) = (&cell.fitted, &cell.fit) {
        let (a, b) = (x_range.start.max(1e-12), x_range.end);
        let curve: Vec<(f64, f64)> = (0..=300)
            .map(|k| {
                let x = a + (b - a) * f64::from(k) / 300.0;
                (x, fitted.psi(x))
            })
            .collect();
        chart
            .draw_series(LineSeries::new(curve, c.stroke_width(2)))?
            .label(format!("{prefix}fit, lapse {:.3}", f.lapse))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c.stroke_width(2)));
        if let Some([lo, hi]) = f.ci95_threshold {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    [(lo, 0.75), (hi, 0.75)],
                    RED.stroke_width(3),
                )))?
                .label(format!("{prefix}95 % CI of the 75 % point"))
                .legend(|(x, y)| PathElement::new([(x, y), (x + 18, y)], RED.stroke_width(3)));
            for end in [lo, hi] {
                chart.draw_series(std::iter::once(PathElement::new(
                    [(end, 0.73), (end, 0.77)],
                    RED.stroke_width(2),
                )))?;
            }
        }
        chart
            .draw_series(std::iter::once(TriangleMarker::new(
                (f.threshold_75, 0.75),
                8,
                RED.filled(),
            )))?
            .label(format!(
                "{prefix}75 % point {:.4} (Weber {:.3})",
                f.threshold_75, f.weber_75
            ))
            .legend(|(x, y)| TriangleMarker::new((x + 9, y), 6, RED.filled()));
    }
    Ok(())
}
