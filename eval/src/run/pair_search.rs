//! One pair's global search (correlative scan matching, `icp_core::global`), shared by every
//! registration of the pair: the reference's likelihood grid, the source made ready for
//! searches, the best pose when a start needs it (`--init global`), and the check of each
//! result against it ([`GlobalCheck`]), the results of a pair's variants together.
//!
//! The same grid scores the poses around each result (`Searched::ambiguity`): the ambiguity
//! term of the extended covariance and the `ambiguous` flag. The lattice's sums are kept
//! across the pair's results (`LatticeScores`): its variants' results usually sit in one basin,
//! and a pose is summed once. Each result's answer is the one a lattice of its own gives
//! (whatever was assessed before it, in any order), so it does not depend on which variants a
//! shard holds, nor on the threads.
//!
//! A check asks only the question the suspect rule asks: does a pose score
//! [`clearly_better`] than the result (by [`SUSPECT_SCORE_GAIN`](crate::run::status::SUSPECT_SCORE_GAIN),
//! or by a share of the result's score where that is less)? The branch and bound searches above that bar alone
//! ([`GlobalMatcher::best_above`]): when nothing clears it (a right result) it proves the
//! answer no early; when something does, it finds the search's best pose, the one the rule has
//! always been applied to. The decisions are those of a check against the full search.

use std::sync::{Mutex, PoisonError};
use std::time::Instant;

use icp_core::global::ambiguity::{Ambiguity, AmbiguityParams, AmbiguityProblem, LatticeScores};
use icp_core::global::{
    score_at, Above, GlobalGuess, GlobalMatcher, GlobalParams, GlobalWorkspace, GridPool,
    SourceSearch,
};
use icp_core::{IcpError, Prepared, Registration, Scan, SurfaceParams, Surfaces};
use nalgebra::Isometry2;

use crate::run::status::{clearly_better, GlobalCheck};

/// The conditioning ratio below which a registration's ambiguity is assessed: ten times
/// [`icp_core::quality::DEGENERATE_RATIO`]. The lattice of the ambiguity term is as coarse as
/// the likelihood grid (0.1 m cells, σ 0.1 m): around a well-conditioned optimum its
/// near-optimal poses reach a cell or two by the grid's own blur, not because the scene allows
/// them, and a term of a cell's size would swamp a covariance of millimetres; a better place
/// elsewhere is the global check's question. Along a weakly constrained direction the blur and
/// a slide look alike to the grid, and the lattice is scored. Chosen on `synthetic:corridor`
/// seeds 7, 11, 13 with the paper and rough harbours' default seeds beside them: of the
/// registrations whose near-optimal poses reach beyond
/// [`AmbiguityParams::peak_radius_m`], those more than 0.1 m off on the corridor (seed 13,
/// 869 over the four variants) all have a ratio below 0.067; those within 5 cm on the paper
/// harbour (701) all above 0.156, on the rough harbour (681) 97 % above 0.1. It also keeps the
/// lattice's cost off the well-conditioned registrations (`reports/performance.md`).
pub const WEAK_CONDITIONING: f64 = 0.1;

/// A pair's global search, shared by the threads that register the pair (a check's answer
/// does not depend on the checks before it).
pub(crate) struct Searched<'w> {
    matcher: GlobalMatcher,
    source: Mutex<SourceSearch<'w>>,
    guess: Option<GlobalGuess>,
    /// The lattice sums of the source scan around the results assessed so far.
    lattice: Mutex<LatticeScores>,
    /// Wall time of the checks so far, microseconds.
    check_us: Mutex<f64>,
}

impl<'w> Searched<'w> {
    /// The grid of `reference` (in storage from `pool`) and `source` prepared around the
    /// identity in `workspace`, with the best pose when `best` (a start needs it).
    pub fn new(
        reference: Prepared<'_>,
        source: Prepared<'_>,
        params: &GlobalParams,
        best: bool,
        workspace: &'w mut GlobalWorkspace,
        pool: &mut GridPool,
    ) -> Result<Self, IcpError> {
        let matcher = GlobalMatcher::new_in(reference, params, pool)?;
        let mut prepared = matcher.prepare(workspace, source, Isometry2::identity())?;
        let guess = best.then(|| matcher.best(&mut prepared));
        Ok(Self {
            matcher,
            source: Mutex::new(prepared),
            guess,
            lattice: Mutex::new(LatticeScores::default()),
            check_us: Mutex::new(0.0),
        })
    }

