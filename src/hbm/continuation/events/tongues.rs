//! Pairs of crossings stepped over whole: a test function's deep minimum at an accepted point
//! (golden section on its magnitude), and a tongue told by the flipped sense of a Floquet pair
//! near ±1 (bisection on the sense); a state inside is inserted as a point.

use super::test_functions::{PairSenses, Senses, Tests, insert_point, nearest_factor, test_functions};
use crate::hbm::balance::{Hbm, Setup};
use crate::hbm::continuation::branch::{Branch, BranchPoint};
use crate::hbm::series::PairSense;
use nalgebra::DVector;

impl Hbm {
    /// Pairs of crossings that one step stepped over whole: a multiplier that leaves the unit
    /// circle and comes back inside a stretch shorter than the step (a narrow Mathieu tongue of
    /// period doubling, a short loss of unison) leaves its test function with one sign at every
    /// accepted point, but with a deep minimum of its magnitude at the point nearest the
    /// stretch. Where a test function's magnitude at an accepted point is below a quarter of
    /// both neighbours' (same sign at all three), and its factor nearest to zero
    /// ([`nearest_factor`]) below half of theirs, its minimum over the two segments around the
    /// point is searched (golden section in arclength, states from [`Branch::interpolate`]
    /// solved at the fixed parameter, 16 evaluations at most); a state where the function has
    /// the other sign is inserted as a point, so that the pair shows as two changes of sign
    /// between accepted points and is located and classified like any other. Segments with a
    /// fold are left alone (the parameter is not monotone there).
    pub(in crate::hbm::continuation) fn split_narrow_pairs(
        &mut self,
        su: &Setup,
        branch: &mut Branch,
        tests: &mut Tests,
        senses: &mut Senses,
    ) {
        const DEPTH: f64 = std::f64::consts::LN_2 * 2.0;
        let mut i = 1;
        // `tests` holds every accepted point's test functions but the end point's, made by a
        // solve at fixed parameter: the two agree index by index up to there.
        while i + 1 < tests.len() && tests.len() <= branch.points.len() {
            let (a, b, c) = (&tests[i - 1].1, &tests[i].1, &tests[i + 1].1);
            let near_fold = branch.folds.iter().any(|f| f.after + 1 == i || f.after == i);
            // The slope (index 0) is the folds' own test, kept by the tangents.
            let suspect = (1..b.len()).find(|&j| {
                a.len() == b.len()
                    && c.len() == b.len()
                    && b[j].0 != 0.0
                    && a[j].0 == b[j].0
                    && c[j].0 == b[j].0
                    && b[j].1 + DEPTH < a[j].1.min(c[j].1)
            });
            let (Some(j), false) = (suspect, near_fold) else {
                i += 1;
                continue;
            };
            // A product over many multipliers (33 on 16 pendulums: 528 factors in the
            // Neimark–Sacker test) dips by far more than this from the small motions of factors
            // nowhere near zero; a pair that passes through its critical value and back drags its
            // own factor down with it. So the nearest factor must dip too (by half the depth: a
            // conjugate pair's two factors have the same magnitude and make the product's dip
            // twice its own).
            let nearest = |k: usize| nearest_factor(&branch.points[k], j);
            if nearest(i) + 0.5 * DEPTH >= nearest(i - 1).min(nearest(i + 1)) {
                i += 1;
                continue;
            }
            let sign = b[j].0;
            // t in [0, 2]: segment i−1 for t < 1, segment i beyond; t = 1 is point i.
            let at = |t: f64| if t < 1.0 { (i - 1, t) } else { (i, t - 1.0) };
            let Some((t, found)) = self.golden_for_sign(su, branch, &at, (0.0, 1.0, 2.0), b[j].1, j, sign) else {
                i += 1;
                continue;
            };
            let at = if t < 1.0 { i } else { i + 1 };
            insert_point(branch, tests, senses, at, found);
            // Past the inserted point and its neighbours: they now straddle the changes.
            i = at + 2;
        }
    }

