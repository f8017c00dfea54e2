//! Baselines the planemaps are compared with: per-view plane-sweep stereo (winner takes all)
//! over fronto-parallel planes spanning the sparse points' depth range plus one plane family
//! per dominant axis (Gallup et al. 2007) — the ordinary stereo that fails on texture-poor
//! walls.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::geometry::Plane;
use crate::photo::{
    axis_planes, axis_sweep_planes, fronto_parallel_planes, multi_family_sweep, select_neighbours,
    Aggregation, PhotoConfig, PhotoError, PlaneFamily, SgmConfig, SweepConfig, SweepResult,
};
pub use crate::photo::{refine_subplane, Spacing};
use crate::raster::ImageF32;
use crate::scene::{Scene, SceneError, View};
use nalgebra::{Vector2, Vector3};
use rayon::prelude::*;

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
    /// A bad setting or inconsistent input (message says which).
    #[error("sweep baseline: {0}")]
    Config(String),
}

/// Plane-sweep baseline settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct SweepBaselineConfig {
    /// Fronto-parallel planes, evenly spaced in inverse depth.
    pub planes: usize,
    /// Also sweep along each dominant axis of the scene (Gallup et al. 2007), the winner
    /// taken over all families ([`multi_family_sweep`]): floors, walls and facades seen at
    /// a slant are then matched with correctly slanted windows, which a fronto-parallel
    /// window cannot do.
    pub axis_families: bool,
    /// Planes per axis family, evenly spaced in offset.
    pub axis_planes: usize,
    /// An axis family spans the range along the axis of the sparse points inside the view's
    /// frustum between the near and far depths of its own points (all but the
    /// `range_trim_points` most extreme at each end), widened by this fraction of that range
    /// on each side, and clipped to the frustum between the near and far depths.
    pub axis_margin: f64,
    /// Sparse points left out at each end of a range read from the points in the view's
    /// image, whichever views tracked them (isolated SfM outliers): the depth range and each
    /// axis family's range. A count, not a quantile: a floor or table top seen at a grazing
    /// angle may hold under 2 % of a view's points, and a range cut at the 2nd percentile
    /// left such surfaces unswept (tiny: 61.5 % of textured surfaces within 1 %, 95.3 %
    /// without the cut).
    pub range_trim_points: usize,
    /// Neighbour views per reference view ([`select_neighbours`]); the cost combines the
    /// best `sweep.photo.best_k` of those that see the window. 8 rather than 4: on walks
    /// (forward motion) and orbits many pixels are seen by only a few of them.
    pub neighbours: usize,
    /// The depth range is [near · z_lo, far · z_hi]: z_lo is the smaller of the 2nd
    /// percentile of the depths of the view's own sparse points and the depth of the
    /// (`range_trim_points` + 1)-th nearest sparse point in its image, whichever views
    /// tracked it; z_hi likewise at the far end. The view's own points alone miss a pillar
    /// next to the camera or a far gable that other views tracked. `near_factor` …
    pub near_factor: f64,
    /// … and `far_factor`.
    pub far_factor: f64,
    /// Sub-plane refinement ([`refine_subplane`]): fit a parabola to the cost at the
    /// winning plane and its two neighbours and move the depth to the parabola's minimum.
    /// Without it the WTA depth is quantised to the plane spacing (a few % of depth for
    /// 128 planes over the usual range), which alone defeats a 1% tolerance.
    pub subplane: bool,
    /// Densify a family whose consecutive planes move a pixel by more than this many pixels
    /// in the neighbours (median over the view, [`family_step_px`]): its plane count is
    /// scaled up to bring the median step to this value, at most to `max_family_planes`.
    /// Gallup et al. (2007) space their sweeps so that no plane step exceeds a pixel of
    /// disparity; coarser, the NCC basin is narrower than the step and sub-plane
    /// refinement has nothing to fit. 0 = the configured counts as they are. 0.7 by default
    /// (1.0 until 6 Dec): with the semi-global paths a finer step is also a smaller P1 jump;
    /// every view of the 13 scenes, textured surfaces within 1 % pooled 89.99 → 90.42 %
    /// (exterior, occlusion, stairs +1–2 points, courtyard −0.6) for about 10 % more time
    /// (papers.md, *Finer plane steps*).
    pub max_step_px: f64,
    /// Cap on a densified family's plane count (time and memory grow linearly with it).
    pub max_family_planes: usize,
    /// Non-Manhattan directions (roof slopes, turned wings) swept besides the three axes: the
    /// pipeline's `axes.max_extra_directions` for [`scene_axes`]. 0 = the Manhattan axes only.
    /// 2: gable's textured surfaces within 1 % went 69.2 → 83.2 % (its 45° roofs and 30° wing
    /// had only the fronto-parallel family); of the other scenes only the stairs gain one (the
    /// flight's 32° slope, mixed from tread and riser normals), and lose 74.7 → 70.2 %.
    pub extra_directions: usize,
    /// Scoring (measure, window, normalisation, aggregation).
    pub sweep: SweepConfig,
}

