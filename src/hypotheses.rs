//! Plane hypotheses along the dominant directions (Furukawa et al. 2009, §4.2).
//!
//! For each dominant direction `d_k`, the points whose normals lie within
//! `normal_tolerance_deg` of `±d_k` vote with their offsets `d_k·P`; a 1D mean-shift
//! (bandwidth `bandwidth_r · R`) finds the density peaks; a peak with at least `min_support`
//! points within the bandwidth becomes the plane `d_k·X = offset`.
//!
//! Cost: offsets are sorted once per direction; with the flat kernel each mean-shift step is
//! two binary searches on prefix sums (O(log n)), so seeding from every point costs
//! O(n log n · iterations). The Gaussian kernel sums a ±3σ window per step and seeds from the
//! points thinned to one per quarter bandwidth, which keeps it near-linear.

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::axes::DominantAxes;
use crate::photo::texture_mask;
use crate::geometry::Plane;
use crate::photo::{plane_cost_volume, select_neighbours};
use crate::raster::ImageF32;
use crate::scene::{Scene, View};

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
    /// A point votes for direction `d_k` if its normal is within this angle (degrees) of ±d_k.
    pub normal_tolerance_deg: f64,
    /// Normal tolerance (degrees) for the third axis when it was completed as d1 × d2
    /// ([`crate::axes::AxesConfig::complete_frame`]): no histogram peak supports that axis, so
    /// points whose noisy normals happen to lie within `normal_tolerance_deg` of it are mostly
    /// edge and corner points of the other planes, and their mean-shift modes are spurious
    /// planes (corridor: five along the walls). 0 = no point-based hypotheses along it (the
    /// photo-consistency sweep still proposes its planes).
    pub completed_axis_tolerance_deg: f64,
    /// Mean-shift bandwidth in units of the sampling scale `R` (paper: R or 2R).
    pub bandwidth_r: f64,
    /// Mean-shift kernel.
    pub kernel: Kernel,
    /// Minimum number of points within the bandwidth of a peak (paper: 50).
    pub min_support: usize,
    /// Relative minimum for small clouds: the effective minimum support is
    /// `min(min_support, max(MIN_SUPPORT_FLOOR, ceil(min_support_fraction · N)))`, N = number of points.
    pub min_support_fraction: f64,
    /// Hypotheses with normals within this angle (degrees) and offsets closer than
    /// `merge_offset_r · R` are duplicates; the better supported one is kept.
    pub merge_angle_deg: f64,
    /// Offset tolerance of duplicate merging, in units of `R`.
    pub merge_offset_r: f64,
    /// Points with confidence below this do not vote.
    pub min_confidence: f64,
    /// Mean-shift iteration limit per seed.
    pub max_iterations: usize,
    /// A hypothesis along an extra (non-Manhattan) direction is dropped when more than this
    /// fraction of its points also lie within the bandwidth of a Manhattan hypothesis. A
    /// staircase's nosings lie on one slanted plane, and their normals, smeared between
    /// tread and riser, make that slope a direction of its own; but each nosing point also
    /// lies on a tread plane, while a roof's or a turned wall's points meet the Manhattan
    /// planes along a few lines only. Measured: the stairs' slope 77–95 % (of 365 points),
    /// gable's roof 1 % and its house front 53 % (that house's axes are extras there: the
    /// turned wing's took the Manhattan slots). 1 = keep every such hypothesis.
    pub max_shared_fraction: f64,
    /// The photo-consistency sweep proposing planes the points are too few for.
    pub sweep: SweepHypothesesConfig,
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
            sweep: SweepHypothesesConfig::default(),
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

/// Sorted 1D samples with prefix sums for O(log n) window statistics.
struct Offsets {
    x: Vec<f64>,
    prefix: Vec<f64>,
}

impl Offsets {
    fn new(mut x: Vec<f64>) -> Self {
        x.sort_unstable_by(f64::total_cmp);
        let mut prefix = Vec::with_capacity(x.len() + 1);
        let mut s = 0.0;
        prefix.push(0.0);
        for v in &x {
            s += v;
            prefix.push(s);
        }
        Offsets { x, prefix }
    }

    /// Index range of the samples in `[lo, hi]`.
    fn range(&self, lo: f64, hi: f64) -> (usize, usize) {
        (
            self.x.partition_point(|&v| v < lo),
            self.x.partition_point(|&v| v <= hi),
        )
    }

    fn count(&self, c: f64, h: f64) -> usize {
        let (a, b) = self.range(c - h, c + h);
        b - a
    }

    /// One mean-shift step from `c`; `None` if the window is empty.
    fn shift(&self, c: f64, h: f64, kernel: Kernel) -> Option<f64> {
        match kernel {
            Kernel::Flat => {
                let (a, b) = self.range(c - h, c + h);
                (b > a).then(|| (self.prefix[b] - self.prefix[a]) / (b - a) as f64)
            }
            Kernel::Gaussian => {
                let (a, b) = self.range(c - 3.0 * h, c + 3.0 * h);
                let inv = 1.0 / (2.0 * h * h);
                let (mut w, mut s) = (0.0, 0.0);
                for &v in &self.x[a..b] {
                    let k = (-(v - c) * (v - c) * inv).exp();
                    w += k;
                    s += k * v;
                }
                (w > 0.0).then(|| s / w)
            }
        }
    }
}

/// The modes of the offset density with their supports (sorted by offset).
fn mean_shift_modes(off: &Offsets, h: f64, kernel: Kernel, max_iter: usize) -> Vec<(f64, usize)> {
    if off.x.is_empty() {
        return Vec::new();
    }
    // Seeds: every point (flat) or points thinned to one per h/4 cell (Gaussian).
    let seeds: Vec<f64> = match kernel {
        Kernel::Flat => {
            let mut s = off.x.clone();
            s.dedup();
            s
        }
        Kernel::Gaussian => {
            let cell = h / 4.0;
            let mut s: Vec<f64> = Vec::new();
            let mut last = f64::NEG_INFINITY;
            for &v in &off.x {
                if v >= last + cell {
                    s.push(v);
                    last = v;
                }
            }
            s
        }
    };
    let tol = 1e-6 * h;
    let mut modes: Vec<f64> = seeds
        .par_iter()
        .map(|&s| {
            let mut c = s;
            for _ in 0..max_iter {
                match off.shift(c, h, kernel) {
                    Some(next) => {
                        let done = (next - c).abs() <= tol;
                        c = next;
                        if done {
                            break;
                        }
                    }
                    None => break,
                }
            }
            c
        })
        .collect();
    modes.sort_unstable_by(f64::total_cmp);
    // Dedupe: modes within h/2 of the first mode of a group are one peak; keep the member
    // with the largest support (ties: smallest offset).
    let mut out: Vec<(f64, usize)> = Vec::new();
    let mut i = 0;
    while i < modes.len() {
        let start = modes[i];
        let mut best = (start, off.count(start, h));
        let mut j = i + 1;
        let mut prev = start;
        while j < modes.len() && modes[j] - start <= h / 2.0 {
            if modes[j] != prev {
                let s = off.count(modes[j], h);
                if s > best.1 {
                    best = (modes[j], s);
                }
                prev = modes[j];
            }
            j += 1;
        }
        out.push(best);
        i = j;
    }
    out
}

/// Plane hypotheses along every dominant direction (see the module doc); those along an
/// extra direction made of points on Manhattan planes are dropped
/// ([`HypothesesConfig::max_shared_fraction`]).
pub fn plane_hypotheses(
    input: &HypothesesInput<'_>,
    config: &HypothesesConfig,
) -> Result<Vec<PlaneHypothesis>, HypothesesError> {
    config.validate()?;
    let n = input.positions.len();
    if input.normals.len() != n || input.confidence.len() != n {
        return Err(HypothesesError::Input(format!(
            "{n} positions, {} normals, {} confidences",
            input.normals.len(),
            input.confidence.len()
        )));
    }
    if !(input.scale > 0.0 && input.scale.is_finite()) {
        return Err(HypothesesError::Input(format!(
            "sampling scale {} must be positive and finite",
            input.scale
        )));
    }
    let h = config.bandwidth_r * input.scale;
    let cos_tol = config.normal_tolerance_deg.to_radians().cos();
    let min_support = config.effective_min_support(n);

    let mut hyps: Vec<PlaneHypothesis> = Vec::new();
    for (k, d) in input.axes.directions.iter().enumerate() {
        let len = d.norm();
        if !(len > 0.0 && len.is_finite()) {
            return Err(HypothesesError::Input(format!(
                "direction {k} is zero or not finite"
            )));
        }
        let d = d / len;
        let completed = k == 2
            && input
                .axes
                .warnings
                .iter()
                .any(|w| matches!(w, crate::axes::AxesWarning::CompletedThird(_)));
        let cos_k = if completed {
            if config.completed_axis_tolerance_deg <= 0.0 {
                continue;
            }
            config.completed_axis_tolerance_deg.to_radians().cos()
        } else {
            cos_tol
        };
        let offsets: Vec<f64> = (0..n)
            .filter(|&i| {
                input.confidence[i] >= config.min_confidence
                    && input.normals[i].dot(&d).abs() >= cos_k
                    && input.positions[i].iter().all(|v| v.is_finite())
            })
            .map(|i| d.dot(&input.positions[i]))
            .collect();
        let off = Offsets::new(offsets);
        for (offset, support) in mean_shift_modes(&off, h, config.kernel, config.max_iterations) {
            if support >= min_support {
                hyps.push(PlaneHypothesis {
                    id: 0,
                    plane: Plane { normal: d, offset },
                    axis: Some(k),
                    support,
                });
            }
        }
    }

    // Merge duplicates (near-identical directions and offsets): keep the better supported.
    let cos_merge = config.merge_angle_deg.to_radians().cos();
    let tol = config.merge_offset_r * input.scale;
    let mut order: Vec<usize> = (0..hyps.len()).collect();
    order.sort_by(|&a, &b| hyps[b].support.cmp(&hyps[a].support).then(a.cmp(&b)));
    let mut kept: Vec<usize> = Vec::new();
    for &i in &order {
        let dup = kept.iter().any(|&j| {
            let c = hyps[i].plane.normal.dot(&hyps[j].plane.normal);
            c.abs() >= cos_merge
                && (hyps[i].plane.offset - c.signum() * hyps[j].plane.offset).abs() < tol
        });
        if !dup {
            kept.push(i);
        }
    }
    kept.sort_unstable();
    let mut out: Vec<PlaneHypothesis> = kept.into_iter().map(|i| hyps[i].clone()).collect();
    if config.max_shared_fraction < 1.0 {
        let m = input.axes.num_manhattan;
        let manhattan: Vec<Plane> = out
            .iter()
            .filter(|h| h.axis.is_some_and(|k| k < m))
            .map(|h| h.plane)
            .collect();
        out.retain(|hyp| {
            if hyp.axis.is_none_or(|k| k < m) {
                return true;
            }
            let (mut own, mut shared) = (0usize, 0usize);
            for (p, nrm) in input.positions.iter().zip(input.normals) {
                let on_it = (hyp.plane.normal.dot(p) - hyp.plane.offset).abs() <= h
                    && nrm.dot(&hyp.plane.normal).abs() >= cos_tol;
                if on_it {
                    own += 1;
                    if manhattan
                        .iter()
                        .any(|q| (q.normal.dot(p) - q.offset).abs() <= h)
                    {
                        shared += 1;
                    }
                }
            }
            own == 0 || (shared as f64) <= config.max_shared_fraction * own as f64
        });
    }
    // Already ordered by direction then offset (modes come sorted per direction).
    for (id, h) in out.iter_mut().enumerate() {
        h.id = id as u32;
    }
    Ok(out)
}

