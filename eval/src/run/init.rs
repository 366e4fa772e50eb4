//! Where a registration starts: the initial-guess stage.
//!
//! The paper starts every registration at the identity (Algorithm 1, step 0), which works when
//! the scanner moves little between scans (a vessel at 5 Hz). On a log with large motion
//! between scans an identity start lands outside the basin of every local method; the stage
//! lets a run start elsewhere, and `reference` separates starting-point failures from a
//! method's own accuracy. A chain of modes (`constant-velocity,identity`) tries the next mode
//! when a registration from the previous one is flagged (any status but `ok`).

use std::fmt;
use std::str::FromStr;

use datasets::{Dataset, Pose2, ScanPair};
use icp_core::global::GlobalGuess;
use nalgebra::{Isometry2, Matrix2};
use serde::{Deserialize, Serialize};

use crate::data;
use crate::error::InitError;
use crate::run::modes;

/// One way of choosing a registration's start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitMode {
    /// The identity: no motion between the scans (the paper's start).
    Identity,
    /// The same variant's estimate of the previous pair, as a constant twist over the pair's
    /// time step; the identity after a flagged estimate, on the first pair, or when the pairs
    /// are not consecutive.
    ConstantVelocity,
    /// The best pose of a global search (correlative scan matching with branch and bound,
    /// `icp_core::global`) around the identity: for motion beyond a local method's basin.
    Global,
    /// The motion of the dataset's odometry channel between the two scans (needs an
    /// odometry that is independent of the reference).
    Odometry,
    /// The reference motion itself: a diagnostic that tells starting-point failures from a
    /// method's own accuracy (needs a reference that is a rigid 2D pose).
    Reference,
}

/// Every mode with its name and help, registered once: parsing, `--init`'s help and the
/// error messages are generated from it.
pub const MODES: [(InitMode, &str, &str); 5] = [
    (
        InitMode::Identity,
        "identity",
        "no motion between the scans (the paper's start)",
    ),
    (
        InitMode::ConstantVelocity,
        "constant-velocity",
        "the variant's previous estimate over this pair's time step; the identity after a flagged one",
    ),
    (
        InitMode::Global,
        "global",
        "correlative scan matching (branch and bound) within --global-window-m, rotations as --global-rotation says",
    ),
    (
        InitMode::Odometry,
        "odometry",
        "the odometry's motion between the scans (needs an odometry channel independent of the reference)",
    ),
    (
        InitMode::Reference,
        "reference",
        "the reference motion: a diagnostic (needs a rigid reference pose)",
    ),
];

impl InitMode {
    /// True for a start known to lie close to the true motion: the global search's best pose
    /// (within about a cell of the best alignment) and the reference motion (the diagnostic
    /// of a perfect start). Registrations from such a start gate their correspondences
    /// ([`crate::run::start_gate`]).
    pub fn is_close(self) -> bool {
        matches!(self, Self::Global | Self::Reference)
    }

    /// Its name on the command line and in the reports.
    pub fn name(self) -> &'static str {
        modes::name_of(&MODES, &self)
    }
}

impl fmt::Display for InitMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The modes to try in turn: the first one's start, then the next one's while the
/// registration is flagged. The result kept is the first unflagged one, else the last.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct InitChain(Vec<InitMode>);

impl Default for InitChain {
    /// The identity alone, as in the paper.
    fn default() -> Self {
        Self(vec![InitMode::Identity])
    }
}

impl FromStr for InitChain {
    type Err = InitError;
    fn from_str(s: &str) -> Result<Self, InitError> {
        let mut modes = Vec::new();
        for part in s.split(',') {
            let part = part.trim();
            if part.is_empty() {
                return Err(InitError::Empty(s.to_owned()));
            }
            let mode = modes::named(&MODES, part, str::eq_ignore_ascii_case).ok_or_else(|| {
                InitError::Unknown {
                    got: part.to_owned(),
                    known: modes::names(&MODES),
                }
            })?;
            if modes.contains(&mode) {
                return Err(InitError::Repeated(mode.name()));
            }
            modes.push(mode);
        }
        Ok(Self(modes))
    }
}

impl fmt::Display for InitChain {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = self.0.iter().map(|m| m.name()).collect();
        f.write_str(&names.join(","))
    }
}

impl InitChain {
    /// The modes, in the order they are tried.
    pub fn modes(&self) -> &[InitMode] {
        &self.0
    }

    /// True when the chain starts some registration at a global search's result.
    pub fn global(&self) -> bool {
        self.0.contains(&InitMode::Global)
    }

    /// True when some registration of the chain starts close to the true motion
    /// ([`InitMode::is_close`]).
    pub fn close_starts(&self) -> bool {
        self.0.iter().any(|m| m.is_close())
    }

    /// True when a pair's start depends on the previous pair's result (the pairs of a variant
    /// then run one after the other).
    pub fn sequential(&self) -> bool {
        self.0.contains(&InitMode::ConstantVelocity)
    }

    /// `Err` when `ds` cannot give what a mode of the chain needs.
    pub fn check(&self, ds: &Dataset) -> Result<(), InitError> {
        for &mode in &self.0 {
            let unavailable = |why| InitError::Unavailable {
                mode: mode.name(),
                dataset: ds.provenance.name.clone(),
                why,
            };
            if mode == InitMode::Odometry {
                if ds.odometry.is_none() {
                    return Err(unavailable("it has no odometry channel"));
                }
                if ds.independent_odometry().is_none() {
                    return Err(unavailable(
                        "its odometry equals the reference poses (no independent odometry): \
                         a start from it would be the reference motion itself",
                    ));
                }
            }
            if mode == InitMode::Reference {
                match &ds.reference {
                    None => return Err(unavailable("it has no reference")),
                    Some(_) if !ds.rigid_reference() => {
                        return Err(unavailable(
                            "its reference is not a rigid 2D pose of the scanner",
                        ))
                    }
                    Some(_) => {}
                }
            }
        }
        Ok(())
    }
}

