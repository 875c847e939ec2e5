//! A deformable patch: its constant mass, damping and stiffness matrices, its state, the
//! integrator and the static solve.

use crate::DynamicsError;
use crate::band::{Cholesky, SymBand};
use crate::params::{Fixed, Params};
use crate::shape::{Local, Shape};

/// Generalised forces or displacements: one `[x, y, z]` per control point (`z = 0` for planar
/// curves).
pub type Nodes = Vec<[f64; 3]>;

/// The energy of the motion about the rest shape.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Energy {
    /// `½ ṗᵀ M ṗ` (J).
    pub kinetic_j: f64,
    /// `½ (p − p₀)ᵀ K (p − p₀)` (J).
    pub elastic_j: f64,
}

impl Energy {
    /// Kinetic plus elastic (J).
    pub fn total_j(&self) -> f64 {
        self.kinetic_j + self.elastic_j
    }
}

/// A spring between a point of the object and an anchor (a penalty contact: the HIP pressing
/// on the object), included implicitly in a step ([`Body::step_coupled`]): its force on the
/// object `k P (anchor − x(params))`, `P` the projector on `normal` (or the identity when
/// `None`), acts at the end of the step with the object's new shape. A stiff contact on a
/// light object stepped explicitly (its force from the shape before the step) gains energy
/// every step and throws the object off; implicit, the pair is the trapezoidal rule's again.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coupling {
    /// Where on the object (`[u, 0]` on curves).
    pub params: [f64; 2],
    /// Where the spring's other end is (m).
    pub anchor: [f64; 3],
    /// Its stiffness (N/m).
    pub stiffness: f64,
    /// The one direction it acts along (unit), or every direction when `None`.
    pub normal: Option<[f64; 3]>,
}

/// A D-NURBS patch with frozen weights: `M p̈ + D ṗ + K (p − p₀) = f_p` (thesis eq. 4.9 with
/// `p₀` the rest shape), `M = ∫ μ RRᵀ`, `D = ∫ γ RRᵀ`, `K = ∫ α R_s R_sᵀ + β R_ss R_ssᵀ`
/// (curves; derivatives by arc length `s` of the rest shape) or their surface forms (the
/// gradient and covariant Hessian in the rest shape's metric), assembled once by
/// Gauss–Legendre quadrature over each knot span.
#[derive(Clone, Debug)]
pub struct Body {
    shape: Shape,
    params: Params,
    rest: Nodes,
    m: SymBand,
    d: SymBand,
    k: SymBand,
    /// `∫ R_k ds` (or `dA`): the generalised force of a unit uniform load.
    area: Vec<f64>,
    /// Rest arc length (curves) or area (surfaces).
    measure: f64,
    fixed: Vec<bool>,
    u: Nodes,
    v: Nodes,
    a: Nodes,
    /// `M` pinned at the fixed points, factored.
    mass_factor: Option<Cholesky>,
    /// `K + (2/Δt) D + (4/Δt²) M` pinned at the fixed points, factored, for `Δt`.
    newmark: Option<(f64, Cholesky)>,
    /// Buffers of a step (no allocation per step): two products, the right-hand side, the
    /// coupling's columns and their solves.
    scratch: [Nodes; 2],
    rhs: Nodes,
    columns: [Nodes; 3],
    solved: [Nodes; 3],
    local: Local,
}

