//! The app's side of a deformable object (one with a `"dynamics"` block): the *deform* switch
//! of the objects panel, what it says about the object's dynamics, and the moving shape the
//! loop publishes ([`host::deform::SharedShape`]), read when a frame is drawn and turned into
//! what the 2-D view ([`ObjectView`]) and the 3-D view ([`super::view3d::Scene3d::set_moving`])
//! draw over the faint rest shape.

use std::sync::Arc;

use host::deform::{DeformChangeError, DeformStatus, ShapeFrame, SharedShape};
use scene::{Object, Patch, Scene};

use super::scene_view::ObjectView;

/// What the objects panel says about a deformable object.
#[derive(Clone, Debug, PartialEq)]
pub struct DeformInfo {
    /// Its index in the scene.
    pub object: usize,
    /// Whether it is a surface (the parameters are per area) or a curve (per length).
    pub surface: bool,
    /// Tension: N (curve) or N/m (surface).
    pub tension: f64,
    /// Density: kg/m or kg/m².
    pub density: f64,
    /// Damping: N·s/m² or N·s/m³.
    pub damping: f64,
    /// Bending stiffness: N·m² or N·m.
    pub bending: f64,
    /// Its lowest natural frequency about the rest shape (Hz), or why it has none.
    pub lowest_mode_hz: Result<f64, String>,
    /// The object at rest.
    pub rest: Object,
}

impl DeformInfo {
    /// Object `index` of `scene`, when it has a `"dynamics"` block.
    pub fn of(scene: &Scene, index: usize) -> Option<Self> {
        let object = scene.object(index)?;
        let params = object.dynamics()?;
        let surface = matches!(object.patches().first(), Some(Patch::Surface(_)));
        let lowest_mode_hz = match object.body() {
            Some(Ok(body)) => body.lowest_mode_hz().map_err(|e| e.message(surface)),
            Some(Err(e)) => Err(e.message(surface)),
            None => Err("rigid".to_owned()),
        };
        Some(DeformInfo {
            object: index,
            surface,
            tension: params.tension,
            density: params.density,
            damping: params.damping,
            bending: params.bending,
            lowest_mode_hz,
            rest: object.clone(),
        })
    }

    /// The hover text of the *deform* switch: what it does and the parameters.
    pub fn describe(&self) -> String {
        let (t, rho, gamma, beta) = if self.surface {
            ("N/m", "kg/m²", "N·s/m³", "N·m")
        } else {
            ("N", "kg/m", "N·s/m²", "N·m²")
        };
        let mode = match &self.lowest_mode_hz {
            Ok(f) => format!("{f:.1} Hz"),
            Err(e) => format!("none ({e})"),
        };
        format!(
            "The hand pushes the object and it moves (D-NURBS: mass, damping and stiffness \
             on its control points, stepped every 1 ms), drawn over its rest shape, faint; \
             off, it is rigid at rest again.\n\
             tension {} {t}, density {} {rho}, damping {} {gamma}, bending {} {beta}\n\
             first natural frequency {mode}",
            shortest(self.tension),
            shortest(self.density),
            shortest(self.damping),
            shortest(self.bending)
        )
    }
}

/// A parameter as the scene file says it: the scene reads numbers as `f32` (the loop's type)
/// and the dynamics widen them to f64, so 0.1 is 0.10000000149011612 there; the shortest
/// decimal that reads back as the same `f32` is what the user wrote.
fn shortest(value: f64) -> String {
    format!("{}", value as f32)
}

/// The *deform* switch and the moving shape, as the app knows them.
#[derive(Debug, Default)]
pub struct DeformState {
    /// Whether the user asked the object felt to deform (the switch).
    pub requested: bool,
    /// Whether the loop said it deforms.
    pub deforming: bool,
    /// The object felt, when it is deformable.
    pub info: Option<DeformInfo>,
    /// Why the last switch was refused.
    pub error: Option<String>,
    /// Where the loop of the object felt publishes its shape.
    shape: Option<Arc<SharedShape>>,
    /// The newest shape read.
    frame: ShapeFrame,
    /// The moving shape, while the object deforms.
    pub moving: Option<Object>,
    /// The moving shape as the 2-D view draws it (planar objects).
    pub moving_view: Option<ObjectView>,
}

impl DeformState {
    /// The switch off for a scene just shown whose felt object is `felt`; the request stays
    /// (the app asks the new loop again when the new object deforms too). Returns whether to
    /// ask.
    pub fn scene_shown(&mut self, scene: &Scene, felt: Option<usize>) -> bool {
        self.info = felt.and_then(|i| DeformInfo::of(scene, i));
        self.deforming = false;
        self.shape = None;
        self.frame = ShapeFrame::default();
        self.moving = None;
        self.moving_view = None;
        if self.info.is_none() {
            self.requested = false;
        }
        self.requested
    }

    /// Takes in a loop's answer to the switch.
    pub fn on_reply(&mut self, reply: Result<DeformStatus, DeformChangeError>) {
        match reply {
            Ok(status) => {
                self.deforming = status.deforming;
                self.requested = status.deforming;
                self.shape = Some(status.shape);
                self.error = None;
                if !status.deforming {
                    self.moving = None;
                    self.moving_view = None;
                }
            }
            Err(e) => {
                self.error = Some(e.to_string());
                self.refused();
            }
        }
    }

    /// The loop cannot deform (or refused): the switch goes off.
    pub fn refused(&mut self) {
        self.requested = false;
        self.deforming = false;
        self.moving = None;
        self.moving_view = None;
    }

    /// Reads the loop's newest shape (never waiting for the loop: it holds the lock only to
    /// copy); whether the moving shape changed.
    pub fn refresh(&mut self) -> bool {
        let Some(shape) = &self.shape else {
            return false;
        };
        if !shape.read_into(&mut self.frame) {
            return false;
        }
        self.deforming = self.frame.deforming;
        let moved = self
            .info
            .as_ref()
            .filter(|i| self.frame.deforming && i.object == self.frame.object)
            .and_then(|i| i.rest.reshaped(&self.frame.points).ok());
        self.moving_view = moved
            .as_ref()
            .filter(|o| o.curve_views().is_some())
            .map(|o| ObjectView::new(o).0);
        self.moving = moved;
        true
    }

    /// The object moving, while one does: its index, its rest shape and its current shape.
    pub fn moving_object(&self) -> Option<(usize, &Object, &Object)> {
        let info = self.info.as_ref()?;
        self.moving.as_ref().map(|o| (info.object, &info.rest, o))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The hover text gives the parameters as the scene file states them (the bundled
    /// string's `"density_kg_per_m": 0.1`), not their f32 → f64 widening.
    #[test]
    fn the_parameters_read_as_written() {
        let scene = scene::Bundled::find("deformable")
            .and_then(|b| b.scene().ok())
            .expect("the bundled deformable scene");
        let info = DeformInfo::of(&scene, 0).expect("object 0 deforms");
        let text = info.describe();
        assert!(text.contains("density 0.1 kg/m,"), "{text}");
        assert!(text.contains("tension 5 N,"), "{text}");
        assert!(!text.contains("0000000"), "{text}");
    }
}
