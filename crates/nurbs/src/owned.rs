//! Owned curves and surfaces for the host (`alloc` feature). They validate once on
//! construction and hand out borrowed [`Curve`] / [`Surface`] views for evaluation.

use alloc::vec::Vec;
use glam::{Vec3, Vec4};

use crate::control::{check_control_point, largest_weight};
use crate::error::{At, Field, NurbsError};
use crate::knots::Knots;
use crate::point::Point;
use crate::{Curve, Surface};

/// A validated NURBS curve that owns its knots and homogeneous control points.
#[derive(Clone, Debug, PartialEq)]
pub struct CurveBuf<P: Point> {
    degree: usize,
    knots: Vec<f32>,
    points: Vec<P::Hom>,
}

impl<P: Point> CurveBuf<P> {
    /// Validates and takes ownership of homogeneous control points `(w·P, w)`.
    pub fn new(degree: usize, knots: Vec<f32>, points: Vec<P::Hom>) -> Result<Self, NurbsError> {
        Curve::<P>::new(degree, &knots, &points)?;
        Ok(CurveBuf {
            degree,
            knots,
            points,
        })
    }

    /// From Cartesian control points and optional weights (all 1 when `None`).
    pub fn from_cartesian(
        degree: usize,
        knots: Vec<f32>,
        points: &[P],
        weights: Option<&[f32]>,
    ) -> Result<Self, NurbsError> {
        if let Some(w) = weights
            && w.len() != points.len()
        {
            return Err(NurbsError::WeightCount {
                expected: points.len(),
                found: w.len(),
            });
        }
        let weight = |i: usize| weights.map_or(1.0, |w| w[i]);
        // Checked in Cartesian form, as given, with the rules `Curve::new` applies again to
        // the homogeneous points.
        let largest = largest_weight((0..points.len()).map(weight));
        let mut hom = Vec::with_capacity(points.len());
        for (i, &p) in points.iter().enumerate() {
            check_control_point(At::I(i), p, weight(i), largest)?;
            hom.push(p.weighted(weight(i)));
        }
        Self::new(degree, knots, hom)
    }

    /// The borrowed view used for evaluation.
    #[inline]
    pub fn view(&self) -> Curve<'_, P> {
        Curve::from_validated(
            Knots::from_validated(&self.knots, self.degree),
            &self.points,
        )
    }

    /// Degree.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Knot vector.
    pub fn knots(&self) -> &[f32] {
        &self.knots
    }

    /// Homogeneous control points.
    pub fn points(&self) -> &[P::Hom] {
        &self.points
    }

    /// The curve with `f` applied to every Cartesian control point. For an affine `f` this is
    /// exactly the image of the curve (affine invariance of NURBS).
    pub fn map_points(&self, f: impl Fn(P) -> P) -> Result<Self, NurbsError> {
        let pts: Vec<P::Hom> = self
            .points
            .iter()
            .map(|&h| {
                let (xw, w) = P::split(h);
                f(xw * (1.0 / w)).weighted(w)
            })
            .collect();
        Self::new(self.degree, self.knots.clone(), pts)
    }
}

/// A validated NURBS surface that owns its knots and homogeneous control net.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceBuf {
    degree: (usize, usize),
    knots_u: Vec<f32>,
    knots_v: Vec<f32>,
    count_v: usize,
    points: Vec<Vec4>,
}

impl SurfaceBuf {
    /// Validates and takes ownership of a homogeneous net, row-major with `i` along u and
    /// `count_v` points per row.
    pub fn new(
        degree: (usize, usize),
        knots: (Vec<f32>, Vec<f32>),
        count_v: usize,
        points: Vec<Vec4>,
    ) -> Result<Self, NurbsError> {
        Surface::new(degree, (&knots.0, &knots.1), count_v, &points)?;
        Ok(SurfaceBuf {
            degree,
            knots_u: knots.0,
            knots_v: knots.1,
            count_v,
            points,
        })
    }

    /// From rows of Cartesian points (`rows[i][j]`, `i` along u) and optional weights of the
    /// same shape.
    pub fn from_rows<R: AsRef<[Vec3]>, W: AsRef<[f32]>>(
        degree: (usize, usize),
        knots: (Vec<f32>, Vec<f32>),
        rows: &[R],
        weights: Option<&[W]>,
    ) -> Result<Self, NurbsError> {
        let count_v = rows.first().map_or(0, |r| r.as_ref().len());
        for (row, r) in rows.iter().enumerate() {
            if r.as_ref().len() != count_v {
                return Err(NurbsError::RaggedNet {
                    field: Field::Points,
                    row,
                    expected: count_v,
                    found: r.as_ref().len(),
                });
            }
        }
        if let Some(w) = weights {
            if w.len() != rows.len() {
                return Err(NurbsError::WeightCount {
                    expected: rows.len(),
                    found: w.len(),
                });
            }
            for (row, r) in w.iter().enumerate() {
                if r.as_ref().len() != count_v {
                    return Err(NurbsError::RaggedNet {
                        field: Field::Weights,
                        row,
                        expected: count_v,
                        found: r.as_ref().len(),
                    });
                }
            }
        }
        let weight = |i: usize, j: usize| weights.map_or(1.0, |w| w[i].as_ref()[j]);
        let largest = largest_weight(
            (0..rows.len())
                .flat_map(|i| (0..count_v).map(move |j| (i, j)))
                .map(|(i, j)| weight(i, j)),
        );
        let mut hom = Vec::with_capacity(rows.len() * count_v);
        for (i, r) in rows.iter().enumerate() {
            for (j, &p) in r.as_ref().iter().enumerate() {
                let w = weight(i, j);
                check_control_point(At::Ij(i, j), p, w, largest)?;
                hom.push((p * w).extend(w));
            }
        }
        Self::new(degree, knots, count_v, hom)
    }

    /// The borrowed view used for evaluation.
    #[inline]
    pub fn view(&self) -> Surface<'_> {
        Surface::from_validated(
            Knots::from_validated(&self.knots_u, self.degree.0),
            Knots::from_validated(&self.knots_v, self.degree.1),
            &self.points,
        )
    }

    /// Degrees `(p, q)`.
    pub fn degree(&self) -> (usize, usize) {
        self.degree
    }

    /// Knot vectors `(U, V)`.
    pub fn knots(&self) -> (&[f32], &[f32]) {
        (&self.knots_u, &self.knots_v)
    }

    /// Control net size `(along u, along v)`.
    pub fn counts(&self) -> (usize, usize) {
        (self.points.len() / self.count_v.max(1), self.count_v)
    }

    /// Homogeneous control net, row-major with `i` along u.
    pub fn points(&self) -> &[Vec4] {
        &self.points
    }

    /// The surface with `f` applied to every Cartesian control point (exact for affine `f`).
    pub fn map_points(&self, f: impl Fn(Vec3) -> Vec3) -> Result<Self, NurbsError> {
        let pts = self
            .points
            .iter()
            .map(|h| (f(h.truncate() / h.w) * h.w).extend(h.w))
            .collect();
        Self::new(
            self.degree,
            (self.knots_u.clone(), self.knots_v.clone()),
            self.count_v,
            pts,
        )
    }
}