// ---------------------------------------------------------------------------------------
// Photo-consistency sweep hypotheses: planes the sparse points are too few to propose.
// ---------------------------------------------------------------------------------------

/// Settings of [`sweep_hypotheses`], a second source of plane hypotheses for planes with
/// too few sparse points (a plain wall whose only texture is a door seen by few views).
///
/// Every view sweeps planes along each Manhattan axis (Gallup et al. 2007) at offsets
/// spaced `step_r · R` apart; each textured pixel votes for the (axis, offset) of its
/// clearly best photo-consistent plane; an offset with enough votes from enough views,
/// not already a hypothesis, becomes one.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SweepHypothesesConfig {
    /// Run the sweep (needs the images).
    pub enabled: bool,
    /// Offset step of the sweep in units of R (full-resolution R).
    pub step_r: f64,
    /// At most this many offsets per axis and view; the step grows for larger ranges.
    pub max_planes_per_axis: usize,
    /// Sweep each offset bin at several evenly spaced sub-planes (scored by the cheapest)
    /// until consecutive sub-planes move a pixel at most this far in the neighbours (pixels
    /// of the reduced images; the `step_quantile` over a view's pixels and plane pairs,
    /// median over the views; [`crate::photo::family_step_px`]). A plane seen at a
    /// grazing angle (a lawn from eye height) moves pixels several pixels per step of 2 R,
    /// further than the 5×5 NCC basin is wide, so none of the bin's offsets matched and
    /// nothing voted for it. Bins, margins and peaks stay those of the `step_r` grid; a
    /// hypothesis' offset is the mean of its voters' best sub-planes. 0 = one plane per bin.
    pub max_step_px: f64,
    /// Quantile of the pixel steps over a view that `max_step_px` bounds (Gallup et al.
    /// 2007 bound the largest; the 90th percentile ignores planes grazing the camera).
    pub step_quantile: f64,
    /// Sub-planes are never closer than this (units of R) ...
    pub min_step_r: f64,
    /// ... and an axis never has more than this many (the sweep's time grows with them).
    pub max_fine_planes: usize,
    /// Neighbour views matched against each view ([`crate::photo::select_neighbours`]).
    pub neighbours: usize,
    /// Sweep on images reduced by this integer factor (box filter); 1 = full resolution.
    pub downsample: u32,
    /// ... or by more, so that the reduced images are at most this wide (0 = no limit):
    /// the sweep's cost grows with the pixel count, and 160 pixels across were enough on
    /// every scene. At 640×480 this means 4×.
    pub max_width: u32,
    /// A pixel votes only if its best cost (NCC cost in [0, 1]) is at most this.
    pub max_cost: f32,
    /// ... and the next best plane (another axis, or the same axis more than two steps
    /// away) costs at least this much more.
    pub min_margin: f32,
    /// ... and its grey-level standard deviation over the matching window is at least this.
    pub texture_threshold: f32,
    /// An offset becomes a hypothesis with at least this many votes in total, as a fraction
    /// of one (downsampled) view's pixels.
    pub min_vote_fraction: f64,
    /// ... from at least this many views (each contributing at least a tenth of the votes
    /// threshold).
    pub min_views: usize,
    /// Photo-consistency measure and window.
    pub photo: crate::photo::PhotoConfig,
    /// Snap a sweep plane to a concentration of sparse points near it: the sweep's offsets
    /// are only as fine as its step (≥ `step_r` R on reduced images), but a small plane
    /// whose points got edge-like normals (a stair riser's nosing strip: its PCA
    /// neighbourhoods reach into the tread) has its points at one offset. Within
    /// ±1.5 steps of the sweep's offset, the densest window of width `snap_window_r` R is
    /// taken if it holds at least [`MIN_SUPPORT_FLOOR`] points and `snap_density` times the
    /// points a uniform spread over the range would put there; the plane moves to the
    /// median offset of those points. Normals are not used. 0 = off.
    pub snap_window_r: f64,
    /// Density ratio required by the snap (see `snap_window_r`).
    pub snap_density: f64,
}

impl Default for SweepHypothesesConfig {
    fn default() -> Self {
        SweepHypothesesConfig {
            enabled: true,
            step_r: 2.0,
            max_planes_per_axis: 160,
            max_step_px: 2.0,
            step_quantile: 0.9,
            min_step_r: 0.5,
            max_fine_planes: 1024,
            neighbours: 3,
            downsample: 2,
            max_width: 160,
            max_cost: 0.25,
            min_margin: 0.1,
            texture_threshold: 0.02,
            min_vote_fraction: 0.004,
            min_views: 2,
            photo: crate::photo::PhotoConfig {
                window_radius: 2,
                ..Default::default()
            },
            snap_window_r: 1.0,
            snap_density: 4.0,
        }
    }
}

impl SweepHypothesesConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), HypothesesError> {
        let bad = |m: String| Err(HypothesesError::Config(format!("sweep.{m}")));
        if !(self.step_r > 0.0 && self.step_r.is_finite()) {
            return bad(format!("step_r = {} must be positive", self.step_r));
        }
        if self.max_planes_per_axis < 2 || self.neighbours == 0 || self.min_views == 0 {
            return bad("max_planes_per_axis ≥ 2, neighbours ≥ 1, min_views ≥ 1 expected".into());
        }
        let fine_ok = self.max_step_px >= 0.0
            && self.max_step_px.is_finite()
            && (0.0..=1.0).contains(&self.step_quantile)
            && self.min_step_r > 0.0
            && self.min_step_r.is_finite()
            && self.max_fine_planes >= 1;
        if !fine_ok {
            return bad(format!(
                "max_step_px = {} must be ≥ 0, step_quantile = {} in [0, 1], min_step_r = {} \
                 > 0, max_fine_planes = {} ≥ 1",
                self.max_step_px, self.step_quantile, self.min_step_r, self.max_fine_planes
            ));
        }
        if !(1..=8).contains(&self.downsample) {
            return bad(format!("downsample = {} must be in 1..=8", self.downsample));
        }
        for (name, v) in [
            ("max_cost", self.max_cost),
            ("min_margin", self.min_margin),
            ("texture_threshold", self.texture_threshold),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return bad(format!("{name} = {v} must be in [0, 1]"));
            }
        }
        let snap_ok = self.snap_window_r >= 0.0
            && self.snap_window_r.is_finite()
            && self.snap_density >= 1.0
            && self.snap_density.is_finite();
        if !snap_ok {
            return bad(format!(
                "snap_window_r = {} must be ≥ 0 and snap_density = {} ≥ 1",
                self.snap_window_r, self.snap_density
            ));
        }
        if !(self.min_vote_fraction > 0.0 && self.min_vote_fraction <= 1.0) {
            return bad(format!(
                "min_vote_fraction = {} must be in (0, 1]",
                self.min_vote_fraction
            ));
        }
        self.photo
            .validate()
            .map_err(|e| HypothesesError::Config(format!("sweep.photo: {e}")))
    }
}

