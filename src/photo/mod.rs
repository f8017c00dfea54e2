//! Photo-consistency (tutorial chapter 2) and plane-sweep stereo.
//!
//! The vocabulary every depth estimate in planemap is scored in:
//!
//! - [`measures`]: SSD, SAD, NCC (colour: per-channel means, one joint variance), Census,
//!   Rank and mutual information between a reference patch and a warped patch;
//! - [`normalize`]: raw scores → costs in `[0, 1]` (exponential, truncated linear, smooth
//!   step) with the tutorial's thresholds as defaults;
//! - [`aggregate`]: box (integral images), bilateral, guided and weighted-median filtering of
//!   cost slices;
//! - [`neighbours`]: which views a view is matched against;
//! - [`families`]: fronto-parallel and axis-aligned plane families;
//! - [`volume`]: the plane cost volume (cost per pixel and plane, what the planemap data term
//!   consumes), computed by the costing core in `cost`;
//! - [`sweep`]: winner-takes-all plane-sweep depth, sub-plane refinement and the sweep over
//!   several families (Collins 1996; Gallup et al. 2007 for sweeps along the dominant axes);
//! - [`sgm`]: optional semi-global aggregation of a family's cost volume before the
//!   winner-takes-all (Hirschmüller 2008);
//! - [`multisweep`]: the multi-family sweep driver — which plane families and neighbours a
//!   view is swept with, densified to a pixel step;
//! - [`texture`]: windowed grey-level deviation and the texture mask read off an image.

pub mod aggregate;
mod cost;
pub mod families;
pub mod measures;
pub mod multisweep;
pub mod neighbours;
pub mod normalize;
pub mod sgm;
pub mod sweep;
pub mod texture;
pub mod volume;

pub use aggregate::{box_filter, Aggregation, Integral};
pub use families::{
    axis_planes, axis_sweep_planes, fronto_parallel_depths, fronto_parallel_planes, PlaneFamily,
    Spacing,
};
pub use measures::{raw_cost, Measure};
pub use multisweep::{family_step_px, sweep_setup, MultiSweepConfig, SweepSetup};
pub use neighbours::select_neighbours;
pub use normalize::Normalization;
pub use sgm::{semi_global, SgmConfig};
pub use sweep::{
    multi_family_sweep, pixel_on_plane, plane_sweep, refine_subplane, winner_takes_all,
    FamilySweepResult, SweepResult, NO_PLANE,
};
pub use texture::{local_std, texture_mask};
pub use volume::{plane_cost_volume, CostVolume};

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Errors of the photo-consistency stage.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PhotoError {
    /// A configuration value is out of range (message names the field and the value).
    #[error("invalid photo-consistency config: {0}")]
    InvalidConfig(String),
    /// An image or slice does not have the expected size (message says which and what).
    #[error("size mismatch: {0}")]
    Size(String),
    /// A view's camera has lens distortion; plane homographies need undistorted images.
    #[error("view {0:?} has a distorted camera: undistort it first (Scene::undistorted)")]
    Distorted(String),
    /// A view index is out of range.
    #[error("view index {index} out of range: the scene has {count} views")]
    ViewIndex {
        /// The index asked for.
        index: usize,
        /// Number of views.
        count: usize,
    },
    /// Inputs that leave nothing to compute (no neighbours, no planes, bad depth range).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// The view sees no sparse points, so there is no depth range to sweep.
    #[error("the view sees no sparse points: no depth range to sweep")]
    NoPoints,
}

/// How colour is used (tutorial §2.1 lists both strategies).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ColorMode {
    /// Convert to grey (Rec. 601 luma) first: 3× cheaper, the common choice in sweeps.
    #[default]
    Gray,
    /// Use all channels (NCC: per-channel means, one joint variance; the other measures
    /// concatenate the channels). Grey images stay grey.
    Color,
}

