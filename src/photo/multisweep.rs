//! The multi-family plane sweep driver: which planes a view is swept over and with which
//! neighbours. Fronto-parallel planes over the depth range of the sparse points the view
//! sees, plus one family per dominant direction over the points' extent along it (Gallup et
//! al. 2007), each densified until consecutive planes move a pixel by at most
//! [`MultiSweepConfig::max_step_px`] in the neighbours. The sweep baseline
//! (`crate::baselines`) and the non-planar label (`crate::nonplanar`) both sweep this way.

use nalgebra::{Vector2, Vector3};
use serde::{Deserialize, Serialize};

use super::{
    axis_planes, axis_sweep_planes, fronto_parallel_planes, multi_family_sweep, select_neighbours,
    Aggregation, PhotoConfig, PhotoError, PlaneFamily, SgmConfig, Spacing, SweepConfig,
    SweepResult,
};
use crate::geometry::Plane;
use crate::raster::ImageF32;
use crate::scene::{Scene, View};

/// Settings of the multi-family plane sweep: the plane families, their density, the
/// neighbours and the scoring.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct MultiSweepConfig {
    /// Fronto-parallel planes, evenly spaced in inverse depth, a count: where the family
    /// starts before `max_step_px` densifies it.
    pub planes: usize,
    /// Also sweep along each dominant axis of the scene (Gallup et al. 2007), the winner
    /// taken over all families ([`multi_family_sweep`]). On: floors, walls and facades seen
    /// at a slant are then matched with correctly slanted windows, which a fronto-parallel
    /// window cannot do.
    pub axis_families: bool,
    /// Planes per axis family, evenly spaced in offset, a count (0 = no axis families):
    /// where each family starts before `max_step_px` densifies it.
    pub axis_planes: usize,
    /// An axis family spans the range along the axis of the sparse points inside the
    /// view's frustum between the near and far depths of its own points (all but the
    /// `range_trim_points` most extreme at each end), widened by this fraction of that
    /// range on each side (≥ 0) and clipped to the frustum between the near and far
    /// depths. Not tuned.
    pub axis_margin: f64,
    /// Sparse points left out at each end of a range read from the points in the view's
    /// image, whichever views tracked them (isolated SfM outliers): the depth range and
    /// each axis family's range. A count, not a quantile: a floor or table top
    /// seen at a grazing angle may hold under 2 % of a view's points, and a percentile cut
    /// leaves it unswept (docs/notes/photo-and-sweep-baseline.md).
    pub range_trim_points: usize,
    /// The depth range is [near · z_lo, far · z_hi]: z_lo is the smaller of the 2nd
    /// percentile of the depths of the view's own sparse points and the depth of the
    /// (`range_trim_points` + 1)-th nearest sparse point in its image, whichever views
    /// tracked it; z_hi likewise at the far end (the view's own points alone miss a pillar
    /// next to the camera or a far gable that other views tracked). `near_factor`, a
    /// factor (below 1 to reach nearer than the points) …
    pub near_factor: f64,
    /// … and `far_factor` (above 1 to reach farther): a little room beyond the points; a
    /// wider far end gave the winner-takes-all more wrong planes
    /// (docs/notes/photo-and-sweep-baseline.md).
    pub far_factor: f64,
    /// Sub-plane refinement ([`super::refine_subplane`]): fit a parabola to the cost at the
    /// winning plane and its two neighbours and move the depth to the parabola's minimum.
    /// On: without it the winner-takes-all depth is quantised to the plane spacing (a few %
    /// of depth), which alone defeats a 1 % tolerance.
    pub subplane: bool,
    /// Densify a family whose consecutive planes move a pixel by more than this many pixels
    /// in the neighbours (median over the view, [`family_step_px`]): its plane count is
    /// scaled up to bring the median step to this value, at most to `max_family_planes`.
    /// In pixels, ≥ 0; 0 = the configured counts as they are. Gallup et al. (2007) space
    /// their sweeps so that no plane step exceeds a pixel of disparity; coarser, the NCC
    /// basin is narrower than the step and sub-plane refinement has nothing to fit. The
    /// sweep baseline's sub-pixel step was the best tried with its semi-global paths, where
    /// a finer step is also a smaller P1 jump; the non-planar label keeps the 1 px step it
    /// was tuned with (docs/notes/photo-and-sweep-baseline.md).
    pub max_step_px: f64,
    /// Cap on a densified family's plane count, ≥ 2: time and memory grow linearly with
    /// it, and a higher cap changed nothing on the 13 scenes.
    pub max_family_planes: usize,
    /// Non-Manhattan directions (roof slopes, turned wings) swept besides the three axes,
    /// a count, 0 = the Manhattan axes only: the `axes.max_extra_directions` with which the
    /// sweep baseline asks the points for its directions
    /// ([`crate::baselines::scene_axes`]); the non-planar label sweeps the pipeline's own
    /// axes and does not read it. Pitched roofs and turned wings otherwise have only the
    /// fronto-parallel family (docs/notes/photo-and-sweep-baseline.md).
    pub extra_directions: usize,
    /// Scoring: neighbour views (the cost combines the best `photo.best_k` of those that
    /// see the window), measure, window, normalisation, aggregation, support weights. The
    /// comments of `Default` explain the sweep baseline's choices; `nonplanar.sweep` the
    /// non-planar label's.
    pub photo: PhotoConfig,
    /// Confidence is `second-best − best` cost, the second best taken over planes whose
    /// index differs from the winner's by more than this, a count
    /// ([`SweepConfig::confidence_exclusion`]).
    pub confidence_exclusion: usize,
    /// Semi-global aggregation of each family's cost volume before the winner-takes-all
    /// (Hirschmüller 2008); `sgm.paths` = 0 turns it off. The sweep baseline aggregates
    /// over 8 paths, which settles plain surfaces between textured edges; the non-planar
    /// label does not (see `nonplanar.sweep`).
    pub sgm: SgmConfig,
}

