//! Planar / non-planar classification of image regions (Gallup, Frahm & Pollefeys, "Piecewise
//! planar and non-planar stereo for urban scene reconstruction", CVPR 2010, §4).
//!
//! Real buildings stand among trees, statues and cars; forcing those onto planes wrecks them.
//! A classifier trained on appearance (and here a label-free geometric cue) says, per image
//! region, how likely it is to be planar, so that the planar prior is applied only where it
//! belongs.
//!
//! - [`features`]: per-cell feature vectors (Lab histograms, gradient orientations, LBP,
//!   plane-fit residual of nearby sparse points);
//! - [`knn`] and [`logistic`]: the two classifiers (the paper reports both working alike);
//! - [`dataset`]: training cells from synthetic workspaces' ground truth (`gt/planes/*.png`,
//!   0 = non-planar; sky, depth 0, skipped) and precision / recall of "non-planar";
//! - [`mod@format`]: the versioned little-endian model file; [`default_model`] is embedded.
//!
//! # Using the planarity map in the planemap energy
//!
//! [`PlanarityModel::planarity_map`] gives `P(planar)` per pixel (bilinear between cell
//! centres); [`PlanarityMap::unary_costs`] turns it into the two cost terms below. The intended integration (issue 7, done in `planemap::energy` by its owner): add
//! one label "non-planar" whose depth at pixel `p` is the plane-sweep depth and whose data
//! cost is `D_np(p) = C_sweep(p) + β·(−ln(1 − P(p) + ε))`, while every plane label `ℓ` gets
//! `D_ℓ(p) = C_ℓ(p) + β·(−ln(P(p) + ε))` (Gallup et al. §5: the classifier's output enters
//! as a unary term beside photo-consistency). `β` weighs the classifier against the
//! photo-consistency, `ε ≈ 0.01` keeps a confident mistake recoverable. Smoothness between a
//! plane label and the non-planar label is the ordinary Potts penalty.

pub mod dataset;
pub mod features;
pub mod format;
pub mod knn;
pub mod logistic;

use std::path::Path;

use rayon::prelude::*;
use thiserror::Error;

pub use dataset::{evaluate_workspace, workspace_samples, Confusion, TrainingSet};
pub use features::{cell_features, CellFeatures, FeatureSpec, ViewPoints, FEATURE_DIM};
pub use format::{model_from_bytes, model_to_bytes, read_model_path, write_model_path};
pub use knn::KnnClassifier;
pub use logistic::{train_logistic, LogisticClassifier, LogisticConfig};

use crate::io::atomic::write_atomic;
use crate::raster::ImageF32;

/// Errors of the classifier module.
#[derive(Debug, Error)]
pub enum ClassifyError {
    /// A configuration value is out of range (message names it).
    #[error("invalid classifier config: {0}")]
    InvalidConfig(String),
    /// Inputs that cannot be used (sizes, empty sets; message says which).
    #[error("invalid input: {0}")]
    InvalidInput(String),
    /// A model file is malformed at a byte offset.
    #[error("{file}: byte {offset}: {message}")]
    Format {
        /// The file (`<stream>` for readers).
        file: String,
        /// Byte offset of the bad or missing field.
        offset: u64,
        /// What was expected.
        message: String,
    },
    /// A file could not be read or written.
    #[error("{file}: {message}")]
    Io {
        /// The file.
        file: String,
        /// The OS or decoder message.
        message: String,
    },
    /// A workspace could not be loaded (message names the file).
    #[error("workspace {workspace}: {message}")]
    Workspace {
        /// The workspace directory.
        workspace: String,
        /// What failed.
        message: String,
    },
}

impl ClassifyError {
    fn in_file(self, file: &str) -> Self {
        match self {
            ClassifyError::Format {
                offset, message, ..
            } => ClassifyError::Format {
                file: file.to_string(),
                offset,
                message,
            },
            other => other,
        }
    }
}

/// Which classifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// k nearest neighbours.
    Knn,
    /// L2-regularised logistic regression.
    Logistic,
}

impl std::str::FromStr for Method {
    type Err = ClassifyError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "knn" => Ok(Method::Knn),
            "logistic" => Ok(Method::Logistic),
            _ => Err(ClassifyError::InvalidConfig(format!(
                "method {s:?} (want knn or logistic)"
            ))),
        }
    }
}

/// Per-feature standardisation `z = (x − mean) · scale` learned on the training set
/// (scale = 1 / standard deviation; 1 for constant features).
#[derive(Debug, Clone, PartialEq)]
pub struct Standardizer {
    /// Mean of each feature.
    pub mean: Vec<f32>,
    /// Inverse standard deviation of each feature.
    pub scale: Vec<f32>,
}

