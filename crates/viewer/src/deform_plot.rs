//! The picture of a deformed planar curve (`viewer deform --static --plot`): its rest shape,
//! its shape under the load and the load's forces, with the displacement drawn to a larger
//! vertical scale than the length when it is small (the axes say so by their ranges).

use std::path::Path;

use host::deform::Load;
use plotters::prelude::*;
use scene::Object;

use crate::plot::{FONT, PlotError, load_font};

/// A force to draw: the point it pushes (mm), the force (N), its label.
type Arrow = ((f64, f64), (f64, f64), String);

/// Samples of a planar object's first curve (mm).
fn samples(object: &Object) -> Option<Vec<(f64, f64)>> {
    let curves = object.curve_views()?;
    let c = curves.first()?;
    let (a, b) = c.domain();
    Some(
        (0..=400)
            .map(|i| {
                let p = c.point(a + (b - a) * i as f32 / 400.0);
                (f64::from(p.x) * 1e3, f64::from(p.y) * 1e3)
            })
            .collect(),
    )
}

/// Draws `rest` and `deformed` (the same planar curve at rest and under `load`) into `file`,
/// errors naming `path`.
pub fn write_png(
    rest: &Object,
    deformed: &Object,
    load: Load,
    file: &Path,
    path: &Path,
) -> Result<(), PlotError> {
    load_font()?;
    let draw_error = |message: String| PlotError::Draw {
        path: path.to_owned(),
        message,
    };
    let (Some(a), Some(b)) = (samples(rest), samples(deformed)) else {
        return Err(draw_error("only planar curves are drawn".to_owned()));
    };
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in a.iter().chain(&b) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let span_y = (y1 - y0).max(1e-3);
    let (y0, y1) = (y0 - 0.6 * span_y, y1 + 0.6 * span_y);
    let margin_x = 0.05 * (x1 - x0).max(1e-3);
    let (x0, x1) = (x0 - margin_x, x1 + margin_x);
    // Arrows: a length of 40 % of the vertical range for the largest force drawn.
    let arrows: Vec<Arrow> = match load {
        Load::Point { params, force_n } => {
            let curves = deformed.curve_views().unwrap_or_default();
            let at = curves
                .first()
                .map(|c| c.point(params[0] as f32))
                .unwrap_or_default();
            let f = (force_n[0], force_n[1]);
            let label = format!("F = {:.3} N", f.0.hypot(f.1));
            let tip = (f64::from(at.x) * 1e3, f64::from(at.y) * 1e3);
            vec![(tip, f, label)]
        }
        Load::Uniform(q) => (1..10)
            .map(|i| {
                let p = b[i * 40];
                (p, (q[0], q[1]), String::new())
            })
            .chain(std::iter::once((
                b[200],
                (0.0, 0.0),
                format!("q = {:.3} N/m", q[0].hypot(q[1])),
            )))
            .collect(),
    };
    let largest = arrows
        .iter()
        .map(|(_, f, _)| f.0.hypot(f.1))
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    let scale = (0.4 * (y1 - y0) / largest, 0.4 * (y1 - y0) / largest);
    let root = BitMapBackend::new(file, (1200, 600)).into_drawing_area();
    let result = (|| -> Result<(), Box<dyn std::error::Error>> {
        root.fill(&WHITE)?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{}: rest shape and shape under the load", rest.name()),
                (FONT, 22),
            )
            .margin(20)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc("x (mm)")
            .y_desc("y (mm)")
            .label_style((FONT, 15))
            .draw()?;
        chart
            .draw_series(LineSeries::new(
                a.clone(),
                RGBColor(170, 170, 170).stroke_width(3),
            ))?
            .label("rest shape")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(170, 170, 170)));
        chart
            .draw_series(LineSeries::new(b.clone(), BLUE.stroke_width(3)))?
            .label("under the load")
            .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
        for (tip, f, label) in &arrows {
            // The arrow ends at the point it pushes: it starts a force's length behind it.
            let tail = (tip.0 - f.0 * scale.0, tip.1 - f.1 * scale.1);
            if f.0 != 0.0 || f.1 != 0.0 {
                chart.draw_series(std::iter::once(PathElement::new(
                    [tail, *tip],
                    RED.stroke_width(3),
                )))?;
                chart.draw_series(std::iter::once(Circle::new(*tip, 5, RED.filled())))?;
            }
            if !label.is_empty() {
                chart.draw_series(std::iter::once(Text::new(
                    label.clone(),
                    (tail.0 + 0.01 * (x1 - x0), tail.1),
                    (FONT, 18).into_font().color(&RED),
                )))?;
            }
        }
        chart
            .configure_series_labels()
            .label_font((FONT, 16))
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()?;
        root.present()?;
        Ok(())
    })();
    result.map_err(|e| draw_error(e.to_string()))
}
