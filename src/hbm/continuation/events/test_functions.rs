//! The test functions of a branch point (dλ/ds; per Floquet block Π(μ − 1), Π(μ + 1),
//! Π(μ_i μ_j − 1)), kept as sign and logarithm, the dip of one between points that a pair of
//! crossings inside a step leaves, and the insertion of a point found inside a segment.

use crate::hbm::continuation::branch::{Branch, BranchPoint};
use crate::hbm::series::PairSense;

/// Each accepted point's arclength and [`test_functions`].
pub(in crate::hbm::continuation) type Tests = Vec<(f64, Vec<(f64, f64)>)>;

/// One point's pairs near ±1, per Floquet block.
pub(in crate::hbm::continuation) type PairSenses = Vec<Vec<PairSense>>;

/// Each accepted point's [`PairSenses`].
pub(in crate::hbm::continuation) type Senses = Vec<PairSenses>;

/// Inserts a point found inside a segment before index `at`, with its test functions and
/// senses, and moves the folds after it along.
pub(in crate::hbm::continuation) fn insert_point(
    branch: &mut Branch,
    tests: &mut Tests,
    senses: &mut Senses,
    at: usize,
    (point, ps): (BranchPoint, PairSenses),
) {
    tests.insert(at, (point.arclength, test_functions(&point)));
    if senses.len() >= at {
        senses.insert(at, ps);
    }
    branch.points.insert(at, point);
    for f in &mut branch.folds {
        if f.after >= at {
            f.after += 1;
        }
    }
}

/// The test functions of a branch point whose sign changes mark the events of a branch, each as
/// (sign, ln |value|) so that products over many multipliers neither overflow nor underflow:
/// dλ/ds (folds), and per Floquet block Π(μ − 1) (a real multiplier through +1), Π(μ + 1)
/// (through −1) and Π_{i<j}(μ_i μ_j − 1) (a complex pair through the unit circle: Neimark–Sacker;
/// it also vanishes at a neutral saddle, μ_i μ_j = 1 with both real). Products of all the
/// block's multipliers are symmetric functions of them, so they stay smooth where a complex
/// pair meets on the real axis and splits.
pub(in crate::hbm::continuation) fn test_functions(p: &BranchPoint) -> Vec<(f64, f64)> {
    let mut out = vec![(p.slope.signum(), p.slope.abs().ln())];
    let Some(st) = &p.solution.stability else { return out };
    let product = |fs: &mut dyn Iterator<Item = nalgebra::Complex<f64>>| {
        let (mut sign, mut log) = (nalgebra::Complex::new(1.0, 0.0), 0.0);
        for f in fs {
            let r = f.norm();
            log += r.ln();
            if r > 0.0 {
                sign *= f / r;
            }
        }
        (sign.re.signum(), log)
    };
    let one = nalgebra::Complex::new(1.0, 0.0);
    for b in &st.blocks {
        let mu = &b.multipliers;
        out.push(product(&mut mu.iter().map(|m| m - one)));
        out.push(product(&mut mu.iter().map(|m| m + one)));
        out.push(product(
            &mut (0..mu.len()).flat_map(|i| (i + 1..mu.len()).map(move |j| (i, j))).map(|(i, j)| mu[i] * mu[j] - one),
        ));
    }
    out
}

/// ln of the smallest factor's magnitude in test function j of [`test_functions`] at `p` (the
/// multiplier, or product of two, nearest to its critical value); +∞ when `p` has none.
pub(super) fn nearest_factor(p: &BranchPoint, j: usize) -> f64 {
    let Some(st) = &p.solution.stability else { return f64::INFINITY };
    let (Some(block), kind) = (j.checked_sub(1).map(|k| k / 3), j.checked_sub(1).map_or(0, |k| k % 3)) else {
        return f64::INFINITY;
    };
    let Some(b) = st.blocks.get(block) else { return f64::INFINITY };
    let mu = &b.multipliers;
    let one = nalgebra::Complex::new(1.0, 0.0);
    let least = match kind {
        0 => mu.iter().map(|m| (m - one).norm()).fold(f64::INFINITY, f64::min),
        1 => mu.iter().map(|m| (m + one).norm()).fold(f64::INFINITY, f64::min),
        _ => (0..mu.len())
            .flat_map(|a| (a + 1..mu.len()).map(move |c| (a, c)))
            .map(|(a, c)| (mu[a] * mu[c] - one).norm())
            .fold(f64::INFINITY, f64::min),
    };
    least.ln()
}

