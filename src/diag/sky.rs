//! The sky stage ([`crate::sky`]) against a synthetic workspace's ground truth, without a
//! run: per workspace, the share of the pixels with no ground-truth surface (sky) that the
//! stage catches, and the share of pixels with a surface it wrongly takes for sky (each of
//! those becomes a pixel without depth, a miss in every depth score).

use std::path::PathBuf;

use super::{DiagResult, Workspace};
use crate::eval::metrics::has_depth;
use crate::io::output_stem;
use crate::io::pfm::read_pfm_path;
use crate::pipeline::Config;

/// Options of `planemap diag sky`.
#[derive(Debug, Clone, clap::Args)]
pub struct SkyArgs {
    /// `planemap synth` workspaces (sparse/, images/, gt/).
    #[arg(required = true)]
    pub workspaces: Vec<PathBuf>,
    /// Config overrides, e.g. --set sky.max_std=0.03 (repeatable).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Print every view, not only the totals.
    #[arg(long)]
    pub per_view: bool,
    /// Write each view's mask as DIR/WORKSPACE/VIEW.png (white: sky caught, red: a surface
    /// taken for sky, blue: sky missed; the image dimmed elsewhere).
    #[arg(long, value_name = "DIR")]
    pub masks: Option<PathBuf>,
}

/// Runs the audit.
pub fn run(args: &SkyArgs) -> DiagResult {
    let cfg = crate::config::with_overrides(&Config::default(), &args.overrides)?;
    let mut sky_cfg = cfg.sky.clone();
    sky_cfg.enabled = true;
    println!("| workspace | sky pixels | caught | surface pixels | taken for sky |");
    println!("|---|---|---|---|---|");
    for root in &args.workspaces {
        let ws = Workspace::open(root)?;
        let scene = &ws.scene;
        let up = crate::sky::scene_vertical(&scene.views);
        let (mut empty, mut caught, mut surface, mut wrong) = (0u64, 0u64, 0u64, 0u64);
        for view in &scene.views {
            let path = ws
                .gt()
                .join("depth")
                .join(format!("{}.pfm", output_stem(&view.name)));
            let gt = read_pfm_path(&path)?;
            let image = view.load_undistorted_image()?;
            let mask = crate::sky::sky_mask(view, &image, &scene.cloud, up.as_ref(), &sky_cfg);
            if let Some(dir) = &args.masks {
                let name = root.file_name().map(|n| n.to_string_lossy().into_owned());
                let path = dir
                    .join(name.unwrap_or_default())
                    .join(format!("{}.png", output_stem(&view.name)));
                write_mask(&path, &image, &gt.data, &mask)?;
            }
            let (mut e, mut c, mut s, mut x) = (0u64, 0u64, 0u64, 0u64);
            for (&z, &m) in gt.data.iter().zip(&mask) {
                if has_depth(z) {
                    s += 1;
                    x += m as u64;
                } else {
                    e += 1;
                    c += m as u64;
                }
            }
            if args.per_view {
                println!(
                    "|   {} | {e} | {:.1} % | {s} | {:.2} % |",
                    view.name,
                    100.0 * c as f64 / e.max(1) as f64,
                    100.0 * x as f64 / s.max(1) as f64
                );
            }
            (empty, caught, surface, wrong) = (empty + e, caught + c, surface + s, wrong + x);
        }
        println!(
            "| {} | {empty} | {:.1} % | {surface} | {:.2} % |",
            root.display(),
            100.0 * caught as f64 / empty.max(1) as f64,
            100.0 * wrong as f64 / surface.max(1) as f64
        );
    }
    Ok(())
}

fn write_mask(
    path: &std::path::Path,
    image: &crate::raster::ImageF32,
    gt: &[f32],
    mask: &[bool],
) -> DiagResult {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)?;
    }
    let mut img = image::RgbImage::new(image.width, image.height);
    for (p, px) in img.pixels_mut().enumerate() {
        let (x, y) = (p as u32 % image.width, p as u32 / image.width);
        let v = image.pixel(x, y);
        let grey = v.iter().sum::<f32>() / v.len().max(1) as f32;
        let dim = (grey * 160.0) as u8;
        px.0 = match (has_depth(gt[p]), mask[p]) {
            (false, true) => [255, 255, 255],
            (true, true) => [230, 30, 30],
            (false, false) => [40, 60, 230],
            (true, false) => [dim, dim, dim],
        };
    }
    img.save(path)?;
    Ok(())
}
