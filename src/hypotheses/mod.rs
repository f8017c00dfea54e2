//! Plane hypotheses (Furukawa et al. 2009, §4.2): the global list of planes every view's
//! planemap chooses from. Three sources, in pipeline order:
//!
//! - [`points`]: along each dominant direction `d_k`, the points whose normals lie within
//!   `normal_tolerance_deg` of `±d_k` vote with their offsets `d_k·P`; a 1D mean-shift
//!   (bandwidth `bandwidth_r · R`) finds the density peaks; a peak with at least
//!   `min_support` points within the bandwidth becomes the plane `d_k·X = offset`;
//! - [`free`]: planes of any orientation fitted by sequential RANSAC to the points the
//!   axis hypotheses leave unexplained (sloped paving, roofs, turned wings);
//! - [`sweep`]: a photo-consistency sweep along each axis proposes planes the sparse points
//!   are too few to propose;
//! - [`lines`]: planes spanned by 3D lines ([`crate::lines`]), for plain walls bounded by
//!   edges;
//! - [`creases`]: after a first labelling, dominant image lines lifted onto their labelled
//!   plane vote for the planes meeting it there.

pub mod creases;
pub mod free;
pub mod lines;
pub mod points;
pub mod sweep;

pub use creases::{crease_hypotheses, CreaseHypothesesConfig, CreaseHypothesis, LabelledView};
pub use free::{free_plane_hypotheses, FreePlanesConfig};
pub use lines::{line_plane_hypotheses, LinePlanesConfig};
pub use points::plane_hypotheses;
pub use sweep::{sweep_hypotheses, SweepHypothesesConfig, SweepVotes};

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::axes::DominantAxes;
use crate::geometry::Plane;

/// Errors of the plane-hypothesis stage.
#[derive(Debug, Error, PartialEq)]
pub enum HypothesesError {
    /// The configuration is invalid (message says which field and why).
    #[error("invalid hypotheses config: {0}")]
    Config(String),
    /// Input arrays disagree or the scale is not usable.
    #[error("invalid hypotheses input: {0}")]
    Input(String),
}

/// Mean-shift kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Kernel {
    /// Uniform weight within ± bandwidth (the mode is the mean of the points in the window).
    #[default]
    Flat,
    /// Gaussian with σ = bandwidth, truncated at 3σ.
    Gaussian,
}

/// Configuration of [`plane_hypotheses`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct HypothesesConfig {
    /// A point votes for direction `d_k` if its normal is within this angle of ±`d_k`, in
    /// degrees in (0, 90). A start value, not tuned (docs/notes/hypotheses.md).
    pub normal_tolerance_deg: f64,
    /// The same tolerance for a third axis completed as d1 × d2
    /// ([`crate::axes::AxesConfig::complete_frame`]), in degrees in [0, 90); 0 = no
    /// point-based hypotheses along it (the photo-consistency sweep still proposes its
    /// planes). 0: no histogram peak supports that axis, so the points whose noisy normals
    /// lie near it are mostly edge and corner points of the other planes, and their
    /// mean-shift modes are spurious planes (corridor; docs/notes/hypotheses.md).
    pub completed_axis_tolerance_deg: f64,
    /// Mean-shift bandwidth in units of the sampling scale `R`, > 0: the paper's R or 2R.
    pub bandwidth_r: f64,
    /// Mean-shift kernel: `flat` (uniform weight within ± the bandwidth; a mode is the mean
    /// of the offsets in the window) or `gaussian` (σ = the bandwidth, truncated at 3σ).
    pub kernel: Kernel,
    /// Minimum number of points within the bandwidth of a mode for it to become a
    /// hypothesis, a count ≥ 1: the paper's 50, relaxed for small clouds by
    /// `min_support_fraction`.
    pub min_support: usize,
    /// Relative minimum support for small clouds, a fraction of the N points in [0, 1]: the
    /// effective minimum is
    /// `min(min_support, max(MIN_SUPPORT_FLOOR, ceil(min_support_fraction · N)))` with
    /// [`MIN_SUPPORT_FLOOR`] = 6 points, since synthetic and small real clouds are smaller
    /// than the paper's.
    pub min_support_fraction: f64,
    /// Hypotheses whose normals are within this angle (degrees, > 0) and whose offsets are
    /// closer than `merge_offset_r · R` are duplicates; the better supported one is kept.
    /// Not tuned.
    pub merge_angle_deg: f64,
    /// Offset tolerance of that duplicate test, in units of `R`, > 0. Not tuned.
    pub merge_offset_r: f64,
    /// Points whose normal confidence (in [0, 1]) is below this do not vote; in [0, 1].
    /// Just above 0, so that normals whose fit failed (confidence 0) are left out.
    pub min_confidence: f64,
    /// Mean-shift iterations per seed at most, a count ≥ 1. A bound, not tuned.
    pub max_iterations: usize,
    /// A hypothesis along an extra (non-Manhattan) direction is dropped when more than this
    /// fraction of its points also lie within the bandwidth of a Manhattan hypothesis; in
    /// [0, 1], 1 = keep every such hypothesis. A staircase's nosings lie on one slanted
    /// plane whose smeared normals make that slope a direction of its own, but each nosing
    /// point also lies on a tread plane, while a roof's or a turned wall's points meet the
    /// Manhattan planes along a few lines only; the default sits between the shares
    /// measured in those two cases (docs/notes/hypotheses.md).
    pub max_shared_fraction: f64,
    /// Free planes (any orientation) for the points the axis hypotheses leave unexplained.
    pub free: FreePlanesConfig,
    /// The photo-consistency sweep proposing planes the sparse points are too few for.
    pub sweep: SweepHypothesesConfig,
    /// Planes spanned by 3D lines: plain walls bounded by edges.
    pub lines: LinePlanesConfig,
    /// Planes through image creases lifted onto the first labelling's planes.
    pub creases: CreaseHypothesesConfig,
}

