//! The 3-D view of a scene of surfaces (and spatial curves), drawn with wgpu inside egui
//! through a paint callback ([`egui_wgpu::Callback`]): the shaded surfaces (tessellated for
//! display only), their control nets and the spatial curves; over them, with egui's painter
//! and the same camera, the HIP, CP, GO, the hand's target and the force vectors.
//!
//! egui's render pass has no depth buffer (and the snapshot harness's has none either), so the
//! triangles are sorted back to front on the CPU every frame (painter's algorithm, a stable
//! sort: the same picture for the same camera) and drawn two-sided with a head light.
//!
//! Mouse: primary drag moves the hand in the view plane (the plane through the hand's target
//! perpendicular to the view direction); the wheel while the hand is held (or shift + wheel)
//! moves it in depth, 1 mm per 50 points of scroll, along the view direction; secondary or
//! middle drag, or alt + primary drag, orbits; the wheel zooms; a double click fits the scene.

mod camera;
pub mod geometry;
mod overlays;
mod pipeline;

pub use camera::Camera3d;
pub use geometry::{
    DISPLAY_TOL_M, Geometry, MOVING_GRID, REST_LINES, Scene3d, VERTEX_FLOATS, WIRE_SAMPLES,
};
pub use overlays::M_PER_N;
pub use pipeline::{Installed, back_to_front, install};

use eframe::egui;
use eframe::egui_wgpu;
use egui::{Align2, Color32, FontId, Rect, Sense};

use super::state::AppState;
use super::surface_scene::SpatialState;
use super::view::pointer_interval_s;
use overlays::{draw_axes, draw_hand, draw_legend};
use pipeline::Draw3d;

/// The 3-D view, filling the space it is given. `installed` says whether the wgpu side is
/// there ([`install`]).
pub fn view_3d_ui(ui: &mut egui::Ui, state: &mut AppState, camera: &mut Camera3d, installed: bool) {
    let size = ui.available_size();
    let (response, painter) = ui.allocate_painter(size, Sense::click_and_drag());
    let rect = response.rect;
    painter.rect_filled(rect, 0.0, Color32::from_gray(245));
    let Some(spatial) = state.spatial.as_mut() else {
        painter.text(
            rect.center(),
            Align2::CENTER_CENTER,
            "no 3-D scene",
            FontId::proportional(16.0),
            Color32::from_gray(60),
        );
        return;
    };
    if camera.fit_pending || response.double_clicked() {
        camera.fit(spatial.view.bounds, spatial.start, rect.aspect_ratio());
    }
    controls_ui(ui, rect, spatial, camera);

    let modifiers = ui.input(|i| i.modifiers);
    let orbiting = response.dragged_by(egui::PointerButton::Secondary)
        || response.dragged_by(egui::PointerButton::Middle)
        || (modifiers.alt && response.dragged_by(egui::PointerButton::Primary));
    if orbiting {
        camera.orbit(response.drag_delta());
    }
    let primary_down = ui.input(|i| i.pointer.primary_down());
    let holding = response.is_pointer_button_down_on() && primary_down && !modifiers.alt;
    if response.hovered() {
        let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta(), i.zoom_delta()));
        // The wheel moves the hand in depth while it is held (or with shift), else zooms.
        if modifiers.shift || holding {
            // Shift turns the wheel sideways on some platforms: take both axes.
            let notches = (scroll.y + scroll.x) / 50.0;
            if notches.abs() > 1e-3 {
                let target = spatial.target + camera.view_dir() * (notches * 1e-3);
                spatial.set_target(target);
            }
        } else {
            let factor = zoom * (scroll.y / 200.0).exp();
            if (factor - 1.0).abs() > 1e-4 {
                camera.distance_m = (camera.distance_m / factor).clamp(0.01, 2.0);
            }
        }
    }
    if !orbiting && holding {
        if let Some(p) = response.interact_pointer_pos()
            && let Some(target) = camera.on_view_plane(rect, p, spatial.target)
        {
            let over_s = pointer_interval_s(ui, state.dragging);
            state.dragging = true;
            spatial.glide_to(target, over_s);
        }
    } else {
        state.dragging = false;
    }

    let geometry = spatial.view.geometry.clone();
    if installed {
        let draw = Draw3d::new(geometry, camera, rect.aspect_ratio());
        painter.add(egui_wgpu::Callback::new_paint_callback(rect, draw));
    }
    let painter = painter.with_clip_rect(rect);
    let latest = state.latest().copied();
    let spatial = state.spatial.as_ref();
    let deforming = state
        .deform
        .moving
        .is_some()
        .then(|| super::view::deform_summary(state));
    if let Some(spatial) = spatial {
        draw_hand(&painter, rect, camera, spatial, latest.as_ref());
        draw_axes(&painter, rect, camera);
        draw_legend(
            &painter,
            rect,
            spatial,
            latest.as_ref(),
            installed,
            deforming.as_deref(),
        );
    }
}

/// The representation switch, the chordal tolerance, the export and the fit buttons, top
/// right.
fn controls_ui(ui: &mut egui::Ui, rect: Rect, spatial: &mut SpatialState, camera: &mut Camera3d) {
    let area = Rect::from_min_max(
        egui::pos2(rect.right() - 330.0, rect.top() + 6.0),
        egui::pos2(rect.right() - 6.0, rect.top() + 130.0),
    );
    ui.scope_builder(egui::UiBuilder::new().max_rect(area), |ui| {
        egui::Frame::popup(ui.style()).show(ui, |ui| {
            ui.horizontal(|ui| {
                if ui.button("fit").clicked() {
                    camera.fit(spatial.view.bounds, spatial.start, rect.aspect_ratio());
                }
                if spatial.can_tessellate() {
                    let mut mesh = spatial.render_mesh;
                    ui.label("feel:");
                    let a = ui.radio_value(&mut mesh, false, "NURBS");
                    let b = ui.radio_value(&mut mesh, true, "mesh");
                    if a.changed() || b.changed() {
                        spatial.set_render_mesh(mesh);
                    }
                }
            });
            if spatial.can_tessellate() {
                let mut tol_mm = spatial.tolerance_m * 1e3;
                let slider = ui.add(
                    egui::Slider::new(&mut tol_mm, 0.05..=5.0)
                        .logarithmic(true)
                        .text("chordal tol. (mm)"),
                );
                if slider.drag_stopped() || (slider.changed() && !slider.dragged()) {
                    spatial.set_tolerance(tol_mm * 1e-3);
                } else if slider.changed() {
                    spatial.tolerance_m = tol_mm * 1e-3;
                }
                ui.horizontal(|ui| {
                    ui.add(
                        egui::TextEdit::singleline(&mut spatial.export_path)
                            .hint_text("out.obj")
                            .desired_width(150.0),
                    );
                    if ui.button("Export OBJ").clicked() {
                        spatial.export_obj_to_path();
                    }
                });
            }
            if let Some(m) = &spatial.message {
                ui.label(m);
            }
        });
    });
}
