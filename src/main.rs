//! The `planemap` command line: parses arguments, builds a config, calls the library, prints
//! a summary. All work happens in the library (`planemap::pipeline`, `planemap::synth`, …).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use planemap::pipeline::{self, Config, RunOptions};
use planemap::progress::Progress;

/// Piecewise-planar multi-view stereo for buildings: planemaps, depth and normal maps, planes
/// and fused points from calibrated photographs.
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
        after_help = "Examples:\n  planemap synth scenes/room.toml -o out/room --width 640 --height 480\n  planemap synth --generate plaza --seed 3 -o out/plaza-0003"
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
    /// Planar / non-planar classifier (Gallup et al. 2010): train on synthetic workspaces,
    /// score on held-out ones, write per-view planarity maps.
    #[command(subcommand)]
    Classify(ClassifyCommand),
    /// Benchmark: render synthetic scenes (cached), run planemap and the baselines on each,
    /// score them against ground truth; writes results.json, results.md and PNG charts.
    #[command(after_help = "Examples:
  planemap bench scenes/ -o bench-out
  planemap bench scenes/ -o bench-out --methods planemap,sweep --scenes room,hard --size small")]
    Bench(BenchArgs),
    /// The configuration: print the defaults with each key's meaning, unit and range.
    #[command(after_help = "Examples:
  planemap config --defaults > my.toml
  planemap config --check my.toml --set planemap.lambda=0.5")]
    Config(ConfigArgs),
    /// Audits on a synthetic workspace: why a result is what it is.
    #[command(subcommand)]
    Diag(DiagCommand),
}

#[derive(Subcommand)]
enum DiagCommand {
    /// planemap's labelling against the best ground-truth-correct labelling under the same
    /// energy, split into visibility, photo and smoothness.
    #[command(after_help = "Example:\n  planemap diag energy ws/room 0 5 --pairs 5 --maps maps/")]
    Energy(planemap::diag::energy::EnergyArgs),
    /// Existing runs scored on a real set's held-out points, agreement and ground.
    #[command(
        after_help = "Example:\n  planemap diag heldout ../shared/data/real/castle-P19 out/ sweep-out/depth --per-view"
    )]
    Heldout(planemap::diag::heldout::HeldoutArgs),
    /// Every offered label's visibility and photo costs at chosen pixels of a view.
    #[command(
        after_help = "Example:\n  planemap diag pixel ../shared/data/real/castle-P19 0 --pixel 100,480 --pixel 600,100"
    )]
    Pixel(planemap::diag::pixel::PixelArgs),
    /// The sky stage's mask against the ground truth: sky caught, surfaces taken for sky.
    #[command(
        after_help = "Example:\n  planemap diag sky ws/exterior ws/room --set sky.max_std=0.03"
    )]
    Sky(planemap::diag::sky::SkyArgs),
    /// Data costs of the non-planar label against the cheapest plane on non-planar pixels
    /// whose sweep depth is right.
    #[command(after_help = "Example:\n  planemap diag nonplanar ws/statues 2")]
    Nonplanar(planemap::diag::nonplanar::NonplanarArgs),
    /// The plane-sweep baseline's families and where its winner is wrong.
    #[command(after_help = "Example:\n  planemap diag sweep ws/stairs 3 --pixel 120,80")]
    Sweep(planemap::diag::sweep::SweepArgs),
    /// Segments, 3D lines and their accuracy against the ground truth, and the planes they
    /// propose.
    #[command(after_help = "Example:\n  planemap diag lines ws/street --per-view")]
    Lines(planemap::diag::lines::LinesArgs),
    /// Where the photo-consistency sweep for plane hypotheses votes.
    #[command(after_help = "Example:\n  planemap diag votes ws/stairs")]
    Votes(planemap::diag::votes::VotesArgs),
    /// Depth maps scored on planar and non-planar pixels, optionally split at a world box.
    #[command(
        after_help = "Example:\n  planemap diag score-split ws/courtyard/gt out/depth out/sweep --box -9,9.95,0,9,10.05,4"
    )]
    ScoreSplit(planemap::diag::split::SplitArgs),
}

#[derive(Args)]
struct ConfigArgs {
    /// Print the default configuration as TOML, each key with its meaning, unit and range.
    #[arg(long)]
    defaults: bool,
    /// Check a configuration file (and --set overrides) and print the effective configuration.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
    /// Override a value (repeatable), e.g. --set planemap.lambda=0.5
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    overrides: Vec<String>,
}

