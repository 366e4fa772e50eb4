//! The batch smoother: Gauss–Newton over every scan's pose, twist and error with faer's sparse
//! Cholesky (the symbolic factorisation once per run, the numeric one per iteration into
//! buffers kept across iterations), and the
//! marginal covariances of each scan and of each consecutive pair from the final system.

use std::collections::BTreeSet;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, Mat, Par, Side};
use nalgebra::{Matrix3, Vector3};

use super::band::Band;
use super::factors::Matrix6;
use super::system::{descend, stopped, Discard, Estimates, Layout, Model, Sink};
use super::{SequenceError, SolveStop};

/// The upper triangle of H in compressed columns, its symbolic factorisation, and g.
pub(crate) struct SparseSystem {
    mat: SparseColMat<usize, f64>,
    symbolic: SymbolicCholesky<usize>,
    /// The numeric factor's values and the factorisation's and solve's workspace, kept from
    /// one Gauss–Newton iteration to the next.
    factor: Vec<f64>,
    work: MemBuffer,
    g: Vec<f64>,
    /// Per block column b, its blocks `(a, first)`, a ≤ b ascending: the values of block
    /// `(a, b)`'s column `3b + c` start at `first[c]` (row `3a`, its rows being consecutive), so
    /// adding a block costs no search.
    starts: Vec<Vec<(usize, [usize; 3])>>,
}

impl SparseSystem {
    /// The pattern of H for every factor of `model` over `layout` (all states of the run).
    pub fn new(model: &Model<'_>, layout: &Layout, n_states: usize) -> Result<Self, SequenceError> {
        let mut pairs = BTreeSet::new();
        let mut add = |blocks: &[Option<usize>]| {
            for &a in blocks.iter().flatten() {
                for &b in blocks.iter().flatten() {
                    if a <= b {
                        pairs.insert((a, b));
                    }
                }
            }
        };
        for k in 0..n_states - 1 {
            add(&[
                layout.pose(k),
                layout.twist(k),
                layout.pose(k + 1),
                layout.twist(k + 1),
            ]);
        }
        for k in 0..n_states {
            add(&[layout.error(k)]);
        }
        for reg in model.regs {
            add(&[
                layout.pose(reg.source),
                layout.error(reg.source),
                layout.pose(reg.reference),
                layout.error(reg.reference),
            ]);
        }
        let mut triplets = Vec::with_capacity(pairs.len() * 9);
        for &(a, b) in &pairs {
            for r in 0..3 {
                for c in 0..3 {
                    if a < b || r <= c {
                        triplets.push(Triplet::new(3 * a + r, 3 * b + c, 0.0));
                    }
                }
            }
        }
        let n = layout.dim();
        let mat = SparseColMat::try_new_from_triplets(n, n, &triplets)
            .map_err(|_| SequenceError::Factorisation { what: "pattern" })?;
        let symbolic = factorize_symbolic_cholesky(
            mat.symbolic(),
            Side::Upper,
            SymmetricOrdering::Amd,
            // faer's choice between simplicial and supernodal: simplicial here. Forcing the
            // supernodal factor was slower on the harbour's size (batch with Qc given 57 ms
            // against 39 ms).
            CholeskySymbolicParams::default(),
        )
        .map_err(|_| SequenceError::Factorisation { what: "symbolic" })?;
        let work = MemBuffer::new(
            symbolic
                .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
                .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq)),
        );
        let (col_ptr, row_idx) = (mat.symbolic().col_ptr(), mat.symbolic().row_idx());
        let mut starts = vec![Vec::new(); n / 3];
        for &(a, b) in &pairs {
            let first = std::array::from_fn(|c| {
                let col = 3 * b + c;
                let rows = &row_idx[col_ptr[col]..col_ptr[col + 1]];
                col_ptr[col] + rows.partition_point(|&r| r < 3 * a)
            });
            starts[b].push((a, first));
        }
        Ok(Self {
            factor: vec![0.0; symbolic.len_val()],
            mat,
            symbolic,
            work,
            g: vec![0.0; n],
            starts,
        })
    }

    pub fn clear(&mut self) {
        self.mat.val_mut().fill(0.0);
        self.g.fill(0.0);
    }

    /// The Gauss–Newton step `−H⁻¹g`, by the numeric factorisation of H.
    pub fn step(&mut self) -> Result<Vec<f64>, SequenceError> {
        self.symbolic
            .factorize_numeric_llt(
                &mut self.factor,
                self.mat.as_ref(),
                Side::Upper,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.work),
                Default::default(),
            )
            .map_err(|_| SequenceError::Factorisation { what: "numeric" })?;
        let mut rhs = Mat::from_fn(self.g.len(), 1, |i, _| -self.g[i]);
        LltRef::new(&self.symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            rhs.as_mut(),
            Par::Seq,
            MemStack::new(&mut self.work),
        );
        Ok((0..self.g.len()).map(|i| rhs[(i, 0)]).collect())
    }
}

