//! Pair weighting, Algorithm 1 step 3 (Naus & Marchel 2019, eqs. 11–13).
//!
//! A scheme sees one pair at a time through [`PairView`], so a new scheme is a few lines: see
//! the README's recipe (one file with its `impl PairWeighting` and its `KIND`, and one line in
//! [`WEIGHTINGS`]). A scheme written outside Rust weighs a whole iteration through
//! [`BatchWeighting`].

use nalgebra::{Point2, UnitComplex, Vector2};

use crate::pairs::PairSet;
use crate::registry::{Family, StageSpec};
use crate::scan::Return;

mod batch;
mod directional;
mod inverse_range;
mod mean_error;
mod normal_directional;
mod uniform;

pub use batch::BatchWeighting;
pub(crate) use batch::Weighting;
pub use directional::Directional;
pub use inverse_range::InverseRange;
pub use mean_error::MeanError;
pub use normal_directional::NormalDirectional;
pub use uniform::Uniform;

/// Every registered weighting scheme, one line each.
pub static WEIGHTINGS: Family<dyn PairWeighting> = Family {
    name: "weighting",
    summary: "Alg. 1 step 3: the weight w_i of each pair in eq. 14",
    kinds: &[
        &uniform::KIND,
        &mean_error::KIND,
        &directional::KIND,
        &normal_directional::KIND,
        &inverse_range::KIND,
    ],
};

/// What a weighting scheme knows about one matched pair.
#[derive(Clone, Copy, Debug)]
pub struct PairView<'a> {
    /// The source return (scan k), in scan k's frame.
    pub src: &'a Return,
    /// The matched reference return (scan k+1), in scan k+1's frame.
    pub dst: &'a Return,
    /// The source point moved by the current estimate into scan k+1's frame.
    pub src_moved: Point2<f64>,
    /// Rotation of the current estimate `t_ref_src`: a direction `β` in scan k+1's frame is
    /// `β − θ` in scan k's frame.
    pub rotation_ref_src: UnitComplex<f64>,
    /// The unit normal of the reference surface at `dst`, in scan k+1's frame, when it has a
    /// usable estimate (see [`crate::surface`]).
    pub normal: Option<Vector2<f64>>,
}

/// Gives each pair its weight `w_i` of eq. 14.
pub trait PairWeighting: Send + Sync {
    /// What this stage is, as configuration data (a scheme written outside the registry
    /// reports its Rust type).
    fn spec(&self) -> StageSpec {
        StageSpec::unregistered::<Self>()
    }

    /// The weight of one pair: finite and positive.
    fn weight(&self, pair: &PairView<'_>) -> f64;

    /// The weights of every pair of `set`, in order, into `out` (cleared first). There is no
    /// need to override it: it exists so that a boxed scheme costs one dynamic call per
    /// iteration, with [`PairWeighting::weight`] inlined in the loop, not one call per pair.
    fn weigh_all(&self, set: &PairSet<'_>, out: &mut Vec<f64>) {
        out.clear();
        out.extend(set.pairs.iter().map(|c| {
            self.weight(&PairView {
                src: &set.src[c.src],
                dst: &set.dst[c.dst],
                src_moved: set.src_moved[c.src],
                rotation_ref_src: set.t_ref_src.rotation,
                normal: set.dst_surfaces[c.dst].map(|s| s.normal),
            })
        }));
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::registry::BuildContext;
    use crate::SensorModel;

    /// A return at range `r`, bearing `a`.
    pub(crate) fn ret(r: f64, a: f64) -> Return {
        Return {
            point: Point2::new(r * a.cos(), r * a.sin()),
            range_m: r,
            bearing_rad: a,
        }
    }

    /// The view of `src` → `dst` at the identity, with `normal`.
    pub(crate) fn view<'a>(
        src: &'a Return,
        dst: &'a Return,
        normal: Option<Vector2<f64>>,
    ) -> PairView<'a> {
        PairView {
            src,
            dst,
            src_moved: src.point,
            rotation_ref_src: UnitComplex::identity(),
            normal,
        }
    }

    #[test]
    fn every_kind_builds_reports_itself_and_weighs_positively() {
        let ctx = BuildContext {
            sensor: SensorModel::sweep(),
        };
        let (a, b) = (ret(12.0, 0.3), ret(12.2, 0.31));
        for kind in WEIGHTINGS.kinds {
            let spec = StageSpec::kind(kind.name());
            let scheme = WEIGHTINGS.build(&spec, &ctx).unwrap();
            assert_eq!(
                scheme.spec(),
                WEIGHTINGS.normalize(&spec).unwrap(),
                "{}",
                kind.name()
            );
            for normal in [None, Some(Vector2::new(0.0, 1.0))] {
                let w = scheme.weight(&view(&a, &b, normal));
                assert!(w.is_finite() && w > 0.0, "{}: {w}", kind.name());
            }
        }
    }
}
