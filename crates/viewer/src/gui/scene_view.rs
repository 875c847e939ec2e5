//! The running scene as the 2-D view draws it: each object's curves sampled for display,
//! their control polygons, and the bounds of everything (spatial patches included).

use nurbs::Vec2;
use scene::{Object, Patch, Scene, Space};

/// Points per curve patch drawn in the 2-D view (for display only).
pub const CURVE_SAMPLES: usize = 256;

/// One object as the 2-D view draws it.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectView {
    /// Its name.
    pub name: String,
    /// Planar or spatial.
    pub space: Space,
    /// Each patch sampled along its parameter (planar curves; empty for surfaces).
    pub curves: Vec<Vec<Vec2>>,
    /// Each patch's control polygon (x, y of the control points).
    pub control_polygons: Vec<Vec<Vec2>>,
}

/// A scene as the UI knows it.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneView {
    /// Where it came from (a bundled name or a path).
    pub label: String,
    /// Its objects.
    pub objects: Vec<ObjectView>,
    /// The object the device renders.
    pub rendered: Option<usize>,
    /// Bounding box of everything drawn (m): min, max.
    pub bounds: (Vec2, Vec2),
    /// The scene itself, which edits start from.
    pub model: Scene,
}

impl ObjectView {
    /// The drawable geometry of `o`, and the points of its spatial patches (projected on
    /// z = 0: not drawn in the 2-D view, they still bound the scene).
    pub fn new(o: &Object) -> (Self, Vec<Vec2>) {
        let mut curves = Vec::new();
        let mut control_polygons = Vec::new();
        let mut extra = Vec::new();
        for p in o.patches() {
            match p {
                Patch::Curve2(c) => {
                    let view = c.view();
                    let (a, b) = view.domain();
                    let pts: Vec<Vec2> = (0..=CURVE_SAMPLES)
                        .map(|i| {
                            let u = a + (b - a) * i as f32 / CURVE_SAMPLES as f32;
                            view.point(u)
                        })
                        .collect();
                    curves.push(pts);
                    control_polygons.push(
                        (0..view.points().len())
                            .filter_map(|i| view.control_point(i).map(|(p, _)| p))
                            .collect(),
                    );
                }
                Patch::Curve3(c) => {
                    let dehom = c.points().iter().map(|h| Vec2::new(h.x / h.w, h.y / h.w));
                    extra.extend(dehom);
                }
                Patch::Surface(s) => {
                    let dehom = s.points().iter().map(|h| Vec2::new(h.x / h.w, h.y / h.w));
                    extra.extend(dehom);
                }
            }
        }
        let view = ObjectView {
            name: o.name().to_owned(),
            space: o.space(),
            curves,
            control_polygons,
        };
        (view, extra)
    }
}

impl SceneView {
    /// The drawable geometry of `scene`.
    pub fn new(label: &str, scene: &Scene, rendered: Option<usize>) -> Self {
        let mut objects = Vec::new();
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for o in scene.objects() {
            let (view, extra) = ObjectView::new(o);
            for p in view
                .curves
                .iter()
                .chain(&view.control_polygons)
                .flatten()
                .chain(&extra)
            {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
            objects.push(view);
        }
        if !(lo.is_finite() && hi.is_finite()) {
            (lo, hi) = (Vec2::new(-0.05, 0.05), Vec2::new(0.05, 0.13));
        }
        SceneView {
            label: label.to_owned(),
            objects,
            rendered,
            bounds: (lo, hi),
            model: scene.clone(),
        }
    }

    /// Whether the scene has an object the 2-D view and the device render.
    pub fn is_planar(&self) -> bool {
        self.rendered.is_some()
    }
}
