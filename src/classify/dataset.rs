//! Training cells from synthetic workspaces (`planemap synth` output) and the precision /
//! recall of "non-planar" on held-out workspaces.
//!
//! A workspace is read as `sparse/` (COLMAP model: cameras, poses, sparse points for the
//! geometric cue), `images/`, and the ground truth `gt/planes/NAME.png` (16-bit plane id,
//! 0 = non-planar) and `gt/depth/NAME.pfm` (camera z, 0 where the ray hits only sky). A cell
//! is labelled by majority over its own `cell × cell` pixels (not the context margin):
//! non-planar when gt-non-planar pixels outnumber gt-planar ones; cells that are at least half
//! sky are skipped (sky is neither, and the pipeline never labels it).

use std::path::{Path, PathBuf};

use super::features::{cell_features, FeatureSpec, ViewPoints, FEATURE_DIM};
use super::{ClassifyError, PlanarityModel};
use crate::io::labelpng::read_label_png;
use crate::io::output_stem;
use crate::io::pfm::read_pfm_path;
use crate::raster::ImageF32;
use crate::scene::Scene;

/// Labelled feature vectors (`labels.len() × FEATURE_DIM`, row-major); label 1 = non-planar.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TrainingSet {
    /// Raw (unstandardised) feature vectors.
    pub features: Vec<f32>,
    /// 1 = non-planar, 0 = planar.
    pub labels: Vec<u8>,
}

impl TrainingSet {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.labels.len()
    }
    /// No samples.
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }
    /// Number of non-planar samples.
    pub fn nonplanar(&self) -> usize {
        self.labels.iter().filter(|&&l| l == 1).count()
    }
    /// Appends another set.
    pub fn extend(&mut self, other: &TrainingSet) {
        self.features.extend_from_slice(&other.features);
        self.labels.extend_from_slice(&other.labels);
    }
}

/// Ground truth of one view.
#[derive(Debug, Clone)]
pub struct ViewTruth {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Plane id per pixel (0 = non-planar or sky).
    pub planes: Vec<u16>,
    /// Depth per pixel (0 or non-finite = sky).
    pub depth: Vec<f32>,
}

impl ViewTruth {
    /// Is pixel `i` sky (no surface)?
    pub fn is_sky(&self, i: usize) -> bool {
        let d = self.depth[i];
        !(d.is_finite() && d > 0.0)
    }

    /// Label per cell of `spec`'s grid: `Some(1)` non-planar, `Some(0)` planar, `None` skipped
    /// (at least half sky).
    pub fn cell_labels(&self, spec: &FeatureSpec) -> Vec<Option<u8>> {
        let (cols, rows) = spec.grid(self.width, self.height);
        let (w, h, c) = (
            self.width as usize,
            self.height as usize,
            spec.cell as usize,
        );
        let mut out = Vec::with_capacity((cols * rows) as usize);
        for cy in 0..rows as usize {
            for cx in 0..cols as usize {
                let (mut sky, mut planar, mut nonplanar) = (0usize, 0usize, 0usize);
                for y in cy * c..((cy + 1) * c).min(h) {
                    for x in cx * c..((cx + 1) * c).min(w) {
                        let i = y * w + x;
                        if self.is_sky(i) {
                            sky += 1;
                        } else if self.planes[i] == 0 {
                            nonplanar += 1;
                        } else {
                            planar += 1;
                        }
                    }
                }
                out.push(if 2 * sky >= sky + planar + nonplanar {
                    None
                } else {
                    Some((nonplanar > planar) as u8)
                });
            }
        }
        out
    }
}

/// A synthetic workspace opened for training or evaluation.
pub struct Workspace {
    /// The directory.
    pub dir: PathBuf,
    /// Views and sparse points.
    pub scene: Scene,
}

fn ws_err(dir: &Path, message: String) -> ClassifyError {
    ClassifyError::Workspace {
        workspace: dir.display().to_string(),
        message,
    }
}

