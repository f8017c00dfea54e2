//! The `planemap` command line: parses arguments, builds a config, calls the library, prints
//! a summary. All work happens in the library (`planemap::pipeline`, `planemap::synth`, …).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
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
    /// Render the embedded demo scene into ./planemap-demo/.
    Demo(DemoArgs),
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
        Command::Demo(a) => demo(a, &progress),
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

fn demo(a: DemoArgs, progress: &Progress) -> Result<()> {
    let spec = planemap::workspace::demo_spec()?;
    let opts = planemap::synth::RenderOptions::default();
    let summary = planemap::workspace::render_to_workspace(&spec, &opts, &a.output, progress)?;
    println!("{summary}");
    Ok(())
}