impl Body {
    /// The body of `shape` at rest at `rest` (its Cartesian control points) with `params`.
    pub fn new(shape: Shape, rest: Nodes, params: Params) -> Result<Self, DynamicsError> {
        params.validate()?;
        let n = shape.n_points();
        if rest.len() != n || n < 2 {
            return Err(DynamicsError::PointCount {
                expected: n,
                found: rest.len(),
            });
        }
        let fixed = fixed_mask(&shape, &params.fixed, n)?;
        let b = shape.bandwidth();
        let (mut m, mut k) = (SymBand::zeros(n, b), SymBand::zeros(n, b));
        let mut area = vec![0.0; n];
        let mut measure = 0.0;
        let mut local = Local::default();
        // Order p + 2 per direction: the mass integrand R Rᵀ·|C'| is a polynomial of degree
        // 2p + (p − 1) on a straight polynomial curve (exact with ⌈(3p)/2⌉ ≤ p + 2 points for
        // p ≤ 4) and close to one otherwise.
        let order = shape.max_degree() + 2;
        let surface = shape.is_surface();
        for (params_uv, weight) in shape.quadrature(order) {
            shape.eval(params_uv, &mut local);
            let geometry = rest_geometry(&local, &rest);
            let (dmeasure, grads) = if surface {
                surface_terms(&geometry, &local, params_uv)?
            } else {
                curve_terms(&geometry, &local, params_uv)?
            };
            let w = weight * dmeasure;
            measure += w;
            for (x, &i) in local.index.iter().enumerate() {
                area[i] += w * local.r[x];
                for (y, &j) in local.index.iter().enumerate() {
                    if j > i {
                        continue;
                    }
                    m.add(i, j, w * local.r[x] * local.r[y]);
                    let stretch = dot(&grads.first[x], &grads.first[y]);
                    let bend = dot(&grads.second[x], &grads.second[y]);
                    k.add(i, j, w * (params.tension * stretch + params.bending * bend));
                }
            }
        }
        // Held: K on the free points is positive definite, so no motion of the object costs
        // no energy. Else a load sends it away (a static solve has no answer, a push makes it
        // drift off under the hand).
        let mut pinned = k.clone();
        for (i, _) in fixed.iter().enumerate().filter(|(_, f)| **f) {
            pinned.pin(i);
        }
        if pinned.cholesky().is_err() {
            return Err(DynamicsError::NotHeld);
        }
        let mass = SymBand::combine(&[(params.density, &m)]);
        let damping = SymBand::combine(&[(params.damping, &m)]);
        Ok(Body {
            shape,
            params,
            rest,
            m: mass,
            d: damping,
            k,
            area,
            measure,
            fixed,
            u: vec![[0.0; 3]; n],
            v: vec![[0.0; 3]; n],
            a: vec![[0.0; 3]; n],
            mass_factor: None,
            newmark: None,
            scratch: [vec![[0.0; 3]; n], vec![[0.0; 3]; n]],
            rhs: vec![[0.0; 3]; n],
            columns: std::array::from_fn(|_| vec![[0.0; 3]; n]),
            solved: std::array::from_fn(|_| vec![[0.0; 3]; n]),
            local,
        })
    }

