//! The whole chain: sparse points → normals → dominant axes → plane hypotheses → one
//! planemap per view (α-expansion) → depth and normal maps → fused points.
//!
//! The CLI and library users call the same functions: [`prepare`] for the global stages,
//! [`label_view`] for one view, [`run`] for everything including the output files.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::time::Instant;

use nalgebra::{Point3, Vector2, Vector3};
use planemap_solvers::{DataCost, ExpansionConfig, LabelOrder, Mrf, MrfError, Smoothness};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::axes::{
    dominant_axes, refine_axes_from_planes, AxesConfig, AxesError, AxisPlane, DominantAxes,
};
use crate::classify::{PlanarityMap, PlanarityModel};
use crate::hypotheses::{
    crease_hypotheses, plane_hypotheses, sweep_hypotheses, CreaseHypothesis, HypothesesConfig,
    HypothesesError, HypothesesInput, LabelledView, PlaneHypothesis,
};
use crate::io::atomic::write_atomic;
use crate::io::output_stem;
use crate::io::dense::{write_dense_map_path, DenseError};
use crate::io::labelpng::{label_colors, write_label_png, LabelPngError};
use crate::io::pfm::{write_pfm_path, PfmError};
use crate::io::ply::{write_ply_points_path, PlyError, PlyPoints};
use crate::normals::{estimate_normals_with_scale, NormalsConfig, NormalsError, OrientedCloud};
use crate::nonplanar::{
    normals_from_depth, ExtendedEnergy, NonplanarConfig, NonplanarView, NONPLANAR,
};
use crate::planemap::{PlanemapConfig, PlanemapEnergy, PlanemapError, ViewInputs};
use crate::progress::Progress;
use crate::raster::ImageF32;
use crate::scale::{sampling_scale, ScaleError};
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

fn write_err(path: &Path, e: impl std::fmt::Display) -> PipelineError {
    PipelineError::Write {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Options of the α-expansion solve.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct SolverConfig {
    /// Maximum α-expansion cycles (sweeps over all labels).
    pub max_cycles: usize,
    /// Integer cost units per unit of real cost: costs are rounded to integers so the
    /// max-flow is exact. 1000 keeps rounding below 0.1% of the smallest useful cost.
    pub cost_scale: f64,
}

impl Default for SolverConfig {
    fn default() -> Self {
        SolverConfig {
            max_cycles: 10,
            cost_scale: 1000.0,
        }
    }
}

/// Options of the fused point cloud.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct FusionConfig {
    /// Keep a pixel's point only if at least this many other views agree with its depth.
    pub min_consistent_views: usize,
    /// Relative depth tolerance for "agree": |z_j − z| ≤ tolerance · z.
    pub depth_tolerance: f64,
    /// Take every `stride`-th pixel in x and y (1 = all).
    pub stride: u32,
}

impl Default for FusionConfig {
    fn default() -> Self {
        FusionConfig {
            min_consistent_views: 1,
            depth_tolerance: 0.01,
            stride: 2,
        }
    }
}

/// A whole run's configuration: one section per stage (TOML).
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(default, deny_unknown_fields)]
pub struct Config {
    /// Normals for points without them.
    pub normals: NormalsConfig,
    /// Dominant axes.
    pub axes: AxesConfig,
    /// Plane hypotheses.
    pub hypotheses: HypothesesConfig,
    /// Per-view planemap energy.
    pub planemap: PlanemapConfig,
    /// α-expansion.
    pub solver: SolverConfig,
    /// Fused point cloud.
    pub fusion: FusionConfig,
    /// The classifier-driven "non-planar" label (off by default).
    pub nonplanar: NonplanarConfig,
}

impl Config {
    /// Parses a TOML config onto the defaults ([`crate::config::from_toml_str`]); errors
    /// name `origin` and the line.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Config, PipelineError> {
        Ok(crate::config::from_toml_str(text, origin)?)
    }

    /// Reads a TOML config file.
    pub fn from_path(path: &Path) -> Result<Config, PipelineError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| PipelineError::Config(format!("{}: {e}", path.display())))?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// The configuration as TOML, each key preceded by its documentation (meaning, unit,
    /// range) as comments: what `planemap config --defaults` prints.
    pub fn describe(&self) -> Result<String, PipelineError> {
        Ok(crate::config::describe(self, crate::config::CONFIG_DOCS, "")?)
    }

    /// Checks every stage's config.
    pub fn validate(&self) -> Result<(), PipelineError> {
        self.normals.validate()?;
        self.axes.validate()?;
        self.hypotheses.validate()?;
        self.planemap
            .validate()
            .map_err(|e| PipelineError::Config(format!("planemap: {e}")))?;
        self.nonplanar
            .validate()
            .map_err(|e| PipelineError::Config(e.to_string()))?;
        if !(self.solver.cost_scale.is_finite() && self.solver.cost_scale > 0.0) {
            return Err(PipelineError::Config(
                "solver.cost_scale must be positive".into(),
            ));
        }
        let tolerance_ok =
            self.fusion.depth_tolerance.is_finite() && self.fusion.depth_tolerance > 0.0;
        if self.fusion.stride == 0 || !tolerance_ok {
            return Err(PipelineError::Config(
                "fusion.stride must be ≥ 1 and fusion.depth_tolerance > 0".into(),
            ));
        }
        Ok(())
    }
}

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
    /// first, then those of the photo-consistency sweep.
    pub hypotheses: Vec<PlaneHypothesis>,
    /// How many of `hypotheses` (the last ones) come from the photo-consistency sweep
    /// ([`crate::hypotheses::sweep_hypotheses`]); they are offered in every view where they
    /// lie in front of the camera, since few sparse points support them.
    pub sweep_hypotheses: usize,
    /// One entry per crease hypothesis ([`crate::hypotheses::crease_hypotheses`]) — the very
    /// last of `hypotheses`, after the sweep's, added by [`run`] after a first labelling —
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
    /// Plane hypotheses of the points along the refit axes.
    pub hypotheses: Vec<PlaneHypothesis>,
    /// Seconds spent: scale + normals, axes, hypotheses (with the refit).
    pub seconds: [f64; 3],
}

