//! The "non-planar" label: the planar prior restricted to planar regions (Gallup, Frahm and
//! Pollefeys, CVPR 2010).
//!
//! With `[nonplanar] enabled`, a view's label set gains one label beyond its planes. Its depth
//! at each pixel is ordinary plane-sweep stereo (the baseline's plane families and neighbours,
//! [`sweep_setup`], winner-takes-all with sub-plane refinement,
//! [`crate::photo::multi_family_sweep`]); its data cost is the planar/non-planar
//! classifier's ([`crate::classify`]) `β·(−ln(1 − P + ε))` plus the photo term's weight times
//! the sweep's winning cost, while every plane label pays `β·(−ln(P + ε))` on top of its
//! visibility and photo costs, P being the classifier's probability that the pixel is planar.
//! Plane labels also pay a *fit gap* (a label-free geometric cue): up to γ where the view's
//! best plane, scored with the sweep's own measure, matches the neighbours worse than the
//! sweep's winner does ([`NonplanarConfig::fit_gap_weight`]).
//! The smoothness term is unchanged in form: the truncated 3D gap, in units of R, between the
//! two labels' depths on the ray through the pixel pair's midpoint, where the non-planar
//! label's depth on that ray is the mean of the two pixels' sweep depths (or the one that
//! exists). All depths are taken on the same ray, so V stays a truncated metric and
//! α-expansion stays exact.
//!
//! The label is infeasible where the sweep found no depth. Outputs: the sweep depth at
//! non-planar pixels, normals from the depth map's gradient, label [`NONPLANAR`] (written as 0
//! in the 16-bit planemap PNG, like "no plane").
//!
//! After every view is labelled, a multi-view confirmation ([`sweep_confirmations`],
//! `crate::pipeline::confirm_nonplanar`) also makes non-planar the textured pixels whose
//! sweep depth [`NonplanarConfig::consistent_views`] other views agree with and that no plane
//! fits as well — what the classifier misses on grey stone.

use std::path::PathBuf;

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::classify::{PlanarityMap, PlanarityModel, ViewPoints};
use crate::geometry::Plane;
use crate::photo::plane_cost_volume;
use crate::photo::{sweep_setup, texture_mask, MultiSweepConfig};
use crate::planemap::{PlanemapConfig, PlanemapEnergy, PlanemapError};
use crate::raster::ImageF32;
use crate::scene::Scene;

/// The global label of a non-planar pixel in [`crate::pipeline::ViewPlanemap::labels`].
pub const NONPLANAR: u32 = u32::MAX;

