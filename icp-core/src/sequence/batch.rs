//! The batch smoother: Gauss–Newton over every scan's pose and twist with faer's sparse
//! Cholesky (the symbolic factorisation once per run, the numeric one per iteration), and the
//! marginal covariances of each scan and of each consecutive pair from the final system.

use std::collections::BTreeSet;

use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};
use faer::{Mat, Side};
use nalgebra::{Matrix3, Vector3};

use super::band::Band;
use super::factors::Matrix6;
use super::system::{descend, stopped, Discard, Estimates, Layout, Model, Sink};
use super::{SequenceError, SolveStop};

/// The upper triangle of H in compressed columns, its symbolic factorisation, and g.
pub(crate) struct SparseSystem {
    mat: SparseColMat<usize, f64>,
    symbolic: SymbolicLlt<usize>,
    g: Vec<f64>,
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
        let symbolic = SymbolicLlt::try_new(mat.symbolic(), Side::Upper)
            .map_err(|_| SequenceError::Factorisation { what: "symbolic" })?;
        Ok(Self {
            mat,
            symbolic,
            g: vec![0.0; n],
        })
    }

    pub fn clear(&mut self) {
        self.mat.val_mut().fill(0.0);
        self.g.fill(0.0);
    }

    /// The numeric factorisation of H.
    pub fn factor(&self) -> Result<Llt<usize, f64>, SequenceError> {
        Llt::try_new_with_symbolic(self.symbolic.clone(), self.mat.as_ref(), Side::Upper)
            .map_err(|_| SequenceError::Factorisation { what: "numeric" })
    }

    /// The Gauss–Newton step `−H⁻¹g`.
    pub fn step(&self, llt: &Llt<usize, f64>) -> Vec<f64> {
        let mut rhs = Mat::from_fn(self.g.len(), 1, |i, _| -self.g[i]);
        llt.solve_in_place(rhs.as_mut());
        (0..self.g.len()).map(|i| rhs[(i, 0)]).collect()
    }

    fn add_entry(&mut self, row: usize, col: usize, v: f64) {
        let start = self.mat.symbolic().col_ptr()[col];
        let end = self.mat.symbolic().col_ptr()[col + 1];
        let pos = self.mat.symbolic().row_idx()[start..end]
            .binary_search(&row)
            .expect("the pattern holds every block a factor adds");
        self.mat.val_mut()[start + pos] += v;
    }
}

impl Sink for SparseSystem {
    fn add_h(&mut self, bi: usize, bj: usize, m: &Matrix3<f64>) {
        for r in 0..3 {
            for c in 0..3 {
                if bi < bj || r <= c {
                    self.add_entry(3 * bi + r, 3 * bj + c, m[(r, c)]);
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
        let delta = sys.step(&sys.factor()?);
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
        if let Some(how) = stopped(taken, &delta, tolerance) {
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