impl Standardizer {
    /// Fits mean and scale on `x` (`n × FEATURE_DIM`, row-major); sums in f64 in row order.
    pub fn fit(x: &[f32]) -> Self {
        let n = (x.len() / FEATURE_DIM).max(1) as f64;
        let mut sum = vec![0.0f64; FEATURE_DIM];
        let mut sum2 = vec![0.0f64; FEATURE_DIM];
        for row in x.chunks_exact(FEATURE_DIM) {
            for (d, &v) in row.iter().enumerate() {
                sum[d] += v as f64;
                sum2[d] += v as f64 * v as f64;
            }
        }
        // Below this standard deviation a feature is constant on the training set.
        const MIN_STD: f64 = 1e-6;
        let mean: Vec<f32> = sum.iter().map(|s| (s / n) as f32).collect();
        let scale = (0..FEATURE_DIM)
            .map(|d| {
                let m = sum[d] / n;
                let sd = (sum2[d] / n - m * m).max(0.0).sqrt();
                if sd > MIN_STD {
                    (1.0 / sd) as f32
                } else {
                    1.0
                }
            })
            .collect();
        Standardizer { mean, scale }
    }

    /// Standardises one vector.
    pub fn apply(&self, x: &[f32]) -> [f32; FEATURE_DIM] {
        let mut z = [0.0f32; FEATURE_DIM];
        for d in 0..FEATURE_DIM {
            z[d] = (x[d] - self.mean[d]) * self.scale[d];
        }
        z
    }
}

/// The trained classifier proper.
#[derive(Debug, Clone, PartialEq)]
pub enum Classifier {
    /// k nearest neighbours.
    Knn(KnnClassifier),
    /// Logistic regression.
    Logistic(LogisticClassifier),
}

/// A complete planarity model: feature spec, standardisation, classifier and the threshold on
/// `P(non-planar)` above which a cell is called non-planar.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarityModel {
    /// How features are computed.
    pub spec: FeatureSpec,
    /// Feature standardisation.
    pub standardizer: Standardizer,
    /// Decision threshold on `P(non-planar)` in [0, 1].
    pub threshold: f32,
    /// The classifier.
    pub classifier: Classifier,
}

/// Training options.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainConfig {
    /// Which classifier.
    pub method: Method,
    /// kNN: neighbours that vote.
    pub k: u32,
    /// kNN: at most this many training vectors are kept (deterministic even subsample), so
    /// the model stays small and queries fast.
    pub max_knn_samples: u32,
    /// Logistic options.
    pub logistic: LogisticConfig,
    /// Decision threshold on `P(non-planar)`.
    pub threshold: f32,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            method: Method::Logistic,
            k: 15,
            max_knn_samples: 4000,
            logistic: LogisticConfig::default(),
            threshold: 0.5,
        }
    }
}

/// The shipped default model (logistic; see papers.md for the command that reproduces it).
pub const DEFAULT_MODEL_BYTES: &[u8] = include_bytes!("default_model.bin");

/// Parses the embedded default model.
pub fn default_model() -> Result<PlanarityModel, ClassifyError> {
    model_from_bytes(DEFAULT_MODEL_BYTES).map_err(|e| e.in_file("<embedded default_model.bin>"))
}

/// Trains a model on a training set.
pub fn train(
    set: &TrainingSet,
    spec: FeatureSpec,
    config: &TrainConfig,
) -> Result<PlanarityModel, ClassifyError> {
    spec.validate()?;
    if set.is_empty() {
        return Err(ClassifyError::InvalidInput("empty training set".into()));
    }
    // One class only: the model would call everything that class. Say so instead.
    let nonplanar = set.nonplanar();
    if nonplanar == 0 || nonplanar == set.len() {
        let (have, missing) = if nonplanar == 0 {
            (
                "planar",
                "non-planar (gt/planes id 0: trees, statues, clutter)",
            )
        } else {
            ("non-planar", "planar")
        };
        return Err(ClassifyError::InvalidInput(format!(
            "all {} training cells are {have}: add workspaces with {missing} surfaces",
            set.len()
        )));
    }
    if !(0.0..=1.0).contains(&config.threshold) {
        return Err(ClassifyError::InvalidConfig(format!(
            "threshold {} (want 0..=1)",
            config.threshold
        )));
    }
    let standardizer = Standardizer::fit(&set.features);
    let z: Vec<f32> = set
        .features
        .chunks_exact(FEATURE_DIM)
        .flat_map(|row| standardizer.apply(row))
        .collect();
    let classifier = match config.method {
        Method::Logistic => {
            let fit = train_logistic(&z, &set.labels, FEATURE_DIM, &config.logistic)?;
            Classifier::Logistic(fit.model)
        }
        Method::Knn => {
            let n = set.len();
            let keep = (config.max_knn_samples as usize).clamp(1, n.max(1));
            // Even subsample: sample i·n/keep for i < keep (deterministic, keeps the mix of
            // scenes and views).
            let mut samples = Vec::with_capacity(keep * FEATURE_DIM);
            let mut labels = Vec::with_capacity(keep);
            for i in 0..keep {
                let j = i * n / keep;
                samples.extend_from_slice(&z[j * FEATURE_DIM..(j + 1) * FEATURE_DIM]);
                labels.push(set.labels[j]);
            }
            Classifier::Knn(KnnClassifier::new(config.k, samples, labels)?)
        }
    };
    Ok(PlanarityModel {
        spec,
        standardizer,
        threshold: config.threshold,
        classifier,
    })
}

