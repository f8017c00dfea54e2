//! Scores depth maps against a `planemap synth` workspace's ground truth, split into planar
//! and non-planar pixels (ground-truth plane id 0): share within 1 %, mean absolute error,
//! and how the non-planar error divides between pixels too far by more than 20 %, too near
//! by more than 20 %, and the rest.
//!
//! `DEPTH_DIR` holds `NAME.pfm` per ground-truth `depth/NAME.pfm` (a run's `depth/`, its
//! `sweep/`, or `planemap sweep`'s `depth/`); a view whose file is missing is skipped.
//!
//! `--box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX` (world frame) also splits the planar pixels into
//! those whose ground-truth surface point lies in the box and the rest, and describes the
//! box's surface as the input saw it: the sparse points of the workspace's `sparse/` model
//! inside the box, and the median 5×5 standard deviation of the grey image (`images/`) over
//! its pixels (the image noise alone gives about 0.007 in the synthetic scenes) — e.g. to
//! show that a surface carried no evidence of its depth. The workspace is `GT_DIR/..`.

use std::path::PathBuf;

use nalgebra::{Vector2, Vector3};

use super::DiagResult;
use crate::eval::metrics::{depth_counts, has_depth, DepthCounts};
use crate::io::colmap::read_model;
use crate::io::labelpng::read_label_png;
use crate::io::pfm::read_pfm_path;
use crate::photo::local_std;
use crate::scene::View;

/// Options of `planemap diag score-split`.
#[derive(Debug, Clone, clap::Args)]
pub struct SplitArgs {
    /// The workspace's ground truth (`WORKSPACE/gt`).
    pub gt: PathBuf,
    /// Folders of `NAME.pfm` depth maps to score (a run's depth/, its sweep/, or
    /// `planemap sweep`'s depth/).
    #[arg(required = true)]
    pub depth_dirs: Vec<PathBuf>,
    /// Also split the planar pixels at a world box XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX.
    #[arg(long = "box", value_name = "XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX", value_parser = WorldBox::parse)]
    pub world_box: Option<WorldBox>,
}

/// An axis-aligned world box.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldBox {
    /// Lower corner.
    pub min: Vector3<f64>,
    /// Upper corner.
    pub max: Vector3<f64>,
}

impl WorldBox {
    /// Parses `XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX`.
    pub fn parse(s: &str) -> Result<Self, String> {
        let v: Vec<f64> = s
            .split(',')
            .map(|t| t.trim().parse::<f64>())
            .collect::<Result<_, _>>()
            .map_err(|e| format!("--box {s:?}: {e}"))?;
        if v.len() != 6 || (0..3).any(|i| v[i] > v[i + 3]) {
            return Err(format!(
                "--box {s:?}: expected XMIN,YMIN,ZMIN,XMAX,YMAX,ZMAX with each min <= max"
            ));
        }
        Ok(WorldBox {
            min: Vector3::new(v[0], v[1], v[2]),
            max: Vector3::new(v[3], v[4], v[5]),
        })
    }

    /// Whether `x` is inside (boundary included).
    pub fn contains(&self, x: &Vector3<f64>) -> bool {
        (0..3).all(|i| x[i] >= self.min[i] && x[i] <= self.max[i])
    }
}

/// Per pixel of `view`: whether its ground-truth surface point (depth `gt`) is in `b`.
fn in_box(view: &View, gt: &[f32], width: u32, b: &WorldBox) -> Vec<bool> {
    gt.iter()
        .enumerate()
        .map(|(p, &z)| {
            let (x, y) = (
                (p as u32 % width) as f64 + 0.5,
                (p as u32 / width) as f64 + 0.5,
            );
            let (o, d) = view.ray(&Vector2::new(x, y));
            has_depth(z) && b.contains(&(o + d * z as f64))
        })
        .collect()
}

#[derive(Default)]
struct Gross {
    far: (u64, f64),
    near: (u64, f64),
}

