//! Symmetric banded matrices and their Cholesky factors, for the D-NURBS matrices: a control
//! point interacts only with those whose basis functions share a knot span, so `M`, `D` and
//! `K` are banded (half-bandwidth `p` for a curve of degree `p`, `p·n_v + q` for a surface
//! stored row by row).

/// A symmetric `n × n` matrix whose entries vanish more than `b` off the diagonal. Row `i`
/// stores columns `i − b ..= i`.
#[derive(Clone, Debug, PartialEq)]
pub struct SymBand {
    n: usize,
    b: usize,
    data: Vec<f64>,
}

/// A pivot at most this fraction of its row's diagonal is rounding, not stiffness: the
/// factorisation takes the matrix as singular there. A plate pinned on one line (free to
/// turn about it) leaves pivots of rounding size, a few ε of the diagonal, that a bare
/// `> 0` test took for stiffness (`tests/held.rs` fails with a zero tolerance); the held
/// bodies of the tests keep their pivots within a few orders of their diagonals. 1e-10 lies
/// far from both.
pub const PIVOT_TOL: f64 = 1e-10;

/// A matrix that is not positive definite: its Cholesky factorisation met a pivot that is
/// not positive, not finite, or at most [`PIVOT_TOL`] of its diagonal, at `row`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotPositive {
    /// The row of the failing pivot.
    pub row: usize,
}

impl SymBand {
    /// The zero matrix.
    pub fn zeros(n: usize, b: usize) -> Self {
        let b = b.min(n.saturating_sub(1));
        SymBand {
            n,
            b,
            data: vec![0.0; n * (b + 1)],
        }
    }

    /// Order.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Half-bandwidth.
    pub fn bandwidth(&self) -> usize {
        self.b
    }

    fn index(&self, i: usize, j: usize) -> Option<usize> {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        (i < self.n && i - j <= self.b).then(|| i * (self.b + 1) + self.b + j - i)
    }

    /// Entry `(i, j)` (zero outside the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.index(i, j).map_or(0.0, |k| self.data[k])
    }

    /// Adds `value` to entries `(i, j)` and `(j, i)` (once when `i = j`). Entries outside the
    /// band are a caller's bug: debug builds assert, release builds ignore them.
    pub fn add(&mut self, i: usize, j: usize, value: f64) {
        let k = self.index(i, j);
        debug_assert!(k.is_some(), "({i}, {j}) outside the band {}", self.b);
        if let Some(k) = k {
            self.data[k] += value;
        }
    }

    /// `Σ cₖ Aₖ` of matrices of one shape.
    pub fn combine(terms: &[(f64, &SymBand)]) -> SymBand {
        let (n, b) = terms.first().map_or((0, 0), |(_, a)| (a.n, a.b));
        let mut out = SymBand::zeros(n, b);
        for (c, a) in terms {
            debug_assert!(a.n == n && a.b == b);
            for (o, x) in out.data.iter_mut().zip(&a.data) {
                *o += c * x;
            }
        }
        out
    }

    /// Replaces row and column `k` with those of the identity: the equation of a fixed
    /// coordinate (`x_k = rhs_k`, with the rhs set to 0).
    pub fn pin(&mut self, k: usize) {
        for j in k.saturating_sub(self.b)..(k + self.b + 1).min(self.n) {
            if let Some(idx) = self.index(k, j) {
                self.data[idx] = if j == k { 1.0 } else { 0.0 };
            }
        }
    }

    /// `y = A x` for vectors of `D`-component nodes.
    pub fn mul<const D: usize>(&self, x: &[[f64; D]], y: &mut [[f64; D]]) {
        for i in 0..self.n {
            y[i] = [0.0; D];
        }
        for i in 0..self.n {
            let row = &self.data[i * (self.b + 1)..][..self.b + 1];
            let j0 = i.saturating_sub(self.b);
            for j in j0..i {
                let a = row[self.b + j - i];
                for c in 0..D {
                    y[i][c] += a * x[j][c];
                    y[j][c] += a * x[i][c];
                }
            }
            let a = row[self.b];
            for c in 0..D {
                y[i][c] += a * x[i][c];
            }
        }
    }

    /// `xᵀ A x` summed over the components of `D`-component nodes.
    pub fn quadratic<const D: usize>(&self, x: &[[f64; D]]) -> f64 {
        let mut y = vec![[0.0; D]; self.n];
        self.mul(x, &mut y);
        x.iter()
            .zip(&y)
            .map(|(a, b)| (0..D).map(|c| a[c] * b[c]).sum::<f64>())
            .sum()
    }

    /// The banded Cholesky factor `L` (`A = L Lᵀ`, `L` with the same band), or the row where
    /// `A` shows it is not positive definite.
    pub fn cholesky(&self) -> Result<Cholesky, NotPositive> {
        let (n, b) = (self.n, self.b);
        let mut l = self.clone();
        for i in 0..n {
            let j0 = i.saturating_sub(b);
            for j in j0..=i {
                let k0 = j.saturating_sub(b).max(j0);
                let mut s = l.get(i, j);
                for k in k0..j {
                    s -= l.get(i, k) * l.get(j, k);
                }
                let Some(idx) = l.index(i, j) else { continue };
                if j == i {
                    if !(s > PIVOT_TOL * self.get(i, i) && s.is_finite()) {
                        return Err(NotPositive { row: i });
                    }
                    l.data[idx] = s.sqrt();
                } else {
                    l.data[idx] = s / l.get(j, j);
                }
            }
        }
        Ok(Cholesky { l })
    }
}