/// A variant's previous estimate, for a constant-velocity start.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Previous {
    /// The pair it registered.
    pub pair: ScanPair,
    /// Its time step, s.
    pub dt_s: f64,
    /// Its estimate, when it was not flagged (`None` resets the constant-velocity start).
    pub t_ref_src: Option<Isometry2<f64>>,
}

/// The start `mode` gives for `pair` (time step `dt_s`), with the mode that actually gave it
/// (a constant-velocity start without a usable previous estimate is the identity; so is a
/// global start without a search result, `global`). The chain was
/// [checked](InitChain::check) against `ds`.
pub fn start(
    mode: InitMode,
    ds: &Dataset,
    pair: ScanPair,
    dt_s: f64,
    previous: Option<&Previous>,
    global: Option<&GlobalGuess>,
) -> (Isometry2<f64>, InitMode) {
    let identity = (Isometry2::identity(), InitMode::Identity);
    match mode {
        // The search is made for every pair when the chain has it; a search that could not
        // run (its error is kept with the pair) leaves the identity.
        InitMode::Global => global.map_or(identity, |g| (g.t_ref_src, mode)),
        InitMode::Identity => identity,
        InitMode::ConstantVelocity => match previous {
            Some(&Previous {
                pair: p,
                dt_s: dt_prev,
                t_ref_src: Some(t),
            }) if p.reference == pair.source && dt_prev > 0.0 && dt_s.is_finite() => {
                (scale_twist(&t, dt_s / dt_prev), mode)
            }
            _ => identity,
        },
        InitMode::Odometry => ds
            .odometry
            .as_ref()
            .and_then(|o| Some(odometry_motion(o.get(pair.source)?, o.get(pair.reference)?)))
            .map_or(identity, |t| (t, mode)),
        InitMode::Reference => data::motion(ds, pair.source, pair.reference, dt_s)
            .and_then(|m| m.t_ref_src)
            .map_or(identity, |t| (t, mode)),
    }
}

/// `t_ref_src` from the odometry poses of the two scans (`t_odom_k`, `t_odom_k1`): the
/// motion from scan k to scan k+1 seen from k+1, with the scanner at the odometry's point (an
/// offset between them changes the start by a rotation of the lever arm, which the
/// registration removes).
pub(crate) fn odometry_motion(source: &Pose2, reference: &Pose2) -> Isometry2<f64> {
    reference.isometry().inverse() * source.isometry()
}

/// `t` as a constant twist applied over `ratio` times its time: `exp(ratio · log t)` on SE(2),
/// so an arc stays on its circle.
pub fn scale_twist(t: &Isometry2<f64>, ratio: f64) -> Isometry2<f64> {
    let theta = t.rotation.angle();
    let v = v_matrix(theta)
        .try_inverse()
        .map_or(t.translation.vector, |vi| vi * t.translation.vector);
    let theta_s = theta * ratio;
    Isometry2::new(v_matrix(theta_s) * (v * ratio), theta_s)
}

/// The matrix `V(θ)` of SE(2)'s exponential: translation = V(θ) · v for the twist (v, θ).
fn v_matrix(theta: f64) -> Matrix2<f64> {
    let (a, b) = if theta.abs() < 1e-9 {
        (1.0 - theta * theta / 6.0, theta / 2.0)
    } else {
        (theta.sin() / theta, (1.0 - theta.cos()) / theta)
    };
    Matrix2::new(a, -b, b, a)
}

#[cfg(test)]
mod tests {
    use nalgebra::Vector2;

    use super::*;

    #[test]
    fn chains_parse_and_refuse_what_they_cannot_mean() {
        let c: InitChain = "constant-velocity, Identity".parse().unwrap();
        assert_eq!(c.modes(), &[InitMode::ConstantVelocity, InitMode::Identity]);
        assert_eq!(c.to_string(), "constant-velocity,identity");
        assert!(c.sequential());
        assert_eq!(
            "identity,,reference".parse::<InitChain>(),
            Err(InitError::Empty("identity,,reference".into()))
        );
        assert_eq!(
            "identity,identity".parse::<InitChain>(),
            Err(InitError::Repeated("identity"))
        );
        let e = "odometer".parse::<InitChain>().unwrap_err().to_string();
        assert!(
            e.contains("identity, constant-velocity, global, odometry, reference"),
            "{e}"
        );
    }

    #[test]
    fn a_constant_twist_scales_along_its_arc() {
        let t = Isometry2::new(Vector2::new(1.0, 0.2), 0.3);
        let same = scale_twist(&t, 1.0);
        assert!((same.translation.vector - t.translation.vector).norm() < 1e-12);
        assert!((same.rotation.angle() - 0.3).abs() < 1e-12);
        let twice = scale_twist(&t, 2.0);
        let composed = t * t;
        assert!((twice.translation.vector - composed.translation.vector).norm() < 1e-12);
        assert!((twice.rotation.angle() - composed.rotation.angle()).abs() < 1e-12);
        let straight = scale_twist(&Isometry2::new(Vector2::new(1.0, 0.0), 0.0), 0.5);
        assert!((straight.translation.vector - Vector2::new(0.5, 0.0)).norm() < 1e-12);
    }
}
