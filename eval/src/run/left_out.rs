//! What a detector of moving returns left out of a pair's registration (`run::moving`), as
//! the records, the summaries and the figures take it.

use serde::{Deserialize, Serialize};

use icp_core::moving::Detection;

/// What a pair's registration left out.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LeftOut {
    /// Returns of the source scan left out.
    pub source: usize,
    /// Returns of the reference scan left out.
    pub reference: usize,
    /// The source scan's detection against its truth labels, where it has them.
    pub source_truth: Option<Confusion>,
    /// The source scan's returns left out, by index (what `report.html` draws).
    #[serde(default)]
    pub source_indices: Vec<u32>,
    /// The reference scan's returns left out, by index.
    #[serde(default)]
    pub reference_indices: Vec<u32>,
    /// Whether the pair's result is its registration without these returns: false where that
    /// registration jumped from its start while the kept returns fit the start, so the start
    /// (registered with every return) stands (`run::moving`). What `--sequence deskew` follows
    /// when it registers the pair a second time.
    #[serde(default)]
    pub result_without: bool,
}

/// A scan drawn with the returns its variant's detector left out (`report.html`).
#[derive(Clone, Debug, PartialEq)]
pub struct DrawnScan {
    /// The variant whose detection it is.
    pub variant: String,
    /// The scan's index in the dataset.
    pub scan: usize,
    /// Its returns left out, by index.
    pub left_out: Vec<u32>,
}

/// A detection scored against the labels of a scan.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Confusion {
    /// Returns labelled moving.
    pub moving: usize,
    /// …of them left out.
    pub moving_left_out: usize,
    /// Returns labelled static.
    pub r#static: usize,
    /// …of them left out.
    pub static_left_out: usize,
}

impl Confusion {
    /// `detection` of `scan` scored against its labels; `None` for an unlabelled scan.
    pub fn of(scan: &icp_core::Scan, detection: &Detection) -> Option<Self> {
        let labels = scan.moving()?;
        let mut c = Self::default();
        for (&moving, &out) in labels.iter().zip(&detection.left_out) {
            if moving {
                c.moving += 1;
                c.moving_left_out += usize::from(out);
            } else {
                c.r#static += 1;
                c.static_left_out += usize::from(out);
            }
        }
        Some(c)
    }
}

impl std::ops::Add for Confusion {
    type Output = Self;

    /// The sum of two scores.
    fn add(self, other: Self) -> Self {
        Self {
            moving: self.moving + other.moving,
            moving_left_out: self.moving_left_out + other.moving_left_out,
            r#static: self.r#static + other.r#static,
            static_left_out: self.static_left_out + other.static_left_out,
        }
    }
}
