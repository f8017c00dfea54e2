//! The data costs of every label a view is offered, at chosen pixels: visibility (sparse-point
//! conflicts), photo-consistency and their sum, with each label's plane and its depth there,
//! cheapest first. Needs no ground truth, so it also audits real photographs ("why did the
//! paving here take the wall's plane?"). The hypotheses are the run's first pass (points and
//! sweep; no crease hypotheses).

use std::path::PathBuf;

use super::{DiagResult, Workspace};
use crate::pipeline::{prepare, view_energy, Config};

/// Options of `planemap diag pixel`.
#[derive(Debug, Clone, clap::Args)]
pub struct PixelArgs {
    /// A workspace or real set (sparse/ and images/).
    pub workspace: PathBuf,
    /// The view, an index in image-id order.
    pub view: usize,
    /// Pixels X,Y (repeatable).
    #[arg(long = "pixel", value_name = "X,Y", required = true, value_parser = parse_pixel)]
    pub pixels: Vec<(u32, u32)>,
    /// Config overrides, e.g. --set planemap.photo_weight=0.5 (repeatable).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Print at most this many labels per pixel.
    #[arg(long, default_value_t = 12)]
    pub top: usize,
}

fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let v: Vec<&str> = s.split(',').collect();
    match v.as_slice() {
        [x, y] => Ok((
            x.trim().parse().map_err(|e| format!("{s:?}: {e}"))?,
            y.trim().parse().map_err(|e| format!("{s:?}: {e}"))?,
        )),
        _ => Err(format!("{s:?}: expected X,Y")),
    }
}

/// Runs the audit.
pub fn run(args: &PixelArgs) -> DiagResult {
    let cfg = crate::config::with_overrides(&Config::default(), &args.overrides)?;
    let ws = Workspace::open(&args.workspace)?;
    let scene = &ws.scene;
    let v = ws.views(&[args.view])?[0];
    let view = &scene.views[v];
    for &(x, y) in &args.pixels {
        if x >= view.camera.width || y >= view.camera.height {
            return Err(format!(
                "pixel {x},{y} outside view {} ({}×{})",
                view.name, view.camera.width, view.camera.height
            )
            .into());
        }
    }
    let prepared = prepare(scene, &cfg)?;
    let image = view.load_undistorted_image()?;
    let full = view_energy(scene, &prepared, v, &image, &cfg)?;
    let mut no_photo = cfg.clone();
    no_photo.planemap.photo_weight = 0.0;
    let visibility = view_energy(scene, &prepared, v, &image, &no_photo)?;
    let n = full.labels.len();
    println!(
        "view {} ({}): {} labels offered of {} hypotheses",
        v,
        view.name,
        n,
        prepared.hypotheses.len()
    );
    for &(x, y) in &args.pixels {
        let p = (y * view.camera.width + x) as usize;
        let ray = full.smoothness.pixel_ray(p);
        let mut rows: Vec<(f32, f32, f32, u32, Option<f64>)> = (0..n as u32)
            .map(|a| {
                let total = full.unary(p, a);
                let vis = visibility.unary(p, a);
                (
                    total,
                    vis,
                    total - vis,
                    full.labels[a as usize],
                    full.smoothness.depth(&ray, a),
                )
            })
            .collect();
        rows.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.3.cmp(&b.3)));
        println!("pixel {x},{y}: label  total  visibility  photo  depth  plane (n; d)");
        for (total, vis, photo, id, depth) in rows.iter().take(args.top) {
            let pl = &prepared.hypotheses[*id as usize].plane;
            println!(
                "  {id:5} {total:6.3} {vis:10.3} {photo:6.3} {:>7} ({:.2}, {:.2}, {:.2}; {:.2})",
                depth.map_or("–".into(), |z| format!("{z:.2}")),
                pl.normal.x,
                pl.normal.y,
                pl.normal.z,
                pl.offset
            );
        }
    }
    Ok(())
}
