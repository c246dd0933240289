//! The first-order optimality (Karush–Kuhn–Tucker) check of a reported optimum, in the
//! optimiser's scaled variables (u, t): the multipliers λ ≥ 0 of the active constraints and
//! bounds that best cancel the objective's gradient, by non-negative least squares
//! (Lawson–Hanson's active-set loop on a system of at most a few tens of columns: no crate in
//! the tree offers it, and nalgebra's least squares give the unconstrained step), and the
//! residual `max(‖∇t + Σλᵢ∇gᵢ‖∞, max gᵢ⁺, max |λᵢ gᵢ|)`.

use nalgebra::{DMatrix, DVector};

/// A constraint row counts as active when its scaled value is at least −this.
pub const ACTIVE: f64 = 1e-6;

/// The optimality check of one design.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Kkt {
    /// Per constraint row, its multiplier (0 where inactive).
    pub multipliers: Vec<f64>,
    /// Per variable, the multiplier of its active bound (negative: the lower bound), else 0.
    pub bound_multipliers: Vec<f64>,
    /// The stationarity residual ‖∇t + Σλ∇g‖∞ in the scaled variables.
    pub stationarity: f64,
    /// The largest constraint violation (scaled, ≥ 0).
    pub violation: f64,
    /// The largest |λᵢ gᵢ|.
    pub complementarity: f64,
    /// The largest of the three: the KKT residual.
    pub residual: f64,
}

/// The check at u ∈ [0, 1]ⁿ with the constraint rows `(name, g, ∇g in (u, t))`.
pub fn kkt(rows: &[(String, f64, Vec<f64>)], u: &[f64], n: usize) -> Kkt {
    // The active columns: constraint rows, then bounds (−eⱼ for u = 0, +eⱼ for u = 1).
    let mut cols: Vec<(Option<usize>, Vec<f64>)> = Vec::new();
    for (k, (_, g, grad)) in rows.iter().enumerate() {
        if *g >= -ACTIVE {
            cols.push((Some(k), grad.clone()));
        }
    }
    let mut bound_of = Vec::new();
    for (j, &uj) in u.iter().enumerate() {
        let sign = if uj <= 1e-9 {
            -1.0
        } else if uj >= 1.0 - 1e-9 {
            1.0
        } else {
            continue;
        };
        let mut e = vec![0.0; n + 1];
        e[j] = sign;
        bound_of.push((cols.len(), j, sign));
        cols.push((None, e));
    }
    let a = DMatrix::from_fn(n + 1, cols.len(), |i, c| cols[c].1[i]);
    let mut b = DVector::zeros(n + 1);
    b[n] = -1.0;
    let lambda = nnls(&a, &b);
    let stationarity = if cols.is_empty() { 1.0 } else { (&a * &lambda - &b).amax() };
    let mut multipliers = vec![0.0; rows.len()];
    for (c, (row, _)) in cols.iter().enumerate() {
        if let Some(k) = row {
            multipliers[*k] = lambda[c];
        }
    }
    let mut bound_multipliers = vec![0.0; n];
    for &(c, j, sign) in &bound_of {
        bound_multipliers[j] = sign * lambda[c];
    }
    let violation = rows.iter().map(|r| r.1.max(0.0)).fold(0.0, f64::max);
    let complementarity = rows.iter().zip(&multipliers).map(|(r, l)| (r.1 * l).abs()).fold(0.0, f64::max);
    let residual = stationarity.max(violation).max(complementarity);
    Kkt { multipliers, bound_multipliers, stationarity, violation, complementarity, residual }
}

/// Lawson and Hanson's non-negative least squares: min ‖Aλ − b‖ over λ ≥ 0.
fn nnls(a: &DMatrix<f64>, b: &DVector<f64>) -> DVector<f64> {
    let m = a.ncols();
    let mut x = DVector::zeros(m);
    let mut passive = vec![false; m];
    // Each outer step frees one column; the inner loop keeps the iterate feasible. 3m outer
    // steps bound the work (the loop ends in at most m on exact arithmetic).
    for _ in 0..3 * m.max(1) {
        let w = a.transpose() * (b - a * &x);
        let free = (0..m).filter(|&j| !passive[j] && w[j] > 1e-14).max_by(|&i, &j| w[i].total_cmp(&w[j]));
        let Some(j) = free else { break };
        passive[j] = true;
        loop {
            let idx: Vec<usize> = (0..m).filter(|&j| passive[j]).collect();
            let sub = a.select_columns(&idx);
            let z_sub = sub.clone().svd(true, true).solve(b, 1e-14).unwrap_or_else(|_| DVector::zeros(idx.len()));
            if z_sub.iter().all(|&v| v > 0.0) {
                for (k, &j) in idx.iter().enumerate() {
                    x[j] = z_sub[k];
                }
                break;
            }
            // Step back to the first passive variable that would turn negative, and drop it.
            let mut alpha = 1.0f64;
            for (k, &j) in idx.iter().enumerate() {
                if z_sub[k] <= 0.0 && x[j] - z_sub[k] > 0.0 {
                    alpha = alpha.min(x[j] / (x[j] - z_sub[k]));
                }
            }
            for (k, &j) in idx.iter().enumerate() {
                x[j] += alpha * (z_sub[k] - x[j]);
                if x[j] <= 1e-15 {
                    x[j] = 0.0;
                    passive[j] = false;
                }
            }
        }
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// min t s.t. t ≥ 1 − u (one row g = 1 − u − t) and u ≤ 1: at u = 1, t = 0 the row is active
    /// with λ = 1 (∇t = (0, 1), ∇g = (−1, −1)) and the upper bound with μ = 1; the hand KKT
    /// system `(0,1) + λ(−1,−1) + μ(1,0) = 0` gives both exactly.
    #[test]
    fn multipliers_of_a_corner_solve_the_hand_system() {
        let rows = vec![("row".to_string(), 0.0, vec![-1.0, -1.0])];
        let k = kkt(&rows, &[1.0], 1);
        assert!((k.multipliers[0] - 1.0).abs() < 1e-12 && (k.bound_multipliers[0] - 1.0).abs() < 1e-12, "{k:?}");
        assert!(k.residual < 1e-12, "{k:?}");
    }

    /// A row whose gradient points the wrong way gets λ = 0 and leaves a residual: the check
    /// can fail (∇t = (0, 1) cannot be cancelled by λ(0, 1) with λ ≥ 0).
    #[test]
    fn a_wrong_signed_row_is_not_an_optimum() {
        let rows = vec![("row".to_string(), 0.0, vec![0.0, 1.0])];
        let k = kkt(&rows, &[0.5], 1);
        assert_eq!(k.multipliers[0], 0.0);
        assert!((k.residual - 1.0).abs() < 1e-12, "{k:?}");
    }
}
