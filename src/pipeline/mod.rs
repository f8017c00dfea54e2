//! The whole chain: sparse points → normals → dominant axes → plane hypotheses → one
//! planemap per view (α-expansion) → depth and normal maps → fused points.
//!
//! The CLI and library users call the same functions: [`prepare`] for the global stages,
//! [`label_view`] for one view, [`run`] for everything including the output files.
//!
//! - [`config`]: the run configuration ([`Config`]), one section per stage;
//! - [`stages`]: the global stages ([`sparse_stages`], [`prepare`]);
//! - [`label`]: one view's energy and labelling ([`view_energy`], [`label_view`]) and the
//!   multi-view confirmation of the non-planar label;
//! - [`creases`]: the crease pass between the two labellings;
//! - [`outputs`]: the files of a run, and what `--resume` reads back;
//! - [`mod@fuse`]: the fused point cloud ([`fuse()`]).

pub mod config;
pub mod creases;
pub mod fuse;
pub mod label;
pub mod outputs;
pub mod stages;

pub use config::{Config, FusionConfig, SolverConfig};
pub use creases::read_crease_hypotheses;
pub use fuse::fuse;
pub use label::{confirm_nonplanar, label_view, view_energy, ViewPlanemap};
pub use outputs::{write_view_outputs, PlaneRecord, NONPLANAR_COLOR, SWEEP_DIR};
pub use stages::{prepare, sparse_stages, Prepared, SparseStages};

use creases::{crease_pass, write_crease_hypotheses, CREASES_FILE};
use outputs::{load_view_outputs, write_planes_json};

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

use planemap_solvers::MrfError;
use rayon::prelude::*;
use serde::Serialize;
use thiserror::Error;

use crate::axes::AxesError;
use crate::hypotheses::HypothesesError;
use crate::io::atomic::write_atomic;
use crate::io::dense::DenseError;
use crate::io::labelpng::LabelPngError;
use crate::io::pfm::PfmError;
use crate::io::ply::{write_ply_points_path, PlyError};
use crate::normals::NormalsError;
use crate::planemap::PlanemapError;
use crate::progress::Progress;
use crate::scale::ScaleError;
use crate::scene::{Scene, SceneError};

