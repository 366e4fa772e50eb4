//! The marginal covariances of the batch smoother: the entries of `H⁻¹` within H's band, from
//! the Cholesky factor `H = L Lᵀ` (faer's, with H's rows and columns in the scans' order, so
//! that L has no entry outside H's band) by the Takahashi recursion (Takahashi, Fagan & Chen
//! 1973): for `j` from the last down, `Σ_ij = (δ_ij / L_jj − Σ_{k>j} L_kj Σ_ik) / L_jj` over
//! the band. Every `Σ_ik` it needs lies within the band, so the cost is `O(n b²)` for bandwidth
//! b (about 6 × the longest lag, in scalars), where solving for the columns of `H⁻¹` costs
//! `O(n² b)`.

use super::SequenceError;

/// The columns of a lower Cholesky factor L (`H = L Lᵀ`) whose entries lie within H's band.
pub(crate) trait FactorColumns {
    /// Writes `L(j..j + out.len(), j)` into `out`, which holds zeros (left where L has no
    /// entry). An entry of the column past `out` that is not zero is an error: the factor
    /// is not within the band.
    fn column(&mut self, j: usize, out: &mut [f64]) -> Result<(), SequenceError>;
}

/// What the recursion knows of `Σ = H⁻¹` once column j is done: `Σ(i₁, i₂)` for `i₁` and
/// `i₂` in `j..=j + b`.
pub(crate) struct Window<'a> {
    ring: &'a [f64],
    stride: usize,
    w: usize,
    first: usize,
}

impl Window<'_> {
    /// `Σ(i₁, i₂)`, or none where either index lies outside the window.
    pub fn at(&self, i1: usize, i2: usize) -> Option<f64> {
        let inside = |i: usize| i >= self.first && i - self.first < self.w;
        (inside(i1) && inside(i2)).then(|| self.ring[(i2 % self.w) * self.stride + i1 % self.w])
    }
}

/// Takahashi's recursion over the `n` columns of a factor within bandwidth `b`, from the
/// last: `visit(j, window)` once column j of `Σ = H⁻¹` is known (the window then holds
/// `Σ(j..=j + b, j..=j + b)`); returns `ln det H` (`2 Σ ln L_jj`). A diagonal entry of L that
/// is not positive and finite is an error.
///
/// Column j of Σ below the diagonal is `Σ(j+1.., j) = −W l / L_jj` with `l = L(j+1.., j)` and
/// W the window after j, already known. The window is kept whole (both triangles) in a ring
/// of `b + 1` columns, index `i` in slot `i mod (b + 1)`, and column j takes the slot that
/// index `j + b + 1` leaves: `W l` is then a sum of whole, contiguous columns (see
/// [`Recursion`]). Reading the lower band alone, a product and a dot per column of W of
/// decreasing lengths, took a quarter of the estimation of `Qc` on the harbour's size
/// (bandwidth 32); reports/performance.md (issue 35) has the figures. The window is all the
/// callers read (each scan's blocks and its next scan's lie within it when the scan's first
/// column is done), so no band of Σ is written out.
pub(crate) fn inverse_in_band(
    n: usize,
    b: usize,
    factor: &mut impl FactorColumns,
    mut visit: impl FnMut(usize, &Window<'_>),
) -> Result<f64, SequenceError> {
    pulp::Arch::new().dispatch(Recursion {
        n,
        b,
        factor,
        visit: &mut visit,
    })
}

/// Takahashi's recursion ([`inverse_in_band`]). Run through pulp's dispatch (faer's own, as
/// its factorisation is), so that `W l` is compiled for the machine's widest vectors and fused
/// multiply–adds, a tile of rows at a time summed in registers ([`tile`]); the slot of the
/// index that left the window is multiplied by no entry of `l`, and its row of `W l` is
/// computed and not read.
struct Recursion<'a, F, V> {
    n: usize,
    b: usize,
    factor: &'a mut F,
    visit: &'a mut V,
}