impl Default for SweepBaselineConfig {
    fn default() -> Self {
        SweepBaselineConfig {
            planes: 128,
            axis_families: true,
            axis_planes: 128,
            axis_margin: 0.1,
            range_trim_points: 2,
            neighbours: 8,
            near_factor: 0.8,
            far_factor: 1.25,
            subplane: true,
            max_step_px: 0.7,
            max_family_planes: 512,
            extra_directions: 2,
            // 5×5 NCC whose cost slices are guided-filtered over 15×15 (cost-volume
            // filtering, Hosni et al. 2013): the weak textures (paving, floor boards, brick)
            // need 15×15 of support under 1% image noise, and the guided filter gives it
            // without fattening depth edges the way a 15×15 NCC window does. The best 4 of
            // the 8 neighbours, not 2: on the stairs' repeated treads and nosings two
            // neighbours often agree on a shifted copy, four rarely do. papers.md has the
            // per-scene figures; corridor's 8 views took 54 s before both changes, 64 s after.
            sweep: SweepConfig {
                photo: PhotoConfig {
                    window_radius: 2,
                    best_k: 4,
                    aggregation: Aggregation::Guided {
                        radius: 7,
                        eps: 1e-3,
                    },
                    // Adaptive support weights (σc 0.1, σs 3): with the semi-global paths
                    // below settling plain paint, the weights' loss there is small and their
                    // gain beside depth edges stays (papers.md, *Semi-global aggregation*;
                    // 0.15 until 6 Dec, 0.1 since: *Narrower support weights, stiffer paths*).
                    support_sigma_color: 0.1,
                    ..Default::default()
                },
                // Semi-global aggregation (Hirschmüller 2008) over 8 paths before the
                // winner-takes-all: every view of the 13 scenes, textured surfaces within 1 %
                // 88.16 → 88.87 %, plain surfaces 42.91 → 68.24 % (papers.md, *Semi-global
                // aggregation*), 10–15 % more time. P1 0.1 / P2 1.0 rather than the module's
                // 0.06 / 0.6, chosen with σc 0.1 above (view 2 of every scene: the same
                // textured surfaces, plain ones +1.3 points).
                sgm: SgmConfig {
                    paths: 8,
                    p1: 0.1,
                    p2: 1.0,
                    ..Default::default()
                },
                ..Default::default()
            },
        }
    }
}

impl SweepBaselineConfig {
    /// Applies `key=value` overrides (value in TOML syntax, keys dotted as in the TOML
    /// form), e.g. `sweep.photo.window_radius=5`; unknown keys are errors.
    pub fn with_overrides(&self, overrides: &[String]) -> Result<Self, BaselineError> {
        let bad = |m: String| BaselineError::Config(m);
        let mut root = toml::Value::try_from(self).map_err(|e| bad(e.to_string()))?;
        for ov in overrides {
            let (key, value) = ov
                .split_once('=')
                .ok_or_else(|| bad(format!("override {ov:?}: expected key=value")))?;
            let parsed: toml::Value = toml::from_str::<toml::Table>(&format!("v = {value}"))
                .ok()
                .and_then(|mut t| t.remove("v"))
                .unwrap_or_else(|| toml::Value::String(value.to_string()));
            let parts: Vec<&str> = key.trim().split('.').collect();
            let mut node = &mut root;
            for (i, part) in parts.iter().enumerate() {
                let table = node
                    .as_table_mut()
                    .ok_or_else(|| bad(format!("override {ov:?}: {part:?} is not a section")))?;
                // `normalization` is absent while it is the measure's default.
                if !table.contains_key(*part) && *part != "normalization" {
                    return Err(bad(format!("override {ov:?}: unknown key {part:?}")));
                }
                if i + 1 == parts.len() {
                    table.insert(part.to_string(), parsed.clone());
                    break;
                }
                node = table
                    .get_mut(*part)
                    .ok_or_else(|| bad(format!("override {ov:?}: {part:?} is not a section")))?;
            }
        }
        let text = toml::to_string(&root).map_err(|e| bad(e.to_string()))?;
        let cfg: SweepBaselineConfig =
            toml::from_str(&text).map_err(|e| bad(format!("overrides: {e}")))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// Checks the values; the error names the field.
    pub fn validate(&self) -> Result<(), BaselineError> {
        let bad = |m: String| Err(BaselineError::Config(m));
        if !(self.axis_margin.is_finite() && self.axis_margin >= 0.0) {
            return bad(format!(
                "axis_margin = {} (want a finite value ≥ 0)",
                self.axis_margin
            ));
        }
        if !(self.max_step_px.is_finite() && self.max_step_px >= 0.0) {
            return bad(format!(
                "max_step_px = {} (want a finite value ≥ 0; 0 = off)",
                self.max_step_px
            ));
        }
        if self.max_family_planes < 2 {
            return bad(format!(
                "max_family_planes = {} (want ≥ 2)",
                self.max_family_planes
            ));
        }
        self.sweep
            .validate()
            .map_err(|e| BaselineError::Config(e.to_string()))
    }
}

/// The scene's dominant directions for axis sweeps: the pipeline's sparse-point stages with
/// their default settings ([`crate::pipeline::sparse_stages`]: normals, dominant axes, and
/// the refit of the axes from the points on their plane hypotheses). Empty when none are
/// found (the sweep is then fronto-parallel only).
///
/// The refit matters: on the stairs the normals of the points alone put the "vertical" axis
/// 11° off (nosing and tread points mix in their neighbourhoods), so the horizontal family
/// matched no tread and the fronto-parallel family won there with wrong depths.
///
/// The points can miss a direction the images still show: on `thin` the lawn, seen at
/// grazing angles, holds one sparse point, so the points give the back wall's normal alone.
/// The pipeline then completes the axes with the cameras' vertical
/// ([`crate::axes::camera_vertical`], `axes.camera_vertical`), and so do these directions;
/// without any point stage (no usable points) the vertical alone is swept along.
///
/// `cfg.extra_directions` non-Manhattan directions are asked of the points as well; one is
/// swept only if some plane hypothesis along it survived the pipeline's filter
/// (`hypotheses.max_shared_fraction`).
pub fn scene_axes(scene: &Scene, cfg: &SweepBaselineConfig) -> Vec<Vector3<f64>> {
    let mut pipeline = crate::pipeline::Config::default();
    pipeline.axes.max_extra_directions = cfg.extra_directions;
    crate::pipeline::sparse_stages(scene, &pipeline)
        .map(|s| {
            // An extra direction none of whose plane hypotheses survived (the stairs' slope:
            // its points are the nosings, on the treads' planes) is not swept either.
            let m = s.axes.num_manhattan;
            s.axes
                .directions
                .iter()
                .enumerate()
                .filter(|&(k, _)| k < m || s.hypotheses.iter().any(|h| h.axis == Some(k)))
                .map(|(_, d)| *d)
                .collect()
        })
        .unwrap_or_else(|_| {
            crate::axes::camera_vertical(&scene.views)
                .into_iter()
                .collect()
        })
}

/// Plane sweep for view `index` of an undistorted scene; `images` holds every view's image.
/// With `cfg.axis_families` the dominant axes are found with [`scene_axes`] (once per call:
/// sweeping many views, compute them once and call [`sweep_view_with_axes`]).
pub fn sweep_view(
    scene: &Scene,
    images: &[ImageF32],
    index: usize,
    cfg: &SweepBaselineConfig,
) -> Result<SweepResult, BaselineError> {
    let axes = if cfg.axis_families {
        scene_axes(scene, cfg)
    } else {
        Vec::new()
    };
    sweep_view_with_axes(scene, images, index, &axes, cfg)
}

/// What a view's plane sweep runs over: its plane families and its neighbour views.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepSetup {
    /// The fronto-parallel family first, then one family per usable sweep direction.
    pub families: Vec<PlaneFamily>,
    /// Neighbour views ([`select_neighbours`]), best first; never empty.
    pub neighbours: Vec<usize>,
}

