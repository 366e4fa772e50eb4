//! What every registration method takes and returns: the [`Registrar`] trait, the prepared
//! scans it registers and the [`Registration`] it yields.

use nalgebra::Isometry2;

use crate::covariance::Covariance;
use crate::error::ScanRole;
use crate::moving::MovingReturns;
use crate::quality::{Conditioning, MIN_OVERLAP};
use crate::spec::VariantSpec;
use crate::surface::{SurfaceParams, Surfaces};
use crate::termination::StopReason;
use crate::workspace::Workspace;
use crate::{IcpError, Scan};

/// The outcome of one registration of a source scan onto a reference scan.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Registration {
    /// Maps points of the source scan (k) into the reference scan's frame (k+1).
    pub t_ref_src: Isometry2<f64>,
    /// Minimisation steps taken.
    pub iterations: usize,
    /// Why the loop stopped.
    pub stop: StopReason,
    /// Pairs the metric used at the solution.
    pub n_pairs: usize,
    /// Pairs the metric could not use at the solution (no surface estimate at a point, or
    /// beyond the correspondence gate); 0 for the paper's point-to-point variants.
    pub n_unusable: usize,
    /// Sum of the final pair weights of the last minimisation step (scheme × robust factor).
    pub weight_sum: f64,
    /// Mean residual of the used pairs after the final estimate, metres: the pair distance for
    /// point-to-point, the distance along the reference normal for the other metrics.
    pub mean_residual_m: f64,
    /// How well the final pairs constrain the motion (`None` with fewer than 3 usable normals).
    pub conditioning: Option<Conditioning>,
    /// How much the scans overlap at the solution: the smaller of the fractions of source
    /// points near reference points and of reference points near source points (see
    /// [`crate::quality::overlap`]).
    pub overlap: f64,
    /// The covariance of `t_ref_src` over `(tx m, ty m, θ rad)` by Censi's closed form (see
    /// [`crate::covariance`]), from the final pairs and weights and the chain's sensor model;
    /// `None` for a metric without a valid closed form (point-to-point).
    pub covariance: Option<Covariance>,
    /// The grouped jackknife of the same final pairs over angular sectors (see
    /// [`crate::covariance::Sandwich::jackknife_covariance`]): the covariance the residuals
    /// show, whatever the sensor model says; `None` where `covariance` is, and when the method
    /// was told not to compute it ([`Registrar::set_jackknife`]).
    #[serde(default)]
    pub jackknife_covariance: Option<Covariance>,
}

impl Registration {
    /// True when the iteration settled (mean residual or update) before the iteration limit;
    /// false for a pose made elsewhere (nothing settled here, see [`Self::iterated`]).
    pub fn converged(&self) -> bool {
        !matches!(self.stop, StopReason::MaxIterations | StopReason::Given)
    }

    /// False for a pose estimated elsewhere and assessed here (the `assess` module): its
    /// iteration count and convergence are not ours to report.
    pub fn iterated(&self) -> bool {
        self.stop != StopReason::Given
    }

    /// True when too few final pairs are close (overlap below [`MIN_OVERLAP`], or NaN).
    pub fn no_overlap(&self) -> bool {
        self.overlap.is_nan() || self.overlap < MIN_OVERLAP
    }
}

/// A scan with its surface estimates: what a registration takes. The estimates are made once
/// per scan ([`Surfaces::estimate`]) and shared by every registration that uses the scan.
#[derive(Clone, Copy, Debug)]
pub struct Prepared<'a> {
    /// The scan.
    pub scan: &'a Scan,
    /// Its surface estimates, one per return.
    pub surfaces: &'a Surfaces,
}

impl<'a> Prepared<'a> {
    /// `scan` with `surfaces`.
    pub fn new(scan: &'a Scan, surfaces: &'a Surfaces) -> Self {
        Self { scan, surfaces }
    }

    /// `Err` unless the estimates are one per return of the scan, made with `params`.
    pub(crate) fn check(&self, params: &SurfaceParams, role: ScanRole) -> Result<(), IcpError> {
        if self.surfaces.points().len() != self.scan.len() {
            return Err(IcpError::SurfacesMismatch {
                role,
                why: "do not have one estimate per return",
            });
        }
        if self.surfaces.params() != params {
            return Err(IcpError::SurfacesMismatch {
                role,
                why: "were made with other parameters than the method's",
            });
        }
        Ok(())
    }
}

/// A registration method: estimates `t_ref_src` from two prepared scans and an initial guess.
pub trait Registrar: Send + Sync {
    /// A short name, e.g. `HD_ICP`.
    fn name(&self) -> &str;

    /// What this method is, stage by stage, for reports: a registered chain gives the
    /// configuration it was built from, and a stage written in user code reports its type.
    fn spec(&self) -> VariantSpec;

    /// How the surface estimates this method takes are made.
    fn surface_params(&self) -> SurfaceParams;

    /// The detector of moving returns a harness runs over the sequence before registering
    /// each pair again without them ([`crate::moving`]); `None`: every return is kept.
    fn moving(&self) -> Option<&dyn MovingReturns> {
        None
    }

    /// Whether its registrations also compute the grouped jackknife of their covariance
    /// ([`Registration::jackknife_covariance`]; on unless turned off): a caller that uses the
    /// closed form alone, or no covariance, turns it off. Changes nothing else of a result. A
    /// method without a jackknife ignores it.
    fn set_jackknife(&mut self, _on: bool) {}

    /// Registers `source` (scan k) onto `reference` (scan k+1), starting from `init`, in the
    /// buffers of `workspace`.
    fn register_prepared(
        &self,
        workspace: &mut Workspace,
        source: Prepared<'_>,
        reference: Prepared<'_>,
        init: Isometry2<f64>,
    ) -> Result<Registration, IcpError>;

    /// Registers `source` onto `reference`, estimating their surfaces and with buffers of its
    /// own.
    fn register(
        &self,
        source: &Scan,
        reference: &Scan,
        init: Isometry2<f64>,
    ) -> Result<Registration, IcpError> {
        let params = self.surface_params();
        let (s, r) = (
            Surfaces::estimate(source, &params),
            Surfaces::estimate(reference, &params),
        );
        self.register_prepared(
            &mut Workspace::default(),
            Prepared::new(source, &s),
            Prepared::new(reference, &r),
            init,
        )
    }
}

/// `Err` unless `init` is finite.
pub(crate) fn check_init(init: &Isometry2<f64>) -> Result<(), IcpError> {
    for (what, value) in [
        ("init.translation", init.translation.vector.norm()),
        ("init.rotation", init.rotation.angle()),
    ] {
        if !value.is_finite() {
            return Err(IcpError::NonFinite {
                what,
                index: 0,
                value,
            });
        }
    }
    Ok(())
}