    /// Tongues stepped over whole, told by the sense of a pair near ±1 (see
    /// `stability::PairSense`): where the member with Im μ > 0 of a pair near −1 (+1) turns the
    /// other way at the end of a segment than at its start (the same pair: eigenvectors parallel
    /// up to conjugation) while the block's Π(μ + 1) (Π(μ − 1)) kept its sign, the pair met on
    /// the real axis inside the segment, and passed through −1 (+1) and back there unless it met
    /// inside the unit circle. The segment is bisected on the sense (states from
    /// [`Branch::interpolate`] solved at the fixed parameter) until a state inside the tongue is
    /// found, or one where the pair is real but the test function has its old sign (the real
    /// stretch is wider than the tongue): then its magnitude is minimised by golden section
    /// between the two senses' states. A state where the test function has the other sign is
    /// inserted as a point, so the pair becomes two changes of sign between accepted points.
    /// Segments with a fold are left alone, and so are flips whose pair match is ambiguous or
    /// whose senses are faint (`clear_flip`: clustered pairs).
    pub(in crate::hbm::continuation) fn split_tongues(
        &mut self,
        su: &Setup,
        branch: &mut Branch,
        tests: &mut Tests,
        senses: &mut Senses,
    ) {
        let mut i = 0;
        while i + 1 < tests.len() && tests.len() <= branch.points.len() && senses.len() == tests.len() {
            let Some((j, block, pair, span)) = flipped(tests, senses, i) else {
                i += 1;
                continue;
            };
            if branch.folds.iter().any(|f| f.after >= i && f.after < i + span) {
                i += 1;
                continue;
            }
            let sign = tests[i].1[j].0;
            let found = if span == 1 {
                self.bisect_on_sense(su, branch, i, (j, block, sign), &pair)
            } else {
                // The points in between hold the pair on the real axis: the tongue, if any, is
                // around the one where the test function is least.
                let m = (1..span).min_by(|&a, &b| tests[i + a].1[j].1.total_cmp(&tests[i + b].1[j].1)).unwrap_or(1);
                let at = |t: f64| {
                    let k = (t.floor() as usize).min(span - 1);
                    (i + k, t - k as f64)
                };
                self.golden_for_sign(su, branch, &at, (0.0, m as f64, span as f64), tests[i + m].1[j].1, j, sign)
            };
            let Some((t, point)) = found else {
                i += 1;
                continue;
            };
            let at = i + (t.floor() as usize).min(span - 1) + 1;
            insert_point(branch, tests, senses, at, point);
            i += span + 1;
        }
    }

    /// Bisection of segment i on the sense of `pair` (of `block`, at point i) until a state
    /// where test function j has the other sign than `sign`, or the pair is on the real axis
    /// (then golden section on the test function between the two senses' states): that σ and
    /// state.
    fn bisect_on_sense(
        &mut self,
        su: &Setup,
        branch: &Branch,
        i: usize,
        (j, block, sign): (usize, usize, f64),
        pair: &PairSense,
    ) -> Option<(f64, (BranchPoint, PairSenses))> {
        let (mut lo, mut hi) = (0.0, 1.0);
        let mut reference = pair.v.clone();
        let at = |t: f64| (i, t);
        for _ in 0..40 {
            if hi - lo < 1e-9 {
                break;
            }
            let mid = 0.5 * (lo + hi);
            let (point, ps) = self.point_on_segment(su, branch, i, mid)?;
            let f = test_functions(&point)[j];
            if f.0 != sign && f.0 != 0.0 {
                return Some((mid, (point, ps)));
            }
            match ps.get(block).and_then(|b| same_pair(b, pair.side, &reference)) {
                Some(p) if p.sense * pair.sense > 0.0 => {
                    lo = mid;
                    reference = p.v.clone();
                }
                Some(_) => hi = mid,
                None => return self.golden_for_sign(su, branch, &at, (lo, mid, hi), f.1, j, sign),
            }
        }
        None
    }

    /// The solution at fraction σ of segment `seg`, solved at the interpolated parameter, as a
    /// branch point with its stability (no tangent), and its pairs' senses.
    fn point_on_segment(
        &mut self,
        su: &Setup,
        branch: &Branch,
        seg: usize,
        sigma: f64,
    ) -> Option<(BranchPoint, PairSenses)> {
        let guess = branch.interpolate(seg, sigma)?;
        let lambda = su.param.value(&guess) / su.p_ref;
        let sol = self.solve_within(&su.at(lambda), Some(&guess), self.stall_floor()).ok()?;
        let y = self.y_of(su, &sol);
        let (sa, sb) = (branch.points[seg].arclength, branch.points[seg + 1].arclength);
        let point = self.branch_point(su, &y, None, sa + sigma * (sb - sa), sol.iterations, true).ok()?;
        Some((point, std::mem::take(&mut self.pair_senses)))
    }

