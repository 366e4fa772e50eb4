//! The batch smoother: Gauss–Newton over every scan's pose, twist and error with faer's sparse
//! Cholesky (the symbolic factorisation once per run, the numeric one per iteration into
//! buffers kept across iterations), and the marginal covariances of each scan and of each
//! consecutive pair from the factor of the final system.

use std::collections::BTreeSet;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::supernodal::{SupernodalLltRef, SymbolicSupernodalCholesky};
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMat, Triplet};
use faer::{Conj, Mat, MatRef, Par, Side};
use nalgebra::{Matrix3, SMatrix, Vector3};

use super::band::{inverse_in_band, FactorColumns};
use super::system::{descend, stopped, Discard, Estimates, Layout, Model, Sink};
use super::{SequenceError, SolveStop};

/// The upper triangle of H in compressed columns, its symbolic factorisation, and g.
///
/// H's rows and columns keep the layout's order, scan after scan: H is then a band matrix
/// (each factor ties scans at most the longest lag apart) and its Cholesky factor has no
/// entry outside that band, so the factor is also what the marginals need ([`marginals`]).
/// faer's supernodal factor, whose supernodes are dense blocks of the band: on the issue-35
/// bench (`icp-core/benches/sequence.rs`, 865 scans, lags 1–3) the estimation of `Qc` took
/// 277 ms with AMD's ordering and the simplicial factor, 260 ms in the scans' order, 233–247
/// ms with the supernodal factor in that order (each with a separate band factorisation for
/// the marginals, since dropped).
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
    /// The blocks of the current linearisation, in the order the factors added them, with
    /// where each one's values start: every linearisation adds the same blocks in the same
    /// order, so from the second one on a block's place is read here, not searched for (the
    /// search was 12 % of the estimation of `Qc`).
    added: Vec<(usize, usize, [usize; 3])>,
    /// How many blocks the current linearisation has added.
    cursor: usize,
    /// H's bandwidth, in scalars: the largest `column − row` of its pattern.
    width: usize,
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
                layout.accel(k),
                layout.pose(k + 1),
                layout.twist(k + 1),
                layout.accel(k + 1),
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
            SymmetricOrdering::Identity,
            CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            },
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
        let width = pairs
            .iter()
            .map(|&(a, b)| 3 * (b - a) + 2)
            .max()
            .unwrap_or(0);
        Ok(Self {
            factor: vec![0.0; symbolic.len_val()],
            mat,
            symbolic,
            work,
            g: vec![0.0; n],
            starts,
            added: Vec::new(),
            cursor: 0,
            width,
        })
    }

    pub fn clear(&mut self) {
        self.mat.val_mut().fill(0.0);
        self.g.fill(0.0);
        self.cursor = 0;
    }

    /// Where the values of block `(bi, bj)` of H start, column by column: the last
    /// linearisation's block at this place in the order when it is the same block, else
    /// searched for in the pattern (and remembered).
    fn first(&mut self, bi: usize, bj: usize) -> [usize; 3] {
        let at = self.cursor;
        self.cursor += 1;
        if let Some(&(a, b, first)) = self.added.get(at) {
            if (a, b) == (bi, bj) {
                return first;
            }
        }
        let column = &self.starts[bj];
        let (a, first) = column[column.partition_point(|&(a, _)| a < bi)];
        assert_eq!(a, bi, "the pattern holds every block a factor adds");
        self.added.truncate(at);
        self.added.push((bi, bj, first));
        first
    }

    /// The numeric factorisation of H as it is now.
    pub fn factorise(&mut self) -> Result<(), SequenceError> {
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
        Ok(())
    }

    /// The Gauss–Newton step `−H⁻¹g`, by the numeric factorisation of H (kept for
    /// [`marginals`]).
    pub fn step(&mut self) -> Result<Vec<f64>, SequenceError> {
        self.factorise()?;
        Ok(self.step_on_last_factor())
    }

    /// `−H₀⁻¹g`: g as it is now, H₀ the system of the last factorisation (the Gauss–Newton
    /// step right after it; a simplified Newton, or chord, step where the system was
    /// linearised again since).
    fn step_on_last_factor(&mut self) -> Vec<f64> {
        let mut rhs = Mat::from_fn(self.g.len(), 1, |i, _| -self.g[i]);
        LltRef::new(&self.symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            rhs.as_mut(),
            Par::Seq,
            MemStack::new(&mut self.work),
        );
        (0..self.g.len()).map(|i| rhs[(i, 0)]).collect()
    }
}

