//! The causal smoother: scan k is estimated from the factors of scans ≤ k (+ a fixed lag) in a
//! sliding window. When a scan leaves the window, the factors on it are replaced by their
//! Gaussian marginal on the remaining scans (Schur complement at the current estimate), so the
//! window's solve is the batch solve over the scans seen so far for a linear model.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn, Matrix3, Vector3};

use super::factors;
use super::system::{descend, stopped, Discard, Estimates, Layout, Model, Sink};
use super::{
    Outputs, ScanEstimate, SequenceError, SmootherOptions, SolveStop, StateCovariance, StepEstimate,
};

/// H and g of a window, dense.
struct DenseSystem {
    h: DMatrix<f64>,
    g: DVector<f64>,
}

impl DenseSystem {
    fn zeros(dim: usize) -> Self {
        Self {
            h: DMatrix::zeros(dim, dim),
            g: DVector::zeros(dim),
        }
    }
}

impl Sink for DenseSystem {
    fn add_h(&mut self, bi: usize, bj: usize, m: &Matrix3<f64>) {
        let mut view = self.h.fixed_view_mut::<3, 3>(3 * bi, 3 * bj);
        view += m;
        if bi != bj {
            let mut view = self.h.fixed_view_mut::<3, 3>(3 * bj, 3 * bi);
            view += m.transpose();
        }
    }

    fn add_g(&mut self, bi: usize, v: &Vector3<f64>) {
        let mut view = self.g.fixed_rows_mut::<3>(3 * bi);
        view += v;
    }
}

/// The marginal of the factors on the scans that left the window: the cost
/// `½ δᵀHδ + gᵀδ` of `δ = x ⊖ x̄` over the scans `first..first + len`, linearised at `x̄`.
struct MarginalPrior {
    layout: Layout,
    first: usize,
    at: Estimates,
    h: DMatrix<f64>,
    g: DVector<f64>,
}

impl MarginalPrior {
    /// Adds the prior, at `est`, into `sink` laid out as `window`; returns its cost
    /// `½ δᵀHδ + gᵀδ`.
    fn add<S: Sink>(
        &self,
        model: &Model<'_>,
        est: &Estimates,
        window: &Layout,
        sink: &mut S,
    ) -> f64 {
        let len = self.at.poses.len();
        let mut map = vec![0; self.layout.dim() / 3];
        let mut delta = DVector::zeros(self.layout.dim());
        for i in 0..len {
            let state = self.first + i;
            let in_window = window.state_blocks(state);
            for (kind, b) in self.layout.state_blocks(state).into_iter().enumerate() {
                let Some(b) = b else { continue };
                map[b] = in_window[kind].expect("the window holds the prior's scans");
                let d = est.minus(model.geometry, kind, state, &self.at, i);
                delta.fixed_rows_mut::<3>(3 * b).copy_from(&d);
            }
        }
        let h_delta = &self.h * &delta;
        let grad = &h_delta + &self.g;
        // Both layouts order the blocks by state, pose first: `map` keeps `bi ≤ bj`.
        for (bi, &wi) in map.iter().enumerate() {
            sink.add_g(wi, &grad.fixed_rows::<3>(3 * bi).into_owned());
            for (bj, &wj) in map.iter().enumerate().skip(bi) {
                sink.add_h(
                    wi,
                    wj,
                    &self.h.fixed_view::<3, 3>(3 * bi, 3 * bj).into_owned(),
                );
            }
        }
        0.5 * delta.dot(&h_delta) + self.g.dot(&delta)
    }
}

