//! Baselines the planemaps are compared with: per-view plane-sweep stereo (winner takes all)
//! over fronto-parallel planes spanning the sparse points' depth range — the ordinary stereo
//! that fails on texture-poor walls.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::geometry::Plane;
use crate::photo::{
    fronto_parallel_planes, plane_cost_volume, select_neighbours, winner_takes_all, CostVolume,
    PhotoError, SweepConfig, SweepResult, NO_PLANE,
};
use crate::raster::ImageF32;
use crate::scene::View;
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
    /// Sub-plane refinement ([`refine_subplane`]): fit a parabola to the cost at the
    /// winning plane and its two neighbours and move the depth to the parabola's minimum.
    /// Without it the WTA depth is quantised to the plane spacing (a few % of depth for
    /// 128 planes over the usual range), which alone defeats a 1% tolerance.
    pub subplane: bool,
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
            subplane: true,
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
    cfg.sweep.validate().map_err(photo_err)?;
    let volume = plane_cost_volume(view, &images[index], &pairs, &planes, &cfg.sweep.photo)
        .map_err(photo_err)?;
    let mut result = winner_takes_all(&volume, view, &planes, cfg.sweep.confidence_exclusion)
        .map_err(photo_err)?;
    if cfg.subplane {
        refine_subplane(&volume, &mut result, view, &planes, Spacing::InverseDepth);
    }
    Ok(result)
}

/// How the consecutive planes of one sweep family are spaced, which fixes how a fractional
/// plane index maps to a depth along a pixel's ray.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spacing {
    /// Parallel planes evenly spaced in inverse depth ([`fronto_parallel_planes`]): the
    /// inverse depth is interpolated linearly in the index.
    InverseDepth,
    /// Parallel planes evenly spaced in offset ([`crate::photo::axis_sweep_planes`]): the
    /// depth along a ray is `d / (n·ray)`, so it is interpolated linearly in the index.
    Offset,
}

/// Sub-plane refinement of a winner-takes-all result (in place). For a pixel whose winning
/// plane `k` has both neighbours `k ± 1` with evidence (cost < 1), the parabola through
/// `(k−1, c₋), (k, c₀), (k+1, c₊)` has its minimum at `k + δ`,
/// `δ = (c₋ − c₊) / (2 (c₋ − 2c₀ + c₊))`, clamped to `[−½, ½]`; the depth becomes the
/// interpolation (see [`Spacing`]) between the depths of planes `k` and `k ± 1` along the
/// pixel's ray. `planes` must be one family of parallel planes in sweep order; pixels at
/// the ends of the sweep or on a non-convex cost keep the plane's depth. `plane_index` and
/// `cost` are left as WTA chose them.
pub fn refine_subplane(
    volume: &CostVolume,
    result: &mut SweepResult,
    reference: &View,
    planes: &[Plane],
    spacing: Spacing,
) {
    let np = volume.num_planes;
    if np < 3 || planes.len() != np || result.depth.len() != volume.width * volume.height {
        return;
    }
    let cam_planes: Vec<Plane> = planes
        .iter()
        .map(|p| p.in_camera(&reference.cam_from_world))
        .collect();
    let w = volume.width;
    for (i, z) in result.depth.iter_mut().enumerate() {
        let k = result.plane_index[i];
        if k == NO_PLANE || k == 0 || k as usize + 1 >= np {
            continue;
        }
        let k = k as usize;
        let c = volume.pixel_costs(i);
        let (cm, c0, cp) = (c[k - 1] as f64, c[k] as f64, c[k + 1] as f64);
        if cm >= 1.0 || cp >= 1.0 {
            continue;
        }
        let curvature = cm - 2.0 * c0 + cp;
        if curvature <= 0.0 {
            continue;
        }
        let delta = (0.5 * (cm - cp) / curvature).clamp(-0.5, 0.5);
        if delta == 0.0 {
            continue;
        }
        let j = if delta < 0.0 { k - 1 } else { k + 1 };
        let t = delta.abs();
        let ray = reference.camera.pixel_ray((i % w) as u32, (i / w) as u32);
        let (Some(zk), Some(zj)) = (
            cam_planes[k].depth_along(&ray),
            cam_planes[j].depth_along(&ray),
        ) else {
            continue;
        };
        let refined = match spacing {
            Spacing::InverseDepth => 1.0 / ((1.0 - t) / zk + t / zj),
            Spacing::Offset => (1.0 - t) * zk + t * zj,
        };
        if refined.is_finite() && refined > 0.0 {
            *z = refined as f32;
        }
    }
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

    /// A cost that is a parabola in inverse depth with its minimum between two planes:
    /// WTA is off by up to half a plane step, the refinement recovers the true depth.
    #[test]
    fn subplane_refinement_recovers_depth_between_planes() {
        use crate::geometry::{Camera, CameraModel, Rigid3};
        let camera = Camera::new(CameraModel::Pinhole, 4, 1, vec![100.0, 100.0, 2.0, 0.5])
            .expect("valid camera");
        let view = View {
            id: 0,
            name: "v".into(),
            camera,
            cam_from_world: Rigid3::identity(),
            image_path: None,
        };
        let planes = fronto_parallel_planes(&view, 2.0, 10.0, 9).expect("planes");
        let inv: Vec<f64> = planes.iter().map(|p| 1.0 / p.offset).collect();
        let true_depth = [3.1, 4.4, 5.05, 7.7];
        let (w, np) = (4, planes.len());
        let mut costs = vec![0.0f32; w * np];
        for (px, &z) in true_depth.iter().enumerate() {
            for k in 0..np {
                let d = (inv[k] - 1.0 / z) / (inv[0] - inv[1]);
                costs[px * np + k] = (0.1 + 0.05 * d * d).min(0.99) as f32;
            }
        }
        let volume = CostVolume {
            width: w,
            height: 1,
            num_planes: np,
            costs,
        };
        let mut result = winner_takes_all(&volume, &view, &planes, 1).expect("wta");
        let wta_err = |r: &SweepResult| {
            r.depth
                .iter()
                .zip(&true_depth)
                .map(|(&d, &z)| ((d as f64 - z) / z).abs())
                .fold(0.0f64, f64::max)
        };
        let before = wta_err(&result);
        assert!(before > 0.02, "WTA should be quantised, error {before}");
        refine_subplane(&volume, &mut result, &view, &planes, Spacing::InverseDepth);
        let after = wta_err(&result);
        assert!(after < 1e-5, "refined error {after}");
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
