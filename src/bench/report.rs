//! Benchmark reports: results.json, Markdown tables (results.md, also printed), and PNG
//! charts drawn with the image crate — accuracy per scene and method, time per stage, and
//! per-view depth-error maps with the methods side by side.

use std::path::Path;

use image::{Rgb, RgbImage};

use super::font::{draw_text, text_width, GLYPH};
use super::{io_err, BenchError, BenchResults, Method, MethodResult};
use crate::eval::metrics::has_depth;
use crate::io::output_stem;
use crate::scene::Scene;

/// Writes `results.json`, `results.md`, `accuracy.png` and `time.png` into `out`.
pub fn write_reports(results: &BenchResults, out: &Path) -> Result<(), BenchError> {
    let json = serde_json::to_string_pretty(results).map_err(|e| io_err(out, e))?;
    write_atomic(&out.join("results.json"), json.as_bytes())?;
    write_atomic(&out.join("results.md"), markdown(results).as_bytes())?;
    save_png(&accuracy_chart(results), &out.join("accuracy.png"))?;
    save_png(&time_chart(results), &out.join("time.png"))?;
    Ok(())
}

pub(super) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), BenchError> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(|e| io_err(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))
}

pub(super) fn save_png(img: &RgbImage, path: &Path) -> Result<(), BenchError> {
    let tmp = path.with_extension("tmp.png");
    img.save(&tmp).map_err(|e| io_err(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| io_err(path, e))
}

fn pct(x: f64) -> String {
    format!("{:.1}", 100.0 * x)
}

fn num(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

/// Methods in the order of the first scene (all scenes run the same list).
fn method_names(results: &BenchResults) -> Vec<String> {
    results
        .scenes
        .first()
        .map(|s| s.methods.iter().map(|m| m.method.clone()).collect())
        .unwrap_or_default()
}

fn find<'a>(methods: &'a [MethodResult], name: &str) -> Option<&'a MethodResult> {
    methods.iter().find(|m| m.method == name)
}

/// The summary table (depth within 1% and F-score per scene and method), the full table
/// and the time-per-stage table, in Markdown.
pub fn markdown(results: &BenchResults) -> String {
    let mut s = summary_table(results);
    s.push_str(&details_table(results));
    s
}

/// The summary: depth within 1 % / F-score per scene and method, with the means.
pub fn summary_table(results: &BenchResults) -> String {
    let names = method_names(results);
    let mut s = String::new();
    s.push_str(&format!(
        "Depth within 1% of ground truth (% of ground-truth pixels) / F-score of the fused points at τ = {}% of the median depth (%):\n\n",
        100.0 * results.cloud_tolerance_fraction
    ));
    s.push_str("| scene | category | size | views |");
    for n in &names {
        s.push_str(&format!(" {n} |"));
    }
    s.push_str("\n|---|---|---|---|");
    for _ in &names {
        s.push_str("---|");
    }
    s.push('\n');
    let mut sums = vec![(0.0, 0.0); names.len()];
    for sc in &results.scenes {
        s.push_str(&format!(
            "| {} | {} | {}×{} | {} |",
            sc.name, sc.category, sc.width, sc.height, sc.views
        ));
        for (k, n) in names.iter().enumerate() {
            match find(&sc.methods, n) {
                Some(m) if m.error.is_none() => {
                    sums[k].0 += m.depth.accuracy(1);
                    sums[k].1 += m.cloud.f_score;
                    s.push_str(&format!(
                        " {} / {} |",
                        pct(m.depth.accuracy(1)),
                        pct(m.cloud.f_score)
                    ));
                }
                Some(_) => s.push_str(" failed |"),
                None => s.push_str(" – |"),
            }
        }
        s.push('\n');
    }
    let count = results.scenes.len().max(1) as f64;
    s.push_str("| **mean** | | | |");
    for (d, f) in &sums {
        s.push_str(&format!(" **{} / {}** |", pct(d / count), pct(f / count)));
    }
    s.push('\n');
    s
}