impl SweepSetup {
    /// The neighbour views with their images, as the photo functions take them.
    pub fn pairs<'a>(
        &self,
        scene: &'a Scene,
        images: &'a [ImageF32],
    ) -> Vec<(&'a View, &'a ImageF32)> {
        self.neighbours
            .iter()
            .map(|&j| (&scene.views[j], &images[j]))
            .collect()
    }

    /// Sweeps view `index` over the families with `cfg`'s scoring and sub-plane refinement
    /// ([`multi_family_sweep`]); `images` holds every view's image.
    pub fn sweep(
        &self,
        scene: &Scene,
        images: &[ImageF32],
        index: usize,
        cfg: &SweepBaselineConfig,
    ) -> Result<SweepResult, PhotoError> {
        multi_family_sweep(
            &scene.views[index],
            &images[index],
            &self.pairs(scene, images),
            &self.families,
            &cfg.sweep,
            cfg.subplane,
        )
        .map(|r| r.sweep)
    }
}

/// The plane families and neighbours [`sweep_view_with_axes`] sweeps view `index` with:
/// fronto-parallel planes over the depth range of the view's sparse points, and (with
/// `cfg.axis_families`) one family per direction of `axes` over the points' extent along
/// it. Split out so a caller can score other planes with the same neighbours.
pub fn sweep_setup(
    scene: &Scene,
    index: usize,
    axes: &[Vector3<f64>],
    cfg: &SweepBaselineConfig,
) -> Result<SweepSetup, BaselineError> {
    cfg.validate()?;
    let count = scene.views.len();
    let view = scene.views.get(index).ok_or(BaselineError::Photo {
        view: format!("#{index}"),
        source: PhotoError::ViewIndex { index, count },
    })?;
    let photo_err = |source| BaselineError::Photo {
        view: view.name.clone(),
        source,
    };
    let seen: Vec<Vector3<f64>> = scene
        .cloud
        .positions
        .iter()
        .zip(&scene.cloud.tracks)
        .filter(|(p, t)| {
            t.contains(&(index as u32)) && view.project(p).is_some_and(|(_, z)| z > 0.0)
        })
        .map(|(p, _)| *p)
        .collect();
    let mut depths: Vec<f64> = seen
        .iter()
        .filter_map(|p| view.project(p).map(|(_, z)| z))
        .collect();
    if depths.is_empty() {
        return Err(BaselineError::NoPoints(view.name.clone()));
    }
    depths.sort_by(f64::total_cmp);
    // Every sparse point in the image, whichever views tracked it: a pillar beside the
    // camera or a distant gable may hold under 2 % of the view's own points, or none.
    // Each point is projected once: (position, depth).
    let in_image: Vec<(Vector3<f64>, f64)> = scene
        .cloud
        .positions
        .iter()
        .filter_map(|p| {
            view.project(p)
                .filter(|&(uv, z)| z > 0.0 && view.camera.contains(&uv))
                .map(|(_, z)| (*p, z))
        })
        .collect();
    let mut image_depths: Vec<f64> = in_image.iter().map(|&(_, z)| z).collect();
    image_depths.sort_by(f64::total_cmp);
    let (own_lo, own_hi) = (percentile(&depths, 0.02), percentile(&depths, 0.98));
    let (mut z_lo, mut z_hi) = (own_lo, own_hi);
    if !image_depths.is_empty() {
        let trim = cfg.range_trim_points.min((image_depths.len() - 1) / 2);
        z_lo = z_lo.min(image_depths[trim]);
        z_hi = z_hi.max(image_depths[image_depths.len() - 1 - trim]);
    }
    let near = z_lo * cfg.near_factor;
    let far = (z_hi * cfg.far_factor).max(near * 1.01);
    // The view's own points' depth range, which the axis families' range points are taken
    // from (below).
    let own_near = own_lo * cfg.near_factor;
    let own_far = (own_hi * cfg.far_factor).max(own_near * 1.01);
    let neighbours = select_neighbours(scene, index, cfg.neighbours).map_err(photo_err)?;
    if neighbours.is_empty() {
        return Err(photo_err(PhotoError::InvalidInput(
            "no neighbour view shares points with this view".into(),
        )));
    }
    let nbr_views: Vec<&View> = neighbours.iter().map(|&j| &scene.views[j]).collect();
    // A family of `n` planes, `n` raised until its median step is at most `max_step_px`.
    let dense = |n: usize, build: &dyn Fn(usize) -> Result<Vec<Plane>, PhotoError>| {
        let planes = build(n)?;
        if cfg.max_step_px <= 0.0 || n >= cfg.max_family_planes {
            return Ok(planes);
        }
        match family_step_px(view, &nbr_views, &planes, 0.5) {
            Some(step) if step > cfg.max_step_px => {
                let wanted = (n as f64 * step / cfg.max_step_px).ceil() as usize;
                build(wanted.min(cfg.max_family_planes))
            }
            _ => Ok(planes),
        }
    };
    let mut families = vec![PlaneFamily {
        planes: dense(cfg.planes, &|n| fronto_parallel_planes(view, near, far, n))
            .map_err(photo_err)?,
        spacing: Spacing::InverseDepth,
    }];
    // The points an axis family's range is read from: every sparse point inside the view's
    // frustum between the near and far depths of its own points, whichever views tracked
    // it — a floor seen at a grazing angle may hold only one or two of the view's own
    // points. Not the widened depth range: on gable views 10–12 the ground beside the
    // camera (3 m, against 7.6 m from the view's own points) stretched every family, its
    // planes grew twice as far apart and view 11 fell from 99.4 to 83.7 %.
    let in_frustum: Vec<Vector3<f64>> = in_image
        .iter()
        .filter(|&&(_, z)| z >= own_near && z <= own_far)
        .map(|&(p, _)| p)
        .collect();
    let range_points = if in_frustum.is_empty() {
        &seen
    } else {
        &in_frustum
    };
    if cfg.axis_families && cfg.axis_planes > 0 {
        for axis in axes {
            // The frustum's extent along the axis, narrowed to where the points are.
            let frustum = axis_sweep_planes(view, &[*axis], near, far, 2).map_err(photo_err)?;
            let (f_lo, f_hi) = (frustum[0].offset, frustum[1].offset);
            let u = frustum[0].normal;
            let mut along: Vec<f64> = range_points.iter().map(|p| u.dot(p)).collect();
            along.sort_by(f64::total_cmp);
            let trim = cfg.range_trim_points.min((along.len() - 1) / 2);
            let (p_lo, p_hi) = (along[trim], along[along.len() - 1 - trim]);
            let pad = cfg.axis_margin * (p_hi - p_lo);
            let (lo, hi) = ((p_lo - pad).max(f_lo), (p_hi + pad).min(f_hi));
            if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
                continue;
            }
            let offsets = |n: usize| -> Result<Vec<Plane>, PhotoError> {
                let offsets: Vec<f64> = (0..n)
                    .map(|i| lo + (hi - lo) * i as f64 / (n.max(2) - 1) as f64)
                    .collect();
                axis_planes(&[u], &offsets)
            };
            families.push(PlaneFamily {
                planes: dense(cfg.axis_planes, &offsets).map_err(photo_err)?,
                spacing: Spacing::Offset,
            });
        }
    }
    Ok(SweepSetup {
        families,
        neighbours,
    })
}

