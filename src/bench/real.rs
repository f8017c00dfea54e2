//! Real photograph sets in the benchmark (`planemap bench --real DIR`): a folder with a
//! COLMAP model (`sparse/`), its images (`images/`) and the points held out of that model
//! (`heldout.json`, see [`crate::eval::heldout`]), as in `../shared/data/real/` or as
//! `tools/make_real_set.py` makes from any COLMAP reconstruction.
//!
//! Each method runs on every view, as on a synthetic scene (the same runner), and is
//! scored with what real data allows: the held-out observations within 1, 2 and 5 % depth
//! and their median error, neighbouring views' agreement within 1 %, the share of pixels
//! given a depth, the share of the bottom rows (paving in architectural captures) labelled
//! with a horizontal plane, the planes used and the time per stage. A picture sheet per view
//! (`real/SET/VIEW.png`) puts the photograph beside each method's depth map with the
//! held-out points coloured by their error.

use std::path::{Path, PathBuf};
use std::time::Instant;

use image::{Rgb, RgbImage};
use nalgebra::Vector3;
use rayon::prelude::*;
use serde::Serialize;

use super::font::{draw_text, GLYPH};
use super::report::{save_png, write_atomic};
use super::{io_err, run_method, BenchConfig, BenchError, Method, Prediction};
use crate::eval::heldout::{
    horizontal_share, neighbour_pairs, observations_by_view, pooled_agreement, read_heldout,
    view_errors, Agreement, HeldoutScores, Observation, HELDOUT_THRESHOLDS,
};
use crate::eval::metrics::{has_depth, peak_memory_bytes, reset_peak_memory};
use crate::io::output_stem;
use crate::progress::Progress;
use crate::raster::ImageF32;
use crate::scene::Scene;

/// Relative tolerance of [`crate::eval::heldout::agreement`] in the real benchmark.
pub const AGREEMENT_TOLERANCE: f64 = 0.01;
/// Neighbours per view whose agreement is measured (the views sharing most points).
pub const AGREEMENT_NEIGHBOURS: usize = 2;
/// Bottom share of the image rows scored for horizontal labels: paving in both Strecha
/// sets, checked by eye on every view of castle-P19 and Herz-Jesu-P8.
pub const GROUND_ROWS: f64 = 0.08;

/// One method on one real set.
#[derive(Debug, Clone, Serialize)]
pub struct RealMethodResult {
    /// Method name.
    pub method: String,
    /// Why the method failed (its scores are then empty).
    pub error: Option<String>,
    /// Held-out observations over all views.
    pub heldout: HeldoutScores,
    /// Per view (image name).
    pub views: Vec<(String, HeldoutScores)>,
    /// Neighbouring views' agreement within [`AGREEMENT_TOLERANCE`].
    pub agreement: Agreement,
    /// Pixels given a depth, over all pixels.
    pub coverage: f64,
    /// (Horizontal, with a normal) pixels in the bottom [`GROUND_ROWS`] of the rows; methods
    /// with plane labels only (the baselines' normals are not surface normals).
    pub ground_horizontal: Option<(u64, u64)>,
    /// Distinct plane labels used over all views (methods with plane labels only).
    pub planes_used: Option<usize>,
    /// Wall-clock seconds per stage.
    pub stages: Vec<(String, f64)>,
    /// Total wall-clock seconds.
    pub seconds: f64,
    /// Peak resident memory during the method (bytes), if measurable.
    pub peak_memory_bytes: Option<u64>,
}

/// One real set.
#[derive(Debug, Clone, Serialize)]
pub struct RealSetResult {
    /// The folder's name.
    pub name: String,
    /// The folder.
    pub dir: PathBuf,
    /// Image size (of the first view).
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Views.
    pub views: usize,
    /// Sparse points of the input model.
    pub sparse_points: usize,
    /// Held-out points.
    pub heldout_points: usize,
    /// Held-out observations in the model's images (others are left out).
    pub heldout_observations: usize,
    /// Per method.
    pub methods: Vec<RealMethodResult>,
}