fn hyp_input<'a>(
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
    if cfg.axes.camera_vertical {
        let m = axes.num_manhattan.min(axes.directions.len());
        if let Some(up) = crate::axes::camera_vertical_given(&scene.views, &axes.directions[..m]) {
            axes.complete_with_vertical(&up, &oriented.normals, cfg.axes.refine_angle_deg);
        }
    }
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
        hypotheses = plane_hypotheses(&hyp_input(scene, &oriented, &axes, scale), &cfg.hypotheses)?;
    }
    Ok(SparseStages {
        scale,
        oriented,
        axes,
        hypotheses,
        seconds: [t_normals, t_axes, t.elapsed().as_secs_f64()],
    })
}

/// Runs the global stages on an (undistorted) scene.
pub fn prepare(scene: &Scene, cfg: &Config) -> Result<Prepared, PipelineError> {
    let SparseStages {
        scale,
        oriented,
        axes,
        mut hypotheses,
        seconds,
    } = sparse_stages(scene, cfg)?;
    let t = Instant::now();
    let input = hyp_input(scene, &oriented, &axes, scale);
    // Images are loaded once for all views when a stage matches views against each other.
    let wants_images =
        cfg.hypotheses.sweep.enabled || cfg.planemap.photo_weight > 0.0 || cfg.nonplanar.enabled;
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
    let mut num_sweep = 0;
    if let (true, Some(imgs)) = (cfg.hypotheses.sweep.enabled, &images) {
        let (extra, _) = sweep_hypotheses(scene, imgs, &input, &hypotheses, &cfg.hypotheses)?;
        num_sweep = extra.len();
        hypotheses.extend(extra);
    }
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
        crease_views: Vec::new(),
        images,
        seconds: [
            seconds[0],
            seconds[1],
            seconds[2] + t.elapsed().as_secs_f64(),
        ],
    })
}

/// One view's planemap and what follows from it.
#[derive(Debug, Clone)]
pub struct ViewPlanemap {
    /// Index into `Scene::views`.
    pub view_index: usize,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Hypothesis index per pixel (row-major); [`NONPLANAR`] where the non-planar label won.
    pub labels: Vec<u32>,
    /// Depth (camera z) per pixel; 0 where the plane gives none.
    pub depth: Vec<f32>,
    /// Camera-frame unit normal per pixel, facing the camera (COLMAP's convention).
    pub normals: Vec<[f32; 3]>,
    /// Hypotheses kept for this view (after pruning).
    pub candidate_labels: usize,
    /// Energy of the data-argmin start and of the result (real units).
    pub energy: (f64, f64),
    /// α-expansion cycles run.
    pub cycles: usize,
    /// Seconds: building the energy, solving.
    pub seconds: (f64, f64),
    /// The classifier's `P(planar)` map, when the non-planar label was used.
    pub planarity: Option<PlanarityMap>,
    /// The non-planar label's sweep depth where the multi-view confirmation may adopt it
    /// (camera z, 0 elsewhere: [`NonplanarView::confirmable_depth`]), when the label was
    /// used; written to
    /// `sweep/NAME.pfm` and reloaded by `--resume`, since the multi-view confirmation
    /// ([`confirm_nonplanar`]) needs every view's.
    pub sweep_depth: Option<Vec<f32>>,
}

/// The planar part of one view's energy: the visibility-conflict data term, the optional
/// photo-consistency term, smoothness and dominant-line weights over the labels kept for
/// the view. [`label_view`] minimises it (plus the non-planar label, when enabled); it is
/// public so that a labelling can be scored against it (e.g. ground truth's, see
/// `examples/energy_audit.rs`).
pub fn view_energy(
    scene: &Scene,
    prepared: &Prepared,
    view_index: usize,
    image: &ImageF32,
    cfg: &Config,
) -> Result<PlanemapEnergy, PipelineError> {
    let planes: Vec<_> = prepared.hypotheses.iter().map(|h| h.plane).collect();
    // The sweep's and the crease hypotheses have few or no sparse points: the sweep's are
    // offered wherever they lie in front of the camera, a crease hypothesis in the views that
    // see it.
    let creases_start = prepared.hypotheses.len() - prepared.crease_views.len();
    let photo_planes: Vec<u32> = (creases_start - prepared.sweep_hypotheses..creases_start)
        .chain(
            prepared
                .crease_views
                .iter()
                .enumerate()
                .filter(|(_, v)| v.binary_search(&view_index).is_ok())
                .map(|(c, _)| creases_start + c),
        )
        .map(|i| i as u32)
        .collect();
    let inputs = ViewInputs {
        photo_planes: &photo_planes,
        view_index,
        views: &scene.views,
        image,
        cloud: &scene.cloud,
        planes: &planes,
        dominant_directions: &prepared.axes.directions,
        scale: prepared.scale,
    };
    let planemap_err = |source| PipelineError::Planemap {
        view: scene.views[view_index].name.clone(),
        source,
    };
    let mut energy = PlanemapEnergy::build(&inputs, &cfg.planemap).map_err(planemap_err)?;
    if let (true, Some(images)) = (cfg.planemap.photo_weight > 0.0, &prepared.images) {
        add_photo_term(scene, view_index, image, images, &mut energy, &cfg.planemap)
            .map_err(planemap_err)?;
    }
    Ok(energy)
}

