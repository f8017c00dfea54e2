//! The global stages, once per scene: sampling scale, normals, dominant axes and plane
//! hypotheses (and, with the non-planar label, the classifier and the images).

use std::time::Instant;

use rayon::prelude::*;

use super::{Config, PipelineError};
use crate::axes::{dominant_axes, refine_axes_from_planes, AxisPlane, DominantAxes};
use crate::classify::PlanarityModel;
use crate::hypotheses::{
    free_plane_hypotheses, line_plane_hypotheses, plane_hypotheses, sweep_hypotheses,
    CreaseHypothesis, HypothesesInput, PlaneHypothesis,
};
use crate::nonplanar::NonplanarView;
use crate::normals::{estimate_normals_with_scale, OrientedCloud};
use crate::progress::Progress;
use crate::raster::ImageF32;
use crate::scale::sampling_scale;
use crate::scene::Scene;

/// The global (all-view) results: scale, oriented points, axes, plane hypotheses.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Sampling scale R (3D size of a pixel at the points' depths).
    pub scale: f64,
    /// Normals and confidences of the sparse points.
    pub oriented: OrientedCloud,
    /// Dominant directions.
    pub axes: DominantAxes,
    /// Plane hypotheses; a planemap label `l` is hypothesis `l`. The sparse-point ones come
    /// first (the free planes last among them), then those of the photo-consistency sweep,
    /// then those of the 3D lines.
    pub hypotheses: Vec<PlaneHypothesis>,
    /// How many of `hypotheses` come from the photo-consistency sweep
    /// ([`crate::hypotheses::sweep_hypotheses`]), just before the lines'; they are offered
    /// in every view where they lie in front of the camera, since few sparse points support
    /// them.
    pub sweep_hypotheses: usize,
    /// How many of `hypotheses` (the last ones before the creases') come from 3D lines
    /// ([`crate::hypotheses::line_plane_hypotheses`]); offered as the sweep's are.
    pub line_hypotheses: usize,
    /// How many of the point hypotheses (the last ones, just before the sweep's) are free
    /// planes ([`crate::hypotheses::free_plane_hypotheses`]).
    pub free_hypotheses: usize,
    /// One entry per crease hypothesis ([`crate::hypotheses::crease_hypotheses`]) — the very
    /// last of `hypotheses`, after the sweep's, added by [`super::run`] after a first labelling —
    /// in order: the indices of the views that see it, the only views offered it. Empty
    /// after [`prepare`].
    pub crease_views: Vec<Vec<usize>>,
    /// The undistorted images of all views, when a stage needs the neighbours' images (the
    /// sweep or the photo-consistency data term); `None` otherwise.
    pub images: Option<Vec<ImageF32>>,
    /// The planar/non-planar classifier, loaded when `nonplanar.enabled`.
    pub classifier: Option<PlanarityModel>,
    /// Per view, the non-planar label's classifier map and sweep once computed
    /// ([`NonplanarView::sweep`]): they do not depend on the plane labels, so the labelling
    /// after the crease hypotheses reuses the first pass's. Empty without the label.
    pub nonplanar_sweeps: Vec<std::sync::OnceLock<NonplanarView>>,
    /// Seconds spent per stage: scale + normals, axes, hypotheses.
    pub seconds: [f64; 3],
}

impl Prepared {
    /// Appends crease hypotheses (their ids continue `hypotheses`'), each offered in the
    /// views that see it.
    pub fn add_crease_hypotheses(&mut self, creases: Vec<CreaseHypothesis>) {
        for c in creases {
            self.hypotheses.push(c.hypothesis);
            self.crease_views.push(c.views);
        }
    }
}

/// The sparse-point stages: sampling scale, normals, dominant axes and the plane hypotheses
/// of the points, with the axes refit from the points on their hypotheses
/// (`cfg.axes.refine.iterations` rounds). No images are read.
#[derive(Debug, Clone)]
pub struct SparseStages {
    /// Sampling scale R.
    pub scale: f64,
    /// Normals and confidences of the sparse points.
    pub oriented: OrientedCloud,
    /// Dominant directions after the refit.
    pub axes: DominantAxes,
    /// Plane hypotheses of the points: along the refit axes, then the free planes.
    pub hypotheses: Vec<PlaneHypothesis>,
    /// How many of `hypotheses` (the last ones) are free planes
    /// ([`crate::hypotheses::free_plane_hypotheses`]).
    pub free_hypotheses: usize,
    /// Seconds spent: scale + normals, axes, hypotheses (with the refit).
    pub seconds: [f64; 3],
}

