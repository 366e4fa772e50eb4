//! The quantised likelihood of a grid cell, `quantise(exp(−x))` for an exponent
//! `x = d²/(2σ²)`, and what is known of it without computing `exp`.
//!
//! A cell is written once per reference point within reach, and `exp` was most of the grid's
//! cost. The quantised value is a step function of `x` with 255 steps, at the thresholds
//! `T_v = ln(255 / (v + ½))` where `255 e^{−x}` rounds up to `v + 1`. So:
//! * beyond `T_v` a point cannot lift a cell that already holds `v` ([`exponent_below`]);
//! * between two thresholds the value is constant, and a table over small intervals of `x`
//!   ([`QuantisedExp`]) gives it for every interval no threshold comes near; only inside the
//!   few intervals that hold one is `exp` computed. Every value is the one `exp` would give,
//!   bit for bit (the margin [`EXPONENT_SLACK`] is far above the rounding of `exp` and `ln`).

/// The likelihood is cut to 0 beyond this many σ from every reference point
/// (`exp(−4.5) ≈ 0.011`).
pub const TRUNCATION_SIGMAS: f64 = 3.0;

/// The quantised likelihood of 1.
pub const FULL_SCALE: u8 = u8::MAX;

/// A likelihood in [0, 1] as a `u8`, rounded.
pub(crate) fn quantise(v: f64) -> u8 {
    (v * f64::from(FULL_SCALE)).round() as u8
}

/// Slack on the thresholds, far above the rounding of `exp` and `ln` (about 1e-16 relative)
/// and far below a quantisation step.
pub(crate) const EXPONENT_SLACK: f64 = 1e-9;

/// `below[v]`: an `x ≥ 0` beyond which `quantise(exp(−x)) ≤ v` for certain: `255 e^{−x}` is
/// below `v + ½` (where rounding would give `v + 1`) from `x = ln(255 / (v + ½))` on, and
/// the slack covers the rounding of the computed `exp` and `ln`. (Negative for 255: every
/// `x` beyond the slack.)
pub(crate) fn exponent_below() -> [f64; 256] {
    let full = f64::from(FULL_SCALE);
    std::array::from_fn(|v| (full / (v as f64 + 0.5)).ln() + EXPONENT_SLACK)
}

/// Intervals of the table per unit of exponent: ~5 % of them hold a threshold.
const INTERVALS_PER_UNIT: f64 = 1024.0;

/// `quantise(exp(−x))` by table, for the exponents of a grid's cells, `0 ≤ x ≤
/// TRUNCATION_SIGMAS² / 2` (beyond, and inside an interval that holds a threshold, by `exp`).
#[derive(Debug)]
pub(crate) struct QuantisedExp {
    /// Per interval `[k, k + 1) / INTERVALS_PER_UNIT` of `x`: its value, or `None` where a
    /// threshold lies in it or within [`EXPONENT_SLACK`] of it; then `None` for every `x`
    /// past the intervals (by `exp`).
    values: Vec<Option<u8>>,
    /// [`exponent_below`].
    below: [f64; 256],
}

/// [`QuantisedExp`], made once per process.
pub(crate) static QUANTISED_EXP: std::sync::LazyLock<QuantisedExp> =
    std::sync::LazyLock::new(QuantisedExp::new);

impl QuantisedExp {
    fn new() -> Self {
        let x_max = 0.5 * TRUNCATION_SIGMAS * TRUNCATION_SIGMAS;
        let intervals = (x_max * INTERVALS_PER_UNIT).ceil() as usize + 1;
        // The thresholds themselves (without the slack `exponent_below` adds).
        let thresholds: Vec<f64> = exponent_below()
            .iter()
            .map(|t| t - EXPONENT_SLACK)
            .collect();
        let values = (0..intervals)
            .map(|k| {
                let lo = k as f64 / INTERVALS_PER_UNIT;
                let hi = (k + 1) as f64 / INTERVALS_PER_UNIT;
                let near = |t: f64| t >= lo - EXPONENT_SLACK && t <= hi + EXPONENT_SLACK;
                (!thresholds.iter().any(|&t| near(t))).then(|| quantise((-0.5 * (lo + hi)).exp()))
            })
            .chain([None])
            .collect();
        Self {
            values,
            below: exponent_below(),
        }
    }

