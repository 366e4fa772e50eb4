//! The paper's Table 1 (Naus & Marchel 2019), for side-by-side comparison. These are the
//! published figures, not ours: 865 scan sets every 0.2 s, errors are ICP minus GNSS RTK.

/// One published row: SOG (m/s) and ΔCOG (°) error mean, std and signed max.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PublishedRow {
    /// Variant name.
    pub variant: &'static str,
    /// SOG error mean, m/s.
    pub sog_mean: f64,
    /// ΔCOG error mean, °.
    pub dcog_mean: f64,
    /// SOG error std, m/s.
    pub sog_std: f64,
    /// ΔCOG error std, °.
    pub dcog_std: f64,
    /// SOG error signed max, m/s.
    pub sog_max: f64,
    /// ΔCOG error signed max, °.
    pub dcog_max: f64,
}

/// Table 1 of the paper.
pub const TABLE1: [PublishedRow; 4] = [
    PublishedRow {
        variant: "K_ICP",
        sog_mean: -0.031,
        dcog_mean: 0.08,
        sog_std: 0.113,
        dcog_std: 0.57,
        sog_max: -0.524,
        dcog_max: -3.5,
    },
    PublishedRow {
        variant: "H_ICP",
        sog_mean: -0.013,
        dcog_mean: 0.05,
        sog_std: 0.031,
        dcog_std: 0.14,
        sog_max: -0.319,
        dcog_max: 0.72,
    },
    PublishedRow {
        variant: "HM_ICP",
        sog_mean: -0.012,
        dcog_mean: 0.03,
        sog_std: 0.031,
        dcog_std: 0.13,
        sog_max: -0.185,
        dcog_max: -0.48,
    },
    PublishedRow {
        variant: "HD_ICP",
        sog_mean: -0.007,
        dcog_mean: 0.03,
        sog_std: 0.026,
        dcog_std: 0.11,
        sog_max: -0.18,
        dcog_max: 0.42,
    },
];

/// The published row of a variant.
pub fn row(variant: &str) -> Option<&'static PublishedRow> {
    TABLE1.iter().find(|r| r.variant == variant)
}