/// Photo-consistency settings: how a pixel is scored on a plane against its neighbour views.
/// Every stage that matches photographs nests one as its `photo` section
/// (`planemap.photo`, `hypotheses.sweep.photo`, `nonplanar.sweep.photo`, the sweep
/// baseline's `photo`), each with defaults of its own.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PhotoConfig {
    /// Neighbour views matched against each view ([`select_neighbours`]: views sharing
    /// sparse points, at a useful baseline angle), a count ≥ 1. Each section that matches
    /// images sets its own (see the doc of its `photo` key).
    pub neighbours: usize,
    /// The measure (tutorial §2.1 table): `ssd`, `sad`, `ncc`, `census`, `rank` or
    /// `mutual_information`. NCC ignores gain and bias between views.
    pub measure: Measure,
    /// Support-window radius in pixels, at most 64: the window is `(2r+1)²` (3 → 7×7). The
    /// tutorial: the domain should grow with resolution and viewpoint separation and shrink
    /// with distance; larger is more robust, but smooths geometry. SSD/SAD/NCC cost O(1)
    /// per pixel for any radius; Census/Rank/MI cost O(r²) (Rank O(r⁴)). The sweeps use
    /// 5×5 where a guided filter or sub-planes supply the support.
    pub window_radius: u32,
    /// Grey (`gray`, Rec. 601 luma) or colour (`color`) matching. Grey: 3× cheaper, and
    /// colour NCC lost on the sweep (docs/notes/photo-and-sweep-baseline.md).
    pub color: ColorMode,
    /// Raw score → cost map; `None` = [`Normalization::default_for`] the measure.
    pub normalization: Option<Normalization>,
    /// Aggregation of each plane's cost slice after combining neighbours: `kind` = `none`,
    /// `box`, `bilateral`, `guided` or `weighted_median`, with that kind's parameters
    /// beside it ([`Aggregation`]).
    pub aggregation: Aggregation,
    /// Occlusion handling: the cost of a pixel on a plane is the mean of the `best_k` lowest
    /// neighbour costs (Kang, Szeliski, Chai 2001), so up to `n − best_k` of the n
    /// neighbours may be occluded or out of view. A count ≥ 1, clamped to the number of
    /// neighbours.
    pub best_k: usize,
    /// Neighbours that must give evidence at a pixel (window warped into their image) for
    /// it to get a cost below 1; the best-k mean then runs over those that do. A count,
    /// clamped to `1..=best_k`; `best_k` reproduces a strict best-k (every averaged cost
    /// from a neighbour that sees the window). 1: under forward motion and at a scene's
    /// edge most pixels are seen by fewer than `best_k` neighbours and must still be
    /// scored.
    pub min_evidence: usize,
    /// A neighbour scores a window only if at least this fraction of the window's
    /// in-image reference pixels warp inside the neighbour image, in (0, 1]; otherwise it
    /// gives no evidence (cost 1 before the best-k choice).
    pub min_valid_fraction: f64,
    /// Grey-level bins for mutual information, in 2..=32; windows are small, so few bins.
    pub mi_bins: u32,
    /// σc of adaptive support weights for NCC (Yoon and Kweon 2006; the bilaterally
    /// weighted NCC of COLMAP's PatchMatch, Schönberger et al. 2016), in intensity units
    /// (`[0, 1]` scale), ≥ 0; 0 = uniform weights (the O(1) box NCC); needs
    /// `measure = "ncc"`. Window pixel q of pixel p weighs
    /// `exp(−Δc²/(2σc²) − Δs²/(2σs²))`, Δc the RMS difference of the reference image's
    /// colours at p and q, Δs their distance in pixels, so a window straddling a depth edge
    /// matches mostly the side of its centre pixel and a thin foreground (a fence picket, a
    /// pillar) does not lend its depth to the background around it. Costs O(r²) per pixel
    /// (5×5: 1.23× the box NCC). Off unless a section turns it on: alone the weights lose
    /// on plain surfaces (docs/notes/photo-and-sweep-baseline.md).
    pub support_sigma_color: f64,
    /// σs of the support weights, in pixels, > 0 (checked when `support_sigma_color` > 0).
    pub support_sigma_space: f64,
}

impl Default for PhotoConfig {
    fn default() -> Self {
        PhotoConfig {
            neighbours: 4,
            measure: Measure::Ncc,
            window_radius: 3,
            color: ColorMode::Gray,
            normalization: None,
            aggregation: Aggregation::None,
            best_k: 2,
            min_evidence: 1,
            min_valid_fraction: 0.5,
            mi_bins: 8,
            support_sigma_color: 0.0,
            support_sigma_space: 3.0,
        }
    }
}

impl PhotoConfig {
    /// Whether NCC windows use adaptive support weights (`support_sigma_color` > 0).
    pub fn support_weighted(&self) -> bool {
        self.support_sigma_color > 0.0
    }

    /// The normalisation in effect (explicit or the measure's default).
    pub fn effective_normalization(&self) -> Normalization {
        self.normalization
            .unwrap_or_else(|| Normalization::default_for(self.measure))
    }

