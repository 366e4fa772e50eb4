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

    /// Column j's entries `(j..=j + b, j)`, as many as lie in the matrix.
    pub fn column_mut(&mut self, j: usize) -> &mut [f64] {
        let w = self.b + 1;
        let len = w.min(self.n - j);
        &mut self.vals[j * w..j * w + len]
    }

    /// Taking this band as the lower Cholesky factor L of a positive-definite matrix
    /// `H = L Lᵀ` (the factor lies within H's band where H's rows and columns keep their
    /// order: no fill outside it), the band of `H⁻¹` and `ln det H` (`2 Σ ln L_jj`).
    ///
    /// Column j of `Σ = H⁻¹` below the diagonal is `Σ(j+1.., j) = −W l / L_jj` with
    /// `l = L(j+1.., j)` and W the window `Σ(j+1..j+b, j+1..j+b)`, already known. The window
    /// is kept whole (both triangles) in a ring of `b + 1` columns, index `i` in slot
    /// `i mod (b + 1)`, and column j takes the slot that index `j + b + 1` leaves: `W l` is
    /// then a sum of whole, contiguous columns (see [`Recursion`]). Reading the lower band
    /// alone, a product and a dot per column of W of decreasing lengths, took a quarter of
    /// the estimation of `Qc` on the harbour's size (bandwidth 32); reports/performance.md
    /// (issue 35) has the figures.
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
        let mut s = vec![0.0; n * w];
        pulp::Arch::new().dispatch(Recursion {
            factor: self,
            sigma: &mut s,
        });
        Ok((Band { n, b, vals: s }, log_det))
    }
}

/// Takahashi's recursion over the factor's columns from the last (see
/// [`Band::inverse_of_factor`]), writing the band of `Σ` into `sigma` (laid out as the
/// factor's). Run through pulp's dispatch (faer's own, as its factorisation is), so that
/// `W l` is compiled for the machine's widest vectors and fused multiply–adds, a tile of rows
/// at a time summed in registers ([`tile`]); the slot of the index that left the window is
/// multiplied by no entry of `l`, and its row of `W l` is computed and not read.
struct Recursion<'a> {
    factor: &'a Band,
    sigma: &'a mut [f64],
}

impl pulp::WithSimd for Recursion<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let (n, b) = (self.factor.n, self.factor.b);
        let w = b + 1;
        let l = &self.factor.vals;
        let s = self.sigma;
        // The window, column-major by slot, each column padded to a whole number of the
        // widest vectors; slots no index has reached yet hold zeros.
        let stride = w.div_ceil(PAD) * PAD;
        let mut ring = vec![0.0; w * stride];
        let mut v = vec![0.0; stride];
        // The slot of index j + 1 + k, k = 0..b (the window after j).
        let mut slots = vec![0usize; b];
        for j in (0..n).rev() {
            let ljj = l[j * w];
            let len = w.min(n - j);
            let lcol = &l[j * w + 1..j * w + len];
            let own = j % w;
            let slots = &mut slots[..len - 1];
            let mut next = own;
            for slot in slots.iter_mut() {
                next = if next + 1 == w { 0 } else { next + 1 };
                *slot = next;
            }
            // v = W l, in slot order.
            let (acc, _) = S::as_mut_simd_f64s(&mut v);
            let mut start = 0;
            while start < acc.len() {
                let ring = &ring[..];
                let columns = slots.iter().zip(lcol).map(|(&slot, &lk)| {
                    let (col, _) = S::as_simd_f64s(&ring[slot * stride..(slot + 1) * stride]);
                    (col, lk)
                });
                start += match acc.len() - start {
                    8.. => tile::<S, 8>(simd, columns, start, acc),
                    4.. => tile::<S, 4>(simd, columns, start, acc),
                    2.. => tile::<S, 2>(simd, columns, start, acc),
                    _ => tile::<S, 1>(simd, columns, start, acc),
                };
            }
            let out = &mut s[j * w..j * w + len];
            let mut dot = 0.0;
            for ((&slot, lk), below) in slots.iter().zip(lcol).zip(&mut out[1..]) {
                *below = -v[slot] / ljj;
                dot += lk * *below;
            }
            out[0] = (1.0 / ljj - dot) / ljj;
            // Column and row j of the window, in the slot index j + b + 1 leaves.
            ring[own * stride + own] = out[0];
            for (&slot, sij) in slots.iter().zip(&out[1..]) {
                ring[own * stride + slot] = *sij;
                ring[slot * stride + own] = *sij;
            }
        }
    }
}

/// Rows `start..start + T` (in vectors) of `Σ_c col_c l_c` over `columns`, summed in `T`
/// registers, into `out`; returns `T`.
#[inline(always)]
fn tile<'a, S: pulp::Simd, const T: usize>(
    simd: S,
    columns: impl Iterator<Item = (&'a [S::f64s], f64)>,
    start: usize,
    out: &mut [S::f64s],
) -> usize {
    let mut acc = [simd.splat_f64s(0.0); T];
    for (col, lk) in columns {
        let lk = simd.splat_f64s(lk);
        let col = &col[start..start + T];
        for t in 0..T {
            acc[t] = simd.mul_add_e_f64s(col[t], lk, acc[t]);
        }
    }
    out[start..start + T].copy_from_slice(&acc);
    T
}

/// The window's columns are padded to a multiple of this many values: the widest vector
/// (AVX-512's eight), so that every column is whole vectors on every machine.
const PAD: usize = 8;

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn the_band_of_the_inverse_and_the_log_determinant_match_dense_ones() {
        // Narrow and wide bands (window columns of 2 to 12 vectors of four: every tile size
        // but one), the harbour's bandwidth, and one wider than the matrix (the window's slots
        // past its last index never filled).
        for (n, b) in [(40, 5), (60, 11), (7, 9), (120, 32), (50, 45)] {
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
                        factor.column_mut(j)[i - j] = l[(i, j)];
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
        factor.column_mut(0)[0] = 1.0;
        factor.column_mut(2)[0] = 1.0;
        assert!(factor.inverse_of_factor().is_err());
        factor.column_mut(1)[0] = f64::NAN;
        assert!(factor.inverse_of_factor().is_err());
        factor.column_mut(1)[0] = 2.0;
        assert!(factor.inverse_of_factor().is_ok());
    }
}
