//! The synthetic-scene benchmark (`planemap bench`): renders each scene (cached), runs every
//! method on it — planemap and its variants, the plane-sweep WTA baseline
//! ([`crate::baselines::sweep_view`]) and per-view Delaunay interpolation of the sparse points
//! ([`crate::baselines::delaunay`]) — and scores all of them with the same [`crate::eval::metrics`] against the scene's
//! ground truth. [`report`] writes results.json, Markdown tables and PNG charts.
//!
//! Every method's depth maps are fused by the same [`crate::pipeline::fuse()`] (planemap's own
//! run does exactly that), so the point-cloud scores compare depth maps, not fusion rules.
//!
//! Besides scene files, [`BenchConfig::generated`] asks for procedural scenes
//! ([`crate::synth::generate`]): each is drawn, written to `OUT/generated/NAME.toml` and then
//! cached, run and scored exactly like a file; [`markdown`] reports them under their own
//! heading, per kind, with the 10th-percentile and the worst view beside the mean.

pub mod cache;
pub mod font;
pub mod generated;
pub mod real;
pub mod record;
pub mod report;

use std::path::{Path, PathBuf};
use std::time::Instant;

use nalgebra::Vector3;
use rayon::prelude::*;
use serde::Serialize;
use thiserror::Error;

use crate::baselines::{delaunay, scene_axes, sweep_view_with_axes};
use crate::eval::metrics;
use crate::io::labelpng::read_label_png;
use crate::io::output_stem;
use crate::io::pfm::read_pfm_path;
use crate::io::ply::{read_ply_mesh_path, read_ply_points_path};
use crate::nonplanar::NONPLANAR;
use crate::photo::MultiSweepConfig;
use crate::pipeline::{self, Config, FusionConfig, RunOptions, ViewPlanemap};
use crate::progress::Progress;
use crate::scene::Scene;

use metrics::{
    cloud_scores, depth_counts, has_depth, peak_memory_bytes, reset_peak_memory,
    resident_memory_bytes, segmentation, view_collapsed, CloudScores, Collapses, DepthCounts,
    MeshDistance, Segmentation,
};

pub use generated::{
    generated_markdown, kind_summaries, markdown, parse_generated, GeneratedSet, GeneratedTag,
    KindSummary,
};