/// Errors of the pipeline; each names the stage (and view) that failed.
#[derive(Debug, Error)]
pub enum PipelineError {
    /// The configuration is invalid.
    #[error("config: {0}")]
    Config(String),
    /// A configuration file or override that cannot be read.
    #[error("config: {0}")]
    ConfigInput(#[from] crate::config::ConfigError),
    /// The scene cannot be used.
    #[error("scene: {0}")]
    Scene(String),
    /// Sampling scale.
    #[error("scale: {0}")]
    Scale(#[from] ScaleError),
    /// Normals stage.
    #[error("normals: {0}")]
    Normals(#[from] NormalsError),
    /// Dominant axes stage.
    #[error("dominant axes: {0}")]
    Axes(#[from] AxesError),
    /// Plane hypotheses stage.
    #[error("plane hypotheses: {0}")]
    Hypotheses(#[from] HypothesesError),
    /// Building a view's energy.
    #[error("view {view:?}: planemap energy: {source}")]
    Planemap {
        /// The view's image name.
        view: String,
        /// What failed.
        source: PlanemapError,
    },
    /// The solver rejected the problem.
    #[error("view {view:?}: solver: {source}")]
    Solver {
        /// The view's image name.
        view: String,
        /// What failed.
        source: MrfError,
    },
    /// Loading an image.
    #[error(transparent)]
    Image(#[from] SceneError),
    /// Writing a PFM.
    #[error(transparent)]
    Pfm(#[from] PfmError),
    /// Writing a COLMAP dense map.
    #[error(transparent)]
    Dense(#[from] DenseError),
    /// Writing a label PNG.
    #[error(transparent)]
    LabelPng(#[from] LabelPngError),
    /// Writing a PLY.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// Another output file.
    #[error("{path}: {message}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

pub(super) fn write_err(path: &Path, e: impl std::fmt::Display) -> PipelineError {
    PipelineError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Which views to process and how.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Indices into `Scene::views` to label (`None` = all).
    pub views: Option<Vec<usize>>,
    /// Skip views whose outputs already exist (reloading their depth for fusion).
    pub resume: bool,
}

/// What a run produced, per view and globally.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    /// Sampling scale R.
    pub scale: f64,
    /// Dominant directions found.
    pub directions: Vec<[f64; 3]>,
    /// Angles between them (degrees).
    pub direction_angles_deg: Vec<(usize, usize, f64)>,
    /// Axial support of each dominant direction (normals within the refine cone).
    pub direction_support: Vec<usize>,
    /// Whether d3 was completed as d1 × d2 (`axes.complete_frame`).
    pub third_axis_completed: bool,
    /// How many directions were added from the cameras' vertical (`axes.camera_vertical`).
    pub directions_from_cameras: usize,
    /// Plane hypotheses.
    pub hypotheses: usize,
    /// Of those, crease hypotheses found after the first labelling (the last ones).
    pub crease_hypotheses: usize,
    /// Per view: name, candidate labels, energy before/after, cycles, build and solve seconds.
    pub views: Vec<ViewSummary>,
    /// Points in fused.ply.
    pub fused_points: usize,
    /// Wall-clock seconds per stage: normals, axes, hypotheses, planemaps, fusion.
    pub stage_seconds: [f64; 5],
}

/// One view's line of the summary.
#[derive(Debug, Clone, Serialize)]
pub struct ViewSummary {
    /// Image name.
    pub name: String,
    /// Hypotheses kept for the view.
    pub candidate_labels: usize,
    /// Energy of the start labelling.
    pub initial_energy: f64,
    /// Energy of the result.
    pub energy: f64,
    /// α-expansion cycles.
    pub cycles: usize,
    /// Seconds to build the energy.
    pub build_seconds: f64,
    /// Seconds to solve.
    pub solve_seconds: f64,
    /// Whether the view was skipped by `--resume`.
    pub resumed: bool,
}

/// Creates `out` and checks that a file can be written there, so that a read-only or
/// mistyped output folder fails at once rather than after the global stages.
fn check_writable(out: &Path) -> Result<(), PipelineError> {
    std::fs::create_dir_all(out).map_err(|e| write_err(out, e))?;
    let probe = crate::io::atomic::temp_path(&out.join(".planemap-write-check"));
    std::fs::write(&probe, b"").map_err(|e| write_err(out, e))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Runs the whole chain on a scene and writes into `out`:
///
/// ```text
/// out/planemaps/NAME.png       16-bit hypothesis id + 1 per pixel (0 = no plane)
/// out/planemaps/NAME_vis.png   the same in colour (a stable colour per plane)
/// out/depth/NAME.pfm           depth (camera z), 0 = none
/// out/stereo/depth_maps/IMAGE.geometric.bin    COLMAP dense depth map
/// out/stereo/normal_maps/IMAGE.geometric.bin   COLMAP dense normal map (camera frame)
/// out/planes.json              hypotheses, support, which views use them
/// out/crease_hypotheses.json   the crease hypotheses of the first labelling (for --resume)
/// out/fused.ply                back-projected, cross-view consistent points
/// out/summary.json             this summary
/// out/config.toml              the effective configuration (every key, with its doc)
/// ```
pub fn run(
    scene: &Scene,
    cfg: &Config,
    out: &Path,
    opts: &RunOptions,
    progress: &Progress,
) -> Result<(Prepared, Vec<ViewPlanemap>, RunSummary), PipelineError> {
    // Everything cheap is checked before the global stages, which take minutes.
    cfg.validate()?;
    crate::io::check_image_names(scene.views.iter().map(|v| v.name.as_str()))
        .map_err(|e| PipelineError::Scene(e.to_string()))?;
    let indices: Vec<usize> = match &opts.views {
        Some(v) => {
            if let Some(&bad) = v.iter().find(|&&i| i >= scene.views.len()) {
                return Err(PipelineError::Scene(format!(
                    "view index {bad} out of range (the scene has {} views, 0..{})",
                    scene.views.len(),
                    scene.views.len()
                )));
            }
            // Each view once, in the order given: a view listed twice would be labelled
            // twice at once, its files written by two threads.
            let mut seen = std::collections::BTreeSet::new();
            v.iter().copied().filter(|i| seen.insert(*i)).collect()
        }
        None => (0..scene.views.len()).collect(),
    };
    check_writable(out)?;
    let scene = scene.undistorted();
    let bar = progress.bar(3, "sparse stages");
    let prepared = prepare(&scene, cfg)?;
    bar.inc(3);
    bar.finish();
    progress.println(&format!(
        "R = {:.4}, {} dominant directions, {} plane hypotheses",
        prepared.scale,
        prepared.axes.directions.len(),
        prepared.hypotheses.len()
    ));
    let t = Instant::now();
    let mut prepared = prepared;
    // With crease hypotheses: a first labelling of every view (nothing written), the
    // hypotheses it yields, then the labelling below with them. If there are none, the first
    // labelling is the result. `--resume` reuses the hypotheses a previous run saved.
    let mut first: Option<Vec<ViewPlanemap>> = None;
    if cfg.hypotheses.creases.enabled {
        let saved_path = out.join(CREASES_FILE);
        let saved = if opts.resume {
            read_crease_hypotheses(&saved_path, &scene, prepared.hypotheses.len())
        } else {
            None
        };
        let extra = match saved {
            Some(extra) => {
                progress.println(&format!(
                    "{} crease hypotheses reloaded from {}",
                    extra.len(),
                    saved_path.display()
                ));
                extra
            }
            None => {
                let (extra, pass) = crease_pass(&scene, &prepared, &indices, cfg, progress)?;
                write_crease_hypotheses(&saved_path, &scene, &extra)?;
                progress.println(&format!(
                    "{} crease hypotheses from the first labelling",
                    extra.len()
                ));
                if extra.is_empty() {
                    first = Some(pass);
                }
                extra
            }
        };
        prepared.add_crease_hypotheses(extra);
    }
    let prepared = prepared;
    let bar = progress.bar(indices.len() as u64, "planemaps");
    let results: Vec<Result<(ViewPlanemap, bool), PipelineError>> = indices
        .par_iter()
        .enumerate()
        .map(|(k, &i)| {
            let view = &scene.views[i];
            if let Some(done) = first.as_ref().map(|f| &f[k]) {
                write_view_outputs(out, &scene, done)?;
                bar.inc(1);
                return Ok((done.clone(), false));
            }
            if opts.resume {
                let need_sweep = prepared.classifier.is_some();
                if let Some(done) = load_view_outputs(out, &scene, &prepared, i, need_sweep) {
                    bar.inc(1);
                    return Ok((done, true));
                }
            }
            let image = view.load_undistorted_image()?;
            let result = label_view(&scene, &prepared, i, &image, cfg)?;
            write_view_outputs(out, &scene, &result)?;
            bar.inc(1);
            Ok((result, false))
        })
        .collect();
    bar.finish();
    let t_views = t.elapsed().as_secs_f64();
    let mut views = Vec::with_capacity(results.len());
    let mut resumed = Vec::with_capacity(results.len());
    for r in results {
        let (v, skipped) = r?;
        views.push(v);
        resumed.push(skipped);
    }
    let np = &cfg.nonplanar;
    if np.enabled && np.consistent_views > 0 {
        let changed = confirm_nonplanar(&scene, &mut views, np);
        for (v, &n) in views.iter().zip(&changed) {
            if n > 0 {
                write_view_outputs(out, &scene, v)?;
            }
        }
        progress.println(&format!(
            "{} pixels made non-planar: their sweep depth is confirmed by ≥ {} other views and no plane gives it",
            changed.iter().sum::<usize>(),
            np.consistent_views
        ));
    }
    let t = Instant::now();
    let fused = fuse(&scene, &views, &cfg.fusion)?;
    write_ply_points_path(&out.join("fused.ply"), &fused)?;
    write_planes_json(&out.join("planes.json"), &scene, &prepared, &views)?;
    let t_fuse = t.elapsed().as_secs_f64();
    let summary = RunSummary {
        scale: prepared.scale,
        directions: prepared
            .axes
            .directions
            .iter()
            .map(|d| [d.x, d.y, d.z])
            .collect(),
        direction_angles_deg: prepared.axes.pairwise_angles_deg.clone(),
        direction_support: prepared.axes.support.clone(),
        third_axis_completed: prepared
            .axes
            .warnings
            .iter()
            .any(|w| matches!(w, crate::axes::AxesWarning::CompletedThird(_))),
        directions_from_cameras: prepared
            .axes
            .warnings
            .iter()
            .map(|w| match w {
                crate::axes::AxesWarning::CompletedWithVertical(n) => *n,
                _ => 0,
            })
            .sum(),
        hypotheses: prepared.hypotheses.len(),
        crease_hypotheses: prepared.crease_views.len(),
        views: views
            .iter()
            .zip(&resumed)
            .map(|(v, &r)| ViewSummary {
                name: scene.views[v.view_index].name.clone(),
                candidate_labels: v.candidate_labels,
                initial_energy: v.energy.0,
                energy: v.energy.1,
                cycles: v.cycles,
                build_seconds: v.seconds.0,
                solve_seconds: v.seconds.1,
                resumed: r,
            })
            .collect(),
        fused_points: fused.positions.len(),
        stage_seconds: [
            prepared.seconds[0],
            prepared.seconds[1],
            prepared.seconds[2],
            t_views,
            t_fuse,
        ],
    };
    let path = out.join("summary.json");
    let json = serde_json::to_string_pretty(&summary).map_err(|e| write_err(&path, e))?;
    write_atomic::<std::io::Error, _>(&path, |f: &mut BufWriter<File>| {
        std::io::Write::write_all(f, json.as_bytes())
    })
    .map_err(|e| write_err(&path, e))?;
    // The configuration the run used, every key spelled out: `--config` reads it back.
    let path = out.join("config.toml");
    let text = cfg.describe()?;
    write_atomic::<std::io::Error, _>(&path, |f: &mut BufWriter<File>| {
        std::io::Write::write_all(f, text.as_bytes())
    })
    .map_err(|e| write_err(&path, e))?;
    Ok((prepared, views, summary))
}

#[cfg(test)]
mod tests;