impl Default for MultiSweepConfig {
    fn default() -> Self {
        MultiSweepConfig {
            planes: 128,
            axis_families: true,
            axis_planes: 128,
            axis_margin: 0.1,
            range_trim_points: 2,
            near_factor: 0.8,
            far_factor: 1.25,
            subplane: true,
            max_step_px: 0.7,
            max_family_planes: 512,
            extra_directions: 2,
            // 5×5 NCC whose cost slices are guided-filtered over 15×15 (cost-volume
            // filtering, Hosni et al. 2013): weak textures (paving, floor boards, brick)
            // need 15×15 of support under 1 % image noise, which the guided filter gives
            // without fattening depth edges as a 15×15 window would. The best 4 of 8
            // neighbours: on repeated texture (stair treads) two neighbours often agree on a
            // shifted copy, four rarely do. Adaptive support weights (σc 0.1, σs 3) keep a
            // foreground's texture out of the background's windows.
            photo: PhotoConfig {
                neighbours: 8,
                window_radius: 2,
                best_k: 4,
                aggregation: Aggregation::Guided {
                    radius: 7,
                    eps: 1e-3,
                },
                support_sigma_color: 0.1,
                ..Default::default()
            },
            confidence_exclusion: SweepConfig::default().confidence_exclusion,
            // Semi-global aggregation over 8 paths settles plain surfaces between textured
            // edges; P1 0.1 / P2 1.0, chosen together with σc 0.1
            // (docs/notes/photo-and-sweep-baseline.md).
            sgm: SgmConfig {
                paths: 8,
                p1: 0.1,
                p2: 1.0,
                ..Default::default()
            },
        }
    }
}

impl MultiSweepConfig {
    /// The settings of one sweep call ([`multi_family_sweep`]).
    pub fn sweep_config(&self) -> SweepConfig {
        SweepConfig {
            photo: self.photo,
            confidence_exclusion: self.confidence_exclusion,
            sgm: self.sgm,
        }
    }

    /// Checks the values; the error names the field.
    pub fn validate(&self) -> Result<(), PhotoError> {
        let bad = |m: String| Err(PhotoError::InvalidConfig(m));
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
        self.sweep_config().validate()
    }
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
        cfg: &MultiSweepConfig,
    ) -> Result<SweepResult, PhotoError> {
        multi_family_sweep(
            &scene.views[index],
            &images[index],
            &self.pairs(scene, images),
            &self.families,
            &cfg.sweep_config(),
            cfg.subplane,
        )
        .map(|r| r.sweep)
    }
}

/// The plane families and neighbours the sweep baseline (`crate::baselines::sweep_view_with_axes`) sweeps view `index` with:
/// fronto-parallel planes over the depth range of the view's sparse points, and (with
/// `cfg.axis_families`) one family per direction of `axes` over the points' extent along
/// it. Split out so a caller can score other planes with the same neighbours.
pub fn sweep_setup(
    scene: &Scene,
    index: usize,
    axes: &[Vector3<f64>],
    cfg: &MultiSweepConfig,
) -> Result<SweepSetup, PhotoError> {
    cfg.validate()?;
    let count = scene.views.len();
    let view = scene
        .views
        .get(index)
        .ok_or(PhotoError::ViewIndex { index, count })?;
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
        return Err(PhotoError::NoPoints);
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
    let neighbours = select_neighbours(scene, index, cfg.photo.neighbours)?;
    if neighbours.is_empty() {
        return Err(PhotoError::InvalidInput(
            "no neighbour view shares points with this view".into(),
        ));
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
        planes: dense(cfg.planes, &|n| fronto_parallel_planes(view, near, far, n))?,
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
            let frustum = axis_sweep_planes(view, &[*axis], near, far, 2)?;
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
                planes: dense(cfg.axis_planes, &offsets)?,
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

/// The `q`-quantile (nearest rank) of sorted, non-empty `values`.
fn percentile(values: &[f64], q: f64) -> f64 {
    values[((values.len() - 1) as f64 * q).round() as usize]
}