    /// Checks every field; the error names the field and its value.
    pub fn validate(&self) -> Result<(), PhotoError> {
        if self.neighbours == 0 {
            return Err(PhotoError::InvalidConfig(
                "neighbours must be at least 1".into(),
            ));
        }
        if self.window_radius > 64 {
            return Err(PhotoError::InvalidConfig(format!(
                "window_radius must be at most 64 pixels, got {}",
                self.window_radius
            )));
        }
        if self.best_k == 0 {
            return Err(PhotoError::InvalidConfig(
                "best_k must be at least 1".into(),
            ));
        }
        if !(self.min_valid_fraction > 0.0 && self.min_valid_fraction <= 1.0) {
            return Err(PhotoError::InvalidConfig(format!(
                "min_valid_fraction must be in (0, 1], got {}",
                self.min_valid_fraction
            )));
        }
        if !(2..=measures::MAX_MI_BINS as u32).contains(&self.mi_bins) {
            return Err(PhotoError::InvalidConfig(format!(
                "mi_bins must be in 2..={}, got {}",
                measures::MAX_MI_BINS,
                self.mi_bins
            )));
        }
        if !(self.support_sigma_color.is_finite() && self.support_sigma_color >= 0.0) {
            return Err(PhotoError::InvalidConfig(format!(
                "support_sigma_color must be finite and ≥ 0, got {}",
                self.support_sigma_color
            )));
        }
        if self.support_weighted() {
            if self.measure != Measure::Ncc {
                return Err(PhotoError::InvalidConfig(format!(
                    "support_sigma_color = {} (adaptive support weights) needs measure = ncc, got {:?}",
                    self.support_sigma_color, self.measure
                )));
            }
            if !(self.support_sigma_space.is_finite() && self.support_sigma_space > 0.0) {
                return Err(PhotoError::InvalidConfig(format!(
                    "support_sigma_space must be finite and > 0, got {}",
                    self.support_sigma_space
                )));
            }
        }
        self.effective_normalization().validate()?;
        self.aggregation.validate()
    }
}

/// Plane-sweep settings of one sweep call ([`plane_sweep`], [`multi_family_sweep`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SweepConfig {
    /// How each (pixel, plane) is scored.
    pub photo: PhotoConfig,
    /// Confidence is `second-best − best` cost, the second best taken over planes whose
    /// index differs from the winner's by more than this, a count; 0 = plain second-best.
    /// Adjacent planes of a fine sweep score almost alike at a correct match, which would
    /// make every match look ambiguous.
    pub confidence_exclusion: usize,
    /// Semi-global aggregation of each family's cost volume before the winner-takes-all
    /// (Hirschmüller 2008); off unless `sgm.paths` > 0.
    pub sgm: SgmConfig,
}

impl Default for SweepConfig {
    fn default() -> Self {
        SweepConfig {
            photo: PhotoConfig::default(),
            confidence_exclusion: 2,
            sgm: SgmConfig::default(),
        }
    }
}

impl SweepConfig {
    /// Checks every field.
    pub fn validate(&self) -> Result<(), PhotoError> {
        self.photo.validate()?;
        self.sgm.validate()
    }
}

#[cfg(test)]
mod sweep_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_validate_and_bad_fields_are_named() {
        PhotoConfig::default().validate().unwrap();
        SweepConfig::default().validate().unwrap();
        let cfg = PhotoConfig {
            min_valid_fraction: 0.0,
            ..Default::default()
        };
        assert!(cfg
            .validate()
            .unwrap_err()
            .to_string()
            .contains("min_valid_fraction"));
        let cfg = PhotoConfig {
            mi_bins: 64,
            ..Default::default()
        };
        assert!(cfg.validate().unwrap_err().to_string().contains("mi_bins"));
        let cfg = PhotoConfig {
            best_k: 0,
            ..Default::default()
        };
        assert!(cfg.validate().unwrap_err().to_string().contains("best_k"));
        let err = |cfg: PhotoConfig| cfg.validate().unwrap_err().to_string();
        let weighted = PhotoConfig {
            support_sigma_color: 0.15,
            ..Default::default()
        };
        weighted.validate().unwrap();
        assert!(err(PhotoConfig {
            support_sigma_color: -0.1,
            ..Default::default()
        })
        .contains("support_sigma_color"));
        assert!(err(PhotoConfig {
            support_sigma_space: 0.0,
            ..weighted
        })
        .contains("support_sigma_space"));
        let census = err(PhotoConfig {
            measure: Measure::Census,
            ..weighted
        });
        assert!(
            census.contains("support_sigma_color") && census.contains("ncc"),
            "{census}"
        );
        assert_eq!(
            PhotoConfig::default().effective_normalization(),
            Normalization::default_for(Measure::Ncc)
        );
    }

    #[test]
    fn config_round_trips_through_toml() {
        let cfg = SweepConfig {
            photo: PhotoConfig {
                measure: Measure::Census,
                aggregation: Aggregation::Guided {
                    radius: 4,
                    eps: 1e-3,
                },
                ..Default::default()
            },
            confidence_exclusion: 1,
            sgm: SgmConfig {
                paths: 8,
                p2: 0.5,
                ..Default::default()
            },
        };
        let text = toml::to_string(&cfg).unwrap();
        let back: SweepConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, cfg);
        let partial: PhotoConfig = toml::from_str("measure = \"sad\"").unwrap();
        assert_eq!(partial.measure, Measure::Sad);
        assert_eq!(partial.window_radius, 3);
    }
}