/// Every metric per scene and method.
fn details_table(results: &BenchResults) -> String {
    let mut s = String::new();
    s.push_str("\nAll metrics:\n\n");
    s.push_str("| scene | method | ≤0.5% | ≤1% | ≤2% | MAE | complete | sky given depth | normal° | ≤10° | planes | over/under | τ | cloud acc | cloud comp | F | time s | peak MB (+growth) |\n");
    s.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for sc in &results.scenes {
        for m in &sc.methods {
            if let Some(e) = &m.error {
                s.push_str(&format!(
                    "| {} | {} | failed: {} ||||||||||||||||\n",
                    sc.name,
                    m.method,
                    e.replace('|', "/").lines().next().unwrap_or("")
                ));
                continue;
            }
            let d = &m.depth;
            let (seg, ou) = match &m.segmentation {
                Some(g) => (
                    pct(g.accuracy()),
                    format!(
                        "{}/{} of {}/{}",
                        g.over_segmented,
                        g.under_segmented,
                        g.planes_considered,
                        g.labels_considered
                    ),
                ),
                None => ("–".into(), "–".into()),
            };
            let within10 = d.normal_within_10deg as f64 / d.normal_pixels.max(1) as f64;
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                sc.name,
                m.method,
                pct(d.accuracy(0)),
                pct(d.accuracy(1)),
                pct(d.accuracy(2)),
                num(d.mean_abs_error(), 3),
                pct(d.completeness()),
                if d.empty_pixels > 0 {
                    pct(d.empty_with_depth())
                } else {
                    "–".into()
                },
                num(d.mean_normal_error_deg(), 1),
                pct(within10),
                seg,
                ou,
                num(m.cloud.tolerance, 3),
                pct(m.cloud.accuracy),
                pct(m.cloud.completeness),
                pct(m.cloud.f_score),
                num(m.seconds, 1),
                match (m.peak_memory_bytes, m.start_memory_bytes) {
                    (Some(p), Some(s)) => format!(
                        "{:.0} (+{:.0})",
                        p as f64 / 1048576.0,
                        p.saturating_sub(s) as f64 / 1048576.0
                    ),
                    (Some(p), None) => format!("{:.0}", p as f64 / 1048576.0),
                    _ => "–".into(),
                },
            ));
        }
    }
    // Scenes with non-planar surfaces (≥ 1 % of ground-truth pixels): planar / non-planar.
    let mixed: Vec<_> = results
        .scenes
        .iter()
        .filter(|sc| {
            sc.methods.iter().any(|m| {
                m.error.is_none() && m.nonplanar_depth.gt_pixels * 100 >= m.depth.gt_pixels.max(1)
            })
        })
        .collect();
    if !mixed.is_empty() {
        s.push_str(
            "\nPlanar / non-planar ground-truth pixels: depth within 1% (%) and mean absolute \
             error on the non-planar ones:\n\n| scene | method | planar ≤1% | non-planar ≤1% | \
             non-planar MAE |\n|---|---|---|---|---|\n",
        );
        for sc in mixed {
            for m in sc.methods.iter().filter(|m| m.error.is_none()) {
                s.push_str(&format!(
                    "| {} | {} | {} | {} | {} |\n",
                    sc.name,
                    m.method,
                    pct(m.planar_depth.accuracy(1)),
                    pct(m.nonplanar_depth.accuracy(1)),
                    num(m.nonplanar_depth.mean_abs_error(), 3)
                ));
            }
        }
    }
    s.push_str("\nTime per stage (s):\n\n| scene | method | stages |\n|---|---|---|\n");
    for sc in &results.scenes {
        for m in &sc.methods {
            let stages: Vec<String> = m
                .stages
                .iter()
                .map(|(n, t)| format!("{n} {t:.2}"))
                .collect();
            s.push_str(&format!(
                "| {} | {} | {} |\n",
                sc.name,
                m.method,
                stages.join(", ")
            ));
        }
    }
    let rendered: f64 = results.scenes.iter().map(|s| s.render_seconds).sum();
    s.push_str(&format!(
        "\nTotal {:.0} s (rendering {:.0} s; {} of {} scenes from the cache).\n",
        results.seconds,
        rendered,
        results.scenes.iter().filter(|s| s.cache_hit).count(),
        results.scenes.len()
    ));
    s
}

/// A fixed colour per method name (by its position in [`Method::ALL`], else grey).
fn method_color(name: &str) -> [u8; 3] {
    const COLORS: [[u8; 3]; 8] = [
        [31, 119, 180],
        [23, 190, 207],
        [148, 103, 189],
        [255, 127, 14],
        [44, 160, 44],
        [214, 39, 40],
        [227, 119, 194],
        [140, 86, 75],
    ];
    Method::ALL
        .iter()
        .position(|m| m.name() == name)
        .and_then(|k| COLORS.get(k).copied())
        .unwrap_or([120, 120, 120])
}

const STAGE_COLORS: [[u8; 3]; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [127, 127, 127],
];

fn fill(img: &mut RgbImage, x0: i64, y0: i64, x1: i64, y1: i64, c: [u8; 3]) {
    for y in y0.max(0)..y1.min(img.height() as i64) {
        for x in x0.max(0)..x1.min(img.width() as i64) {
            img.put_pixel(x as u32, y as u32, Rgb(c));
        }
    }
}