/// Labels one view: builds its energy ([`view_energy`]) and minimises it by α-expansion.
/// `scene` must be undistorted (PINHOLE) and `image` its image.
pub fn label_view(
    scene: &Scene,
    prepared: &Prepared,
    view_index: usize,
    image: &ImageF32,
    cfg: &Config,
) -> Result<ViewPlanemap, PipelineError> {
    let view = &scene.views[view_index];
    let planemap_err = |source| PipelineError::Planemap {
        view: view.name.clone(),
        source,
    };
    let solver_err = |source| PipelineError::Solver {
        view: view.name.clone(),
        source,
    };
    let t = Instant::now();
    let mut energy = view_energy(scene, prepared, view_index, image, cfg)?;
    // The non-planar label (Gallup et al. 2010): classifier costs and the sweep's depth.
    let evidence = match (&prepared.classifier, &prepared.images) {
        (Some(model), Some(images)) => {
            let axes = &prepared.axes.directions;
            let cached = prepared.nonplanar_sweeps.get(view_index);
            let swept = match cached.and_then(|c| c.get()) {
                Some(v) => v.clone(),
                None => {
                    let v = NonplanarView::sweep(
                        scene,
                        images,
                        view_index,
                        axes,
                        model,
                        &cfg.nonplanar,
                    )
                    .map_err(planemap_err)?;
                    if let Some(c) = cached {
                        // Each view is labelled by one thread at a time: set once.
                        let _ = c.set(v.clone());
                    }
                    v
                }
            };
            Some(
                swept
                    .with_plane_costs(
                        scene,
                        images,
                        view_index,
                        axes,
                        &energy.planes,
                        &cfg.nonplanar,
                    )
                    .map_err(planemap_err)?,
            )
        }
        _ => None,
    };
    let unary_np = match &evidence {
        Some(ev) => Some(
            crate::nonplanar::add_classifier_costs(
                &mut energy,
                ev,
                &cfg.nonplanar,
                &cfg.planemap,
            )
            .map_err(planemap_err)?,
        ),
        None => None,
    };
    let energy = energy;
    let ext = match (&evidence, unary_np) {
        (Some(ev), Some(unary_np)) => Some(ExtendedEnergy {
            planar: &energy,
            evidence: ev,
            unary_np,
        }),
        _ => None,
    };
    let t_build = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let planar_labels = energy.num_labels();
    let num_labels = ext.as_ref().map_or(planar_labels, |x| x.num_labels());
    let scale = cfg.solver.cost_scale;
    let to_int = |c: f32| (c as f64 * scale).round().min(i32::MAX as f64 / 8.0) as i32;
    let unary: Vec<i32> = match &ext {
        Some(x) => x.dense_unary().iter().map(|&c| to_int(c)).collect(),
        None => energy.unary.iter().map(|&c| to_int(c)).collect(),
    };
    let initial = energy.initial_labels();
    let smooth: Box<dyn Fn(usize, usize, u32, u32) -> i32 + Sync + '_> = match &ext {
        Some(x) => Box::new(move |p, q, a, b| to_int(x.pairwise(p, q, a, b))),
        None => Box::new(|p, q, a, b| to_int(energy.pairwise(p, q, a, b))),
    };
    let mut mrf = Mrf::grid(
        energy.width as usize,
        energy.height as usize,
        planemap_solvers::Connectivity::Four,
        num_labels,
        DataCost::Dense(&unary),
    )
    .map_err(solver_err)?
    .with_smoothness(Smoothness::Fn(smooth))
    .map_err(solver_err)?;
    for a in 0..planar_labels as u32 {
        if let Some(mut sites) = energy.feasible_sites(a) {
            // The start may put an infeasible label where nothing is feasible: allow it there.
            sites.extend(
                initial
                    .iter()
                    .enumerate()
                    .filter(|&(_, &l)| l == a)
                    .map(|(p, _)| p as u32),
            );
            sites.sort_unstable();
            sites.dedup();
            mrf = mrf.with_feasible_sites(a, &sites).map_err(solver_err)?;
        }
    }
    if let Some(x) = &ext {
        mrf = mrf
            .with_feasible_sites(x.nonplanar_label(), &x.evidence.feasible_sites())
            .map_err(solver_err)?;
    }
    let solution = mrf
        .expansion(
            &ExpansionConfig {
                max_cycles: cfg.solver.max_cycles,
                order: LabelOrder::Fixed,
            },
            Some(&initial),
        )
        .map_err(solver_err)?;
    let t_solve = t.elapsed().as_secs_f64();
    let labels = solution.labels;
    let (w, h) = (energy.width as usize, energy.height as usize);
    let Some(x) = ext.as_ref() else {
        return Ok(ViewPlanemap {
            view_index,
            width: energy.width,
            height: energy.height,
            depth: energy.depth_for_labels(&labels),
            normals: energy.normals_for_labels(&labels),
            energy: (energy.energy(&initial), energy.energy(&labels)),
            labels: energy.global_labels(&labels),
            candidate_labels: num_labels,
            cycles: solution.cycles.len(),
            seconds: (t_build, t_solve),
            planarity: None,
            sweep_depth: None,
        });
    };
    // Planes where a plane won; the sweep's depth (and its gradient's normals) elsewhere.
    let np = x.nonplanar_label();
    let planar_only: Vec<u32> = labels
        .iter()
        .map(|&l| if l == np { 0 } else { l })
        .collect();
    let mut depth = energy.depth_for_labels(&planar_only);
    let mut normals = energy.normals_for_labels(&planar_only);
    let mut global = energy.global_labels(&planar_only);
    let sweep_normals = normals_from_depth(&x.evidence.depth, w, h, |px, py| {
        energy.smoothness.pixel_ray(py * w + px)
    });
    for (p, &l) in labels.iter().enumerate() {
        if l == np {
            depth[p] = x.evidence.depth[p];
            normals[p] = sweep_normals[p];
            global[p] = NONPLANAR;
        }
    }
    Ok(ViewPlanemap {
        view_index,
        width: energy.width,
        height: energy.height,
        depth,
        normals,
        energy: (x.energy(&initial), x.energy(&labels)),
        labels: global,
        candidate_labels: num_labels,
        cycles: solution.cycles.len(),
        seconds: (t_build, t_solve),
        planarity: Some(x.evidence.planarity.clone()),
        sweep_depth: Some(x.evidence.confirmable_depth()),
    })
}