/// How far apart, in pixels of the neighbour images, consecutive planes of `planes` (one
/// family in sweep order) move a reference pixel: the `quantile` over a grid of reference
/// pixels, every neighbour and every pair of consecutive planes whose points lie in front of
/// both cameras and inside the neighbour's image. `None` when no such pair exists.
///
/// Plane sweeps sample the scene finely enough when this is about a pixel (Collins 1996;
/// Gallup et al. 2007 choose their plane count the same way): coarser, a match falls
/// between two planes and the narrow NCC basin leaves both neighbours of the winner at the
/// outlier cost, so sub-plane interpolation cannot recover the depth.
pub fn family_step_px(
    view: &View,
    neighbours: &[&View],
    planes: &[Plane],
    quantile: f64,
) -> Option<f64> {
    const GRID: usize = 8;
    let cam = &view.camera;
    let mut steps = Vec::new();
    let mut prev: Vec<Option<Vector2<f64>>> = Vec::with_capacity(neighbours.len());
    for gy in 0..GRID {
        for gx in 0..GRID {
            let xy = Vector2::new(
                (gx as f64 + 0.5) / GRID as f64 * cam.width as f64,
                (gy as f64 + 0.5) / GRID as f64 * cam.height as f64,
            );
            let (origin, dir) = view.ray(&xy);
            prev.clear();
            prev.resize(neighbours.len(), None);
            for plane in planes {
                let point = plane
                    .intersect_ray(&origin, &dir)
                    .filter(|&t| t > 0.0)
                    .map(|t| origin + dir * t);
                for (j, nb) in neighbours.iter().enumerate() {
                    let here = point
                        .and_then(|x| nb.project(&x))
                        .filter(|(uv, z)| *z > 0.0 && nb.camera.contains(uv))
                        .map(|(uv, _)| uv);
                    if let (Some(a), Some(b)) = (prev[j], here) {
                        steps.push((b - a).norm());
                    }
                    prev[j] = here;
                }
            }
        }
    }
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    Some(percentile(&steps, quantile))
}