/// A real set, loaded.
pub struct RealSet {
    /// The folder's name.
    pub name: String,
    /// The folder.
    pub dir: PathBuf,
    /// The input model with its images, undistorted.
    pub scene: Scene,
    /// Held-out observations per view: world point and COLMAP pixel coordinates.
    pub observations: Vec<Vec<Observation>>,
    /// Held-out points.
    pub heldout_points: usize,
}

/// Loads `dir/sparse`, `dir/images` and `dir/heldout.json`, each missing part named.
pub fn load_real_set(dir: &Path) -> Result<RealSet, BenchError> {
    for part in ["sparse", "images", "heldout.json"] {
        if !dir.join(part).exists() {
            return Err(BenchError::Option(format!(
                "{}: not a real set: expected {part} in it (a real set holds sparse/, images/ \
                 and heldout.json; tools/make_real_set.py makes one from a COLMAP model)",
                dir.display()
            )));
        }
    }
    let name = dir
        .canonicalize()
        .ok()
        .and_then(|d| d.file_name().map(|n| n.to_string_lossy().into_owned()))
        .unwrap_or_else(|| "real".into());
    super::check_scene_name(&name, dir)?;
    let model = crate::io::colmap::read_model(&dir.join("sparse"))?;
    let scene = model.to_scene(Some(&dir.join("images")))?.undistorted();
    let points = read_heldout(&dir.join("heldout.json"))
        .map_err(|e| super::gt_err(&dir.join("heldout.json"), e))?;
    let (observations, unknown) = observations_by_view(&scene, &points);
    if observations.iter().all(|o| o.is_empty()) {
        return Err(super::gt_err(
            &dir.join("heldout.json"),
            format!(
                "none of its observations is in an image of the model ({unknown} in other images)"
            ),
        ));
    }
    Ok(RealSet {
        name,
        dir: dir.to_path_buf(),
        scene,
        observations,
        heldout_points: points.len(),
    })
}

/// Runs every method of `cfg` on each real set, writing `real.json`, `real.md`, the runs
/// under `runs/SET/METHOD/` and the picture sheets under `real/SET/`.
pub fn run_real_bench(
    dirs: &[PathBuf],
    cfg: &BenchConfig,
    out: &Path,
    progress: &Progress,
) -> Result<Vec<RealSetResult>, BenchError> {
    std::fs::create_dir_all(out).map_err(|e| io_err(out, e))?;
    // Every set is loaded before any work: a bad folder fails in seconds, not after hours.
    let sets: Vec<RealSet> = dirs
        .iter()
        .map(|d| load_real_set(d))
        .collect::<Result<_, _>>()?;
    let mut results = Vec::new();
    for set in &sets {
        progress.println(&format!("real set {}", set.name));
        results.push(bench_real_set(set, cfg, out, progress)?);
        let json = serde_json::to_string_pretty(&results).map_err(|e| io_err(out, e))?;
        write_atomic(&out.join("real.json"), json.as_bytes())?;
        write_atomic(&out.join("real.md"), real_markdown(&results).as_bytes())?;
    }
    Ok(results)
}