/// Adds the photo-consistency data term `photo_weight · c_p(h)` to a view's energy: the NCC
/// cost volume of the view's labels against its best neighbours.
fn add_photo_term(
    scene: &Scene,
    view_index: usize,
    image: &ImageF32,
    images: &[ImageF32],
    energy: &mut PlanemapEnergy,
    cfg: &PlanemapConfig,
) -> Result<(), PlanemapError> {
    let photo_err = |e: crate::photo::PhotoError| PlanemapError::Input(format!("photo term: {e}"));
    let nb = crate::photo::select_neighbours(scene, view_index, cfg.photo_neighbours)
        .map_err(photo_err)?;
    if nb.is_empty() {
        return Ok(());
    }
    let neighbours: Vec<_> = nb.iter().map(|&j| (&scene.views[j], &images[j])).collect();
    let volume = crate::photo::plane_cost_volume(
        &scene.views[view_index],
        image,
        &neighbours,
        &energy.planes,
        &photo_term_config(cfg),
    )
    .map_err(photo_err)?;
    let w = cfg.photo_weight as f32;
    for (u, c) in energy.unary.iter_mut().zip(&volume.costs) {
        *u += w * c;
    }
    Ok(())
}

/// The cost volume settings of the photo-consistency data term: 7×7 NCC (the measure's
/// defaults), with `cfg.photo_support_sigma_color`'s adaptive support weights.
fn photo_term_config(cfg: &PlanemapConfig) -> crate::photo::PhotoConfig {
    crate::photo::PhotoConfig {
        support_sigma_color: cfg.photo_support_sigma_color as f32,
        ..Default::default()
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
/// ```
pub fn run(
    scene: &Scene,
    cfg: &Config,
    out: &Path,
    opts: &RunOptions,
    progress: &Progress,
) -> Result<(Prepared, Vec<ViewPlanemap>, RunSummary), PipelineError> {
    cfg.validate()?;
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
    let indices: Vec<usize> = match &opts.views {
        Some(v) => {
            if let Some(&bad) = v.iter().find(|&&i| i >= scene.views.len()) {
                return Err(PipelineError::Scene(format!(
                    "view index {bad} out of range (the scene has {} views)",
                    scene.views.len()
                )));
            }
            v.clone()
        }
        None => (0..scene.views.len()).collect(),
    };
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
    Ok((prepared, views, summary))
}

/// Multi-view confirmation of the non-planar label ([`NonplanarConfig::consistent_views`]):
/// in every view of `views` (labelled, with their sweep depths), a pixel whose sweep depth
/// at least `consistent_views` other views of `views` confirm
/// ([`crate::nonplanar::sweep_confirmations`]) and whose labelled depth differs
/// from it by more than `consistency_tolerance` becomes non-planar with the sweep's depth
/// (and its normal); so does a pixel whose labelled depth is more than `gross_gap` off when
/// that many views agree within `gross_tolerance`, away from depth jumps by
/// `gross_edge_px` (the gross tier). Every count is taken from the sweep depths as they were
/// labelled, so the result does not depend on the order of the views. Returns the pixels
/// changed per view.
pub fn confirm_nonplanar(
    scene: &Scene,
    views: &mut [ViewPlanemap],
    cfg: &NonplanarConfig,
) -> Vec<usize> {
    let mut sweeps: Vec<Option<&[f32]>> = vec![None; scene.views.len()];
    for v in views.iter() {
        if let (Some(d), Some(slot)) = (&v.sweep_depth, sweeps.get_mut(v.view_index)) {
            *slot = Some(d.as_slice());
        }
    }
    // Per view, the strict tier's counts and (when on) the gross tier's, one projection.
    let mut tiers = vec![(cfg.consistency_tolerance, cfg.consistency_edge_px)];
    if cfg.gross_gap > 0.0 {
        tiers.push((cfg.gross_tolerance, cfg.gross_edge_px));
    }
    let counts: Vec<Vec<Vec<u16>>> = views
        .iter()
        .map(|v| {
            crate::nonplanar::sweep_confirmation_tiers(
                scene,
                v.view_index,
                &sweeps,
                &tiers,
            )
        })
        .collect();
    let gap = cfg.gross_gap as f32;
    let tol = cfg.consistency_tolerance as f32;
    let min_views = cfg.consistent_views.min(u16::MAX as usize) as u16;
    views
        .iter_mut()
        .zip(&counts)
        .map(|(v, tiers)| {
            let (count, loose) = (&tiers[0], tiers.get(1));
            let Some(sweep) = &v.sweep_depth else {
                return 0;
            };
            let camera = &scene.views[v.view_index].camera;
            let (w, h) = (v.width as usize, v.height as usize);
            if sweep.len() != w * h || count.len() != w * h {
                return 0;
            }
            let normals =
                normals_from_depth(sweep, w, h, |x, y| camera.pixel_ray(x as u32, y as u32));
            let mut changed = 0;
            for p in 0..w * h {
                let z = sweep[p];
                let off_by = |t: f32| {
                    v.depth[p].is_nan() || v.depth[p] <= 0.0 || (v.depth[p] - z).abs() > t * z
                };
                let confirmed = count[p] >= min_views && off_by(tol);
                let gross = loose.is_some_and(|l| l[p] >= min_views) && off_by(gap);
                if z > 0.0 && (confirmed || gross) {
                    v.depth[p] = z;
                    v.normals[p] = normals[p];
                    v.labels[p] = NONPLANAR;
                    changed += 1;
                }
            }
            changed
        })
        .collect()
}

/// `OUT/stereo/KIND/IMAGE.geometric.bin` (KIND `depth_maps` or `normal_maps`), IMAGE the
/// view's image file name, as COLMAP's `stereo_fusion` reads them.
fn dense_map_path(out: &Path, kind: &str, view_name: &str) -> PathBuf {
    let name = Path::new(view_name)
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| view_name.to_string());
    out.join("stereo")
        .join(kind)
        .join(format!("{name}.geometric.bin"))
}

/// Where the non-planar label's sweep depth maps go (PFM, camera z, 0 = none).
pub const SWEEP_DIR: &str = "sweep";

/// The per-view output folders under a run's output directory.
const OUTPUT_DIRS: [&str; 4] = [
    "planemaps",
    "depth",
    "stereo/depth_maps",
    "stereo/normal_maps",
];

/// Writes one view's planemap, depth and normal maps (creating the folders).
pub fn write_view_outputs(
    out: &Path,
    scene: &Scene,
    result: &ViewPlanemap,
) -> Result<(), PipelineError> {
    let view = &scene.views[result.view_index];
    let stem = output_stem(&view.name);
    let (w, h) = (result.width, result.height);
    for d in OUTPUT_DIRS {
        let dir = out.join(d);
        std::fs::create_dir_all(&dir).map_err(|e| write_err(&dir, e))?;
    }
    let ids: Vec<u16> = result
        .labels
        .iter()
        .zip(&result.depth)
        .map(|(&l, &z)| {
            if z > 0.0 && l != NONPLANAR {
                (l + 1).min(u16::MAX as u32) as u16
            } else {
                0
            }
        })
        .collect();
    let vis_path = out.join("planemaps").join(format!("{stem}_vis.png"));
    let mut vis = label_colors(&ids, w, h);
    // Non-planar pixels (label 0 but a depth) in one fixed colour, unlike "no plane" (black).
    for (i, (&l, &z)) in result.labels.iter().zip(&result.depth).enumerate() {
        if l == NONPLANAR && z > 0.0 {
            vis.put_pixel(i as u32 % w, i as u32 / w, image::Rgb(NONPLANAR_COLOR));
        }
    }
    if let Some(map) = &result.planarity {
        let dir = out.join("planarity");
        std::fs::create_dir_all(&dir).map_err(|e| write_err(&dir, e))?;
        let path = dir.join(format!("{stem}.png"));
        map.write_png(&path).map_err(|e| write_err(&path, e))?;
    }
    write_atomic::<std::io::Error, _>(&vis_path, |f: &mut BufWriter<File>| {
        vis.write_to(f, image::ImageFormat::Png)
            .map_err(std::io::Error::other)
    })
    .map_err(|e| write_err(&vis_path, e))?;
    let depth = ImageF32 {
        width: w,
        height: h,
        channels: 1,
        data: result.depth.clone(),
    };
    write_pfm_path(&out.join("depth").join(format!("{stem}.pfm")), &depth)?;
    if let Some(sweep) = &result.sweep_depth {
        let dir = out.join(SWEEP_DIR);
        std::fs::create_dir_all(&dir).map_err(|e| write_err(&dir, e))?;
        let map = ImageF32 {
            width: w,
            height: h,
            channels: 1,
            data: sweep.clone(),
        };
        write_pfm_path(&dir.join(format!("{stem}.pfm")), &map)?;
    }
    write_dense_map_path(&dense_map_path(out, "depth_maps", &view.name), &depth)?;
    let normals = ImageF32 {
        width: w,
        height: h,
        channels: 3,
        data: result.normals.iter().flatten().copied().collect(),
    };
    write_dense_map_path(&dense_map_path(out, "normal_maps", &view.name), &normals)?;
    // The label map last: its presence marks the view complete for --resume.
    write_label_png(
        &out.join("planemaps").join(format!("{stem}.png")),
        w,
        h,
        &ids,
    )?;
    Ok(())
}

/// Colour of non-planar pixels in the `_vis.png` planemaps (label PNG value 0 with a depth).
pub const NONPLANAR_COLOR: [u8; 3] = [255, 0, 255];

/// Reloads a view's outputs for `--resume`; `None` if any is missing or unreadable
/// (including the non-planar label's sweep depth when `need_sweep`).
fn load_view_outputs(
    out: &Path,
    scene: &Scene,
    prepared: &Prepared,
    view_index: usize,
    need_sweep: bool,
) -> Option<ViewPlanemap> {
    let view = &scene.views[view_index];
    let stem = output_stem(&view.name);
    let (w, h, ids) =
        crate::io::labelpng::read_label_png(&out.join("planemaps").join(format!("{stem}.png")))
            .ok()?;
    let depth =
        crate::io::pfm::read_pfm_path(&out.join("depth").join(format!("{stem}.pfm"))).ok()?;
    let sweep_depth = if need_sweep {
        let d =
            crate::io::pfm::read_pfm_path(&out.join(SWEEP_DIR).join(format!("{stem}.pfm"))).ok()?;
        if (d.width, d.height, d.channels) != (w, h, 1) {
            return None;
        }
        Some(d.data)
    } else {
        None
    };
    if (w, h) != (view.camera.width, view.camera.height)
        || (depth.width, depth.height) != (w, h)
        || ids
            .iter()
            .any(|&id| id as usize > prepared.hypotheses.len())
    {
        return None;
    }
    // The normals exactly as labelled (planes' facing the camera, non-planar pixels' from
    // the sweep's depth map): the COLMAP normal map, written before the label map.
    let normals =
        crate::io::dense::read_normal_map_path(&dense_map_path(out, "normal_maps", &view.name))
            .ok()
            .filter(|n| (n.width, n.height, n.channels) == (w, h, 3))?
            .data
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
    Some(ViewPlanemap {
        view_index,
        width: w,
        height: h,
        labels: ids
            .iter()
            .zip(&depth.data)
            .map(|(&id, &z)| match (id, z > 0.0) {
                (0, true) => NONPLANAR,
                _ => (id as u32).saturating_sub(1),
            })
            .collect(),
        depth: depth.data,
        normals,
        candidate_labels: 0,
        energy: (0.0, 0.0),
        cycles: 0,
        seconds: (0.0, 0.0),
        planarity: None,
        sweep_depth,
    })
}

/// Back-projects every view's depth (every `stride`-th pixel), keeping points that at least
/// `min_consistent_views` other labelled views see at the same depth (relative tolerance).
/// Colours are black: fusion does not reload images.
pub fn fuse(
    scene: &Scene,
    views: &[ViewPlanemap],
    cfg: &FusionConfig,
) -> Result<PlyPoints, PipelineError> {
    let per_view: Vec<Vec<(Vector3<f64>, Vector3<f64>)>> = views
        .par_iter()
        .map(|vr| {
            let view = &scene.views[vr.view_index];
            let rot_inv = view.cam_from_world.rotation.inverse();
            let mut pts = Vec::new();
            for y in (0..vr.height).step_by(cfg.stride as usize) {
                for x in (0..vr.width).step_by(cfg.stride as usize) {
                    let p = (y * vr.width + x) as usize;
                    let z = vr.depth[p] as f64;
                    if z <= 0.0 {
                        continue;
                    }
                    let ray = view.camera.pixel_ray(x, y);
                    let x_cam = Point3::from(ray * z);
                    let x_world = view.cam_from_world.inverse_transform_point(&x_cam).coords;
                    let mut agree = 0usize;
                    for other in views.iter().filter(|o| o.view_index != vr.view_index) {
                        let ov = &scene.views[other.view_index];
                        if let Some((xy, oz)) = ov.project(&x_world) {
                            if ov.camera.contains(&xy) {
                                let (ox, oy) = (xy.x as u32, xy.y as u32);
                                let od = other.depth[(oy * other.width + ox) as usize] as f64;
                                if od > 0.0 && (od - oz).abs() <= cfg.depth_tolerance * oz {
                                    agree += 1;
                                }
                            }
                        }
                    }
                    if agree >= cfg.min_consistent_views {
                        let n = vr.normals[p];
                        let n_world = rot_inv * Vector3::new(n[0] as f64, n[1] as f64, n[2] as f64);
                        pts.push((x_world, n_world));
                    }
                }
            }
            pts
        })
        .collect();
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for v in per_view {
        for (p, n) in v {
            positions.push(p);
            normals.push(n);
        }
    }
    let colors = vec![[200u8, 200, 200]; positions.len()];
    let _ = Vector2::<f64>::zeros;
    Ok(PlyPoints {
        positions,
        normals: Some(normals),
        colors: Some(colors),
    })
}

/// The crease hypotheses of a run, saved so `--resume` need not repeat the first labelling.
const CREASES_FILE: &str = "crease_hypotheses.json";

/// The first labelling pass of [`run`]: every view in `indices` labelled with the sparse and
/// sweep hypotheses, and the crease hypotheses that labelling yields (ids continuing after
/// `prepared.hypotheses`).
fn crease_pass(
    scene: &Scene,
    prepared: &Prepared,
    indices: &[usize],
    cfg: &Config,
    progress: &Progress,
) -> Result<(Vec<CreaseHypothesis>, Vec<ViewPlanemap>), PipelineError> {
    let bar = progress.bar(indices.len() as u64, "planemaps (first pass)");
    let pass: Vec<(ViewPlanemap, Vec<bool>)> = indices
        .par_iter()
        .map(|&i| {
            let view = &scene.views[i];
            let image = view.load_undistorted_image()?;
            let result = label_view(scene, prepared, i, &image, cfg)?;
            let lines = crate::planemap::lines::dominant_line_mask(
                &image,
                &view.camera,
                &view.cam_from_world,
                &prepared.axes.directions,
                &cfg.planemap,
            )
            .map_err(|source| PipelineError::Planemap {
                view: view.name.clone(),
                source,
            })?;
            bar.inc(1);
            Ok((result, lines))
        })
        .collect::<Result<_, PipelineError>>()?;
    bar.finish();
    let labelled: Vec<LabelledView> = pass
        .iter()
        .map(|(v, lines)| LabelledView {
            view_index: v.view_index,
            labels: &v.labels,
            depth: &v.depth,
            lines,
        })
        .collect();
    let base = prepared.hypotheses.len();
    let extra = crease_hypotheses(
        scene,
        &prepared.axes,
        &prepared.hypotheses,
        &labelled,
        prepared.scale,
        &cfg.hypotheses.creases,
    )?
    .into_iter()
    .enumerate()
    .map(|(i, mut c)| {
        c.hypothesis.id = (base + i) as u32;
        c
    })
    .collect();
    Ok((extra, pass.into_iter().map(|(v, _)| v).collect()))
}

/// One crease hypothesis in `crease_hypotheses.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct CreaseRecord {
    id: u32,
    normal: [f64; 3],
    offset: f64,
    axis: Option<usize>,
    /// Image names of the views that see it (offered it as a label).
    views: Vec<String>,
}