impl SparseStages {
    /// The hypothesis stages' input: `scene`'s points with these normals, axes and scale.
    pub fn input<'a>(&'a self, scene: &'a Scene) -> HypothesesInput<'a> {
        hyp_input(scene, &self.oriented, &self.axes, self.scale)
    }
}

pub(super) fn hyp_input<'a>(
    scene: &'a Scene,
    oriented: &'a OrientedCloud,
    axes: &'a DominantAxes,
    scale: f64,
) -> HypothesesInput<'a> {
    HypothesesInput {
        positions: &scene.cloud.positions,
        normals: &oriented.normals,
        confidence: &oriented.confidence,
        axes,
        scale,
    }
}

/// Runs the sparse-point stages ([`SparseStages`]) on an (undistorted) scene; [`prepare`]
/// starts with them, and the plane-sweep baseline takes its sweep directions from them.
pub fn sparse_stages(scene: &Scene, cfg: &Config) -> Result<SparseStages, PipelineError> {
    if scene.views.is_empty() {
        return Err(PipelineError::Scene("the scene has no views".into()));
    }
    if scene.cloud.is_empty() {
        return Err(PipelineError::Scene(
            "the scene has no sparse points: plane hypotheses come from them".into(),
        ));
    }
    scene
        .cloud
        .validate(scene.views.len())
        .map_err(|e| PipelineError::Scene(e.to_string()))?;
    let t = Instant::now();
    let scale = sampling_scale(scene)?;
    let oriented = estimate_normals_with_scale(scene, scale, &cfg.normals)?;
    let t_normals = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut axes = dominant_axes(&oriented, &cfg.axes)?;
    // The cameras' vertical, when they were held upright (or walked with a known wall).
    let m = axes.num_manhattan.min(axes.directions.len());
    let given = crate::axes::camera_vertical_given(&scene.views, &axes.directions[..m]);
    let camera_up = crate::axes::camera_vertical(&scene.views).or(given);
    if let (true, Some(up)) = (cfg.axes.camera_vertical, given) {
        axes.complete_with_vertical(&up, &oriented.normals, cfg.axes.refine_angle_deg);
    }
    let level = |axes: &mut DominantAxes| {
        if let (true, Some(up)) = (cfg.axes.level_to_camera_vertical, camera_up) {
            axes.level_to(&up, cfg.axes.level_max_deg);
        }
    };
    level(&mut axes);
    let t_axes = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut hypotheses =
        plane_hypotheses(&hyp_input(scene, &oriented, &axes, scale), &cfg.hypotheses)?;
    // Axis refit from the points on the hypotheses, then hypotheses along the refit axes.
    for _ in 0..cfg.axes.refine.iterations {
        let planes: Vec<AxisPlane> = hypotheses
            .iter()
            .filter_map(|h| {
                let axis = h.axis?;
                let sign = h.plane.normal.dot(&axes.directions[axis]).signum();
                Some(AxisPlane {
                    axis,
                    offset: sign * h.plane.offset,
                })
            })
            .collect();
        axes = refine_axes_from_planes(
            &axes,
            &scene.cloud.positions,
            &oriented.normals,
            &planes,
            scale,
            &cfg.axes.refine,
        );
        level(&mut axes);
        hypotheses = plane_hypotheses(&hyp_input(scene, &oriented, &axes, scale), &cfg.hypotheses)?;
    }
    let free = free_plane_hypotheses(
        &hyp_input(scene, &oriented, &axes, scale),
        &hypotheses,
        &cfg.hypotheses,
    )?;
    let free_hypotheses = free.len();
    hypotheses.extend(free);
    Ok(SparseStages {
        scale,
        oriented,
        axes,
        hypotheses,
        free_hypotheses,
        seconds: [t_normals, t_axes, t.elapsed().as_secs_f64()],
    })
}

/// Runs the global stages on an (undistorted) scene.
pub fn prepare(scene: &Scene, cfg: &Config) -> Result<Prepared, PipelineError> {
    prepare_with_progress(scene, cfg, &Progress::hidden())
}