    /// Gives the grid's storage back to `pool`, for the next pair's.
    pub fn recycle(self, pool: &mut GridPool) {
        self.matcher.recycle(pool);
    }

    /// The best pose, when it was asked for.
    pub fn guess(&self) -> Option<&GlobalGuess> {
        self.guess.as_ref()
    }

    /// The poses around `reg`'s result (of `source`) that the reference's likelihood grid
    /// scores almost as well, with the default [`AmbiguityParams`]
    /// (`icp_core::global::ambiguity`), where `reg` is weakly conditioned (ratio below
    /// [`WEAK_CONDITIONING`], or not known) and [`needs_lattice`] after its `check`; `None`
    /// elsewhere. Its time is the checks'. On the sums the pair's results before it left (the
    /// module doc): the same answer.
    pub fn ambiguity(
        &self,
        reg: &Registration,
        check: Option<&GlobalCheck>,
        source: &Scan,
    ) -> Option<Result<Ambiguity, AmbiguityProblem>> {
        if reg
            .conditioning
            .is_some_and(|c| c.ratio >= WEAK_CONDITIONING)
            || !needs_lattice(reg, check)
        {
            return None;
        }
        // Timed once the scores are this thread's, as a check is.
        let mut lattice = self.lattice.lock().unwrap_or_else(PoisonError::into_inner);
        let clock = Instant::now();
        // Whether the scene pins it is asked of a degenerate registration alone: it lifts
        // that flag (`PairStatus::of`) and nothing else.
        let default = AmbiguityParams::default();
        let params = AmbiguityParams {
            pinned_ratio: default
                .pinned_ratio
                .filter(|_| reg.conditioning.is_some_and(|c| c.degenerate())),
            ..default
        };
        let answer = lattice.ambiguity(self.matcher.grid(), source, &reg.t_ref_src, &params);
        drop(lattice);
        *self.check_us.lock().unwrap_or_else(PoisonError::into_inner) +=
            clock.elapsed().as_secs_f64() * 1e6;
        Some(answer)
    }

    /// Wall time of the checks made so far, microseconds.
    pub fn check_us(&self) -> f64 {
        *self.check_us.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// What the search says about each of `results` of the source scan `source`, in their
    /// order. They are asked lowest bar (result score) first: the first search runs above
    /// the lowest bar, and what it proves answers the others (the best pose once found, or
    /// that nothing clears a lower bar), where asked one by one in another order each lower
    /// bar would need a search of its own. The answers are the same in any order.
    pub fn check_all(&self, results: &[&Registration], source: &Scan) -> Vec<GlobalCheck> {
        // Timed once the search is this thread's: waiting for another's check is not this one.
        let mut prepared = self.source.lock().unwrap_or_else(PoisonError::into_inner);
        let clock = Instant::now();
        let scores: Vec<f64> = results
            .iter()
            .map(|r| score_at(self.matcher.grid(), source, &r.t_ref_src))
            .collect();
        let mut by_bar: Vec<usize> = (0..results.len()).collect();
        by_bar.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]));
        let mut answers: Vec<(usize, Above)> = by_bar
            .into_iter()
            .map(|k| {
                let clears = |score| clearly_better(score, scores[k]);
                (k, self.matcher.best_above(&mut prepared, clears))
            })
            .collect();
        drop(prepared);
        answers.sort_by_key(|&(k, _)| k);
        *self.check_us.lock().unwrap_or_else(PoisonError::into_inner) +=
            clock.elapsed().as_secs_f64() * 1e6;
        results
            .iter()
            .zip(scores)
            .zip(answers)
            .map(|((result, result_score), (_, above))| {
                let (best_t_ref_src, best_score) = match above {
                    Above::Best { t_ref_src, score } => (Some(t_ref_src), score),
                    Above::AtMost { score } => (None, score),
                };
                GlobalCheck {
                    best_t_ref_src,
                    best_score,
                    result_t_ref_src: result.t_ref_src,
                    result_score,
                }
            })
            .collect()
    }
}