impl Workspace {
    /// Opens `dir/sparse` (COLMAP) with images in `dir/images`.
    pub fn open(dir: &Path) -> Result<Self, ClassifyError> {
        let model = crate::io::colmap::read_model(&dir.join("sparse"))
            .map_err(|e| ws_err(dir, e.to_string()))?;
        let scene = model
            .to_scene(Some(&dir.join("images")))
            .map_err(|e| ws_err(dir, e.to_string()))?;
        Ok(Workspace {
            dir: dir.to_path_buf(),
            scene,
        })
    }

    /// Image of view `i` (as stored, RGB in [0, 1]).
    pub fn image(&self, i: usize) -> Result<ImageF32, ClassifyError> {
        self.scene.views[i]
            .load_image()
            .map_err(|e| ws_err(&self.dir, e.to_string()))
    }

    /// Ground truth of view `i` from `gt/planes/NAME.png` and `gt/depth/NAME.pfm`.
    pub fn truth(&self, i: usize) -> Result<ViewTruth, ClassifyError> {
        let view = &self.scene.views[i];
        let stem = output_stem(&view.name);
        let gt = self.dir.join("gt");
        let (w, h, planes) = read_label_png(&gt.join("planes").join(format!("{stem}.png")))
            .map_err(|e| ws_err(&self.dir, e.to_string()))?;
        let depth = read_pfm_path(&gt.join("depth").join(format!("{stem}.pfm")))
            .map_err(|e| ws_err(&self.dir, e.to_string()))?;
        if (w, h) != (view.camera.width, view.camera.height)
            || (depth.width, depth.height, depth.channels) != (w, h, 1)
        {
            return Err(ws_err(
                &self.dir,
                format!(
                    "view {}: ground truth {w}x{h} / depth {}x{}x{} do not match the camera {}x{}",
                    view.name,
                    depth.width,
                    depth.height,
                    depth.channels,
                    view.camera.width,
                    view.camera.height
                ),
            ));
        }
        Ok(ViewTruth {
            width: w,
            height: h,
            planes,
            depth: depth.data,
        })
    }
}

/// All labelled cells of all views of a workspace, views in model order, cells row-major.
pub fn workspace_samples(dir: &Path, spec: &FeatureSpec) -> Result<TrainingSet, ClassifyError> {
    let ws = Workspace::open(dir)?;
    let mut set = TrainingSet::default();
    for i in 0..ws.scene.views.len() {
        let image = ws.image(i)?;
        let truth = ws.truth(i)?;
        let points = ViewPoints::from_scene(&ws.scene, i);
        let features = cell_features(&image, Some(&points), spec)?;
        for (c, label) in truth.cell_labels(spec).into_iter().enumerate() {
            if let Some(l) = label {
                set.features
                    .extend_from_slice(&features.data[c * FEATURE_DIM..(c + 1) * FEATURE_DIM]);
                set.labels.push(l);
            }
        }
    }
    Ok(set)
}

/// Confusion counts for the positive class "non-planar".
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Confusion {
    /// Non-planar called non-planar.
    pub true_positive: u64,
    /// Planar called non-planar.
    pub false_positive: u64,
    /// Non-planar called planar.
    pub false_negative: u64,
    /// Planar called planar.
    pub true_negative: u64,
}

impl Confusion {
    /// Counts one decision.
    pub fn add(&mut self, truth_nonplanar: bool, called_nonplanar: bool) {
        match (truth_nonplanar, called_nonplanar) {
            (true, true) => self.true_positive += 1,
            (false, true) => self.false_positive += 1,
            (true, false) => self.false_negative += 1,
            (false, false) => self.true_negative += 1,
        }
    }
    /// Sums two tables.
    pub fn merge(&mut self, o: &Confusion) {
        self.true_positive += o.true_positive;
        self.false_positive += o.false_positive;
        self.false_negative += o.false_negative;
        self.true_negative += o.true_negative;
    }
    /// TP / (TP + FP); 0 when nothing was called non-planar.
    pub fn precision(&self) -> f64 {
        ratio(self.true_positive, self.true_positive + self.false_positive)
    }
    /// TP / (TP + FN); 0 when there is no non-planar truth.
    pub fn recall(&self) -> f64 {
        ratio(self.true_positive, self.true_positive + self.false_negative)
    }
    /// TN / (TN + FP): fraction of planar truth kept planar; 0 when there is none.
    pub fn specificity(&self) -> f64 {
        ratio(self.true_negative, self.true_negative + self.false_positive)
    }
    /// Harmonic mean of precision and recall.
    pub fn f1(&self) -> f64 {
        let (p, r) = (self.precision(), self.recall());
        if p + r == 0.0 {
            0.0
        } else {
            2.0 * p * r / (p + r)
        }
    }
    /// Fraction of correct decisions.
    pub fn accuracy(&self) -> f64 {
        let n = self.true_positive + self.false_positive + self.false_negative + self.true_negative;
        if n == 0 {
            0.0
        } else {
            (self.true_positive + self.true_negative) as f64 / n as f64
        }
    }
}