/// Errors of the benchmark.
#[derive(Debug, Error)]
pub enum BenchError {
    /// A file could not be read or written.
    #[error("{path}: {message}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A scene file is invalid or could not be rendered.
    #[error(transparent)]
    Synth(#[from] crate::synth::SynthError),
    /// The rendered workspace could not be written.
    #[error(transparent)]
    Workspace(#[from] crate::workspace::WorkspaceError),
    /// The rendered workspace could not be read back.
    #[error(transparent)]
    Colmap(#[from] crate::io::colmap::ColmapError),
    /// Ground truth could not be read.
    #[error("ground truth {path}: {message}")]
    GroundTruth {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A bad option (method name, size, filter).
    #[error("{0}")]
    Option(String),
}

fn io_err(path: &Path, e: impl std::fmt::Display) -> BenchError {
    BenchError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn gt_err(path: &Path, e: impl std::fmt::Display) -> BenchError {
    BenchError::GroundTruth {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// A method the benchmark runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Method {
    /// planemap with the default config (plus `--set` overrides): the visibility-conflict
    /// data term of Furukawa et al. plus the photo-consistency term (`planemap.photo_weight`).
    Planemap,
    /// planemap with the visibility-conflict data term alone (`planemap.photo_weight = 0`):
    /// what the photo-consistency term adds, scene by scene.
    PlanemapVisibility,
    /// planemap without the dominant-line prior (w_pq = 1 everywhere): smoothness alone.
    PlanemapNoLines,
    /// planemap with the classifier's "non-planar" label (`nonplanar.enabled = true`): the
    /// plane-sweep depth where the classifier and the photo costs prefer it to any plane.
    PlanemapClassifier,
    /// Plane-sweep stereo, winner takes all, sub-plane refinement (ordinary MVS).
    Sweep,
    /// Delaunay interpolation of the view's sparse points (OpenMVS's depth initialisation).
    Delaunay,
}

impl Method {
    /// The methods run by default: planemap against both baselines (the variants are
    /// opt-in: each doubles planemap's share of the run time).
    pub const DEFAULT: [Method; 3] = [Method::Planemap, Method::Sweep, Method::Delaunay];

    /// Every method, in report order.
    pub const ALL: [Method; 6] = [
        Method::Planemap,
        Method::PlanemapVisibility,
        Method::PlanemapNoLines,
        Method::PlanemapClassifier,
        Method::Sweep,
        Method::Delaunay,
    ];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Method::Planemap => "planemap",
            Method::PlanemapVisibility => "planemap-vis",
            Method::PlanemapNoLines => "planemap-nolines",
            Method::PlanemapClassifier => "planemap-cls",
            Method::Sweep => "sweep",
            Method::Delaunay => "delaunay",
        }
    }

    /// Parses a name of [`Method::name`].
    pub fn from_name(s: &str) -> Result<Method, BenchError> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s.trim())
            .ok_or_else(|| {
                BenchError::Option(format!(
                    "unknown method {s:?}; expected one of {}",
                    Method::ALL.map(Method::name).join(", ")
                ))
            })
    }
}

/// Parses `--size`: a preset (`tiny` 96×72, `small` 160×120, `default` = each scene's own,
/// `large` 640×480, `stress` 1280×960) or `WxH`.
pub fn parse_size(s: &str) -> Result<Option<(u32, u32)>, BenchError> {
    let preset = match s {
        "default" => return Ok(None),
        "tiny" => Some((96, 72)),
        "small" => Some((160, 120)),
        "large" => Some((640, 480)),
        "stress" => Some((1280, 960)),
        _ => None,
    };
    if preset.is_some() {
        return Ok(preset);
    }
    let bad = || {
        BenchError::Option(format!(
            "bad size {s:?}: expected tiny, small, default, large, stress or WxH (e.g. 320x240)"
        ))
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.parse().map_err(|_| bad())?;
    let h: u32 = h.parse().map_err(|_| bad())?;
    if !(16..=8192).contains(&w) || !(16..=8192).contains(&h) {
        return Err(bad());
    }
    Ok(Some((w, h)))
}

/// Settings of a benchmark run.
#[derive(Debug, Clone)]
pub struct BenchConfig {
    /// Methods to run, in report order.
    pub methods: Vec<Method>,
    /// Image size override for every scene (`None` = each scene's own).
    pub size: Option<(u32, u32)>,
    /// Only scene files whose name, file stem or category is in this list (empty = all);
    /// generated scenes are chosen by [`BenchConfig::generated`] alone.
    pub scene_filter: Vec<String>,
    /// Generated scenes to run after the scene files (`--generated KIND:COUNT@FIRST`).
    pub generated: Vec<GeneratedSet>,
    /// Where rendered scenes are cached (default `OUT/cache`).
    pub cache_dir: Option<PathBuf>,
    /// planemap config (for both planemap methods).
    pub planemap: Config,
    /// Plane-sweep baseline settings.
    pub sweep: MultiSweepConfig,
    /// Fusion of the baselines' depth maps (planemap uses `planemap.fusion`).
    pub fusion: FusionConfig,
    /// Point-cloud tolerance as a fraction of the scene's median ground-truth depth.
    pub cloud_tolerance_fraction: f64,
    /// Write per-view error maps.
    pub error_maps: bool,
}

impl Default for BenchConfig {
    fn default() -> Self {
        BenchConfig {
            methods: Method::DEFAULT.to_vec(),
            size: None,
            scene_filter: Vec::new(),
            generated: Vec::new(),
            cache_dir: None,
            planemap: Config::default(),
            sweep: bench_sweep_config(),
            fusion: Config::default().fusion,
            cloud_tolerance_fraction: 0.01,
            error_maps: true,
        }
    }
}

/// The plane-sweep settings of the benchmark: [`MultiSweepConfig::default`] with
/// [`BENCH_SWEEP_PLANES`] planes and [`BENCH_SWEEP_NEIGHBOURS`] neighbours, so that the whole
/// suite fits its time budget on a shared 2-core machine (the sweep's cost is linear in
/// planes × neighbours; sub-plane refinement keeps the depth continuous). `--sweep-planes`
/// and `--sweep-neighbours` restore the full setting. The benchmark's sweep stays the plain
/// winner-takes-all over box NCC at a 1 px plane step (no semi-global aggregation nor
/// support weights, which the baseline's own default has): the recorded sweep figures and
/// the non-planar comparisons are against it.
pub fn bench_sweep_config() -> MultiSweepConfig {
    let base = MultiSweepConfig::default();
    MultiSweepConfig {
        planes: BENCH_SWEEP_PLANES,
        max_step_px: 1.0,
        photo: crate::photo::PhotoConfig {
            neighbours: BENCH_SWEEP_NEIGHBOURS,
            support_sigma_color: 0.0,
            ..base.photo
        },
        sgm: crate::photo::SgmConfig::default(),
        ..base
    }
}

/// Fronto-parallel planes of the benchmark's sweep (the baseline's own default is 128).
pub const BENCH_SWEEP_PLANES: usize = 64;
/// Neighbour views of the benchmark's sweep (the baseline's own default is 8).
pub const BENCH_SWEEP_NEIGHBOURS: usize = 2;

/// One method's scores on one scene.
#[derive(Debug, Clone, Serialize)]
pub struct MethodResult {
    /// Method name.
    pub method: String,
    /// Why the method failed on this scene (its scores are then empty).
    pub error: Option<String>,
    /// Depth/normal counters over all views.
    pub depth: DepthCounts,
    /// The same over ground-truth planar pixels only (plane id ≠ 0) …
    pub planar_depth: DepthCounts,
    /// … and over ground-truth non-planar pixels only (plane id 0 with a surface: trees,
    /// statues, columns).
    pub nonplanar_depth: DepthCounts,
    /// Per view (image name).
    pub views: Vec<(String, DepthCounts)>,
    /// Plane segmentation (methods with global plane labels only).
    pub segmentation: Option<Segmentation>,
    /// Views collapsed to one plane label ([`metrics::view_collapsed`]; methods with global
    /// plane labels only).
    pub collapse: Option<Collapses>,
    /// Fused point cloud against the ground-truth mesh.
    pub cloud: CloudScores,
    /// Wall-clock seconds per stage, in order.
    pub stages: Vec<(String, f64)>,
    /// Total wall-clock seconds of the method (all stages).
    pub seconds: f64,
    /// Peak resident memory of the process during the method (bytes), if measurable. It
    /// includes what earlier work left resident: see `start_memory_bytes`.
    pub peak_memory_bytes: Option<u64>,
    /// Resident memory when the method started (bytes).
    pub start_memory_bytes: Option<u64>,
}

/// One scene's results.
#[derive(Debug, Clone, Serialize)]
pub struct SceneResult {
    /// Scene name.
    pub name: String,
    /// Category (Manhattan interior, exterior, non-Manhattan, mixed, hard, test).
    pub category: String,
    /// The scene file.
    pub file: PathBuf,
    /// Image size.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Views.
    pub views: usize,
    /// Sparse points.
    pub sparse_points: usize,
    /// Whether the render came from the cache.
    pub cache_hit: bool,
    /// Seconds spent rendering (0 when cached).
    pub render_seconds: f64,
    /// Median ground-truth depth (scene units).
    pub median_depth: f64,
    /// Results per method.
    pub methods: Vec<MethodResult>,
    /// Set for a generated scene (absent from results.json for scene files).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generated: Option<GeneratedTag>,
}

/// A whole benchmark run.
#[derive(Debug, Clone, Serialize)]
pub struct BenchResults {
    /// [`cache::RENDERER_VERSION`].
    pub renderer_version: u32,
    /// Relative depth thresholds of [`DepthCounts::within`].
    pub depth_thresholds: [f64; 3],
    /// Point-cloud tolerance as a fraction of each scene's median depth.
    pub cloud_tolerance_fraction: f64,
    /// Per scene.
    pub scenes: Vec<SceneResult>,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
}

/// Categories of the scenes that predate the `category` field.
fn default_category(name: &str) -> &'static str {
    match name {
        "demo" | "room" | "stairs" => "manhattan-interior",
        "exterior" => "manhattan-exterior",
        "courtyard" => "mixed",
        _ => "uncategorised",
    }
}

/// Expands the arguments into scene files: directories give their `*.toml` (sorted by
/// name), files are taken as they are.
pub fn collect_scene_files(args: &[PathBuf]) -> Result<Vec<PathBuf>, BenchError> {
    let mut files = Vec::new();
    for a in args {
        if a.is_dir() {
            let mut in_dir: Vec<PathBuf> = std::fs::read_dir(a)
                .map_err(|e| io_err(a, e))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "toml"))
                .collect();
            in_dir.sort();
            files.extend(in_dir);
        } else if a.is_file() {
            files.push(a.clone());
        } else {
            return Err(io_err(a, "no such scene file or folder"));
        }
    }
    Ok(files)
}

