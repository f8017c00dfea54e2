//! Why is the plane-sweep baseline wrong? Scores the ground-truth planes of a
//! `planemap synth` workspace with the sweep's own measure and neighbours, beside the
//! sweep's winner.
//!
//! Per view it prints:
//! - per plane family, its plane count and how far consecutive planes move a pixel in the
//!   neighbour images (median, 90th percentile, maximum; [`family_step_px`]) — a sweep
//!   sampled much coarser than a pixel loses depths between its planes;
//! - over the ground-truth non-planar pixels: how often the sweep depth is within 1 %, how
//!   often it is confident (`nonplanar.min_confidence`), both;
//! - over the textured planar pixels (the mask `planemap sweep` scores) whose depth is off
//!   by more than 1 %: `truth cheaper` — the ground-truth plane costs less than the winner,
//!   so the sweep never tried a plane close enough (sampling, sub-plane interpolation);
//!   `truth dearer` — the measure itself prefers the wrong depth (repeated texture,
//!   occlusion, a window straddling an edge); how many of those have no signal at all
//!   before aggregation (the truth's raw cost is the outlier cost 1); which family won; the
//!   median relative error.
//!
//! `--nonplanar` audits the sweep of the non-planar label (`NonplanarConfig::sweep_config`)
//! instead of the baseline's; `--set` overrides either (keys as in `planemap sweep --set`; with --nonplanar, as under `nonplanar.sweep`).
//! `--pixel X,Y` adds, for that pixel, the truth's and the winner's cost per neighbour,
//! aggregated and raw. `--families` prints the plane families (count, step, first and last
//! plane) and skips the sweep.

use std::path::PathBuf;

use super::{DiagResult, Workspace};
use crate::baselines::scene_axes;
use crate::eval::read_gt_planes;
use crate::geometry::Plane;
use crate::nonplanar::NonplanarConfig;
use crate::photo::{
    family_step_px, multi_family_sweep, plane_cost_volume, sweep_setup, texture_mask, Aggregation,
    MultiSweepConfig,
};

/// Options of `planemap diag sweep`.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepArgs {
    /// A `planemap synth` workspace (sparse/, images/, gt/).
    pub workspace: PathBuf,
    /// Views to audit (indices in image-id order; default: all).
    pub views: Vec<usize>,
    /// Override a sweep setting (repeatable; keys as in `planemap sweep --set`).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Audit the non-planar label's sweep (`nonplanar.sweep`) instead of the baseline's.
    #[arg(long)]
    pub nonplanar: bool,
    /// For this pixel, the truth's and the winner's cost per neighbour, aggregated and raw.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel)]
    pub pixel: Option<(usize, usize)>,
    /// Print the plane families only, without sweeping.
    #[arg(long)]
    pub families: bool,
}

fn parse_pixel(s: &str) -> Result<(usize, usize), String> {
    let (x, y) = s.split_once(',').ok_or("expected X,Y")?;
    let n = |t: &str| t.trim().parse::<usize>().map_err(|e| format!("{t:?}: {e}"));
    Ok((n(x)?, n(y)?))
}

