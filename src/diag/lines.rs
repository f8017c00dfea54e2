//! How good are the 3D lines? Runs the sparse stages and [`crate::lines::triangulate_lines`]
//! on a `planemap synth` workspace and reports, per view, the segments found, those pointing
//! at a dominant direction and long enough to match; for the 3D lines, how many there are
//! and the share within 1 % (and 2 %) of the ground-truth depth, sampled along each line in
//! every view that saw it (the best of a 3×3 window, since an edge pixel may show the
//! surface behind); then the planes the lines propose, each with the nearest ground-truth
//! plane of the same normal.

use std::path::PathBuf;

use nalgebra::Vector2;

use super::{DiagResult, Workspace};
use crate::pipeline::{sparse_stages, Config};

/// Options of `planemap diag lines`.
#[derive(Debug, Clone, clap::Args)]
pub struct LinesArgs {
    /// A `planemap synth` workspace (sparse/, images/, gt/).
    pub workspace: PathBuf,
    /// Override a config value (repeatable), e.g. --set lines.min_views=4
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Print every view's counts, not only the totals.
    #[arg(long)]
    pub per_view: bool,
}

/// Samples per line and view.
const SAMPLES: usize = 9;

/// Runs the audit.
pub fn run(args: &LinesArgs) -> DiagResult {
    let mut cfg = crate::config::with_overrides(&Config::default(), &args.overrides)?;
    cfg.hypotheses.lines.enabled = true;
    let ws = Workspace::open(&args.workspace)?;
    let scene = &ws.scene;
    let images = ws.images()?;
    let s = sparse_stages(scene, &cfg)?;
    let t = std::time::Instant::now();
    let set =
        crate::lines::triangulate_lines(scene, &images, &s.axes.directions, s.scale, &cfg.lines);
    let seconds = t.elapsed().as_secs_f64();
    let (mut found, mut assigned) = (0usize, 0usize);
    for (v, vl) in set.views.iter().enumerate() {
        let a = vl.direction.iter().filter(|d| d.is_some()).count();
        found += vl.segments.len();
        assigned += a;
        if args.per_view {
            println!(
                "view {v:3}: {:4} segments, {a:4} toward a dominant direction",
                vl.segments.len()
            );
        }
    }
    let nv = set.views.len().max(1) as f64;
    println!(
        "{} views: {:.1} segments per view, {:.1} toward a dominant direction; {} 3D lines \
         ({:.1} s)",
        set.views.len(),
        found as f64 / nv,
        assigned as f64 / nv,
        set.lines.len(),
        seconds
    );
    // Accuracy against the ground-truth depth maps.
    let gt: Vec<_> = (0..scene.views.len())
        .map(|v| ws.gt_pfm("depth", v))
        .collect::<Result<_, _>>()?;
    let (mut within1, mut within2, mut scored) = (0usize, 0usize, 0usize);
    for l in &set.lines {
        let d = s.axes.directions[l.direction].normalize();
        let mut errs = Vec::new();
        for &v in &l.views {
            let view = &scene.views[v];
            let g = &gt[v];
            for i in 0..SAMPLES {
                let t = l.extent.0 + (i as f64 + 0.5) / SAMPLES as f64 * l.length();
                let Some((xy, z)) = view.project(&(l.point + t * d)) else {
                    continue;
                };
                if !view.camera.contains(&xy) {
                    continue;
                }
                errs.push(best_rel_err(g, &xy, z));
            }
        }
        if errs.is_empty() {
            continue;
        }
        errs.sort_by(f64::total_cmp);
        let median = errs[errs.len() / 2];
        if args.per_view {
            println!(
                "line dir {} views {:?} length {:.2} sigma {:.4}: median error {:.2} %",
                l.direction,
                l.views,
                l.length(),
                l.sigma,
                100.0 * median
            );
        }
        scored += 1;
        within1 += usize::from(median <= 0.01);
        within2 += usize::from(median <= 0.02);
    }
    let pct = |n: usize| 100.0 * n as f64 / scored.max(1) as f64;
    println!(
        "3D lines within 1 % of the ground-truth depth: {:.1} % (2 %: {:.1} %) of {scored}",
        pct(within1),
        pct(within2)
    );
    // The planes they propose.
    let input = s.input(scene);
    let planes = crate::hypotheses::line_plane_hypotheses(
        &input,
        &set.lines,
        &s.hypotheses,
        &cfg.hypotheses,
    )?;
    let gt_planes = ws.gt_planes()?;
    println!(
        "{} planes from lines (beside {} from the points):",
        planes.len(),
        s.hypotheses.len()
    );
    for h in &planes {
        let n = h.plane.normal;
        let nearest = gt_planes
            .iter()
            .filter_map(|g| {
                let gn = nalgebra::Vector3::from(g.normal);
                let c = gn.dot(&n);
                (c.abs() > 0.999).then(|| ((c.signum() * g.offset - h.plane.offset).abs(), g))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0));
        match nearest {
            Some((dist, g)) => println!(
                "  axis {:?} offset {:8.4}: nearest ground-truth plane {} ({}) {:.4} away",
                h.axis, h.plane.offset, g.id, g.label, dist
            ),
            None => println!(
                "  axis {:?} offset {:8.4}: no ground-truth plane of that normal",
                h.axis, h.plane.offset
            ),
        }
    }
    Ok(())
}

/// The smallest relative depth error between `z` and the ground truth in the 3×3 window
/// around `xy`; infinity where the ground truth has no depth.
fn best_rel_err(g: &crate::raster::ImageF32, xy: &Vector2<f64>, z: f64) -> f64 {
    let (cx, cy) = (xy.x.floor() as i64, xy.y.floor() as i64);
    let mut best = f64::INFINITY;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let (x, y) = (cx + dx, cy + dy);
            if x < 0 || y < 0 || x >= g.width as i64 || y >= g.height as i64 {
                continue;
            }
            let zg = g.get(x as u32, y as u32, 0) as f64;
            if zg > 0.0 && zg.is_finite() {
                best = best.min((z - zg).abs() / zg);
            }
        }
    }
    best
}