impl Default for HypothesesConfig {
    fn default() -> Self {
        HypothesesConfig {
            normal_tolerance_deg: 25.0,
            completed_axis_tolerance_deg: 0.0,
            bandwidth_r: 2.0,
            kernel: Kernel::Flat,
            min_support: 50,
            min_support_fraction: 0.005,
            merge_angle_deg: 1.0,
            merge_offset_r: 1.0,
            min_confidence: 1e-3,
            max_iterations: 100,
            max_shared_fraction: 0.65,
            free: FreePlanesConfig::default(),
            sweep: SweepHypothesesConfig::default(),
            lines: LinePlanesConfig::default(),
            creases: CreaseHypothesesConfig::default(),
        }
    }
}

impl HypothesesConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), HypothesesError> {
        let bad = |m: String| Err(HypothesesError::Config(m));
        if !(self.normal_tolerance_deg > 0.0 && self.normal_tolerance_deg < 90.0) {
            return bad(format!(
                "normal_tolerance_deg = {} must be in (0, 90)",
                self.normal_tolerance_deg
            ));
        }
        if !(0.0..90.0).contains(&self.completed_axis_tolerance_deg) {
            return bad(format!(
                "completed_axis_tolerance_deg = {} must be in [0, 90)",
                self.completed_axis_tolerance_deg
            ));
        }
        for (name, v) in [
            ("bandwidth_r", self.bandwidth_r),
            ("merge_offset_r", self.merge_offset_r),
            ("merge_angle_deg", self.merge_angle_deg),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return bad(format!("{name} = {v} must be positive and finite"));
            }
        }
        if self.min_support == 0 {
            return bad("min_support must be ≥ 1".into());
        }
        for (name, v) in [
            ("min_support_fraction", self.min_support_fraction),
            ("min_confidence", self.min_confidence),
            ("max_shared_fraction", self.max_shared_fraction),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(format!("{name} = {v} must be in [0, 1]"));
            }
        }
        if self.max_iterations == 0 {
            return bad("max_iterations must be ≥ 1".into());
        }
        self.creases.validate()?;
        self.free.validate()?;
        self.lines.validate()?;
        self.sweep.validate()
    }

    /// The support threshold used for a cloud of `n` points.
    pub fn effective_min_support(&self, n: usize) -> usize {
        let rel = ((self.min_support_fraction * n as f64).ceil() as usize).max(MIN_SUPPORT_FLOOR);
        self.min_support.min(rel)
    }
}

/// No plane is ever accepted with fewer points than this, whatever the relative rule says.
pub const MIN_SUPPORT_FLOOR: usize = 6;

/// What the stage reads: oriented points, the dominant axes and the sampling scale.
#[derive(Debug, Clone, Copy)]
pub struct HypothesesInput<'a> {
    /// Point positions (world frame).
    pub positions: &'a [Vector3<f64>],
    /// Unit normals, parallel to `positions`.
    pub normals: &'a [Vector3<f64>],
    /// Confidence in [0, 1], parallel to `positions`.
    pub confidence: &'a [f64],
    /// The dominant directions.
    pub axes: &'a DominantAxes,
    /// The sampling scale `R` (world units), see [`crate::scale::sampling_scale`].
    pub scale: f64,
}

/// A candidate plane for the per-view labelling.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlaneHypothesis {
    /// 0-based id, stable: hypotheses are ordered by direction index, then offset.
    pub id: u32,
    /// The plane `d_k·X = offset` (unit normal = the dominant direction).
    pub plane: Plane,
    /// Index into `DominantAxes::directions` of its normal; `None` for a free plane.
    pub axis: Option<usize>,
    /// Points within the bandwidth of the plane (with a normal near its direction).
    pub support: usize,
}

#[cfg(test)]
mod tests;
