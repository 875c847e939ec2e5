//! Surface evaluation, partial derivatives and normals against an independent `f64`
//! evaluation of the definition and its central differences.
#![allow(clippy::unwrap_used)]

use glam::{DVec3, Vec3, Vec4};
use nurbs::{Surface, SurfaceDerivs};
use proptest::prelude::*;
use testkit::{
    EPS32, RefSurface, SurfaceSpec, central_mixed, central1, central2, hom3, in_span, min_gap,
    rel_err, surface_spec,
};

/// Rounding scale of ∂^(k+l)S/∂u^k∂v^l: |P|max R^(k+l) Du^k Dv^l with R = wmax/wmin and
/// D = degree / smallest knot gap (as for curves, A4.4 divides by w once per order).
fn scales(spec: &SurfaceSpec) -> impl Fn(usize, usize) -> f64 {
    let pmax = spec.pmax().max(1e-3);
    let r = spec.weight_ratio();
    let du = spec.p as f64 / min_gap(&spec.ku) * r;
    let dv = spec.q as f64 / min_gap(&spec.kv) * r;
    move |k, l| pmax * du.powi(k as i32) * dv.powi(l as i32)
}

fn check_derivs(
    spec: &SurfaceSpec,
    pu: f64,
    tu: f64,
    pv: f64,
    tv: f64,
) -> Result<(), TestCaseError> {
    let buf = spec.build();
    let s = buf.view();
    let r = RefSurface::new(&s);
    let (u, lu) = in_span(&spec.ku, pu, tu);
    let (v, lv) = in_span(&spec.kv, pv, tv);
    let (uf, vf) = (u as f64, v as f64);
    let sc = scales(spec);
    // The f64 central differences (steps 1e-5 / 1e-4 of the spans for first / second
    // derivatives, stencils inside the spans) add well under 1 ulp of these scales (see
    // curves.rs). Over 5 000 random surfaces of degrees ≤ 5 the total error stayed below 3 ulps
    // of the scale; 32 ulps leaves a 10× margin, while a wrong term in A3.6/A4.4 is an error of
    // order the scale.
    let tol = 32.0 * EPS32;
    let d = s.derivs(u, v, 2);
    let (h1u, h1v, h2u, h2v) = (1e-5 * lu, 1e-5 * lv, 1e-4 * lu, 1e-4 * lv);
    let want = SurfaceDerivsD {
        point: r.point(uf, vf),
        du: central1(|x| r.point(x, vf), uf, h1u),
        dv: central1(|y| r.point(uf, y), vf, h1v),
        duu: central2(|x| r.point(x, vf), uf, h2u),
        duv: central_mixed(|x, y| r.point(x, y), uf, vf, h2u, h2v),
        dvv: central2(|y| r.point(uf, y), vf, h2v),
    };
    let got = [d.point, d.du, d.dv, d.duu, d.duv, d.dvv].map(|x| x.as_dvec3());
    let refs = [want.point, want.du, want.dv, want.duu, want.duv, want.dvv];
    let orders = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)];
    let names = ["S", "S_u", "S_v", "S_uu", "S_uv", "S_vv"];
    for i in 0..6 {
        let (k, l) = orders[i];
        let e = rel_err(got[i], refs[i], sc(k, l));
        prop_assert!(
            e <= tol,
            "{}: {} vs f64 {} (error {:.1} ulps of scale)",
            names[i],
            got[i],
            refs[i],
            e / EPS32
        );
    }
    prop_assert!(rel_err(s.point(u, v).as_dvec3(), want.point, sc(0, 0)) <= tol);

    // Lower orders: the higher entries are zero and the rest identical.
    let d1 = s.derivs(u, v, 1);
    let d0 = s.derivs(u, v, 0);
    prop_assert_eq!(
        d0,
        SurfaceDerivs {
            point: d.point,
            ..SurfaceDerivs::default()
        }
    );
    prop_assert_eq!(
        d1,
        SurfaceDerivs {
            point: d.point,
            du: d.du,
            dv: d.dv,
            ..SurfaceDerivs::default()
        }
    );

    // Normal: unit, orthogonal to both partials; where S_u × S_v is well conditioned it is the
    // f64 normal. Orthogonality of a normalised f32 cross product holds to ~eps / sin θ, θ the
    // angle between S_u and S_v.
    let n = s.normal(u, v);
    prop_assert!(n.is_finite());
    prop_assert!((n.length() - 1.0).abs() <= 1e-6);
    let (su, sv) = (d.du.as_dvec3(), d.dv.as_dvec3());
    let sin = su.cross(sv).length() / (su.length() * sv.length());
    if sin >= 1e-3 && su.length() >= 1e-3 * sc(1, 0) && sv.length() >= 1e-3 * sc(0, 1) {
        let nd = n.as_dvec3();
        prop_assert!(nd.dot(su).abs() <= 8.0 * EPS32 / sin * su.length(), "n·S_u");
        prop_assert!(nd.dot(sv).abs() <= 8.0 * EPS32 / sin * sv.length(), "n·S_v");
        let n_ref = want.du.cross(want.dv).normalize();
        let bound = 4.0 * tol * (sc(1, 0) / su.length() + sc(0, 1) / sv.length()) / sin;
        prop_assert!(
            (nd - n_ref).length() <= bound,
            "n = {nd}, f64 {n_ref}, bound {bound}"
        );
        prop_assert_eq!(s.normal_from(u, v, &d1), n);
    }
    Ok(())
}