/// Ground truth of one view.
struct GtView {
    depth: Vec<f32>,
    normals: Vec<[f32; 3]>,
    planes: Vec<u16>,
}

/// A method's output on one view (before scoring).
struct ViewPrediction {
    view_index: usize,
    depth: Vec<f32>,
    /// Camera-frame normals (zero = none).
    normals_cam: Vec<[f32; 3]>,
    /// Global plane label per pixel.
    labels: Option<Vec<Option<u32>>>,
}

struct Prediction {
    views: Vec<ViewPrediction>,
    fused: Vec<Vector3<f64>>,
    stages: Vec<(String, f64)>,
}

/// A scene's `name` names folders of the output (`runs/NAME/`, `maps/NAME/`, the cache): it
/// must be one plain path component, so that no scene file can make the benchmark write
/// outside its output folder.
pub fn check_scene_name(name: &str, file: &Path) -> Result<(), BenchError> {
    let plain = !name.is_empty()
        && name != "."
        && name != ".."
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if plain {
        Ok(())
    } else {
        Err(BenchError::Option(format!(
            "{}: scene name {name:?} must be letters, digits, '-', '_' or '.' (it names \
             the scene's output folders)",
            file.display()
        )))
    }
}

/// Runs the benchmark on `scene_files`, writing into `out`: `results.json`, `results.md`,
/// `accuracy.png`, `time.png`, `maps/SCENE/VIEW.png` and each method's run under `runs/`.
pub fn run_bench(
    scene_files: &[PathBuf],
    cfg: &BenchConfig,
    out: &Path,
    progress: &Progress,
) -> Result<BenchResults, BenchError> {
    let start = Instant::now();
    if cfg.methods.is_empty() {
        return Err(BenchError::Option("no methods to run".into()));
    }
    std::fs::create_dir_all(out).map_err(|e| io_err(out, e))?;
    let cache_root = cfg.cache_dir.clone().unwrap_or_else(|| out.join("cache"));
    std::fs::create_dir_all(&cache_root).map_err(|e| io_err(&cache_root, e))?;
    let mut jobs: Vec<(PathBuf, Option<GeneratedTag>)> =
        scene_files.iter().map(|f| (f.clone(), None)).collect();
    let drawn = generated::write_generated(&cfg.generated, &out.join("generated"))?;
    if !drawn.is_empty() {
        // Before any work: a scene file named like a generated scene would share its output
        // folders.
        let names: std::collections::BTreeSet<String> = drawn
            .iter()
            .filter_map(|(f, _)| f.file_stem().map(|s| s.to_string_lossy().into_owned()))
            .collect();
        for file in scene_files {
            let spec = crate::synth::SceneSpec::from_path(file)?;
            if names.contains(&spec.name) {
                return Err(BenchError::Option(format!(
                    "{}: scene {} has the name of a generated scene of this run (their \
                     outputs would overwrite each other); leave the file out",
                    file.display(),
                    spec.name
                )));
            }
        }
    }
    jobs.extend(drawn);
    let mut scenes = Vec::new();
    for (file, generated) in &jobs {
        let file = file.as_path();
        let spec = crate::synth::SceneSpec::from_path(file)?;
        check_scene_name(&spec.name, file)?;
        let category = if spec.category.is_empty() {
            default_category(&spec.name).to_string()
        } else {
            spec.category.clone()
        };
        let stem = file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        if generated.is_none()
            && !cfg.scene_filter.is_empty()
            && !cfg
                .scene_filter
                .iter()
                .any(|f| f == &spec.name || f == &stem || f == &category)
        {
            continue;
        }
        progress.println(&format!("scene {} ({category})", spec.name));
        let cached = cache::render_cached(file, cfg.size, &cache_root, progress)?;
        let mut result = bench_scene(&cached, &category, file, cfg, out, progress)?;
        result.generated = generated.clone();
        for m in &result.methods {
            progress.println(&format!(
                "  {:<17} depth within 1%: {:5.1}%  F: {:5.1}%  sky given a depth: {:5.1}%  {:6.1} s",
                m.method,
                100.0 * m.depth.accuracy(1),
                100.0 * m.cloud.f_score,
                100.0 * m.depth.empty_with_depth(),
                m.seconds
            ));
        }
        scenes.push(result);
        // Partial results, so an interrupted run still leaves the scenes done so far.
        let partial = BenchResults {
            renderer_version: cache::RENDERER_VERSION,
            depth_thresholds: metrics::DEPTH_THRESHOLDS,
            cloud_tolerance_fraction: cfg.cloud_tolerance_fraction,
            scenes: scenes.clone(),
            seconds: start.elapsed().as_secs_f64(),
        };
        generated::write_reports(&partial, out)?;
    }
    if scenes.is_empty() {
        return Err(BenchError::Option(
            "no scene left after the --scenes filter".into(),
        ));
    }
    let results = BenchResults {
        renderer_version: cache::RENDERER_VERSION,
        depth_thresholds: metrics::DEPTH_THRESHOLDS,
        cloud_tolerance_fraction: cfg.cloud_tolerance_fraction,
        scenes,
        seconds: start.elapsed().as_secs_f64(),
    };
    generated::write_reports(&results, out)?;
    Ok(results)
}

