//! The 2-D view of a planar scene, drawn with egui's painter: the device's reach, the curves
//! and their control polygons, the hand's target, the HIP, CP and GO, and the normal,
//! friction and total force. Pressing and dragging with the primary button moves the hand's
//! target; dragging with the secondary or middle button pans, the wheel zooms about the
//! pointer, a double click fits the scene.
//!
//! In edit mode ([`super::editing`]) the control points are handles: pressing on one selects
//! it, dragging it moves it (the edit is applied when the drag ends; meanwhile the edited
//! curve is drawn over the running one), and a panel shows the selected point's weight and
//! the knot, split, join, undo and redo buttons (Ctrl+Z, Ctrl+Shift+Z; Escape deselects).
//! Pressing anywhere else still moves the hand (the selection stays), so an edit can be felt
//! at once. The Voronoi region boundaries
//! of the rendered object ([`scene::regions::region_boundaries`]) are drawn faintly on request.
//!
//! While the rendered object deforms ([`super::moving_shape`]) its rest shape is drawn faint and its
//! current shape, as the loop last published it, over it.

use eframe::egui;
use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, StrokeKind, Vec2 as EVec2};
use friction::Mode;
use nurbs::Vec2;

use super::state::AppState;
use scene::regions::region_boundaries;

/// Screen pixels per newton of the force arrows (independent of the zoom).
pub const PX_PER_N: f32 = 30.0;
/// Screen points within which a press picks a control point's handle.
pub const HANDLE_PICK_PX: f32 = 8.0;
/// Screen length of the drawn region boundaries.
pub const REGION_RAY_PX: f32 = 70.0;

/// One line on a tick, as the 2-D and 3-D views print it over the scene: the mode, the
/// normal, friction and total force, and the depth.
pub fn tick_summary(k: &host::tick::Tick) -> String {
    format!(
        "{}  F_N {:.2} N  F_T {:+.2} N  |F| {:.2} N  depth {:.2} mm",
        k.mode.name(),
        k.normal_force_n,
        k.friction_force_n,
        k.force.length(),
        k.depth_m.max(0.0) * 1e3
    )
}

/// One line on a deforming object, as the 2-D and 3-D views print it: how far it moved at
/// the CP, and that the faint shape is its rest shape.
pub fn deform_summary(state: &AppState) -> String {
    match state.latest().and_then(|s| s.tick.deform) {
        Some(w) => format!(
            "deforming: moved {:.2} mm at the CP (rest shape faint)",
            w.length() * 1e3
        ),
        None => "deforming (rest shape faint)".to_owned(),
    }
}

/// The colour of a friction mode: the bands of `sim --plot`, deepened for lines on white.
pub fn mode_colour(mode: Mode) -> Color32 {
    let c = crate::plot::mode_colour(mode);
    let deepen = |v: u8| (f32::from(v) * 0.8) as u8;
    Color32::from_rgb(deepen(c.0), deepen(c.1), deepen(c.2))
}

/// Where the view looks: the device-frame point at the centre of the view and the zoom.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View2d {
    /// Device-frame point at the centre (m).
    pub centre: Vec2,
    /// Screen points per metre.
    pub scale: f32,
    /// Fit to the scene at the next frame.
    pub fit_pending: bool,
    /// Where on the screen the view was last drawn.
    pub last_rect: Option<Rect>,
}

impl Default for View2d {
    fn default() -> Self {
        View2d {
            centre: Vec2::new(0.0, 0.09),
            scale: 4000.0,
            fit_pending: true,
            last_rect: None,
        }
    }
}

impl View2d {
    /// The screen position of device-frame point `p` (m) in a view drawn in `rect`.
    pub fn screen_of(&self, rect: Rect, p: Vec2) -> Pos2 {
        let c = rect.center();
        Pos2::new(
            c.x + (p.x - self.centre.x) * self.scale,
            c.y - (p.y - self.centre.y) * self.scale,
        )
    }

    /// The device-frame point (m) at screen position `p` of a view drawn in `rect`.
    pub fn device_of(&self, rect: Rect, p: Pos2) -> Vec2 {
        let c = rect.center();
        Vec2::new(
            self.centre.x + (p.x - c.x) / self.scale,
            self.centre.y - (p.y - c.y) / self.scale,
        )
    }

