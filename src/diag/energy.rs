//! Why is a view's planemap wrong? Scores planemap's labelling and a ground-truth labelling
//! under the same energy, on a `planemap synth` workspace.
//!
//! Per view it prints:
//! - coverage: the share of pixels with ground-truth depth that some plane hypothesis (all
//!   of them / the labels kept for this view) explains within 1 % — what the labelling could
//!   reach at best;
//! - planemap's result and the "oracle" labelling (each pixel takes the kept label closest
//!   to ground truth if one is within 1 %, else planemap's label), each with its energy split
//!   into the visibility data term, the photo-consistency term and the smoothness term.
//!
//! If the oracle's energy is lower, the solver stopped in a worse local minimum; if it is
//! higher, the energy itself prefers the wrong answer, and the split says which term.
//!
//! `--creases FILE` adds a run's `crease_hypotheses.json` to the labels (the energy of
//! `planemap run`'s second labelling; without it, the first). `--erode N` constrains the
//! oracle only where the whole (2N+1)² window around a pixel agrees on its right label, so
//! its boundaries may move N pixels onto the image's lines instead of following the ground
//! truth's exact silhouettes (which the line detector may miss by a pixel). `--pairs K`
//! prints, for both labellings, the smoothness paid per kind of pair (on a dominant line /
//! on another image edge / elsewhere) and the K dearest (plane, plane, kind) groups.
//!
//! `--maps DIR` writes `smooth_VIEW.png`: planemap's labels, the oracle's, each darkened
//! with the smoothness it pays in red, and the pixels where they differ (red where the
//! oracle's photo cost is higher, green where lower). `--photo-pair A,B` adds
//! `photo_VIEW_A_B.png`, plane A's photo cost minus plane B's (red: A dearer).

use std::path::PathBuf;

use planemap_solvers::{
    Connectivity, DataCost, ExpansionConfig, LabelOrder, Mrf, Smoothness as SolverSmoothness,
};

use super::{DiagResult, Workspace};
use crate::pipeline::{self, Config};
use crate::planemap::PlanemapEnergy;

/// Options of `planemap diag energy`.
#[derive(Debug, Clone, clap::Args)]
pub struct EnergyArgs {
    /// A `planemap synth` workspace (sparse/, images/, gt/).
    pub workspace: PathBuf,
    /// Views to audit (indices in image-id order; default: all).
    pub views: Vec<usize>,
    /// Override a planemap config value (repeatable).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub overrides: Vec<String>,
    /// A run's crease_hypotheses.json: audit the second labelling's energy.
    #[arg(long)]
    pub creases: Option<PathBuf>,
    /// Constrain the oracle only where the (2N+1)² window around a pixel agrees on its label.
    #[arg(long, default_value_t = 0, value_name = "N")]
    pub erode: usize,
    /// Print the smoothness split by kind of pair and the K dearest plane pairs.
    #[arg(long, default_value_t = 0, value_name = "K")]
    pub pairs: usize,
    /// Write smooth_VIEW.png and lines_VIEW.png maps into this folder.
    #[arg(long, value_name = "DIR")]
    pub maps: Option<PathBuf>,
    /// With --maps: photo_VIEW_A_B.png, plane A's photo cost minus plane B's.
    #[arg(
        long,
        value_name = "A,B",
        value_delimiter = ',',
        num_args = 2,
        requires = "maps"
    )]
    pub photo_pair: Option<Vec<u32>>,
}

/// Energy of a labelling split into (visibility data, photo data, smoothness).
fn split(e: &PlanemapEnergy, vis: &PlanemapEnergy, labels: &[u32]) -> (f64, f64, f64) {
    let (w, h) = (e.width as usize, e.height as usize);
    let (mut dv, mut dp, mut s) = (0.0, 0.0, 0.0);
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let a = labels[p];
            let v = vis.unary(p, a) as f64;
            dv += v;
            dp += e.unary(p, a) as f64 - v;
            if x + 1 < w {
                s += e.pairwise(p, p + 1, a, labels[p + 1]) as f64;
            }
            if y + 1 < h {
                s += e.pairwise(p, p + w, a, labels[p + w]) as f64;
            }
        }
    }
    (dv, dp, s)
}