/// Settings of the non-planar label (`[nonplanar]` in the run's TOML config).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct NonplanarConfig {
    /// Add the non-planar label. Off: it gains only on scenes with trees and statues,
    /// costs a Manhattan building up to a point of accuracy and takes about 3× the time
    /// (docs/notes/nonplanar-classifier.md).
    pub enabled: bool,
    /// Classifier model file (`planemap classify train`); `None` = the built-in default model.
    pub model: Option<PathBuf>,
    /// β, the weight of the classifier's costs, in data-cost units, ≥ 0: a plane label at
    /// a pixel the classifier calls surely non-planar pays up to β·ln(1/ε) more. Chosen
    /// together with `consistent_views` and the label sweep's support weights on statues,
    /// whose grey stone the classifier calls planar (docs/notes/nonplanar-classifier.md).
    pub beta: f64,
    /// ε in the classifier's costs `−ln(P + ε)`, in (0, 1]: bounds a confident mistake's
    /// cost.
    pub epsilon: f64,
    /// The plane sweep that gives the label its depth ([`crate::photo::multisweep`]): the
    /// sweep baseline's guided-filtered 5×5 NCC, but 64 planes per family at a 1 px step,
    /// 4 neighbours (the best 2 averaged), support weights σc 0.15 and no semi-global
    /// aggregation. The plane counts and step are those the label was tuned with; the
    /// support weights keep a statue's depth halo off the facade behind it; the label's
    /// confidence gate and confirmation read the raw winner-takes-all costs, and
    /// semi-global paths would pull trees and statues onto the wall behind them
    /// (docs/notes/nonplanar-classifier.md).
    pub sweep: MultiSweepConfig,
    /// The label is allowed only where the sweep is at least this confident (second-best
    /// minus best cost, [`crate::photo::SweepResult::confidence`]), in cost units in
    /// [0, 1]: where the best depth is ambiguous (plain paint, glass) the sweep's depth
    /// means nothing and the planes must decide (without the gate it replaced glass's
    /// facade).
    pub min_confidence: f64,
    /// Where the classifier's `P(planar)` is below this, the label is allowed wherever the
    /// sweep has a depth, however unsure (`min_confidence` applies elsewhere); a
    /// probability in [0, 1], 0 = off. Where the classifier is sure a pixel is not planar,
    /// a plane forced onto it is worse than an ambiguous sweep depth; higher thresholds
    /// reach glass's planar-looking reflections (docs/notes/nonplanar-classifier.md).
    pub sure_nonplanar_below: f64,
    /// γ of the fit-gap cost (a label-free geometric cue), in data-cost units, ≥ 0,
    /// 0 = off: every plane label pays `γ·g`,
    /// `g = clamp((C_plane − C_sweep) / fit_gap_scale, 0, 1)`, where `C_sweep` is the
    /// sweep's winning cost and `C_plane` the lowest cost of the view's plane labels under
    /// the same measure and neighbours. Where every plane explains the pixel clearly worse
    /// than the free-form sweep depth (statues, trees) the planes pay up to γ more; where
    /// some plane does as well nothing changes. The largest γ that keeps statues' planar
    /// pixels at 95 % (docs/notes/nonplanar-classifier.md).
    pub fit_gap_weight: f64,
    /// The cost difference, in photo-consistency cost units (> 0), that counts as a full
    /// gap (`g = 1`).
    pub fit_gap_scale: f64,
    /// Multi-view confirmation, after every view is labelled (MVS fusion's geometric
    /// consistency, used as a label decision): a pixel whose sweep depth at least this many
    /// *other* views' sweep depths confirm (the point, projected into them, lands on a
    /// pixel whose sweep depth agrees within `consistency_tolerance`) becomes non-planar
    /// with that depth wherever its label's depth differs by more than the tolerance. Only
    /// textured pixels where no plane label fits the images as well as the sweep take part
    /// ([`NonplanarView::confirmable_depth`]; [`sweep_confirmations`]). A count of views,
    /// 0 = off. Fewer views also confirm the halo a statue's sweep depth leaves on the
    /// facade behind it (docs/notes/nonplanar-classifier.md).
    pub consistent_views: usize,
    /// Relative depth tolerance of that confirmation and of "differs", in (0, 1): the
    /// benchmark's 1 % scoring tolerance.
    pub consistency_tolerance: f64,
    /// Pixels within this many pixels (Chebyshev) of a jump of more than 5 % in the sweep's
    /// depth map (between 4-neighbours) are never confirmed, a count: a window straddling a
    /// silhouette lends the near depth to the far side (the "halo"), consistently in every
    /// view. Set on statues (docs/notes/nonplanar-classifier.md).
    pub consistency_edge_px: usize,
    /// The confirmation's *gross tier*: a pixel whose labelled depth is more than this far
    /// from its sweep depth (relative to the sweep's depth; ≥ 0, 0 = off) also becomes
    /// non-planar when `consistent_views` other views agree with that sweep depth within
    /// [`Self::gross_tolerance`]. On rough, curved stone the views' sweep depths wander by
    /// a few per cent, so the 1 % agreement never comes, while a plane metres behind a
    /// statue is the label's worst case: such far-off pixels carried most of statues'
    /// non-planar error (docs/notes/nonplanar-classifier.md).
    pub gross_gap: f64,
    /// Relative agreement between views that the gross tier accepts, in (0, 1): rough,
    /// curved stone agrees within a few per cent.
    pub gross_tolerance: f64,
    /// Pixels within this many pixels (Chebyshev) of a jump in the sweep's depth map are
    /// not confirmed by the gross tier, a count: its looser agreement also accepts the halo
    /// a tree lends the wall behind it, which reaches further from the silhouette than
    /// [`Self::consistency_edge_px`]; the default keeps the canopies' halo out.
    pub gross_edge_px: usize,
}

