//! The corridor scenario (`synthetic:corridor`): seeded, its steps within the stated limits,
//! a SICK LMS-like fan within its range, people's returns (and only theirs) labelled moving,
//! the CSV round trip, and a scene that really is ambiguous along its bare stretch.

use std::path::Path;

use datasets::csvdir;
use datasets::synthetic::corridor::building::walls;
use datasets::synthetic::{generate_corridor, Corridor};
use datasets::{Dataset, ReferenceKind};
use icp_core::variants::builtin;
use icp_core::Registrar;
use nalgebra::{Isometry2, Point2};

fn corridor(n_scans: usize) -> Corridor {
    Corridor {
        n_scans,
        ..Corridor::default()
    }
}

/// Exact returns, no dropouts and no spurious ones: every return lies on a surface.
fn exact(n_scans: usize) -> Corridor {
    let mut c = corridor(n_scans);
    c.scanner.noise = false;
    c.scanner.dropout_prob = 0.0;
    c.scanner.gross_error_fraction = 0.0;
    c
}

fn poses(ds: &Dataset) -> Vec<Isometry2<f64>> {
    let r = ds.reference.as_ref().unwrap();
    r.iter().map(|p| p.scan_pose().unwrap()).collect()
}

#[test]
fn generation_is_deterministic_and_seeded() {
    let a = generate_corridor(&corridor(60)).unwrap();
    let b = generate_corridor(&corridor(60)).unwrap();
    assert_eq!(a.scans, b.scans);
    assert_eq!(a.reference, b.reference);
    let other = generate_corridor(&Corridor {
        seed: 7,
        ..corridor(60)
    })
    .unwrap();
    assert_ne!(other.scans, a.scans);
    assert_ne!(other.reference, a.reference, "the seed draws the steps");
    assert_eq!(a.reference_kind, Some(ReferenceKind::GroundTruth));
    assert!(a
        .scans
        .iter()
        .enumerate()
        .all(|(k, s)| s.timestamp_s() == Some(k as f64)));
}

/// Over two laps: no step moves more than 0.5 m or turns more than 20°; straight stretches
/// move 0.3–0.5 m; the run turns on the spot at corners and the laboratory door (18°, 20°).
#[test]
fn steps_stay_within_the_stated_limits_and_vary() {
    let ds = generate_corridor(&exact(1200)).unwrap();
    let p = poses(&ds);
    let (mut max_t, mut max_r, mut min_moving) = (0.0f64, 0.0f64, f64::INFINITY);
    let mut turns = Vec::new();
    for w in p.windows(2) {
        let step = w[0].inverse() * w[1];
        let (t, r) = (step.translation.vector.norm(), step.rotation.angle().abs());
        (max_t, max_r) = (max_t.max(t), max_r.max(r.to_degrees()));
        if t > 1e-9 {
            min_moving = min_moving.min(t);
            assert!(r < 1e-9, "a step both moves and turns: {t} m, {r} rad");
        } else {
            turns.push(r.to_degrees());
        }
    }
    assert!(max_t <= 0.5 + 1e-12 && max_t > 0.45, "{max_t}");
    assert!(min_moving >= 0.29, "{min_moving}");
    assert!(max_r <= 20.0 + 1e-9, "{max_r}");
    assert!(turns.iter().any(|&r| (r - 18.0).abs() < 1e-6));
    assert!(turns.iter().any(|&r| (r - 20.0).abs() < 1e-6));
    // Two laps: back past the start.
    assert!(p
        .iter()
        .skip(100)
        .any(|q| q.translation.vector.norm() < 0.5));
}

/// 180 beams 1° apart over the front half; returns within the 50 m range (noise-free exactly,
/// noisy within 5 σ_r), no return beyond it.
#[test]
fn the_scanner_is_a_180_beam_fan_within_its_range() {
    let c = exact(200);
    let ds = generate_corridor(&c).unwrap();
    let mut beyond_range = 0;
    for s in &ds.scans {
        assert_eq!(s.len() + s.no_returns(), 180);
        beyond_range += s.no_returns();
        for r in s.returns() {
            let k = (r.bearing_rad.to_degrees() + 89.5).round();
            assert!((0.0..180.0).contains(&k), "{}", r.bearing_rad);
            assert!((r.bearing_rad.to_degrees() - (k - 89.5)).abs() < 1e-9);
            assert!(r.range_m <= 50.0, "{}", r.range_m);
        }
    }
    assert!(beyond_range > 0, "some beams run down a corridor past 50 m");
    let noisy = generate_corridor(&corridor(200)).unwrap();
    assert_eq!(noisy.sensor, datasets::carmen::SICK_LMS2XX);
    let far = noisy
        .scans
        .iter()
        .flat_map(|s| s.returns())
        .map(|r| r.range_m)
        .fold(0.0, f64::max);
    assert!(far <= 50.05 && far > 30.0, "{far}");
}