fn bench_real_set(
    set: &RealSet,
    cfg: &BenchConfig,
    out: &Path,
    progress: &Progress,
) -> Result<RealSetResult, BenchError> {
    let scene = &set.scene;
    let pairs = neighbour_pairs(scene, AGREEMENT_NEIGHBOURS);
    let up = crate::sky::scene_vertical(&scene.views);
    let mut methods = Vec::new();
    let mut depths_of = Vec::new();
    for &m in &cfg.methods {
        progress.println(&format!("{}: {}", set.name, m.name()));
        reset_peak_memory();
        let t = Instant::now();
        let run_dir = out.join("runs").join(&set.name).join(m.name());
        let pred = run_method(m, scene, cfg, &run_dir);
        let seconds = t.elapsed().as_secs_f64();
        let peak = peak_memory_bytes();
        let result = match pred {
            Ok(pred) => {
                let r = score_real(m, set, &pred, &pairs, up.as_ref());
                depths_of.push((m, Some(pred)));
                RealMethodResult {
                    seconds,
                    peak_memory_bytes: peak,
                    ..r
                }
            }
            Err(e) => {
                depths_of.push((m, None));
                RealMethodResult {
                    method: m.name().into(),
                    error: Some(e),
                    heldout: HeldoutScores::default(),
                    views: Vec::new(),
                    agreement: Agreement::default(),
                    coverage: 0.0,
                    ground_horizontal: None,
                    planes_used: None,
                    stages: Vec::new(),
                    seconds,
                    peak_memory_bytes: peak,
                }
            }
        };
        progress.println(&format!(
            "  {:<17} held-out within 1%: {:5.1}%  2%: {:5.1}%  agreement: {:5.1}%  {:6.1} s",
            result.method,
            100.0 * result.heldout.share(0),
            100.0 * result.heldout.share(1),
            100.0 * result.agreement.share(),
            result.seconds
        ));
        methods.push(result);
    }
    if cfg.error_maps {
        write_sheets(&out.join("real").join(&set.name), set, &depths_of)?;
    }
    let (width, height) = scene
        .views
        .first()
        .map_or((0, 0), |v| (v.camera.width, v.camera.height));
    Ok(RealSetResult {
        name: set.name.clone(),
        dir: set.dir.clone(),
        width,
        height,
        views: scene.views.len(),
        sparse_points: scene.cloud.len(),
        heldout_points: set.heldout_points,
        heldout_observations: set.observations.iter().map(Vec::len).sum(),
        methods,
    })
}

fn score_real(
    m: Method,
    set: &RealSet,
    pred: &Prediction,
    pairs: &[(usize, usize)],
    up: Option<&Vector3<f64>>,
) -> RealMethodResult {
    let scene = &set.scene;
    let mut depth_of: Vec<Option<&[f32]>> = vec![None; scene.views.len()];
    for v in &pred.views {
        depth_of[v.view_index] = Some(&v.depth);
    }
    let per_view: Vec<(String, Vec<Option<f64>>)> = pred
        .views
        .iter()
        .map(|v| {
            let view = &scene.views[v.view_index];
            let e = view_errors(view, &v.depth, &set.observations[v.view_index]);
            (view.name.clone(), e)
        })
        .collect();
    let all: Vec<Option<f64>> = per_view.iter().flat_map(|(_, e)| e.clone()).collect();
    let agreement = pooled_agreement(scene, pairs, &depth_of, AGREEMENT_TOLERANCE);
    let (with, total) = pred.views.iter().fold((0usize, 0usize), |(w, t), v| {
        (
            w + v.depth.iter().filter(|&&z| has_depth(z)).count(),
            t + v.depth.len(),
        )
    });
    let labelled = pred.views.iter().all(|v| v.labels.is_some()) && !pred.views.is_empty();
    let ground_horizontal = match (labelled, up) {
        (true, Some(up)) => Some(pred.views.iter().fold((0, 0), |(h, t), v| {
            let (a, b) =
                horizontal_share(&scene.views[v.view_index], &v.normals_cam, up, GROUND_ROWS);
            (h + a, t + b)
        })),
        _ => None,
    };
    let planes_used = labelled.then(|| {
        let mut used = std::collections::BTreeSet::new();
        for v in &pred.views {
            used.extend(v.labels.iter().flatten().flatten().copied());
        }
        used.len()
    });
    RealMethodResult {
        method: m.name().into(),
        error: None,
        heldout: HeldoutScores::from_errors(&all),
        views: per_view
            .into_iter()
            .map(|(n, e)| (n, HeldoutScores::from_errors(&e)))
            .collect(),
        agreement,
        coverage: with as f64 / total.max(1) as f64,
        ground_horizontal,
        planes_used,
        stages: pred.stages.clone(),
        seconds: 0.0,
        peak_memory_bytes: None,
    }
}

