//! Point selection, Algorithm 1 step 1.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::registry::{Family, Kind, NoParams, Params, StageKind, StageSpec};

/// Chooses which points of each scan take part in the registration.
pub trait Selection: Send + Sync {
    /// What this stage is, as configuration data.
    fn spec(&self) -> StageSpec {
        StageSpec::unregistered::<Self>()
    }

    /// Fills `src` and `reference` (cleared first) with the ascending indices of the points
    /// kept from a source scan of `n_src` points and a reference scan of `n_ref` points.
    fn select(&self, n_src: usize, n_ref: usize, src: &mut Vec<usize>, reference: &mut Vec<usize>);
}

/// Every registered selection. Adding one: a file or a struct with its `impl Selection` and
/// its `KIND`, and one line here.
pub static SELECTIONS: Family<dyn Selection> = Family {
    name: "selection",
    summary: "Alg. 1 step 1: which points of each scan take part",
    kinds: &[&ALL, &EQUAL_COUNT],
};

/// The registered kind of [`AllPoints`].
pub const ALL: Kind<NoParams, dyn Selection> =
    Kind::new("all", "every point of both scans", |_, _| {
        Box::new(AllPoints)
    });

/// The registered kind of [`EqualCount`].
pub const EQUAL_COUNT: Kind<EqualCount, dyn Selection> = Kind::new(
    "equal_count",
    "points removed at random (seeded) from the larger scan until both have as many (Naus & Marchel 2019, Alg. 1 step 1)",
    |p, _| Box::new(p),
);

/// Keeps every point of both scans.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AllPoints;

impl Selection for AllPoints {
    fn spec(&self) -> StageSpec {
        StageSpec::kind(ALL.name())
    }

    fn select(&self, n_src: usize, n_ref: usize, src: &mut Vec<usize>, reference: &mut Vec<usize>) {
        src.clear();
        src.extend(0..n_src);
        reference.clear();
        reference.extend(0..n_ref);
    }
}

/// Random equalisation of the point counts (Naus & Marchel 2019, Algorithm 1 step 1): points
/// are removed at random from the larger scan until both scans have the same number.
///
/// The draw is seeded (ChaCha8), so a registration is reproducible; the same seed is used for
/// every pair, which keeps results independent of the order in which pairs are run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(default, deny_unknown_fields)]
pub struct EqualCount {
    /// Seed of the random draw.
    pub seed: u64,
}

impl Params for EqualCount {}

impl Selection for EqualCount {
    fn spec(&self) -> StageSpec {
        StageSpec::of(EQUAL_COUNT.name(), self)
    }

    fn select(&self, n_src: usize, n_ref: usize, src: &mut Vec<usize>, reference: &mut Vec<usize>) {
        let n = n_src.min(n_ref);
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        for (out, total) in [(src, n_src), (reference, n_ref)] {
            out.clear();
            if total == n {
                out.extend(0..n);
            } else {
                out.extend(rand::seq::index::sample(&mut rng, total, n).iter());
                out.sort_unstable();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_count_equalises_deterministically() {
        let sel = EqualCount { seed: 3 };
        let (mut a, mut b) = (Vec::new(), Vec::new());
        sel.select(10, 6, &mut a, &mut b);
        assert_eq!(b, (0..6).collect::<Vec<_>>());
        assert_eq!(a.len(), 6);
        assert!(a.windows(2).all(|w| w[0] < w[1]) && a.iter().all(|&i| i < 10));
        let (mut a2, mut b2) = (Vec::new(), Vec::new());
        sel.select(10, 6, &mut a2, &mut b2);
        assert_eq!((a, b), (a2, b2));
        let (mut c, mut d) = (Vec::new(), Vec::new());
        sel.select(4, 9, &mut c, &mut d);
        assert_eq!((c.len(), d.len()), (4, 4));
    }

    #[test]
    fn all_points_keeps_everything() {
        let (mut a, mut b) = (vec![7], vec![]);
        AllPoints.select(3, 5, &mut a, &mut b);
        assert_eq!((a, b), (vec![0, 1, 2], vec![0, 1, 2, 3, 4]));
    }
}