/// [`sweep_view`] with given sweep directions (world frame; used only when
/// `cfg.axis_families`): the fronto-parallel family, then one family per direction
/// ([`sweep_setup`]).
pub fn sweep_view_with_axes(
    scene: &Scene,
    images: &[ImageF32],
    index: usize,
    axes: &[Vector3<f64>],
    cfg: &SweepBaselineConfig,
) -> Result<SweepResult, BaselineError> {
    let count = scene.views.len();
    if images.len() != count {
        return Err(BaselineError::Config(format!(
            "{} images for {count} views",
            images.len()
        )));
    }
    let setup = sweep_setup(scene, index, axes, cfg)?;
    setup
        .sweep(scene, images, index, cfg)
        .map_err(|source| BaselineError::Photo {
            view: scene.views[index].name.clone(),
            source,
        })
}

/// The `q`-quantile (nearest rank) of sorted, non-empty `values`.
fn percentile(values: &[f64], q: f64) -> f64 {
    values[((values.len() - 1) as f64 * q).round() as usize]
}

/// Per-pixel texture mask: the grey level's standard deviation over a `(2r+1)²` window is at
/// least `threshold` (in [0, 1] units). What counts as "textured" is read off the image, as
/// a stereo method would see it.
pub fn texture_mask(image: &ImageF32, radius: u32, threshold: f32) -> Vec<bool> {
    local_std(image, radius)
        .into_iter()
        .map(|s| s >= threshold as f64)
        .collect()
}

