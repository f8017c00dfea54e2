//! Baselines the planemaps are compared with: per-view plane-sweep stereo (winner takes all)
//! over fronto-parallel planes spanning the sparse points' depth range — the ordinary stereo
//! that fails on texture-poor walls.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::photo::{
    fronto_parallel_planes, plane_sweep, select_neighbours, PhotoError, SweepConfig, SweepResult,
};
use crate::raster::ImageF32;
use crate::scene::{Scene, SceneError};

/// Errors of the baselines.
#[derive(Debug, Error)]
pub enum BaselineError {
    /// Photo-consistency failed.
    #[error("view {view:?}: {source}")]
    Photo {
        /// The view's image name.
        view: String,
        /// What failed.
        source: PhotoError,
    },
    /// An image could not be loaded.
    #[error(transparent)]
    Image(#[from] SceneError),
    /// The view sees no sparse points, so there is no depth range to sweep.
    #[error("view {0:?} sees no sparse points: no depth range to sweep")]
    NoPoints(String),
}

/// Plane-sweep baseline settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct SweepBaselineConfig {
    /// Fronto-parallel planes, evenly spaced in inverse depth.
    pub planes: usize,
    /// Neighbour views per reference view.
    pub neighbours: usize,
    /// The depth range is [near · p2, far · p98] of the view's sparse point depths:
    /// `near_factor` …
    pub near_factor: f64,
    /// … and `far_factor`.
    pub far_factor: f64,
    /// Scoring (measure, window, normalisation, aggregation).
    pub sweep: SweepConfig,
}

impl Default for SweepBaselineConfig {
    fn default() -> Self {
        SweepBaselineConfig {
            planes: 128,
            neighbours: 4,
            near_factor: 0.8,
            far_factor: 1.25,
            sweep: SweepConfig::default(),
        }
    }
}

/// Plane sweep for view `index` of an undistorted scene; `images` holds every view's image.
pub fn sweep_view(
    scene: &Scene,
    images: &[ImageF32],
    index: usize,
    cfg: &SweepBaselineConfig,
) -> Result<SweepResult, BaselineError> {
    let view = &scene.views[index];
    let photo_err = |source| BaselineError::Photo {
        view: view.name.clone(),
        source,
    };
    let mut depths: Vec<f64> = scene
        .cloud
        .positions
        .iter()
        .zip(&scene.cloud.tracks)
        .filter(|(_, t)| t.contains(&(index as u32)))
        .filter_map(|(p, _)| view.project(p).map(|(_, z)| z))
        .filter(|z| *z > 0.0)
        .collect();
    if depths.is_empty() {
        return Err(BaselineError::NoPoints(view.name.clone()));
    }
    depths.sort_by(f64::total_cmp);
    let pct = |q: f64| depths[((depths.len() - 1) as f64 * q).round() as usize];
    let near = pct(0.02) * cfg.near_factor;
    let far = (pct(0.98) * cfg.far_factor).max(near * 1.01);
    let planes = fronto_parallel_planes(view, near, far, cfg.planes).map_err(photo_err)?;
    let neighbours = select_neighbours(scene, index, cfg.neighbours).map_err(photo_err)?;
    let pairs: Vec<_> = neighbours
        .iter()
        .map(|&j| (&scene.views[j], &images[j]))
        .collect();
    plane_sweep(view, &images[index], &pairs, &planes, &cfg.sweep).map_err(photo_err)
}

/// Per-pixel texture mask: the grey level's standard deviation over a `(2r+1)²` window is at
/// least `threshold` (in [0, 1] units). What counts as "textured" is read off the image, as
/// a stereo method would see it.
pub fn texture_mask(image: &ImageF32, radius: u32, threshold: f32) -> Vec<bool> {
    let grey = image.to_gray();
    let (w, h) = (grey.width as usize, grey.height as usize);
    // Integral images of v and v² (f64 for exactness over large images).
    let mut s1 = vec![0.0f64; (w + 1) * (h + 1)];
    let mut s2 = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let (mut r1, mut r2) = (0.0, 0.0);
        for x in 0..w {
            let v = grey.data[y * w + x] as f64;
            r1 += v;
            r2 += v * v;
            s1[(y + 1) * (w + 1) + x + 1] = s1[y * (w + 1) + x + 1] + r1;
            s2[(y + 1) * (w + 1) + x + 1] = s2[y * (w + 1) + x + 1] + r2;
        }
    }
    let r = radius as usize;
    let mut mask = vec![false; w * h];
    for y in 0..h {
        let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
        for x in 0..w {
            let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
            let n = ((y1 - y0) * (x1 - x0)) as f64;
            let sum = |s: &[f64]| {
                s[y1 * (w + 1) + x1] - s[y0 * (w + 1) + x1] - s[y1 * (w + 1) + x0]
                    + s[y0 * (w + 1) + x0]
            };
            let mean = sum(&s1) / n;
            let var = (sum(&s2) / n - mean * mean).max(0.0);
            mask[y * w + x] = var.sqrt() >= threshold as f64;
        }
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_mask_separates_plain_from_checker() {
        let mut img = ImageF32::filled(20, 10, 1, 0.5);
        for y in 0..10 {
            for x in 10..20 {
                img.pixel_mut(x, y)[0] = if (x + y) % 2 == 0 { 0.2 } else { 0.8 };
            }
        }
        let m = texture_mask(&img, 2, 0.02);
        assert!(!m[5 * 20 + 2] && !m[5 * 20 + 7]);
        assert!(m[5 * 20 + 12] && m[5 * 20 + 17]);
    }
}

/// Depth accuracy of a depth map, split by texture.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct SplitScores {
    /// Textured pixels with ground-truth depth.
    pub textured: u64,
    /// Of those, within tolerance.
    pub textured_accurate: u64,
    /// Plain (untextured) pixels with ground-truth depth.
    pub plain: u64,
    /// Of those, within tolerance.
    pub plain_accurate: u64,
}

impl SplitScores {
    /// Adds another view's counts.
    pub fn add(&mut self, o: &SplitScores) {
        self.textured += o.textured;
        self.textured_accurate += o.textured_accurate;
        self.plain += o.plain;
        self.plain_accurate += o.plain_accurate;
    }

    /// Share of textured pixels within tolerance.
    pub fn textured_accuracy(&self) -> f64 {
        self.textured_accurate as f64 / self.textured.max(1) as f64
    }

    /// Share of plain pixels within tolerance.
    pub fn plain_accuracy(&self) -> f64 {
        self.plain_accurate as f64 / self.plain.max(1) as f64
    }
}

/// Scores `depth` (NaN or ≤ 0 = no depth) against `gt_depth` (0 = background, not scored)
/// at relative `tolerance`, split by `textured`.
pub fn split_scores(
    depth: &[f32],
    gt_depth: &[f32],
    textured: &[bool],
    tolerance: f64,
) -> SplitScores {
    let mut s = SplitScores::default();
    for ((&z, &g), &t) in depth.iter().zip(gt_depth).zip(textured) {
        if g <= 0.0 {
            continue;
        }
        let ok = z.is_finite() && z > 0.0 && ((z - g).abs() as f64) <= tolerance * g as f64;
        if t {
            s.textured += 1;
            s.textured_accurate += ok as u64;
        } else {
            s.plain += 1;
            s.plain_accurate += ok as u64;
        }
    }
    s
}