/// Noise-free: a return is labelled moving exactly when it lies off every wall (on a person);
/// people are seen.
#[test]
fn people_and_only_people_are_labelled_moving() {
    let ds = generate_corridor(&exact(440)).unwrap();
    let walls = walls();
    let (mut moving, mut still) = (0, 0);
    for (s, pose) in ds.scans.iter().zip(poses(&ds)) {
        for (r, &m) in s.returns().iter().zip(s.moving().unwrap()) {
            let p: Point2<f64> = pose * r.point;
            let on_wall = walls.iter().any(|w| w.distance_to(&p) < 1e-9);
            assert_eq!(m, !on_wall, "{p} at {:?}", s.timestamp_s());
            if m {
                moving += 1;
            } else {
                still += 1;
            }
        }
    }
    assert!(
        moving > 200 && moving * 50 < still,
        "{moving} moving of {still}"
    );
}

#[test]
fn written_and_read_back_bit_for_bit() {
    let ds = generate_corridor(&corridor(30)).unwrap();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("csv_roundtrip_corridor");
    let _ = std::fs::remove_dir_all(&dir);
    csvdir::write(&dir, &ds).unwrap();
    let back = csvdir::load(&dir).unwrap();
    assert_eq!(back.scans, ds.scans);
    assert_eq!(back.reference, ds.reference);
    assert_eq!(
        (back.dt_s, back.sweep_s, back.sensor, back.reference_kind),
        (ds.dt_s, ds.sweep_s, ds.sensor, ds.reference_kind)
    );
    assert_eq!(back.provenance.description, ds.provenance.description);
    let bits = |ds: &Dataset| -> Vec<(u64, Option<[u64; 2]>, bool)> {
        ds.scans
            .iter()
            .flat_map(|s| {
                s.returns()
                    .iter()
                    .zip(s.true_normals().unwrap())
                    .zip(s.moving().unwrap())
                    .map(|((r, n), &m)| {
                        (
                            r.range_m.to_bits(),
                            n.map(|n| [n.x.to_bits(), n.y.to_bits()]),
                            m,
                        )
                    })
            })
            .collect()
    };
    assert_eq!(bits(&back), bits(&ds));
    assert!(
        bits(&ds).iter().any(|b| b.2),
        "the round trip covers moving returns"
    );
}

/// The scene's ambiguity, a property of the world: PL_ICP from the true motion, on the
/// consecutive pairs in the middle of the north side's bare stretch, ends with a
/// conditioning ratio below the degenerate flag's 0.01 (the walls pin nothing along the
/// corridor; seed 2036: at most 0.0035 over 44 pairs); in the laboratory, walls face every
/// way and the median is above 0.1 (0.19 over 30 pairs). (The south side's offices are
/// neither: seen through their doors from the corridor they pin the motion only at times,
/// 0.001–0.04.)
#[test]
fn the_bare_stretch_is_ill_conditioned_and_the_laboratory_is_not() {
    let ds = generate_corridor(&corridor(440)).unwrap();
    let p = poses(&ds);
    let icp = builtin("PL_ICP").unwrap().build().unwrap();
    let ratio = |k: usize| {
        let truth = p[k].inverse() * p[k + 1];
        icp.register(&ds.scans[k + 1], &ds.scans[k], truth)
            .unwrap()
            .conditioning
            .unwrap()
            .ratio
    };
    let at = |pred: &dyn Fn(f64, f64) -> bool| -> Vec<f64> {
        (0..p.len() - 1)
            .filter(|&k| pred(p[k].translation.x, p[k].translation.y))
            .map(ratio)
            .collect()
    };
    let bare = at(&|x, y| (y - 24.0).abs() < 0.1 && (46.0..64.0).contains(&x));
    let mut lab = at(&|x, _| x > 72.5);
    assert!(
        bare.len() >= 30 && lab.len() >= 20,
        "{} {}",
        bare.len(),
        lab.len()
    );
    lab.sort_by(f64::total_cmp);
    let worst_bare = bare.iter().copied().fold(0.0, f64::max);
    let median_lab = lab[lab.len() / 2];
    eprintln!("bare stretch: max ratio {worst_bare:.4}; laboratory: median {median_lab:.4}");
    assert!(worst_bare < 0.01, "{bare:?}");
    assert!(median_lab > 0.1, "{lab:?}");
}

/// `synthetic:corridor` in the loader registry: `scans` and `seed` as for the harbour,
/// `dt_s` and `boats` refused with the reason.
#[test]
fn the_registry_opens_the_corridor_and_refuses_what_does_not_apply() {
    let ds = datasets::open("synthetic:corridor?scans=5&seed=3").unwrap();
    assert_eq!(ds.scans.len(), 5);
    assert_eq!(ds.provenance.name, "synthetic:corridor");
    assert_eq!(
        ds.reference,
        generate_corridor(&Corridor {
            seed: 3,
            ..corridor(5)
        })
        .unwrap()
        .reference
    );
    let refusal = |text: &str| datasets::open(text).unwrap_err().to_string();
    assert_eq!(
        refusal("synthetic:corridor?dt_s=2"),
        format!(
            "dataset synthetic: option dt_s (--dt) does not apply: {}",
            Corridor::PLANNED_PER_SCAN
        )
    );
    assert_eq!(
        refusal("synthetic:corridor?boats=none"),
        "boats: the \"corridor\" scenario has no moving boats to replace (boats apply to the \
         rough scenario only)"
    );
    assert!(refusal("synthetic:corridor?scans=1").contains("at least 2"));
    assert!(refusal("synthetic:hall").contains("paper, marina-like, rough or corridor"));
}