fn write_crease_hypotheses(
    path: &Path,
    scene: &Scene,
    creases: &[CreaseHypothesis],
) -> Result<(), PipelineError> {
    let records: Vec<CreaseRecord> = creases
        .iter()
        .map(|c| {
            let h = &c.hypothesis;
            CreaseRecord {
                id: h.id,
                normal: [h.plane.normal.x, h.plane.normal.y, h.plane.normal.z],
                offset: h.plane.offset,
                axis: h.axis,
                views: c
                    .views
                    .iter()
                    .map(|&v| scene.views[v].name.clone())
                    .collect(),
            }
        })
        .collect();
    let json = serde_json::to_string_pretty(&records).map_err(|e| write_err(path, e))?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| write_err(dir, e))?;
    }
    write_atomic::<std::io::Error, _>(path, |f: &mut BufWriter<File>| {
        std::io::Write::write_all(f, json.as_bytes())
    })
    .map_err(|e| write_err(path, e))
}

/// Saved crease hypotheses for `--resume`, if the file exists, parses, continues the ids
/// of the `base` hypotheses this run prepared and names only views of `scene`; `None`
/// (recompute) otherwise.
pub fn read_crease_hypotheses(
    path: &Path,
    scene: &Scene,
    base: usize,
) -> Option<Vec<CreaseHypothesis>> {
    let text = std::fs::read_to_string(path).ok()?;
    let records: Vec<CreaseRecord> = serde_json::from_str(&text).ok()?;
    records
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let n = Vector3::new(r.normal[0], r.normal[1], r.normal[2]);
            let unit = (n.norm() - 1.0).abs() < 1e-9 && r.offset.is_finite();
            if r.id as usize != base + i || !unit {
                return None;
            }
            let mut views = r
                .views
                .iter()
                .map(|name| scene.views.iter().position(|v| &v.name == name))
                .collect::<Option<Vec<usize>>>()?;
            views.sort_unstable();
            views.dedup();
            Some(CreaseHypothesis {
                hypothesis: PlaneHypothesis {
                    id: r.id,
                    plane: crate::geometry::Plane {
                        normal: n,
                        offset: r.offset,
                    },
                    axis: r.axis,
                    support: 0,
                },
                views,
            })
        })
        .collect()
}