#[derive(Subcommand)]
enum ClassifyCommand {
    /// Train a model on synthetic workspaces' ground truth (gt/planes: 0 = non-planar).
    #[command(after_help = "Example:
  planemap classify train ws/train_park ws/train_street -o model.bin --method logistic")]
    Train(ClassifyTrainArgs),
    /// Precision / recall / F1 of \"non-planar\" on (held-out) synthetic workspaces.
    #[command(after_help = "Example:\n  planemap classify eval model.bin ws/courtyard ws/room")]
    Eval(ClassifyEvalArgs),
    /// Write a planarity map PNG per view (255 = planar, 0 = non-planar).
    #[command(after_help = "Example:
  planemap classify map default --images ws/images -o ws/planarity")]
    Map(ClassifyMapArgs),
}

#[derive(Args)]
struct ClassifyTrainArgs {
    /// Synthetic workspaces (from `planemap synth`) to train on.
    #[arg(required = true)]
    workspaces: Vec<PathBuf>,
    /// Output model file.
    #[arg(short, long)]
    output: PathBuf,
    /// Classifier: knn or logistic.
    #[arg(long, default_value = "logistic")]
    method: String,
    /// kNN: neighbours that vote.
    #[arg(long, default_value_t = 15)]
    k: u32,
    /// kNN: training vectors kept (even subsample).
    #[arg(long, default_value_t = 4000)]
    max_samples: u32,
    /// Logistic: L2 weight.
    #[arg(long, default_value_t = 1e-3)]
    l2: f64,
    /// Logistic: weight both classes equally.
    #[arg(long)]
    balance: bool,
    /// Decision threshold on P(non-planar).
    #[arg(long, default_value_t = 0.5)]
    threshold: f32,
}

#[derive(Args)]
struct ClassifyEvalArgs {
    /// Model file, or `default` for the model built into planemap.
    model: String,
    /// Synthetic workspaces to score on.
    #[arg(required = true)]
    workspaces: Vec<PathBuf>,
}

#[derive(Args)]
struct ClassifyMapArgs {
    /// Model file, or `default` for the model built into planemap.
    model: String,
    /// Images directory.
    #[arg(long)]
    images: PathBuf,
    /// COLMAP sparse model for the geometric cue (default: ../sparse beside the images, if
    /// present; without one every image in the directory is mapped from appearance alone).
    #[arg(long)]
    sparse: Option<PathBuf>,
    /// Output directory (NAME.png per view).
    #[arg(short, long)]
    output: PathBuf,
}

#[derive(Args)]
struct BenchArgs {
    /// Scene files or folders of *.toml (default: scenes/, unless --generated is given).
    scenes: Vec<PathBuf>,
    /// Generated scenes, KIND:COUNT[@FIRST_SEED] (repeatable or comma-separated): KIND
    /// interior, hall, street, pavilion, plaza or all; FIRST_SEED 0 by default. Seeds below
    /// 1000 develop, 1000–1999 are the test split, e.g. all:10@1000. Reported per kind under
    /// their own heading.
    #[arg(long, value_delimiter = ',', value_name = "KIND:COUNT[@FIRST_SEED]")]
    generated: Vec<String>,
    /// Real photograph sets (repeatable or comma-separated): folders with sparse/, images/
    /// and heldout.json, scored on their held-out points (real.md, real.json and picture
    /// sheets under real/). Alone, they are all that runs.
    #[arg(long, value_delimiter = ',', value_name = "DIR")]
    real: Vec<PathBuf>,
    /// Keep the run: results.md, results.json and a README (date, commit, command, machine)
    /// under RESULTS_DIR/DATE-COMMIT/ (real sets alone: real.md and real.json under
    /// RESULTS_DIR/DATE-COMMIT-real/), and update README.md's results table (between its
    /// markers) when run from the project's folder.
    #[arg(long)]
    record: bool,
    /// Where --record keeps runs.
    #[arg(long, default_value = "docs/results")]
    results_dir: PathBuf,
    /// Output directory.
    #[arg(short, long, default_value = "bench-out")]
    output: PathBuf,
    /// Methods (comma-separated): planemap, planemap-vis, planemap-nolines, planemap-cls, sweep, delaunay, or all
    /// (default: planemap, sweep, delaunay).
    #[arg(long, value_delimiter = ',')]
    methods: Option<Vec<String>>,
    /// Only scenes with these names, file stems or categories (comma-separated).
    #[arg(long = "scenes", value_delimiter = ',')]
    scene_filter: Option<Vec<String>>,
    /// Image size: tiny (96x72), small (160x120), default (each scene's own), large
    /// (640x480), stress (1280x960) or WxH.
    #[arg(long, default_value = "default")]
    size: String,
    /// Cache of rendered scenes (default: OUTPUT/cache).
    #[arg(long)]
    cache: Option<PathBuf>,
    /// planemap configuration file (TOML), for the planemap methods.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Override a planemap config value (repeatable), e.g. --set planemap.lambda=0.5.
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    overrides: Vec<String>,
    /// Do not write per-view error maps.
    #[arg(long)]
    no_maps: bool,
    /// Planes of the plane-sweep baseline (the baseline's own default is 128).
    #[arg(long, default_value_t = planemap::bench::BENCH_SWEEP_PLANES)]
    sweep_planes: usize,
    /// Neighbour views of the plane-sweep baseline (its own default is 4).
    #[arg(long, default_value_t = planemap::bench::BENCH_SWEEP_NEIGHBOURS)]
    sweep_neighbours: usize,
}