impl Default for NonplanarConfig {
    fn default() -> Self {
        NonplanarConfig {
            enabled: false,
            model: None,
            beta: 0.5,
            epsilon: 0.01,
            sweep: default_sweep(),
            min_confidence: 0.1,
            sure_nonplanar_below: 0.3,
            fit_gap_weight: 1.0,
            fit_gap_scale: 0.2,
            consistent_views: 3,
            consistency_tolerance: 0.01,
            consistency_edge_px: 2,
            gross_gap: 0.2,
            gross_tolerance: 0.05,
            gross_edge_px: 5,
        }
    }
}

/// The default sweep of the non-planar label: the baseline's scoring with 64 planes per
/// family at a 1 px step, 4 neighbours (the best half averaged), σc 0.15, and
/// winner-takes-all on the raw costs (no semi-global aggregation).
fn default_sweep() -> MultiSweepConfig {
    let base = MultiSweepConfig::default();
    MultiSweepConfig {
        planes: 64,
        axis_planes: 64,
        axis_families: true,
        max_step_px: 1.0,
        photo: crate::photo::PhotoConfig {
            neighbours: 4,
            best_k: 2,
            support_sigma_color: 0.15,
            ..base.photo
        },
        sgm: crate::photo::SgmConfig::default(),
        ..base
    }
}

impl NonplanarConfig {
    /// Checks the values.
    pub fn validate(&self) -> Result<(), PlanemapError> {
        let bad =
            |field: &'static str, message: String| Err(PlanemapError::Config { field, message });
        if !(self.beta.is_finite() && self.beta >= 0.0) {
            return bad(
                "nonplanar.beta",
                format!("= {} must be finite and ≥ 0", self.beta),
            );
        }
        if !(self.epsilon.is_finite() && self.epsilon > 0.0 && self.epsilon <= 1.0) {
            return bad(
                "nonplanar.epsilon",
                format!("= {} must be in (0, 1]", self.epsilon),
            );
        }
        if self.sweep.planes < 2 {
            return bad(
                "nonplanar.sweep.planes",
                format!("= {} must be ≥ 2", self.sweep.planes),
            );
        }
        if let Err(e) = self.sweep.validate() {
            return bad("nonplanar.sweep", e.to_string());
        }
        if !(self.min_confidence.is_finite() && (0.0..=1.0).contains(&self.min_confidence)) {
            return bad(
                "nonplanar.min_confidence",
                format!("= {} must be in [0, 1]", self.min_confidence),
            );
        }
        if !(0.0..=1.0).contains(&self.sure_nonplanar_below) {
            return bad(
                "nonplanar.sure_nonplanar_below",
                format!("= {} must be in [0, 1]", self.sure_nonplanar_below),
            );
        }
        if !(self.fit_gap_weight.is_finite() && self.fit_gap_weight >= 0.0) {
            return bad(
                "nonplanar.fit_gap_weight",
                format!("= {} must be finite and ≥ 0", self.fit_gap_weight),
            );
        }
        if !(self.fit_gap_scale.is_finite() && self.fit_gap_scale > 0.0) {
            return bad(
                "nonplanar.fit_gap_scale",
                format!("= {} must be finite and > 0", self.fit_gap_scale),
            );
        }
        let tol = self.consistency_tolerance;
        if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
            return bad(
                "nonplanar.consistency_tolerance",
                format!("= {tol} must be in (0, 1)"),
            );
        }
        let tol = self.gross_tolerance;
        if !(tol.is_finite() && tol > 0.0 && tol < 1.0) {
            return bad(
                "nonplanar.gross_tolerance",
                format!("= {tol} must be in (0, 1)"),
            );
        }
        if !(self.gross_gap.is_finite() && self.gross_gap >= 0.0) {
            return bad(
                "nonplanar.gross_gap",
                format!("= {} must be finite and ≥ 0", self.gross_gap),
            );
        }
        Ok(())
    }

    /// The non-planar label's depth at a pixel whose sweep gave depth `z` with confidence
    /// `confidence` where the classifier's `P(planar)` is `p_planar`: `z` when the sweep is
    /// at least `min_confidence` sure or the classifier is surer than
    /// `sure_nonplanar_below` that the pixel is not planar; 0 (label infeasible) otherwise
    /// or when the sweep found no depth.
    pub fn label_depth(&self, z: f32, confidence: f32, p_planar: f32) -> f32 {
        let sure = confidence as f64 >= self.min_confidence
            || (p_planar as f64) < self.sure_nonplanar_below;
        if z.is_finite() && z > 0.0 && sure {
            z
        } else {
            0.0
        }
    }
}