/// The sweep plane's offset `offset` along `d`, moved to the median offset of the densest
/// window of `window` width among the points within `reach` of it, if that window holds at
/// least [`MIN_SUPPORT_FLOOR`] points and `density` times a uniform share of the points in
/// reach (see [`SweepHypothesesConfig::snap_window_r`]); unchanged otherwise.
fn snap_to_points(
    positions: &[Vector3<f64>],
    d: &Vector3<f64>,
    offset: f64,
    reach: f64,
    window: f64,
    density: f64,
) -> f64 {
    if window <= 0.0 || reach <= 0.0 {
        return offset;
    }
    let mut near: Vec<f64> = positions
        .iter()
        .map(|p| d.dot(p))
        .filter(|o| o.is_finite() && (o - offset).abs() <= reach)
        .collect();
    near.sort_unstable_by(f64::total_cmp);
    // Densest window: for each start point, the points within `window` after it (ties: the
    // first, so the result does not depend on anything but the sorted offsets).
    let (mut best, mut best_start) = (0usize, 0usize);
    let mut end = 0;
    for start in 0..near.len() {
        end = end.max(start);
        while end < near.len() && near[end] - near[start] <= window {
            end += 1;
        }
        if end - start > best {
            (best, best_start) = (end - start, start);
        }
    }
    let uniform = near.len() as f64 * window / (2.0 * reach);
    if best < MIN_SUPPORT_FLOOR || (best as f64) < density * uniform {
        return offset;
    }
    let w = &near[best_start..best_start + best];
    if w.len() % 2 == 1 {
        w[w.len() / 2]
    } else {
        0.5 * (w[w.len() / 2 - 1] + w[w.len() / 2])
    }
}

/// Box-filter downsampling by an integer factor (the rescaled camera's rays through the
/// new pixel centres pass through the centres of the averaged blocks).
fn downsample_image(img: &ImageF32, f: u32) -> ImageF32 {
    if f == 1 {
        return img.clone();
    }
    let (w, h, c) = (img.width / f, img.height / f, img.channels as usize);
    let mut out = ImageF32::filled(w, h, img.channels, 0.0);
    let norm = 1.0 / (f * f) as f32;
    for y in 0..h {
        for x in 0..w {
            let o = out.index(x, y);
            for dy in 0..f {
                for dx in 0..f {
                    let i = img.index(x * f + dx, y * f + dy);
                    for k in 0..c {
                        out.data[o + k] += img.data[i + k] * norm;
                    }
                }
            }
        }
    }
    out
}

/// The range of `d·X` over the view's frustum between the 5th and 95th percentile depth of
/// the points it sees (widened ×0.7 / ×1.5); `None` if it sees fewer than 3 points.
fn frustum_offset_range(scene: &Scene, view_index: usize, d: &Vector3<f64>) -> Option<(f64, f64)> {
    let view = &scene.views[view_index];
    let mut depths: Vec<f64> = scene
        .cloud
        .positions
        .iter()
        .zip(&scene.cloud.tracks)
        .filter(|(_, t)| t.contains(&(view_index as u32)))
        .filter_map(|(p, _)| view.project(p).map(|(_, z)| z))
        .filter(|z| z.is_finite() && *z > 0.0)
        .collect();
    if depths.len() < 3 {
        return None;
    }
    depths.sort_unstable_by(f64::total_cmp);
    let q = |f: f64| depths[((depths.len() - 1) as f64 * f).round() as usize];
    let (near, far) = (0.7 * q(0.05), 1.5 * q(0.95));
    let (w, h) = (view.camera.width as f64, view.camera.height as f64);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for xy in [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h), (0.5 * w, 0.5 * h)] {
        let (o, dir) = view.ray(&nalgebra::Vector2::new(xy.0, xy.1));
        for z in [near, far] {
            let v = d.dot(&(o + dir * z));
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    (hi > lo).then_some((lo, hi))
}

/// What [`sweep_hypotheses`] found, per axis, for reports and tests.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepVotes {
    /// Offset step per Manhattan axis (world units): the width of a vote bin.
    pub step: Vec<f64>,
    /// Sub-planes swept per bin and axis (`max_step_px`).
    pub sub_planes: Vec<usize>,
    /// Per axis: (offset of the bin, total votes, views voting) for every bin with votes.
    pub bins: Vec<Vec<(f64, u32, u32)>>,
}