struct SurfaceDerivsD {
    point: DVec3,
    du: DVec3,
    dv: DVec3,
    duu: DVec3,
    duv: DVec3,
    dvv: DVec3,
}

proptest! {
    #![proptest_config(testkit::config())]

    /// S and all partials up to second order of random surfaces (degrees 1–5 in each
    /// direction, interior multiplicities up to the degree, rational or not, arbitrary domains)
    /// against the f64 definition and its central differences, inside a knot-span rectangle.
    #[test]
    fn derivatives_match_central_differences(
        spec in surface_spec(5, 5),
        pu in 0.0f64..1.0, tu in 0.05f64..0.95, pv in 0.0f64..1.0, tv in 0.05f64..0.95,
    ) {
        check_derivs(&spec, pu, tu, pv, tv)?;
    }

    /// Evaluation anywhere (including edges, knots and corners) agrees with the definition.
    #[test]
    fn point_matches_definition_everywhere(
        spec in surface_spec(5, 5), tu in 0.0f64..=1.0, tv in 0.0f64..=1.0, edge in 0..4u8,
    ) {
        let buf = spec.build();
        let s = buf.view();
        let r = RefSurface::new(&s);
        let ((u0, u1), (v0, v1)) = s.domain();
        let lerp = |a: f32, b: f32, t: f64| ((a as f64 + t * (b as f64 - a as f64)) as f32).min(b);
        let (u, v) = match edge {
            0 => (u0, lerp(v0, v1, tv)),
            1 => (lerp(u0, u1, tu), v1),
            2 => (u1, lerp(v0, v1, tv)),
            _ => (lerp(u0, u1, tu), lerp(v0, v1, tv)),
        };
        let sc = scales(&spec);
        prop_assert!(rel_err(s.point(u, v).as_dvec3(), r.point(u as f64, v as f64), sc(0, 0)) <= 32.0 * EPS32);
    }
}

#[test]
fn accessors() {
    // A 3 × 2 net, degree (2, 1), u on [−3, 7], v on [1, 2].
    let ku = [-3.0f32, -3.0, -3.0, 7.0, 7.0, 7.0];
    let kv = [1.0f32, 1.0, 2.0, 2.0];
    let pts = [
        hom3(Vec3::new(0.0, 0.0, 0.0), 1.0),
        hom3(Vec3::new(0.0, 1.0, 0.0), 2.0),
        hom3(Vec3::new(1.0, 0.0, 1.0), 0.5),
        hom3(Vec3::new(1.0, 1.0, 1.0), 1.0),
        hom3(Vec3::new(2.0, 0.0, 0.0), 1.0),
        hom3(Vec3::new(2.0, 1.0, 0.0), 3.0),
    ];
    let s = Surface::new((2, 1), (&ku, &kv), 2, &pts).unwrap();
    assert_eq!(s.degree(), (2, 1));
    assert_eq!(s.counts(), (3, 2));
    assert_eq!(s.domain(), ((-3.0, 7.0), (1.0, 2.0)));
    assert_eq!(s.knots().0.as_slice(), &ku);
    assert_eq!(s.points(), &pts);
    assert_eq!(s.control_point(1, 0), Some((Vec3::new(1.0, 0.0, 1.0), 0.5)));
    assert_eq!(s.control_point(2, 1), Some((Vec3::new(2.0, 1.0, 0.0), 3.0)));
    assert_eq!(s.control_point(3, 0), None);
    assert_eq!(s.control_point(0, 2), None);
    // Corners interpolate the corner control points (clamped knots).
    for (u, v, p) in [
        (-3.0, 1.0, Vec3::ZERO),
        (-3.0, 2.0, Vec3::Y),
        (7.0, 1.0, Vec3::new(2.0, 0.0, 0.0)),
        (7.0, 2.0, Vec3::new(2.0, 1.0, 0.0)),
    ] {
        assert!(
            (s.point(u, v) - p).length() <= 4.0 * f32::EPSILON,
            "S({u}, {v})"
        );
    }
    let bb = s.bounding_box();
    assert_eq!(bb.min, Vec3::ZERO);
    assert_eq!(bb.max, Vec3::new(2.0, 1.0, 1.0));
    // Out-of-domain parameters are clamped (documented): identical to the domain edge.
    assert_eq!(s.point(-100.0, 5.0), s.point(-3.0, 2.0));
    assert_eq!(s.derivs(f32::NAN, f32::INFINITY, 2), s.derivs(-3.0, 2.0, 2));
}