    /// Centres `bounds` (with the hand's start) in `rect` with a margin.
    pub fn fit(&mut self, rect: Rect, (lo, hi): (Vec2, Vec2), include: Vec2) {
        let (lo, hi) = (lo.min(include), hi.max(include));
        let size = (hi - lo).max(Vec2::splat(0.01));
        self.centre = (lo + hi) * 0.5;
        self.scale = (rect.width() / size.x).min(rect.height() / size.y) * 0.8;
        self.fit_pending = false;
    }
}

/// The 2-D view, filling the space it is given.
pub fn view_2d_ui(ui: &mut egui::Ui, state: &mut AppState, view: &mut View2d) {
    let size = ui.available_size();
    let (response, painter) = ui.allocate_painter(size, Sense::click_and_drag());
    let rect = response.rect;
    view.last_rect = Some(rect);
    painter.rect_filled(rect, 0.0, Color32::from_gray(250));

    if !state.scene.is_planar() {
        let names: Vec<&str> = state
            .scene
            .objects
            .iter()
            .map(|o| o.name.as_str())
            .collect();
        painter.text(
            rect.center(),
            Align2::CENTER_CENTER,
            format!(
                "3-D view comes later.\n\n{} has no object of planar curves ({}).\n\
                 The pantograph is planar: it renders nothing for this scene.\n\
                 Open a planar scene (thesis-2d, examples) to feel it.",
                state.scene.label,
                names.join(", ")
            ),
            FontId::proportional(16.0),
            Color32::from_gray(60),
        );
        return;
    }

    if view.fit_pending || response.double_clicked() {
        view.fit(rect, state.scene.bounds, haptic_start());
    }
    // Two buttons in the top right corner: fit the scene, or the device's whole workspace.
    let buttons = Rect::from_min_size(
        rect.right_top() + EVec2::new(-230.0, 6.0),
        EVec2::new(224.0, 24.0),
    );
    // The editing toggles, bottom right above the scale bars (the title runs along the top).
    let toggles = Rect::from_min_size(
        rect.right_bottom() + EVec2::new(-160.0, -84.0),
        EVec2::new(154.0, 24.0),
    );
    ui.scope_builder(egui::UiBuilder::new().max_rect(toggles), |ui| {
        ui.horizontal(|ui| {
            ui.checkbox(&mut state.edit.enabled, "edit")
                .on_hover_text("control points become handles");
            ui.checkbox(&mut state.edit.show_regions, "regions")
                .on_hover_text("the Voronoi region boundaries of the rendered object");
        });
    });
    ui.scope_builder(egui::UiBuilder::new().max_rect(buttons), |ui| {
        ui.horizontal(|ui| {
            if ui.button("fit scene").clicked() {
                view.fit(rect, state.scene.bounds, haptic_start());
            }
            if ui.button("fit workspace").clicked() {
                let reach = &state.reach;
                let b = reach.safety_box;
                view.fit(rect, (b.min_in_device, b.max_in_device), haptic_start());
            }
        });
    });

    // Pan with the secondary or middle button, zoom with the wheel about the pointer.
    if response.dragged_by(egui::PointerButton::Secondary)
        || response.dragged_by(egui::PointerButton::Middle)
    {
        let d = response.drag_delta();
        view.centre -= Vec2::new(d.x, -d.y) / view.scale;
    }
    if response.hovered() {
        let (scroll, zoom) = ui.input(|i| (i.smooth_scroll_delta().y, i.zoom_delta()));
        let factor = zoom * (scroll / 200.0).exp();
        if (factor - 1.0).abs() > 1e-4
            && let Some(at) = response.hover_pos()
        {
            let anchor = view.device_of(rect, at);
            view.scale = (view.scale * factor).clamp(200.0, 200_000.0);
            let moved = view.device_of(rect, at);
            view.centre += anchor - moved;
        }
    }
    let primary_down = ui.input(|i| i.pointer.primary_down());
    if state.edit.enabled {
        edit_input(ui, &response, rect, view, state, primary_down);
    } else {
        state.edit.drag = None;
    }
    // The hand: press and drag with the primary button (not on a handle).
    if state.edit.drag.is_none() && response.is_pointer_button_down_on() && primary_down {
        if let Some(p) = response.interact_pointer_pos() {
            let over_s = pointer_interval_s(ui, state.dragging);
            state.dragging = true;
            state.glide_hand_to(view.device_of(rect, p), over_s);
        }
    } else {
        state.dragging = false;
    }

    let painter = painter.with_clip_rect(rect);
    draw_reach(&painter, rect, view, state);
    if state.edit.show_regions {
        draw_regions(&painter, rect, view, state);
    }
    draw_scene(&painter, rect, view, state);
    if state.edit.enabled {
        draw_handles(&painter, rect, view, state);
    }
    draw_hand(&painter, rect, view, state);
    draw_legend(&painter, rect, view, state);
    if let Some(hint) = state.hand_hint() {
        // Bottom left, above the scale bars; stronger while the user drags.
        let area = Rect::from_min_size(
            rect.left_bottom() + EVec2::new(8.0, -120.0),
            EVec2::new((rect.width() - 180.0).clamp(120.0, 520.0), 40.0),
        );
        let colour = if state.dragging {
            Color32::from_rgb(190, 30, 30)
        } else {
            Color32::from_rgb(150, 90, 0)
        };
        ui.scope_builder(egui::UiBuilder::new().max_rect(area), |ui| {
            ui.label(egui::RichText::new(hint).color(colour));
        });
    }
    if state.edit.enabled {
        let panel = Rect::from_min_size(
            rect.right_top() + EVec2::new(-300.0, 72.0),
            EVec2::new(294.0, 240.0),
        );
        ui.scope_builder(egui::UiBuilder::new().max_rect(panel), |ui| {
            if let Some(action) = state.edit.ui(ui, &state.scene.model) {
                state.edit_action(action);
            }
        });
    }
}