/// Plane hypotheses from a photo-consistency sweep along the Manhattan axes (see
/// [`SweepHypothesesConfig`]): returns the new planes (not within the merge tolerance of
/// `existing`, ids continuing after them, `support` = sparse points within the bandwidth)
/// and the votes. `scene` must be undistorted and `images[i]` view i's image.
// Bins index several parallel per-axis arrays (votes, totals, views): ranges read clearer.
#[allow(clippy::needless_range_loop)]
pub fn sweep_hypotheses(
    scene: &Scene,
    images: &[ImageF32],
    input: &HypothesesInput<'_>,
    existing: &[PlaneHypothesis],
    config: &HypothesesConfig,
) -> Result<(Vec<PlaneHypothesis>, SweepVotes), HypothesesError> {
    let sc = &config.sweep;
    sc.validate()?;
    if images.len() != scene.views.len() {
        return Err(HypothesesError::Input(format!(
            "{} images for {} views",
            images.len(),
            scene.views.len()
        )));
    }
    let nax = input.axes.num_manhattan.min(input.axes.directions.len());
    let dirs: Vec<Vector3<f64>> = input.axes.directions[..nax]
        .iter()
        .map(|d| d.normalize())
        .collect();
    let widest_image = images.iter().map(|i| i.width).max().unwrap_or(1);
    let f = if sc.max_width > 0 {
        sc.downsample.max(widest_image.div_ceil(sc.max_width))
    } else {
        sc.downsample
    };
    // Global offset grid per axis: union of the views' frustum ranges, step ≥ step_r·R.
    // Per view and axis: the view's frustum offset range (each scans the cloud once).
    let view_ranges: Vec<Vec<Option<(f64, f64)>>> = (0..scene.views.len())
        .map(|v| {
            dirs.iter()
                .map(|d| frustum_offset_range(scene, v, d))
                .collect()
        })
        .collect();
    let mut ranges = vec![(f64::INFINITY, f64::NEG_INFINITY); nax];
    let mut widest = vec![0.0f64; nax];
    for per_axis in &view_ranges {
        for (k, r) in per_axis.iter().enumerate() {
            if let Some((lo, hi)) = *r {
                ranges[k].0 = ranges[k].0.min(lo);
                ranges[k].1 = ranges[k].1.max(hi);
                widest[k] = widest[k].max(hi - lo);
            }
        }
    }
    let steps: Vec<f64> = (0..nax)
        .map(|k| (sc.step_r * input.scale).max(widest[k] / sc.max_planes_per_axis as f64))
        .collect();
    let nbins: Vec<usize> = (0..nax)
        .map(|k| {
            if ranges[k].1 > ranges[k].0 {
                ((ranges[k].1 - ranges[k].0) / steps[k]).ceil() as usize + 1
            } else {
                0
            }
        })
        .collect();
    let offset_of = |k: usize, i: usize| ranges[k].0 + i as f64 * steps[k];
    let small: Vec<(View, ImageF32)> = scene
        .views
        .iter()
        .zip(images)
        .map(|(v, img)| {
            let mut sv = v.clone();
            let (w, h) = ((img.width / f).max(1), (img.height / f).max(1));
            sv.camera = v.camera.rescaled(w, h);
            (sv, downsample_image(img, f))
        })
        .collect();
    let neighbours_of: Vec<Vec<usize>> = (0..scene.views.len())
        .map(|v| select_neighbours(scene, v, sc.neighbours))
        .collect::<Result<_, _>>()
        .map_err(|e| HypothesesError::Input(e.to_string()))?;
    // Sub-planes per offset bin: where a bin's step moves pixels further than the 5×5 NCC
    // basin is wide, each bin is swept at `sub` evenly spaced offsets and scored by the
    // cheapest of them; bins, margins and peaks stay those of the bin grid.
    let mut subdivision = vec![1usize; nax];
    if sc.max_step_px > 0.0 {
        for k in 0..nax {
            let mut px: Vec<f64> = (0..scene.views.len())
                .filter_map(|v| {
                    let (lo, hi) = view_ranges[v][k]?;
                    let n =
                        (((hi - lo) / steps[k]).ceil() as usize + 1).min(sc.max_planes_per_axis);
                    let planes: Vec<Plane> = (0..n)
                        .map(|i| Plane {
                            normal: dirs[k],
                            offset: lo + i as f64 * steps[k],
                        })
                        .collect();
                    let nbrs: Vec<&View> = neighbours_of[v].iter().map(|&j| &small[j].0).collect();
                    crate::photo::family_step_px(&small[v].0, &nbrs, &planes, sc.step_quantile)
                })
                .collect();
            px.sort_by(f64::total_cmp);
            let Some(&median) = px.get(px.len() / 2) else {
                continue;
            };
            let cap = (sc.max_fine_planes / nbins[k].max(1))
                .min((steps[k] / (sc.min_step_r * input.scale)).floor() as usize)
                .max(1);
            subdivision[k] = ((median / sc.max_step_px).ceil() as usize).clamp(1, cap);
            tracing::debug!(
                axis = k,
                step = steps[k],
                px = median,
                sub = subdivision[k],
                "sweep hypotheses: sub-planes per bin"
            );
        }
    }
    let px_per_view = small.first().map_or(1, |(v, _)| {
        v.camera.width as usize * v.camera.height as usize
    });
    let min_votes = ((sc.min_vote_fraction * px_per_view as f64).ceil() as u32).max(1);
    let min_view_votes = (min_votes / 10).max(1);
    let mut total: Vec<Vec<u32>> = nbins.iter().map(|&n| vec![0; n]).collect();
    // Per bin: the sum of its voters' offsets (their best sub-plane's).
    let mut offset_sum: Vec<Vec<f64>> = nbins.iter().map(|&n| vec![0.0; n]).collect();
    let mut views_voting: Vec<Vec<u32>> = nbins.iter().map(|&n| vec![0; n]).collect();
    for v in 0..scene.views.len() {
        let nb = &neighbours_of[v];
        if nb.is_empty() {
            continue;
        }
        let (ref_view, ref_img) = &small[v];
        let neighbours: Vec<(&View, &ImageF32)> =
            nb.iter().map(|&j| (&small[j].0, &small[j].1)).collect();
        let npx = ref_view.camera.width as usize * ref_view.camera.height as usize;
        // Per axis: best cost, its bin, the best cost more than two bins away, and the
        // offset of the best (sub-)plane.
        let mut best = vec![(1.0f32, u32::MAX, 1.0f32, 0.0f64); npx * nax];
        for (k, d) in dirs.iter().enumerate() {
            let Some((lo, hi)) = view_ranges[v][k] else {
                continue;
            };
            let i0 = ((lo - ranges[k].0) / steps[k]).floor().max(0.0) as usize;
            let i1 = (((hi - ranges[k].0) / steps[k]).ceil() as usize).min(nbins[k] - 1);
            if i1 <= i0 {
                continue;
            }
            let sub = subdivision[k];
            // Sub-plane s of bin i sits at the bin's offset + (s + ½)/sub − ½ steps (the
            // bin's own offset when sub = 1).
            let sub_offset = |j: usize| {
                offset_of(k, i0 + j / sub)
                    + ((j % sub) as f64 + 0.5 - 0.5 * sub as f64) / sub as f64 * steps[k]
            };
            let planes: Vec<Plane> = (0..(i1 - i0 + 1) * sub)
                .map(|j| Plane {
                    normal: *d,
                    offset: sub_offset(j),
                })
                .collect();
            let vol = plane_cost_volume(ref_view, ref_img, &neighbours, &planes, &sc.photo)
                .map_err(|e| HypothesesError::Input(e.to_string()))?;
            let np = planes.len();
            let mut bin_cost = vec![0.0f32; i1 - i0 + 1];
            for p in 0..npx {
                let c = &vol.costs[p * np..(p + 1) * np];
                let (bj, bc) = c
                    .iter()
                    .enumerate()
                    .fold(
                        (0usize, f32::INFINITY),
                        |a, (i, &x)| if x < a.1 { (i, x) } else { a },
                    );
                for (b, chunk) in bin_cost.iter_mut().zip(c.chunks_exact(sub)) {
                    *b = chunk.iter().fold(f32::INFINITY, |a, &x| a.min(x));
                }
                let bi = bj / sub;
                let second = bin_cost
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| i.abs_diff(bi) > 2)
                    .fold(1.0f32, |a, (_, &x)| a.min(x));
                best[p * nax + k] = (bc, (i0 + bi) as u32, second, sub_offset(bj));
            }
        }
        let texture = texture_mask(ref_img, sc.photo.window_radius, sc.texture_threshold);
        let mut votes: Vec<Vec<u32>> = nbins.iter().map(|&n| vec![0; n]).collect();
        for p in 0..npx {
            if !texture[p] {
                continue;
            }
            let row = &best[p * nax..(p + 1) * nax];
            let Some((k, &(bc, bi, second, offset))) = row
                .iter()
                .enumerate()
                .filter(|(_, b)| b.1 != u32::MAX)
                .min_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
            else {
                continue;
            };
            let other = row
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .fold(second, |a, (_, b)| a.min(b.0));
            if bc <= sc.max_cost && other - bc >= sc.min_margin {
                votes[k][bi as usize] += 1;
                offset_sum[k][bi as usize] += offset;
            }
        }
        for k in 0..nax {
            for i in 0..nbins[k] {
                total[k][i] += votes[k][i];
                let near: u32 = votes[k][i.saturating_sub(1)..(i + 2).min(nbins[k])]
                    .iter()
                    .sum();
                if near >= min_view_votes {
                    views_voting[k][i] += 1;
                }
            }
        }
    }
    // Peaks of the vote histogram (±1 bin window) that are not existing hypotheses.
    let mut out = Vec::new();
    let h = config.bandwidth_r * input.scale;
    for k in 0..nax {
        let n = nbins[k];
        let win = |i: usize| -> u32 { total[k][i.saturating_sub(1)..(i + 2).min(n)].iter().sum() };
        for i in 0..n {
            let t = win(i);
            if t < min_votes || views_voting[k][i] < sc.min_views as u32 {
                continue;
            }
            let left_ok = i == 0 || win(i - 1) < t;
            let right_ok = i + 1 >= n || win(i + 1) <= t;
            if !(left_ok && right_ok) {
                continue;
            }
            let (mut sw, mut so) = (0.0f64, 0.0f64);
            for j in i.saturating_sub(1)..(i + 2).min(n) {
                sw += total[k][j] as f64;
                so += offset_sum[k][j];
            }
            let d = dirs[k];
            let offset = snap_to_points(
                input.positions,
                &d,
                so / sw,
                1.5 * steps[k] / subdivision[k] as f64,
                sc.snap_window_r * input.scale,
                sc.snap_density,
            );
            let dup = existing
                .iter()
                .chain(out.iter())
                .any(|e: &PlaneHypothesis| {
                    let c = e.plane.normal.dot(&d);
                    c.abs() >= config.merge_angle_deg.to_radians().cos()
                        && (e.plane.offset - c.signum() * offset).abs()
                            < (config.merge_offset_r * input.scale).max(1.5 * steps[k])
                });
            if dup {
                continue;
            }
            let support = input
                .positions
                .iter()
                .filter(|p| (d.dot(p) - offset).abs() <= h)
                .count();
            out.push(PlaneHypothesis {
                id: 0,
                plane: Plane { normal: d, offset },
                axis: Some(k),
                support,
            });
        }
    }
    for (i, hyp) in out.iter_mut().enumerate() {
        hyp.id = (existing.len() + i) as u32;
    }
    let bins = (0..nax)
        .map(|k| {
            (0..nbins[k])
                .filter(|&i| total[k][i] > 0)
                .map(|i| (offset_of(k, i), total[k][i], views_voting[k][i]))
                .collect()
        })
        .collect();
    Ok((
        out,
        SweepVotes {
            step: steps,
            sub_planes: subdivision,
            bins,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::axes::{dominant_axes, AxesConfig};
    use crate::normals::tests::{scene_from, test_view};
    use crate::normals::{estimate_normals, NormalsConfig};
    use crate::scale::sampling_scale;
    use nalgebra::{Rotation3, Unit};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Points on the faces of a box with half-sizes `half`, rotated by `rot` and shifted by
    /// `center`, with position noise `noise` and `outliers` random points. Returns positions
    /// and the true face planes.
    fn box_points(
        rng: &mut ChaCha8Rng,
        rot: &Rotation3<f64>,
        center: Vector3<f64>,
        half: Vector3<f64>,
        per_face: usize,
        noise: f64,
        outliers: usize,
    ) -> (Vec<Vector3<f64>>, Vec<Plane>) {
        let mut pts = Vec::new();
        let mut planes = Vec::new();
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut local_n = Vector3::zeros();
                local_n[axis] = sign;
                let n = rot * local_n;
                planes.push(Plane::through(&(center + n * half[axis]), &n));
                for _ in 0..per_face {
                    let mut q = Vector3::zeros();
                    for a in 0..3 {
                        q[a] = if a == axis {
                            sign * half[a] + rng.random_range(-noise..noise)
                        } else {
                            rng.random_range(-half[a]..half[a])
                        };
                    }
                    pts.push(center + rot * q);
                }
            }
        }
        for _ in 0..outliers {
            let q = Vector3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
            pts.push(center + rot * q.component_mul(&half) * 1.5);
        }
        (pts, planes)
    }

    #[test]
    fn box_faces_recovered_from_pca_normals() {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let rot =
            Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(0.3, 0.8, -0.4)), 0.7);
        let center = Vector3::new(0.3, -0.2, 0.1);
        let half = Vector3::new(1.0, 0.7, 0.5);
        let (pts, planes) = box_points(&mut rng, &rot, center, half, 1500, 0.004, 300);
        // Cameras all around, at ~6 units: R ≈ 6/500 = 0.012.
        let views: Vec<_> = (0..8)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 8.0;
                let z = if i % 2 == 0 { 3.0 } else { -3.0 };
                test_view(i, Vector3::new(6.0 * a.cos(), 6.0 * a.sin(), z))
            })
            .collect();
        let scene = scene_from(views, pts);
        let r = sampling_scale(&scene).unwrap();
        assert!(r > 0.005 && r < 0.03, "R = {r}");
        let oc = estimate_normals(&scene, &NormalsConfig::default()).unwrap();
        let axes = dominant_axes(&oc, &AxesConfig::default()).unwrap();
        assert_eq!(axes.directions.len(), 3);
        for k in 0..3 {
            let truth = rot * Vector3::ith(k, 1.0);
            let e = axes
                .directions
                .iter()
                .map(|d| d.dot(&truth).abs().min(1.0).acos().to_degrees())
                .fold(f64::INFINITY, f64::min);
            assert!(e < 1.0, "axis {k} error {e}°");
        }
        let input = HypothesesInput {
            positions: &scene.cloud.positions,
            normals: &oc.normals,
            confidence: &oc.confidence,
            axes: &axes,
            scale: r,
        };
        let hyps = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
        assert_eq!(hyps.len(), 6, "{hyps:#?}");
        for truth in &planes {
            let matched: Vec<_> = hyps
                .iter()
                .filter(|h| {
                    let c = h.plane.normal.dot(&truth.normal);
                    c.abs() > 0.999 && (h.plane.offset - c.signum() * truth.offset).abs() < r
                })
                .collect();
            assert_eq!(matched.len(), 1, "plane {truth:?}: {matched:?}");
            assert!(matched[0].support > 1000);
        }
        for (i, h) in hyps.iter().enumerate() {
            assert_eq!(h.id as usize, i);
        }
        // Stable order: by direction, then offset.
        for w in hyps.windows(2) {
            assert!(
                w[0].axis < w[1].axis
                    || (w[0].axis == w[1].axis && w[0].plane.offset < w[1].plane.offset)
            );
        }
    }

    #[test]
    fn house_with_roof_slopes_end_to_end() {
        // Walls x, y ∈ [-1, 1], z ∈ [0, 1], floor z = 0, gable roof at 30° over x.
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        let slope = 30f64.to_radians();
        let mut pts = Vec::new();
        let mut u = |a: f64, b: f64| rng.random_range(a..b);
        let noise = 0.003;
        for _ in 0..2000 {
            for s in [-1.0, 1.0] {
                pts.push(Vector3::new(
                    s + u(-noise, noise),
                    u(-1.0, 1.0),
                    u(0.0, 1.0),
                ));
                pts.push(Vector3::new(
                    u(-1.0, 1.0),
                    s + u(-noise, noise),
                    u(0.0, 1.0),
                ));
            }
        }
        for _ in 0..2500 {
            pts.push(Vector3::new(u(-1.0, 1.0), u(-1.0, 1.0), u(-noise, noise)));
        }
        for _ in 0..1500 {
            for s in [-1.0, 1.0] {
                let x: f64 = u(0.0, 1.0);
                pts.push(Vector3::new(
                    s * x,
                    u(-1.0, 1.0),
                    1.0 + (1.0 - x) * slope.tan() + u(-noise, noise),
                ));
            }
        }
        let truth = [
            Plane::new(Vector3::x(), 1.0),
            Plane::new(Vector3::x(), -1.0),
            Plane::new(Vector3::y(), 1.0),
            Plane::new(Vector3::y(), -1.0),
            Plane::new(Vector3::z(), 0.0),
            Plane::through(
                &Vector3::new(1.0, 0.0, 1.0),
                &Vector3::new(slope.sin(), 0.0, slope.cos()),
            ),
            Plane::through(
                &Vector3::new(-1.0, 0.0, 1.0),
                &Vector3::new(-slope.sin(), 0.0, slope.cos()),
            ),
        ];
        let views: Vec<_> = (0..8)
            .map(|i| {
                let a = i as f64 * std::f64::consts::TAU / 8.0 + 0.2;
                let z = if i % 2 == 0 { 4.0 } else { -3.0 };
                test_view(i, Vector3::new(6.0 * a.cos(), 6.0 * a.sin(), z))
            })
            .collect();
        let scene = scene_from(views, pts);
        let r = sampling_scale(&scene).unwrap();
        let oc = estimate_normals(&scene, &NormalsConfig::default()).unwrap();
        let with_extras = |max_extra_directions| {
            let cfg = AxesConfig {
                max_extra_directions,
                ..Default::default()
            };
            dominant_axes(&oc, &cfg).unwrap()
        };
        assert_eq!(with_extras(0).directions.len(), 3);
        let axes = with_extras(4);
        assert_eq!(axes.directions.len(), 5, "{:?}", axes.directions);
        let input = HypothesesInput {
            positions: &scene.cloud.positions,
            normals: &oc.normals,
            confidence: &oc.confidence,
            axes: &axes,
            scale: r,
        };
        let hyps = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
        let mut matched_ids = Vec::new();
        for t in &truth {
            let m: Vec<_> = hyps
                .iter()
                .filter(|h| {
                    let c = h.plane.normal.dot(&t.normal);
                    c.abs() > 0.9995 && (h.plane.offset - c.signum() * t.offset).abs() < r
                })
                .collect();
            assert_eq!(m.len(), 1, "plane {t:?}: {m:?}");
            matched_ids.push(m[0].id);
        }
        // Anything else (e.g. the ridge line, whose PCA normals point up) is weakly supported.
        let weakest_true = matched_ids
            .iter()
            .map(|&i| hyps[i as usize].support)
            .min()
            .unwrap();
        for h in hyps.iter().filter(|h| !matched_ids.contains(&h.id)) {
            assert!(h.support * 4 < weakest_true, "spurious {h:?}");
        }
    }

    /// A textured room corner (walls x = 0, y = 0, floor z = 0) seen by the corner views;
    /// sparse points only on the floor and the wall y = 0 (plus 3 on x = 0, below any
    /// support threshold): the sweep must propose x = 0, and nothing the points already give.
    #[test]
    fn sweep_proposes_the_textured_wall_the_points_miss() {
        use crate::planemap::testutil::{cast, corner_views};
        let views = corner_views();
        let texture = |p: &Vector3<f64>, face: usize| -> f32 {
            // Random grey per 0.15 m cell of the face's two in-plane coordinates.
            let (a, b) = match face {
                0 => (p.y, p.z),
                1 => (p.x, p.z),
                _ => (p.x, p.y),
            };
            let (i, j) = ((a / 0.15).floor() as i64, (b / 0.15).floor() as i64);
            let h = (i.wrapping_mul(73_856_093)
                ^ j.wrapping_mul(19_349_663)
                ^ (face as i64 * 83_492_791))
                .rem_euclid(1000);
            0.2 + 0.6 * h as f32 / 1000.0
        };
        let images: Vec<ImageF32> = views
            .iter()
            .map(|v| {
                let (w, h) = (v.camera.width, v.camera.height);
                let mut img = ImageF32::filled(w, h, 1, 0.0);
                for y in 0..h {
                    for x in 0..w {
                        let (o, d) = v.ray(&nalgebra::Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
                        img.pixel_mut(x, y)[0] = cast(&o, &d).map_or(0.05, |(f, p)| texture(&p, f));
                    }
                }
                img
            })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut positions = Vec::new();
        for (face, count) in [(1usize, 150), (2, 150), (0, 3)] {
            for _ in 0..count {
                let mut p = Vector3::zeros();
                for k in 0..3 {
                    if k != face {
                        p[k] = rng.random_range(0.1..3.9);
                    }
                }
                positions.push(p);
            }
        }
        let n = positions.len();
        let mut normals = vec![Vector3::z(); n];
        for (i, nr) in normals.iter_mut().enumerate().take(150) {
            let _ = i;
            *nr = Vector3::y();
        }
        normals[300..].fill(Vector3::x());
        let confidence = vec![1.0; n];
        let scene = seen_by_every_view(views, &positions);
        let axes = manual_axes(vec![Vector3::x(), Vector3::y(), Vector3::z()]);
        let input = HypothesesInput {
            positions: &positions,
            normals: &normals,
            confidence: &confidence,
            axes: &axes,
            scale: 0.02,
        };
        let cfg = HypothesesConfig {
            sweep: SweepHypothesesConfig {
                max_planes_per_axis: 60,
                ..Default::default()
            },
            ..Default::default()
        };
        let existing = plane_hypotheses(&input, &cfg).unwrap();
        assert!(existing.iter().all(|h| h.axis != Some(0)), "{existing:?}");
        let (extra, votes) = sweep_hypotheses(&scene, &images, &input, &existing, &cfg).unwrap();
        assert_eq!(votes.step.len(), 3);
        let wall: Vec<_> = extra.iter().filter(|h| h.axis == Some(0)).collect();
        assert_eq!(wall.len(), 1, "{extra:?}");
        assert!(
            wall[0].plane.offset.abs() < 2.0 * votes.step[0],
            "{:?}",
            wall[0]
        );
        assert_eq!(wall[0].id as usize, existing.len());
        // Nothing within the merge tolerance of the floor or the wall y = 0.
        for h in &extra {
            for e in &existing {
                let same = h.plane.normal.dot(&e.plane.normal).abs() > 0.99;
                assert!(
                    !same || (h.plane.offset - e.plane.offset).abs() > 0.02,
                    "{h:?}"
                );
            }
        }
        // Bad input: image count.
        assert!(sweep_hypotheses(&scene, &images[..2], &input, &existing, &cfg).is_err());
    }

    /// A textured lawn z = 0 seen from eye height at grazing angles and a back wall y = 8
    /// that holds every sparse point (thin's garden in miniature). A step of a few R moves
    /// lawn pixels by several pixels in the neighbours, wider than the 5×5 NCC basin: no
    /// offset matched, nothing voted for the lawn. With the step refined to the pixels
    /// (`max_step_px`), the sweep proposes z = 0.
    #[test]
    fn sweep_refines_its_step_until_a_grazing_lawn_votes() {
        use crate::geometry::{look_at, Camera};
        let value = |a: f64, b: f64, salt: i64| -> f32 {
            let (i, j) = ((a / 0.2).floor() as i64, (b / 0.2).floor() as i64);
            let h =
                (i.wrapping_mul(73_856_093) ^ j.wrapping_mul(19_349_663) ^ salt).rem_euclid(1000);
            0.2 + 0.6 * h as f32 / 1000.0
        };
        let shade = |o: &Vector3<f64>, d: &Vector3<f64>| -> f32 {
            let t_wall = if d.y > 1e-9 {
                (8.0 - o.y) / d.y
            } else {
                f64::INFINITY
            };
            let t_lawn = if d.z < -1e-9 {
                -o.z / d.z
            } else {
                f64::INFINITY
            };
            if t_lawn < t_wall {
                let p = o + d * t_lawn;
                value(p.x, p.y, 11)
            } else if t_wall.is_finite() {
                let p = o + d * t_wall;
                value(p.x, p.z, 29)
            } else {
                0.9
            }
        };
        let cam = Camera::pinhole(120, 90, 100.0, 100.0, 60.0, 45.0);
        let views: Vec<View> = [-1.2, -0.4, 0.4, 1.2]
            .iter()
            .enumerate()
            .map(|(i, &x)| View {
                id: i as u32 + 1,
                name: format!("v{i}.png"),
                camera: cam.clone(),
                cam_from_world: look_at(
                    &Vector3::new(x, 0.0, 1.5),
                    &Vector3::new(0.3 * x, 8.0, 0.4),
                    &Vector3::z(),
                ),
                image_path: None,
            })
            .collect();
        let images: Vec<ImageF32> = views
            .iter()
            .map(|v| {
                let mut img = ImageF32::filled(120, 90, 1, 0.0);
                for y in 0..90 {
                    for x in 0..120 {
                        let (o, d) = v.ray(&nalgebra::Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
                        img.pixel_mut(x, y)[0] = shade(&o, &d);
                    }
                }
                img
            })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let positions: Vec<Vector3<f64>> = (0..150)
            .map(|_| Vector3::new(rng.random_range(-3.0..3.0), 8.0, rng.random_range(0.1..3.0)))
            .collect();
        let n = positions.len();
        let (normals, confidence) = (vec![Vector3::y(); n], vec![1.0; n]);
        let scene = seen_by_every_view(views, &positions);
        let axes = manual_axes(vec![Vector3::y(), Vector3::z(), Vector3::x()]);
        let input = HypothesesInput {
            positions: &positions,
            normals: &normals,
            confidence: &confidence,
            axes: &axes,
            scale: 0.02,
        };
        let coarse = HypothesesConfig {
            sweep: SweepHypothesesConfig {
                downsample: 1,
                max_planes_per_axis: 40,
                max_fine_planes: 400,
                max_step_px: 0.0,
                ..Default::default()
            },
            ..Default::default()
        };
        let existing = plane_hypotheses(&input, &coarse).unwrap();
        assert!(existing.iter().all(|h| h.axis == Some(0)), "{existing:?}");
        let lawn = |extra: &[PlaneHypothesis]| {
            extra
                .iter()
                .filter(|h| h.axis == Some(1) && h.plane.offset.abs() < 0.02)
                .count()
        };
        let (extra, votes) = sweep_hypotheses(&scene, &images, &input, &existing, &coarse).unwrap();
        assert_eq!(lawn(&extra), 0, "step {:?}: {extra:?}", votes.step);
        let mut fine = coarse.clone();
        fine.sweep.max_step_px = SweepHypothesesConfig::default().max_step_px;
        let (extra, fine_votes) =
            sweep_hypotheses(&scene, &images, &input, &existing, &fine).unwrap();
        assert_eq!(lawn(&extra), 1, "step {:?}: {extra:?}", fine_votes.step);
        assert_eq!(votes.sub_planes, vec![1; 3]);
        assert!(fine_votes.sub_planes[1] >= 2, "{fine_votes:?}");
    }

    /// A scene of `views` whose sparse points are all seen by every view.
    fn seen_by_every_view(views: Vec<View>, positions: &[Vector3<f64>]) -> Scene {
        let n = positions.len();
        let track: Vec<u32> = (0..views.len() as u32).collect();
        Scene {
            views,
            cloud: crate::scene::SparseCloud {
                tracks: vec![track; n],
                colors: vec![[128; 3]; n],
                errors: vec![0.5; n],
                confidence: vec![1.0; n],
                normals: None,
                positions: positions.to_vec(),
            },
        }
    }

    fn manual_axes(dirs: Vec<Vector3<f64>>) -> DominantAxes {
        let m = dirs.len();
        DominantAxes {
            support: vec![0; m],
            directions: dirs,
            pairwise_angles_deg: vec![],
            num_manhattan: m,
            warnings: vec![],
        }
    }

    /// A flight of ten treads (points with vertical normals) whose nosings (40 points each on
    /// the tread's front edge, normals smeared to the flight's slope) line up on one slanted
    /// plane, and a roof along a second extra direction: the slope's hypothesis, whose
    /// points all lie on tread planes, is dropped; the roof's is kept; with
    /// `max_shared_fraction` = 1 both are proposed.
    #[test]
    fn a_slope_through_stair_nosings_is_not_a_plane_but_a_roof_is() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let slope = Vector3::new(0.0, -0.2, 0.3).normalize();
        let roof_n = Vector3::new(1.0, 0.0, 1.0).normalize();
        let (mut positions, mut normals) = (Vec::new(), Vec::new());
        for k in 0..10 {
            let (y0, z) = (0.3 * k as f64, 0.2 * k as f64);
            for _ in 0..60 {
                positions.push(Vector3::new(
                    rng.random(),
                    y0 + 0.3 * rng.random::<f64>(),
                    z,
                ));
                normals.push(Vector3::z());
            }
            for _ in 0..40 {
                positions.push(Vector3::new(rng.random(), y0, z));
                normals.push(slope);
            }
        }
        let (e1, e2) = (Vector3::y(), Vector3::new(-1.0, 0.0, 1.0).normalize());
        for _ in 0..300 {
            let (u, v): (f64, f64) = (rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            positions.push(Vector3::new(5.0, 0.0, 5.0) + e1 * u + e2 * v);
            normals.push(roof_n);
        }
        let mut axes = manual_axes(vec![
            Vector3::x(),
            Vector3::y(),
            Vector3::z(),
            slope,
            roof_n,
        ]);
        axes.num_manhattan = 3;
        let confidence = vec![1.0; positions.len()];
        let input = HypothesesInput {
            positions: &positions,
            normals: &normals,
            confidence: &confidence,
            axes: &axes,
            scale: 0.01,
        };
        let along =
            |hyps: &[PlaneHypothesis], k: usize| hyps.iter().filter(|h| h.axis == Some(k)).count();
        let all = plane_hypotheses(
            &input,
            &HypothesesConfig {
                max_shared_fraction: 1.0,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(along(&all, 2), 10, "one per tread");
        assert_eq!(along(&all, 3), 1, "the nosings' plane is proposed");
        assert_eq!(along(&all, 4), 1, "the roof");
        let kept = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
        assert_eq!(along(&kept, 2), 10);
        assert_eq!(along(&kept, 3), 0, "its points all lie on tread planes");
        assert_eq!(along(&kept, 4), 1, "the roof meets no tread plane");
        assert!(kept.iter().enumerate().all(|(i, h)| h.id == i as u32));
    }

    /// A riser's points at y = 2.10 (±4 mm) next to tread points spread over y ∈ [2.10, 2.40]:
    /// a sweep plane 2 cm off snaps to the riser; without the concentration it stays put.
    #[test]
    fn sweep_planes_snap_to_a_concentration_of_points_only() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let d = Vector3::y();
        let riser: Vec<Vector3<f64>> = (0..40)
            .map(|_| Vector3::new(rng.random(), 2.10 + rng.random_range(-0.004..0.004), 1.4))
            .collect();
        let tread: Vec<Vector3<f64>> = (0..150)
            .map(|_| Vector3::new(rng.random(), rng.random_range(2.10..2.40), 1.44))
            .collect();
        let all: Vec<Vector3<f64>> = riser.iter().chain(&tread).copied().collect();
        let (reach, window) = (0.045, 0.0138);
        let snapped = snap_to_points(&all, &d, 2.12, reach, window, 4.0);
        assert!((snapped - 2.10).abs() < 0.003, "{snapped}");
        // The tread alone is a uniform spread: no snap.
        assert_eq!(snap_to_points(&tread, &d, 2.25, reach, window, 4.0), 2.25);
        // Too few points, or the snap off: no snap.
        assert_eq!(
            snap_to_points(&riser[..5], &d, 2.12, reach, window, 4.0),
            2.12
        );
        assert_eq!(snap_to_points(&all, &d, 2.12, reach, 0.0, 4.0), 2.12);
        // Nothing within reach: unchanged; non-finite points are ignored.
        let mut far = all.clone();
        far.push(Vector3::new(f64::NAN, 0.0, 0.0));
        assert_eq!(snap_to_points(&far, &d, 3.5, reach, window, 4.0), 3.5);
        assert!((snap_to_points(&far, &d, 2.12, reach, window, 4.0) - 2.10).abs() < 0.003);
    }

    #[test]
    fn parallel_planes_gaussian_and_flat_agree_and_small_clouds() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let d = Vector3::new(0.0, 0.6, 0.8);
        let r = 0.01;
        // Three parallel planes 10R apart, 200 / 80 / 30 points, σ ≈ R/3, plus spread noise.
        let mut pts = Vec::new();
        for (off, c) in [(0.5, 200), (0.6, 80), (0.7, 30)] {
            for _ in 0..c {
                let e = rng.random_range(-0.005..0.005);
                let t = Vector3::new(rng.random_range(-1.0..1.0), 0.8, -0.6)
                    * rng.random_range(-1.0..1.0);
                pts.push(
                    d * (off + e)
                        + Vector3::new(t.x, 0.0, 0.0)
                        + Vector3::new(0.0, 0.8, -0.6) * t.y,
                );
            }
        }
        for _ in 0..100 {
            pts.push(d * rng.random_range(-2.0..2.0));
        }
        let n = pts.len();
        let normals = vec![d; n];
        let conf = vec![1.0; n];
        let axes = manual_axes(vec![d]);
        let input = HypothesesInput {
            positions: &pts,
            normals: &normals,
            confidence: &conf,
            axes: &axes,
            scale: r,
        };
        let cfg = HypothesesConfig::default();
        // 410 points: effective minimum min(50, max(10, ceil(4.1))) = 10.
        assert_eq!(cfg.effective_min_support(n), MIN_SUPPORT_FLOOR);
        let flat = plane_hypotheses(&input, &cfg).unwrap();
        let offs: Vec<f64> = flat.iter().map(|h| h.plane.offset).collect();
        assert_eq!(offs.len(), 3, "{flat:?}");
        for (o, t) in offs.iter().zip([0.5, 0.6, 0.7]) {
            assert!((o - t).abs() < r, "{o} vs {t}");
        }
        let gauss = plane_hypotheses(
            &input,
            &HypothesesConfig {
                kernel: Kernel::Gaussian,
                bandwidth_r: 1.0,
                ..cfg.clone()
            },
        )
        .unwrap();
        assert_eq!(gauss.len(), 3, "{gauss:?}");
        for (g, f) in gauss.iter().zip(&flat) {
            assert!((g.plane.offset - f.plane.offset).abs() < r);
        }
        // Paper threshold 50 without the relative rule drops the 30-point plane.
        let strict = plane_hypotheses(
            &input,
            &HypothesesConfig {
                min_support_fraction: 1.0,
                ..cfg.clone()
            },
        )
        .unwrap();
        assert_eq!(strict.len(), 2);
    }

    #[test]
    fn duplicate_directions_merge_and_bad_input_errors() {
        let d = Vector3::z();
        let d2 = Vector3::new(0.001, 0.0, 1.0).normalize();
        let pts: Vec<_> = (0..100)
            .map(|i| Vector3::new(i as f64 * 0.01, 0.0, 1.0))
            .collect();
        let normals = vec![d; 100];
        let conf = vec![1.0; 100];
        let axes = manual_axes(vec![d, d2]);
        let mut input = HypothesesInput {
            positions: &pts,
            normals: &normals,
            confidence: &conf,
            axes: &axes,
            scale: 0.01,
        };
        let hyps = plane_hypotheses(&input, &HypothesesConfig::default()).unwrap();
        assert_eq!(hyps.len(), 1, "{hyps:?}");
        assert_eq!(hyps[0].support, 100);
        assert!((hyps[0].plane.offset - 1.0).abs() < 1e-12);
        input.scale = 0.0;
        assert!(plane_hypotheses(&input, &HypothesesConfig::default()).is_err());
        input.scale = 0.01;
        input.confidence = &conf[..3];
        assert!(plane_hypotheses(&input, &HypothesesConfig::default()).is_err());
        assert!(HypothesesConfig {
            bandwidth_r: -1.0,
            ..Default::default()
        }
        .validate()
        .is_err());
    }

    #[test]
    fn deterministic_across_thread_counts() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let rot = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3);
        let (pts, _) = box_points(
            &mut rng,
            &rot,
            Vector3::zeros(),
            Vector3::new(1.0, 1.0, 1.0),
            400,
            0.01,
            200,
        );
        let normals: Vec<_> = pts
            .iter()
            .map(|p| (rot.inverse() * p).map(|v| if v.abs() > 0.98 { v.signum() } else { 0.0 }))
            .map(|v| {
                if v.norm() == 1.0 {
                    rot * v
                } else {
                    Vector3::x()
                }
            })
            .collect();
        let conf = vec![1.0; pts.len()];
        let axes = manual_axes(vec![rot * Vector3::x(), rot * Vector3::y(), Vector3::z()]);
        let input = HypothesesInput {
            positions: &pts,
            normals: &normals,
            confidence: &conf,
            axes: &axes,
            scale: 0.01,
        };
        let run = |t| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| plane_hypotheses(&input, &HypothesesConfig::default()).unwrap())
        };
        let a = run(1);
        assert_eq!(a, run(2));
        assert_eq!(a.len(), 6, "{a:?}");
    }

    /// Near-linear cost check (run with `--ignored`): 200k offsets on 40 planes.
    #[test]
    #[ignore]
    fn mean_shift_timing() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let x: Vec<f64> = (0..200_000)
            .map(|i| (i % 40) as f64 * 0.5 + rng.random_range(-0.01..0.01))
            .collect();
        for kernel in [Kernel::Flat, Kernel::Gaussian] {
            let t = std::time::Instant::now();
            let modes = mean_shift_modes(&Offsets::new(x.clone()), 0.02, kernel, 100);
            let strong = modes.iter().filter(|m| m.1 >= 50).count();
            eprintln!(
                "{kernel:?}: {} modes, {strong} strong, {:?}",
                modes.len(),
                t.elapsed()
            );
            assert_eq!(strong, 40);
        }
    }
}