    /// The entry of `x ≥ 0`: its interval's, or the one past them. (A float to usize cast
    /// saturates: a huge `x` falls past them too.)
    #[inline]
    fn entry(&self, x: f64) -> usize {
        ((x * INTERVALS_PER_UNIT) as usize).min(self.values.len() - 1)
    }

    /// `quantise(exp(−x))` for `x ≥ 0`.
    #[cfg(test)]
    fn of(&self, x: f64) -> u8 {
        self.values[self.entry(x)].unwrap_or_else(|| quantise((-x).exp()))
    }

    /// Raises `cell` to `quantise(exp(−x))` (`x ≥ 0`) when that is higher. `exp` is computed
    /// only in an interval that holds a threshold, and then only when `x` is below the cell's
    /// own threshold (beyond it the value would not lift the cell).
    #[inline]
    pub(crate) fn raise(&self, cell: &mut u8, x: f64) {
        match self.values[self.entry(x)] {
            Some(v) => *cell = (*cell).max(v),
            None => {
                if x <= self.below[usize::from(*cell)] {
                    *cell = (*cell).max(quantise((-x).exp()));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Beyond its threshold an exponent's likelihood never quantises above the value the
        /// threshold is for (just past the threshold, and anywhere in the grid's range), and
        /// every value is reached just below its own threshold: the skipped `exp`s would not
        /// have changed a cell.
        #[test]
        fn skipped_exponents_change_no_cell(v in any::<u8>(), just_past in 0.0..1e-6f64, x in 0.0..4.6f64) {
            let below = exponent_below();
            let t = below[usize::from(v)];
            for e in [t + just_past, t.next_up(), x] {
                if e > t && e >= 0.0 {
                    prop_assert!(quantise((-e).exp()) <= v, "v {} e {}", v, e);
                }
            }
            if v < u8::MAX {
                // The slack is small: a little below the threshold the value is above v.
                let e = t - 2.0 * EXPONENT_SLACK - 1e-7;
                if e >= 0.0 {
                    prop_assert!(quantise((-e).exp()) > v, "v {} e {}", v, e);
                }
            }
        }

        /// The table gives `exp`'s value anywhere in (and past) the grid's range, and at and
        /// around every threshold, where a wrong interval would show first.
        #[test]
        fn the_table_is_exp_bit_for_bit(x in 0.0..6.0f64, v in any::<u8>(), tiny in -1e-6..1e-6f64) {
            let table = &*QUANTISED_EXP;
            prop_assert_eq!(table.of(x), quantise((-x).exp()), "x {}", x);
            let t = exponent_below()[usize::from(v)] - EXPONENT_SLACK;
            for e in [t, t.next_up(), t.next_down(), t + tiny] {
                if e >= 0.0 {
                    prop_assert_eq!(table.of(e), quantise((-e).exp()), "e {}", e);
                }
            }
        }
    }

    proptest! {
        /// Raising a cell is the max of it and the likelihood: the same cells as the test on
        /// the threshold then the likelihood.
        #[test]
        fn raising_a_cell_is_the_max(
            cell in any::<u8>(),
            x in 0.0..6.0f64,
            v in any::<u8>(),
            tiny in -1e-6..1e-6f64,
        ) {
            let table = &*QUANTISED_EXP;
            let t = exponent_below()[usize::from(v)] - EXPONENT_SLACK;
            for e in [x, t, t.next_up(), t.next_down(), t + tiny] {
                if e >= 0.0 {
                    let mut raised = cell;
                    table.raise(&mut raised, e);
                    prop_assert_eq!(raised, cell.max(quantise((-e).exp())), "cell {} e {}", cell, e);
                }
            }
        }
    }

    /// On a fine lattice over the grid's range (100 points per interval of the table) the
    /// table and `exp` agree, and most intervals need no `exp`.
    #[test]
    fn the_table_agrees_on_a_fine_lattice() {
        let table = &*QUANTISED_EXP;
        let n = table.values.len() * 100;
        for k in 0..n {
            let x = k as f64 / (INTERVALS_PER_UNIT * 100.0);
            assert_eq!(table.of(x), quantise((-x).exp()), "x {x}");
        }
        let by_exp = table.values.iter().filter(|v| v.is_none()).count();
        assert!(
            by_exp * 10 < table.values.len(),
            "{by_exp} of {}",
            table.values.len()
        );
    }
}