/// Grouped bar chart: depth within 1% (bars) per scene, one bar per method; the legend and
/// scene names are drawn with the 3×5 font; a tick on each bar marks the point-cloud F-score.
pub fn accuracy_chart(results: &BenchResults) -> RgbImage {
    let names = method_names(results);
    let bar_w = 10i64;
    let group_w = bar_w * names.len().max(1) as i64 + 14;
    let (left, top, plot_h) = (44i64, 40i64, 300i64);
    let title = "DEPTH WITHIN 1% (BARS), POINT-CLOUD F (TICKS)";
    let width = (left + group_w * results.scenes.len() as i64 + 20)
        .max(left + text_width(title, 2) as i64 + 10);
    let height = top + plot_h + 70;
    let mut img = RgbImage::from_pixel(width as u32, height as u32, Rgb([255, 255, 255]));
    draw_text(&mut img, left, 6, title, 2, [0, 0, 0]);
    let mut lx = left;
    for n in &names {
        fill(&mut img, lx, 24, lx + 8, 32, method_color(n));
        draw_text(&mut img, lx + 11, 25, n, 1, [0, 0, 0]);
        lx += 16 + text_width(n, 1) as i64;
    }
    for k in 0..=4 {
        let y = top + plot_h - plot_h * k / 4;
        fill(&mut img, left - 3, y, width - 10, y + 1, [215, 215, 215]);
        draw_text(&mut img, 4, y - 2, &format!("{}", 25 * k), 1, [0, 0, 0]);
    }
    for (g, sc) in results.scenes.iter().enumerate() {
        let gx = left + 7 + g as i64 * group_w;
        for (k, n) in names.iter().enumerate() {
            let Some(m) = find(&sc.methods, n) else {
                continue;
            };
            let x = gx + k as i64 * bar_w;
            let h = (plot_h as f64 * m.depth.accuracy(1)).round() as i64;
            fill(
                &mut img,
                x,
                top + plot_h - h,
                x + bar_w - 1,
                top + plot_h,
                method_color(n),
            );
            let fy = top + plot_h - (plot_h as f64 * m.cloud.f_score).round() as i64;
            fill(&mut img, x - 1, fy, x + bar_w, fy + 2, [0, 0, 0]);
        }
        // Scene name below the group, on two rows if long.
        let label: String = sc.name.chars().take(12).collect();
        let (a, b) = label.split_at(label.len().min(6));
        draw_text(&mut img, gx, top + plot_h + 6, a, 1, [0, 0, 0]);
        draw_text(&mut img, gx, top + plot_h + 13, b, 1, [0, 0, 0]);
    }
    img
}

/// Stacked bars of seconds per stage, one bar per scene and method; the stages are
/// coloured by name in order of first appearance (legend on top).
pub fn time_chart(results: &BenchResults) -> RgbImage {
    let names = method_names(results);
    let mut stage_names: Vec<String> = Vec::new();
    for sc in &results.scenes {
        for m in &sc.methods {
            for (s, _) in &m.stages {
                if !stage_names.contains(s) {
                    stage_names.push(s.clone());
                }
            }
        }
    }
    let max_t = results
        .scenes
        .iter()
        .flat_map(|sc| {
            sc.methods
                .iter()
                .map(|m| m.stages.iter().map(|s| s.1).sum::<f64>())
        })
        .fold(0.0f64, f64::max)
        .max(1e-3);
    // A round axis maximum: 1, 2 or 5 × 10^k.
    let mag = 10f64.powf(max_t.log10().floor());
    let axis = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|&a| a >= max_t)
        .unwrap_or(10.0 * mag);
    let bar_w = 10i64;
    let group_w = bar_w * names.len().max(1) as i64 + 14;
    let (left, top, plot_h) = (44i64, 40i64, 300i64);
    let title = "SECONDS PER STAGE; BARS IN ORDER:";
    let methods_label = names.join(" ");
    let width = (left + group_w * results.scenes.len() as i64 + 20)
        .max(left + text_width(title, 2) as i64 + 10 + text_width(&methods_label, 1) as i64 + 10);
    let height = top + plot_h + 70;
    let mut img = RgbImage::from_pixel(width as u32, height as u32, Rgb([255, 255, 255]));
    draw_text(&mut img, left, 6, title, 2, [0, 0, 0]);
    draw_text(
        &mut img,
        left + text_width(title, 2) as i64 + 10,
        10,
        &methods_label,
        1,
        [0, 0, 0],
    );
    let mut lx = left;
    for (k, n) in stage_names.iter().enumerate() {
        fill(
            &mut img,
            lx,
            24,
            lx + 8,
            32,
            STAGE_COLORS[k % STAGE_COLORS.len()],
        );
        draw_text(&mut img, lx + 11, 25, n, 1, [0, 0, 0]);
        lx += 16 + text_width(n, 1) as i64;
    }
    for k in 0..=4 {
        let y = top + plot_h - plot_h * k / 4;
        fill(&mut img, left - 3, y, width - 10, y + 1, [215, 215, 215]);
        draw_text(
            &mut img,
            2,
            y - 2,
            &num(axis * k as f64 / 4.0, 1),
            1,
            [0, 0, 0],
        );
    }
    for (g, sc) in results.scenes.iter().enumerate() {
        let gx = left + 7 + g as i64 * group_w;
        for (k, n) in names.iter().enumerate() {
            let Some(m) = find(&sc.methods, n) else {
                continue;
            };
            let x = gx + k as i64 * bar_w;
            let mut acc = 0.0;
            for (s, t) in &m.stages {
                let c = stage_names.iter().position(|x| x == s).unwrap_or(0);
                let y0 = top + plot_h - (plot_h as f64 * (acc + t) / axis).round() as i64;
                let y1 = top + plot_h - (plot_h as f64 * acc / axis).round() as i64;
                fill(
                    &mut img,
                    x,
                    y0,
                    x + bar_w - 1,
                    y1,
                    STAGE_COLORS[c % STAGE_COLORS.len()],
                );
                acc += t;
            }
        }
        let label: String = sc.name.chars().take(12).collect();
        let (a, b) = label.split_at(label.len().min(6));
        draw_text(&mut img, gx, top + plot_h + 6, a, 1, [0, 0, 0]);
        draw_text(&mut img, gx, top + plot_h + 13, b, 1, [0, 0, 0]);
    }
    img
}