/// Per-pixel planarity of one view: `P(planar)` in [0, 1], row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarityMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `P(planar)` per pixel.
    pub planar: Vec<f32>,
}

/// The classifier's unary terms for the planemap energy, per pixel (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarityCosts {
    /// Added to every plane label's data cost: `β·(−ln(P + ε))`.
    pub planar: Vec<f32>,
    /// Added to the "non-planar" label's data cost: `β·(−ln(1 − P + ε))`.
    pub nonplanar: Vec<f32>,
}

impl PlanarityMap {
    /// The unary costs this map contributes to the planemap energy: `β` weighs the
    /// classifier against photo-consistency, `ε` (e.g. 0.01) bounds the cost of a confident
    /// mistake at `β·ln(1/ε)`. At `P = 0.5` both costs are equal, so the classifier is
    /// neutral where it is unsure.
    pub fn unary_costs(&self, beta: f32, epsilon: f32) -> Result<PlanarityCosts, ClassifyError> {
        let valid = beta.is_finite() && beta >= 0.0 && epsilon.is_finite() && epsilon > 0.0;
        if !valid {
            return Err(ClassifyError::InvalidConfig(format!(
                "unary costs: beta = {beta} (want ≥ 0), epsilon = {epsilon} (want > 0)"
            )));
        }
        let cost = |q: f32| -beta * (q.clamp(0.0, 1.0) + epsilon).ln();
        Ok(PlanarityCosts {
            planar: self.planar.iter().map(|&p| cost(p)).collect(),
            nonplanar: self.planar.iter().map(|&p| cost(1.0 - p)).collect(),
        })
    }