impl Sink for SparseSystem {
    fn add_h(&mut self, bi: usize, bj: usize, m: &Matrix3<f64>) {
        let column = &self.starts[bj];
        let at = column.partition_point(|&(a, _)| a < bi);
        let (a, first) = column[at];
        assert_eq!(a, bi, "the pattern holds every block a factor adds");
        let vals = self.mat.val_mut();
        for c in 0..3 {
            for r in 0..3 {
                if bi < bj || r <= c {
                    vals[first[c] + r] += m[(r, c)];
                }
            }
        }
    }

    fn add_g(&mut self, bi: usize, v: &Vector3<f64>) {
        for r in 0..3 {
            self.g[3 * bi + r] += v[r];
        }
    }
}

/// Linearises every factor of `model` at `est` into `sys`; returns the total cost.
pub(crate) fn linearise(
    model: &Model<'_>,
    est: &Estimates,
    layout: &Layout,
    sys: &mut SparseSystem,
) -> f64 {
    sys.clear();
    add_all(model, est, layout, sys)
}

/// Adds every factor of `model` at `est` into `sink`; returns the total cost.
fn add_all<S: Sink>(model: &Model<'_>, est: &Estimates, layout: &Layout, sink: &mut S) -> f64 {
    let mut cost = model.add_twist0(est, layout, sink);
    for k in 0..est.poses.len() - 1 {
        cost += model.add_prior(est, layout, k, sink);
    }
    for k in 0..est.poses.len() {
        cost += model.add_scan_error(est, layout, k, sink);
    }
    for i in 0..model.regs.len() {
        cost += model.add_reg(est, layout, i, sink);
    }
    cost
}

/// Gauss–Newton with step control ([`descend`]) from `est` until the largest step is below
/// `tolerance`, no step lowers the cost, or after `max_iterations`; leaves `sys` linearised
/// at the result and returns the cost there and how it stopped.
pub(crate) fn solve(
    model: &Model<'_>,
    est: &mut Estimates,
    sys: &mut SparseSystem,
    layout: &Layout,
    max_iterations: usize,
    tolerance: f64,
) -> Result<(f64, SolveStop), SequenceError> {
    let mut trial = est.clone();
    let mut stop = SolveStop::IterationCap;
    for _ in 0..max_iterations {
        let cost = linearise(model, est, layout, sys);
        let delta = sys.step()?;
        if delta.iter().any(|d| !d.is_finite()) {
            return Err(SequenceError::Factorisation { what: "step" });
        }
        let cost_at = |e: &Estimates| add_all(model, e, layout, &mut Discard);
        let taken = descend(
            model.geometry,
            layout,
            est,
            &mut trial,
            &delta,
            cost,
            cost_at,
        );
        let decrement = -sys.g.iter().zip(&delta).map(|(g, d)| g * d).sum::<f64>();
        if let Some(how) = stopped(taken, decrement, tolerance) {
            stop = how;
            break;
        }
    }
    Ok((linearise(model, est, layout, sys), stop))
}

/// The marginals of a solution (see [`marginals`]).
pub(crate) struct Marginals {
    /// Each scan's `[pose; twist]` covariance (scan 0's pose rows zero).
    pub own: Vec<Matrix6>,
    /// `Σ_k,k+1` of consecutive scans.
    pub cross: Vec<Matrix6>,
    /// `ln det H` of the system.
    pub log_det_h: f64,
}

/// The marginal covariance of each scan's `[pose; twist]` (scan 0's pose rows zero; its error,
/// where the model has them, is marginalised out like every scan's), the
/// cross-covariance `Σ_k,k+1` of consecutive scans, and `ln det H`: from the band of `H⁻¹`
/// (see [`Band`]) of the system linearised at the solution.
pub(crate) fn marginals(
    sys: &SparseSystem,
    layout: &Layout,
    n_states: usize,
) -> Result<Marginals, SequenceError> {
    let m = sys.mat.as_ref();
    let (col_ptr, row_idx, vals) = (m.symbolic().col_ptr(), m.symbolic().row_idx(), m.val());
    let n = layout.dim();
    let width = (0..n)
        .flat_map(|c| {
            row_idx[col_ptr[c]..col_ptr[c + 1]]
                .iter()
                .map(move |&r| c - r)
        })
        .max()
        .unwrap_or(0);
    let mut h = Band::zeros(n, width);
    for c in 0..n {
        for p in col_ptr[c]..col_ptr[c + 1] {
            h.set(c, row_idx[p], vals[p]);
        }
    }
    let (sigma, log_det_h) = h.inverse_band()?;
    let block = |a: usize, b: usize| -> Matrix6 {
        let mut out = Matrix6::zeros();
        for (sa, ba) in layout.state_blocks(a).into_iter().take(2).enumerate() {
            let Some(ba) = ba else { continue };
            for (sb, bb) in layout.state_blocks(b).into_iter().take(2).enumerate() {
                let Some(bb) = bb else { continue };
                for r in 0..3 {
                    for c in 0..3 {
                        out[(3 * sa + r, 3 * sb + c)] = sigma.at(3 * ba + r, 3 * bb + c);
                    }
                }
            }
        }
        out
    };
    Ok(Marginals {
        own: (0..n_states).map(|k| block(k, k)).collect(),
        cross: (0..n_states.saturating_sub(1))
            .map(|k| block(k, k + 1))
            .collect(),
        log_det_h,
    })
}
