//! The `planemap` command line: parses arguments, builds a config, calls the library, prints
//! a summary. All work happens in the library (`planemap::pipeline`, `planemap::synth`, …).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use planemap::pipeline::{self, Config, RunOptions};
use planemap::progress::Progress;

/// Piecewise-planar multi-view stereo for buildings: planemaps, depth and normal maps, planes
/// and planar meshes from calibrated photographs.
#[derive(Parser)]
#[command(name = "planemap", version, about, long_about = None)]
#[command(after_help = "Examples:
  planemap demo                                  render the built-in demo scene and reconstruct it
  planemap synth scenes/room.toml -o room        render a synthetic scene with ground truth
  planemap info room/sparse --images room/images summarise a COLMAP model and check it
")]
struct Cli {
    /// No progress bars or log lines.
    #[arg(short, long, global = true)]
    quiet: bool,
    /// Explain more (repeat for debug output).
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    verbose: u8,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a synthetic scene (TOML) into a COLMAP-style workspace with ground truth.
    #[command(
        after_help = "Example:\n  planemap synth scenes/room.toml -o out/room --width 640 --height 480"
    )]
    Synth(SynthArgs),
    /// Summarise a COLMAP sparse model and warn about problems.
    #[command(after_help = "Example:\n  planemap info out/room/sparse --images out/room/images")]
    Info(InfoArgs),
    /// Reconstruct planemaps, depth/normal maps, planes and fused points from a COLMAP
    /// model (or a PMVS workspace).
    #[command(after_help = "Examples:
  planemap run --model ws/sparse --images ws/images -o out
  planemap run --pmvs ws/pmvs -o out --config my.toml --set planemap.lambda=0.5
  planemap run --model ws/sparse --images ws/images -o out --views 0,3 --resume")]
    Run(RunArgs),
    /// Render the embedded demo scene into ./planemap-demo/ and reconstruct it.
    Demo(DemoArgs),
    /// Baseline: plane-sweep stereo (winner takes all) per view, scored against ground truth
    /// on textured and on plain pixels.
    #[command(after_help = "Example:\n  planemap sweep --model ws/sparse -o ws/sweep")]
    Sweep(SweepArgs),
}

#[derive(Args)]
struct SweepArgs {
    /// COLMAP sparse model directory.
    #[arg(long)]
    model: PathBuf,
    /// Images directory (default: ../images beside the model).
    #[arg(long)]
    images: Option<PathBuf>,
    /// Output directory (depth/NAME.pfm; NaN = no depth).
    #[arg(short, long)]
    output: PathBuf,
    /// Only these views (comma-separated indices).
    #[arg(long, value_delimiter = ',')]
    views: Option<Vec<usize>>,
    /// Ground truth directory (default: ../gt beside the model, if present).
    #[arg(long)]
    gt: Option<PathBuf>,
    /// Setting overrides `key=value` of the sweep baseline config (TOML values), e.g.
    /// `--set sweep.photo.window_radius=5 --set axis_families=false`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
}

#[derive(Args)]
struct RunArgs {
    /// COLMAP sparse model directory (text or binary).
    #[arg(long, conflicts_with = "pmvs", required_unless_present = "pmvs")]
    model: Option<PathBuf>,
    /// Images directory of the COLMAP model.
    #[arg(long, requires = "model")]
    images: Option<PathBuf>,
    /// A PMVS workspace (txt/, models/*.patch, visualize/) instead of a COLMAP model.
    #[arg(long)]
    pmvs: Option<PathBuf>,
    /// Output directory.
    #[arg(short, long)]
    output: PathBuf,
    /// Configuration file (TOML; sections normals, axes, hypotheses, planemap, solver,
    /// fusion).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Override a config value, e.g. --set planemap.lambda=0.5 (repeatable).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    overrides: Vec<String>,
    /// Only these views (comma-separated indices in image-id order).
    #[arg(long, value_delimiter = ',')]
    views: Option<Vec<usize>>,
    /// Skip views whose outputs already exist.
    #[arg(long)]
    resume: bool,
    /// Ground truth directory to score against (default: ../gt beside the model, if present).
    #[arg(long)]
    gt: Option<PathBuf>,
}