/// [`prepare`], reporting each global stage as it ends: the sparse-point stages, the images,
/// the photo-consistency sweep (the long one) and the classifier.
pub fn prepare_with_progress(
    scene: &Scene,
    cfg: &Config,
    progress: &Progress,
) -> Result<Prepared, PipelineError> {
    let bar = progress.bar(4, "global stages");
    let SparseStages {
        scale,
        oriented,
        axes,
        mut hypotheses,
        free_hypotheses,
        seconds,
    } = sparse_stages(scene, cfg)?;
    progress.println(&format!(
        "R = {scale:.4}, {} dominant directions, {} plane hypotheses from the points",
        axes.directions.len(),
        hypotheses.len()
    ));
    bar.inc(1);
    let t = Instant::now();
    let input = hyp_input(scene, &oriented, &axes, scale);
    // Images are loaded once for all views when a stage matches views against each other.
    let wants_images = cfg.hypotheses.sweep.enabled
        || cfg.hypotheses.lines.enabled
        || cfg.planemap.photo_weight > 0.0
        || cfg.nonplanar.enabled;
    let images = if wants_images && scene.views.iter().all(|v| v.image_path.is_some()) {
        Some(
            scene
                .views
                .par_iter()
                .map(|v| v.load_undistorted_image())
                .collect::<Result<Vec<_>, _>>()?,
        )
    } else {
        None
    };
    bar.inc(1);
    let mut num_sweep = 0;
    if let (true, Some(imgs)) = (cfg.hypotheses.sweep.enabled, &images) {
        let t = Instant::now();
        let (extra, _) = sweep_hypotheses(scene, imgs, &input, &hypotheses, &cfg.hypotheses)?;
        num_sweep = extra.len();
        hypotheses.extend(extra);
        progress.println(&format!(
            "{num_sweep} more plane hypotheses from the photo-consistency sweep ({:.1} s)",
            t.elapsed().as_secs_f64()
        ));
    }
    let mut num_lines = 0;
    if let (true, Some(imgs)) = (cfg.hypotheses.lines.enabled, &images) {
        let t = Instant::now();
        let set = crate::lines::triangulate_lines(scene, imgs, &axes.directions, scale, &cfg.lines);
        let input = hyp_input(scene, &oriented, &axes, scale);
        let extra = line_plane_hypotheses(&input, &set.lines, &hypotheses, &cfg.hypotheses)?;
        num_lines = extra.len();
        for h in &extra {
            tracing::debug!(
                "plane from lines: normal {:.3?}, offset {:.4}, {} sparse points",
                h.plane.normal.as_slice(),
                h.plane.offset,
                h.support
            );
        }
        hypotheses.extend(extra);
        progress.println(&format!(
            "{} segments, {} 3D lines, {num_lines} more plane hypotheses from lines ({:.1} s)",
            set.views.iter().map(|v| v.segments.len()).sum::<usize>(),
            set.lines.len(),
            t.elapsed().as_secs_f64()
        ));
    }
    bar.inc(1);
    if hypotheses.is_empty() {
        return Err(PipelineError::Scene(format!(
            "no plane hypothesis has enough support ({} points, {} dominant directions)",
            scene.cloud.len(),
            axes.directions.len()
        )));
    }
    let classifier = if cfg.nonplanar.enabled {
        if images.is_none() {
            return Err(PipelineError::Scene(
                "nonplanar.enabled needs the images (a view has no image path)".into(),
            ));
        }
        let model = match &cfg.nonplanar.model {
            Some(path) => crate::classify::read_model_path(path),
            None => crate::classify::default_model(),
        };
        Some(model.map_err(|e| PipelineError::Config(format!("nonplanar.model: {e}")))?)
    } else {
        None
    };
    bar.inc(1);
    bar.finish();
    let nonplanar_sweeps = match classifier {
        Some(_) => (0..scene.views.len())
            .map(|_| std::sync::OnceLock::new())
            .collect(),
        None => Vec::new(),
    };
    Ok(Prepared {
        classifier,
        nonplanar_sweeps,
        scale,
        oriented,
        axes,
        hypotheses,
        sweep_hypotheses: num_sweep,
        line_hypotheses: num_lines,
        free_hypotheses,
        crease_views: Vec::new(),
        images,
        seconds: [
            seconds[0],
            seconds[1],
            seconds[2] + t.elapsed().as_secs_f64(),
        ],
    })
}