/// Runs the audit.
pub fn run(args: &SweepArgs) -> DiagResult {
    let base = if args.nonplanar {
        NonplanarConfig::default().sweep
    } else {
        MultiSweepConfig::default()
    };
    let cfg = crate::config::with_overrides(&base, &args.overrides)?;
    cfg.validate()?;
    let probe = args.pixel;
    let min_confidence = NonplanarConfig::default().min_confidence as f32;
    let ws = Workspace::open(&args.workspace)?;
    let scene = &ws.scene;
    let views = ws.views(&args.views)?;
    let images = ws.images()?;
    let axes = if cfg.axis_families {
        scene_axes(scene, &cfg)
    } else {
        Vec::new()
    };
    let gt_planes = read_gt_planes(&ws.gt())?;
    let mut totals = [0usize; 4];
    for &v in &views {
        let view = &scene.views[v];
        let gt_depth = ws.gt_pfm("depth", v)?;
        let gt_ids = ws.gt_plane_ids(v)?;
        let setup = sweep_setup(scene, v, &axes, &cfg)?;
        let pairs = setup.pairs(scene, &images);
        let nbr_views: Vec<_> = pairs.iter().map(|(nb, _)| *nb).collect();
        println!("{}:", view.name);
        for (f, fam) in setup.families.iter().enumerate() {
            let q = |x| family_step_px(view, &nbr_views, &fam.planes, x).unwrap_or(f64::NAN);
            let (first, last) = (&fam.planes[0], &fam.planes[fam.planes.len() - 1]);
            println!(
                "  family {f}: {} planes, step (px) median {:.2}, 90% {:.2}, max {:.1}; first n = [{:.3}, {:.3}, {:.3}] d = {:.3}, last n = [{:.3}, {:.3}, {:.3}] d = {:.3}",
                fam.planes.len(),
                q(0.5),
                q(0.9),
                q(1.0),
                first.normal.x,
                first.normal.y,
                first.normal.z,
                first.offset,
                last.normal.x,
                last.normal.y,
                last.normal.z,
                last.offset,
            );
        }
        if args.families {
            continue;
        }
        let swept = multi_family_sweep(
            view,
            &images[v],
            &pairs,
            &setup.families,
            &cfg.sweep_config(),
            cfg.subplane,
        )?;
        let (result, family) = (swept.sweep, swept.family);
        // The ground-truth planes this view shows, scored like the sweep's planes.
        let mut ids: Vec<u16> = gt_ids.iter().copied().filter(|&i| i > 0).collect();
        ids.sort_unstable();
        ids.dedup();
        let planes = ids
            .iter()
            .map(|id| {
                gt_planes
                    .iter()
                    .find(|r| r.id == *id)
                    .map(|r| Plane::new(r.normal.into(), r.offset))
                    .ok_or_else(|| format!("plane id {id} is not in gt/planes.json"))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let truth = plane_cost_volume(view, &images[v], &pairs, &planes, &cfg.photo)?;
        let mut raw_cfg = cfg.photo;
        raw_cfg.aggregation = Aggregation::None;
        let truth_raw = plane_cost_volume(view, &images[v], &pairs, &planes, &raw_cfg)?;

        let within = |p: usize| {
            let (z, g) = (result.depth[p], gt_depth.data[p]);
            z.is_finite() && (z - g).abs() <= 0.01 * g
        };
        let (mut np, mut right, mut sure, mut both) = (0usize, 0usize, 0usize, 0usize);
        let mask = texture_mask(&images[v], 3, 0.02);
        let (mut textured, mut wrong, mut cheaper, mut saturated) = (0usize, 0, 0, 0);
        let mut by_family = vec![0usize; setup.families.len() + 1];
        let mut errors = Vec::new();
        for (p, (&g, &id)) in gt_depth.data.iter().zip(&gt_ids).enumerate() {
            if g <= 0.0 {
                continue;
            }
            if id == 0 {
                let (ok, c) = (within(p), result.confidence[p] >= min_confidence);
                np += 1;
                right += usize::from(ok);
                sure += usize::from(c);
                both += usize::from(ok && c);
                continue;
            }
            if !mask[p] {
                continue;
            }
            textured += 1;
            if within(p) {
                continue;
            }
            wrong += 1;
            errors.push(((result.depth[p] - g) / g).abs());
            let k = ids.binary_search(&id).expect("ids lists every plane id");
            saturated += usize::from(truth_raw.pixel_costs(p)[k] >= 0.999);
            cheaper += usize::from(truth.pixel_costs(p)[k] < result.cost[p]);
            by_family[(family[p] as usize).min(setup.families.len())] += 1;
        }
        errors.sort_by(f32::total_cmp);
        let median = errors.get(errors.len() / 2).copied().unwrap_or(0.0);
        println!("  non-planar pixels {np}: within 1% {right}, confident {sure}, both {both}");
        println!(
            "  textured planar pixels {textured}, within 1% {:.1}%; of the {wrong} wrong: truth cheaper {cheaper}, truth dearer {}, no raw signal {saturated}; median |error| {median:.3}; won by family (fronto, axes…, none) {by_family:?}",
            100.0 * (textured - wrong) as f64 / textured.max(1) as f64,
            wrong - cheaper,
        );
        for (t, x) in totals.iter_mut().zip([textured, wrong, cheaper, saturated]) {
            *t += x;
        }

        if let Some((x, y)) = probe {
            let p = y * view.camera.width as usize + x;
            let k = ids
                .binary_search(&gt_ids[p])
                .map_err(|_| format!("pixel ({x}, {y}) is on no ground-truth plane"))?;
            let all: Vec<&Plane> = setup.families.iter().flat_map(|f| &f.planes).collect();
            let Some(&&win) = all.get(result.plane_index[p] as usize) else {
                println!("  pixel ({x}, {y}): no plane won");
                continue;
            };
            println!(
                "  pixel ({x}, {y}): ground truth {:.4} (plane {}), sweep {:.4} (family {}, cost {:.4}), truth's cost {:.4}",
                gt_depth.data[p],
                gt_ids[p],
                result.depth[p],
                family[p],
                result.cost[p],
                truth.pixel_costs(p)[k]
            );
            for (agg, label) in [
                (cfg.photo.aggregation, "aggregated"),
                (Aggregation::None, "raw"),
            ] {
                let mut one = cfg.photo;
                one.best_k = 1;
                one.min_evidence = 1;
                one.aggregation = agg;
                for (j, pair) in pairs.iter().enumerate() {
                    let vol = plane_cost_volume(
                        view,
                        &images[v],
                        std::slice::from_ref(pair),
                        &[planes[k], win],
                        &one,
                    )?;
                    println!(
                        "    {label}, neighbour {} ({}): truth {:.4}, winner {:.4}",
                        setup.neighbours[j],
                        pair.0.name,
                        vol.pixel_costs(p)[0],
                        vol.pixel_costs(p)[1]
                    );
                }
            }
        }
    }
    println!(
        "all: textured planar pixels {}, within 1% {:.1}%; wrong {}: truth cheaper {}, truth dearer {}, no raw signal {}",
        totals[0],
        100.0 * (totals[0] - totals[1]) as f64 / totals[0].max(1) as f64,
        totals[1],
        totals[2],
        totals[1] - totals[2],
        totals[3]
    );
    Ok(())
}