/// Presses on handles, the drag of a control point, and the undo/redo shortcuts.
fn edit_input(
    ui: &egui::Ui,
    response: &egui::Response,
    rect: Rect,
    view: &View2d,
    state: &mut AppState,
    primary_down: bool,
) {
    let (pressed, origin, latest) = ui.input(|i| {
        (
            i.pointer.primary_pressed(),
            i.pointer.press_origin(),
            i.pointer.latest_pos(),
        )
    });
    if pressed
        && response.hovered()
        && let Some(p) = origin
    {
        // A press elsewhere moves the hand and keeps the selection, so that the selected
        // point's weight can be changed while feeling the curve; Escape deselects.
        if let Some(at) = state.handle_near(view.device_of(rect, p), HANDLE_PICK_PX / view.scale) {
            state.begin_point_drag(at);
        }
    }
    if ui.input(|i| i.key_pressed(egui::Key::Escape)) {
        state.select_point(None);
    }
    if state.edit.drag.is_some() {
        if primary_down {
            if let Some(p) = latest {
                state.drag_point_to(view.device_of(rect, p));
            }
        } else {
            state.end_point_drag();
        }
    }
    let no_text_focus = ui.memory(|m| m.focused().is_none());
    if no_text_focus {
        let redo = egui::KeyboardShortcut::new(
            egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
            egui::Key::Z,
        );
        let undo = egui::KeyboardShortcut::new(egui::Modifiers::COMMAND, egui::Key::Z);
        // Redo first: the undo shortcut also matches with Shift held.
        if ui.input_mut(|i| i.consume_shortcut(&redo)) {
            state.redo();
        } else if ui.input_mut(|i| i.consume_shortcut(&undo)) {
            state.undo();
        }
    }
}

fn draw_regions(painter: &egui::Painter, rect: Rect, view: &View2d, state: &AppState) {
    let Some(object) = state
        .scene
        .rendered
        .and_then(|i| state.scene.model.object(i))
    else {
        return;
    };
    let colour = Color32::from_rgba_unmultiplied(130, 70, 170, 120);
    for b in region_boundaries(object, REGION_RAY_PX / view.scale) {
        let ends = [view.screen_of(rect, b.from), view.screen_of(rect, b.to)];
        if b.bisector {
            painter.add(Shape::dashed_line(
                &ends,
                Stroke::new(1.0, colour),
                5.0,
                4.0,
            ));
        } else {
            painter.line_segment(ends, Stroke::new(1.0, colour));
        }
    }
}