fn photo_err(e: crate::photo::PhotoError) -> PlanemapError {
    PlanemapError::Input(format!("non-planar sweep: {e}"))
}

/// One view's non-planar evidence: the classifier's map and the sweep's depth and cost.
#[derive(Debug, Clone)]
pub struct NonplanarView {
    /// `P(planar)` per pixel.
    pub planarity: PlanarityMap,
    /// Sweep depth per pixel (camera z); 0 where the sweep found none or was less confident
    /// than `min_confidence`.
    pub depth: Vec<f32>,
    /// The sweep's winning photo-consistency cost per pixel in [0, 1] (1 where none).
    pub cost: Vec<f32>,
    /// The sweep's depth wherever the reference image is textured (grey-level std ≥ 0.02
    /// over 7×7, [`texture_mask`]), whatever its confidence; 0 elsewhere.
    /// What the multi-view confirmation ([`sweep_confirmations`]) checks: agreement between
    /// views is a stronger test of a depth than the margin over the second-best plane, which
    /// shrinks as the planes get denser; on plain paint every view can agree on a wrong
    /// depth, hence the texture mask.
    pub textured_depth: Vec<f32>,
    /// The lowest cost of the view's plane labels per pixel, scored like the sweep (same
    /// measure, aggregation and neighbours; 1 where none); empty when not computed
    /// (`fit_gap_weight` = 0).
    pub best_plane_cost: Vec<f32>,
}

impl NonplanarView {
    /// Classifies view `view_index` of an undistorted scene (`images` holds every view's
    /// image), sweeps it along `axes` (world directions) and, when `cfg.fit_gap_weight > 0`,
    /// scores the view's plane labels `planes` the way the sweep scores its planes:
    /// [`NonplanarView::sweep`] then [`NonplanarView::with_plane_costs`].
    pub fn compute(
        scene: &Scene,
        images: &[ImageF32],
        view_index: usize,
        axes: &[Vector3<f64>],
        planes: &[Plane],
        model: &PlanarityModel,
        cfg: &NonplanarConfig,
    ) -> Result<Self, PlanemapError> {
        Self::sweep(scene, images, view_index, axes, model, cfg)?
            .with_plane_costs(scene, images, view_index, axes, planes, cfg)
    }