#[derive(Args)]
struct SweepArgs {
    /// COLMAP sparse model directory.
    #[arg(long)]
    model: PathBuf,
    /// Images directory (default: ../images beside the model).
    #[arg(long)]
    images: Option<PathBuf>,
    /// Output directory (depth/NAME.pfm; 0 = no depth).
    #[arg(short, long)]
    output: PathBuf,
    /// Only these views (comma-separated): indices in image-id order, or image names.
    #[arg(long, value_delimiter = ',')]
    views: Option<Vec<String>>,
    /// Ground truth directory (default: ../gt beside the model, if present).
    #[arg(long)]
    gt: Option<PathBuf>,
    /// Setting overrides `key=value` of the sweep baseline config (TOML values), e.g.
    /// `--set photo.window_radius=5 --set axis_families=false`.
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
    /// fusion, nonplanar; `planemap config --defaults` prints them all).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Override a config value, e.g. --set planemap.lambda=0.5 (repeatable).
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    overrides: Vec<String>,
    /// Only these views (comma-separated): indices in image-id order (not name order: after
    /// SfM the two often differ), or image names as in the model.
    #[arg(long, value_delimiter = ',')]
    views: Option<Vec<String>>,
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
    #[arg(required_unless_present = "generate", conflicts_with = "generate")]
    scene: Option<PathBuf>,
    /// Output directory (created; existing files of the same names are replaced).
    #[arg(short, long)]
    output: PathBuf,
    /// Draw a scene of this kind instead of reading one (interior, hall, street, pavilion,
    /// plaza) from --seed; it is also written to OUTPUT/scene.toml.
    #[arg(long, value_name = "KIND")]
    generate: Option<String>,
    /// Override the image width (intrinsics scale with it); with --generate, the generated
    /// scene's width (default 320).
    #[arg(long)]
    width: Option<u32>,
    /// Override the image height; with --generate, the generated scene's height (default
    /// 240, or 3/4 of --width).
    #[arg(long)]
    height: Option<u32>,
    /// Override the scene's random seed; with --generate, the generator's seed (default 0;
    /// seeds 1000–1999 are the held-out test split).
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
        Command::Classify(c) => classify(c, &progress),
        Command::Bench(a) => bench(a, &progress),
        Command::Config(a) => config(a),
        Command::Diag(d) => diag(d),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", error_chain(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes as one line, `outer: cause: root`, leaving out a cause whose
/// text the line already holds (our errors often print their source inside their own
/// message, and `{:#}` would then repeat it).
fn error_chain(e: &anyhow::Error) -> String {
    let mut line = e.to_string();
    for cause in e.chain().skip(1) {
        let text = cause.to_string();
        if !line.contains(&text) {
            line.push_str(": ");
            line.push_str(&text);
        }
    }
    line
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
    // Colour codes only on a terminal: logs redirected to a file stay plain text.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
}

fn synth(a: SynthArgs, progress: &Progress) -> Result<()> {
    if let Some(kind) = &a.generate {
        return synth_generated(kind, &a, progress);
    }
    let scene = a
        .scene
        .as_ref()
        .context("a scene file or --generate is required")?;
    let spec = planemap::synth::SceneSpec::from_path(scene)?;
    let opts = planemap::synth::RenderOptions {
        width: a.width,
        height: a.height,
        seed_override: a.seed,
    };
    let summary = planemap::workspace::render_to_workspace(&spec, &opts, &a.output, progress)
        .with_context(|| format!("rendering {} into {}", scene.display(), a.output.display()))?;
    println!("{summary}");
    Ok(())
}

/// `synth --generate KIND`: draws the scene, writes OUTPUT/scene.toml, renders it as
/// `synth OUTPUT/scene.toml` would.
fn synth_generated(kind: &str, a: &SynthArgs, progress: &Progress) -> Result<()> {
    use planemap::synth::generate::{generate, split, GenerateOptions, Kind};
    let kind = Kind::from_name(kind).with_context(|| {
        let names: Vec<&str> = Kind::ALL.iter().map(|k| k.name()).collect();
        format!(
            "unknown kind {kind:?}; expected one of {}",
            names.join(", ")
        )
    })?;
    let seed = a.seed.unwrap_or(0);
    let width = a.width.unwrap_or(320);
    let opts = GenerateOptions {
        width,
        height: a.height.unwrap_or(if a.width.is_some() {
            width * 3 / 4
        } else {
            240
        }),
    };
    let generated = generate(kind, seed, &opts)?;
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("creating {}", a.output.display()))?;
    let toml_path = a.output.join("scene.toml");
    generated.write_toml(&toml_path)?;
    let summary = planemap::workspace::render_to_workspace(
        &generated.spec,
        &planemap::synth::RenderOptions::default(),
        &a.output,
        progress,
    )
    .with_context(|| {
        format!(
            "rendering {} into {}",
            generated.spec.name,
            a.output.display()
        )
    })?;
    println!("{summary}");
    println!(
        "  generated {kind} seed {seed} ({} split): {}\n  scene written to {}",
        split(seed),
        generated.spec.description,
        toml_path.display()
    );
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
    config = planemap::config::with_overrides(&config, &a.overrides)?;
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
        views: a
            .views
            .as_deref()
            .map(|v| view_indices(&scene, v))
            .transpose()?,
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
        "R = {:.4}; {} dominant directions (angles: {}); {} plane hypotheses ({} of them crease hypotheses)",
        summary.scale,
        summary.directions.len(),
        summary
            .direction_angles_deg
            .iter()
            .map(|(i, j, a)| format!("d{}-d{} {:.1}°", i + 1, j + 1, a))
            .collect::<Vec<_>>()
            .join(", "),
        summary.hypotheses,
        summary.crease_hypotheses
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
    use planemap::baselines::{scene_axes, sweep_view_with_axes};
    use planemap::eval::split::{texture_scores, SplitScores, TextureScores};
    let model = planemap::io::colmap::read_model(&a.model)?;
    let images = a.images.clone().or_else(|| {
        a.model
            .parent()
            .map(|p| p.join("images"))
            .filter(|p| p.is_dir())
    });
    let scene = model.to_scene(images.as_deref())?.undistorted();
    let gt = a.gt.clone().or_else(|| sibling_gt(&a.model));
    let cfg =
        planemap::config::with_overrides(&planemap::photo::MultiSweepConfig::default(), &a.set)?;
    cfg.validate()?;
    let axes = if cfg.axis_families {
        scene_axes(&scene, &cfg)
    } else {
        Vec::new()
    };
    let all: Vec<planemap::ImageF32> = scene
        .views
        .iter()
        .map(|v| v.load_undistorted_image())
        .collect::<Result<_, _>>()?;
    let indices = match &a.views {
        Some(v) => view_indices(&scene, v)?,
        None => (0..scene.views.len()).collect(),
    };
    planemap::io::check_image_names(scene.views.iter().map(|v| v.name.as_str()))?;
    // Every view's ground-truth depth, read once: the swept views are scored against their
    // own, and the covisible-surface figure needs the others' (stereo cannot measure what
    // only one view sees).
    let gt_depths: Vec<Vec<f32>> = match &gt {
        Some(gt) => scene
            .views
            .iter()
            .map(|v| {
                let stem = planemap::io::output_stem(&v.name);
                planemap::io::pfm::read_pfm_path(&gt.join("depth").join(format!("{stem}.pfm")))
                    .map(|d| d.data)
            })
            .collect::<Result<_, _>>()?,
        None => Vec::new(),
    };
    let all_gt: Vec<&[f32]> = gt_depths.iter().map(|d| d.as_slice()).collect();
    std::fs::create_dir_all(a.output.join("depth"))?;
    let bar = progress.bar(indices.len() as u64, "plane sweep");
    let mut total = TextureScores::default();
    for &i in &indices {
        let view = &scene.views[i];
        let result = sweep_view_with_axes(&scene, &all, i, &axes, &cfg)?;
        // 0 marks "no depth" in every depth map planemap writes (the sweep's NaN).
        let depth = planemap::ImageF32 {
            width: view.camera.width,
            height: view.camera.height,
            channels: 1,
            data: result
                .depth
                .iter()
                .map(|&z| if z.is_finite() && z > 0.0 { z } else { 0.0 })
                .collect(),
        };
        planemap::io::pfm::write_pfm_path(
            &output_file(&a.output.join("depth"), &view.name, ".pfm")?,
            &depth,
        )?;
        if let Some(gt) = &gt {
            total.add(&texture_scores(
                &scene.views,
                &all_gt,
                i,
                &all[i],
                &result.depth,
                gt,
            )?);
        }
        bar.inc(1);
    }
    bar.finish();
    println!(
        "plane sweep: {} views written to {}",
        indices.len(),
        a.output.display()
    );
    let report = |what: &str, s: &SplitScores, source: &str| {
        println!(
            "depth within 1%: textured {what} {:.1}% (of {}), plain {what} {:.1}% (of {}) — {source}",
            100.0 * s.textured_accuracy(),
            s.textured,
            100.0 * s.plain_accuracy(),
            s.plain
        )
    };
    if gt.is_some() {
        report(
            "pixels",
            &total.image_texture,
            "texture read off the image (grey std over 7×7 ≥ 0.02)",
        );
    }
    if let Some(s) = &total.surfaces {
        report("surfaces", s, "the renderer's ground truth (gt/texture)");
    }
    if let Some(s) = &total.covisible_surfaces {
        report(
            "surfaces",
            s,
            "the same, where another view sees the surface unhidden (covisible)",
        );
    }
    Ok(())
}