/// The control points as handles, the selected one highlighted, and a dragged point's
/// edited curves (or why the edit would be refused).
fn draw_handles(painter: &egui::Painter, rect: Rect, view: &View2d, state: &AppState) {
    let selected_fill = Color32::from_rgb(235, 140, 30);
    if let Some(drag) = &state.edit.drag
        && drag.to != drag.from
    {
        match &drag.preview {
            Ok((_, preview)) => {
                if let Some(o) = preview.objects.get(drag.at.object) {
                    let stroke = Stroke::new(2.0, selected_fill);
                    for curve in &o.curves {
                        let pts: Vec<Pos2> =
                            curve.iter().map(|p| view.screen_of(rect, *p)).collect();
                        painter.line(pts, stroke);
                    }
                    for poly in &o.control_polygons {
                        let pts: Vec<Pos2> =
                            poly.iter().map(|p| view.screen_of(rect, *p)).collect();
                        painter.add(Shape::dashed_line(
                            &pts,
                            Stroke::new(1.0, selected_fill),
                            4.0,
                            3.0,
                        ));
                    }
                }
            }
            Err(e) => {
                painter.text(
                    view.screen_of(rect, drag.to) + EVec2::new(10.0, 10.0),
                    Align2::LEFT_TOP,
                    e,
                    FontId::proportional(12.0),
                    Color32::from_rgb(190, 30, 30),
                );
            }
        }
    }
    for (i, o) in state.scene.objects.iter().enumerate() {
        for (k, poly) in o.control_polygons.iter().enumerate() {
            for (j, p) in poly.iter().enumerate() {
                let at = scene::edit::PointRef::new(i, k, j);
                let dragged = state.edit.drag.as_ref().filter(|d| d.at == at);
                let p = dragged.map_or(*p, |d| d.to);
                let c = view.screen_of(rect, p);
                if state.edit.selected == Some(at) {
                    painter.circle_filled(c, 6.0, selected_fill);
                    painter.circle_stroke(c, 6.0, Stroke::new(1.5, Color32::BLACK));
                } else {
                    painter.circle_filled(c, 4.5, Color32::WHITE);
                    painter.circle_stroke(c, 4.5, Stroke::new(1.5, Color32::from_gray(60)));
                }
            }
        }
    }
}

fn haptic_start() -> Vec2 {
    host::planar::START_HIP
}

fn draw_reach(painter: &egui::Painter, rect: Rect, view: &View2d, state: &AppState) {
    let reach = &state.reach;
    let stroke = Stroke::new(1.0, Color32::from_gray(170));
    for [a, b] in &reach.outline {
        painter.line_segment([view.screen_of(rect, *a), view.screen_of(rect, *b)], stroke);
    }
    let boxed = |b: &device::spec::WorkspaceBox, colour: Color32| {
        let r = Rect::from_two_pos(
            view.screen_of(rect, b.min_in_device),
            view.screen_of(rect, b.max_in_device),
        );
        painter.rect_stroke(r, 0.0, Stroke::new(1.0, colour), StrokeKind::Middle);
    };
    boxed(&reach.guaranteed, Color32::from_rgb(150, 190, 150));
    boxed(&reach.safety_box, Color32::from_rgb(225, 150, 110));
}

fn draw_scene(painter: &egui::Painter, rect: Rect, view: &View2d, state: &AppState) {
    let polygon = Stroke::new(1.0, Color32::from_gray(150));
    let moving = state
        .deform
        .moving_view
        .as_ref()
        .zip(state.deform.info.as_ref())
        .filter(|(_, info)| state.scene.rendered == Some(info.object));
    for (i, o) in state.scene.objects.iter().enumerate() {
        let rendered = state.scene.rendered == Some(i);
        if let Some((now, _)) = moving.filter(|(_, info)| info.object == i) {
            draw_moving(painter, rect, view, o, now);
            continue;
        }
        for poly in &o.control_polygons {
            let pts: Vec<Pos2> = poly.iter().map(|p| view.screen_of(rect, *p)).collect();
            painter.add(Shape::dashed_line(&pts, polygon, 4.0, 3.0));
            for p in &pts {
                painter.rect_filled(
                    Rect::from_center_size(*p, EVec2::splat(5.0)),
                    0.0,
                    polygon.color,
                );
            }
        }
        let stroke = if rendered {
            Stroke::new(3.0, Color32::from_rgb(30, 30, 30))
        } else {
            Stroke::new(1.5, Color32::from_gray(120))
        };
        for curve in &o.curves {
            let pts: Vec<Pos2> = curve.iter().map(|p| view.screen_of(rect, *p)).collect();
            painter.line(pts, stroke);
        }
    }
}