/// Colour of a relative depth error: green within 1%, yellow within 2%, orange within 5%,
/// red beyond; black = no prediction; grey = no ground truth.
pub fn error_color(pred: f32, gt: f32) -> [u8; 3] {
    if !has_depth(gt) {
        return [90, 90, 110];
    }
    if !has_depth(pred) {
        return [0, 0, 0];
    }
    let e = ((pred - gt) / gt).abs();
    if e <= 0.005 {
        [0, 150, 60]
    } else if e <= 0.01 {
        [110, 210, 90]
    } else if e <= 0.02 {
        [240, 220, 60]
    } else if e <= 0.05 {
        [245, 140, 40]
    } else {
        [215, 40, 40]
    }
}

/// Writes `dir/VIEW.png` per view: the methods' error maps ([`error_color`]) side by side,
/// each titled with its name.
pub fn write_error_maps(
    dir: &Path,
    scene: &Scene,
    gt: &[&[f32]],
    predictions: &[(Method, Option<Vec<Vec<f32>>>)],
) -> Result<(), BenchError> {
    std::fs::create_dir_all(dir).map_err(|e| io_err(dir, e))?;
    let gap = 4u32;
    let title_h = GLYPH.1 + 4;
    for (i, view) in scene.views.iter().enumerate() {
        let (w, h) = (view.camera.width, view.camera.height);
        let tiles = predictions.len() as u32;
        let mut img = RgbImage::from_pixel(
            tiles * w + tiles.saturating_sub(1) * gap,
            h + title_h,
            Rgb([255, 255, 255]),
        );
        for (k, (m, depths)) in predictions.iter().enumerate() {
            let x0 = k as u32 * (w + gap);
            draw_text(&mut img, x0 as i64 + 1, 2, m.name(), 1, [0, 0, 0]);
            for y in 0..h {
                for x in 0..w {
                    let p = (y * w + x) as usize;
                    let z = depths.as_ref().map_or(0.0, |d| d[i][p]);
                    img.put_pixel(x0 + x, title_h + y, Rgb(error_color(z, gt[i][p])));
                }
            }
        }
        save_png(&img, &dir.join(format!("{}.png", output_stem(&view.name))))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_has_its_own_colour() {
        let colours: Vec<_> = Method::ALL.iter().map(|m| method_color(m.name())).collect();
        for (i, c) in colours.iter().enumerate() {
            assert_ne!(*c, [120, 120, 120], "{}", Method::ALL[i].name());
            assert!(!colours[..i].contains(c), "{}", Method::ALL[i].name());
        }
        assert_eq!(method_color("unknown"), [120, 120, 120]);
    }

    #[test]
    fn error_colours_follow_thresholds() {
        assert_eq!(error_color(100.0, 100.0), [0, 150, 60]);
        assert_eq!(error_color(101.0, 100.0), [110, 210, 90]);
        assert_eq!(error_color(101.5, 100.0), [240, 220, 60]);
        assert_eq!(error_color(110.0, 100.0), [215, 40, 40]);
        assert_eq!(error_color(0.0, 100.0), [0, 0, 0]);
        assert_eq!(error_color(f32::NAN, 100.0), [0, 0, 0]);
        assert_eq!(error_color(1.0, 0.0), [90, 90, 110]);
    }
}