/// One hypothesis in `planes.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PlaneRecord {
    /// Hypothesis id (= label − 1 in the planemap PNGs).
    pub id: u32,
    /// Unit normal (world).
    pub normal: [f64; 3],
    /// Offset d in n·X = d.
    pub offset: f64,
    /// The dominant direction it came from.
    pub axis: Option<usize>,
    /// Supporting sparse points.
    pub support: usize,
    /// Image names of the views whose planemap uses it, with pixel counts.
    pub views: Vec<(String, usize)>,
}

fn write_planes_json(
    path: &Path,
    scene: &Scene,
    prepared: &Prepared,
    views: &[ViewPlanemap],
) -> Result<(), PipelineError> {
    let mut usage = vec![Vec::new(); prepared.hypotheses.len()];
    for v in views {
        let mut counts = vec![0usize; prepared.hypotheses.len()];
        for (&l, &z) in v.labels.iter().zip(&v.depth) {
            if z > 0.0 && (l as usize) < counts.len() {
                counts[l as usize] += 1;
            }
        }
        for (h, &c) in counts.iter().enumerate() {
            if c > 0 {
                usage[h].push((scene.views[v.view_index].name.clone(), c));
            }
        }
    }
    let records: Vec<PlaneRecord> = prepared
        .hypotheses
        .iter()
        .zip(usage)
        .map(|(h, views)| PlaneRecord {
            id: h.id,
            normal: [h.plane.normal.x, h.plane.normal.y, h.plane.normal.z],
            offset: h.plane.offset,
            axis: h.axis,
            support: h.support,
            views,
        })
        .collect();
    let json = serde_json::to_string_pretty(&records).map_err(|e| write_err(path, e))?;
    write_atomic::<std::io::Error, _>(path, |f: &mut BufWriter<File>| {
        std::io::Write::write_all(f, json.as_bytes())
    })
    .map_err(|e| write_err(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nonplanar::tests::corner_depths;

    /// Views of `scene` labelled 0 with depth `label(view, pixel, truth)` and the given
    /// sweep depths.
    fn labelled(
        scene: &Scene,
        truth: &[Vec<f32>],
        sweeps: &[Vec<f32>],
        label: impl Fn(usize, usize, f32) -> f32,
    ) -> Vec<ViewPlanemap> {
        truth
            .iter()
            .zip(sweeps)
            .enumerate()
            .map(|(i, (d, sweep))| {
                let w = scene.views[i].camera.width as usize;
                ViewPlanemap {
                    view_index: i,
                    width: w as u32,
                    height: (d.len() / w) as u32,
                    labels: vec![0; d.len()],
                    depth: d.iter().enumerate().map(|(p, &z)| label(i, p, z)).collect(),
                    normals: vec![[0.0, 0.0, -1.0]; d.len()],
                    candidate_labels: 1,
                    energy: (0.0, 0.0),
                    cycles: 0,
                    seconds: (0.0, 0.0),
                    planarity: None,
                    sweep_depth: Some(sweep.clone()),
                }
            })
            .collect()
    }

    #[test]
    fn the_photo_term_is_the_cost_volume_with_the_configured_support_weights() {
        let corner = crate::planemap::testutil::corner_scene();
        let scene = Scene {
            views: corner.views.clone(),
            cloud: corner.cloud.clone(),
        };
        let inputs = crate::planemap::ViewInputs {
            photo_planes: &[],
            view_index: 0,
            views: &corner.views,
            image: &corner.images[0],
            cloud: &corner.cloud,
            planes: &corner.planes,
            dominant_directions: &corner.directions,
            scale: corner.scale,
        };
        let photo_costs = |sigma: f64| {
            let cfg = PlanemapConfig {
                photo_support_sigma_color: sigma,
                ..PlanemapConfig::default()
            };
            let mut energy = PlanemapEnergy::build(&inputs, &cfg).unwrap();
            let before = energy.unary.clone();
            add_photo_term(
                &scene,
                0,
                &corner.images[0],
                &corner.images,
                &mut energy,
                &cfg,
            )
            .unwrap();
            // Against the cost volume computed directly with σc = sigma.
            let nb = crate::photo::select_neighbours(&scene, 0, cfg.photo_neighbours).unwrap();
            assert!(!nb.is_empty());
            let neighbours: Vec<_> = nb
                .iter()
                .map(|&j| (&scene.views[j], &corner.images[j]))
                .collect();
            let volume = crate::photo::plane_cost_volume(
                &scene.views[0],
                &corner.images[0],
                &neighbours,
                &energy.planes,
                &crate::photo::PhotoConfig {
                    support_sigma_color: sigma as f32,
                    ..Default::default()
                },
            )
            .unwrap();
            let added: Vec<f32> = energy
                .unary
                .iter()
                .zip(&before)
                .map(|(a, b)| a - b)
                .collect();
            assert_eq!(added.len(), volume.costs.len());
            for (a, c) in added.iter().zip(&volume.costs) {
                assert!((a - cfg.photo_weight as f32 * c).abs() < 1e-5, "{a} vs {c}");
            }
            added
        };
        let boxed = photo_costs(0.0);
        let weighted = photo_costs(0.15);
        // The weights change the windows that straddle the corner's creases and the stripe.
        let changed = boxed
            .iter()
            .zip(&weighted)
            .filter(|(a, b)| (*a - *b).abs() > 0.01)
            .count();
        assert!(
            changed * 100 > boxed.len(),
            "only {changed} of {} costs changed",
            boxed.len()
        );
        assert!(PlanemapConfig {
            photo_support_sigma_color: -0.1,
            ..PlanemapConfig::default()
        }
        .validate()
        .is_err_and(|e| e.to_string().contains("photo_support_sigma_color")));
    }

    #[test]
    fn confirmed_sweep_depths_replace_the_planes_that_miss_them() {
        let (scene, depths) = corner_depths();
        // Every view labelled with a plane 10 % too far, except view 0's left half, which a
        // plane gets right; the sweep has the truth everywhere.
        let w = scene.views[0].camera.width as usize;
        let views = labelled(&scene, &depths, &depths, |i, p, z| {
            if i == 0 && p % w < w / 2 {
                z
            } else {
                z * 1.1
            }
        });
        let cfg = NonplanarConfig {
            consistent_views: 2,
            ..Default::default()
        };
        let mut out = views.clone();
        let changed = confirm_nonplanar(&scene, &mut out, &cfg);
        let w = scene.views[0].camera.width as usize;
        let counts: Vec<Vec<u16>> = (0..3)
            .map(|i| {
                let all: Vec<Option<&[f32]>> = depths.iter().map(|d| Some(d.as_slice())).collect();
                crate::nonplanar::sweep_confirmations(&scene, i, &all, 0.01, 2)
            })
            .collect();
        for (i, v) in out.iter().enumerate() {
            let mut n = 0;
            for p in 0..v.depth.len() {
                let right_plane = i == 0 && p % w < w / 2;
                if counts[i][p] >= 2 && !right_plane && depths[i][p] > 0.0 {
                    assert_eq!(v.labels[p], NONPLANAR);
                    assert_eq!(v.depth[p], depths[i][p]);
                    assert!(v.normals[p] != [0.0, 0.0, -1.0] || v.normals[p] == [0.0; 3]);
                    n += 1;
                } else {
                    assert_eq!(v.labels[p], 0);
                    assert_eq!(v.depth[p], views[i].depth[p]);
                }
            }
            assert_eq!(changed[i], n);
            assert!(n > 1000, "view {i}: {n}");
        }
        // More confirmations than there are other views: nothing changes; nor without
        // sweep depths.
        let mut out = views.clone();
        let strict = NonplanarConfig {
            consistent_views: 3,
            ..Default::default()
        };
        assert_eq!(confirm_nonplanar(&scene, &mut out, &strict), vec![0, 0, 0]);
        for (a, b) in out.iter().zip(&views) {
            assert_eq!((&a.depth, &a.labels), (&b.depth, &b.labels));
        }
        let mut bare = views.clone();
        for v in &mut bare {
            v.sweep_depth = None;
        }
        assert_eq!(confirm_nonplanar(&scene, &mut bare, &cfg), vec![0, 0, 0]);
    }

    #[test]
    fn the_gross_tier_takes_loosely_confirmed_sweeps_from_planes_far_off() {
        let (scene, depths) = corner_depths();
        // Sweeps 2 % off the truth, view 1 nearer and the others farther: no two views
        // that differ in sign agree within 1 %, all of them within 5 %.
        let sweeps: Vec<Vec<f32>> = depths
            .iter()
            .enumerate()
            .map(|(i, d)| {
                let f = if i == 1 { 0.98 } else { 1.02 };
                d.iter().map(|&z| z * f).collect()
            })
            .collect();
        let cfg = NonplanarConfig {
            consistent_views: 2,
            ..Default::default()
        };
        let off = NonplanarConfig {
            gross_gap: 0.0,
            ..cfg.clone()
        };
        // Planes 30 % too far: only the gross tier changes them, to the sweep's depth.
        let far = labelled(&scene, &depths, &sweeps, |_, _, z| z * 1.3);
        let mut out = far.clone();
        assert_eq!(confirm_nonplanar(&scene, &mut out, &off), vec![0, 0, 0]);
        let changed = confirm_nonplanar(&scene, &mut out, &cfg);
        for (i, (v, before)) in out.iter().zip(&far).enumerate() {
            assert!(changed[i] > 1000, "view {i}: {}", changed[i]);
            let mut n = 0;
            for (p, &z) in sweeps[i].iter().enumerate() {
                if v.labels[p] == NONPLANAR {
                    assert_eq!(v.depth[p], z);
                    n += 1;
                } else {
                    assert_eq!(v.depth[p], before.depth[p]);
                }
            }
            assert_eq!(n, changed[i]);
        }
        // Planes 10 % too far are within the gap: the gross tier leaves them.
        let mut near = labelled(&scene, &depths, &sweeps, |_, _, z| z * 1.1);
        assert_eq!(confirm_nonplanar(&scene, &mut near, &cfg), vec![0, 0, 0]);
        // A looser agreement than the views have is a config error, not a silent change.
        let bad = NonplanarConfig {
            gross_tolerance: 1.5,
            ..cfg.clone()
        };
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("nonplanar.gross_tolerance"));
    }
}