fn load_classifier(name: &str) -> Result<planemap::classify::PlanarityModel> {
    if name == "default" {
        Ok(planemap::classify::default_model()?)
    } else {
        Ok(planemap::classify::read_model_path(std::path::Path::new(
            name,
        ))?)
    }
}

fn classify(c: ClassifyCommand, progress: &Progress) -> Result<()> {
    use planemap::classify::{self as cls, FeatureSpec, TrainConfig, TrainingSet};
    match c {
        ClassifyCommand::Train(a) => {
            let spec = FeatureSpec::default();
            let config = TrainConfig {
                method: a.method.parse()?,
                k: a.k,
                max_knn_samples: a.max_samples,
                logistic: cls::LogisticConfig {
                    l2: a.l2,
                    balance_classes: a.balance,
                    ..Default::default()
                },
                threshold: a.threshold,
            };
            let mut set = TrainingSet::default();
            let bar = progress.bar(a.workspaces.len() as u64, "features");
            for ws in &a.workspaces {
                set.extend(&cls::workspace_samples(ws, &spec)?);
                bar.inc(1);
            }
            bar.finish();
            let model = cls::train(&set, spec, &config)?;
            cls::write_model_path(&a.output, &model)?;
            let size = std::fs::metadata(&a.output)?.len();
            println!(
                "trained {} on {} cells ({} non-planar) from {} workspaces → {} ({size} bytes)",
                a.method,
                set.len(),
                set.nonplanar(),
                a.workspaces.len(),
                a.output.display()
            );
        }
        ClassifyCommand::Eval(a) => {
            let model = load_classifier(&a.model)?;
            println!(
                "{:<28} {:>6} {:>9} {:>9} {:>9} {:>9} {:>12}",
                "workspace", "unit", "nonplanar", "precision", "recall", "F1", "planar kept"
            );
            let mut total = cls::dataset::WorkspaceScores::default();
            for ws in &a.workspaces {
                let s = cls::evaluate_workspace(&model, ws)?;
                total.cells.merge(&s.cells);
                total.pixels.merge(&s.pixels);
                print_scores(&ws.display().to_string(), &s);
            }
            if a.workspaces.len() > 1 {
                print_scores("all", &total);
            }
        }
        ClassifyCommand::Map(a) => {
            let model = load_classifier(&a.model)?;
            std::fs::create_dir_all(&a.output)?;
            let sparse = a.sparse.clone().or_else(|| {
                a.images
                    .parent()
                    .map(|p| p.join("sparse"))
                    .filter(|p| p.is_dir())
            });
            let mut written = 0usize;
            if let Some(sparse) = sparse {
                let scene = planemap::io::colmap::read_model(&sparse)?.to_scene(Some(&a.images))?;
                planemap::io::check_image_names(scene.views.iter().map(|v| v.name.as_str()))?;
                let bar = progress.bar(scene.views.len() as u64, "planarity maps");
                for (i, view) in scene.views.iter().enumerate() {
                    let image = view.load_image()?;
                    let points = cls::ViewPoints::from_scene(&scene, i);
                    let map = model.planarity_map(&image, Some(&points))?;
                    map.write_png(&output_file(&a.output, &view.name, ".png")?)?;
                    written += 1;
                    bar.inc(1);
                }
                bar.finish();
            } else {
                let mut files: Vec<PathBuf> = std::fs::read_dir(&a.images)
                    .with_context(|| format!("reading {}", a.images.display()))?
                    .filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| {
                        p.extension().is_some_and(|x| {
                            let x = x.to_string_lossy().to_ascii_lowercase();
                            x == "png" || x == "jpg" || x == "jpeg"
                        })
                    })
                    .collect();
                files.sort();
                for f in &files {
                    // Format from the content, size checked before decoding.
                    let image = planemap::scene::load_image_file(f, None)?;
                    let map = model.planarity_map(&image, None)?;
                    let name = f.file_name().unwrap_or_default().to_string_lossy();
                    map.write_png(&output_file(&a.output, &name, ".png")?)?;
                    written += 1;
                }
            }
            println!("wrote {written} planarity maps to {}", a.output.display());
        }
    }
    Ok(())
}

