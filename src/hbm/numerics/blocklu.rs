//! Block elimination of the harmonic-balance Jacobian along the mechanism's tree.
//!
//! # Method
//!
//! ∂R̂/∂x is made of n_dof × n_dof blocks of size 2H + 1, block (i, k) holding how equation i's
//! Fourier projections depend on coordinate k's coefficients. Block (i, k) is zero whenever the
//! per-sample derivatives A, B, C have a zero (i, k) entry at every sample, which Kane's
//! equations give for every pair of coordinates that are not ancestor and descendant in the tree
//! (a speed's partial velocities are non-zero only on the bodies it moves). A rotor with N
//! absorbers is an *arrow*: the rotor's block row and column are full, each absorber's block
//! couples to itself and the rotor only.
//!
//! Such a matrix is factorised by block Gaussian elimination in a fill-avoiding order (greedy
//! minimum degree on the block graph: an absorber first, as it touches the rotor only): each
//! eliminated block k is factorised on its own (dense LU with partial pivoting inside the
//! block), its neighbours' Schur complement `B_ij −= B_ik B_kk⁻¹ B_kj` updated, and what remains
//! (the blocks every other one couples to, and the continuation's border row and column) is
//! factorised densely with partial pivoting. The border stays in that dense tail on purpose:
//! at a fold ∂R̂/∂x is singular and only the bordered matrix is regular, so its last pivots
//! must be chosen across the border. The determinant is the product of the blocks' and the
//! tail's (Schur's formula), so the determinant test functions of the continuation read it too.
//!
//! Pivoting is restricted to the eliminated diagonal blocks, each of which is one coordinate's
//! equations with every other coordinate held: an absorber on a held rotor, regular with any
//! damping. A block whose LU has a pivot below `1e-10` of its largest is refused and the caller
//! falls back to the dense LU, so the restriction never meets a singular block.
//!
//! NOTE: faer's sparse LU (`faer = 0.24`, already a dependency) was the first candidate, but its
//! symbolic analysis bounds the fill by the column elimination tree of AᵀA, and the rotor's block
//! row (and the border row) couples every column with every other: AᵀA is full, the analysis
//! returns one dense supernode and the factorisation is the dense one. The elimination below
//! uses the symmetric block pattern instead, which is what the tree gives. On 16 pendulums
//! (H = 10, 358 × 358 bordered) it measured ≈ 0.2 ms against ≈ 3 ms for nalgebra's dense LU
//! (`BENCHMARKS.md`, "Harmonic balance that scales").

use nalgebra::{DMatrix, DVector, Dyn, LU};

type Lu = LU<f64, Dyn, Dyn>;

/// Smallest accepted ratio of an eliminated block's pivots to its largest.
const PIVOT_RATIO: f64 = 1e-10;

/// A neighbour j of an eliminated block k: j, `B_jk` (forward elimination) and `B_kk⁻¹ B_kj`
/// (back substitution), each absent where zero.
type Neighbour = (usize, Option<DMatrix<f64>>, Option<DMatrix<f64>>);

/// One eliminated block: its LU and its neighbours.
#[derive(Debug, Clone)]
struct Step {
    k: usize,
    lu: Lu,
    neighbours: Vec<Neighbour>,
}

/// A block-eliminated factorisation (module docs).
#[derive(Debug, Clone)]
pub(in crate::hbm) struct BlockLu {
    offsets: Vec<usize>,
    sizes: Vec<usize>,
    steps: Vec<Step>,
    tail: Vec<usize>,
    tail_lu: Lu,
    dim: usize,
}

/// A factorisation of a Jacobian or bordered Jacobian: dense LU (small problems, dense patterns,
/// a refused block) or block elimination.
#[derive(Debug, Clone)]
pub(in crate::hbm) enum Factor {
    Dense(Lu),
    Block(Box<BlockLu>),
}

impl Factor {
    /// x = B⁻¹ r, None when singular.
    pub(in crate::hbm) fn solve(&self, r: &DVector<f64>) -> Option<DVector<f64>> {
        match self {
            Factor::Dense(lu) => lu.solve(r),
            Factor::Block(b) => b.solve(r),
        }
    }

    /// Sign and ln |·| of the determinant.
    pub(in crate::hbm) fn determinant(&self) -> (f64, f64) {
        match self {
            Factor::Dense(lu) => lu_determinant(lu),
            Factor::Block(b) => {
                let (mut sign, mut log) = lu_determinant(&b.tail_lu);
                for s in &b.steps {
                    let (sg, lg) = lu_determinant(&s.lu);
                    sign *= sg;
                    log += lg;
                }
                (sign, log)
            }
        }
    }
}

fn lu_determinant(lu: &Lu) -> (f64, f64) {
    let (mut sign, mut log) = (lu.p().determinant::<f64>(), 0.0);
    for d in lu.u().diagonal().iter() {
        sign *= d.signum();
        log += d.abs().ln();
    }
    (sign, log)
}