    /// The part that does not depend on the plane labels: the classifier's map and the
    /// sweep (`best_plane_cost` left empty). The pipeline computes it once per view and
    /// reuses it in the labelling after the crease hypotheses.
    pub fn sweep(
        scene: &Scene,
        images: &[ImageF32],
        view_index: usize,
        axes: &[Vector3<f64>],
        model: &PlanarityModel,
        cfg: &NonplanarConfig,
    ) -> Result<Self, PlanemapError> {
        let image = &images[view_index];
        let points = ViewPoints::from_scene(scene, view_index);
        let planarity = model
            .planarity_map(image, Some(&points))
            .map_err(|e| PlanemapError::Input(format!("planarity classifier: {e}")))?;
        let n = image.width as usize * image.height as usize;
        let sweep_cfg = &cfg.sweep;
        // No neighbour or no points: the label has no depth anywhere (infeasible).
        let Ok(setup) = sweep_setup(scene, view_index, axes, sweep_cfg) else {
            return Ok(NonplanarView {
                planarity,
                depth: vec![0.0; n],
                cost: vec![1.0; n],
                textured_depth: vec![0.0; n],
                best_plane_cost: Vec::new(),
            });
        };
        let sweep = setup
            .sweep(scene, images, view_index, sweep_cfg)
            .map_err(photo_err)?;
        let depth = sweep
            .depth
            .iter()
            .zip(&sweep.confidence)
            .zip(&planarity.planar)
            .map(|((&z, &c), &p_planar)| cfg.label_depth(z, c, p_planar))
            .collect();
        let textured = texture_mask(image, 3, 0.02);
        let textured_depth = sweep
            .depth
            .iter()
            .zip(&textured)
            .map(|(&z, &t)| {
                if t && z.is_finite() && z > 0.0 {
                    z
                } else {
                    0.0
                }
            })
            .collect();
        Ok(NonplanarView {
            planarity,
            depth,
            cost: sweep.cost,
            textured_depth,
            best_plane_cost: Vec::new(),
        })
    }

    /// Adds the fit gap's plane costs (when `cfg.fit_gap_weight > 0`): the view's planes
    /// scored with the sweep's measure and neighbours. Without neighbours they stay empty.
    pub fn with_plane_costs(
        mut self,
        scene: &Scene,
        images: &[ImageF32],
        view_index: usize,
        axes: &[Vector3<f64>],
        planes: &[Plane],
        cfg: &NonplanarConfig,
    ) -> Result<Self, PlanemapError> {
        self.best_plane_cost = Vec::new();
        if cfg.fit_gap_weight.is_nan() || cfg.fit_gap_weight <= 0.0 || planes.is_empty() {
            return Ok(self);
        }
        let sweep_cfg = &cfg.sweep;
        let Ok(setup) = sweep_setup(scene, view_index, axes, sweep_cfg) else {
            return Ok(self);
        };
        let image = &images[view_index];
        let n = image.width as usize * image.height as usize;
        let pairs = setup.pairs(scene, images);
        let view = &scene.views[view_index];
        let volume =
            plane_cost_volume(view, image, &pairs, planes, &sweep_cfg.photo).map_err(photo_err)?;
        self.best_plane_cost = (0..n)
            .map(|p| volume.pixel_costs(p).iter().copied().fold(1.0f32, f32::min))
            .collect();
        Ok(self)
    }

    /// The depths the multi-view confirmation may adopt: [`Self::textured_depth`] where no
    /// plane label fits the images as well as the sweep's depth (the view's best plane costs
    /// more than the sweep's winner under the same measure; everywhere when the plane costs
    /// were not computed), 0 elsewhere. Where some plane fits as well, a confirmed sweep depth
    /// that differs from the labelled plane is more likely the sweep's own bias — every view
    /// sweeps the same plane families, so a step off is the same 3D plane in all of them —
    /// than a surface no plane explains.
    pub fn confirmable_depth(&self) -> Vec<f32> {
        if self.best_plane_cost.len() != self.textured_depth.len() {
            return self.textured_depth.clone();
        }
        self.textured_depth
            .iter()
            .zip(&self.cost)
            .zip(&self.best_plane_cost)
            .map(|((&z, &c), &b)| if b > c { z } else { 0.0 })
            .collect()
    }

    /// The fit-gap cost of the plane labels at pixel `p` ([`NonplanarConfig::fit_gap_weight`]);
    /// 0 when the plane costs were not computed.
    pub fn fit_gap_cost(&self, p: usize, cfg: &NonplanarConfig) -> f32 {
        let Some(&plane) = self.best_plane_cost.get(p) else {
            return 0.0;
        };
        let g = ((plane - self.cost[p]) as f64 / cfg.fit_gap_scale).clamp(0.0, 1.0);
        (cfg.fit_gap_weight * g) as f32
    }

    /// Pixels where the non-planar label is allowed (the sweep gave a depth).
    pub fn feasible_sites(&self) -> Vec<u32> {
        (0..self.depth.len() as u32)
            .filter(|&p| self.depth[p as usize] > 0.0)
            .collect()
    }
}