/// `A = L Lᵀ` of a symmetric positive definite banded matrix.
#[derive(Clone, Debug, PartialEq)]
pub struct Cholesky {
    l: SymBand,
}

impl Cholesky {
    /// Solves `A x = rhs` in place, for every component of `D`-component nodes.
    pub fn solve<const D: usize>(&self, x: &mut [[f64; D]]) {
        let (n, b) = (self.l.n, self.l.b);
        for i in 0..n {
            let row = &self.l.data[i * (b + 1)..][..b + 1];
            let mut s = x[i];
            for j in i.saturating_sub(b)..i {
                let a = row[b + j - i];
                for c in 0..D {
                    s[c] -= a * x[j][c];
                }
            }
            for c in 0..D {
                x[i][c] = s[c] / row[b];
            }
        }
        for i in (0..n).rev() {
            let d = self.l.data[i * (b + 1) + b];
            for c in 0..D {
                x[i][c] /= d;
            }
            let xi = x[i];
            let row = &self.l.data[i * (b + 1)..][..b + 1];
            for j in i.saturating_sub(b)..i {
                let a = row[b + j - i];
                for c in 0..D {
                    x[j][c] -= a * xi[c];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 1-D Laplacian with Dirichlet ends, `tridiag(−1, 2, −1)`, whose inverse is known in
    /// closed form: `(A⁻¹)_ij = min(i, j)+1 · (n − max(i, j)) / (n + 1)` (0-based).
    #[test]
    fn solves_the_discrete_laplacian_exactly() {
        let n = 9;
        let mut a = SymBand::zeros(n, 1);
        for i in 0..n {
            a.add(i, i, 2.0);
            if i > 0 {
                a.add(i, i - 1, -1.0);
            }
        }
        let chol = a.cholesky().expect("the Laplacian is positive definite");
        for k in 0..n {
            let mut x = vec![[0.0; 1]; n];
            x[k][0] = 1.0;
            chol.solve(&mut x);
            for i in 0..n {
                let exact = ((i.min(k) + 1) * (n - i.max(k))) as f64 / (n + 1) as f64;
                assert!(
                    (x[i][0] - exact).abs() < 1e-13,
                    "({i}, {k}): {} vs {exact}",
                    x[i][0]
                );
            }
        }
    }

    /// A wider band, checked by multiplying back: `A (A⁻¹ r) = r`, and against the dense
    /// product for `mul`.
    #[test]
    fn wide_band_round_trips() {
        let (n, b) = (20, 4);
        let mut a = SymBand::zeros(n, b);
        for i in 0..n {
            for j in i.saturating_sub(b)..=i {
                let v = if i == j {
                    10.0
                } else {
                    1.0 / (1.0 + (i * 7 + j * 3) as f64 % 5.0)
                };
                a.add(i, j, v);
            }
        }
        let r: Vec<[f64; 2]> = (0..n).map(|i| [i as f64, 1.0 - i as f64 * 0.5]).collect();
        let mut dense = vec![[0.0; 2]; n];
        for i in 0..n {
            for j in 0..n {
                for c in 0..2 {
                    dense[i][c] += a.get(i, j) * r[j][c];
                }
            }
        }
        let mut y = vec![[0.0; 2]; n];
        a.mul(&r, &mut y);
        assert_eq!(y, dense);
        let mut x = r.clone();
        a.cholesky().expect("diagonally dominant").solve(&mut x);
        let mut back = vec![[0.0; 2]; n];
        a.mul(&x, &mut back);
        for i in 0..n {
            for c in 0..2 {
                assert!((back[i][c] - r[i][c]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn indefinite_is_refused_at_its_row() {
        let mut a = SymBand::zeros(3, 1);
        a.add(0, 0, 1.0);
        a.add(1, 0, 2.0);
        a.add(1, 1, 1.0);
        a.add(2, 2, 1.0);
        assert_eq!(a.cholesky(), Err(NotPositive { row: 1 }));
    }
}