    /// The rest shape's patch description.
    pub fn shape(&self) -> &Shape {
        &self.shape
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Number of control points.
    pub fn n_points(&self) -> usize {
        self.rest.len()
    }

    /// Rest arc length (m) of a curve or area (m²) of a surface.
    pub fn measure(&self) -> f64 {
        self.measure
    }

    /// Which control points are fixed.
    pub fn fixed(&self) -> &[bool] {
        &self.fixed
    }

    /// The rest shape's control points (they move when the object is plastic).
    pub fn rest(&self) -> &[[f64; 3]] {
        &self.rest
    }

    /// The displacement of every control point from the rest shape.
    pub fn displacement(&self) -> &[[f64; 3]] {
        &self.u
    }

    /// The control points' velocities.
    pub fn velocity(&self) -> &[[f64; 3]] {
        &self.v
    }

    /// The current control points.
    pub fn points(&self) -> Nodes {
        self.rest
            .iter()
            .zip(&self.u)
            .map(|(p, u)| add(*p, *u))
            .collect()
    }

    /// The mass matrix `M`.
    pub fn mass(&self) -> &SymBand {
        &self.m
    }

    /// The stiffness matrix `K`.
    pub fn stiffness(&self) -> &SymBand {
        &self.k
    }

    /// The point of the current shape at `params` (`[u, 0]` on curves).
    pub fn point(&mut self, params: [f64; 2]) -> [f64; 3] {
        self.shape.eval(params, &mut self.local);
        let mut x = [0.0; 3];
        for (m, &i) in self.local.index.iter().enumerate() {
            x = add(x, scale(add(self.rest[i], self.u[i]), self.local.r[m]));
        }
        x
    }

    /// The parameters of the point of the current shape closest to `target` near `start`:
    /// Gauss–Newton on `|x(params) − target|²` from `start` (`[u, 0]` on curves), clamped
    /// into the domain, `iterations` steps. For a host that knows where a device's contact
    /// is (a telemetry frame's CP) but not its parameters.
    pub fn project(&mut self, target: [f64; 3], start: [f64; 2], iterations: usize) -> [f64; 2] {
        let domain = self.shape.domain();
        let surface = self.shape.is_surface();
        let mut at = start;
        for _ in 0..iterations {
            self.shape.eval(at, &mut self.local);
            let (mut x, mut xu, mut xv) = ([0.0; 3], [0.0; 3], [0.0; 3]);
            for (m, &i) in self.local.index.iter().enumerate() {
                let p = add(self.rest[i], self.u[i]);
                x = add(x, scale(p, self.local.r[m]));
                xu = add(xu, scale(p, self.local.d1[m][0]));
                xv = add(xv, scale(p, self.local.d1[m][1]));
            }
            let e = sub(x, target);
            let step = if surface {
                let (a, b, c) = (dot(&xu, &xu), dot(&xu, &xv), dot(&xv, &xv));
                let det = a * c - b * b;
                if det.abs() <= f64::MIN_POSITIVE {
                    break;
                }
                let (gu, gv) = (dot(&xu, &e), dot(&xv, &e));
                [-(c * gu - b * gv) / det, -(a * gv - b * gu) / det]
            } else {
                let a = dot(&xu, &xu);
                if a <= f64::MIN_POSITIVE {
                    break;
                }
                [-dot(&xu, &e) / a, 0.0]
            };
            for k in 0..2 {
                at[k] = (at[k] + step[k]).clamp(domain[k].0, domain[k].1);
            }
        }
        at
    }

    /// The displacement from the rest shape of the point at `params`.
    pub fn displacement_at(&mut self, params: [f64; 2]) -> [f64; 3] {
        self.shape.eval(params, &mut self.local);
        let mut x = [0.0; 3];
        for (m, &i) in self.local.index.iter().enumerate() {
            x = add(x, scale(self.u[i], self.local.r[m]));
        }
        x
    }

    /// A load of zero.
    pub fn zero_load(&self) -> Nodes {
        vec![[0.0; 3]; self.n_points()]
    }

    /// Adds a force `force_n` (N) applied at `params` to `load`: `f_p += Jᵀ f` (thesis eq.
    /// 4.8 for a point force).
    pub fn add_point_force(&mut self, load: &mut [[f64; 3]], params: [f64; 2], force_n: [f64; 3]) {
        self.shape.eval(params, &mut self.local);
        for (m, &i) in self.local.index.iter().enumerate() {
            if let Some(f) = load.get_mut(i) {
                *f = add(*f, scale(force_n, self.local.r[m]));
            }
        }
    }

    /// Adds a uniform load `q` (N/m on curves, N/m² on surfaces, per rest length or area):
    /// `f_p += ∫ Jᵀ q`.
    pub fn add_uniform_load(&self, load: &mut [[f64; 3]], q: [f64; 3]) {
        for (f, a) in load.iter_mut().zip(&self.area) {
            *f = add(*f, scale(q, *a));
        }
    }

    /// Back to rest: no displacement, no velocity.
    pub fn reset(&mut self) {
        self.u.iter_mut().for_each(|x| *x = [0.0; 3]);
        self.v.iter_mut().for_each(|x| *x = [0.0; 3]);
    }

    /// The energy of the current motion.
    pub fn energy(&self) -> Energy {
        Energy {
            kinetic_j: 0.5 * self.m.quadratic(&self.v),
            elastic_j: 0.5 * self.k.quadratic(&self.u),
        }
    }

    /// The equilibrium under `load`: `K (p − p₀) = f_p` on the free points, at rest.
    /// [`DynamicsError::NotHeld`] when nothing holds the object against the load (too few
    /// fixed points for its stiffness).
    pub fn solve_static(&mut self, load: &[[f64; 3]]) -> Result<(), DynamicsError> {
        check_load(load, self.n_points())?;
        let mut k = self.k.clone();
        self.pin(&mut k);
        let chol = k.cholesky().map_err(|_| DynamicsError::NotHeld)?;
        let mut x = load.to_vec();
        zero_fixed(&self.fixed, &mut x);
        chol.solve(&mut x);
        self.u = x;
        self.v.iter_mut().for_each(|x| *x = [0.0; 3]);
        Ok(())
    }

    /// One step of `dt_s` under `load` (the generalised force at the end of the step,
    /// [`Body::add_point_force`]): Newmark's average acceleration (β = ¼, γ = ½), the
    /// trapezoidal rule, which is unconditionally stable for the linear system and conserves
    /// its energy exactly when undamped and unloaded. The present acceleration is computed
    /// from the present state under this step's forces (one solve with `M`), so a load that
    /// changes between steps is a force, never a kick. A plastic object's rest shape then
    /// creeps towards the new shape.
    pub fn step(&mut self, dt_s: f64, load: &[[f64; 3]]) -> Result<(), DynamicsError> {
        self.step_coupled(dt_s, load, None)
    }

    /// The force (N) `coupling` exerts on the object in its current shape.
    pub fn coupling_force(&mut self, coupling: &Coupling) -> [f64; 3] {
        let x = self.point(coupling.params);
        let pull = sub(coupling.anchor, x);
        let along = match coupling.normal {
            Some(n) => scale(n, dot(&n, &pull)),
            None => pull,
        };
        scale(along, coupling.stiffness)
    }

    /// [`Body::step`] with `coupling`'s spring acting too, implicitly: `(K_eff + k Jᵀ P J)`
    /// solved by the Woodbury identity on the factored `K_eff` (one solve per direction of
    /// `P`, a 3 × 3 system at most), so the factorisation is still made once per step size.
    pub fn step_coupled(
        &mut self,
        dt_s: f64,
        load: &[[f64; 3]],
        coupling: Option<&Coupling>,
    ) -> Result<(), DynamicsError> {
        if !(dt_s.is_finite() && dt_s > 0.0 && dt_s <= 1.0) {
            return Err(DynamicsError::Step { dt_s });
        }
        check_load(load, self.n_points())?;
        if self.newmark.as_ref().is_none_or(|(dt, _)| *dt != dt_s) {
            let c = 4.0 / (dt_s * dt_s);
            let mut eff = SymBand::combine(&[(1.0, &self.k), (2.0 / dt_s, &self.d), (c, &self.m)]);
            self.pin(&mut eff);
            let chol = eff.cholesky().map_err(|_| DynamicsError::Step { dt_s })?;
            self.newmark = Some((dt_s, chol));
        }
        if self.mass_factor.is_none() {
            let mut m = self.m.clone();
            self.pin(&mut m);
            self.mass_factor = Some(m.cholesky().map_err(|_| DynamicsError::Degenerate)?);
        }
        // The coupling's columns `J ⊗ e_j` (zero at fixed points) and the constant parts of
        // its force, `k e_j·(anchor − x₀(params))` (x₀ the rest shape's point): its force
        // on the shape `u` is `Σ_j col_j (c_j − k col_j·u)`.
        const AXES: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let mut pulls = [0.0; 3];
        let mut n_columns = 0;
        let mut k_c = 0.0;
        if let Some(c) = coupling.filter(|c| c.stiffness > 0.0 && c.stiffness.is_finite()) {
            k_c = c.stiffness;
            self.shape.eval(c.params, &mut self.local);
            let mut x0 = [0.0; 3];
            for (m, &i) in self.local.index.iter().enumerate() {
                x0 = add(x0, scale(self.rest[i], self.local.r[m]));
            }
            let normal = c.normal.map(|n| [n]);
            let axes: &[[f64; 3]] = match &normal {
                Some(n) => n,
                None => &AXES,
            };
            let pull = sub(c.anchor, x0);
            for (j, e) in axes.iter().enumerate() {
                let col = &mut self.columns[j];
                col.iter_mut().for_each(|x| *x = [0.0; 3]);
                for (m, &i) in self.local.index.iter().enumerate() {
                    if !self.fixed[i] {
                        col[i] = scale(*e, self.local.r[m]);
                    }
                }
                pulls[j] = k_c * dot(e, &pull);
            }
            n_columns = axes.len();
        }
        let columns = &self.columns[..n_columns];
        let pulls = &pulls[..n_columns];
        let (Some((_, chol)), Some(mass)) = (&self.newmark, &self.mass_factor) else {
            return Err(DynamicsError::Step { dt_s });
        };
        let [s0, s1] = &mut self.scratch;
        // The acceleration of the present state under this step's forces, `a = M⁻¹ (f − D v
        // − K u)`: consistent with the forces, so that a load or a contact that starts now
        // enters the trapezoidal rule as a force, not as a kick of stale acceleration.
        self.d.mul(&self.v, s0);
        self.k.mul(&self.u, s1);
        for i in 0..self.u.len() {
            self.a[i] = sub(sub(load[i], s0[i]), s1[i]);
        }
        for (col, pull) in columns.iter().zip(pulls) {
            let along = pull - k_c * node_dot(col, &self.u);
            for (a, x) in self.a.iter_mut().zip(col) {
                *a = add(*a, scale(*x, along));
            }
        }
        zero_fixed(&self.fixed, &mut self.a);
        mass.solve(&mut self.a);
        // rhs = f + M (c u + (4/Δt) v + a) + D ((2/Δt) u + v) + Σ_j col_j c_j
        let c = 4.0 / (dt_s * dt_s);
        for i in 0..self.u.len() {
            for j in 0..3 {
                s0[i][j] = c * self.u[i][j] + 4.0 / dt_s * self.v[i][j] + self.a[i][j];
            }
        }
        self.m.mul(s0, s1);
        let rhs = &mut self.rhs;
        for (r, (f, x)) in rhs.iter_mut().zip(load.iter().zip(s1.iter())) {
            *r = add(*f, *x);
        }
        for i in 0..self.u.len() {
            for j in 0..3 {
                s0[i][j] = 2.0 / dt_s * self.u[i][j] + self.v[i][j];
            }
        }
        self.d.mul(s0, s1);
        for (r, x) in rhs.iter_mut().zip(s1.iter()) {
            *r = add(*r, *x);
        }
        for (col, pull) in columns.iter().zip(pulls) {
            for (r, x) in rhs.iter_mut().zip(col) {
                *r = add(*r, scale(*x, *pull));
            }
        }
        zero_fixed(&self.fixed, rhs);
        chol.solve(rhs);
        if n_columns > 0 {
            woodbury(chol, k_c, columns, &mut self.solved[..n_columns], rhs);
        }
        // Trapezoidal velocity: v₁ = 2 (u₁ − u₀)/Δt − v₀.
        for i in 0..self.u.len() {
            for j in 0..3 {
                self.v[i][j] = 2.0 / dt_s * (self.rhs[i][j] - self.u[i][j]) - self.v[i][j];
                self.u[i][j] = self.rhs[i][j];
            }
        }
        if let Some(tau) = self.params.plastic_time_s {
            let alpha = (dt_s / tau).min(1.0);
            for (p, u) in self.rest.iter_mut().zip(self.u.iter_mut()) {
                *p = add(*p, scale(*u, alpha));
                *u = scale(*u, 1.0 - alpha);
            }
        }
        Ok(())
    }

    /// The lowest natural frequency (Hz) of the undamped object about its rest shape: the
    /// smallest `λ` of `K x = λ M x` on the free points by inverse iteration, `f = √λ / 2π`.
    pub fn lowest_mode_hz(&self) -> Result<f64, DynamicsError> {
        let n = self.n_points();
        let mut k = self.k.clone();
        self.pin(&mut k);
        let chol = k.cholesky().map_err(|_| DynamicsError::NotHeld)?;
        let mut x: Vec<[f64; 1]> = (0..n)
            .map(|i| {
                [if self.fixed[i] {
                    0.0
                } else {
                    1.0 + (i % 3) as f64 * 0.1
                }]
            })
            .collect();
        let mut y = vec![[0.0; 1]; n];
        let mut lambda = 0.0;
        for _ in 0..500 {
            self.m.mul(&x, &mut y);
            for (yi, &f) in y.iter_mut().zip(&self.fixed) {
                if f {
                    *yi = [0.0];
                }
            }
            chol.solve(&mut y);
            let norm = self.m.quadratic(&y).sqrt();
            if norm.is_nan() || norm <= 0.0 {
                return Err(DynamicsError::NotHeld);
            }
            y.iter_mut().for_each(|v| v[0] /= norm);
            let next = self.k.quadratic(&y);
            std::mem::swap(&mut x, &mut y);
            if (next - lambda).abs() <= 1e-15 * next {
                lambda = next;
                break;
            }
            lambda = next;
        }
        Ok(lambda.sqrt() / (2.0 * std::f64::consts::PI))
    }

    fn pin(&self, a: &mut SymBand) {
        for (i, &f) in self.fixed.iter().enumerate() {
            if f {
                a.pin(i);
            }
        }
    }
}

/// `y ← (A + k U Uᵀ)⁻¹ b` from `y = A⁻¹ b`: `y − Z (I/k + Uᵀ Z)⁻¹ Uᵀ y` with `Z = A⁻¹ U`
/// (the Woodbury identity), for the up to three columns of `U` (`z`: as many buffers).
fn woodbury(chol: &Cholesky, k: f64, columns: &[Nodes], z: &mut [Nodes], y: &mut [[f64; 3]]) {
    let r = columns.len();
    let mut uty = [0.0; 3];
    for (j, u) in columns.iter().enumerate() {
        uty[j] = node_dot(u, y);
    }
    for (zj, u) in z.iter_mut().zip(columns) {
        zj.copy_from_slice(u);
        chol.solve(zj);
    }
    let mut s = [[0.0; 3]; 3];
    for i in 0..r {
        for j in 0..r {
            s[i][j] = node_dot(&columns[i], &z[j]) + if i == j { 1.0 / k } else { 0.0 };
        }
    }
    let coef = solve_small(&s, &uty, r);
    for (j, zj) in z.iter().enumerate() {
        for (yi, zi) in y.iter_mut().zip(zj) {
            *yi = sub(*yi, scale(*zi, coef[j]));
        }
    }
}

/// Solves the symmetric positive definite `r × r` (r ≤ 3) system `s x = b` by Gaussian
/// elimination.
fn solve_small(s: &[[f64; 3]; 3], b: &[f64], r: usize) -> [f64; 3] {
    let mut a = *s;
    let mut x = [0.0; 3];
    x[..r].copy_from_slice(&b[..r]);
    for c in 0..r {
        for row in c + 1..r {
            let f = a[row][c] / a[c][c];
            for k in c..r {
                a[row][k] -= f * a[c][k];
            }
            x[row] -= f * x[c];
        }
    }
    for c in (0..r).rev() {
        for k in c + 1..r {
            x[c] -= a[c][k] * x[k];
        }
        x[c] /= a[c][c];
    }
    x
}

fn zero_fixed(fixed: &[bool], x: &mut [[f64; 3]]) {
    for (xi, &f) in x.iter_mut().zip(fixed) {
        if f {
            *xi = [0.0; 3];
        }
    }
}

fn node_dot(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    a.iter().zip(b).map(|(x, y)| dot(x, y)).sum()
}

fn check_load(load: &[[f64; 3]], n: usize) -> Result<(), DynamicsError> {
    if load.len() != n {
        return Err(DynamicsError::PointCount {
            expected: n,
            found: load.len(),
        });
    }
    if load.iter().flatten().any(|x| !x.is_finite()) {
        return Err(DynamicsError::Load);
    }
    Ok(())
}

fn fixed_mask(shape: &Shape, fixed: &Fixed, n: usize) -> Result<Vec<bool>, DynamicsError> {
    let mut mask = vec![false; n];
    match fixed {
        Fixed::Edge => match shape {
            Shape::Curve { .. } => {
                mask[0] = true;
                mask[n - 1] = true;
            }
            Shape::Surface { count_v, .. } => {
                let nv = *count_v;
                let nu = n / nv;
                for i in 0..nu {
                    for j in 0..nv {
                        if i == 0 || j == 0 || i + 1 == nu || j + 1 == nv {
                            mask[i * nv + j] = true;
                        }
                    }
                }
            }
        },
        Fixed::Points(list) => {
            for &i in list {
                let slot = mask
                    .get_mut(i)
                    .ok_or(DynamicsError::FixedIndex { index: i, count: n })?;
                if *slot {
                    return Err(DynamicsError::FixedTwice { index: i });
                }
                *slot = true;
            }
        }
    }
    Ok(mask)
}

/// Derivatives of the rest shape at a quadrature point: `[S, S_u, S_v, S_uu, S_uv, S_vv]`.
fn rest_geometry(local: &Local, rest: &[[f64; 3]]) -> [[f64; 3]; 6] {
    let mut g = [[0.0; 3]; 6];
    for (m, &i) in local.index.iter().enumerate() {
        let p = rest[i];
        let c = [
            local.r[m],
            local.d1[m][0],
            local.d1[m][1],
            local.d2[m][0],
            local.d2[m][1],
            local.d2[m][2],
        ];
        for (gk, ck) in g.iter_mut().zip(c) {
            *gk = add(*gk, scale(p, ck));
        }
    }
    g
}

/// Per basis function, the quantities whose products make the stiffness: the gradient and
/// the Hessian by the rest shape's arc length or metric, each flattened so that a dot
/// product of two is the integrand's contraction.
struct Grads {
    first: Vec<Vec<f64>>,
    second: Vec<Vec<f64>>,
}

/// Curves: `ds = g du` with `g = |C'|`, `d/ds = (1/g) d/du`,
/// `d²/ds² = (1/g²) (d²/du² − (g'/g) d/du)`, `g' = C'·C''/g`.
fn curve_terms(
    geometry: &[[f64; 3]; 6],
    local: &Local,
    at: [f64; 2],
) -> Result<(f64, Grads), DynamicsError> {
    let (cu, cuu) = (geometry[1], geometry[3]);
    let g = dot(&cu, &cu).sqrt();
    if !(g > 0.0 && g.is_finite()) {
        return Err(DynamicsError::ZeroSpeed { params: at });
    }
    let gp = dot(&cu, &cuu) / g;
    let (first, second) = (0..local.r.len())
        .map(|m| {
            let (ru, ruu) = (local.d1[m][0], local.d2[m][0]);
            (vec![ru / g], vec![(ruu - gp / g * ru) / (g * g)])
        })
        .unzip();
    Ok((g, Grads { first, second }))
}

/// Surfaces: metric `G = [S_u·S_u, S_u·S_v; S_u·S_v, S_v·S_v]`, `dA = √det G du dv`; the
/// membrane term `∇Rᵀ G⁻¹ ∇R`, the bending term the squared norm of the covariant Hessian
/// `H_ab = R_ab − Γᶜ_ab R_c` (`Γᶜ_ab = Gᶜᵈ S_ab·S_d`) contracted with `G⁻¹` on both
/// indices, `tr(G⁻¹ H G⁻¹ H')`. Flattened with `G⁻¹ = Lᵀ L`: `first = L ∇R` and
/// `second = L H Lᵀ`, whose dot products are those contractions.
fn surface_terms(
    geometry: &[[f64; 3]; 6],
    local: &Local,
    at: [f64; 2],
) -> Result<(f64, Grads), DynamicsError> {
    let (su, sv) = (geometry[1], geometry[2]);
    let (e, f, g) = (dot(&su, &su), dot(&su, &sv), dot(&sv, &sv));
    let det = e * g - f * f;
    if !(det > 0.0 && det.is_finite()) {
        return Err(DynamicsError::ZeroSpeed { params: at });
    }
    let inv = [[g / det, -f / det], [-f / det, e / det]];
    // L = Cᵀ with C the (lower) Cholesky factor of G⁻¹ = C Cᵀ.
    let c00 = inv[0][0].sqrt();
    let c10 = inv[1][0] / c00;
    let c11 = (inv[1][1] - c10 * c10).max(0.0).sqrt();
    let l = [[c00, c10], [0.0, c11]];
    let tangents = [su, sv];
    let seconds = [[geometry[3], geometry[4]], [geometry[4], geometry[5]]];
    // Γᶜ_ab = Gᶜᵈ (S_ab · S_d)
    let mut gamma = [[[0.0; 2]; 2]; 2];
    for a in 0..2 {
        for b in 0..2 {
            let proj = [
                dot(&seconds[a][b], &tangents[0]),
                dot(&seconds[a][b], &tangents[1]),
            ];
            for c in 0..2 {
                gamma[c][a][b] = inv[c][0] * proj[0] + inv[c][1] * proj[1];
            }
        }
    }
    let mut first = Vec::with_capacity(local.r.len());
    let mut second = Vec::with_capacity(local.r.len());
    for m in 0..local.r.len() {
        let grad = local.d1[m];
        let [ruu, ruv, rvv] = local.d2[m];
        let raw = [[ruu, ruv], [ruv, rvv]];
        let mut h = [[0.0; 2]; 2];
        for a in 0..2 {
            for b in 0..2 {
                h[a][b] = raw[a][b] - gamma[0][a][b] * grad[0] - gamma[1][a][b] * grad[1];
            }
        }
        first.push(
            (0..2)
                .map(|i| l[i][0] * grad[0] + l[i][1] * grad[1])
                .collect(),
        );
        let mut lhl = Vec::with_capacity(4);
        for i in 0..2 {
            for j in 0..2 {
                let mut s = 0.0;
                for a in 0..2 {
                    for b in 0..2 {
                        s += l[i][a] * h[a][b] * l[j][b];
                    }
                }
                lhl.push(s);
            }
        }
        second.push(lhl);
    }
    Ok((det.sqrt(), Grads { first, second }))
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