/// Runs the causal smoother over every scan; scan j is reported from the window at scan
/// `max(j + lag_scans, O − 1)`, step `j → j+1` from the window at scan `max(j + 1 + lag_scans,
/// O − 1)` (or the last scan, for the run's end), O the derivatives of the prior's state: the
/// first window whose states are determined without a prior on scan 0's twist (and
/// acceleration) spans O scans. Also the worst way a window's solve stopped.
pub(crate) fn run(
    model: &Model<'_>,
    mut est: Estimates,
    lag_scans: usize,
    options: &SmootherOptions,
) -> Result<(Outputs, SolveStop), SequenceError> {
    let n = est.poses.len();
    let max_lag = model
        .regs
        .iter()
        .map(|r| r.reference - r.source)
        .max()
        .unwrap_or(1);
    let keep = max_lag.max(lag_scans + 1);
    let mut scans: Vec<Option<ScanEstimate>> = vec![None; n];
    let mut steps: Vec<Option<StepEstimate>> = vec![None; n - 1];
    let mut first = 0;
    let mut marginal: Option<MarginalPrior> = None;
    let mut trial = est.clone();
    let mut stop = SolveStop::Converged;
    for k in 1..n {
        predict(model, &mut est, k);
        if k + 1 < model.prior.order() && k + 1 < n {
            continue;
        }
        let layout = model.layout(first, k - first + 1);
        let window = Window {
            model,
            layout: &layout,
            marginal: marginal.as_ref(),
            first,
            k,
        };
        let (sys, window_stop) = window.solve(&mut est, &mut trial, options)?;
        stop = stop.max(window_stop);
        let cov = Cholesky::new(sys.h.clone())
            .ok_or(SequenceError::Factorisation {
                what: "causal window",
            })?
            .inverse();
        let last = k == n - 1;
        for j in first..=k {
            if scans[j].is_none() && (j + lag_scans <= k || last) {
                scans[j] = Some(ScanEstimate {
                    pose: est.poses[j],
                    twist: est.twists[j],
                    cov: block(&cov, &layout, j, j),
                });
            }
            if j > first && steps[j - 1].is_none() && (j + lag_scans <= k || last) {
                let (own_a, own_b) = (
                    block(&cov, &layout, j - 1, j - 1),
                    block(&cov, &layout, j, j),
                );
                let cross = block(&cov, &layout, j - 1, j);
                let mut s = super::step(model, &est, j - 1, &own_a, &own_b, &cross);
                s.supported = model
                    .regs
                    .iter()
                    .any(|r| r.source < j && r.reference >= j && r.reference <= k);
                steps[j - 1] = Some(s);
            }
        }
        while k + 1 - first > keep {
            marginal = Some(marginalise(model, &est, marginal.as_ref(), first, k)?);
            first += 1;
        }
    }
    let scans = scans
        .into_iter()
        .map(|s| s.expect("every scan is reported"))
        .collect();
    let steps = steps
        .into_iter()
        .map(|s| s.expect("every step is reported"))
        .collect();
    Ok(((scans, steps), stop))
}

/// Starts scan k from k−1's twist held over Δt (or the registration k−1 → k where there is one),
/// and k−1's acceleration.
fn predict(model: &Model<'_>, est: &mut Estimates, k: usize) {
    let reg = model
        .regs
        .iter()
        .find(|r| r.source == k - 1 && r.reference == k);
    let xi = match reg {
        Some(r) => {
            let motion = super::inverse_params(model.geometry, &r.z);
            super::log_from_origin(model.geometry, &motion)
        }
        None => est.twists[k - 1] * model.dt_s(k - 1),
    };
    est.poses[k] = factors::exp_from(model.geometry, &est.poses[k - 1], &xi);
    est.twists[k] = if reg.is_some() {
        xi / model.dt_s(k - 1)
    } else {
        est.twists[k - 1]
    };
    est.accels[k] = est.accels[k - 1];
}

/// The factors of the window over scans `first..=k` (laid out as `layout`): the priors and
/// registrations within it, and the marginal of what left it.
struct Window<'w> {
    model: &'w Model<'w>,
    layout: &'w Layout,
    marginal: Option<&'w MarginalPrior>,
    first: usize,
    k: usize,
}