fn bench_scene(
    cached: &cache::CachedScene,
    category: &str,
    file: &Path,
    cfg: &BenchConfig,
    out: &Path,
    progress: &Progress,
) -> Result<SceneResult, BenchError> {
    let ws = &cached.dir;
    let model = crate::io::colmap::read_model(&ws.join("sparse"))?;
    let scene = model.to_scene(Some(&ws.join("images")))?.undistorted();
    let gt_dir = ws.join("gt");
    let gt = load_gt(&scene, &gt_dir)?;
    let mesh_path = gt_dir.join("mesh.ply");
    let mesh = read_ply_mesh_path(&mesh_path).map_err(|e| gt_err(&mesh_path, e))?;
    let mut depths: Vec<f32> = gt
        .iter()
        .flat_map(|g| g.depth.iter().copied().filter(|&z| has_depth(z)))
        .collect();
    depths.sort_by(f32::total_cmp);
    let median_depth = depths.get(depths.len() / 2).copied().unwrap_or(1.0) as f64;
    let tolerance = cfg.cloud_tolerance_fraction * median_depth;
    let mesh_distance = MeshDistance::new(&mesh.vertices, &mesh.faces, 10.0 * tolerance);
    let reference = reference_points(&scene, &gt, cfg.fusion.stride.max(1));
    let name = cached.spec.name.clone();
    let mut methods = Vec::new();
    let mut predictions: Vec<(Method, Option<Vec<Vec<f32>>>)> = Vec::new();
    for &m in &cfg.methods {
        let bar_label = format!("{name}: {}", m.name());
        progress.println(&bar_label);
        reset_peak_memory();
        let start_memory = resident_memory_bytes();
        let t = Instant::now();
        let run_dir = out.join("runs").join(&name).join(m.name());
        let pred = run_method(m, &scene, cfg, &run_dir);
        let seconds = t.elapsed().as_secs_f64();
        let peak = peak_memory_bytes();
        let result = match pred {
            Ok(pred) => {
                let r = score(m, &scene, &gt, &pred, &mesh_distance, &reference, tolerance);
                predictions.push((m, Some(pred.views.into_iter().map(|v| v.depth).collect())));
                MethodResult {
                    stages: pred.stages,
                    seconds,
                    peak_memory_bytes: peak,
                    start_memory_bytes: start_memory,
                    ..r
                }
            }
            Err(e) => {
                predictions.push((m, None));
                MethodResult {
                    method: m.name().into(),
                    error: Some(e),
                    depth: DepthCounts::default(),
                    planar_depth: DepthCounts::default(),
                    nonplanar_depth: DepthCounts::default(),
                    views: Vec::new(),
                    segmentation: None,
                    collapse: None,
                    cloud: CloudScores::default(),
                    stages: Vec::new(),
                    seconds,
                    peak_memory_bytes: peak,
                    start_memory_bytes: start_memory,
                }
            }
        };
        methods.push(result);
    }
    if cfg.error_maps {
        report::write_error_maps(
            &out.join("maps").join(&name),
            &scene,
            &gt_depths(&gt),
            &predictions,
        )?;
    }
    let (width, height) = scene
        .views
        .first()
        .map_or((0, 0), |v| (v.camera.width, v.camera.height));
    Ok(SceneResult {
        name,
        category: category.to_string(),
        file: file.to_path_buf(),
        width,
        height,
        views: scene.views.len(),
        sparse_points: scene.cloud.len(),
        cache_hit: cached.hit,
        render_seconds: cached.render_seconds,
        median_depth,
        methods,
        generated: None,
    })
}