/// Prints the smoothness a labelling pays, split by kind of pair — on a dominant line (low
/// weight), on another image edge, elsewhere — and the `top` dearest (plane, plane, kind)
/// groups (global plane ids).
fn print_pair_split(e: &PlanemapEnergy, labels: &[u32], name: &str, top: usize) {
    use std::collections::BTreeMap;
    let (w, h) = (e.width as usize, e.height as usize);
    let kind = |p: usize, q: usize| {
        if e.weights.between(p, q) < 1.0 {
            "line"
        } else if e.weights.edge_between(p, q) {
            "edge"
        } else {
            "plain"
        }
    };
    let mut groups: BTreeMap<(u32, u32, &str), (usize, f64)> = BTreeMap::new();
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            let right = (x + 1 < w).then_some(p + 1);
            let down = (y + 1 < h).then_some(p + w);
            for q in [right, down].into_iter().flatten() {
                let (a, b) = (labels[p], labels[q]);
                if a == b {
                    continue;
                }
                let (ga, gb) = (e.labels[a as usize], e.labels[b as usize]);
                let g = groups
                    .entry((ga.min(gb), ga.max(gb), kind(p, q)))
                    .or_default();
                g.0 += 1;
                g.1 += e.pairwise(p, q, a, b) as f64;
            }
        }
    }
    let mut totals: BTreeMap<&str, (usize, f64)> = BTreeMap::new();
    for ((_, _, k), (count, cost)) in &groups {
        let t = totals.entry(k).or_default();
        t.0 += count;
        t.1 += cost;
    }
    let totals: Vec<String> = totals
        .iter()
        .map(|(k, (count, cost))| format!("{k} {count} pairs {cost:.1}"))
        .collect();
    println!("  {name} smoothness by pair: {}", totals.join(", "));
    let mut groups: Vec<_> = groups.into_iter().collect();
    groups.sort_by(|a, b| b.1 .1.total_cmp(&a.1 .1));
    for ((a, b, k), (count, cost)) in groups.iter().take(top) {
        println!("    planes {a:>3} | {b:<3} {k:<5}: {count:5} pairs, {cost:8.1}");
    }
}