// ---------------------------------------------------------------------------------------
// Crease hypotheses: planes through dominant image lines lifted onto labelled planes.
// ---------------------------------------------------------------------------------------

/// Settings of [`crease_hypotheses`], a third source of plane hypotheses for plain surfaces
/// that neither the points nor the photo-consistency sweep can place (a ceiling, the side
/// faces of a table or a cabinet).
///
/// A dominant line (an image edge toward a vanishing point, [`crate::planemap::lines`]) is
/// most often a crease or an occluding edge between two planes. Where the first labelling
/// puts one of those planes, the line's pixels lifted onto it are 3D points of the crease;
/// the other plane passes through them, and in a Manhattan scene its normal is one of the
/// other dominant axes. Each such pixel votes for the offset `d_k · X` of every axis `d_k`
/// not parallel to its plane's normal; an offset with enough votes from enough views that is
/// not already a hypothesis becomes one, and every view is labelled again with it (Sinha et
/// al. 2009 lift 3D line segments to planes in the same spirit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CreaseHypothesesConfig {
    /// Look for crease hypotheses (needs the images and costs a second labelling of every
    /// view when any is found).
    pub enabled: bool,
    /// Votes an offset needs, as a multiple of the image width (a line's length grows with
    /// the resolution). Offsets are binned at R; a peak pools its bin and the two beside it.
    pub min_votes_per_width: f64,
    /// ... from at least this many views.
    pub min_views: usize,
    /// An axis votes only if |d_k · n| is at most this for the labelled plane's normal n
    /// (0.7 ≈ 45°): a crease joins planes of different orientation.
    pub max_normal_cos: f64,
    /// A candidate within this many R of an existing hypothesis of the same direction is
    /// that hypothesis.
    pub merge_r: f64,
    /// A view *sees* a crease hypothesis when it cast at least this many votes for it, as a
    /// multiple of its image width; only those views count for `min_views`, and only they
    /// are offered the hypothesis as a label (the rest keep their first labelling there).
    /// Without it every view would carry every crease plane (room: 123 of them, 10× the
    /// labels and the solve time of the first pass).
    pub min_view_votes_per_width: f64,
}