/// A view's energy with the non-planar label appended as local label `planes.num_labels()`.
#[derive(Debug)]
pub struct ExtendedEnergy<'a> {
    /// The planar energy (its `unary` already carries the classifier's planar cost:
    /// [`add_classifier_costs`]).
    pub planar: &'a PlanemapEnergy,
    /// The non-planar evidence.
    pub evidence: &'a NonplanarView,
    /// Data cost of the non-planar label per pixel ([`add_classifier_costs`]).
    pub unary_np: Vec<f32>,
}

/// Adds the classifier's planar cost `β·(−ln(P + ε))` to every plane label of `energy` and
/// returns the non-planar label's data cost per pixel: `β·(−ln(1 − P + ε))` plus the photo
/// term's weight times the sweep's winning cost. The plane labels also pay the fit-gap cost
/// ([`NonplanarView::fit_gap_cost`]).
pub fn add_classifier_costs(
    energy: &mut PlanemapEnergy,
    evidence: &NonplanarView,
    cfg: &NonplanarConfig,
    planemap: &PlanemapConfig,
) -> Result<Vec<f32>, PlanemapError> {
    let costs = evidence
        .planarity
        .unary_costs(cfg.beta as f32, cfg.epsilon as f32)
        .map_err(|e| PlanemapError::Input(format!("planarity costs: {e}")))?;
    let labels = energy.num_labels();
    if labels == 0 || costs.planar.len() * labels != energy.unary.len() {
        return Err(PlanemapError::Input(format!(
            "planarity map of {} pixels for an energy of {} values and {labels} labels",
            costs.planar.len(),
            energy.unary.len()
        )));
    }
    for (p, (row, &c)) in energy
        .unary
        .chunks_exact_mut(labels)
        .zip(&costs.planar)
        .enumerate()
    {
        let c = c + evidence.fit_gap_cost(p, cfg);
        for u in row {
            *u += c;
        }
    }
    let w = planemap.photo_weight as f32;
    Ok(costs
        .nonplanar
        .iter()
        .zip(&evidence.cost)
        .map(|(&c, &photo)| c + w * photo)
        .collect())
}

impl ExtendedEnergy<'_> {
    /// Local index of the non-planar label.
    pub fn nonplanar_label(&self) -> u32 {
        self.planar.num_labels() as u32
    }

    /// Number of labels including the non-planar one.
    pub fn num_labels(&self) -> usize {
        self.planar.num_labels() + 1
    }

    /// Data cost of pixel `p` for local label `a` (planes, then the non-planar label).
    pub fn unary(&self, p: usize, a: u32) -> f32 {
        if a == self.nonplanar_label() {
            self.unary_np[p]
        } else {
            self.planar.unary(p, a)
        }
    }

    /// Dense data costs, `[pixel · num_labels + label]`.
    pub fn dense_unary(&self) -> Vec<f32> {
        let l = self.planar.num_labels();
        let mut out = Vec::with_capacity(self.unary_np.len() * (l + 1));
        for (row, &np) in self.planar.unary.chunks_exact(l).zip(&self.unary_np) {
            out.extend_from_slice(row);
            out.push(np);
        }
        out
    }

    /// Depth (camera z) of the non-planar label on the midpoint ray of pixels `p`, `q`: the
    /// mean of their sweep depths, or the one that exists.
    fn np_depth(&self, p: usize, q: usize) -> Option<f64> {
        let (zp, zq) = (self.evidence.depth[p], self.evidence.depth[q]);
        match (zp > 0.0, zq > 0.0) {
            (true, true) => Some(0.5 * (zp as f64 + zq as f64)),
            (true, false) => Some(zp as f64),
            (false, true) => Some(zq as f64),
            (false, false) => None,
        }
    }

    /// λ·w_pq·V_pq(a, b) for local labels including the non-planar one.
    pub fn pairwise(&self, p: usize, q: usize, a: u32, b: u32) -> f32 {
        if a == b {
            return 0.0;
        }
        let np = self.nonplanar_label();
        if a != np && b != np {
            return self.planar.pairwise(p, q, a, b);
        }
        let plane = if a == np { b } else { a };
        let s = &self.planar.smoothness;
        let ray = s.midpoint_ray(p, q);
        let v = match (self.np_depth(p, q), s.depth(&ray, plane)) {
            (Some(z_np), Some(z_pl)) => {
                let gap = (z_np - z_pl).abs() * ray.norm() * s.inv_scale();
                (gap as f32).min(s.truncation())
            }
            _ => s.truncation(),
        };
        self.planar.lambda
            * self.planar.weights.between(p, q)
            * v.max(self.planar.crease_floor(p, q))
    }

    /// Total energy of a labelling in local labels (real units).
    pub fn energy(&self, labels: &[u32]) -> f64 {
        let (w, h) = (self.planar.width as usize, self.planar.height as usize);
        let mut e = 0.0f64;
        for y in 0..h {
            for x in 0..w {
                let p = y * w + x;
                e += self.unary(p, labels[p]) as f64;
                if x + 1 < w {
                    e += self.pairwise(p, p + 1, labels[p], labels[p + 1]) as f64;
                }
                if y + 1 < h {
                    e += self.pairwise(p, p + w, labels[p], labels[p + w]) as f64;
                }
            }
        }
        e
    }
}