/// Scores of a model on one workspace: per labelled cell and per non-sky pixel (pixel
/// decision: the interpolated map's `P(planar) < 1 − threshold`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WorkspaceScores {
    /// Per cell (cells labelled as in training).
    pub cells: Confusion,
    /// Per non-sky pixel.
    pub pixels: Confusion,
}

/// Evaluates `model` on every view of the workspace at `dir`.
pub fn evaluate_workspace(
    model: &PlanarityModel,
    dir: &Path,
) -> Result<WorkspaceScores, ClassifyError> {
    let ws = Workspace::open(dir)?;
    let mut scores = WorkspaceScores::default();
    for i in 0..ws.scene.views.len() {
        let image = ws.image(i)?;
        let truth = ws.truth(i)?;
        let points = ViewPoints::from_scene(&ws.scene, i);
        let features = cell_features(&image, Some(&points), &model.spec)?;
        let probs = model.cell_probabilities(&features);
        for (c, label) in truth.cell_labels(&model.spec).into_iter().enumerate() {
            if let Some(l) = label {
                scores.cells.add(l == 1, probs[c] > model.threshold);
            }
        }
        let map = super::upsample_cells(
            &probs,
            features.cols,
            features.rows,
            model.spec.cell,
            image.width,
            image.height,
        );
        for (p, planar) in map.planar.iter().enumerate() {
            if !truth.is_sky(p) {
                scores
                    .pixels
                    .add(truth.planes[p] == 0, 1.0 - planar > model.threshold);
            }
        }
    }
    Ok(scores)
}

/// `num / den`, or 0 when `den` is 0.
fn ratio(num: u64, den: u64) -> f64 {
    if den == 0 {
        0.0
    } else {
        num as f64 / den as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_labels_by_majority_skip_sky() {
        let spec = FeatureSpec {
            cell: 2,
            ..Default::default()
        };
        // 4×2 image → 2×1 cells. Cell 0: 3 non-planar + 1 planar → 1.
        // Cell 1: 2 sky + 2 planar → skipped (half sky).
        let truth = ViewTruth {
            width: 4,
            height: 2,
            planes: vec![0, 0, 0, 5, 0, 5, 3, 3],
            depth: vec![1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0],
        };
        // Pixel 2 is sky (depth 0) in cell 1; pixel 3 planar; pixels 6, 7 planar → cell 1 has
        // 1 sky + 3 planar → planar.
        assert_eq!(truth.cell_labels(&spec), vec![Some(1), Some(0)]);
        let sky = ViewTruth {
            depth: vec![1.0, 1.0, 0.0, 0.0, 1.0, 1.0, f32::NAN, 1.0],
            ..truth
        };
        assert_eq!(sky.cell_labels(&spec), vec![Some(1), None]);
    }

    #[test]
    fn confusion_rates() {
        let mut c = Confusion::default();
        for (t, p) in [
            (true, true),
            (true, true),
            (true, false),
            (false, true),
            (false, false),
        ] {
            c.add(t, p);
        }
        assert!((c.precision() - 2.0 / 3.0).abs() < 1e-12);
        assert!((c.recall() - 2.0 / 3.0).abs() < 1e-12);
        assert!((c.f1() - 2.0 / 3.0).abs() < 1e-12);
        assert!((c.accuracy() - 0.6).abs() < 1e-12);
        assert!((c.specificity() - 0.5).abs() < 1e-12);
    }
}