impl BlockLu {
    /// Block elimination of `[[j S, col], [rowᵀ]]` (S = diag(`scale`) scales the columns of j;
    /// neither is there when `border` is None) with
    /// `n` diagonal blocks of size `nb` in `j`, the block `keep` never eliminated on its own.
    /// `zero`: where given, the blocks (i, k) known to be zero (`zero[i·n + k]`), which are not
    /// read; the others are tested entry by entry as without it.
    /// None when no block can be eliminated with less fill than the dense LU (the caller then
    /// factorises densely) or an eliminated block is refused (module docs).
    pub(in crate::hbm) fn new(
        j: &DMatrix<f64>,
        border: Option<(&DVector<f64>, &DVector<f64>, &[f64])>,
        n: usize,
        nb: usize,
        keep: usize,
        zero: Option<&[bool]>,
    ) -> Option<Self> {
        let nblk = n + usize::from(border.is_some());
        let mut sizes = vec![nb; n];
        if border.is_some() {
            sizes.push(1);
        }
        let offsets: Vec<usize> = sizes.iter().scan(0, |o, &s| Some(std::mem::replace(o, *o + s))).collect();
        let dim = offsets[nblk - 1] + sizes[nblk - 1];
        let mut blocks: Vec<Option<DMatrix<f64>>> = vec![None; nblk * nblk];
        let (rows, all) = (j.nrows(), j.as_slice());
        for bi in 0..n {
            for bk in 0..n {
                if zero.is_some_and(|z| z[bi * n + bk]) {
                    continue;
                }
                // Column by column (contiguous in the column-major storage), each column's test
                // without early exit so that it is vectorised: most blocks of a tree are zero and
                // are read whole (an element-wise `any` over the view was 90 % of this function).
                let nonzero = (0..nb).any(|c| {
                    let start = (bk * nb + c) * rows + bi * nb;
                    all[start..start + nb].iter().fold(false, |a, &v| a | (v != 0.0))
                });
                if nonzero {
                    let view = j.view((bi * nb, bk * nb), (nb, nb));
                    let mut b = view.into_owned();
                    if let Some((_, _, scale)) = border {
                        for (c, mut col) in b.column_iter_mut().enumerate() {
                            col *= scale[bk * nb + c];
                        }
                    }
                    blocks[bi * nblk + bk] = Some(b);
                }
            }
        }
        if let Some((col, row, _)) = border {
            for b in 0..n {
                blocks[b * nblk + n] = Some(DMatrix::from_column_slice(nb, 1, &col.as_slice()[b * nb..(b + 1) * nb]));
                blocks[n * nblk + b] = Some(DMatrix::from_row_slice(1, nb, &row.as_slice()[b * nb..(b + 1) * nb]));
            }
            blocks[n * nblk + n] = Some(DMatrix::from_element(1, 1, row[n * nb]));
        }
        let linked = |blocks: &[Option<DMatrix<f64>>], a: usize, b: usize| {
            a != b && (blocks[a * nblk + b].is_some() || blocks[b * nblk + a].is_some())
        };
        let mut alive = vec![true; nblk];
        let mut steps = Vec::new();
        loop {
            // Minimum degree over the blocks that may be eliminated (not `keep`, not the border),
            // the degree counted over the coordinate blocks: an elimination pays off while the
            // block does not touch every other remaining one.
            let remaining = (0..n).filter(|&b| alive[b]).count();
            let degree = |b: usize| (0..n).filter(|&o| alive[o] && linked(&blocks, b, o)).count();
            let Some((k, d)) =
                (0..n).filter(|&b| alive[b] && b != keep).map(|b| (b, degree(b))).min_by_key(|&(_, d)| d)
            else {
                break;
            };
            if d + 1 >= remaining {
                break;
            }
            let lu = blocks[k * nblk + k].take()?.lu();
            let u = lu.u();
            let diag = u.diagonal();
            let (lo, hi) = diag.iter().fold((f64::INFINITY, 0.0f64), |(l, h), v| (l.min(v.abs()), h.max(v.abs())));
            if !(hi.is_finite() && lo > PIVOT_RATIO * hi) {
                return None;
            }
            alive[k] = false;
            let neighbours: Vec<usize> = (0..nblk).filter(|&o| alive[o] && linked(&blocks, k, o)).collect();
            let mut entries = Vec::with_capacity(neighbours.len());
            for &o in &neighbours {
                let lower = blocks[o * nblk + k].take();
                let upper = blocks[k * nblk + o].take().map(|mut m| {
                    lu.solve_mut(&mut m);
                    m
                });
                entries.push((o, lower, upper));
            }
            for (i, lower, _) in &entries {
                let Some(lower) = lower else { continue };
                for (jj, _, upper) in &entries {
                    let Some(upper) = upper else { continue };
                    let slot = &mut blocks[i * nblk + jj];
                    match slot {
                        Some(m) => m.gemm(-1.0, lower, upper, 1.0),
                        None => *slot = Some(-(lower * upper)),
                    }
                }
            }
            steps.push(Step { k, lu, neighbours: entries });
        }
        if steps.is_empty() {
            return None;
        }
        let tail: Vec<usize> = (0..nblk).filter(|&b| alive[b]).collect();
        let tail_dim: usize = tail.iter().map(|&b| sizes[b]).sum();
        let mut dense = DMatrix::zeros(tail_dim, tail_dim);
        let (mut r0, mut c0);
        r0 = 0;
        for &bi in &tail {
            c0 = 0;
            for &bk in &tail {
                if let Some(m) = &blocks[bi * nblk + bk] {
                    dense.view_mut((r0, c0), (sizes[bi], sizes[bk])).copy_from(m);
                }
                c0 += sizes[bk];
            }
            r0 += sizes[bi];
        }
        Some(Self { offsets, sizes, steps, tail, tail_lu: dense.lu(), dim })
    }

