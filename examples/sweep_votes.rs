//! Where does the photo-consistency sweep vote? Runs the pipeline's sparse stages and
//! [`planemap::hypotheses::sweep_hypotheses`] on a workspace and prints, per axis, the bin
//! step, the sub-planes per bin and every bin with at least 20 votes (offset, votes, views
//! voting), then the hypotheses it proposes.
//!
//! ```sh
//! cargo run --release --example sweep_votes -- WORKSPACE [section.key=value ...]
//! ```
use std::path::PathBuf;

use planemap::io::colmap::read_model;
use planemap::pipeline::{sparse_stages, Config};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let ws = PathBuf::from(
        std::env::args()
            .nth(1)
            .ok_or("usage: sweep_votes WS [key=value]")?,
    );
    let overrides: Vec<String> = std::env::args().skip(2).collect();
    let cfg = Config::default().with_overrides(&overrides)?;
    let scene = read_model(&ws.join("sparse"))?
        .to_scene(Some(&ws.join("images")))?
        .undistorted();
    let images: Vec<_> = scene
        .views
        .iter()
        .map(|v| v.load_undistorted_image())
        .collect::<Result<_, _>>()?;
    let s = sparse_stages(&scene, &cfg)?;
    let input = planemap::hypotheses::HypothesesInput {
        positions: &scene.cloud.positions,
        normals: &s.oriented.normals,
        confidence: &s.oriented.confidence,
        axes: &s.axes,
        scale: s.scale,
    };
    let (extra, votes) = planemap::hypotheses::sweep_hypotheses(
        &scene,
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
            if *n >= 20 {
                println!("  {o:8.3} {n:6} {v}");
            }
        }
    }
    for h in extra {
        println!("hyp axis {:?} offset {:.3}", h.axis, h.plane.offset);
    }
    Ok(())
}
