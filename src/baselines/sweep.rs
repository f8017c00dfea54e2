//! The plane-sweep baseline: per-view plane-sweep stereo, winner takes all, over
//! fronto-parallel planes spanning the sparse points' depth range plus one plane family per
//! dominant axis (Gallup et al. 2007) — the ordinary stereo that fails on texture-poor walls.
//! The families come from [`crate::photo::multisweep`].

use nalgebra::Vector3;

use super::BaselineError;
use crate::photo::{sweep_setup, MultiSweepConfig, SweepResult};
use crate::raster::ImageF32;
use crate::scene::Scene;

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
pub fn scene_axes(scene: &Scene, cfg: &MultiSweepConfig) -> Vec<Vector3<f64>> {
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
    cfg: &MultiSweepConfig,
) -> Result<SweepResult, BaselineError> {
    let axes = if cfg.axis_families {
        scene_axes(scene, cfg)
    } else {
        Vec::new()
    };
    sweep_view_with_axes(scene, images, index, &axes, cfg)
}

/// [`sweep_view`] with given sweep directions (world frame; used only when
/// `cfg.axis_families`): the fronto-parallel family, then one family per direction
/// ([`sweep_setup`]).
pub fn sweep_view_with_axes(
    scene: &Scene,
    images: &[ImageF32],
    index: usize,
    axes: &[Vector3<f64>],
    cfg: &MultiSweepConfig,
) -> Result<SweepResult, BaselineError> {
    let count = scene.views.len();
    if images.len() != count {
        return Err(BaselineError::Config(format!(
            "{} images for {count} views",
            images.len()
        )));
    }
    let photo_err = |source| BaselineError::Photo {
        view: scene
            .views
            .get(index)
            .map_or_else(|| format!("#{index}"), |v| v.name.clone()),
        source,
    };
    let setup = sweep_setup(scene, index, axes, cfg).map_err(photo_err)?;
    setup.sweep(scene, images, index, cfg).map_err(photo_err)
}
