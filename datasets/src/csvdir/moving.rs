//! The optional `moving` column of `scans.csv`: whether each return came from a moving object
//! (1) or not (0), empty on a no-return. Truth for scoring, like the true normals.

use serde::Deserialize;

/// The column's name.
pub(super) const COLUMN: &str = "moving";

/// A `moving` cell: the column absent, the cell empty, or a label.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) enum MovingCell {
    #[default]
    Absent,
    Empty,
    Label(bool),
}

impl MovingCell {
    /// The row's label: `None` without the column; on a return 0 or 1, on a no-return (whose
    /// label is dropped with it) also empty. The error names the field.
    pub(super) fn label(self, no_return: bool) -> Result<Option<bool>, String> {
        match self {
            Self::Absent => Ok(None),
            Self::Label(m) => Ok(Some(m)),
            Self::Empty if no_return => Ok(Some(false)),
            Self::Empty => Err(format!("{COLUMN} is empty on a return (expected 0 or 1)")),
        }
    }
}

impl<'de> Deserialize<'de> for MovingCell {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Cell;
        impl serde::de::Visitor<'_> for Cell {
            type Value = MovingCell;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "{COLUMN} as 0, 1 or empty")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<MovingCell, E> {
                match v {
                    "" => Ok(MovingCell::Empty),
                    "0" => Ok(MovingCell::Label(false)),
                    "1" => Ok(MovingCell::Label(true)),
                    _ => Err(E::custom(format!("{COLUMN} must be 0 or 1, not {v:?}"))),
                }
            }
        }
        d.deserialize_str(Cell)
    }
}
