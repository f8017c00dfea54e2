//! Scores depth maps against a `planemap synth` workspace's ground truth, split into planar
//! and non-planar pixels (ground-truth plane id 0): share within 1 %, mean absolute error,
//! and how the non-planar error divides between pixels too far by more than 20 %, too near
//! by more than 20 %, and the rest — the figures issue 7 compares with the sweep baseline.
//!
//! ```sh
//! cargo run --release --example score_split -- GT_DIR DEPTH_DIR [DEPTH_DIR ...]
//! ```
//!
//! `DEPTH_DIR` holds `NAME.pfm` per ground-truth `depth/NAME.pfm` (a run's `depth/`, its
//! `sweep/`, or `planemap sweep`'s `depth/`); a view whose file is missing is skipped.

use std::path::PathBuf;

use planemap::bench::metrics::{depth_counts, has_depth, DepthCounts};
use planemap::io::labelpng::read_label_png;
use planemap::io::pfm::read_pfm_path;

#[derive(Default)]
struct Gross {
    far: (u64, f64),
    near: (u64, f64),
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    if args.len() < 2 {
        eprintln!("usage: score_split GT_DIR DEPTH_DIR [DEPTH_DIR ...]");
        std::process::exit(2);
    }
    let gt = &args[0];
    let mut names: Vec<_> = std::fs::read_dir(gt.join("depth"))?
        .filter_map(|e| e.ok().map(|e| e.file_name()))
        .collect();
    names.sort();
    for dir in &args[1..] {
        let (mut planar, mut nonplanar) = (DepthCounts::default(), DepthCounts::default());
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
            let (_, _, ids) = read_label_png(&gt.join("planes").join(stem))?;
            let split = |want_planar: bool| -> Vec<f32> {
                gt_depth
                    .data
                    .iter()
                    .zip(&ids)
                    .map(|(&z, &id)| if (id != 0) == want_planar { z } else { 0.0 })
                    .collect()
            };
            planar.add(&depth_counts(&pred.data, &split(true), None));
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
    }
    Ok(())
}
