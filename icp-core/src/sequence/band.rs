//! The marginal covariances of the batch smoother: the entries of `H⁻¹` within H's band, from
//! the Cholesky factor `H = L Lᵀ` (faer's, with H's rows and columns in the scans' order, so
//! that L has no entry outside H's band) by the Takahashi recursion (Takahashi, Fagan & Chen
//! 1973): for `j` from the last down, `Σ_ij = (δ_ij / L_jj − Σ_{k>j} L_kj Σ_ik) / L_jj` over
//! the band. Every `Σ_ik` it needs lies within the band, so the cost is `O(n b²)` for bandwidth
//! b (about 6 × the longest lag, in scalars), where solving for the columns of `H⁻¹` costs
//! `O(n² b)`.

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

    /// Taking this band as the lower Cholesky factor L of a positive-definite matrix
    /// `H = L Lᵀ` (the factor lies within H's band where H's rows and columns keep their
    /// order: no fill outside it), the band of `H⁻¹` and `ln det H` (`2 Σ ln L_jj`).
    ///
    /// The recursion reads and writes whole columns of the band (contiguous in memory):
    /// `Σ(j+1.., j) = −W l / L_jj` with `l = L(j+1.., j)` and W the window of `Σ` after j,
    /// already known. Reading entry by entry through [`Band::at`] took 57 % of the estimation
    /// of `Qc` on the harbour's size once each scan had an error state (bandwidth 35).
    pub fn inverse_of_factor(&self) -> Result<(Band, f64), SequenceError> {
        let (n, b) = (self.n, self.b);
        let w = b + 1;
        let l = &self.vals;
        if (0..n).any(|j| !(l[j * w] > 0.0 && l[j * w].is_finite())) {
            return Err(SequenceError::Factorisation {
                what: "band marginals",
            });
        }
        let log_det = 2.0 * (0..n).map(|j| l[j * w].ln()).sum::<f64>();
        // Takahashi's recursion, from the last column down.
        let mut s = vec![0.0; n * w];
        let mut v = vec![0.0; b];
        for j in (0..n).rev() {
            let ljj = l[j * w];
            let len = (b + 1).min(n - j);
            let lcol = &l[j * w + 1..j * w + len];
            // v = W l over the window j+1..j+len−1 (symmetric, its lower band stored by column).
            let v = &mut v[..len - 1];
            v.fill(0.0);
            for k in 0..len - 1 {
                let col = &s[(j + 1 + k) * w..(j + 1 + k) * w + (len - 1 - k)];
                let lk = lcol[k];
                for (vi, sik) in v[k..].iter_mut().zip(col) {
                    *vi += sik * lk;
                }
                v[k] += dot(&col[1..], &lcol[k + 1..]);
            }
            let out = &mut s[j * w..j * w + len];
            let mut dot = 0.0;
            for (k, vk) in v.iter().enumerate() {
                out[k + 1] = -vk / ljj;
                dot += lcol[k] * out[k + 1];
            }
            out[0] = (1.0 / ljj - dot) / ljj;
        }
        Ok((Band { n, b, vals: s }, log_det))
    }
}

/// `a · b` over their common length, in four independent sums (the products need not wait
/// for each other).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 4];
    let (chunks_a, chunks_b) = (a.chunks_exact(4), b.chunks_exact(4));
    let (rest_a, rest_b) = (chunks_a.remainder(), chunks_b.remainder());
    for (x, y) in chunks_a.zip(chunks_b) {
        for i in 0..4 {
            acc[i] += x[i] * y[i];
        }
    }
    let tail: f64 = rest_a.iter().zip(rest_b).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn the_band_of_the_inverse_and_the_log_determinant_match_dense_ones() {
        // Widths below, at and past the dot product's blocks of four.
        for (n, b) in [(40, 5), (60, 11), (7, 9)] {
            let mut dense = DMatrix::zeros(n, n);
            for j in 0..n {
                for i in j..(j + b + 1).min(n) {
                    let v = if i == j {
                        2.0 * b as f64 + (j % 3) as f64
                    } else {
                        ((i * 7 + j * 3) % 5) as f64 * 0.1 - 0.2
                    };
                    dense[(i, j)] = v;
                    dense[(j, i)] = v;
                }
            }
            // The factor by nalgebra's dense Cholesky: within the band, as the doc says.
            let l = dense.clone().cholesky().unwrap().l();
            let mut factor = Band::zeros(n, b);
            for j in 0..n {
                for i in j..n {
                    if i - j <= b {
                        factor.set(i, j, l[(i, j)]);
                    } else {
                        assert!(l[(i, j)].abs() < 1e-15, "fill outside the band");
                    }
                }
            }
            let (s, log_det) = factor.inverse_of_factor().unwrap();
            let dense_log_det = dense.clone().cholesky().unwrap().determinant().ln();
            assert!((log_det - dense_log_det).abs() < 1e-10 * dense_log_det.abs());
            let inv = dense.try_inverse().unwrap();
            for j in 0..n {
                for i in j..(j + b + 1).min(n) {
                    assert!(
                        (s.at(i, j) - inv[(i, j)]).abs() < 1e-12,
                        "{n} {b}: ({i}, {j})"
                    );
                }
            }
        }
    }

    #[test]
    fn a_factor_without_a_positive_diagonal_is_an_error() {
        let mut factor = Band::zeros(3, 1);
        factor.set(0, 0, 1.0);
        factor.set(2, 2, 1.0);
        assert!(factor.inverse_of_factor().is_err());
        factor.set(1, 1, f64::NAN);
        assert!(factor.inverse_of_factor().is_err());
        factor.set(1, 1, 2.0);
        assert!(factor.inverse_of_factor().is_ok());
    }
}