fn gt_depths(gt: &[GtView]) -> Vec<&[f32]> {
    gt.iter().map(|g| g.depth.as_slice()).collect()
}

fn load_gt(scene: &Scene, gt_dir: &Path) -> Result<Vec<GtView>, BenchError> {
    scene
        .views
        .iter()
        .map(|v| {
            let stem = output_stem(&v.name);
            let p = gt_dir.join("depth").join(format!("{stem}.pfm"));
            let depth = read_pfm_path(&p).map_err(|e| gt_err(&p, e))?;
            let p = gt_dir.join("normals").join(format!("{stem}.pfm"));
            let normals = read_pfm_path(&p).map_err(|e| gt_err(&p, e))?;
            let p = gt_dir.join("planes").join(format!("{stem}.png"));
            let (w, h, planes) = read_label_png(&p).map_err(|e| gt_err(&p, e))?;
            let (cw, ch) = (v.camera.width, v.camera.height);
            if (depth.width, depth.height) != (cw, ch)
                || (normals.width, normals.height, normals.channels) != (cw, ch, 3)
                || (w, h) != (cw, ch)
            {
                return Err(gt_err(
                    &p,
                    format!("ground truth does not match the {cw}x{ch} view {}", v.name),
                ));
            }
            Ok(GtView {
                depth: depth.data,
                normals: normals
                    .data
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]])
                    .collect(),
                planes,
            })
        })
        .collect()
}