#[derive(Args)]
struct SynthArgs {
    /// Scene description (TOML; see scenes/README.md).
    scene: PathBuf,
    /// Output directory (created; existing files of the same names are replaced).
    #[arg(short, long)]
    output: PathBuf,
    /// Override the image width (intrinsics scale with it).
    #[arg(long)]
    width: Option<u32>,
    /// Override the image height.
    #[arg(long)]
    height: Option<u32>,
    /// Override the scene's random seed.
    #[arg(long)]
    seed: Option<u64>,
}

#[derive(Args)]
struct InfoArgs {
    /// A COLMAP model directory (cameras/images/points3D .bin or .txt), or a workspace
    /// holding sparse/.
    model: PathBuf,
    /// The images directory, to check that images exist and match their cameras.
    #[arg(long)]
    images: Option<PathBuf>,
}

#[derive(Args)]
struct DemoArgs {
    /// Output directory.
    #[arg(short, long, default_value = "planemap-demo")]
    output: PathBuf,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(cli.quiet, cli.verbose);
    let progress = Progress::new(cli.quiet);
    let result = match cli.command {
        Command::Synth(a) => synth(a, &progress),
        Command::Info(a) => info(a),
        Command::Run(a) => run(a, &progress),
        Command::Demo(a) => demo(a, &progress),
        Command::Sweep(a) => sweep(a, &progress),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn init_logging(quiet: bool, verbose: u8) {
    let level = match (quiet, verbose) {
        (true, _) => "error",
        (false, 0) => "warn",
        (false, 1) => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_env("PLANEMAP_LOG")
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}

fn synth(a: SynthArgs, progress: &Progress) -> Result<()> {
    let spec = planemap::synth::SceneSpec::from_path(&a.scene)?;
    let opts = planemap::synth::RenderOptions {
        width: a.width,
        height: a.height,
        seed_override: a.seed,
    };
    let summary = planemap::workspace::render_to_workspace(&spec, &opts, &a.output, progress)
        .with_context(|| {
            format!(
                "rendering {} into {}",
                a.scene.display(),
                a.output.display()
            )
        })?;
    println!("{summary}");
    Ok(())
}

fn info(a: InfoArgs) -> Result<()> {
    let info = planemap::info::ModelInfo::from_dir(&a.model, a.images.as_deref())?;
    println!("{info}");
    Ok(())
}

fn run(a: RunArgs, progress: &Progress) -> Result<()> {
    let mut config = match &a.config {
        Some(p) => Config::from_path(p)?,
        None => Config::default(),
    };
    config = config.with_overrides(&a.overrides)?;
    let (scene, gt) = if let Some(pmvs) = &a.pmvs {
        let scene = planemap::io::pmvs::read_pmvs(pmvs)?;
        (scene, a.gt.clone().or_else(|| sibling_gt(pmvs)))
    } else {
        let model_dir = a.model.as_ref().context("--model or --pmvs is required")?;
        let model = planemap::io::colmap::read_model(model_dir)?;
        let images = a.images.clone().or_else(|| {
            model_dir
                .parent()
                .map(|p| p.join("images"))
                .filter(|p| p.is_dir())
        });
        let scene = model.to_scene(images.as_deref())?;
        (scene, a.gt.clone().or_else(|| sibling_gt(model_dir)))
    };
    let opts = RunOptions {
        views: a.views.clone(),
        resume: a.resume,
    };
    reconstruct(&scene, &config, &a.output, &opts, gt.as_deref(), progress)
}

/// `DIR/../gt` for a model or workspace at `DIR`, if it exists.
fn sibling_gt(dir: &std::path::Path) -> Option<PathBuf> {
    let gt = dir.parent()?.join("gt");
    gt.join("planes.json").is_file().then_some(gt)
}

fn reconstruct(
    scene: &planemap::Scene,
    config: &Config,
    out: &std::path::Path,
    opts: &RunOptions,
    gt: Option<&std::path::Path>,
    progress: &Progress,
) -> Result<()> {
    let (prepared, views, summary) = pipeline::run(scene, config, out, opts, progress)
        .with_context(|| format!("reconstructing into {}", out.display()))?;
    println!(
        "R = {:.4}; {} dominant directions (angles: {}); {} plane hypotheses",
        summary.scale,
        summary.directions.len(),
        summary
            .direction_angles_deg
            .iter()
            .map(|(i, j, a)| format!("d{}-d{} {:.1}°", i + 1, j + 1, a))
            .collect::<Vec<_>>()
            .join(", "),
        summary.hypotheses
    );
    let [t_n, t_a, t_h, t_v, t_f] = summary.stage_seconds;
    println!(
        "time: normals {t_n:.2} s, axes {t_a:.2} s, hypotheses {t_h:.2} s, planemaps {t_v:.2} s ({} views), fusion {t_f:.2} s",
        summary.views.len()
    );
    println!(
        "wrote {} planemaps, depth and normal maps, planes.json, fused.ply ({} points) to {}",
        summary.views.len(),
        summary.fused_points,
        out.display()
    );
    if let Some(gt) = gt {
        let undistorted = scene.undistorted();
        let report = planemap::eval::evaluate(
            gt,
            &undistorted,
            &prepared.hypotheses,
            &views,
            &planemap::eval::EvalConfig::default(),
        )?;
        println!(
            "against ground truth ({}): depth within 1%: {:.1}% of pixels; plane labels correct: {:.1}% of planar pixels",
            gt.display(),
            100.0 * report.total.depth_accuracy(),
            100.0 * report.total.plane_accuracy()
        );
    }
    Ok(())
}

fn demo(a: DemoArgs, progress: &Progress) -> Result<()> {
    let spec = planemap::workspace::demo_spec()?;
    let opts = planemap::synth::RenderOptions::default();
    let summary = planemap::workspace::render_to_workspace(&spec, &opts, &a.output, progress)?;
    println!("{summary}");
    let model = planemap::io::colmap::read_model(&a.output.join("sparse"))?;
    let scene = model.to_scene(Some(&a.output.join("images")))?;
    reconstruct(
        &scene,
        &Config::default(),
        &a.output.join("reconstruction"),
        &RunOptions::default(),
        Some(&a.output.join("gt")),
        progress,
    )
}

fn sweep(a: SweepArgs, progress: &Progress) -> Result<()> {
    use planemap::baseline::{
        scene_axes, split_scores, sweep_view_with_axes, texture_mask, SplitScores,
    };
    let model = planemap::io::colmap::read_model(&a.model)?;
    let images = a.images.clone().or_else(|| {
        a.model
            .parent()
            .map(|p| p.join("images"))
            .filter(|p| p.is_dir())
    });
    let scene = model.to_scene(images.as_deref())?.undistorted();
    let gt = a.gt.clone().or_else(|| sibling_gt(&a.model));
    let cfg = planemap::baseline::SweepBaselineConfig::default().with_overrides(&a.set)?;
    let axes = if cfg.axis_families {
        scene_axes(&scene)
    } else {
        Vec::new()
    };
    let all: Vec<planemap::ImageF32> = scene
        .views
        .iter()
        .map(|v| v.load_undistorted_image())
        .collect::<Result<_, _>>()?;
    let indices = a
        .views
        .clone()
        .unwrap_or_else(|| (0..scene.views.len()).collect());
    std::fs::create_dir_all(a.output.join("depth"))?;
    let bar = progress.bar(indices.len() as u64, "plane sweep");
    let mut total = SplitScores::default();
    for &i in &indices {
        let view = scene
            .views
            .get(i)
            .with_context(|| format!("view index {i} out of range"))?;
        let result = sweep_view_with_axes(&scene, &all, i, &axes, &cfg)?;
        let stem = planemap::pipeline::output_stem(&view.name);
        let depth = planemap::ImageF32 {
            width: view.camera.width,
            height: view.camera.height,
            channels: 1,
            data: result.depth.clone(),
        };
        planemap::io::pfm::write_pfm_path(
            &a.output.join("depth").join(format!("{stem}.pfm")),
            &depth,
        )?;
        if let Some(gt) = &gt {
            let gt_depth =
                planemap::io::pfm::read_pfm_path(&gt.join("depth").join(format!("{stem}.pfm")))?;
            let mask = texture_mask(&all[i], 3, 0.02);
            total.add(&split_scores(&result.depth, &gt_depth.data, &mask, 0.01));
        }
        bar.inc(1);
    }
    bar.finish();
    println!(
        "plane sweep: {} views written to {}",
        indices.len(),
        a.output.display()
    );
    if gt.is_some() {
        println!(
            "depth within 1%: textured pixels {:.1}% (of {}), plain pixels {:.1}% (of {})",
            100.0 * total.textured_accuracy(),
            total.textured,
            100.0 * total.plain_accuracy(),
            total.plain
        );
    }
    Ok(())
}