impl Sink for SparseSystem {
    fn add_h(&mut self, bi: usize, bj: usize, m: &Matrix3<f64>) {
        let first = self.first(bi, bj);
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
    let mut cost = model.add_initial(est, layout, sink);
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

/// Gauss–Newton with step control ([`descend`]) from `est` until a step's Newton decrement
/// `−gᵀδ` is at most `tolerance`, no step lowers the cost, or after `max_iterations` steps;
/// returns the cost at the result and how it stopped, and leaves `sys` factorised for
/// [`marginals`]. Where the last step was below the tolerance (taken, as every step), the
/// factor it was computed with stands for the system at the result: the states moved by less
/// than the tolerance allows, and the marginals of a system linearised and factorised again
/// there differ by as little (the same `Qc` to 3 digits and the same EM rounds on the
/// harbours, marina and aces; reports/performance.md, issue 35). Not taking that last step
/// instead moved the paper harbour's sway `q`, an axis heading for 0, by a factor of 7.
///
/// After a full step (not shortened by [`descend`]) the next one is first tried as a chord
/// step ([`chord_step`]), on the factor already made: where it is below the tolerance it is
/// the last, and one factorisation is spared. An EM round's solve, which starts at the
/// solution of the round before, converged so in two steps and now factorises once
/// (reports/performance.md, issue 35). The chord is tried on a solve's first step, and later
/// only where the decrements' last contraction (this step's over the one before) would bring
/// the next one within the tolerance: where they contract linearly (the Huber weights still
/// changing: the first solve from the chained start, and most of aces' solves, where 3 of 541
/// chords after full steps passed) a chord would not pass, and costs a triangular solve.
pub(crate) fn solve(
    model: &Model<'_>,
    est: &mut Estimates,
    sys: &mut SparseSystem,
    layout: &Layout,
    max_iterations: usize,
    tolerance: f64,
) -> Result<(f64, SolveStop), SequenceError> {
    let mut trial = est.clone();
    let cost_at = |e: &Estimates| add_all(model, e, layout, &mut Discard);
    let mut cost = linearise(model, est, layout, sys);
    let mut previous: Option<f64> = None;
    for _ in 0..max_iterations {
        let delta = sys.step()?;
        let decrement = decrement(&sys.g, &delta)?;
        let next = previous.map_or(0.0, |p| decrement * (decrement / p));
        previous = Some(decrement);
        let taken = descend(
            model.geometry,
            layout,
            est,
            &mut trial,
            &delta,
            cost,
            cost_at,
        );
        match stopped(taken, decrement, tolerance) {
            // `est` has not moved: the factor is its system's.
            Some(SolveStop::NoDescent) => return Ok((cost, SolveStop::NoDescent)),
            // The last step was below the tolerance: the factor it was taken with stands for
            // the system at `est`, and `descend` gave the cost there.
            Some(how) => return Ok((taken.map_or(cost, |t| t.cost), how)),
            None => cost = linearise(model, est, layout, sys),
        }
        if taken.is_some_and(|t| t.scale == 1.0) && next <= tolerance {
            let chord = chord_step(sys, tolerance)?;
            if let Some(t) = chord
                .and_then(|c| descend(model.geometry, layout, est, &mut trial, &c, cost, cost_at))
            {
                return Ok((t.cost, SolveStop::Converged));
            }
        }
    }
    sys.factorise()?;
    Ok((cost, SolveStop::IterationCap))
}

/// The chord step `−H₀⁻¹g` of `sys` linearised at the states a full Gauss–Newton step
/// reached (H₀ the system that step was computed with), where its decrement `−gᵀδ` is at
/// most `tolerance`: then the states are within the tolerance of the minimum as a Newton
/// step would say (H₀ differs from the system there by one step's change of the
/// linearisation, the robust weights' included), and H₀'s factor stands for the system at
/// the result as the last Newton step's does in [`solve`].
fn chord_step(sys: &mut SparseSystem, tolerance: f64) -> Result<Option<Vec<f64>>, SequenceError> {
    let delta = sys.step_on_last_factor();
    Ok((decrement(&sys.g, &delta)? <= tolerance).then_some(delta))
}

/// A step's Newton decrement `−gᵀδ`; an error where the step is not finite.
fn decrement(g: &[f64], delta: &[f64]) -> Result<f64, SequenceError> {
    if delta.iter().any(|d| !d.is_finite()) {
        return Err(SequenceError::Factorisation { what: "step" });
    }
    Ok(-g.iter().zip(delta).map(|(g, d)| g * d).sum::<f64>())
}

/// The covariance of a scan's `[pose; twist; acceleration]` (the acceleration's rows and
/// columns zero where the model has none).
pub(crate) type StateMarginal = SMatrix<f64, 9, 9>;

/// The marginals of a solution (see [`marginals`]).
pub(crate) struct Marginals {
    /// Each scan's `[pose; twist; acceleration]` covariance (scan 0's pose rows zero).
    pub own: Vec<StateMarginal>,
    /// `Σ_k,k+1` of consecutive scans.
    pub cross: Vec<StateMarginal>,
    /// `ln det H` of the system.
    pub log_det_h: f64,
}

/// The marginal covariance of each scan's `[pose; twist; acceleration]` (scan 0's pose rows
/// zero; its error,
/// where the model has them, is marginalised out like every scan's), the
/// cross-covariance `Σ_k,k+1` of consecutive scans, and `ln det H`: from the entries of `H⁻¹`
/// within H's band ([`inverse_in_band`]), by the Cholesky factor of the system as [`solve`]
/// left it. Scan k's blocks and the next scan's are read from the recursion's window when
/// the first column of scan k's pose, twist and acceleration is done; one that lies outside it (a layout
/// whose band is narrower than two scans) is an error, not a zero.
pub(crate) fn marginals(
    sys: &SparseSystem,
    layout: &Layout,
    n_states: usize,
) -> Result<Marginals, SequenceError> {
    let scalars = |k: usize| {
        let blocks = layout.state_blocks(k);
        std::array::from_fn::<_, 3, _>(|s| blocks[s].map(|block| 3 * block))
    };
    // Scan k by the first column of its pose, twist and acceleration.
    let mut scan_at = vec![None; sys.g.len()];
    for k in 0..n_states {
        if let Some(first) = scalars(k).into_iter().flatten().min() {
            scan_at[first] = Some(k);
        }
    }
    let mut own = vec![StateMarginal::zeros(); n_states];
    let mut cross = vec![StateMarginal::zeros(); n_states.saturating_sub(1)];
    let mut outside = false;
    let log_det_h = inverse_in_band(
        sys.g.len(),
        sys.width,
        &mut SupernodeColumns::new(sys)?,
        |j, window| {
            let Some(k) = scan_at[j] else { return };
            let mut block = |a: usize, b: usize, out: &mut StateMarginal| {
                for (sa, ia) in scalars(a).into_iter().enumerate() {
                    let Some(ia) = ia else { continue };
                    for (sb, ib) in scalars(b).into_iter().enumerate() {
                        let Some(ib) = ib else { continue };
                        for r in 0..3 {
                            for c in 0..3 {
                                match window.at(ia + r, ib + c) {
                                    Some(v) => out[(3 * sa + r, 3 * sb + c)] = v,
                                    None => outside = true,
                                }
                            }
                        }
                    }
                }
            };
            block(k, k, &mut own[k]);
            if let Some(next) = cross.get_mut(k) {
                block(k, k + 1, next);
            }
        },
    )?;
    if outside {
        return Err(SequenceError::Factorisation {
            what: "marginal outside the band",
        });
    }
    Ok(Marginals {
        own,
        cross,
        log_det_h,
    })
}

/// The columns of the numeric Cholesky factor of `sys` (its last
/// [`SparseSystem::factorise`]), read from faer's supernodes. A relaxed supernode's columns
/// share one pattern, so a column may hold rows past the band; those entries are exact zeros
/// (no elimination reaches them in the scans' order) and are left out, and one that is not is
/// an error rather than a marginal silently wrong.
struct SupernodeColumns<'a> {
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    factor: SupernodalLltRef<'a, usize, f64>,
    /// The supernode the last column asked lay in: its first column, the rows of its pattern
    /// and its values (the recursion asks for the columns in turn, so it seldom changes).
    node: Option<(usize, &'a [usize], MatRef<'a, f64>)>,
}

impl<'a> SupernodeColumns<'a> {
    fn new(sys: &'a SparseSystem) -> Result<Self, SequenceError> {
        let layout_error = SequenceError::Factorisation {
            what: "factor layout",
        };
        let SymbolicCholeskyRaw::Supernodal(symbolic) = sys.symbolic.raw() else {
            return Err(layout_error);
        };
        if sys.symbolic.perm().is_some() {
            return Err(layout_error);
        }
        Ok(Self {
            symbolic,
            factor: SupernodalLltRef::new(symbolic, &sys.factor),
            node: None,
        })
    }
}

impl FactorColumns for SupernodeColumns<'_> {
    fn column(&mut self, j: usize, out: &mut [f64]) -> Result<(), SequenceError> {
        let (start, pattern, values) = match self.node {
            Some((start, pattern, values)) if (start..start + values.ncols()).contains(&j) => {
                (start, pattern, values)
            }
            _ => {
                let s = self
                    .symbolic
                    .supernode_begin()
                    .partition_point(|&begin| begin <= j)
                    - 1;
                let node = self.factor.supernode(s);
                let found = (node.start(), node.pattern(), node.val());
                self.node = Some(found);
                found
            }
        };
        let columns = values.ncols();
        // Column j of L: its rows in the supernode (contiguous), then the pattern's.
        let column =
            values
                .col(j - start)
                .try_as_col_major()
                .ok_or(SequenceError::Factorisation {
                    what: "factor layout",
                })?;
        let rows = (start..start + columns).chain(pattern.iter().copied());
        for (i, &value) in rows.zip(column.as_slice()).skip(j - start) {
            match out.get_mut(i - j) {
                Some(entry) => *entry = value,
                None if value != 0.0 => {
                    return Err(SequenceError::Factorisation {
                        what: "factor outside the band",
                    })
                }
                None => {}
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