/// A deforming object: its rest shape `rest` faint, its current shape `now` (curves and control
/// polygons) over it as the rendered object is drawn.
fn draw_moving(
    painter: &egui::Painter,
    rect: Rect,
    view: &View2d,
    rest: &super::scene_view::ObjectView,
    now: &super::scene_view::ObjectView,
) {
    let faint = Stroke::new(2.0, Color32::from_rgba_unmultiplied(90, 110, 160, 90));
    for curve in &rest.curves {
        let pts: Vec<Pos2> = curve.iter().map(|p| view.screen_of(rect, *p)).collect();
        painter.line(pts, faint);
    }
    let polygon = Stroke::new(1.0, Color32::from_gray(150));
    for poly in &now.control_polygons {
        let pts: Vec<Pos2> = poly.iter().map(|p| view.screen_of(rect, *p)).collect();
        painter.add(Shape::dashed_line(&pts, polygon, 4.0, 3.0));
        for p in &pts {
            painter.rect_filled(
                Rect::from_center_size(*p, EVec2::splat(5.0)),
                0.0,
                polygon.color,
            );
        }
    }
    for curve in &now.curves {
        let pts: Vec<Pos2> = curve.iter().map(|p| view.screen_of(rect, *p)).collect();
        painter.line(pts, Stroke::new(3.0, Color32::from_rgb(30, 30, 30)));
    }
}

fn draw_hand(painter: &egui::Painter, rect: Rect, view: &View2d, state: &AppState) {
    let command = view.screen_of(rect, state.hand_target);
    let Some(s) = state.latest() else {
        cross(painter, command, Color32::from_rgb(90, 90, 200));
        return;
    };
    // The target follows the command (the pointer) at a bounded speed.
    let target = view.screen_of(rect, s.hand_target);
    if (command - target).length() > 2.0 {
        painter.line_segment(
            [command, target],
            Stroke::new(1.0, Color32::from_rgb(190, 190, 230)),
        );
    }
    let k = &s.tick;
    let xy = |v: nurbs::Vec3| Vec2::new(v.x, v.y);
    let hip = view.screen_of(rect, xy(k.hip));
    // The hand's spring, target to handle.
    painter.add(Shape::dashed_line(
        &[target, hip],
        Stroke::new(1.0, Color32::from_rgb(90, 90, 200)),
        3.0,
        3.0,
    ));
    cross(painter, target, Color32::from_rgb(90, 90, 200));
    let colour = mode_colour(k.mode);
    if k.mode != Mode::Free {
        let cp = view.screen_of(rect, xy(k.cp));
        let go = view.screen_of(rect, xy(k.go));
        painter.line_segment([hip, go], Stroke::new(1.0, Color32::from_gray(90)));
        painter.circle_stroke(cp, 4.0, Stroke::new(2.0, Color32::from_rgb(40, 110, 200)));
        painter.circle_filled(go, 4.5, colour);
        painter.circle_stroke(go, 4.5, Stroke::new(1.0, Color32::BLACK));
    }
    painter.circle_filled(hip, HAND_DOT_PX, colour);
    painter.circle_stroke(hip, HAND_DOT_PX, Stroke::new(1.5, Color32::BLACK));
    if k.mode != Mode::Free {
        // Over the dot, from its rim: a force of 0.2 N is 6 px, which the dot used to hide.
        let arrow = |v: nurbs::Vec3, colour: Color32, width: f32| {
            if let Some((from, d)) = force_arrow(hip, v) {
                painter.arrow(from, d, Stroke::new(width, colour));
            }
        };
        arrow(
            k.normal * k.normal_force_n,
            Color32::from_rgb(40, 110, 200),
            2.5,
        );
        arrow(k.friction, colour, 2.5);
        arrow(k.force, Color32::from_gray(30), 1.0);
    }
}

/// The radius of the hand's dot (px).
pub const HAND_DOT_PX: f32 = 6.0;

/// Where a force arrow starts and its vector on screen (y up in the device, down on screen):
/// from the rim of the hand's dot at `hip`, [`PX_PER_N`] per newton beyond it, so that the
/// scale bar measures it and no force hides under the dot. `None` below 1/30 N (1 px).
pub fn force_arrow(hip: Pos2, force: nurbs::Vec3) -> Option<(Pos2, EVec2)> {
    let d = EVec2::new(force.x, -force.y) * PX_PER_N;
    let length = d.length();
    (length >= 1.0).then(|| (hip + d * (HAND_DOT_PX / length), d))
}

