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
pub mod resume;
pub mod stages;

pub use config::{Config, FusionConfig, SolverConfig};
pub use creases::read_crease_hypotheses;
pub use fuse::fuse;
pub use label::{confirm_nonplanar, label_view, view_energy, ViewPlanemap};
pub use outputs::{write_view_outputs, PlaneRecord, PlaneSource, NONPLANAR_COLOR, SWEEP_DIR};
pub use stages::{prepare, prepare_with_progress, sparse_stages, Prepared, SparseStages};

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

/// Writes `out/config.toml`: the configuration the run used, every key spelled out with its
/// documentation; `--config` reads it back.
fn write_config(out: &Path, cfg: &Config) -> Result<(), PipelineError> {
    let path = out.join("config.toml");
    let text = cfg.describe()?;
    write_atomic::<std::io::Error, _>(&path, |f: &mut BufWriter<File>| {
        std::io::Write::write_all(f, text.as_bytes())
    })
    .map_err(|e| write_err(&path, e))
}

/// Writes `scene` (undistorted) as a COLMAP model into `dir`: binary, as `stereo_fusion`
/// reads it, and `cameras.txt` for people.
fn write_undistorted_model(scene: &Scene, dir: &Path) -> Result<(), PipelineError> {
    use crate::io::colmap::{write_cameras_text, write_model_bin, ColmapModel};
    // Observations are the points projected into the undistorted cameras; a track entry
    // whose point is behind its camera (possible in a user's model) has no 2D position and
    // is left out of the written model rather than failing the run.
    let mut kept = scene.clone();
    let mut observations = Vec::with_capacity(kept.cloud.len());
    let mut dropped = 0usize;
    for (track, p) in kept.cloud.tracks.iter_mut().zip(&scene.cloud.positions) {
        let mut xy = Vec::with_capacity(track.len());
        let before = track.len();
        track.retain(|&v| match scene.views[v as usize].project(p) {
            Some((q, _)) => {
                xy.push([q.x, q.y]);
                true
            }
            None => false,
        });
        dropped += before - track.len();
        observations.push(xy);
    }
    if dropped > 0 {
        tracing::warn!(
            "{}: {dropped} observations of points behind their camera left out",
            dir.display()
        );
    }
    let model =
        ColmapModel::from_scene(&kept, Some(&observations)).map_err(|e| write_err(dir, e))?;
    write_model_bin(dir, &model).map_err(|e| write_err(dir, e))?;
    let path = dir.join("cameras.txt");
    write_atomic::<std::io::Error, _>(&path, |f: &mut BufWriter<File>| {
        write_cameras_text(f, &model.cameras).map_err(std::io::Error::other)
    })
    .map_err(|e| write_err(&path, e))
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
/// out/fingerprint.json         hashes of the inputs and the configuration (for --resume)
/// out/planemaps/NAME.fingerprint   what a view's outputs were made from (for --resume)
/// out/sparse/                  the model in the undistorted cameras the outputs are in
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
    // The fingerprint goes first: whatever a run leaves in `out` is tagged with it, and
    // `--resume` refuses a folder made from other inputs or another configuration.
    let mut fingerprint = resume::Fingerprint::of(scene, cfg)?;
    let previous = if opts.resume {
        Some(fingerprint.check_resumable(out, cfg)?)
    } else {
        fingerprint.write(out)?;
        write_config(out, cfg)?;
        None
    };
    let scene = scene.undistorted();
    let prepared = prepare_with_progress(&scene, cfg, progress)?;
    let t = Instant::now();
    let mut prepared = prepared;
    // With crease hypotheses: a first labelling of every view (nothing written), the
    // hypotheses it yields, then the labelling below with them. If there are none, the first
    // labelling is the result. `--resume` reuses the hypotheses a previous run saved.
    let mut first: Option<Vec<ViewPlanemap>> = None;
    if cfg.hypotheses.creases.enabled {
        let saved_path = out.join(CREASES_FILE);
        let voters: Vec<String> = indices
            .iter()
            .map(|&i| scene.views[i].name.clone())
            .collect();
        // Reloaded only when the same views voted them.
        let saved = match &previous {
            Some(p) if p.crease_voters.as_ref() == Some(&voters) => {
                read_crease_hypotheses(&saved_path, &scene, prepared.hypotheses.len())
            }
            Some(_) => {
                progress
                    .println("the saved crease hypotheses were voted by other views: voting again");
                None
            }
            None => None,
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
                fingerprint.crease_voters = Some(voters);
                fingerprint.write(out)?;
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
    // What every view's outputs are made from; `--resume` reloads a view only if its own
    // key matches.
    let view_key = fingerprint.view_key(&resume::hypotheses_key(&prepared.hypotheses));
    let bar = progress.bar(indices.len() as u64, "planemaps");
    let results: Vec<Result<(ViewPlanemap, bool), PipelineError>> = indices
        .par_iter()
        .enumerate()
        .map(|(k, &i)| {
            let view = &scene.views[i];
            if let Some(done) = first.as_ref().map(|f| &f[k]) {
                resume::write_view_key(out, &view.name, &view_key)?;
                write_view_outputs(out, &scene, done)?;
                bar.inc(1);
                return Ok((done.clone(), false));
            }
            if opts.resume && resume::view_key_matches(out, &view.name, &view_key) {
                let need_sweep = prepared.classifier.is_some();
                if let Some(done) = load_view_outputs(out, &scene, &prepared, i, need_sweep) {
                    bar.inc(1);
                    return Ok((done, true));
                }
            }
            let image = view.load_undistorted_image()?;
            let result = label_view(&scene, &prepared, i, &image, cfg)?;
            resume::write_view_key(out, &view.name, &view_key)?;
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
    // The model in the cameras the outputs are in: distorted cameras were undistorted on
    // load into pinhole ones of the same size, as COLMAP's image_undistorter does, and
    // `stereo_fusion` needs this model beside stereo/.
    write_undistorted_model(&scene, &out.join("sparse"))?;
    Ok((prepared, views, summary))
}

#[cfg(test)]
mod tests;