impl Default for CreaseHypothesesConfig {
    fn default() -> Self {
        CreaseHypothesesConfig {
            enabled: true,
            min_votes_per_width: 1.25,
            min_views: 2,
            max_normal_cos: 0.7,
            merge_r: 3.0,
            min_view_votes_per_width: 0.25,
        }
    }
}

impl CreaseHypothesesConfig {
    /// Checks the fields.
    pub fn validate(&self) -> Result<(), HypothesesError> {
        let bad = |m: String| Err(HypothesesError::Config(format!("creases.{m}")));
        if !(self.min_votes_per_width > 0.0 && self.min_votes_per_width.is_finite()) {
            return bad(format!(
                "min_votes_per_width = {} must be positive",
                self.min_votes_per_width
            ));
        }
        if self.min_views == 0 {
            return bad("min_views must be ≥ 1".into());
        }
        if !(0.0..1.0).contains(&self.max_normal_cos) {
            return bad(format!(
                "max_normal_cos = {} must be in [0, 1)",
                self.max_normal_cos
            ));
        }
        if !(self.merge_r >= 0.0 && self.merge_r.is_finite()) {
            return bad(format!("merge_r = {} must be ≥ 0", self.merge_r));
        }
        if !(self.min_view_votes_per_width >= 0.0 && self.min_view_votes_per_width.is_finite()) {
            return bad(format!(
                "min_view_votes_per_width = {} must be ≥ 0",
                self.min_view_votes_per_width
            ));
        }
        Ok(())
    }
}