/// Per pixel, the standard deviation of the grey level over the `(2r+1)²` window around it
/// (clipped at the image border), in [0, 1] units.
pub fn local_std(image: &ImageF32, radius: u32) -> Vec<f64> {
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
    let mut std = vec![0.0f64; w * h];
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
            std[y * w + x] = (sum(&s2) / n - mean * mean).max(0.0).sqrt();
        }
    }
    std
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photo::{winner_takes_all, CostVolume};
    use crate::scene::View;

    #[test]
    fn overrides_reach_nested_fields_and_bad_ones_are_named() {
        let cfg = SweepBaselineConfig::default()
            .with_overrides(&[
                "sweep.photo.window_radius=5".into(),
                "axis_families=false".into(),
                "neighbours=6".into(),
                "extra_directions=2".into(),
            ])
            .unwrap();
        assert_eq!(cfg.sweep.photo.window_radius, 5);
        assert_eq!(cfg.extra_directions, 2);
        assert_eq!(SweepBaselineConfig::default().extra_directions, 2);
        assert!(!cfg.axis_families);
        assert_eq!(cfg.neighbours, 6);
        assert_eq!(cfg.planes, SweepBaselineConfig::default().planes);
        let err = SweepBaselineConfig::default()
            .with_overrides(&["no_such_key=1".into()])
            .unwrap_err();
        assert!(err.to_string().contains("no_such_key"), "{err}");
        let err = SweepBaselineConfig::default()
            .with_overrides(&["sweep.photo.best_k=0".into()])
            .unwrap_err();
        assert!(err.to_string().contains("best_k"), "{err}");
        // Semi-global aggregation: on by default, off with paths = 0, bad counts named.
        assert_eq!(SweepBaselineConfig::default().sweep.sgm.paths, 8);
        let off = SweepBaselineConfig::default()
            .with_overrides(&["sweep.sgm.paths=0".into()])
            .unwrap();
        assert!(!off.sweep.sgm.enabled());
        let err = SweepBaselineConfig::default()
            .with_overrides(&["sweep.sgm.paths=3".into()])
            .unwrap_err();
        assert!(err.to_string().contains("sgm.paths"), "{err}");
        // The sub-plane fit reads the aggregated costs unless told otherwise.
        assert!(!SweepBaselineConfig::default().sweep.sgm.subplane_on_local);
        let local_fit = SweepBaselineConfig::default()
            .with_overrides(&["sweep.sgm.subplane_on_local=true".into()])
            .unwrap();
        assert!(local_fit.sweep.sgm.subplane_on_local);
        assert!(SweepBaselineConfig::default()
            .with_overrides(&["planes".into()])
            .is_err());
    }

    /// Angle (degrees) between `d` and the nearest world axis, sign ignored.
    fn off_axis_deg(d: &Vector3<f64>) -> f64 {
        let c = d.x.abs().max(d.y.abs()).max(d.z.abs()) / d.norm();
        c.min(1.0).acos().to_degrees()
    }

    /// `scenes/NAME.toml` rendered at its own size and read back from its COLMAP model on
    /// disk, as `planemap sweep` reads it.
    fn scene_through_colmap(name: &str) -> Scene {
        scene_through_colmap_with(name, &Default::default())
    }

    /// [`scene_through_colmap`] rendered with `opts` (another size, say).
    fn scene_through_colmap_with(name: &str, opts: &crate::synth::RenderOptions) -> Scene {
        workspace_through_colmap(name, opts).0
    }

    /// [`scene_through_colmap_with`], with the workspace it was read from (ground truth in
    /// `gt/`), deleted when the second value drops.
    fn workspace_through_colmap(
        name: &str,
        opts: &crate::synth::RenderOptions,
    ) -> (Scene, tempfile::TempDir) {
        let spec = crate::synth::SceneSpec::from_path(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("scenes/{name}.toml")),
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        crate::workspace::render_to_workspace(
            &spec,
            opts,
            dir.path(),
            &crate::progress::Progress::new(true),
        )
        .unwrap();
        let scene = crate::io::colmap::read_model(&dir.path().join("sparse"))
            .unwrap()
            .to_scene(None)
            .unwrap();
        (scene, dir)
    }

    #[test]
    fn thin_sweeps_its_lawn_with_the_cameras_vertical() {
        // On thin the lawn, seen at grazing angles, holds one sparse point: the points give
        // the back wall's normal alone, and without the cameras' vertical no family is
        // horizontal (the sweep got 27 % of thin's textured surfaces within 1 %, 82 % with it).
        let scene = scene_through_colmap("thin");
        let mut points_only = crate::pipeline::Config::default();
        points_only.axes.camera_vertical = false;
        let from_points = crate::pipeline::sparse_stages(&scene, &points_only)
            .unwrap()
            .axes
            .directions;
        assert!(
            from_points.iter().all(|d| d.z.abs() < 0.9),
            "{from_points:?}"
        );
        let axes = scene_axes(&scene, &SweepBaselineConfig::default());
        assert_eq!(axes.len(), 3, "{axes:?}");
        assert!(
            axes.iter().any(|d| d.z.abs() > (0.5f64).to_radians().cos()),
            "{axes:?}"
        );
        assert!(axes.iter().all(|d| off_axis_deg(d) < 3.0), "{axes:?}");
    }

    #[test]
    fn axis_families_reach_a_floor_with_few_points() {
        // tiny at 320×240: the floor (z = 0) and the table top (z = 0.75) hold a handful of
        // the 138 sparse points, seen at grazing angles. A range cut at the 2nd and 98th
        // percentiles of each view's own points left the floor unswept (textured surfaces
        // within 1 %: 61.5 %); even all but two of view 1's own points span only z = 0.10
        // to 1.99. The range of every point in the frustum, less two at each end, covers
        // the floor in every view.
        let scene = scene_through_colmap_with(
            "tiny",
            &crate::synth::RenderOptions {
                width: Some(320),
                height: Some(240),
                seed_override: None,
            },
        );
        let cfg = SweepBaselineConfig::default();
        let axes = scene_axes(&scene, &cfg);
        for v in 0..scene.views.len() {
            let setup = sweep_setup(&scene, v, &axes, &cfg).unwrap();
            let vertical = setup.families[1..]
                .iter()
                .find(|f| f.planes[0].normal.z.abs() > 0.99)
                .unwrap_or_else(|| panic!("view {v}: no horizontal family"));
            // Offsets along ±z, in sweep order; the plane z = h has offset ±h.
            let height = |p: &Plane| p.offset * p.normal.z.signum();
            let (a, b) = (
                height(&vertical.planes[0]),
                height(&vertical.planes[vertical.planes.len() - 1]),
            );
            let (lo, hi) = (a.min(b), a.max(b));
            assert!(
                lo < -0.01 && hi > 0.76,
                "view {v}: heights {lo:.3}..{hi:.3}"
            );
        }
        let bad = SweepBaselineConfig {
            axis_margin: -0.1,
            ..cfg
        };
        let err = bad.validate().unwrap_err().to_string();
        assert!(err.contains("axis_margin"), "{err}");
    }

    #[test]
    fn depth_range_reaches_a_pillar_beside_the_camera() {
        // occlusion: the pillar at the left edge of views 0, 1 and 4 stands nearer than the
        // 2nd percentile of those views' own sparse points (view 4: 1.78 m against 2.42 m),
        // so the fronto-parallel family began behind it: 3.6 % of the scene's textured
        // surfaces were never swept. Other views tracked points on it; with every point in
        // the image, less two at each end, the range covers the pillar.
        let (scene, dir) = workspace_through_colmap("occlusion", &Default::default());
        let cfg = SweepBaselineConfig::default();
        for (v, view) in scene.views.iter().enumerate() {
            let setup = sweep_setup(&scene, v, &[], &cfg).unwrap();
            let centre = view.center();
            let depths: Vec<f64> = setup.families[0]
                .planes
                .iter()
                .map(|p| p.offset - p.normal.dot(&centre))
                .collect();
            let (near, far) = (
                depths[0].min(depths[depths.len() - 1]),
                depths[0].max(depths[depths.len() - 1]),
            );
            let stem = std::path::Path::new(&view.name).with_extension("pfm");
            let gt =
                crate::io::pfm::read_pfm_path(&dir.path().join("gt/depth").join(&stem)).unwrap();
            let seen: Vec<f32> = gt.data.iter().copied().filter(|&z| z > 0.0).collect();
            let outside = seen
                .iter()
                .filter(|&&z| (z as f64) < near || (z as f64) > far)
                .count();
            assert!(
                outside * 200 <= seen.len(),
                "view {v}: {outside} of {} pixels outside the swept depths {near:.2}..{far:.2}",
                seen.len()
            );
        }
    }

    #[test]
    fn gable_sweeps_its_roof_slopes() {
        // The house's 45° roofs have normals (0, ±1, 1)/√2; its Manhattan axes are the
        // vertical and the turned wing's two horizontals. Only the extra directions give
        // the roofs a family of their own.
        let scene = scene_through_colmap("gable");
        let roof = |axes: &[Vector3<f64>]| {
            axes.iter().any(|d| {
                let d = d.normalize();
                d.x.abs() < 0.1 && (d.y.abs() - d.z.abs()).abs() < 0.1
            })
        };
        let manhattan = SweepBaselineConfig {
            extra_directions: 0,
            ..Default::default()
        };
        let axes = scene_axes(&scene, &manhattan);
        assert!(!roof(&axes), "{axes:?}");
        let axes = scene_axes(&scene, &SweepBaselineConfig::default());
        assert!(axes.len() > 3 && roof(&axes[3..]), "{axes:?}");
    }

    #[test]
    fn sweep_directions_of_the_stairs_are_the_world_axes() {
        // The stairs are axis-aligned; at their own 320×240 the normals of their points
        // alone mix treads, risers and nosings and put one "axis" about 11° off, so the
        // tread family matched no tread. The pipeline's refit from the plane hypotheses
        // corrects it.
        let scene = scene_through_colmap("stairs");
        let unrefined = crate::axes::dominant_axes(
            &crate::normals::estimate_normals(&scene, &Default::default()).unwrap(),
            &Default::default(),
        )
        .unwrap();
        let worst_unrefined = unrefined
            .directions
            .iter()
            .map(off_axis_deg)
            .fold(0.0, f64::max);
        // The three Manhattan axes come first; a non-Manhattan extra (the flight's slope,
        // `extra_directions`) may follow them.
        let axes = scene_axes(&scene, &SweepBaselineConfig::default());
        assert!(axes.len() >= 3, "{axes:?}");
        let worst = axes[..3].iter().map(off_axis_deg).fold(0.0, f64::max);
        assert!(
            worst < 1.0,
            "a sweep direction is {worst:.2}° off its world axis"
        );
        assert!(
            worst_unrefined > 3.0 * worst.max(0.5),
            "the refit should matter here: {worst_unrefined:.2}° before, {worst:.2}° after"
        );
    }

    #[test]
    fn family_step_is_the_disparity_between_consecutive_planes() {
        // A neighbour shifted sideways by b: a fronto-parallel plane at depth z moves every
        // pixel by the disparity f·b/z, and planes evenly spaced in inverse depth by the
        // same f·b·Δ(1/z) everywhere.
        use crate::geometry::{Camera, Rigid3};
        let (f, b) = (200.0, 0.3);
        let view = |x: f64| View {
            id: 0,
            name: "v".into(),
            camera: Camera::pinhole(320, 240, f, f, 160.0, 120.0),
            cam_from_world: Rigid3::translation(-x, 0.0, 0.0),
            image_path: None,
        };
        let (reference, neighbour) = (view(0.0), view(b));
        let (near, far, n) = (2.0, 20.0, 64);
        let planes = fronto_parallel_planes(&reference, near, far, n).unwrap();
        let expected = f * b * (1.0 / near - 1.0 / far) / (n - 1) as f64;
        for q in [0.0, 0.5, 1.0] {
            let step = family_step_px(&reference, &[&neighbour], &planes, q).unwrap();
            assert!(
                (step - expected).abs() < 1e-6 * expected,
                "q {q}: {step} vs {expected}"
            );
        }
        // Twice the planes, half the step; no neighbour sees anything: None.
        let fine = fronto_parallel_planes(&reference, near, far, 2 * n - 1).unwrap();
        let half = family_step_px(&reference, &[&neighbour], &fine, 0.5).unwrap();
        assert!((half - expected / 2.0).abs() < 1e-6 * expected);
        let behind = View {
            cam_from_world: Rigid3::translation(0.0, 0.0, -100.0),
            ..view(0.0)
        };
        assert_eq!(family_step_px(&reference, &[&behind], &planes, 0.5), None);
    }

    #[test]
    fn coarse_families_are_densified_to_the_step_target() {
        // Two cameras 1 m apart sideways, f = 200 px, points between 2 and 20 m: 16
        // fronto-parallel planes move a pixel by about 6 px each; the sweep densifies them
        // to a median step of 1 px, up to the cap, and leaves them alone when told to.
        use crate::geometry::{Camera, Rigid3};
        use crate::scene::SparseCloud;
        let view = |x: f64, id: u32| View {
            id,
            name: format!("v{id}"),
            camera: Camera::pinhole(320, 240, 200.0, 200.0, 160.0, 120.0),
            cam_from_world: Rigid3::translation(-x, 0.0, 0.0),
            image_path: None,
        };
        let positions: Vec<Vector3<f64>> = (0..40)
            .map(|i| {
                let z = 2.0 + 18.0 * i as f64 / 39.0;
                Vector3::new(0.5 + 0.1 * (i % 5) as f64, 0.1 * (i % 7) as f64 - 0.3, z)
            })
            .collect();
        let n = positions.len();
        let scene = Scene {
            views: vec![view(0.0, 1), view(1.0, 2)],
            cloud: SparseCloud {
                positions,
                colors: vec![[0; 3]; n],
                normals: None,
                tracks: vec![vec![0, 1]; n],
                errors: vec![0.0; n],
                confidence: vec![1.0; n],
            },
        };
        let coarse = SweepBaselineConfig {
            planes: 16,
            axis_families: false,
            max_step_px: 1.0,
            ..Default::default()
        };
        let step = |setup: &SweepSetup| {
            family_step_px(
                &scene.views[0],
                &[&scene.views[1]],
                &setup.families[0].planes,
                0.5,
            )
            .unwrap()
        };
        let off = sweep_setup(
            &scene,
            0,
            &[],
            &SweepBaselineConfig {
                max_step_px: 0.0,
                ..coarse.clone()
            },
        )
        .unwrap();
        assert_eq!(off.families[0].planes.len(), 16);
        assert!(step(&off) > 4.0, "coarse step {}", step(&off));
        let dense = sweep_setup(&scene, 0, &[], &coarse).unwrap();
        let planes = dense.families[0].planes.len();
        assert!((60..=130).contains(&planes), "{planes} planes");
        assert!(step(&dense) <= 1.0 + 1e-9, "dense step {}", step(&dense));
        let default_step = SweepBaselineConfig::default().max_step_px;
        let finer = sweep_setup(
            &scene,
            0,
            &[],
            &SweepBaselineConfig {
                max_step_px: default_step,
                ..coarse.clone()
            },
        )
        .unwrap();
        assert!(finer.families[0].planes.len() > planes);
        assert!(
            step(&finer) <= default_step + 1e-9,
            "finer step {}",
            step(&finer)
        );
        let capped = sweep_setup(
            &scene,
            0,
            &[],
            &SweepBaselineConfig {
                max_family_planes: 40,
                ..coarse.clone()
            },
        )
        .unwrap();
        assert_eq!(capped.families[0].planes.len(), 40);
        let bad = SweepBaselineConfig {
            max_step_px: f64::NAN,
            ..coarse
        };
        let err = sweep_setup(&scene, 0, &[], &bad).unwrap_err().to_string();
        assert!(err.contains("max_step_px"), "{err}");
    }

    /// Two views of the floor z = 0, the second shifted sideways: view 0's pixels whose
    /// floor point falls outside view 1 are not covisible, the rest are, unless view 1's
    /// depth there says something nearer hides the floor.
    #[test]
    fn covisible_pixels_are_seen_by_another_view_unhidden() {
        let cam = crate::geometry::Camera::pinhole(40, 30, 30.0, 30.0, 20.0, 15.0);
        let down = |x: f64| View {
            id: 1,
            name: "v".into(),
            camera: cam.clone(),
            cam_from_world: crate::geometry::look_at(
                &Vector3::new(x, 0.0, 4.0),
                &Vector3::new(x, 0.0, 0.0),
                &Vector3::y(),
            ),
            image_path: None,
        };
        let views = vec![down(0.0), down(2.0)];
        // Both look straight down from 4 m: the floor's depth is 4 everywhere.
        let floor = vec![4.0f32; 40 * 30];
        let mut hidden = floor.clone();
        let mask = covisible_mask(&views, &[&floor, &floor], 0, 0.01);
        let seen_x = |m: &[bool], x: usize| (0..30).all(|y| m[y * 40 + x]);
        let unseen_x = |m: &[bool], x: usize| (0..30).all(|y| !m[y * 40 + x]);
        // View 1 sees x ∈ [2 − 2.67, 2 + 2.67] m of the floor; view 0's column u shows
        // x = (u + 0.5 − 20) · 4 / 30, so columns from 15 on are seen by it.
        let (world_x, world_u) = (|u: usize| (u as f64 + 0.5 - 20.0) * 4.0 / 30.0, 15usize);
        assert!(world_x(world_u) > 2.0 - 2.67 && world_x(world_u - 1) < 2.0 - 2.67);
        assert!(unseen_x(&mask, 0) && unseen_x(&mask, 13));
        assert!(seen_x(&mask, 16) && seen_x(&mask, 39));
        // Something 1 m above the floor in view 1's left half hides view 0's middle.
        for y in 0..30 {
            for x in 0..20 {
                hidden[y * 40 + x] = 3.0;
            }
        }
        let mask = covisible_mask(&views, &[&floor, &hidden], 0, 0.01);
        assert!(unseen_x(&mask, 20) && unseen_x(&mask, 30));
        assert!(seen_x(&mask, 36) && seen_x(&mask, 39));
        // Background pixels (depth 0) never count.
        let mut sky = floor.clone();
        sky[0..40].fill(0.0);
        let mask = covisible_mask(&views, &[&sky, &floor], 0, 0.01);
        assert!(mask[..40].iter().all(|&m| !m) && mask[40 + 39]);
    }

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