/// Whether the lattice around `reg` can say anything its `check` has not: not where the check
/// flags it `suspect` (a pose clearly better than the result lies beyond 0.3 m or 3°), unless
/// the registration is degenerate. A suspect registration is flagged whatever the lattice says
/// (`PairStatus::of`: `ambiguous` comes after `suspect`), and its extended covariance spans the
/// better pose already (`run::extended::better_pose_term`); a degenerate one is flagged
/// `degenerate` unless the lattice pins it (then `suspect`), so its lattice is scored, and the
/// status does not depend on this gate. On aces' default run (the paper's variants from the
/// identity) 822 of the 1 261 results the lattice was scored around were suspect
/// (`reports/performance.md`).
pub(crate) fn needs_lattice(reg: &Registration, check: Option<&GlobalCheck>) -> bool {
    !check.is_some_and(GlobalCheck::suspect) || reg.conditioning.is_some_and(|c| c.degenerate())
}

/// What a pair's global search says of one result: its check, and its ambiguity (`None`
/// where the plan does not ask, or the search could not be made).
pub type Answers = (
    Option<GlobalCheck>,
    Option<Result<Ambiguity, AmbiguityProblem>>,
);

/// Whether a registration moved from `checked` (the pose its pair's search assessed) to `now`
/// beyond the peak the ambiguity lattice judges as one place ([`AmbiguityParams::peak_radius_m`]
/// in translation, the lattice's rotations either side, [`AmbiguityParams::rotation_steps`] ×
/// [`AmbiguityParams::rotation_step_deg`], in rotation): then the check's score and the
/// lattice around the old pose no longer describe it. Within the peak the answers are the
/// old pose's neighbours' (the lattice is centred on the lattice pose nearest the result).
pub(crate) fn left_the_peak(checked: &Isometry2<f64>, now: &Isometry2<f64>) -> bool {
    let lattice = AmbiguityParams::default();
    let (apart_m, apart_deg) = crate::run::status::apart(checked, now);
    apart_m > lattice.peak_radius_m
        || apart_deg > lattice.rotation_steps as f64 * lattice.rotation_step_deg
}

/// The answers that describe `second`, a registration of `scans` (source, reference) made
/// again from the result `first` (the moving-returns stage's, `run::moving`, and deskew's,
/// `run::deskew`), whose answers were `kept`: those while `second` stays within the first's
/// peak (0.15 m or 1°: `left_the_peak`), else its own ([`assess_alone`], as `params` and
/// `asks`, check and ambiguity, say).
pub fn answers_for_second(
    (first, kept): (&Isometry2<f64>, Answers),
    second: &Registration,
    scans: (&Scan, &Scan),
    (params, asks): (&GlobalParams, (bool, bool)),
) -> Answers {
    if left_the_peak(first, &second.t_ref_src) {
        assess_alone(scans, params, asks, second)
    } else {
        kept
    }
}

/// The global check and ambiguity of `reg`, a registration of `source` onto `reference` made
/// after the pair's own search was given back: from a search of their own, with the surface
/// estimates of the default parameters, as the pair's search was made, so the answers are
/// those the pair's search gives a result at that pose. `check` and `ambiguity` say which the
/// plan asks for; a search that cannot be made answers neither, as a pair's does.
pub fn assess_alone(
    (source, reference): (&Scan, &Scan),
    params: &GlobalParams,
    (check, ambiguity): (bool, bool),
    reg: &Registration,
) -> Answers {
    let default = SurfaceParams::default();
    let (source_surfaces, reference_surfaces) = (
        Surfaces::estimate(source, &default),
        Surfaces::estimate(reference, &default),
    );
    let mut workspace = GlobalWorkspace::default();
    let Ok(searched) = Searched::new(
        Prepared::new(reference, &reference_surfaces),
        Prepared::new(source, &source_surfaces),
        params,
        false,
        &mut workspace,
        &mut GridPool::default(),
    ) else {
        return (None, None);
    };
    let checked = check
        .then(|| searched.check_all(&[reg], source).pop())
        .flatten();
    let assessed = ambiguity
        .then(|| searched.ambiguity(reg, checked.as_ref(), source))
        .flatten();
    (checked, assessed)
}

#[cfg(test)]
mod tests {
    use datasets::synthetic::{generate, Scenario};
    use icp_core::variants::builtin;
    use icp_core::{Registrar, SurfaceParams, Surfaces, Workspace};
    use nalgebra::Vector2;

