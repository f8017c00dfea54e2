//! Where does the photo-consistency sweep vote? Runs the pipeline's sparse stages and
//! [`crate::hypotheses::sweep_hypotheses`] on a workspace and prints, per axis, the bin
//! step, the sub-planes per bin and every bin with at least `--min-votes` votes (offset,
//! votes, views voting), then the hypotheses it proposes.

use std::path::PathBuf;

use super::{DiagResult, Workspace};
use crate::pipeline::{sparse_stages, Config};

/// Options of `planemap diag votes`.
#[derive(Debug, Clone, clap::Args)]
pub struct VotesArgs {
    /// A `planemap synth` workspace (sparse/, images/).
    pub workspace: PathBuf,
    /// Override a planemap config value (repeatable), e.g. --set hypotheses.sweep.step_r=2
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub overrides: Vec<String>,
    /// Print the bins with at least this many votes.
    #[arg(long, default_value_t = 20)]
    pub min_votes: u32,
}

/// Runs the audit.
pub fn run(args: &VotesArgs) -> DiagResult {
    let cfg = crate::config::with_overrides(&Config::default(), &args.overrides)?;
    let ws = Workspace::open(&args.workspace)?;
    let scene = &ws.scene;
    let images = ws.images()?;
    let s = sparse_stages(scene, &cfg)?;
    let input = s.input(scene);
    let (extra, votes) = crate::hypotheses::sweep_hypotheses(
        scene,
        &images,
        &input,
        &s.hypotheses,
        &cfg.hypotheses,
    )?;
    for (k, bins) in votes.bins.iter().enumerate() {
        let d = s.axes.directions[k];
        println!(
            "axis {k} ({:.3}, {:.3}, {:.3}): step {:.4}, {} sub-planes per bin",
            d.x, d.y, d.z, votes.step[k], votes.sub_planes[k]
        );
        for (o, n, v) in bins {
            if *n >= args.min_votes {
                println!("  {o:8.3} {n:6} {v}");
            }
        }
    }
    for h in extra {
        println!("hyp axis {:?} offset {:.3}", h.axis, h.plane.offset);
    }
    Ok(())
}
