//! The marginal covariances of the batch smoother: the entries of `H⁻¹` within H's band, by a
//! band Cholesky factor `H = L Lᵀ` and the Takahashi recursion (Takahashi, Fagan & Chen 1973):
//! for `j` from the last down, `Σ_ij = (δ_ij / L_jj − Σ_{k>j} L_kj Σ_ik) / L_jj` over the band.
//! Every `Σ_ik` it needs lies within the band, so the cost is `O(n b²)` for bandwidth b (the
//! scans' ordering keeps b at about 6 × the longest lag), where solving for the columns of
//! `H⁻¹` costs `O(n² b)`.

use super::SequenceError;

/// A symmetric matrix's lower band: `at(i, j)` for `0 ≤ i − j ≤ b`.
pub(crate) struct Band {
    n: usize,
    b: usize,
    /// Column-major: `vals[j * (b + 1) + (i − j)]`.
    vals: Vec<f64>,
}

impl Band {
    pub fn zeros(n: usize, b: usize) -> Self {
        Self {
            n,
            b,
            vals: vec![0.0; n * (b + 1)],
        }
    }

    /// Entry `(i, j)` of the symmetric matrix (0 outside the band).
    pub fn at(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i - j > self.b {
            0.0
        } else {
            self.vals[j * (self.b + 1) + (i - j)]
        }
    }

    /// Sets entry `(i, j)` (and `(j, i)`); `|i − j| ≤ b`.
    pub fn set(&mut self, i: usize, j: usize, v: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        self.vals[j * (self.b + 1) + (i - j)] = v;
    }

    /// The band of the inverse of this positive-definite matrix, and the natural logarithm of
    /// its determinant (`2 Σ ln L_jj`, from the same factor).
    pub fn inverse_band(&self) -> Result<(Band, f64), SequenceError> {
        let (n, b) = (self.n, self.b);
        let fail = SequenceError::Factorisation {
            what: "band marginals",
        };
        // Band Cholesky, in place on a copy: l(i, j) for j ≤ i ≤ j + b.
        let mut l = Band {
            n,
            b,
            vals: self.vals.clone(),
        };
        for j in 0..n {
            let mut d = l.at(j, j);
            for k in j.saturating_sub(b)..j {
                let v = l.at(j, k);
                d -= v * v;
            }
            if !(d > 0.0 && d.is_finite()) {
                return Err(fail);
            }
            let d = d.sqrt();
            l.set(j, j, d);
            for i in j + 1..(j + b + 1).min(n) {
                let mut v = l.at(i, j);
                for k in i.saturating_sub(b)..j {
                    v -= l.at(i, k) * l.at(j, k);
                }
                l.set(i, j, v / d);
            }
        }
        // `l.at(i, j)` for i < j would read the lower entry back: use `lower` to be explicit.
        let lower = |i: usize, j: usize| if i >= j { l.at(i, j) } else { 0.0 };
        let log_det = 2.0 * (0..n).map(|j| lower(j, j).ln()).sum::<f64>();
        let mut s = Band::zeros(n, b);
        for j in (0..n).rev() {
            let ljj = lower(j, j);
            let end = (j + b + 1).min(n);
            for i in (j..end).rev() {
                let mut acc = 0.0;
                for k in j + 1..end {
                    acc += lower(k, j) * s.at(i, k);
                }
                let delta = if i == j { 1.0 / ljj } else { 0.0 };
                s.set(i, j, (delta - acc) / ljj);
            }
        }
        Ok((s, log_det))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn the_band_of_the_inverse_and_the_log_determinant_match_dense_ones() {
        let (n, b) = (40, 5);
        let mut band = Band::zeros(n, b);
        let mut dense = DMatrix::zeros(n, n);
        for j in 0..n {
            for i in j..(j + b + 1).min(n) {
                let v = if i == j {
                    4.0 + (j % 3) as f64
                } else {
                    ((i * 7 + j * 3) % 5) as f64 * 0.1 - 0.2
                };
                band.set(i, j, v);
                dense[(i, j)] = v;
                dense[(j, i)] = v;
            }
        }
        let (s, log_det) = band.inverse_band().unwrap();
        let dense_log_det = dense.clone().cholesky().unwrap().determinant().ln();
        assert!((log_det - dense_log_det).abs() < 1e-10 * dense_log_det.abs());
        let inv = dense.try_inverse().unwrap();
        for j in 0..n {
            for i in j..(j + b + 1).min(n) {
                assert!((s.at(i, j) - inv[(i, j)]).abs() < 1e-12, "({i}, {j})");
            }
        }
    }
}