    use super::*;

    /// Checked together (lowest bar first, then answered in their own order), results get
    /// the answers each gets alone on a search of its own, in either order of asking.
    #[test]
    fn checks_together_answer_as_one_by_one() {
        let ds = generate(&Scenario {
            n_scans: 2,
            ..Scenario::paper()
        })
        .unwrap();
        let pair = ds.consecutive_pairs().0[0];
        let surfaces: Vec<Surfaces> = ds
            .scans
            .iter()
            .map(|s| Surfaces::estimate(s, &SurfaceParams::default()))
            .collect();
        let prepared = |k: usize| Prepared::new(&ds.scans[k], &surfaces[k]);
        let registered = builtin("HD_GICP")
            .unwrap()
            .build()
            .unwrap()
            .register_prepared(
                &mut Workspace::default(),
                prepared(pair.source),
                prepared(pair.reference),
                Isometry2::identity(),
            )
            .unwrap();
        // The result, results far off (a pose clears their bars) and one a little off.
        let results: Vec<Registration> = [(0.0, 0.0, 0.0), (1.5, 0.0, 0.0), (0.0, 0.0, 20.0)]
            .into_iter()
            .chain([(0.05, -0.03, 0.4)])
            .map(|(x, y, deg): (f64, f64, f64)| Registration {
                t_ref_src: registered.t_ref_src
                    * Isometry2::new(Vector2::new(x, y), deg.to_radians()),
                ..registered
            })
            .collect();
        let params = GlobalParams::default();
        let source = &ds.scans[pair.source];
        fn search<'w>(
            (reference, source): (Prepared<'_>, Prepared<'_>),
            params: &GlobalParams,
            workspace: &'w mut GlobalWorkspace,
        ) -> Searched<'w> {
            let mut pool = GridPool::default();
            Searched::new(reference, source, params, false, workspace, &mut pool).unwrap()
        }
        let scans = || (prepared(pair.reference), prepared(pair.source));
        let one_by_one: Vec<GlobalCheck> = results
            .iter()
            .map(|r| {
                let mut workspace = GlobalWorkspace::default();
                search(scans(), &params, &mut workspace).check_all(&[r], source)[0]
            })
            .collect();
        assert!(one_by_one.iter().any(|c| c.best_t_ref_src.is_some()));
        assert!(one_by_one.iter().any(|c| c.best_t_ref_src.is_none()));
        let asked: Vec<&Registration> = results.iter().collect();
        let mut workspace = GlobalWorkspace::default();
        let together = search(scans(), &params, &mut workspace).check_all(&asked, source);
        assert_eq!(together, one_by_one);
        let reversed: Vec<&Registration> = asked.iter().rev().copied().collect();
        let mut expected = one_by_one.clone();
        expected.reverse();
        let together = search(scans(), &params, &mut workspace).check_all(&reversed, source);
        assert_eq!(together, expected);
    }

    /// A registration assessed alone (after its pair's search was given back) gets the check
    /// and the ambiguity the pair's search gives it, and only what the plan asks for.
    /// `source` registered onto `reference` by PL_ICP from `start`, with the surfaces of the
    /// two scans it used.
    fn pl_icp(
        source: &Scan,
        reference: &Scan,
        start: Isometry2<f64>,
    ) -> (Registration, Surfaces, Surfaces) {
        let surfaces = |scan: &Scan| Surfaces::estimate(scan, &SurfaceParams::default());
        let (source_surfaces, reference_surfaces) = (surfaces(source), surfaces(reference));
        let registered = builtin("PL_ICP")
            .unwrap()
            .build()
            .unwrap()
            .register_prepared(
                &mut Workspace::default(),
                Prepared::new(source, &source_surfaces),
                Prepared::new(reference, &reference_surfaces),
                start,
            )
            .unwrap();
        (registered, source_surfaces, reference_surfaces)
    }

    #[test]
    fn assessed_alone_as_by_the_pairs_search() {
        let ds = generate(&Scenario {
            n_scans: 2,
            ..Scenario::paper()
        })
        .unwrap();
        let pair = ds.consecutive_pairs().0[0];
        let (source, reference) = (&ds.scans[pair.source], &ds.scans[pair.reference]);
        let (registered, source_surfaces, reference_surfaces) =
            pl_icp(source, reference, Isometry2::identity());
        let params = GlobalParams::default();
        let mut suspect = [false; 2];
        for (x, deg) in [(0.0, 0.0), (0.4, 0.0), (0.0, 2.0), (2.0, 30.0)] {
            // Conditioning not known: the ambiguity is assessed, as for a weak one.
            let reg = Registration {
                t_ref_src: registered.t_ref_src
                    * Isometry2::new(Vector2::new(x, 0.0), f64::to_radians(deg)),
                conditioning: None,
                ..registered
            };
            let mut workspace = GlobalWorkspace::default();
            let searched = Searched::new(
                Prepared::new(reference, &reference_surfaces),
                Prepared::new(source, &source_surfaces),
                &params,
                false,
                &mut workspace,
                &mut GridPool::default(),
            )
            .unwrap();
            let check = searched.check_all(&[&reg], source)[0];
            let by_pair = (Some(check), searched.ambiguity(&reg, Some(&check), source));
            // Scored unless the check flags the result (and it is not degenerate).
            assert_eq!(by_pair.1.is_some(), !check.suspect(), "{x} m, {deg}°");
            suspect[usize::from(check.suspect())] = true;
            let unchecked = searched.ambiguity(&reg, None, source);
            assert!(unchecked.is_some());
            let scans = (source, reference);
            assert_eq!(assess_alone(scans, &params, (true, true), &reg), by_pair);
            assert_eq!(
                assess_alone(scans, &params, (false, true), &reg),
                (None, unchecked)
            );
            assert_eq!(
                assess_alone(scans, &params, (true, false), &reg),
                (by_pair.0, None)
            );
        }
        assert_eq!(suspect, [true, true], "results flagged and not");
    }

    /// The lattice is scored around every result but one the check flags `suspect`, and
    /// around that one too where it is degenerate (the lattice may pin it).
    #[test]
    fn the_lattice_is_scored_unless_the_check_flagged_a_result_it_cannot_pin() {
        use icp_core::quality::{Conditioning, DEGENERATE_RATIO};
        let result = Isometry2::identity();
        let check = |best_score: f64, apart_m: f64| GlobalCheck {
            best_t_ref_src: Some(Isometry2::new(Vector2::new(apart_m, 0.0), 0.0)),
            best_score,
            result_t_ref_src: result,
            result_score: 0.5,
        };
        let (far_better, near_better, far_alike) =
            (check(0.7, 1.0), check(0.7, 0.2), check(0.52, 1.0));
        assert!(far_better.suspect() && !near_better.suspect() && !far_alike.suspect());
        let ds = generate(&Scenario {
            n_scans: 2,
            ..Scenario::paper()
        })
        .unwrap();
        let pair = ds.consecutive_pairs().0[0];
        let (registered, _, _) = pl_icp(&ds.scans[pair.source], &ds.scans[pair.reference], result);
        let with_ratio = |ratio: Option<f64>| Registration {
            conditioning: ratio.map(|ratio| Conditioning {
                eigenvalues: [ratio, 0.5, 1.0],
                ratio,
            }),
            ..registered
        };
        for ratio in [None, Some(0.05)] {
            let reg = with_ratio(ratio);
            assert!(needs_lattice(&reg, None));
            assert!(needs_lattice(&reg, Some(&near_better)));
            assert!(needs_lattice(&reg, Some(&far_alike)));
            assert!(!needs_lattice(&reg, Some(&far_better)), "{ratio:?}");
        }
        let degenerate = with_ratio(Some(DEGENERATE_RATIO / 2.0));
        assert!(needs_lattice(&degenerate, Some(&far_better)));
    }

    /// A registration whose pairs leave a corridor's axis weak (conditioning below
    /// `DEGENERATE_RATIO`) stands where the lattice pins it, and is flagged degenerate where it
    /// slid to no motion, where a fixed fan's spots on far walls coincide whatever the scene.
    #[test]
    fn a_weak_registration_the_lattice_pins_stands() {
        use crate::run::status::{PairStatus, StatusKind};
        use datasets::synthetic::{generate_corridor, Corridor};
        use nalgebra::{Point2, Vector2 as V};
        // PL_ICP from the truth, the lattice around its result, the verdict.
        let verdict = |reference: &Scan, source: &Scan, start: Isometry2<f64>| {
            let (registered, source_surfaces, reference_surfaces) =
                pl_icp(source, reference, start);
            assert!(registered.conditioning.unwrap().degenerate());
            let mut workspace = GlobalWorkspace::default();
            let searched = Searched::new(
                Prepared::new(reference, &reference_surfaces),
                Prepared::new(source, &source_surfaces),
                &GlobalParams::default(),
                false,
                &mut workspace,
                &mut GridPool::default(),
            )
            .unwrap();
            let ambiguity = searched.ambiguity(&registered, None, source).unwrap();
            let status = PairStatus::of(&Ok(registered), None, Some(&ambiguity));
            (
                registered.t_ref_src,
                ambiguity.unwrap().pinned,
                status.kind(),
            )
        };
        // The synthetic corridor (seed 13): pair 80, 0.40 m along a corridor, placed by the
        // scene within 2 cm.
        let ds = generate_corridor(&Corridor {
            n_scans: 82,
            seed: 13,
            ..Corridor::default()
        })
        .unwrap();
        let pair = ds.consecutive_pairs().0[80];
        let truth = crate::data::motion(&ds, pair.source, pair.reference, 1.0)
            .and_then(|m| m.t_ref_src)
            .unwrap();
        let (result, pinned, kind) =
            verdict(&ds.scans[pair.reference], &ds.scans[pair.source], truth);
        assert!(truth.translation.vector.norm() > 0.3);
        assert!((result.translation.vector - truth.translation.vector).norm() < 0.05);
        assert!(pinned.is_some());
        assert_eq!(kind, StatusKind::Ok);
        // A corridor 2.4 m wide ending 30 m ahead, seen by a 1° fan over 180° from the origin
        // and from 0.3 m along: the registration slides to no motion, where the two scans'
        // spots on the walls far ahead coincide.
        let scan = |pose: Isometry2<f64>| {
            let walls = [
                ([-40.0, -1.2], [30.0, -1.2]),
                ([-40.0, 1.2], [30.0, 1.2]),
                ([30.0, -1.2], [30.0, 1.2]),
            ];
            let o = Point2::from(pose.translation.vector);
            let points: Vec<[f64; 2]> = (-90..90)
                .filter_map(|k| {
                    let bearing = (f64::from(k) + 0.5).to_radians();
                    let u = pose.rotation * V::new(bearing.cos(), bearing.sin());
                    let range = walls
                        .iter()
                        .filter_map(|&(a, b)| {
                            let (a, e) = (Point2::from(a), V::from(b) - V::from(a));
                            let denom = u.x * e.y - u.y * e.x;
                            let w = a - o;
                            let t = (w.x * e.y - w.y * e.x) / denom;
                            let s = (w.x * u.y - w.y * u.x) / denom;
                            (denom.abs() > 1e-12 && t > 0.0 && (0.0..=1.0).contains(&s))
                                .then_some(t)
                        })
                        .fold(f64::INFINITY, f64::min);
                    (range <= 50.0).then(|| [range * bearing.cos(), range * bearing.sin()])
                })
                .collect();
            Scan::from_cartesian(&points).unwrap()
        };
        let truth = Isometry2::new(V::new(0.3, 0.0), 0.0);
        let (result, pinned, kind) = verdict(&scan(Isometry2::identity()), &scan(truth), truth);
        assert!(result.translation.vector.norm() < 0.01, "{result}");
        assert_eq!((pinned, kind), (None, StatusKind::Degenerate));
    }

    /// The peak: 0.15 m and 1° (the lattice's rotations either side) around the pose checked.
    #[test]
    fn a_result_leaves_the_peak_beyond_its_radius_or_the_lattices_rotations() {
        let at = |x: f64, deg: f64| Isometry2::new(Vector2::new(x, 0.0), deg.to_radians());
        let checked = at(1.0, 10.0);
        assert!(!left_the_peak(&checked, &checked));
        assert!(!left_the_peak(&checked, &at(1.14, 10.9)));
        assert!(left_the_peak(&checked, &at(1.16, 10.0)));
        assert!(left_the_peak(&checked, &at(1.0, 11.1)));
    }
}
