//! Scores existing runs on a real set (`sparse/`, `images/`, `heldout.json`, see
//! [`crate::eval::heldout`]) without running anything: per view and over all views, the
//! held-out observations within 1, 2 and 5 % and the median error, the neighbouring views'
//! agreement within 1 %, the share of pixels with a depth and, for a run folder with normal
//! maps, the share of the bottom 8 % of the rows labelled with a horizontal plane.
//!
//! Each `RUN` is a `planemap run` output folder (its `depth/` and `stereo/normal_maps/`
//! are read) or a folder of `NAME.pfm` depth maps (`planemap sweep`'s `depth/`); views
//! without a map are skipped, so a run on `--views` is scored on those views.

use std::path::PathBuf;

use super::DiagResult;
use crate::bench::real::{load_real_set, AGREEMENT_NEIGHBOURS, AGREEMENT_TOLERANCE, GROUND_ROWS};
use crate::eval::heldout::{
    horizontal_share, neighbour_pairs, pooled_agreement, view_errors, HeldoutScores,
};
use crate::eval::metrics::has_depth;
use crate::io::dense::read_normal_map_path;
use crate::io::output_stem;
use crate::io::pfm::read_pfm_path;

/// Options of `planemap diag heldout`.
#[derive(Debug, Clone, clap::Args)]
pub struct HeldoutArgs {
    /// The real set: a folder with sparse/, images/ and heldout.json.
    pub set: PathBuf,
    /// Run output folders (or folders of NAME.pfm depth maps) to score.
    #[arg(required = true)]
    pub runs: Vec<PathBuf>,
    /// Print every view, not only the totals.
    #[arg(long)]
    pub per_view: bool,
}

/// Runs the audit.
pub fn run(args: &HeldoutArgs) -> DiagResult {
    let set = load_real_set(&args.set)?;
    let scene = &set.scene;
    let up = crate::sky::scene_vertical(&scene.views);
    let pairs = neighbour_pairs(scene, AGREEMENT_NEIGHBOURS);
    for run in &args.runs {
        let depth_dir = if run.join("depth").is_dir() {
            run.join("depth")
        } else {
            run.clone()
        };
        let mut depths: Vec<Option<Vec<f32>>> = vec![None; scene.views.len()];
        let mut all = Vec::new();
        let (mut with, mut total) = (0usize, 0usize);
        let (mut horizontal, mut normals) = (0u64, 0u64);
        println!("{}", run.display());
        for (i, view) in scene.views.iter().enumerate() {
            let path = depth_dir.join(format!("{}.pfm", output_stem(&view.name)));
            if !path.exists() {
                continue;
            }
            let map = read_pfm_path(&path)?;
            if (map.width, map.height) != (view.camera.width, view.camera.height) {
                return Err(format!(
                    "{}: {}×{} but view {} is {}×{}",
                    path.display(),
                    map.width,
                    map.height,
                    view.name,
                    view.camera.width,
                    view.camera.height
                )
                .into());
            }
            let e = view_errors(view, &map.data, &set.observations[i]);
            if args.per_view {
                let s = HeldoutScores::from_errors(&e);
                println!(
                    "  {:<16} {:4} obs  within 1/2/5 %: {:5.1} {:5.1} {:5.1}",
                    view.name,
                    s.observations,
                    100.0 * s.share(0),
                    100.0 * s.share(1),
                    100.0 * s.share(2)
                );
            }
            all.extend(e);
            with += map.data.iter().filter(|&&z| has_depth(z)).count();
            total += map.data.len();
            let normal_path = run
                .join("stereo")
                .join("normal_maps")
                .join(format!("{}.geometric.bin", view.name));
            if let (Some(up), Ok(n)) = (&up, read_normal_map_path(&normal_path)) {
                let cam: Vec<[f32; 3]> =
                    n.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
                if cam.len() == map.data.len() {
                    let (h, t) = horizontal_share(view, &cam, up, GROUND_ROWS);
                    horizontal += h;
                    normals += t;
                }
            }
            depths[i] = Some(map.data);
        }
        if all.is_empty() {
            println!("  no depth map of a view with held-out observations");
            continue;
        }
        let s = HeldoutScores::from_errors(&all);
        let maps: Vec<Option<&[f32]>> = depths.iter().map(|d| d.as_deref()).collect();
        let a = pooled_agreement(scene, &pairs, &maps, AGREEMENT_TOLERANCE);
        println!(
            "  held-out: {} observations, within 1/2/5 %: {:.1} / {:.1} / {:.1}, median {}; \
             coverage {:.1} %; agreement {} ({} pixels)",
            s.observations,
            100.0 * s.share(0),
            100.0 * s.share(1),
            100.0 * s.share(2),
            s.median_error
                .map_or("–".into(), |m| format!("{:.2} %", 100.0 * m)),
            100.0 * with as f64 / total.max(1) as f64,
            if a.overlap > 0 {
                format!("{:.1} %", 100.0 * a.share())
            } else {
                "– (no neighbouring pair scored)".into()
            },
            a.overlap
        );
        if normals > 0 {
            println!(
                "  bottom {:.0} % of rows labelled horizontal: {:.1} %",
                100.0 * GROUND_ROWS,
                100.0 * horizontal as f64 / normals as f64
            );
        }
    }
    Ok(())
}
