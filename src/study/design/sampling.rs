//! The cases a design study draws: a grid's combinations, a Latin hypercube or Monte Carlo from a
//! seeded ChaCha8 stream (the recipe is in the module docs of `design`).

use super::{DesignParameter, DesignSpec, Distribution, Sampling};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};

/// The number of cases, saturating (checked against [`MAX_CASES`](super::MAX_CASES) at load).
pub fn case_count(spec: &DesignSpec) -> usize {
    match spec.sampling {
        Sampling::Grid => spec.parameters.iter().map(grid_len).fold(1usize, usize::saturating_mul),
        Sampling::LatinHypercube { n, .. } | Sampling::MonteCarlo { n, .. } => n,
    }
}

fn grid_len(p: &DesignParameter) -> usize {
    match &p.values {
        Some(v) => v.len(),
        None => p.points.unwrap_or(0),
    }
}

/// The point at fraction `t` ∈ [0, 1] of a parameter's range: uniform (geometric with `log`),
/// or the quantile of the truncated normal (see [`Distribution::Normal`]).
fn at_fraction(p: &DesignParameter, t: f64) -> f64 {
    use statrs::distribution::{ContinuousCDF, Normal};
    let (a, b) = (p.from.unwrap_or(0.0), p.to.unwrap_or(0.0));
    match p.distribution {
        Distribution::Uniform if p.log => a * (b / a).powf(t),
        Distribution::Uniform => a + (b - a) * t,
        Distribution::Normal { mean, sd } => {
            // Checked at load: sd > 0 and finite, so the standard normal is valid.
            let Ok(z) = Normal::new(0.0, 1.0) else { return f64::NAN };
            let (pa, pb) = (z.cdf((a - mean) / sd), z.cdf((b - mean) / sd));
            // Rounding may put the quantile a hair outside the limits; the limits hold.
            (mean + sd * z.inverse_cdf(pa + t * (pb - pa))).clamp(a, b)
        }
    }
}

/// The `k`-th of a grid parameter's values.
fn grid_value(p: &DesignParameter, k: usize) -> f64 {
    if let Some(v) = &p.values {
        return v[k];
    }
    let points = p.points.unwrap_or(2);
    // The ends exactly as written: `a + (b − a)·1` may round away from b.
    if k + 1 == points { p.to.unwrap_or(0.0) } else { at_fraction(p, k as f64 / (points - 1) as f64) }
}

/// A uniform number in [0, 1) from the top 53 bits of one draw.
pub fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform integer in 0..k (k ≥ 1) by rejection: draws at or above the largest multiple of k
/// are redrawn, so every value is equally likely.
pub fn below(rng: &mut ChaCha8Rng, k: u64) -> u64 {
    let zone = u64::MAX - u64::MAX % k;
    loop {
        let x = rng.next_u64();
        if x < zone {
            return x % k;
        }
    }
}

/// Every case's parameter values (outer index: case), as the module docs define them.
pub fn case_values(spec: &DesignSpec) -> Vec<Vec<f64>> {
    let d = spec.parameters.len();
    match spec.sampling {
        Sampling::Grid => {
            let lens: Vec<usize> = spec.parameters.iter().map(grid_len).collect();
            let n = case_count(spec);
            (0..n)
                .map(|i| {
                    let mut rest = i;
                    let mut row = vec![0.0; d];
                    for k in (0..d).rev() {
                        row[k] = grid_value(&spec.parameters[k], rest % lens[k]);
                        rest /= lens[k];
                    }
                    row
                })
                .collect()
        }
        Sampling::LatinHypercube { n, seed } => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut rows = vec![vec![0.0; d]; n];
            for (k, p) in spec.parameters.iter().enumerate() {
                let mut strata: Vec<usize> = (0..n).collect();
                for j in (1..n).rev() {
                    strata.swap(j, below(&mut rng, j as u64 + 1) as usize);
                }
                for (row, &s) in rows.iter_mut().zip(&strata) {
                    row[k] = at_fraction(p, (s as f64 + uniform(&mut rng)) / n as f64);
                }
            }
            rows
        }
        Sampling::MonteCarlo { n, seed } => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            (0..n).map(|_| spec.parameters.iter().map(|p| at_fraction(p, uniform(&mut rng))).collect()).collect()
        }
    }
}