/// How many other views confirm each pixel's sweep depth in view `view_index`
/// ([`NonplanarConfig::consistent_views`]). `sweep_depths[j]` is view `j`'s sweep depth
/// (camera z per pixel, row-major, 0 = none) or `None` where unknown; views without one
/// neither confirm nor get counts (all 0). Pixel `p` with depth `z` is back-projected
/// through its centre, projected into each other view `j`, and counted when the pixel it
/// lands in holds a depth within `tolerance · z_j` of the point's depth `z_j` there. Pixels
/// without a depth, and those within `edge_px` (Chebyshev) of a depth jump of more than 5 %
/// between 4-neighbours of view `view_index`'s map, get 0.
pub fn sweep_confirmations(
    scene: &Scene,
    view_index: usize,
    sweep_depths: &[Option<&[f32]>],
    tolerance: f64,
    edge_px: usize,
) -> Vec<u16> {
    sweep_confirmation_tiers(scene, view_index, sweep_depths, &[(tolerance, edge_px)])
        .pop()
        .unwrap_or_default()
}

/// [`sweep_confirmations`] for several `(tolerance, edge_px)` tiers at once (the
/// confirmation's strict and gross tiers): each pixel is projected into the other views
/// once, and one count map per tier is returned, in the tiers' order.
pub fn sweep_confirmation_tiers(
    scene: &Scene,
    view_index: usize,
    sweep_depths: &[Option<&[f32]>],
    tiers: &[(f64, usize)],
) -> Vec<Vec<u16>> {
    let view = &scene.views[view_index];
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let k = tiers.len();
    let Some(Some(depth)) = sweep_depths.get(view_index) else {
        return vec![vec![0; w * h]; k];
    };
    if depth.len() != w * h {
        return vec![vec![0; w * h]; k];
    }
    // Depth jumps, then every pixel within edge_px of one.
    let jump = |a: f32, b: f32| a > 0.0 && b > 0.0 && (a - b).abs() > 0.05 * a.min(b);
    let mut edge = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            if x + 1 < w && jump(depth[p], depth[p + 1]) {
                edge[p] = true;
                edge[p + 1] = true;
            }
            if y + 1 < h && jump(depth[p], depth[p + w]) {
                edge[p] = true;
                edge[p + w] = true;
            }
        }
    }
    let near_edge: Vec<Vec<bool>> = tiers
        .iter()
        .map(|&(_, edge_px)| dilate(&edge, w, h, edge_px))
        .collect();
    let others: Vec<(&crate::scene::View, &[f32])> = sweep_depths
        .iter()
        .enumerate()
        .filter(|&(j, d)| j != view_index && d.is_some())
        .filter_map(|(j, d)| {
            let v = scene.views.get(j)?;
            let d = (*d)?;
            (d.len() == v.camera.width as usize * v.camera.height as usize).then_some((v, d))
        })
        .collect();
    let (origin, _) = view.ray(&nalgebra::Vector2::new(0.5, 0.5));
    // Interleaved: pixel p's count for tier t at p·k + t.
    let mut counts = vec![0u16; w * h * k];
    counts
        .par_chunks_mut((w * k).max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, c) in row.chunks_mut(k.max(1)).enumerate() {
                let p = y * w + x;
                let z = depth[p];
                if z.is_nan() || z <= 0.0 || near_edge.iter().all(|e| e[p]) {
                    continue;
                }
                let (_, dir) = view.ray(&nalgebra::Vector2::new(x as f64 + 0.5, y as f64 + 0.5));
                let point = origin + dir * z as f64;
                for (other, d) in &others {
                    let Some((xy, zj)) = other.project(&point) else {
                        continue;
                    };
                    if zj.is_nan() || zj <= 0.0 || !other.camera.contains(&xy) {
                        continue;
                    }
                    let q = xy.y as usize * other.camera.width as usize + xy.x as usize;
                    let dj = d[q] as f64;
                    if dj <= 0.0 {
                        continue;
                    }
                    for ((n, &(tolerance, _)), edge) in c.iter_mut().zip(tiers).zip(&near_edge) {
                        if !edge[p] && (dj - zj).abs() <= tolerance * zj {
                            *n += 1;
                        }
                    }
                }
            }
        });
    (0..k)
        .map(|t| counts.iter().skip(t).step_by(k).copied().collect())
        .collect()
}