fn print_scores(name: &str, s: &planemap::classify::dataset::WorkspaceScores) {
    for (unit, c) in [("cells", &s.cells), ("pixels", &s.pixels)] {
        println!(
            "{:<28} {:>6} {:>9} {:>8.1}% {:>8.1}% {:>8.1}% {:>11.1}%",
            name,
            unit,
            c.true_positive + c.false_negative,
            100.0 * c.precision(),
            100.0 * c.recall(),
            100.0 * c.f1(),
            100.0 * c.specificity()
        );
    }
}

fn bench(a: BenchArgs, progress: &Progress) -> Result<()> {
    use planemap::bench::{
        collect_scene_files, parse_generated, parse_size, run_bench, BenchConfig, Method,
    };
    let mut cfg = BenchConfig::default();
    if let Some(m) = &a.methods {
        cfg.methods = if m.iter().any(|s| s == "all") {
            Method::ALL.to_vec()
        } else {
            m.iter()
                .map(|s| Method::from_name(s))
                .collect::<Result<_, _>>()?
        };
    }
    cfg.size = parse_size(&a.size)?;
    cfg.scene_filter = a.scene_filter.clone().unwrap_or_default();
    cfg.generated = a
        .generated
        .iter()
        .map(|g| parse_generated(g))
        .collect::<Result<_, _>>()?;
    cfg.cache_dir = a.cache.clone();
    cfg.error_maps = !a.no_maps;
    cfg.sweep.planes = a.sweep_planes;
    cfg.sweep.photo.neighbours = a.sweep_neighbours;
    let config = match &a.config {
        Some(p) => Config::from_path(p)?,
        None => Config::default(),
    };
    cfg.planemap = planemap::config::with_overrides(&config, &a.overrides)?;
    if !a.real.is_empty() && a.scenes.is_empty() && cfg.generated.is_empty() {
        let results = planemap::bench::real::run_real_bench(&a.real, &cfg, &a.output, progress)?;
        println!("{}", planemap::bench::real::real_markdown(&results));
        println!(
            "wrote real.json, real.md and picture sheets under real/ to {}",
            a.output.display()
        );
        if a.record {
            use planemap::bench::record::{record_real, update_readme_real, RunInfo};
            let command: Vec<String> = std::env::args().collect();
            let info = RunInfo::now(command.join(" "));
            let dir = record_real(&results, &a.output, &a.results_dir, &info)?;
            println!("recorded the run in {}", dir.display());
            let link = dir.to_string_lossy().replace('\\', "/");
            if update_readme_real(std::path::Path::new("README.md"), &results, &info, &link)? {
                println!("updated the real-photograph table of README.md");
            }
        }
        return Ok(());
    }
    // Generated scenes alone when no scene path is given with them.
    let scenes = if a.scenes.is_empty() && cfg.generated.is_empty() {
        vec![PathBuf::from("scenes")]
    } else {
        a.scenes.clone()
    };
    let files = collect_scene_files(&scenes)?;
    let results = run_bench(&files, &cfg, &a.output, progress)?;
    println!("{}", planemap::bench::markdown(&results));
    if !a.real.is_empty() {
        let real = planemap::bench::real::run_real_bench(&a.real, &cfg, &a.output, progress)?;
        println!("{}", planemap::bench::real::real_markdown(&real));
    }
    println!(
        "wrote results.json, results.md, accuracy.png, time.png and maps/ to {}",
        a.output.display()
    );
    if a.record {
        let root = &a.results_dir;
        use planemap::bench::record::{record, update_readme, RunInfo};
        let command: Vec<String> = std::env::args().collect();
        let info = RunInfo::now(command.join(" "));
        let dir = record(&results, &a.output, root, &info)?;
        println!("recorded the run in {}", dir.display());
        let link = dir.to_string_lossy().replace('\\', "/");
        // README.md's table is the scene files': generated scenes stay in results.md.
        let files = results.subset(false);
        if files.scenes.is_empty() {
            println!("README.md's results table shows scene files: left as it is");
        } else if update_readme(std::path::Path::new("README.md"), &files, &info, &link)? {
            println!("updated the results table of README.md");
        }
    }
    Ok(())
}