    fn solve(&self, r: &DVector<f64>) -> Option<DVector<f64>> {
        debug_assert_eq!(r.len(), self.dim);
        let mut x = r.clone();
        let range = |b: usize| self.offsets[b]..self.offsets[b] + self.sizes[b];
        for s in &self.steps {
            let mut y = DVector::from_column_slice(&x.as_slice()[range(s.k)]);
            if !s.lu.solve_mut(&mut y) {
                return None;
            }
            for (i, lower, _) in &s.neighbours {
                if let Some(l) = lower {
                    x.rows_mut(self.offsets[*i], self.sizes[*i]).gemv(-1.0, l, &y, 1.0);
                }
            }
            x.rows_mut(self.offsets[s.k], self.sizes[s.k]).copy_from(&y);
        }
        let mut t = DVector::from_iterator(
            self.tail.iter().map(|&b| self.sizes[b]).sum(),
            self.tail.iter().flat_map(|&b| range(b)).map(|i| x[i]),
        );
        if !self.tail_lu.solve_mut(&mut t) {
            return None;
        }
        let mut o = 0;
        for &b in &self.tail {
            x.rows_mut(self.offsets[b], self.sizes[b]).copy_from(&t.rows(o, self.sizes[b]));
            o += self.sizes[b];
        }
        for s in self.steps.iter().rev() {
            let mut y = DVector::from_column_slice(&x.as_slice()[range(s.k)]);
            for (j, _, upper) in &s.neighbours {
                if let Some(u) = upper {
                    y.gemv(-1.0, u, &x.rows(self.offsets[*j], self.sizes[*j]), 1.0);
                }
            }
            x.rows_mut(self.offsets[s.k], self.sizes[s.k]).copy_from(&y);
        }
        x.iter().all(|v| v.is_finite()).then_some(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::abs_diff_eq;

    /// An arrow (a full first block row and column, the rest block diagonal) with a dense border:
    /// the block elimination solves it and gives its determinant as the dense LU does, to
    /// rounding.
    #[test]
    fn block_elimination_matches_the_dense_lu() {
        let (n, nb) = (6, 5);
        let m = n * nb;
        let f = |i: usize, k: usize| ((i * 7 + k * 13) as f64 * 0.37).sin();
        let j = DMatrix::from_fn(m, m, |r, c| {
            let (bi, bk) = (r / nb, c / nb);
            if bi == 0 || bk == 0 || bi == bk { f(r, c) + if r == c { 4.0 } else { 0.0 } } else { 0.0 }
        });
        let col = DVector::from_fn(m, |r, _| f(r, 3));
        let row = DVector::from_fn(m + 1, |r, _| f(5, r));
        let mut full = DMatrix::zeros(m + 1, m + 1);
        full.view_mut((0, 0), (m, m)).copy_from(&j);
        full.view_mut((0, m), (m, 1)).copy_from(&col);
        full.view_mut((m, 0), (1, m + 1)).copy_from(&row.transpose());
        let r = DVector::from_fn(m + 1, |i, _| (i as f64).cos());
        let ones = vec![1.0; m];
        let block =
            BlockLu::new(&j, Some((&col, &row, &ones)), n, nb, 0, None).expect("an arrow is eliminated by blocks");
        assert_eq!(block.steps.len(), n - 2);
        let (xb, xd) = (block.solve(&r).unwrap(), full.clone().lu().solve(&r).unwrap());
        assert!((&xb - &xd).amax() < 1e-12 * xd.amax(), "{:e}", (&xb - &xd).amax());
        let (sb, lb) = Factor::Block(Box::new(block)).determinant();
        let (sd, ld) = Factor::Dense(full.lu()).determinant();
        assert!(sb == sd && abs_diff_eq!(lb, ld, epsilon = 1e-12 * ld.abs().max(1.0)), "{sb} {lb} vs {sd} {ld}");
        // A full pattern has nothing to eliminate.
        let dense = DMatrix::from_fn(m, m, |r, c| f(r, c) + if r == c { 4.0 } else { 0.0 });
        assert!(BlockLu::new(&dense, None, n, nb, 0, None).is_none());
    }
}