    /// Writes an 8-bit grey PNG (255 = surely planar, 0 = surely non-planar), atomically.
    pub fn write_png(&self, path: &Path) -> Result<(), ClassifyError> {
        let bytes: Vec<u8> = self
            .planar
            .iter()
            .map(|p| (p.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        let img = image::GrayImage::from_raw(self.width, self.height, bytes).ok_or_else(|| {
            ClassifyError::InvalidInput(format!(
                "planarity map {}x{} with {} values",
                self.width,
                self.height,
                self.planar.len()
            ))
        })?;
        let io_err = |m: String| ClassifyError::Io {
            file: path.display().to_string(),
            message: m,
        };
        write_atomic(path, |w| {
            img.write_to(w, image::ImageFormat::Png)
                .map_err(|e| std::io::Error::other(e.to_string()))
        })
        .map_err(|e: std::io::Error| io_err(e.to_string()))
    }
}

impl PlanarityModel {
    /// The method of this model.
    pub fn method(&self) -> Method {
        match self.classifier {
            Classifier::Knn(_) => Method::Knn,
            Classifier::Logistic(_) => Method::Logistic,
        }
    }

    /// `P(non-planar)` of one raw (unstandardised) feature vector.
    pub fn nonplanar_probability(&self, x: &[f32]) -> f32 {
        let z = self.standardizer.apply(x);
        match &self.classifier {
            Classifier::Knn(k) => k.probability(&z),
            Classifier::Logistic(l) => l.probability(&z),
        }
    }

    /// `P(non-planar)` per cell of `features` (row-major, `cols × rows`).
    pub fn cell_probabilities(&self, features: &CellFeatures) -> Vec<f32> {
        features
            .data
            .par_chunks_exact(FEATURE_DIM)
            .map(|x| self.nonplanar_probability(x))
            .collect()
    }

    /// `P(planar)` per pixel of `image` (RGB in [0, 1], as loaded; `points`: the view's
    /// sparse points for the geometric cue, `None` if there is no sparse model). Cell
    /// probabilities are interpolated bilinearly between cell centres (clamped at borders).
    pub fn planarity_map(
        &self,
        image: &ImageF32,
        points: Option<&ViewPoints>,
    ) -> Result<PlanarityMap, ClassifyError> {
        let features = cell_features(image, points, &self.spec)?;
        let probs = self.cell_probabilities(&features);
        Ok(upsample_cells(
            &probs,
            features.cols,
            features.rows,
            self.spec.cell,
            image.width,
            image.height,
        ))
    }
}

/// Bilinear interpolation of per-cell `P(non-planar)` to per-pixel `P(planar)`.
fn upsample_cells(
    probs: &[f32],
    cols: u32,
    rows: u32,
    cell: u32,
    width: u32,
    height: u32,
) -> PlanarityMap {
    let c = cell as f32;
    let coord = |p: u32, n: u32| -> (usize, usize, f32) {
        // Cell i's centre is at (i + 0.5)·cell in image coordinates; pixel centre at p + 0.5.
        let t = ((p as f32 + 0.5) / c - 0.5).clamp(0.0, (n - 1) as f32);
        let i0 = t.floor() as usize;
        let i1 = (i0 + 1).min(n as usize - 1);
        (i0, i1, t - i0 as f32)
    };
    let mut planar = vec![0.0f32; width as usize * height as usize];
    planar
        .par_chunks_mut(width as usize)
        .enumerate()
        .for_each(|(y, row)| {
            let (y0, y1, fy) = coord(y as u32, rows);
            for (x, out) in row.iter_mut().enumerate() {
                let (x0, x1, fx) = coord(x as u32, cols);
                let at = |cx: usize, cy: usize| probs[cy * cols as usize + cx];
                let top = at(x0, y0) * (1.0 - fx) + at(x1, y0) * fx;
                let bottom = at(x0, y1) * (1.0 - fx) + at(x1, y1) * fx;
                *out = 1.0 - (top * (1.0 - fy) + bottom * fy);
            }
        });
    PlanarityMap {
        width,
        height,
        planar,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upsampling_hits_cell_centres_and_interpolates_between() {
        // 2×1 cells of 4 px: P(non-planar) 0 and 1 → P(planar) 1 … 0 across the centres.
        let map = upsample_cells(&[0.0, 1.0], 2, 1, 4, 8, 4);
        let row: Vec<f32> = map.planar[..8].to_vec();
        assert_eq!(row[0], 1.0); // clamped left of the first centre
        assert_eq!(row[7], 0.0);
        // Pixel 3 (centre 3.5) lies 3/8 of the way between centres 2 and 6.
        assert!((row[3] - (1.0 - 0.375)).abs() < 1e-6, "{row:?}");
        for w in row.windows(2) {
            assert!(w[1] <= w[0]);
        }
    }

    #[test]
    fn unary_costs_favour_the_likelier_label() {
        let map = PlanarityMap {
            width: 3,
            height: 1,
            planar: vec![1.0, 0.5, 0.0],
        };
        let c = map.unary_costs(2.0, 0.01).unwrap();
        // Sure planar: plane labels cost −2·ln(1.01), the non-planar label −2·ln(0.01).
        assert!((c.planar[0] - (-2.0 * 1.01f32.ln())).abs() < 1e-6);
        assert!((c.nonplanar[0] - (-2.0 * 0.01f32.ln())).abs() < 1e-5);
        assert_eq!(c.planar[1], c.nonplanar[1]);
        assert_eq!(c.planar[2], c.nonplanar[0]);
        assert!(map.unary_costs(-1.0, 0.01).is_err());
        assert!(map.unary_costs(1.0, 0.0).is_err());
    }

    #[test]
    fn standardizer_zero_mean_unit_variance() {
        let mut x = vec![0.0f32; 4 * FEATURE_DIM];
        for (i, row) in x.chunks_exact_mut(FEATURE_DIM).enumerate() {
            row[0] = i as f32; // 0,1,2,3: mean 1.5, var 1.25
            row[1] = 7.0; // constant
        }
        let s = Standardizer::fit(&x);
        assert!((s.mean[0] - 1.5).abs() < 1e-6);
        assert!((s.scale[0] - 1.0 / 1.25f32.sqrt()).abs() < 1e-6);
        assert_eq!(s.scale[1], 1.0);
        let z = s.apply(&x[3 * FEATURE_DIM..]);
        assert!((z[0] - 1.5 / 1.25f32.sqrt()).abs() < 1e-5);
        assert_eq!(z[1], 0.0);
    }

    #[test]
    fn default_model_loads() {
        let m = default_model().unwrap();
        assert_eq!(model_to_bytes(&m), DEFAULT_MODEL_BYTES);
    }
}