fn config(a: ConfigArgs) -> Result<()> {
    let base = match &a.check {
        Some(p) => Config::from_path(p)?,
        None => Config::default(),
    };
    let cfg = planemap::config::with_overrides(&base, &a.overrides)?;
    cfg.validate()?;
    if a.defaults || a.check.is_some() || !a.overrides.is_empty() {
        print!("{}", cfg.describe()?);
    } else {
        anyhow::bail!("nothing to do: give --defaults, or --check FILE and/or --set");
    }
    Ok(())
}

fn diag(d: DiagCommand) -> Result<()> {
    use planemap::diag;
    let r = match d {
        DiagCommand::Energy(a) => diag::energy::run(&a),
        DiagCommand::Nonplanar(a) => diag::nonplanar::run(&a),
        DiagCommand::Sweep(a) => diag::sweep::run(&a),
        DiagCommand::Votes(a) => diag::votes::run(&a),
        DiagCommand::Lines(a) => diag::lines::run(&a),
        DiagCommand::ScoreSplit(a) => diag::split::run(&a),
        DiagCommand::Heldout(a) => diag::heldout::run(&a),
        DiagCommand::Sky(a) => diag::sky::run(&a),
        DiagCommand::Pixel(a) => diag::pixel::run(&a),
    };
    r.map_err(|e| anyhow::anyhow!(e))
}

/// `dir/STEM{suffix}` for an image name (its output stem keeps subfolders), with the folders
/// it needs created.
fn output_file(dir: &std::path::Path, image_name: &str, suffix: &str) -> Result<PathBuf> {
    let path = dir.join(format!("{}{suffix}", planemap::io::output_stem(image_name)));
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("creating {}", parent.display()))?;
    }
    Ok(path)
}

/// `--views` entries as view indices, each once: an index in image-id order, or an image
/// name as in the model.
fn view_indices(scene: &planemap::Scene, views: &[String]) -> Result<Vec<usize>> {
    let n = scene.views.len();
    let mut seen = std::collections::BTreeSet::new();
    let mut out = Vec::new();
    for v in views {
        let v = v.trim();
        let i = match v.parse::<usize>() {
            Ok(i) if i < n => i,
            Ok(i) => anyhow::bail!(
                "--views: view index {i} out of range (the model has {n} views, 0..{n})"
            ),
            Err(_) => scene
                .views
                .iter()
                .position(|view| view.name == v)
                .with_context(|| format!("--views: no image named {v:?} in the model"))?,
        };
        if seen.insert(i) {
            out.push(i);
        }
    }
    Ok(out)
}