fn cross(painter: &egui::Painter, at: Pos2, colour: Color32) {
    let s = Stroke::new(1.5, colour);
    painter.line_segment([at - EVec2::new(6.0, 0.0), at + EVec2::new(6.0, 0.0)], s);
    painter.line_segment([at - EVec2::new(0.0, 6.0), at + EVec2::new(0.0, 6.0)], s);
}

fn draw_legend(painter: &egui::Painter, rect: Rect, view: &View2d, state: &AppState) {
    let font = FontId::proportional(13.0);
    let text = Color32::from_gray(40);
    let mut y = rect.top() + 8.0;
    let x = rect.left() + 10.0;
    let line = |y: &mut f32, s: String, c: Color32| {
        painter.text(Pos2::new(x, *y), Align2::LEFT_TOP, s, font.clone(), c);
        *y += 17.0;
    };
    if let Some(i) = state.scene.rendered
        && let Some(o) = state.scene.objects.get(i)
    {
        line(&mut y, format!("{}: {}", state.scene.label, o.name), text);
    }
    if let Some(s) = state.latest() {
        let k = &s.tick;
        line(&mut y, tick_summary(k), mode_colour(k.mode));
    }
    if state.deform.moving_view.is_some() {
        line(
            &mut y,
            deform_summary(state),
            Color32::from_rgb(70, 90, 150),
        );
    }
    let help = if state.edit.enabled {
        "edit: drag a handle: move its point  ·  elsewhere: hand  ·  Ctrl+Z: undo"
    } else {
        "drag: hand  ·  right-drag: pan  ·  wheel: zoom  ·  double-click: fit the scene"
    };
    line(&mut y, help.into(), Color32::from_gray(110));
    // Key, bottom left.
    let mut y = rect.bottom() - 8.0 - 17.0 * 4.0;
    let key = [
        (
            "big dot: HIP, coloured by the friction mode",
            Color32::from_gray(40),
        ),
        (
            "blue ring: CP  ·  small dot: GO  ·  cross: hand target",
            Color32::from_rgb(40, 110, 200),
        ),
        (
            "arrows: blue normal, coloured friction, black total",
            Color32::from_gray(40),
        ),
        (
            "green box: guaranteed workspace  ·  orange: safety box  ·  grey: reach",
            Color32::from_gray(110),
        ),
    ];
    for (s, c) in key {
        line(&mut y, s.to_owned(), c);
    }
    // Scale bar, bottom right: 10 mm, and the force scale.
    let bar = 0.01 * view.scale;
    let right = rect.right() - 12.0;
    let bottom = rect.bottom() - 12.0;
    let s = Stroke::new(2.0, Color32::from_gray(60));
    painter.line_segment(
        [Pos2::new(right - bar, bottom), Pos2::new(right, bottom)],
        s,
    );
    painter.text(
        Pos2::new(right - bar * 0.5, bottom - 4.0),
        Align2::CENTER_BOTTOM,
        "10 mm",
        font.clone(),
        text,
    );
    painter.line_segment(
        [
            Pos2::new(right - PX_PER_N, bottom - 26.0),
            Pos2::new(right, bottom - 26.0),
        ],
        Stroke::new(2.0, Color32::from_rgb(40, 110, 200)),
    );
    painter.text(
        Pos2::new(right - PX_PER_N - 6.0, bottom - 26.0),
        Align2::RIGHT_CENTER,
        "1 N",
        font,
        text,
    );
}

/// The longest a pointer sample is stretched over (s): a drag seen at 2 frames a second or
/// more glides; a longer gap (the app idle before the press) is not a pace.
pub(crate) const MAX_POINTER_INTERVAL_S: f32 = 0.5;

/// How long the hand takes to reach the pointer's new position: the time since the previous
/// frame while a drag goes on (the pointer covered the way in that time, so the loop plays it
/// back at that pace, one frame late, whatever the frame rate), 0 at the press (the hand goes
/// to where the button went down as fast as it goes).
pub(crate) fn pointer_interval_s(ui: &egui::Ui, dragging: bool) -> f32 {
    if dragging {
        ui.input(|i| i.unstable_dt)
            .clamp(0.0, MAX_POINTER_INTERVAL_S)
    } else {
        0.0
    }
}
