//! Every score planemap and its baselines are measured with, against the ground truth of a
//! `planemap synth` workspace (`gt/`):
//!
//! - this module: a run's depth accuracy and plane-label accuracy per view and overall (what
//!   `planemap run` prints when ground truth is at hand);
//! - [`metrics`]: the benchmark's metrics — depth accuracy at several thresholds,
//!   completeness, normal error, plane segmentation, point-cloud accuracy / completeness /
//!   F-score against the ground-truth mesh;
//! - [`heldout`]: real photographs' sparse ground truth — held-out points, neighbouring
//!   views' agreement, the ground's share of horizontal planes;
//! - [`split`]: depth accuracy split by texture (the sweep baseline's scoring) and the
//!   pixels another view also sees.

use std::path::Path;

use serde::Serialize;
use thiserror::Error;

use crate::hypotheses::PlaneHypothesis;
use crate::io::labelpng::{read_label_png, LabelPngError};
use crate::io::output_stem;
use crate::io::pfm::{read_pfm_path, PfmError};
use crate::pipeline::ViewPlanemap;
use crate::scene::Scene;
use crate::workspace::GtPlaneRecord;

pub mod heldout;
pub mod metrics;
pub mod split;

/// Errors of loading ground truth.
#[derive(Debug, Error)]
pub enum EvalError {
    /// A depth map could not be read.
    #[error(transparent)]
    Pfm(#[from] PfmError),
    /// A plane-id map could not be read.
    #[error(transparent)]
    LabelPng(#[from] LabelPngError),
    /// planes.json is missing or malformed.
    #[error("{path}: {message}")]
    Planes {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// heldout.json is missing or malformed.
    #[error("{path}: {message}")]
    Heldout {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A ground-truth map disagrees with the view's result in size or channels.
    #[error("view {view}: {path} is {found} but the result is {expected}")]
    Shape {
        /// The view's image name.
        view: String,
        /// The ground-truth file.
        path: String,
        /// Its width × height (× channels).
        found: String,
        /// What the view's result needs.
        expected: String,
    },
}

/// Tolerances of the evaluation.
#[derive(Debug, Clone, Copy)]
pub struct EvalConfig {
    /// Relative depth error counted as accurate (0.01 = 1%).
    pub depth_tolerance: f64,
    /// For [`match_hypotheses`] (geometric matching, a diagnostic): maximal normal angle
    /// (degrees) …
    pub match_angle_deg: f64,
    /// … and offset difference as a fraction of the median ground-truth depth.
    pub match_offset_fraction: f64,
}

impl Default for EvalConfig {
    fn default() -> Self {
        EvalConfig {
            depth_tolerance: 0.01,
            match_angle_deg: 3.0,
            match_offset_fraction: 0.01,
        }
    }
}

/// Scores of one view (or all views pooled).
#[derive(Debug, Clone, Default, Serialize)]
pub struct Scores {
    /// Pixels with ground-truth depth.
    pub gt_pixels: u64,
    /// Of those, pixels whose depth is within the tolerance.
    pub depth_accurate: u64,
    /// Pixels on a ground-truth plane.
    pub planar_pixels: u64,
    /// Of those, pixels whose hypothesis matches that plane.
    pub plane_correct: u64,
}

impl Scores {
    /// Share of ground-truth pixels with accurate depth.
    pub fn depth_accuracy(&self) -> f64 {
        self.depth_accurate as f64 / self.gt_pixels.max(1) as f64
    }

    /// Share of planar pixels labelled with the matching plane.
    pub fn plane_accuracy(&self) -> f64 {
        self.plane_correct as f64 / self.planar_pixels.max(1) as f64
    }

    fn add(&mut self, o: &Scores) {
        self.gt_pixels += o.gt_pixels;
        self.depth_accurate += o.depth_accurate;
        self.planar_pixels += o.planar_pixels;
        self.plane_correct += o.plane_correct;
    }
}

/// Per-view and pooled scores.
#[derive(Debug, Clone, Serialize)]
pub struct EvalReport {
    /// (image name, scores) per evaluated view.
    pub views: Vec<(String, Scores)>,
    /// All views pooled.
    pub total: Scores,
    /// For each hypothesis, the ground-truth plane id it overlaps most (0 = none).
    pub hypothesis_match: Vec<u16>,
    /// For each hypothesis, the ground-truth plane id it matches geometrically (0 = none).
    pub hypothesis_geometric_match: Vec<u16>,
}

/// Reads `gt/planes.json`.
pub fn read_gt_planes(gt_dir: &Path) -> Result<Vec<GtPlaneRecord>, EvalError> {
    let path = gt_dir.join("planes.json");
    let text = std::fs::read_to_string(&path).map_err(|e| EvalError::Planes {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    serde_json::from_str(&text).map_err(|e| EvalError::Planes {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}

/// Matches each hypothesis to the closest ground-truth plane within the tolerances (by
/// angle, then offset); 0 when none is close enough.
pub fn match_hypotheses(
    hypotheses: &[PlaneHypothesis],
    gt: &[GtPlaneRecord],
    offset_tolerance: f64,
    angle_deg: f64,
) -> Vec<u16> {
    let cos_tol = angle_deg.to_radians().cos();
    hypotheses
        .iter()
        .map(|h| {
            let mut best: Option<(f64, u16)> = None;
            for g in gt {
                let n = nalgebra::Vector3::from(g.normal);
                let c = h.plane.normal.dot(&n);
                // Planes are unoriented: compare with the flipped one too.
                let (c, d) = if c >= 0.0 {
                    (c, (h.plane.offset - g.offset).abs())
                } else {
                    (-c, (h.plane.offset + g.offset).abs())
                };
                if c >= cos_tol && d <= offset_tolerance && best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, g.id));
                }
            }
            best.map_or(0, |(_, id)| id)
        })
        .collect()
}

/// Matches each hypothesis to the ground-truth plane it overlaps most, pooled over all views
/// (many-to-one: splitting a plane into several hypotheses is not penalised here, merging
/// two planes into one is). Only pixels where the result has a depth count. 0 = no overlap.
pub fn match_by_overlap<'a>(
    num_hypotheses: usize,
    views: impl Iterator<Item = (&'a ViewPlanemap, &'a crate::raster::ImageF32, &'a [u16])>,
) -> Vec<u16> {
    use std::collections::BTreeMap;
    let mut overlap: Vec<BTreeMap<u16, u64>> = vec![BTreeMap::new(); num_hypotheses];
    for (v, _, ids) in views {
        for (p, &gt_id) in ids.iter().enumerate() {
            let l = v.labels[p] as usize;
            if gt_id > 0 && v.depth[p] > 0.0 && l < num_hypotheses {
                *overlap[l].entry(gt_id).or_default() += 1;
            }
        }
    }
    overlap
        .iter()
        .map(|m| {
            // Largest overlap; ties to the smaller id (BTreeMap order) for determinism.
            m.iter()
                .fold(
                    (0u16, 0u64),
                    |best, (&id, &n)| if n > best.1 { (id, n) } else { best },
                )
                .0
        })
        .collect()
}

/// Scores the planemaps of `views` against the workspace's `gt/` directory.
pub fn evaluate(
    gt_dir: &Path,
    scene: &Scene,
    hypotheses: &[PlaneHypothesis],
    views: &[ViewPlanemap],
    cfg: &EvalConfig,
) -> Result<EvalReport, EvalError> {
    let gt_planes = read_gt_planes(gt_dir)?;
    let mut per_view = Vec::new();
    let mut all_depths = Vec::new();
    let mut gts = Vec::new();
    for v in views {
        let name = &scene.views[v.view_index].name;
        let stem = output_stem(name);
        let depth_path = gt_dir.join("depth").join(format!("{stem}.pfm"));
        let depth = read_pfm_path(&depth_path)?;
        let ids_path = gt_dir.join("planes").join(format!("{stem}.png"));
        let (w, h, ids) = read_label_png(&ids_path)?;
        let shape_err = |path: &Path, found: String, expected: String| EvalError::Shape {
            view: name.clone(),
            path: path.display().to_string(),
            found,
            expected,
        };
        if (depth.width, depth.height, depth.channels) != (v.width, v.height, 1) {
            return Err(shape_err(
                &depth_path,
                format!("{}x{}x{}", depth.width, depth.height, depth.channels),
                format!("{}x{}x1 (one depth per pixel)", v.width, v.height),
            ));
        }
        if (w, h) != (v.width, v.height) {
            return Err(shape_err(
                &ids_path,
                format!("{w}x{h}"),
                format!("{}x{}", v.width, v.height),
            ));
        }
        all_depths.extend(depth.data.iter().filter(|&&z| z > 0.0).copied());
        gts.push((name.clone(), depth, ids));
    }
    all_depths.sort_by(f32::total_cmp);
    let median_depth = all_depths.get(all_depths.len() / 2).copied().unwrap_or(1.0) as f64;
    let matches = match_by_overlap(
        hypotheses.len(),
        views
            .iter()
            .zip(&gts)
            .map(|(v, (_, d, ids))| (v, d, ids.as_slice())),
    );
    let mut total = Scores::default();
    for (v, (name, depth, ids)) in views.iter().zip(gts) {
        let mut s = Scores::default();
        for (p, &gz) in depth.data.iter().enumerate() {
            let gz = gz as f64;
            if gz <= 0.0 {
                continue;
            }
            s.gt_pixels += 1;
            let z = v.depth[p] as f64;
            if z > 0.0 && (z - gz).abs() <= cfg.depth_tolerance * gz {
                s.depth_accurate += 1;
            }
            if ids[p] > 0 {
                s.planar_pixels += 1;
                let l = v.labels[p] as usize;
                if z > 0.0 && l < matches.len() && matches[l] == ids[p] {
                    s.plane_correct += 1;
                }
            }
        }
        total.add(&s);
        per_view.push((name, s));
    }
    Ok(EvalReport {
        views: per_view,
        total,
        hypothesis_geometric_match: match_hypotheses(
            hypotheses,
            &gt_planes,
            cfg.match_offset_fraction * median_depth,
            cfg.match_angle_deg,
        ),
        hypothesis_match: matches,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scores_are_ratios() {
        let s = Scores {
            gt_pixels: 200,
            depth_accurate: 150,
            planar_pixels: 100,
            plane_correct: 99,
        };
        assert_eq!(s.depth_accuracy(), 0.75);
        assert_eq!(s.plane_accuracy(), 0.99);
        assert_eq!(Scores::default().depth_accuracy(), 0.0);
    }

    #[test]
    fn relabelled_planemap_scores_full_after_matching() {
        // Ground truth: left half plane 3, right half plane 7. The result uses hypotheses
        // 1 and 0 for them (any names): matching must map 1→3, 0→7 and score 100%.
        let (w, h) = (8u32, 4u32);
        let gt_ids: Vec<u16> = (0..w * h).map(|p| if p % w < 4 { 3 } else { 7 }).collect();
        let gt_depth = crate::raster::ImageF32::filled(w, h, 1, 2.0);
        let view = ViewPlanemap {
            view_index: 0,
            width: w,
            height: h,
            labels: gt_ids.iter().map(|&g| if g == 3 { 1 } else { 0 }).collect(),
            depth: vec![2.0; (w * h) as usize],
            normals: vec![[0.0, 0.0, -1.0]; (w * h) as usize],
            candidate_labels: 2,
            energy: (0.0, 0.0),
            cycles: 0,
            seconds: (0.0, 0.0),
            planarity: None,
            sweep_depth: None,
        };
        let m = match_by_overlap(2, std::iter::once((&view, &gt_depth, gt_ids.as_slice())));
        assert_eq!(m, vec![7, 3]);
        // One pixel wrong: exactly 1/32 lost.
        let mut wrong = view.clone();
        wrong.labels[0] = 0;
        let m = match_by_overlap(2, std::iter::once((&wrong, &gt_depth, gt_ids.as_slice())));
        assert_eq!(m, vec![7, 3]);
        let correct = (0..(w * h) as usize)
            .filter(|&p| m[wrong.labels[p] as usize] == gt_ids[p])
            .count();
        assert_eq!(correct, 31);
    }

    #[test]
    fn hypotheses_match_flipped_and_reject_far_planes() {
        use crate::geometry::Plane;
        use nalgebra::Vector3;
        let gt = vec![
            GtPlaneRecord {
                id: 1,
                normal: [0.0, 0.0, 1.0],
                offset: 2.0,
                label: "floor".into(),
                pixels: 1,
            },
            GtPlaneRecord {
                id: 2,
                normal: [1.0, 0.0, 0.0],
                offset: 0.0,
                label: "wall".into(),
                pixels: 1,
            },
        ];
        let hyp = |n: Vector3<f64>, d: f64| PlaneHypothesis {
            id: 0,
            plane: Plane::new(n, d),
            axis: None,
            support: 1,
        };
        let hs = vec![
            hyp(Vector3::new(0.0, 0.0, -1.0), -2.005),
            hyp(Vector3::new(1.0, 0.0, 0.0), 0.5),
            hyp(Vector3::new(1.0, 0.0, 0.01), 0.0),
        ];
        assert_eq!(match_hypotheses(&hs, &gt, 0.01, 3.0), vec![1, 0, 2]);
    }
}