/// The Markdown report of the real sets: one table, a row per set and method.
pub fn real_markdown(results: &[RealSetResult]) -> String {
    let mut s = String::from(
        "## Real photographs (held-out points)\n\n\
         Held-out observations within 1, 2 and 5 % of their depth (a pixel without depth is a \
         miss), the median relative error, neighbouring views' agreement within 1 % of their \
         overlap, pixels given a depth, the bottom 8 % of the rows (paving) labelled with a \
         horizontal plane, planes used, and time.\n\n\
         | set | views | method | 1 % | 2 % | 5 % | median | agreement | coverage | ground horizontal | planes | time |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in results {
        for m in &r.methods {
            if let Some(e) = &m.error {
                s.push_str(&format!(
                    "| {} | {} | {} | failed: {} |||||||||\n",
                    r.name, r.views, m.method, e
                ));
                continue;
            }
            let pct = |x: f64| format!("{:.1}", 100.0 * x);
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.0} s |\n",
                r.name,
                r.views,
                m.method,
                pct(m.heldout.share(0)),
                pct(m.heldout.share(1)),
                pct(m.heldout.share(2)),
                m.heldout
                    .median_error
                    .map_or("–".into(), |e| format!("{:.2} %", 100.0 * e)),
                pct(m.agreement.share()),
                pct(m.coverage),
                m.ground_horizontal
                    .map_or("–".into(), |(h, t)| pct(h as f64 / t.max(1) as f64)),
                m.planes_used.map_or("–".into(), |p| p.to_string()),
                m.seconds
            ));
        }
    }
    s.push_str(&format!(
        "\nThresholds {:?}; agreement over each view's {AGREEMENT_NEIGHBOURS} neighbours \
         sharing the most sparse points.\n",
        HELDOUT_THRESHOLDS
    ));
    s
}

/// Colour of a depth on a log scale between `lo` and `hi` (blue near, red far); black for
/// no depth.
fn depth_color(z: f32, lo: f32, hi: f32) -> [u8; 3] {
    if !has_depth(z) {
        return [0, 0, 0];
    }
    let t = ((z.ln() - lo.ln()) / (hi.ln() - lo.ln()).max(1e-6)).clamp(0.0, 1.0);
    // A blue–cyan–yellow–red ramp.
    let stops = [
        [40.0, 60.0, 200.0],
        [40.0, 200.0, 220.0],
        [240.0, 230.0, 60.0],
        [220.0, 40.0, 40.0],
    ];
    let s = t * 3.0;
    let k = (s.floor() as usize).min(2);
    let f = s - k as f32;
    let mut c = [0u8; 3];
    for i in 0..3 {
        c[i] = (stops[k][i] * (1.0 - f) + stops[k + 1][i] * f) as u8;
    }
    c
}

/// Colour of a held-out observation's error: as [`super::report::error_color`]'s scale.
fn heldout_color(e: Option<f64>) -> [u8; 3] {
    match e {
        None => [0, 0, 0],
        Some(e) if e <= 0.01 => [60, 220, 90],
        Some(e) if e <= 0.02 => [240, 220, 60],
        Some(e) if e <= 0.05 => [245, 140, 40],
        Some(_) => [215, 40, 40],
    }
}

