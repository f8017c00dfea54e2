//! Runs planemap's stages one by one on a COLMAP model, as a library user would.
//!
//! ```sh
//! cargo run --release --example reconstruct -- WORKSPACE/sparse WORKSPACE/images OUT
//! ```
//!
//! The same chain `planemap run` executes, spelled out: load → undistort → global stages
//! (scale, normals, dominant axes, plane hypotheses) → one planemap per view → outputs.

use std::path::PathBuf;

use planemap::io::colmap::read_model;
use planemap::pipeline::{self, Config};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<PathBuf> = std::env::args_os().skip(1).map(PathBuf::from).collect();
    let [model_dir, images_dir, out] = args.as_slice() else {
        eprintln!("usage: reconstruct MODEL_DIR IMAGES_DIR OUT_DIR");
        std::process::exit(2);
    };
    // 1. The scene: views (cameras, cam_from_world poses, image paths) and sparse points.
    let scene = read_model(model_dir)?
        .to_scene(Some(images_dir))?
        .undistorted();
    println!(
        "{} views, {} sparse points",
        scene.views.len(),
        scene.cloud.len()
    );

    // 2. Global stages: sampling scale R, normals, dominant axes, plane hypotheses.
    let config = Config::default();
    let prepared = pipeline::prepare(&scene, &config)?;
    println!(
        "R = {:.4}, {} dominant directions, {} plane hypotheses",
        prepared.scale,
        prepared.axes.directions.len(),
        prepared.hypotheses.len()
    );
    for h in &prepared.hypotheses {
        println!(
            "  plane {}: n = ({:.3}, {:.3}, {:.3}), d = {:.3}, support {}",
            h.id, h.plane.normal.x, h.plane.normal.y, h.plane.normal.z, h.plane.offset, h.support
        );
    }

    // 3. One planemap per view: α-expansion on the visibility-conflict energy.
    std::fs::create_dir_all(out)?;
    for index in 0..scene.views.len() {
        let image = scene.views[index].load_undistorted_image()?;
        let result = pipeline::label_view(&scene, &prepared, index, &image, &config)?;
        pipeline::write_view_outputs(out, &scene, &result)?;
        println!(
            "  {}: {} candidate planes, energy {:.1} → {:.1} in {} cycles",
            scene.views[index].name,
            result.candidate_labels,
            result.energy.0,
            result.energy.1,
            result.cycles
        );
    }
    println!(
        "planemaps, depth and normal maps written to {}",
        out.display()
    );
    Ok(())
}