/// Which pixels of view `index` show a surface that some other view also sees: the pixel's
/// ground-truth point (`gt_depths[index]`, camera z; 0 = background) projects inside
/// another view, in front of it, within one pixel of a pixel whose ground-truth depth there
/// agrees within `tolerance` (relative). Stereo cannot measure a surface only one view
/// sees (outside every neighbour's frame, or hidden there): the benchmark reports the sweep
/// on these pixels beside all of them, so the two causes of error stay apart.
/// `gt_depths[j]` must hold `views[j]`'s width × height values.
pub fn covisible_mask(
    views: &[View],
    gt_depths: &[&[f32]],
    index: usize,
    tolerance: f64,
) -> Vec<bool> {
    let view = &views[index];
    let (w, h) = (view.camera.width as usize, view.camera.height as usize);
    let depth = gt_depths[index];
    let seen_in = |j: usize, x: &Vector3<f64>| -> bool {
        let other = &views[j];
        let Some((uv, z)) = other.project(x) else {
            return false;
        };
        if z <= 0.0 || !other.camera.contains(&uv) {
            return false;
        }
        let (ow, oh) = (other.camera.width as i64, other.camera.height as i64);
        let (cx, cy) = (uv.x.floor() as i64, uv.y.floor() as i64);
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (px, py) = (cx + dx, cy + dy);
                if px < 0 || py < 0 || px >= ow || py >= oh {
                    return false;
                }
                let g = gt_depths[j][(py * ow + px) as usize] as f64;
                g > 0.0 && (g - z).abs() <= tolerance * z
            })
        })
    };
    (0..w * h)
        .into_par_iter()
        .map(|p| {
            let g = depth[p] as f64;
            if g <= 0.0 {
                return false;
            }
            let xy = Vector2::new((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
            let (origin, dir) = view.ray(&xy);
            let x = origin + dir * g;
            (0..views.len()).any(|j| j != index && seen_in(j, &x))
        })
        .collect()
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