/// One view's first labelling, as [`crease_hypotheses`] reads it.
#[derive(Debug, Clone, Copy)]
pub struct LabelledView<'a> {
    /// Index into `Scene::views`.
    pub view_index: usize,
    /// Hypothesis index per pixel (row-major); anything out of range (no plane, the
    /// non-planar label) does not vote.
    pub labels: &'a [u32],
    /// Depth (camera z) per pixel; 0 = none.
    pub depth: &'a [f32],
    /// Dominant-line pixels of the view ([`crate::planemap::lines::dominant_line_mask`]).
    pub lines: &'a [bool],
}

/// A crease hypothesis and the views that see it (cast at least
/// [`CreaseHypothesesConfig::min_view_votes_per_width`] votes for it).
#[derive(Debug, Clone, PartialEq)]
pub struct CreaseHypothesis {
    /// The plane (support 0: no sparse points are counted).
    pub hypothesis: PlaneHypothesis,
    /// Indices into `Scene::views`, ascending.
    pub views: Vec<usize>,
}

/// Crease hypotheses from labelled views (see [`CreaseHypothesesConfig`]), sorted by axis
/// then offset, ids 0..; the caller renumbers them after the existing `hypotheses`. Only
/// the Manhattan axes (`axes.num_manhattan`) are used. Deterministic: votes are summed in
/// view and pixel order.
pub fn crease_hypotheses(
    scene: &Scene,
    axes: &DominantAxes,
    hypotheses: &[PlaneHypothesis],
    views: &[LabelledView<'_>],
    scale: f64,
    cfg: &CreaseHypothesesConfig,
) -> Result<Vec<CreaseHypothesis>, HypothesesError> {
    cfg.validate()?;
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(HypothesesError::Input(format!(
            "sampling scale {scale} must be positive and finite"
        )));
    }
    let m = axes.num_manhattan.min(axes.directions.len());
    let dirs: Vec<Vector3<f64>> = axes.directions[..m].iter().map(|d| d.normalize()).collect();
    // Per axis: offset bin (units of R) → (votes, sum of offsets, votes per view).
    type Bin = (u64, f64, Vec<u32>);
    let mut votes: Vec<std::collections::BTreeMap<i64, Bin>> = vec![Default::default(); m];
    let mut width = 0u32;
    let min_view_votes: Vec<u32> = scene
        .views
        .iter()
        .map(|v| ((cfg.min_view_votes_per_width * v.camera.width as f64).ceil() as u32).max(1))
        .collect();
    for lv in views {
        let view = scene.views.get(lv.view_index).ok_or_else(|| {
            HypothesesError::Input(format!("view index {} out of range", lv.view_index))
        })?;
        let (w, h) = (view.camera.width, view.camera.height);
        let n = w as usize * h as usize;
        if lv.labels.len() != n || lv.depth.len() != n || lv.lines.len() != n {
            return Err(HypothesesError::Input(format!(
                "view {}: labelling arrays are not {w}x{h}",
                view.name
            )));
        }
        width = width.max(w);
        let world_from_cam = view.cam_from_world.inverse();
        for p in (0..n).filter(|&p| lv.lines[p]) {
            let (label, z) = (lv.labels[p] as usize, lv.depth[p] as f64);
            if label >= hypotheses.len() || !(z > 0.0 && z.is_finite()) {
                continue;
            }
            let normal = hypotheses[label].plane.normal;
            let ray = view.camera.pixel_ray(p as u32 % w, p as u32 / w);
            let x = (world_from_cam * nalgebra::Point3::from(ray * z)).coords;
            for (k, d) in dirs.iter().enumerate() {
                if d.dot(&normal).abs() > cfg.max_normal_cos {
                    continue;
                }
                let o = d.dot(&x);
                let entry = votes[k]
                    .entry((o / scale).round() as i64)
                    .or_insert_with(|| (0, 0.0, vec![0; scene.views.len()]));
                entry.0 += 1;
                entry.1 += o;
                entry.2[lv.view_index] += 1;
            }
        }
    }
    let min_votes = (cfg.min_votes_per_width * width as f64).ceil() as u64;
    let mut out: Vec<CreaseHypothesis> = Vec::new();
    for (k, map) in votes.iter().enumerate() {
        let count = |b: i64| map.get(&b).map_or(0, |e| e.0);
        for (&b, bin) in map {
            // A local maximum (ties to the left bin) of the pooled three-bin window.
            let pooled = |c: i64| count(c - 1) + count(c) + count(c + 1);
            let here = pooled(b);
            if here < min_votes || pooled(b - 1) > here || pooled(b + 1) >= here {
                continue;
            }
            let mut sum = 0.0;
            let mut per_view = bin.2.clone();
            for e in [b - 1, b + 1].iter().filter_map(|c| map.get(c)) {
                sum += e.1;
                for (s, &t) in per_view.iter_mut().zip(&e.2) {
                    *s += t;
                }
            }
            let seeing: Vec<usize> = (0..per_view.len())
                .filter(|&v| per_view[v] >= min_view_votes[v])
                .collect();
            if seeing.len() < cfg.min_views {
                continue;
            }
            let offset = (sum + bin.1) / here as f64;
            let d = dirs[k];
            let known = hypotheses
                .iter()
                .chain(out.iter().map(|c| &c.hypothesis))
                .any(|h| {
                    let c = h.plane.normal.dot(&d);
                    c.abs() >= 1.0f64.to_radians().cos()
                        && (h.plane.offset - c.signum() * offset).abs() < cfg.merge_r * scale
                });
            if !known {
                out.push(CreaseHypothesis {
                    hypothesis: PlaneHypothesis {
                        id: out.len() as u32,
                        plane: Plane { normal: d, offset },
                        axis: Some(k),
                        support: 0,
                    },
                    views: seeing,
                });
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod crease_tests {
    use super::*;
    use crate::planemap::testutil::corner_views;

    /// Per view: labels, depth, dominant-line mask.
    type Labelling = (Vec<u32>, Vec<f32>, Vec<bool>);

    /// Every pixel of three views labelled with the wall x = 0, and a horizontal line on
    /// that wall at z = 0.7 marked as a dominant line: the z axis gets a plane at 0.7.
    fn wall_with_line(z_line: f64) -> (Scene, Vec<Labelling>) {
        let views = corner_views();
        let mut labelled = Vec::new();
        for v in &views {
            let (w, h) = (v.camera.width, v.camera.height);
            let world_from_cam = v.cam_from_world.inverse();
            let centre = v.center();
            let mut depth = vec![0.0f32; (w * h) as usize];
            let mut lines = vec![false; (w * h) as usize];
            for y in 0..h {
                for x in 0..w {
                    let ray = v.camera.pixel_ray(x, y);
                    let dir = world_from_cam.rotation * ray;
                    // Camera-z depth where the ray meets x = 0.
                    let t = -centre.x / dir.x;
                    if t.is_nan() || t <= 0.0 {
                        continue;
                    }
                    let p = centre + dir * t;
                    let i = (y * w + x) as usize;
                    depth[i] = t as f32;
                    // The line: within half a pixel's footprint of z = z_line.
                    lines[i] = (p.z - z_line).abs() < 0.5 * t / v.camera.fx();
                }
            }
            labelled.push((vec![0u32; (w * h) as usize], depth, lines));
        }
        let scene = Scene {
            views,
            cloud: crate::scene::SparseCloud::default(),
        };
        (scene, labelled)
    }

    fn axes() -> DominantAxes {
        DominantAxes {
            directions: vec![Vector3::x(), Vector3::y(), Vector3::z()],
            support: vec![100; 3],
            pairwise_angles_deg: vec![(0, 1, 90.0), (0, 2, 90.0), (1, 2, 90.0)],
            num_manhattan: 3,
            warnings: Vec::new(),
        }
    }

    fn wall() -> PlaneHypothesis {
        PlaneHypothesis {
            id: 0,
            plane: Plane {
                normal: Vector3::x(),
                offset: 0.0,
            },
            axis: Some(0),
            support: 50,
        }
    }

    fn run(
        scene: &Scene,
        labelled: &[Labelling],
        hyps: &[PlaneHypothesis],
        cfg: &CreaseHypothesesConfig,
    ) -> Vec<CreaseHypothesis> {
        let lv: Vec<LabelledView> = labelled
            .iter()
            .enumerate()
            .map(|(i, (l, d, m))| LabelledView {
                view_index: i,
                labels: l,
                depth: d,
                lines: m,
            })
            .collect();
        crease_hypotheses(scene, &axes(), hyps, &lv, 0.01, cfg).unwrap()
    }

    #[test]
    fn a_line_on_a_labelled_wall_proposes_the_plane_through_it() {
        let (scene, labelled) = wall_with_line(0.7);
        let cfg = CreaseHypothesesConfig {
            min_votes_per_width: 0.5,
            ..Default::default()
        };
        let found = run(&scene, &labelled, &[wall()], &cfg);
        assert_eq!(found.len(), 1, "{found:?}");
        let h = &found[0].hypothesis;
        assert_eq!(h.axis, Some(2));
        assert!((h.plane.offset - 0.7).abs() < 0.01, "{}", h.plane.offset);
        assert_eq!(found[0].views, vec![0, 1, 2]);
        // The wall's own axis never votes (parallel to its normal); nor does y, whose
        // votes spread along the line.
        assert!(found.iter().all(|c| c.hypothesis.axis != Some(0)));
        // A view without the line does not see the crease and is not offered it.
        let mut two = labelled.clone();
        two[1].2.iter_mut().for_each(|m| *m = false);
        let found = run(&scene, &two, &[wall()], &cfg);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].views, vec![0, 2]);
        // A view must cast enough votes to count.
        let picky = CreaseHypothesesConfig {
            min_view_votes_per_width: 50.0,
            ..cfg
        };
        assert!(run(&scene, &labelled, &[wall()], &picky).is_empty());
        // Already a hypothesis: nothing new.
        let mut known = vec![wall()];
        known.push(PlaneHypothesis {
            id: 1,
            plane: Plane {
                normal: -Vector3::z(),
                offset: -0.705,
            },
            axis: Some(2),
            support: 10,
        });
        assert!(run(&scene, &labelled, &known, &cfg).is_empty());
        // More views required than see it, or more votes than the line has: nothing.
        let strict = CreaseHypothesesConfig {
            min_views: 4,
            ..cfg
        };
        assert!(run(&scene, &labelled, &[wall()], &strict).is_empty());
        let long = CreaseHypothesesConfig {
            min_votes_per_width: 50.0,
            ..cfg
        };
        assert!(run(&scene, &labelled, &[wall()], &long).is_empty());
    }

    #[test]
    fn unlabelled_pixels_do_not_vote_and_bad_sizes_are_errors() {
        let (scene, mut labelled) = wall_with_line(0.7);
        for (l, _, _) in &mut labelled {
            l.iter_mut().for_each(|x| *x = 7); // no such hypothesis
        }
        let cfg = CreaseHypothesesConfig {
            min_votes_per_width: 0.5,
            ..Default::default()
        };
        assert!(run(&scene, &labelled, &[wall()], &cfg).is_empty());
        labelled[0].2.pop();
        let lv = [LabelledView {
            view_index: 0,
            labels: &labelled[0].0,
            depth: &labelled[0].1,
            lines: &labelled[0].2,
        }];
        assert!(crease_hypotheses(&scene, &axes(), &[wall()], &lv, 0.01, &cfg).is_err());
    }
}