/// Writes `dir/VIEW.png` per view: the photograph, then each method's depth map (log colour
/// scale, black = no depth) with the held-out observations as dots coloured by their error
/// (green within 1 %, yellow 2 %, orange 5 %, red beyond, black no depth), at half size.
fn write_sheets(
    dir: &Path,
    set: &RealSet,
    preds: &[(Method, Option<Prediction>)],
) -> Result<(), BenchError> {
    std::fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
    let scene = &set.scene;
    (0..scene.views.len()).into_par_iter().try_for_each(|i| {
        let view = &scene.views[i];
        let (w, h) = (view.camera.width, view.camera.height);
        let scale = if w > 400 { 2 } else { 1 };
        let (tw, th) = (w / scale, h / scale);
        let title_h = 2 * GLYPH.1 + 6;
        let gap = 6;
        let tiles = 1 + preds.len() as u32;
        let mut img = RgbImage::from_pixel(
            tiles * tw + (tiles - 1) * gap,
            th + title_h,
            Rgb([255, 255, 255]),
        );
        let photo = view.load_undistorted_image().ok();
        draw_text(&mut img, 1, 2, &view.name, 2, [0, 0, 0]);
        let put = |img: &mut RgbImage, tile: u32, f: &dyn Fn(u32, u32) -> [u8; 3]| {
            let x0 = tile * (tw + gap);
            for y in 0..th {
                for x in 0..tw {
                    img.put_pixel(x0 + x, title_h + y, Rgb(f(x * scale, y * scale)));
                }
            }
        };
        if let Some(p) = &photo {
            put(&mut img, 0, &|x, y| rgb_of(p, x, y));
        }
        let obs = &set.observations[i];
        let mut zs: Vec<f32> = obs
            .iter()
            .filter_map(|(xyz, _)| view.project(xyz).map(|(_, z)| z as f32))
            .collect();
        zs.sort_by(f32::total_cmp);
        let (lo, hi) = match (zs.first(), zs.last()) {
            (Some(&a), Some(&b)) if a > 0.0 => (a * 0.8, b * 1.25),
            _ => (1.0, 100.0),
        };
        for (k, (m, pred)) in preds.iter().enumerate() {
            let tile = k as u32 + 1;
            let x0 = tile * (tw + gap);
            let Some(depth) = pred
                .as_ref()
                .and_then(|p| p.views.iter().find(|v| v.view_index == i))
                .map(|v| &v.depth)
            else {
                draw_text(
                    &mut img,
                    x0 as i64 + 1,
                    2,
                    &format!("{} failed", m.name()),
                    2,
                    [200, 0, 0],
                );
                continue;
            };
            put(&mut img, tile, &|x, y| {
                depth_color(depth[(y * w + x) as usize], lo, hi)
            });
            let errors = view_errors(view, depth, obs);
            let s = HeldoutScores::from_errors(&errors);
            draw_text(
                &mut img,
                x0 as i64 + 1,
                2,
                &format!("{} {:.1}%", m.name(), 100.0 * s.share(0)),
                2,
                [0, 0, 0],
            );
            for ((_, xy), e) in obs.iter().zip(&errors) {
                let (cx, cy) = ((xy.x / scale as f64) as i64, (xy.y / scale as f64) as i64);
                let c = heldout_color(*e);
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (x, y) = (cx + dx, cy + dy);
                        if x >= 0 && y >= 0 && (x as u32) < tw && (y as u32) < th {
                            img.put_pixel(x0 + x as u32, title_h + y as u32, Rgb(c));
                        }
                    }
                }
            }
        }
        save_png(&img, &dir.join(format!("{}.png", output_stem(&view.name))))
    })
}

fn rgb_of(img: &ImageF32, x: u32, y: u32) -> [u8; 3] {
    let c = img.channels as usize;
    let p = (y * img.width + x) as usize * c;
    let g = |k: usize| (img.data[p + k.min(c - 1)].clamp(0.0, 1.0) * 255.0) as u8;
    [g(0), g(1), g(2)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_colours_run_from_blue_to_red_and_black_is_no_depth() {
        assert_eq!(depth_color(0.0, 1.0, 10.0), [0, 0, 0]);
        assert_eq!(depth_color(1.0, 1.0, 10.0), [40, 60, 200]);
        assert_eq!(depth_color(10.0, 1.0, 10.0), [220, 40, 40]);
        assert_eq!(depth_color(100.0, 1.0, 10.0), [220, 40, 40]);
    }

    #[test]
    fn a_folder_without_heldout_points_is_not_a_real_set() {
        let dir = std::env::temp_dir().join(format!("pm-real-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sparse")).unwrap();
        std::fs::create_dir_all(dir.join("images")).unwrap();
        let e = load_real_set(&dir).err().unwrap().to_string();
        assert!(
            e.contains("heldout.json") && e.contains("not a real set"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }
}