/// Points on the visible ground-truth surface: every `stride`-th pixel of every view
/// back-projected with its ground-truth depth (the completeness reference).
fn reference_points(scene: &Scene, gt: &[GtView], stride: u32) -> Vec<Vector3<f64>> {
    let mut pts = Vec::new();
    for (v, g) in scene.views.iter().zip(gt) {
        let world_from_cam = v.cam_from_world.inverse();
        for y in (0..v.camera.height).step_by(stride as usize) {
            for x in (0..v.camera.width).step_by(stride as usize) {
                let z = g.depth[(y * v.camera.width + x) as usize];
                if has_depth(z) {
                    let xc = v.camera.pixel_ray(x, y) * z as f64;
                    pts.push(world_from_cam.transform_point(&xc.into()).coords);
                }
            }
        }
    }
    pts
}

fn run_method(
    m: Method,
    scene: &Scene,
    cfg: &BenchConfig,
    run_dir: &Path,
) -> Result<Prediction, String> {
    match m {
        Method::Planemap
        | Method::PlanemapVisibility
        | Method::PlanemapNoLines
        | Method::PlanemapClassifier => {
            let mut config = cfg.planemap.clone();
            match m {
                Method::PlanemapNoLines => config.planemap.dominant_line_weight = 1.0,
                Method::PlanemapVisibility => config.planemap.photo_weight = 0.0,
                Method::PlanemapClassifier => config.nonplanar.enabled = true,
                _ => {}
            }
            // The bench prints its own progress: the run's bars would interleave.
            let quiet = Progress::new(true);
            let (_, views, summary) =
                pipeline::run(scene, &config, run_dir, &RunOptions::default(), &quiet)
                    .map_err(|e| e.to_string())?;
            let fused_path = run_dir.join("fused.ply");
            let fused = read_ply_points_path(&fused_path).map_err(|e| e.to_string())?;
            let names = ["normals", "axes", "hypotheses", "planemaps", "fusion"];
            Ok(Prediction {
                views: views
                    .into_iter()
                    .map(|v| {
                        let labels = v
                            .labels
                            .iter()
                            .zip(&v.depth)
                            // A non-planar pixel has a depth but no plane.
                            .map(|(&l, &z)| (has_depth(z) && l != NONPLANAR).then_some(l))
                            .collect();
                        ViewPrediction {
                            view_index: v.view_index,
                            depth: v.depth,
                            normals_cam: v.normals,
                            labels: Some(labels),
                        }
                    })
                    .collect(),
                fused: fused.positions,
                stages: names
                    .iter()
                    .zip(summary.stage_seconds)
                    .map(|(n, s)| (n.to_string(), s))
                    .collect(),
            })
        }
        Method::Sweep => {
            let t = Instant::now();
            let images: Vec<_> = scene
                .views
                .par_iter()
                .map(|v| v.load_undistorted_image())
                .collect::<Result<_, _>>()
                .map_err(|e| e.to_string())?;
            let t_load = t.elapsed().as_secs_f64();
            let t = Instant::now();
            // The sweep directions are global: found once, not once per view.
            let axes = if cfg.sweep.axis_families {
                scene_axes(scene, &cfg.sweep)
            } else {
                Vec::new()
            };
            let views: Vec<ViewPrediction> = (0..scene.views.len())
                .into_par_iter()
                .map(|i| {
                    let cam = &scene.views[i].camera;
                    let n = (cam.width * cam.height) as usize;
                    match sweep_view_with_axes(scene, &images, i, &axes, &cfg.sweep) {
                        Ok(r) => ViewPrediction {
                            view_index: i,
                            normals_cam: r
                                .depth
                                .iter()
                                .map(|&z| {
                                    if has_depth(z) {
                                        [0.0, 0.0, -1.0]
                                    } else {
                                        [0.0; 3]
                                    }
                                })
                                .collect(),
                            depth: r.depth,
                            labels: None,
                        },
                        // A view without sparse points has no depth range: no depth.
                        Err(_) => ViewPrediction {
                            view_index: i,
                            depth: vec![0.0; n],
                            normals_cam: vec![[0.0; 3]; n],
                            labels: None,
                        },
                    }
                })
                .collect();
            let t_sweep = t.elapsed().as_secs_f64();
            finish_baseline(
                scene,
                views,
                cfg,
                vec![("load".into(), t_load), ("sweep".into(), t_sweep)],
            )
        }
        Method::Delaunay => {
            let t = Instant::now();
            let views: Vec<ViewPrediction> = (0..scene.views.len())
                .into_par_iter()
                .map(|i| {
                    let d = delaunay::delaunay_view(scene, i);
                    ViewPrediction {
                        view_index: i,
                        depth: d.depth,
                        normals_cam: d.normals,
                        labels: None,
                    }
                })
                .collect();
            let t_tri = t.elapsed().as_secs_f64();
            finish_baseline(scene, views, cfg, vec![("triangulate".into(), t_tri)])
        }
    }
}