    /// Golden section on ln |f_j| (test function j) over the bracket (lo, mid, hi) of a
    /// parameter t that `at` maps to (segment, σ), `f_mid` its value at mid, until a state
    /// where f_j has the other sign than `sign` (16 evaluations at most): that t and state.
    #[allow(clippy::too_many_arguments)]
    fn golden_for_sign(
        &mut self,
        su: &Setup,
        branch: &Branch,
        at: &dyn Fn(f64) -> (usize, f64),
        (mut lo, mut mid, mut hi): (f64, f64, f64),
        mut f_mid: f64,
        j: usize,
        sign: f64,
    ) -> Option<(f64, (BranchPoint, PairSenses))> {
        let golden = 0.381_966_011_250_105_2;
        for _ in 0..16 {
            let t = if mid - lo > hi - mid { mid - golden * (mid - lo) } else { mid + golden * (hi - mid) };
            let (seg, sigma) = at(t);
            let (point, ps) = self.point_on_segment(su, branch, seg, sigma)?;
            let (sg, lg) = *test_functions(&point).get(j)?;
            if sg != sign && sg != 0.0 {
                return Some((t, (point, ps)));
            }
            if lg < f_mid {
                if t < mid {
                    hi = mid;
                } else {
                    lo = mid;
                }
                (mid, f_mid) = (t, lg);
            } else if t < mid {
                lo = t;
            } else {
                hi = t;
            }
        }
        None
    }
}

/// The pair of `pairs` on `side` whose eigenvector is nearest to parallel to `v` or to its
/// conjugate (|vᴴw| or |vᵀw|, both unit vectors), if that overlap exceeds ½: the same pair at a
/// nearby state, whichever member has Im μ > 0 there.
fn same_pair<'a>(pairs: &'a [PairSense], side: f64, v: &DVector<nalgebra::Complex<f64>>) -> Option<&'a PairSense> {
    pairs
        .iter()
        .filter(|p| p.side == side && p.v.len() == v.len())
        .map(|p| (overlap(v, &p.v), p))
        .filter(|(o, _)| *o > 0.5)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, p)| p)
}

/// |vᴴw| or |vᵀw|, whichever is larger: the overlap of two unit eigenvectors of a pair whatever
/// their phase and whichever member of the conjugate pair each is.
fn overlap(v: &DVector<nalgebra::Complex<f64>>, w: &DVector<nalgebra::Complex<f64>>) -> f64 {
    let plain: nalgebra::Complex<f64> = v.iter().zip(w.iter()).map(|(a, b)| a.conj() * b).sum();
    let conj: nalgebra::Complex<f64> = v.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
    plain.norm().max(conj.norm())
}

/// Whether the flip of sense from pair p to its match q (among `pairs`, the next point's pairs
/// of the same block) is worth a search: the match is unambiguous (overlap at least 0.9, no
/// other pair of that side above 0.5) and both senses are clear (|sense| ≥ 0.5). A cluster of
/// nearly equal pairs, as slightly mistuned identical absorbers have (15 pairs within 1e-3 of
/// each other), mixes its eigenvectors from point to point, so senses "flip" with no pair near
/// the real axis: there the matches measured 0.54–0.99 with runners-up up to 0.69 and senses
/// down to 6e-5, where every flip that held a tongue in the tests matched at ≥ 0.957 with
/// runners-up ≤ 0.24 and senses ≥ 0.91 (BENCHMARKS.md, issue 26).
fn clear_flip(pairs: &[PairSense], p: &PairSense, q: &PairSense) -> bool {
    let mut overlaps: Vec<f64> =
        pairs.iter().filter(|r| r.side == p.side && r.v.len() == p.v.len()).map(|r| overlap(&p.v, &r.v)).collect();
    overlaps.sort_by(|a, b| b.total_cmp(a));
    overlaps.first().is_some_and(|&o| o >= 0.9)
        && overlaps.get(1).is_none_or(|&o| o <= 0.5)
        && p.sense.abs() >= 0.5
        && q.sense.abs() >= 0.5
}

/// A pair near ±1 at point i whose sense differs at the next point that holds it (within three
/// points: in between it may sit on the real axis) while its block's test function for that
/// side kept its sign: that test function's index, the block, the pair at i and the number of
/// segments spanned.
fn flipped(tests: &Tests, senses: &Senses, i: usize) -> Option<(usize, usize, PairSense, usize)> {
    let ta = &tests.get(i)?.1;
    let sa = senses.get(i)?;
    if ta.len() != 1 + 3 * sa.len() {
        return None;
    }
    for (k, pa) in sa.iter().enumerate() {
        for p in pa {
            // Index of Π(μ − 1) or Π(μ + 1) of block k (see `test_functions`).
            let j = 1 + 3 * k + usize::from(p.side < 0.0);
            for span in 1..=3 {
                let (Some((_, tb)), Some(sb)) = (tests.get(i + span), senses.get(i + span)) else { break };
                if tb.len() != ta.len() || sb.len() != sa.len() || tb[j].0 != ta[j].0 {
                    break;
                }
                if let Some(q) = same_pair(&sb[k], p.side, &p.v) {
                    if q.sense * p.sense < 0.0 && clear_flip(&sb[k], p, q) {
                        return Some((j, k, p.clone(), span));
                    }
                    break;
                }
            }
        }
    }
    None
}