impl Window<'_> {
    /// Adds the window's factors at `est` into `sink`; returns their cost.
    fn add<S: Sink>(&self, est: &Estimates, sink: &mut S) -> f64 {
        let (model, layout) = (self.model, self.layout);
        let mut cost = 0.0;
        if self.first == 0 {
            cost += model.add_initial(est, layout, sink);
        }
        for j in self.first..self.k {
            cost += model.add_prior(est, layout, j, sink);
        }
        for j in self.first..=self.k {
            cost += model.add_scan_error(est, layout, j, sink);
        }
        for (i, r) in model.regs.iter().enumerate() {
            if r.source >= self.first && r.reference <= self.k {
                cost += model.add_reg(est, layout, i, sink);
            }
        }
        if let Some(m) = self.marginal {
            cost += m.add(model, est, layout, sink);
        }
        cost
    }

    /// The window's system linearised at `est`, and its cost there.
    fn linearise(&self, est: &Estimates) -> (DenseSystem, f64) {
        let mut sys = DenseSystem::zeros(self.layout.dim());
        let cost = self.add(est, &mut sys);
        (sys, cost)
    }

    /// Gauss–Newton with step control ([`descend`]) from `est`; `trial` is scratch states of
    /// the run's size. Returns the system at the result and how it stopped.
    fn solve(
        &self,
        est: &mut Estimates,
        trial: &mut Estimates,
        options: &SmootherOptions,
    ) -> Result<(DenseSystem, SolveStop), SequenceError> {
        let mut stop = SolveStop::IterationCap;
        for _ in 0..options.max_iterations {
            let (sys, cost) = self.linearise(est);
            let chol = Cholesky::new(sys.h.clone()).ok_or(SequenceError::Factorisation {
                what: "causal window",
            })?;
            let delta = chol.solve(&(-&sys.g));
            if delta.iter().any(|d| !d.is_finite()) {
                return Err(SequenceError::Factorisation {
                    what: "causal step",
                });
            }
            let cost_at = |e: &Estimates| self.add(e, &mut Discard);
            let taken = descend(
                self.model.geometry,
                self.layout,
                est,
                trial,
                delta.as_slice(),
                cost,
                cost_at,
            );
            let decrement = -sys.g.dot(&delta);
            if let Some(how) = stopped(taken, decrement, options.tolerance) {
                stop = how;
                break;
            }
        }
        Ok((self.linearise(est).0, stop))
    }
}

/// Replaces the factors on scan `first` (its prior to `first + 1`, its error's, its
/// registrations, and the current marginal) by their marginal on scans `first + 1..=k`.
fn marginalise(
    model: &Model<'_>,
    est: &Estimates,
    marginal: Option<&MarginalPrior>,
    first: usize,
    k: usize,
) -> Result<MarginalPrior, SequenceError> {
    let layout = model.layout(first, k - first + 1);
    let mut sys = DenseSystem::zeros(layout.dim());
    if first == 0 {
        model.add_initial(est, &layout, &mut sys);
    }
    model.add_prior(est, &layout, first, &mut sys);
    model.add_scan_error(est, &layout, first, &mut sys);
    for (i, r) in model.regs.iter().enumerate() {
        if r.source == first {
            model.add_reg(est, &layout, i, &mut sys);
        }
    }
    if let Some(m) = marginal {
        m.add(model, est, &layout, &mut sys);
    }
    let gone = 3 * layout.state_blocks(first).iter().flatten().count();
    let dim = layout.dim();
    let rest = dim - gone;
    let h_ss = sys.h.view((0, 0), (gone, gone)).into_owned();
    let h_rs = sys.h.view((gone, 0), (rest, gone)).into_owned();
    let chol = Cholesky::<f64, Dyn>::new(h_ss).ok_or(SequenceError::Factorisation {
        what: "marginalisation",
    })?;
    let h_ss_inv_h_sr = chol.solve(&h_rs.transpose());
    let h = sys.h.view((gone, gone), (rest, rest)) - &h_rs * &h_ss_inv_h_sr;
    let g = sys.g.rows(gone, rest) - h_ss_inv_h_sr.transpose() * sys.g.rows(0, gone);
    let len = k - first;
    Ok(MarginalPrior {
        layout: model.layout(first + 1, len),
        first: first + 1,
        at: est.slice(first + 1..k + 1),
        h: (&h + h.transpose()) * 0.5,
        g,
    })
}

/// The `[pose; twist]` covariance block of states `a` (rows) and `b` (columns) from the
/// window's `cov`.
fn block(cov: &DMatrix<f64>, layout: &Layout, a: usize, b: usize) -> StateCovariance {
    let mut out = StateCovariance::zeros();
    for (sa, ba) in layout.state_blocks(a).into_iter().take(2).enumerate() {
        let Some(ba) = ba else { continue };
        for (sb, bb) in layout.state_blocks(b).into_iter().take(2).enumerate() {
            let Some(bb) = bb else { continue };
            out.fixed_view_mut::<3, 3>(3 * sa, 3 * sb)
                .copy_from(&cov.fixed_view::<3, 3>(3 * ba, 3 * bb));
        }
    }
    out
}