/// Fuses a baseline's depth maps with [`pipeline::fuse`].
fn finish_baseline(
    scene: &Scene,
    views: Vec<ViewPrediction>,
    cfg: &BenchConfig,
    mut stages: Vec<(String, f64)>,
) -> Result<Prediction, String> {
    let t = Instant::now();
    let as_planemaps: Vec<ViewPlanemap> = views
        .iter()
        .map(|v| {
            let cam = &scene.views[v.view_index].camera;
            ViewPlanemap {
                view_index: v.view_index,
                width: cam.width,
                height: cam.height,
                labels: vec![0; v.depth.len()],
                depth: v
                    .depth
                    .iter()
                    .map(|&z| if has_depth(z) { z } else { 0.0 })
                    .collect(),
                normals: v.normals_cam.clone(),
                candidate_labels: 0,
                energy: (0.0, 0.0),
                cycles: 0,
                seconds: (0.0, 0.0),
                planarity: None,
                sweep_depth: None,
            }
        })
        .collect();
    let fused = pipeline::fuse(scene, &as_planemaps, &cfg.fusion).map_err(|e| e.to_string())?;
    stages.push(("fusion".into(), t.elapsed().as_secs_f64()));
    Ok(Prediction {
        views,
        fused: fused.positions,
        stages,
    })
}

