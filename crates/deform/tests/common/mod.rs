//! What the deform crate's integration tests share: a 10 cm object on clamped uniform
//! knots with its control points at the Greville abscissae (a linear parametrisation).

/// Length of the string or side of the membrane (m): a 10 cm object under a fingertip.
pub const L: f64 = 0.1;

/// Clamped uniform knots of degree `p` for `n` points.
pub fn uniform_knots(p: usize, n: usize) -> Vec<f32> {
    let inner = n - p;
    let mut k = vec![0.0; p + 1];
    k.extend((1..inner).map(|i| i as f32 / inner as f32));
    k.extend(vec![1.0; p + 1]);
    k
}

/// Greville abscissae `(u_{i+1} + … + u_{i+p}) / p`: control points there make the straight
/// curve's parametrisation linear, `x(u) = L u`, so that polynomials in `x` are polynomials
/// in `u` and the spline space holds the string's parabola exactly.
pub fn greville(knots: &[f32], p: usize, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| (1..=p).map(|k| f64::from(knots[i + k])).sum::<f64>() / p as f64)
        .collect()
}
