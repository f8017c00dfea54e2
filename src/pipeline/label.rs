//! One view's planemap: its energy, the α-expansion solve, and the multi-view confirmation
//! of the non-planar label.

use std::time::Instant;

use planemap_solvers::{CoarseToFine, DataCost, ExpansionConfig, LabelOrder, Mrf, Smoothness};

use super::{Config, PipelineError, Prepared};
use crate::classify::PlanarityMap;
use crate::nonplanar::{
    normals_from_depth, ExtendedEnergy, NonplanarConfig, NonplanarView, NONPLANAR,
};
use crate::planemap::{PlanemapConfig, PlanemapEnergy, PlanemapError, ViewInputs};
use crate::raster::ImageF32;
use crate::scene::Scene;

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
    // The sweep's, the lines' and the crease hypotheses have few or no sparse points: the
    // sweep's and the lines' are offered wherever they lie in front of the camera, a crease
    // hypothesis in the views that see it.
    let creases_start = prepared.hypotheses.len() - prepared.crease_views.len();
    let offered_everywhere = prepared.sweep_hypotheses + prepared.line_hypotheses;
    let photo_planes: Vec<u32> = (creases_start - offered_everywhere..creases_start)
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

/// Labels one view: builds its energy ([`view_energy`]), minimises it by α-expansion, then
/// gives the sky no depth ([`crate::sky`]). `scene` must be undistorted (PINHOLE) and
/// `image` its image.
pub fn label_view(
    scene: &Scene,
    prepared: &Prepared,
    view_index: usize,
    image: &ImageF32,
    cfg: &Config,
) -> Result<ViewPlanemap, PipelineError> {
    let mut result = label_planes(scene, prepared, view_index, image, cfg)?;
    if cfg.sky.enabled {
        let up = crate::sky::scene_vertical(&scene.views);
        let sky = crate::sky::sky_mask(
            &scene.views[view_index],
            image,
            &scene.cloud,
            up.as_ref(),
            &cfg.sky,
        );
        for (p, _) in sky.iter().enumerate().filter(|(_, &s)| s) {
            result.labels[p] = NONPLANAR;
            result.depth[p] = 0.0;
            result.normals[p] = [0.0; 3];
        }
    }
    Ok(result)
}

/// [`label_view`] before the sky stage.
fn label_planes(
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
            crate::nonplanar::add_classifier_costs(&mut energy, ev, &cfg.nonplanar, &cfg.planemap)
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
    let pyramid = CoarseToFine {
        levels: cfg.solver.coarse_levels,
        band: cfg.solver.coarse_band,
        min_sites: cfg.solver.coarse_min_pixels,
        polish: cfg.solver.coarse_polish,
    };
    let (solution, levels) = mrf
        .expansion_coarse_to_fine(
            &ExpansionConfig {
                max_cycles: cfg.solver.max_cycles,
                order: LabelOrder::Fixed,
            },
            &pyramid,
            Some(&initial),
        )
        .map_err(solver_err)?;
    tracing::debug!(
        "{}: solved coarse-to-fine (pixels, relabelled, labels per level) {:?}",
        view.name,
        levels.levels
    );
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
pub(super) fn add_photo_term(
    scene: &Scene,
    view_index: usize,
    image: &ImageF32,
    images: &[ImageF32],
    energy: &mut PlanemapEnergy,
    cfg: &PlanemapConfig,
) -> Result<(), PlanemapError> {
    let photo_err = |e: crate::photo::PhotoError| PlanemapError::Input(format!("photo term: {e}"));
    let nb = crate::photo::select_neighbours(scene, view_index, cfg.photo.neighbours)
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
        &cfg.photo,
    )
    .map_err(photo_err)?;
    let w = cfg.photo_weight as f32;
    for (u, c) in energy.unary.iter_mut().zip(&volume.costs) {
        *u += w * c;
    }
    Ok(())
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
        .map(|v| crate::nonplanar::sweep_confirmation_tiers(scene, v.view_index, &sweeps, &tiers))
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
