//! Pure geometry of a planar object's Voronoi regions (thesis §2.2), as the tracker switches
//! between features: what the app's 2-D view draws on request.

use nurbs::Vec2;
use tracker::{Chain, VertexKind};

use crate::Object;

/// A boundary between the Voronoi regions of two features of a chain, drawn from a vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegionBoundary {
    /// Index of the vertex in [`tracker::Chain::vertices`].
    pub vertex: usize,
    /// The segment (m).
    pub from: Vec2,
    /// Its other end (m).
    pub to: Vec2,
    /// Whether it is the bisector between the two curves' regions (where they overlap),
    /// rather than a normal line at a curve's end.
    pub bisector: bool,
}

/// The Voronoi region boundaries of a planar object's chain, `length_m` long from each vertex
/// (the tracker's definition, `tracker::Vertex::region`): at a convex vertex the two rays
/// along the adjacent curves' end normals bound the external vertex wedge and the inward
/// bisector of the normals splits the curves' regions inside; at a reflex vertex the same,
/// mirrored (an internal wedge, an external bisector); at a smooth join and at a free end,
/// the normal line through the vertex. Empty for an object that is not a valid chain.
pub fn region_boundaries(object: &Object, length_m: f32) -> Vec<RegionBoundary> {
    let Some(curves) = object.curve_views() else {
        return Vec::new();
    };
    let Ok(chain) = Chain::new(&curves) else {
        return Vec::new();
    };
    let normal = |t: Vec2| Vec2::new(t.y, -t.x);
    let mut out = Vec::new();
    for (k, v) in chain.vertices().iter().enumerate() {
        let (n_in, n_out) = (normal(v.t_in), normal(v.t_out));
        let at = v.position;
        let mut ray = |d: Vec2, bisector: bool| {
            out.push(RegionBoundary {
                vertex: k,
                from: at,
                to: at + d * length_m,
                bisector,
            });
        };
        let bisector = (n_in + n_out).normalize_or_zero();
        match v.kind {
            VertexKind::Convex => {
                ray(n_in, false);
                ray(n_out, false);
                ray(-bisector, true);
            }
            VertexKind::Reflex => {
                ray(-n_in, false);
                ray(-n_out, false);
                ray(bisector, true);
            }
            VertexKind::Smooth | VertexKind::End => {
                ray(n_out, false);
                ray(-n_out, false);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Scene;
    use tracker::Feature;

    /// Points just either side of the middle of every boundary drawn fall in different
    /// features of the tracker's own definition (`tracker::Vertex::region`): a vertex's wedge
    /// and a curve across a normal ray, the two curves across a bisector.
    fn check_boundaries(object: &Object) -> Vec<(VertexKind, usize, usize)> {
        let length = 0.01;
        let boundaries = region_boundaries(object, length);
        let curves = object.curve_views().expect("planar");
        let chain = Chain::new(&curves).expect("a chain");
        for b in &boundaries {
            let d = b.to - b.from;
            assert!((d.length() - length).abs() < 1e-6, "{b:?}");
            let mid = b.from + d * 0.5;
            let side = Vec2::new(-d.y, d.x) * 1e-3;
            let v = &chain.vertices()[b.vertex];
            let (left, right) = (
                v.region(b.vertex as u16, mid + side),
                v.region(b.vertex as u16, mid - side),
            );
            assert_ne!(left, right, "{b:?}");
            let vertex = |f: Feature| matches!(f, Feature::Vertex(_));
            if b.bisector {
                assert!(!vertex(left) && !vertex(right), "{b:?}: {left:?} {right:?}");
            } else if v.kind != VertexKind::Smooth {
                assert!(vertex(left) != vertex(right), "{b:?}: {left:?} {right:?}");
            }
        }
        // Per vertex: its kind, its boundaries, how many of them are bisectors.
        chain
            .vertices()
            .iter()
            .enumerate()
            .map(|(k, v)| {
                let mine = boundaries.iter().filter(|b| b.vertex == k);
                (
                    v.kind,
                    mine.clone().count(),
                    mine.filter(|b| b.bisector).count(),
                )
            })
            .collect()
    }

    fn thesis() -> Scene {
        Scene::from_json_str(include_str!("../../../scenes/thesis-2d.json")).expect("thesis")
    }

    /// The open arch of thesis-2d: two free ends (a normal line each) and a convex apex (two
    /// outward normal rays bounding the vertex's wedge, the inward bisector).
    #[test]
    fn region_boundaries_of_a_convex_vertex_and_free_ends() {
        let kinds = check_boundaries(&thesis().objects()[0]);
        assert_eq!(
            kinds,
            [
                (VertexKind::End, 2, 0),
                (VertexKind::Convex, 3, 1),
                (VertexKind::End, 2, 0)
            ]
        );
    }

    /// A reflex corner (two inward normal rays, the outward bisector) and a smooth join (the
    /// normal line: an arc split in two).
    #[test]
    fn region_boundaries_of_reflex_and_smooth_vertices() {
        let json = r#"{ "format": "scene/1", "objects": [ { "name": "notch",
            "material": { "stiffness_n_per_m": 500, "damping_ns_per_m": 0,
                          "mu_static": 0.5, "mu_dynamic": 0.4 },
            "patches": [
              { "degree": 1, "knots": [0, 0, 1, 1], "points": [[-0.02, 0.1], [0, 0.1]] },
              { "degree": 1, "knots": [0, 0, 1, 1], "points": [[0, 0.1], [0.02, 0.09]] } ] } ] }"#;
        let notch = Scene::from_json_str(json).expect("notch");
        assert_eq!(
            check_boundaries(&notch.objects()[0])[1],
            (VertexKind::Reflex, 3, 1)
        );
        let split = crate::edit::split_patch(&thesis(), 0, 0, 0.5).expect("split");
        assert_eq!(
            check_boundaries(&split.objects()[0])[1],
            (VertexKind::Smooth, 2, 0)
        );
    }
}