/// Where a test function is suspected to dip through zero and back between `b` and `c` (both
/// with the same sign): the extremum of the quadratic through the three points' values (in
/// arclength), when it lies between b and c and has the other sign. Each point is its arclength
/// and [`test_functions`]; the values are taken relative to b's magnitude. Each dipping test
/// function's index with its extremum's arclength.
pub(in crate::hbm::continuation) fn dip(
    a: &(f64, Vec<(f64, f64)>),
    b: &(f64, Vec<(f64, f64)>),
    c: &(f64, Vec<(f64, f64)>),
) -> Vec<(usize, f64)> {
    let ((s0, ta), (s1, tb), (s2, tc)) = (a, b, c);
    let (s0, s1, s2) = (*s0, *s1, *s2);
    if ta.len() != tb.len() || tb.len() != tc.len() || !(s0 < s1 && s1 < s2) {
        return Vec::new();
    }
    let mut out = Vec::new();
    for (j, ((fa, fb), fc)) in ta.iter().zip(tb).zip(tc).enumerate() {
        if fb.0 != fc.0 || fb.0 == 0.0 || !(fa.1.is_finite() && fb.1.is_finite() && fc.1.is_finite()) {
            continue;
        }
        let v = |f: &(f64, f64)| f.0 * (f.1 - fb.1).clamp(-700.0, 700.0).exp();
        let (y0, y1, y2) = (v(fa), v(fb), v(fc));
        // Newton's divided differences: q(s) = y1 + d1 (s − s1) + d2 (s − s1)(s − s2).
        let d1 = (y2 - y1) / (s2 - s1);
        let d2 = ((y2 - y1) / (s2 - s1) - (y1 - y0) / (s1 - s0)) / (s2 - s0);
        if d2 == 0.0 || !d2.is_finite() {
            continue;
        }
        // q'(s) = d1 + d2 (2s − s1 − s2) = 0.
        let s_ext = 0.5 * (s1 + s2) - 0.5 * d1 / d2;
        if !(s1 < s_ext && s_ext < s2) {
            continue;
        }
        let q = y1 + d1 * (s_ext - s1) + d2 * (s_ext - s1) * (s_ext - s2);
        if q.signum() != fb.0 {
            out.push((j, s_ext));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::dip;
    use approx::abs_diff_eq;

    /// A test function as (sign, ln |value|).
    fn tf(v: f64) -> (f64, f64) {
        (v.signum(), v.abs().ln())
    }

    /// `(s − 1)² − 0.01` is positive at s = −1, 0 and 2 but negative around s = 1: the dip is
    /// found at the parabola's vertex, s = 1 (exact, the quadratic is the function); a monotone
    /// function and one whose vertex keeps the sign give none.
    #[test]
    fn a_dip_between_points_is_found_at_its_vertex() {
        let f = |s: f64| (s - 1.0) * (s - 1.0) - 0.01;
        let p = |s: f64, g: &dyn Fn(f64) -> f64| (s, vec![tf(g(s))]);
        let found = dip(&p(-1.0, &f), &p(0.0, &f), &p(2.0, &f));
        assert_eq!(found.len(), 1);
        assert!(found[0].0 == 0 && abs_diff_eq!(found[0].1, 1.0, epsilon = 1e-12), "{found:?}");
        let g = |s: f64| 1.0 + s;
        assert!(dip(&p(-0.5, &g), &p(0.0, &g), &p(2.0, &g)).is_empty());
        let h = |s: f64| (s - 1.0) * (s - 1.0) + 0.01;
        assert!(dip(&p(-1.0, &h), &p(0.0, &h), &p(2.0, &h)).is_empty());
    }
}