/// A sphere of revolution written out by hand (P&T Ex8.1-style: a semicircle of radius 1 in
/// the xz-plane revolved about z, the full circle in u as nine points with weights
/// {1, √½, 1, …} and the semicircle in v as five points), not through `construct`. The poles
/// at v = 0 and v = 1 collapse a whole row of the net; the normal there must be the finite
/// limit ∓z for every u, not NaN.
#[test]
fn handmade_sphere_poles() {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    // Unit circle in the xy-plane: 9 points, 4 arcs.
    let circle = [
        (1.0, 0.0, 1.0),
        (1.0, 1.0, h),
        (0.0, 1.0, 1.0),
        (-1.0, 1.0, h),
        (-1.0, 0.0, 1.0),
        (-1.0, -1.0, h),
        (0.0, -1.0, 1.0),
        (1.0, -1.0, h),
        (1.0, 0.0, 1.0),
    ];
    // Meridian from the south pole to the north pole in the (ρ, z) half-plane: 2 arcs.
    let meridian = [
        (0.0, -1.0, 1.0),
        (1.0, -1.0, h),
        (1.0, 0.0, 1.0),
        (1.0, 1.0, h),
        (0.0, 1.0, 1.0),
    ];
    let mut pts = Vec::new();
    for &(cx, cy, cw) in &circle {
        for &(rho, z, mw) in &meridian {
            let p = Vec3::new(cx * rho, cy * rho, z);
            pts.push(hom3(p, cw * mw));
        }
    }
    let ku = [
        0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0,
    ];
    let kv = [0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0];
    let s = Surface::new((2, 2), (&ku, &kv), 5, &pts).unwrap();
    for i in 0..=40 {
        let u = i as f32 / 40.0;
        for j in 0..=40 {
            let v = j as f32 / 40.0;
            let p = s.point(u, v);
            assert!(
                (p.length() - 1.0).abs() <= 8.0 * f32::EPSILON,
                "|S({u}, {v})| = {}",
                p.length()
            );
            let n = s.normal(u, v);
            let want = if j == 0 {
                -Vec3::Z
            } else if j == 40 {
                Vec3::Z
            } else {
                p
            };
            // Away from the poles the normal of the unit sphere is the point itself; within
            // 1/40 of them S_u is ~ sin(π/40) of S_v and the normal loses that factor.
            assert!(
                (n - want).length() <= 1e-5,
                "n({u}, {v}) = {n}, want {want}"
            );
        }
    }
    // normal_from agrees with normal at the poles too.
    let d = s.derivs(0.3, 0.0, 1);
    assert!(d.du.length() <= 1e-6, "S_u vanishes at the pole");
    assert_eq!(s.normal_from(0.3, 0.0, &d), s.normal(0.3, 0.0));
}

/// A net collapsed to a single point defines no direction: it is refused at construction,
/// so evaluation never sees it.
#[test]
fn point_surface_is_refused() {
    let pts = [Vec4::new(1.0, 2.0, 3.0, 1.0); 4];
    let k = [0.0, 0.0, 1.0, 1.0];
    let s = Surface::new((1, 1), (&k, &k), 2, &pts);
    assert_eq!(s, Err(nurbs::NurbsError::ZeroArea { width: 0.0 }));
}