impl<F: FactorColumns, V: FnMut(usize, &Window<'_>)> pulp::WithSimd for Recursion<'_, F, V> {
    type Output = Result<f64, SequenceError>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Self::Output {
        let (n, b) = (self.n, self.b);
        let w = b + 1;
        // The window, column-major by slot, each column padded to a whole number of the
        // widest vectors; slots no index has reached yet hold zeros.
        let stride = w.div_ceil(PAD) * PAD;
        let mut ring = vec![0.0; w * stride];
        let mut v = vec![0.0; stride];
        // Column j of L and of Σ, from the diagonal down.
        let (mut l, mut out) = (vec![0.0; w], vec![0.0; w]);
        // L's diagonal, for `ln det H` summed in the columns' order (as before the window was
        // kept whole: the EM's likelihood, and so where it stops, unchanged).
        let mut diagonal = vec![0.0; n];
        // The slot of index j + 1 + k, k = 0..b (the window after j).
        let mut slots = vec![0usize; b];
        for j in (0..n).rev() {
            let len = w.min(n - j);
            let l = &mut l[..len];
            l.fill(0.0);
            self.factor.column(j, l)?;
            let ljj = l[0];
            if !(ljj > 0.0 && ljj.is_finite()) {
                return Err(SequenceError::Factorisation {
                    what: "band marginals",
                });
            }
            diagonal[j] = ljj;
            let lcol = &l[1..];
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
            let out = &mut out[..len];
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
            let window = Window {
                ring: &ring,
                stride,
                w,
                first: j,
            };
            (self.visit)(j, &window);
        }
        Ok(2.0 * diagonal.iter().map(|d| d.ln()).sum::<f64>())
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

    /// A dense lower factor's columns.
    struct Dense(DMatrix<f64>);

    impl FactorColumns for Dense {
        fn column(&mut self, j: usize, out: &mut [f64]) -> Result<(), SequenceError> {
            for (d, o) in out.iter_mut().enumerate() {
                *o = self.0[(j + d, j)];
            }
            match (j + out.len()..self.0.nrows()).all(|i| self.0[(i, j)] == 0.0) {
                true => Ok(()),
                false => Err(SequenceError::Factorisation {
                    what: "factor outside the band",
                }),
            }
        }
    }

    /// The band of Σ and `ln det H` as [`inverse_in_band`] gives them.
    fn band_of_inverse(l: DMatrix<f64>, b: usize) -> Result<(DMatrix<f64>, f64), SequenceError> {
        let n = l.nrows();
        let mut band = DMatrix::from_element(n, n, f64::NAN);
        let log_det = inverse_in_band(n, b, &mut Dense(l), |j, window| {
            for i in j..(j + b + 1).min(n) {
                band[(i, j)] = window.at(i, j).unwrap();
            }
            assert_eq!(window.at(j + b + 1, j), None);
            if j > 0 {
                assert_eq!(window.at(j, j - 1), None);
            }
        })?;
        Ok((band, log_det))
    }

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
            // Rounding leaves entries below 1e-15 past the band; the factor's own columns
            // hold exact zeros there.
            let mut l = l;
            for j in 0..n {
                for i in j + b + 1..n {
                    assert!(l[(i, j)].abs() < 1e-15, "fill outside the band");
                    l[(i, j)] = 0.0;
                }
            }
            let (s, log_det) = band_of_inverse(l, b).unwrap();
            let dense_log_det = dense.clone().cholesky().unwrap().determinant().ln();
            assert!((log_det - dense_log_det).abs() < 1e-10 * dense_log_det.abs());
            let inv = dense.try_inverse().unwrap();
            for j in 0..n {
                for i in j..(j + b + 1).min(n) {
                    assert!(
                        (s[(i, j)] - inv[(i, j)]).abs() < 1e-12,
                        "{n} {b}: ({i}, {j})"
                    );
                }
            }
        }
    }

    #[test]
    fn a_factor_without_a_positive_diagonal_or_outside_the_band_is_an_error() {
        let mut l = DMatrix::zeros(3, 3);
        l[(0, 0)] = 1.0;
        l[(2, 2)] = 1.0;
        assert!(band_of_inverse(l.clone(), 1).is_err());
        l[(1, 1)] = f64::NAN;
        assert!(band_of_inverse(l.clone(), 1).is_err());
        l[(1, 1)] = 2.0;
        assert!(band_of_inverse(l.clone(), 1).is_ok());
        l[(2, 0)] = 0.5;
        assert!(band_of_inverse(l.clone(), 1).is_err());
        assert!(band_of_inverse(l, 2).is_ok());
    }
}