/// Runs the audit.
pub fn run(args: &SplitArgs) -> DiagResult {
    let gt = &args.gt;
    let ws = gt.join("..");
    // Per view name, which pixels' ground-truth surface points lie in the box (computed
    // once, shared by every DEPTH_DIR).
    let mut box_masks: std::collections::HashMap<String, Vec<bool>> = Default::default();
    if let Some(b) = &args.world_box {
        let scene = read_model(&ws.join("sparse"))?
            .to_scene(Some(&ws.join("images")))?
            .undistorted();
        let inside = scene
            .cloud
            .positions
            .iter()
            .filter(|x| b.contains(x))
            .count();
        let mut stds: Vec<f64> = Vec::new();
        for view in &scene.views {
            let stem = std::path::Path::new(&view.name).with_extension("pfm");
            let Ok(gt_depth) = read_pfm_path(&gt.join("depth").join(&stem)) else {
                continue;
            };
            let mask = in_box(view, &gt_depth.data, gt_depth.width, b);
            let std = local_std(&view.load_undistorted_image()?, 2);
            stds.extend(std.iter().zip(&mask).filter(|(_, &m)| m).map(|(&s, _)| s));
            box_masks.insert(view.name.clone(), mask);
        }
        stds.sort_by(f64::total_cmp);
        let median = stds.get(stds.len() / 2).copied().unwrap_or(f64::NAN);
        println!(
            "box: {} ground-truth pixels over all views; {inside} of the {} sparse points \
             inside; grey 5×5 std median {median:.4} over its pixels",
            stds.len(),
            scene.cloud.len()
        );
    }
    let mut names: Vec<_> = std::fs::read_dir(gt.join("depth"))?
        .filter_map(|e| e.ok().map(|e| e.file_name()))
        .collect();
    names.sort();
    for dir in &args.depth_dirs {
        let (mut planar, mut nonplanar) = (DepthCounts::default(), DepthCounts::default());
        let (mut planar_in, mut planar_out) = (DepthCounts::default(), DepthCounts::default());
        let mut gross = Gross::default();
        let mut views = 0;
        for name in &names {
            let pred_path = dir.join(name);
            if !pred_path.exists() {
                continue;
            }
            views += 1;
            let gt_depth = read_pfm_path(&gt.join("depth").join(name))?;
            let pred = read_pfm_path(&pred_path)?;
            let stem = std::path::Path::new(name).with_extension("png");
            let (_, _, ids) = read_label_png(&gt.join("planes").join(&stem))?;
            let split = |want_planar: bool| -> Vec<f32> {
                gt_depth
                    .data
                    .iter()
                    .zip(&ids)
                    .map(|(&z, &id)| if (id != 0) == want_planar { z } else { 0.0 })
                    .collect()
            };
            let planar_gt = split(true);
            planar.add(&depth_counts(&pred.data, &planar_gt, None));
            if let Some(mask) = box_masks.get(stem.to_string_lossy().as_ref()) {
                let part = |want: bool| -> Vec<f32> {
                    planar_gt
                        .iter()
                        .zip(mask)
                        .map(|(&z, &m)| if m == want { z } else { 0.0 })
                        .collect()
                };
                planar_in.add(&depth_counts(&pred.data, &part(true), None));
                planar_out.add(&depth_counts(&pred.data, &part(false), None));
            }
            let np_gt = split(false);
            nonplanar.add(&depth_counts(&pred.data, &np_gt, None));
            for (&z, &g) in pred.data.iter().zip(&np_gt) {
                if has_depth(z) && has_depth(g) {
                    let e = (z - g) as f64;
                    if e > 0.2 * g as f64 {
                        gross.far.0 += 1;
                        gross.far.1 += e;
                    } else if e < -0.2 * g as f64 {
                        gross.near.0 += 1;
                        gross.near.1 -= e;
                    }
                }
            }
        }
        let share = |x: f64| 100.0 * x / nonplanar.abs_error_sum.max(1e-12);
        println!(
            "{}: {views} views; planar {:.2} % within 1 % (of {}, MAE {:.3}); non-planar {:.2} % \
             within 1 % (of {}, {:.1} % with a depth, MAE {:.3}); non-planar > 20 % too far {} px \
             ({:.0} % of the abs. error), > 20 % too near {} px ({:.0} %)",
            dir.display(),
            100.0 * planar.accuracy(1),
            planar.gt_pixels,
            planar.mean_abs_error(),
            100.0 * nonplanar.accuracy(1),
            nonplanar.gt_pixels,
            100.0 * nonplanar.completeness(),
            nonplanar.mean_abs_error(),
            gross.far.0,
            share(gross.far.1),
            gross.near.0,
            share(gross.near.1),
        );
        if args.world_box.is_some() {
            println!(
                "  planar pixels in the box {:.2} % within 1 % (of {}); outside it {:.2} % (of {})",
                100.0 * planar_in.accuracy(1),
                planar_in.gt_pixels,
                100.0 * planar_out.accuracy(1),
                planar_out.gt_pixels
            );
        }
    }
    Ok(())
}
