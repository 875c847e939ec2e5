//! The 3-D view's orbiting camera: projection, picking rays, the hand's plane and fitting.

use eframe::egui;
use egui::{Pos2, Rect};
use glam::{Mat4, Vec4};
use nurbs::Vec3;

/// The orbiting camera: it looks at `target` from `distance_m` away, from the direction given
/// by `yaw_rad` (about +z, from +x) and `pitch_rad` (above the x-y plane); z is up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera3d {
    /// The point looked at (m).
    pub target: Vec3,
    /// Azimuth of the eye about +z (rad).
    pub yaw_rad: f32,
    /// Elevation of the eye above the x-y plane (rad).
    pub pitch_rad: f32,
    /// Eye to target (m).
    pub distance_m: f32,
    /// Vertical field of view (rad).
    pub fov_y_rad: f32,
    /// Fit to the scene at the next frame.
    pub fit_pending: bool,
}

impl Default for Camera3d {
    fn default() -> Self {
        Camera3d {
            target: Vec3::new(0.0, 0.09, 0.0),
            yaw_rad: -60f32.to_radians(),
            pitch_rad: 22f32.to_radians(),
            distance_m: 0.25,
            fov_y_rad: 35f32.to_radians(),
            fit_pending: true,
        }
    }
}

impl Camera3d {
    /// The eye's position.
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw_rad.sin_cos();
        let (sp, cp) = self.pitch_rad.sin_cos();
        self.target + Vec3::new(cp * cy, cp * sy, sp) * self.distance_m
    }

    /// Unit view direction, eye to target.
    pub fn view_dir(&self) -> Vec3 {
        (self.target - self.eye()).normalize_or(Vec3::NEG_Z)
    }

    /// Clip-space transform for a viewport of `aspect` (width / height), wgpu depth [0, 1].
    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        let near = self.distance_m * 0.02;
        let far = self.distance_m * 20.0;
        Mat4::perspective_rh(self.fov_y_rad, aspect.max(1e-3), near, far)
            * Mat4::look_at_rh(self.eye(), self.target, Vec3::Z)
    }

    /// Where `p` appears in `rect` (None behind the eye).
    pub fn project(&self, rect: Rect, p: Vec3) -> Option<Pos2> {
        let clip = self.view_proj(rect.aspect_ratio()) * Vec4::new(p.x, p.y, p.z, 1.0);
        if clip.w <= 1e-9 {
            return None;
        }
        let ndc = clip / clip.w;
        Some(Pos2::new(
            rect.center().x + ndc.x * rect.width() * 0.5,
            rect.center().y - ndc.y * rect.height() * 0.5,
        ))
    }

    /// The ray from the eye through `pos` in `rect`: origin and unit direction.
    pub fn ray(&self, rect: Rect, pos: Pos2) -> (Vec3, Vec3) {
        // From the camera's own frame rather than the inverse of its matrix: metres near
        // 0.1 through a perspective inverse lose a micrometre in f32.
        let forward = self.view_dir();
        let right = forward.cross(Vec3::Z).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let half_h = (self.fov_y_rad * 0.5).tan();
        let half_w = half_h * rect.aspect_ratio();
        let ndc_x = (pos.x - rect.center().x) / (rect.width() * 0.5);
        let ndc_y = -(pos.y - rect.center().y) / (rect.height() * 0.5);
        let d = forward + right * (ndc_x * half_w) + up * (ndc_y * half_h);
        (self.eye(), d.normalize_or(forward))
    }

    /// Where the ray through `pos` meets the plane through `through` perpendicular to the
    /// view direction (the hand's plane); None when the ray runs parallel to it.
    pub fn on_view_plane(&self, rect: Rect, pos: Pos2, through: Vec3) -> Option<Vec3> {
        let (o, d) = self.ray(rect, pos);
        let n = self.view_dir();
        let den = d.dot(n);
        if den.abs() < 1e-6 {
            return None;
        }
        let t = (through - o).dot(n) / den;
        (t > 0.0).then(|| o + d * t)
    }

    /// Centres `bounds` (with `include`) in a view of `aspect` (width / height) at a
    /// distance that shows all of it: its bounding sphere within the narrower field of view.
    pub fn fit(&mut self, (lo, hi): (Vec3, Vec3), include: Vec3, aspect: f32) {
        let (lo, hi) = (lo.min(include), hi.max(include));
        self.target = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(0.005);
        let half_y = self.fov_y_rad * 0.5;
        let half_x = (half_y.tan() * aspect.max(0.1)).atan();
        self.distance_m = radius / half_y.min(half_x).sin() * 0.95;
        self.fit_pending = false;
    }

    /// The head light's direction (towards the light): from behind the eye, above and to
    /// the right of it, so that a bump seen from the front still shows its relief.
    pub fn light_dir(&self) -> Vec3 {
        let forward = self.view_dir();
        let right = forward.cross(Vec3::Z).normalize_or(Vec3::X);
        let up = right.cross(forward);
        (-forward + up * 0.7 + right * 0.35).normalize_or(-forward)
    }

    /// Orbits by a drag of `delta` points.
    pub fn orbit(&mut self, delta: egui::Vec2) {
        self.yaw_rad -= delta.x * 0.01;
        let limit = 89f32.to_radians();
        self.pitch_rad = (self.pitch_rad + delta.y * 0.01).clamp(-limit, limit);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hand's plane: a ray through the centre of the view meets the plane through the
    /// target at the target; one through a point 100 px to the right meets it to the right,
    /// at the distance the field of view gives (tan(fov/2) · d per half height).
    #[test]
    fn the_view_plane_follows_the_pointer() {
        let camera = Camera3d {
            target: Vec3::new(0.0, 0.09, 0.0),
            yaw_rad: 0.3,
            pitch_rad: 0.5,
            distance_m: 0.2,
            ..Camera3d::default()
        };
        let rect = Rect::from_min_size(Pos2::ZERO, egui::vec2(800.0, 600.0));
        let hit = camera
            .on_view_plane(rect, rect.center(), camera.target)
            .expect("hit");
        assert!((hit - camera.target).length() < 1e-6, "{hit}");
        let right = camera
            .on_view_plane(rect, rect.center() + egui::vec2(100.0, 0.0), camera.target)
            .expect("hit");
        let offset = right - camera.target;
        assert!(offset.dot(camera.view_dir()).abs() < 1e-6);
        let expected = (camera.fov_y_rad * 0.5).tan() * 0.2 * (100.0 / 300.0);
        assert!((offset.length() - expected).abs() < 1e-6, "{offset}");
        // And it projects back where the pointer is.
        let back = camera.project(rect, right).expect("in front");
        assert!((back - (rect.center() + egui::vec2(100.0, 0.0))).length() < 0.01);
    }
}
