//! What the 3-D view draws over the surfaces with egui's painter and the same camera: the
//! hand (HIP, CP, GO, its target and the force arrows), the axes and the legend.

use eframe::egui;
use egui::{Align2, Color32, FontId, Pos2, Rect, Shape, Stroke};
use friction::Mode;
use nurbs::Vec3;

use super::camera::Camera3d;
use crate::gui::surface_scene::SpatialState;
use crate::gui::view::{mode_colour, tick_summary};

/// Force arrows: metres of the scene per newton.
pub const M_PER_N: f32 = 0.01;

pub(super) fn draw_hand(
    painter: &egui::Painter,
    rect: Rect,
    camera: &Camera3d,
    spatial: &SpatialState,
    latest: Option<&host::backend::Sample>,
) {
    let at = |p: Vec3| camera.project(rect, p);
    let blue = Color32::from_rgb(40, 110, 200);
    if let Some(t) = at(spatial.target) {
        let s = Stroke::new(1.5, Color32::from_rgb(90, 90, 200));
        painter.line_segment([t - egui::vec2(6.0, 0.0), t + egui::vec2(6.0, 0.0)], s);
        painter.line_segment([t - egui::vec2(0.0, 6.0), t + egui::vec2(0.0, 6.0)], s);
    }
    let Some(sample) = latest else {
        return;
    };
    let k = &sample.tick;
    let Some(hip) = at(k.hip) else {
        return;
    };
    let colour = mode_colour(k.mode);
    if k.mode != Mode::Free {
        if let (Some(cp), Some(go)) = (at(k.cp), at(k.go)) {
            painter.add(Shape::dashed_line(
                &[hip, cp],
                Stroke::new(1.0, Color32::from_gray(90)),
                3.0,
                3.0,
            ));
            painter.line_segment([hip, go], Stroke::new(1.0, Color32::from_gray(90)));
            painter.circle_stroke(cp, 4.0, Stroke::new(2.0, blue));
            painter.circle_filled(go, 4.5, colour);
            painter.circle_stroke(go, 4.5, Stroke::new(1.0, Color32::BLACK));
        }
        let arrow = |v: Vec3, colour: Color32, width: f32| {
            if let Some(end) = at(k.hip + v * M_PER_N)
                && (end - hip).length() > 1.0
            {
                painter.arrow(hip, end - hip, Stroke::new(width, colour));
            }
        };
        arrow(k.normal * k.normal_force_n, blue, 2.5);
        arrow(k.friction, colour, 2.5);
        arrow(k.force, Color32::from_gray(30), 1.0);
    }
    painter.circle_filled(hip, 6.0, colour);
    painter.circle_stroke(hip, 6.0, Stroke::new(1.5, Color32::BLACK));
}

/// x (red), y (green) and z (blue) in the bottom-left corner, 10 mm long at the target.
pub(super) fn draw_axes(painter: &egui::Painter, rect: Rect, camera: &Camera3d) {
    let Some(o) = camera.project(rect, camera.target) else {
        return;
    };
    let corner = Pos2::new(rect.left() + 40.0, rect.bottom() - 40.0);
    for (axis, colour, name) in [
        (Vec3::X, Color32::from_rgb(200, 50, 50), "x"),
        (Vec3::Y, Color32::from_rgb(40, 150, 40), "y"),
        (Vec3::Z, Color32::from_rgb(40, 80, 210), "z"),
    ] {
        let Some(end) = camera.project(rect, camera.target + axis * 0.01) else {
            continue;
        };
        let d = (end - o).normalized() * 28.0;
        if d.is_finite() {
            painter.arrow(corner, d, Stroke::new(1.5, colour));
            painter.text(
                corner + d * 1.2,
                Align2::CENTER_CENTER,
                name,
                FontId::proportional(12.0),
                colour,
            );
        }
    }
}

pub(super) fn draw_legend(
    painter: &egui::Painter,
    rect: Rect,
    spatial: &SpatialState,
    latest: Option<&host::backend::Sample>,
    installed: bool,
    deforming: Option<&str>,
) {
    let font = FontId::proportional(13.0);
    let text = Color32::from_gray(40);
    let x = rect.left() + 10.0;
    let mut y = rect.top() + 8.0;
    let mut line = |s: String, c: Color32| {
        painter.text(Pos2::new(x, y), Align2::LEFT_TOP, s, font.clone(), c);
        y += 17.0;
    };
    let felt = if spatial.render_mesh {
        format!(
            " (felt as its mesh, {} triangles)",
            spatial.mesh_triangles.unwrap_or(0)
        )
    } else {
        String::new()
    };
    match &spatial.view.rendered_name {
        Some(name) => line(format!("{}: {name}{felt}", spatial.view.label), text),
        None => line(
            format!("{}: no object of surfaces to feel", spatial.view.label),
            text,
        ),
    }
    if let Some(s) = latest {
        let k = &s.tick;
        line(tick_summary(k), mode_colour(k.mode));
        line(
            format!(
                "HIP ({:.1}, {:.1}, {:.1}) mm",
                k.hip.x * 1e3,
                k.hip.y * 1e3,
                k.hip.z * 1e3
            ),
            text,
        );
    }
    if let Some(d) = deforming {
        line(d.to_owned(), Color32::from_rgb(70, 90, 150));
    }
    if !installed {
        line(
            "(wgpu renderer not available: surfaces not drawn)".into(),
            Color32::from_rgb(190, 30, 30),
        );
    }
    let key_y = rect.bottom() - 8.0 - 17.0 * 3.0;
    let key = [
        "drag: hand  ·  wheel while dragging, or shift+wheel: depth  ·  right/alt-drag: orbit  \
         ·  wheel: zoom",
        "big dot: HIP (mode colour)  ·  ring: CP  ·  small dot: GO  ·  cross: hand",
        "arrows: blue normal, coloured friction, black total (10 mm per N)",
    ];
    for (i, s) in key.iter().enumerate() {
        painter.text(
            Pos2::new(rect.left() + 90.0, key_y + 17.0 * i as f32),
            Align2::LEFT_TOP,
            *s,
            font.clone(),
            Color32::from_gray(90),
        );
    }
}