/// `mask` grown by `radius` pixels (a (2r+1)² square), separably.
fn dilate(mask: &[bool], w: usize, h: usize, radius: usize) -> Vec<bool> {
    if radius == 0 {
        return mask.to_vec();
    }
    let mut rows = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (x.saturating_sub(radius), (x + radius).min(w - 1));
            rows[y * w + x] = mask[y * w + a..=y * w + b].iter().any(|&m| m);
        }
    }
    let mut out = vec![false; w * h];
    for y in 0..h {
        let (a, b) = (y.saturating_sub(radius), (y + radius).min(h - 1));
        for x in 0..w {
            out[y * w + x] = (a..=b).any(|yy| rows[yy * w + x]);
        }
    }
    out
}

/// Camera-frame unit normals of a depth map from its gradient (central differences where both
/// neighbours have depth, else one-sided), facing the camera; `[0; 3]` where none.
pub fn normals_from_depth(
    depth: &[f32],
    width: usize,
    height: usize,
    ray: impl Fn(usize, usize) -> Vector3<f64>,
) -> Vec<[f32; 3]> {
    let point = |x: usize, y: usize| -> Option<Vector3<f64>> {
        let z = depth[y * width + x];
        (z > 0.0).then(|| ray(x, y) * z as f64)
    };
    let mut out = vec![[0.0f32; 3]; depth.len()];
    for y in 0..height {
        for x in 0..width {
            let Some(c) = point(x, y) else { continue };
            let diff = |a: Option<Vector3<f64>>, b: Option<Vector3<f64>>| match (a, b) {
                (Some(a), Some(b)) => Some(b - a),
                (None, Some(b)) => Some(b - c),
                (Some(a), None) => Some(c - a),
                (None, None) => None,
            };
            let left = (x > 0).then(|| point(x - 1, y)).flatten();
            let right = (x + 1 < width).then(|| point(x + 1, y)).flatten();
            let up = (y > 0).then(|| point(x, y - 1)).flatten();
            let down = (y + 1 < height).then(|| point(x, y + 1)).flatten();
            let (Some(dx), Some(dy)) = (diff(left, right), diff(up, down)) else {
                continue;
            };
            let mut n = dx.cross(&dy);
            let len = n.norm();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            n /= len;
            if n.dot(&c) > 0.0 {
                n = -n;
            }
            out[y * width + x] = [n.x as f32, n.y as f32, n.z as f32];
        }
    }
    out
}

#[cfg(test)]
pub(crate) mod tests;