fn score(
    m: Method,
    scene: &Scene,
    gt: &[GtView],
    pred: &Prediction,
    mesh: &MeshDistance,
    reference: &[Vector3<f64>],
    tolerance: f64,
) -> MethodResult {
    let per_view: Vec<(String, DepthCounts)> = pred
        .views
        .par_iter()
        .map(|v| {
            let view = &scene.views[v.view_index];
            let g = &gt[v.view_index];
            let world_from_cam = view.cam_from_world.rotation.inverse();
            let normals_world: Vec<[f32; 3]> = v
                .normals_cam
                .iter()
                .map(|n| {
                    let w = world_from_cam * Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                    [w.x as f32, w.y as f32, w.z as f32]
                })
                .collect();
            (
                view.name.clone(),
                depth_counts(&v.depth, &g.depth, Some((&normals_world, &g.normals))),
            )
        })
        .collect();
    let mut depth = DepthCounts::default();
    for (_, c) in &per_view {
        depth.add(c);
    }
    // Planar / non-planar split: ground-truth depth kept only where the plane id says so.
    let split = |planar: bool| {
        let mut total = DepthCounts::default();
        for v in &pred.views {
            let g = &gt[v.view_index];
            let masked: Vec<f32> = g
                .depth
                .iter()
                .zip(&g.planes)
                .map(|(&z, &id)| if (id != 0) == planar { z } else { 0.0 })
                .collect();
            total.add(&depth_counts(&v.depth, &masked, None));
        }
        total
    };
    let (planar_depth, nonplanar_depth) = (split(true), split(false));
    let labelled = pred.views.iter().all(|v| v.labels.is_some());
    let collapse = labelled.then(|| {
        let mut c = Collapses::default();
        for v in &pred.views {
            let labels = v.labels.as_deref().unwrap_or(&[]);
            match view_collapsed(labels, &gt[v.view_index].planes) {
                Some(true) => {
                    c.checked += 1;
                    c.collapsed.push(scene.views[v.view_index].name.clone());
                }
                Some(false) => c.checked += 1,
                None => {}
            }
        }
        c
    });
    let seg = if labelled {
        let pairs: Vec<(&[Option<u32>], &[u16])> = pred
            .views
            .iter()
            .filter_map(|v| {
                v.labels
                    .as_deref()
                    .map(|l| (l, gt[v.view_index].planes.as_slice()))
            })
            .collect();
        Some(segmentation(pairs.iter().copied()))
    } else {
        None
    };
    MethodResult {
        method: m.name().into(),
        error: None,
        depth,
        planar_depth,
        nonplanar_depth,
        views: per_view,
        segmentation: seg,
        collapse,
        cloud: cloud_scores(&pred.fused, mesh, reference, tolerance),
        stages: Vec::new(),
        seconds: 0.0,
        peak_memory_bytes: None,
        start_memory_bytes: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn method_names_round_trip_and_are_unique() {
        for m in Method::ALL {
            assert_eq!(Method::from_name(m.name()).unwrap(), m);
        }
        let mut names: Vec<_> = Method::ALL.map(Method::name).to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), Method::ALL.len());
        assert_eq!(
            Method::from_name(" planemap-vis ").unwrap(),
            Method::PlanemapVisibility
        );
        let err = Method::from_name("colmap").unwrap_err().to_string();
        assert!(err.contains("planemap-vis"), "{err}");
        assert!(Method::DEFAULT.iter().all(|m| Method::ALL.contains(m)));
    }

    #[test]
    fn size_presets_parse_and_bad_sizes_are_errors() {
        assert_eq!(parse_size("stress").unwrap(), Some((1280, 960)));
        assert_eq!(parse_size("tiny").unwrap(), Some((96, 72)));
        assert_eq!(parse_size("default").unwrap(), None);
        assert_eq!(parse_size("640x480").unwrap(), Some((640, 480)));
        for bad in ["huge", "0x10", "10x", "x10", "-5x4"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }
}