/// Runs the audit.
pub fn run(args: &EnergyArgs) -> DiagResult {
    let cfg = crate::config::with_overrides(&Config::default(), &args.overrides)?;
    let ws = Workspace::open(&args.workspace)?;
    let scene = &ws.scene;
    let views = ws.views(&args.views)?;
    let erode = args.erode;
    let top_pairs = args.pairs;
    let maps = &args.maps;
    let pair = &args.photo_pair;
    let mut prepared = pipeline::prepare(scene, &cfg)?;
    if let Some(f) = &args.creases {
        let base = prepared.hypotheses.len();
        let extra = pipeline::read_crease_hypotheses(f, scene, base)
            .ok_or("cannot read the crease hypotheses")?;
        prepared.add_crease_hypotheses(extra);
    }
    let prepared = prepared;
    let mut vis_cfg = cfg.clone();
    vis_cfg.planemap.photo_weight = 0.0;
    println!(
        "{}: R = {:.4}, {} hypotheses",
        ws.root.display(),
        prepared.scale,
        prepared.hypotheses.len()
    );
    for &v in &views {
        let image = scene.views[v].load_undistorted_image()?;
        let gt = ws.gt_pfm("depth", v)?;
        let e = pipeline::view_energy(scene, &prepared, v, &image, &cfg)?;
        let vis = pipeline::view_energy(scene, &prepared, v, &image, &vis_cfg)?;
        assert_eq!(
            e.labels, vis.labels,
            "pruning must not depend on the photo term"
        );
        let result = pipeline::label_view(scene, &prepared, v, &image, &cfg)?;
        let local_of = |g: u32| e.labels.iter().position(|&l| l == g).map(|i| i as u32);
        let ours: Vec<u32> = result
            .labels
            .iter()
            .map(|&g| local_of(g).unwrap_or(0))
            .collect();
        let n = e.num_pixels();
        let gt_normals = ws.gt_pfm("normals", v)?;
        // A label is right at p if its depth is within 1 % of ground truth and its normal
        // within 10° of ground truth's (so a floor plane crossing the ceiling's depth on some
        // row does not count).
        let right =
            |p: usize, plane: &crate::geometry::Plane, world_normal: &nalgebra::Vector3<f64>| {
                let z = gt.data[p] as f64;
                let ray = e.smoothness.pixel_ray(p);
                let g = nalgebra::Vector3::new(
                    gt_normals.data[3 * p] as f64,
                    gt_normals.data[3 * p + 1] as f64,
                    gt_normals.data[3 * p + 2] as f64,
                );
                z > 0.0
                    && plane
                        .depth_along(&ray)
                        .is_some_and(|d| (d - z).abs() / z <= 0.01)
                    && (g.norm() < 0.5
                        || world_normal.dot(&g).abs() >= 10f64.to_radians().cos() * g.norm())
            };
        let cams: Vec<_> = (0..e.num_labels() as u32)
            .map(|a| *e.smoothness.plane_in_camera(a))
            .collect();
        let all_cam: Vec<_> = prepared
            .hypotheses
            .iter()
            .map(|h| {
                (
                    h.plane.in_camera(&scene.views[v].cam_from_world),
                    h.plane.normal,
                )
            })
            .collect();
        let ok = |p: usize, a: u32| right(p, &cams[a as usize], &e.planes[a as usize].normal);
        let mut oracle = ours.clone();
        let (mut gt_px, mut any_ok, mut kept_ok, mut ours_ok) = (0usize, 0usize, 0usize, 0usize);
        let mut fixable = vec![false; n];
        for p in 0..n {
            if gt.data[p] <= 0.0 {
                continue;
            }
            gt_px += 1;
            if all_cam.iter().any(|(pl, nw)| right(p, pl, nw)) {
                any_ok += 1;
            }
            if ok(p, ours[p]) {
                ours_ok += 1;
            }
            if let Some(a) = (0..e.num_labels() as u32).find(|&a| ok(p, a)) {
                kept_ok += 1;
                fixable[p] = true;
                if !ok(p, ours[p]) {
                    oracle[p] = a;
                }
            }
        }
        // The lowest-energy labelling among those that are right wherever a kept label can
        // be: α-expansion on the same energy with every wrong label made prohibitive there.
        let fixable = if erode == 0 {
            fixable
        } else {
            let (w, h) = (e.width as usize, e.height as usize);
            (0..n)
                .map(|p| {
                    let (x, y) = (p % w, p / w);
                    fixable[p]
                        && (y.saturating_sub(erode)..(y + erode + 1).min(h)).all(|yy| {
                            (x.saturating_sub(erode)..(x + erode + 1).min(w)).all(|xx| {
                                let q = yy * w + xx;
                                fixable[q] && oracle[q] == oracle[p]
                            })
                        })
                })
                .collect()
        };
        let oracle = {
            let nl = e.num_labels();
            let scale = cfg.solver.cost_scale;
            let to_int = |c: f32| (c as f64 * scale).round() as i32;
            let penalty = to_int(1000.0);
            let mut unary: Vec<i32> = e.unary.iter().map(|&c| to_int(c)).collect();
            for p in (0..n).filter(|&p| fixable[p]) {
                for a in 0..nl {
                    if !ok(p, a as u32) {
                        unary[p * nl + a] += penalty;
                    }
                }
            }
            let smooth = |p: usize, q: usize, a: u32, b: u32| to_int(e.pairwise(p, q, a, b));
            let mrf = Mrf::grid(
                e.width as usize,
                e.height as usize,
                Connectivity::Four,
                nl,
                DataCost::Dense(&unary),
            )?
            .with_smoothness(SolverSmoothness::Fn(Box::new(smooth)))?;
            mrf.expansion(
                &ExpansionConfig {
                    max_cycles: 10,
                    order: LabelOrder::Fixed,
                },
                Some(&oracle),
            )?
            .labels
        };
        let pct = |k: usize| 100.0 * k as f64 / gt_px.max(1) as f64;
        let (ov, op, os) = split(&e, &vis, &ours);
        let (gv, gp, gs) = split(&e, &vis, &oracle);
        println!(
            "view {v} ({}): {} labels; within 1%: ours {:.1}%, reachable with kept labels {:.1}%, with all hypotheses {:.1}%",
            scene.views[v].name,
            e.num_labels(),
            pct(ours_ok),
            pct(kept_ok),
            pct(any_ok)
        );
        println!(
            "  ours   E = {:10.1}  (visibility {:9.1}, photo {:9.1}, smooth {:9.1})",
            ov + op + os,
            ov,
            op,
            os
        );
        println!(
            "  oracle E = {:10.1}  (visibility {:9.1}, photo {:9.1}, smooth {:9.1})  {}",
            gv + gp + gs,
            gv,
            gp,
            gs,
            if gv + gp + gs < ov + op + os {
                "lower: the solver missed it"
            } else {
                "higher: the energy prefers ours"
            }
        );
        if top_pairs > 0 {
            for (name, lab) in [("ours", &ours), ("oracle", &oracle)] {
                print_pair_split(&e, lab, name, top_pairs);
            }
        }
        if let Some(dir) = &maps {
            // The smoothness weights over the image at half brightness: yellow where a pair
            // from the pixel (right or down) has a low weight, blue on other image edges.
            let mut im = image::RgbImage::new(e.width, e.height);
            let grey = image.to_gray();
            for p in 0..n {
                let g = (grey.data[p].clamp(0.0, 1.0) * 127.0) as u8;
                let px = if e.weights.right[p] < 1.0 || e.weights.down[p] < 1.0 {
                    [255, 255, 0]
                } else if e.weights.image_edge[p] {
                    [0, 0, 255]
                } else {
                    [g, g, g]
                };
                let (x, y) = ((p % e.width as usize) as u32, (p / e.width as usize) as u32);
                im.put_pixel(x, y, image::Rgb(px));
            }
            im.save(dir.join(format!("lines_{v}.png")))?;
        }
        if let Some(dir) = &maps {
            // Per-pixel smoothness paid (right and down pairs) and labels, for both labellings.
            let (w, h) = (e.width as usize, e.height as usize);
            let mut im = image::RgbImage::new(e.width * 3, e.height);
            for p in 0..n {
                let (x, y) = ((p % w) as u32, (p / w) as u32);
                let px = if ours[p] != oracle[p] {
                    let d = (e.unary(p, oracle[p]) - vis.unary(p, oracle[p]))
                        - (e.unary(p, ours[p]) - vis.unary(p, ours[p]));
                    let m = ((d.abs() / 0.3) * 255.0).clamp(40.0, 255.0) as u8;
                    if d > 0.0 {
                        [m, 0, 0]
                    } else {
                        [0, m, 0]
                    }
                } else {
                    [0, 0, 0]
                };
                im.put_pixel(2 * e.width + x, y, image::Rgb(px));
            }
            for (k, lab) in [&ours, &oracle].into_iter().enumerate() {
                for y in 0..h {
                    for x in 0..w {
                        let p = y * w + x;
                        let mut c = 0.0;
                        if x + 1 < w {
                            c += e.pairwise(p, p + 1, lab[p], lab[p + 1]);
                        }
                        if y + 1 < h {
                            c += e.pairwise(p, p + w, lab[p], lab[p + w]);
                        }
                        let v = (c / (2.0 * e.lambda * 10.0) * 255.0).min(255.0) as u8;
                        let base =
                            crate::io::labelpng::label_color(e.labels[lab[p] as usize] as u16 + 1);
                        let px = if v > 0 {
                            [v.max(60), 0, 0]
                        } else {
                            [base[0] / 3, base[1] / 3, base[2] / 3]
                        };
                        im.put_pixel((k * w + x) as u32, y as u32, image::Rgb(px));
                    }
                }
            }
            im.save(dir.join(format!("smooth_{v}.png")))?;
        }
        if let (Some(dir), Some(g)) = (&maps, &pair) {
            // Photo cost of global plane a minus that of b: red where a is dearer, green cheaper.
            if let (Some(a), Some(b)) = (local_of(g[0]), local_of(g[1])) {
                let mut im = image::RgbImage::new(e.width, e.height);
                for p in 0..n {
                    let pa = e.unary(p, a) - vis.unary(p, a);
                    let pb = e.unary(p, b) - vis.unary(p, b);
                    let d = ((pa - pb) * 255.0 / cfg.planemap.photo_weight.max(1e-6) as f32) as i32;
                    let px = if d > 0 {
                        [d.min(255) as u8, 0, 0]
                    } else {
                        [0, (-d).min(255) as u8, 0]
                    };
                    im.put_pixel(
                        (p % e.width as usize) as u32,
                        (p / e.width as usize) as u32,
                        image::Rgb(px),
                    );
                }
                im.save(dir.join(format!("photo_{v}_{}_{}.png", g[0], g[1])))?;
            }
        }
        // Which labels the two disagree on most, with the per-pixel data difference.
        let mut pairs: std::collections::BTreeMap<(u32, u32), (usize, f64, f64)> =
            Default::default();
        for p in 0..n {
            if ours[p] != oracle[p] {
                let entry = pairs.entry((ours[p], oracle[p])).or_default();
                entry.0 += 1;
                entry.1 += (vis.unary(p, oracle[p]) - vis.unary(p, ours[p])) as f64;
                entry.2 += ((e.unary(p, oracle[p]) - vis.unary(p, oracle[p]))
                    - (e.unary(p, ours[p]) - vis.unary(p, ours[p])))
                    as f64;
            }
        }
        let mut pairs: Vec<_> = pairs.into_iter().collect();
        pairs.sort_by_key(|(_, (count, _, _))| std::cmp::Reverse(*count));
        for ((a, b), (count, dv, dp)) in pairs.iter().take(5) {
            println!(
                "    ours plane {:>3} -> oracle plane {:>3}: {:6} px, Δvisibility {:+8.1}, Δphoto {:+8.1}",
                e.labels[*a as usize], e.labels[*b as usize], count, dv, dp
            );
        }
    }
    Ok(())
}
