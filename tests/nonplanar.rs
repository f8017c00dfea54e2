//! The classifier-driven "non-planar" label end to end (`--set nonplanar.enabled=true`) on
//! the statues scene at 256×192 (views 0, 4, 8): planarity maps written, non-planar pixels get the sweep's
//! depth and label 0, energies do not rise, outputs identical for 1 and 2 threads and after
//! `--resume`, the statues' pixels are closer to the truth than when forced onto planes, and
//! closer still with the multi-view confirmation (`nonplanar.consistent_views`).

use std::path::{Path, PathBuf};

use planemap::io::labelpng::read_label_png;
use planemap::io::pfm::read_pfm_path;

mod common;
use common::planemap;

/// A cheap sweep for the label's depth (debug builds run the tests).
const FAST: [&str; 4] = [
    "--views",
    "0,4,8",
    "--set",
    "hypotheses.sweep.enabled=false",
];

fn render(dir: &Path) {
    let out = planemap()
        .args([
            "-q",
            "synth",
            "scenes/statues.toml",
            "--width",
            "256",
            "--height",
            "192",
            "-o",
        ])
        .arg(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `confirm`: `nonplanar.consistent_views` (the three views give each pixel at most two
/// other views to confirm it).
fn run(ws: &Path, out: &Path, enabled: bool, confirm: usize, threads: &str, extra: &[&str]) {
    let o = planemap()
        .env("RAYON_NUM_THREADS", threads)
        .args(["-q", "run", "--model"])
        .arg(ws.join("sparse"))
        .arg("-o")
        .arg(out)
        .args(FAST)
        .args(["--set", &format!("nonplanar.enabled={enabled}")])
        .args(["--set", &format!("nonplanar.consistent_views={confirm}")])
        .args(extra)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            out.extend(files_under(&p));
        } else if p.file_name().unwrap() != "summary.json" {
            out.push(p);
        }
    }
    out.sort();
    out
}

/// Every file under `a` has an identical twin under `b` (summary.json, with its timings,
/// aside), and nothing else is there.
fn assert_same_files(a: &Path, b: &Path, when: &str) {
    let (fa, fb) = (files_under(a), files_under(b));
    let rel = |f: &[PathBuf], root: &Path| -> Vec<PathBuf> {
        f.iter()
            .map(|p| p.strip_prefix(root).unwrap().to_path_buf())
            .collect()
    };
    assert_eq!(rel(&fa, a), rel(&fb, b), "different files {when}");
    for (x, y) in fa.iter().zip(&fb) {
        assert!(
            std::fs::read(x).unwrap() == std::fs::read(y).unwrap(),
            "{} differs {when}",
            y.display()
        );
    }
}

/// (within `tol` relative, total) over ground-truth non-planar pixels with a surface, all
/// views.
fn nonplanar_accuracy(ws: &Path, out: &Path, tol: f32) -> (usize, usize) {
    accuracy(ws, out, tol, false)
}

/// (within `tol` relative, total) over ground-truth planar (`planar`) or non-planar pixels
/// with a surface, all views.
fn accuracy(ws: &Path, out: &Path, tol: f32, planar: bool) -> (usize, usize) {
    let (mut ok, mut total) = (0, 0);
    for e in std::fs::read_dir(out.join("depth")).unwrap() {
        let stem = e
            .unwrap()
            .path()
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        let gt_path = ws.join("gt/depth").join(format!("{stem}.pfm"));
        let gt = read_pfm_path(&gt_path).unwrap();
        let (_, _, ids) =
            read_label_png(&ws.join("gt/planes").join(format!("{stem}.png"))).unwrap();
        let pred = read_pfm_path(&out.join("depth").join(format!("{stem}.pfm"))).unwrap();
        for ((&g, &id), &z) in gt.data.iter().zip(&ids).zip(&pred.data) {
            if (id != 0) == planar && g > 0.0 {
                total += 1;
                if (z - g).abs() <= tol * g {
                    ok += 1;
                }
            }
        }
    }
    (ok, total)
}

#[test]
fn nonplanar_label_end_to_end() {
    let tmp = tempfile::tempdir().unwrap();
    let ws = tmp.path().join("ws");
    render(&ws);
    let (on1, on2, off, unconfirmed) = (
        tmp.path().join("on1"),
        tmp.path().join("on2"),
        tmp.path().join("off"),
        tmp.path().join("unconfirmed"),
    );
    run(&ws, &on1, true, 2, "1", &[]);
    run(&ws, &on2, true, 2, "2", &[]);
    run(&ws, &off, false, 2, "2", &[]);
    run(&ws, &unconfirmed, true, 0, "2", &[]);

    // Deterministic whatever the thread count, planarity maps included.
    assert_same_files(&on1, &on2, "between 1 and 2 threads");
    // --resume reloads every view (its sweep depth too) and confirms again: the same bytes.
    run(&ws, &on2, true, 2, "2", &["--resume"]);
    assert_same_files(&on1, &on2, "after --resume");

    // One 8-bit planarity map per view, image-sized; none without the classifier.
    let maps = files_under(&on1.join("planarity"));
    assert_eq!(maps.len(), 3);
    for m in &maps {
        let img = image::open(m).unwrap();
        assert_eq!((img.width(), img.height()), (256, 192));
        assert!(matches!(img, image::DynamicImage::ImageLuma8(_)));
    }
    assert!(!off.join("planarity").exists());
    // The label's sweep depths (for --resume and the confirmation): one per view.
    assert_eq!(files_under(&on1.join("sweep")).len(), 3);
    assert!(!off.join("sweep").exists());

    // Non-planar pixels: label 0 with a finite positive depth; there are some.
    let mut np_pixels = 0;
    for e in std::fs::read_dir(on1.join("depth")).unwrap() {
        let path = e.unwrap().path();
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let depth = read_pfm_path(&path).unwrap();
        let (_, _, ids) =
            read_label_png(&on1.join("planemaps").join(format!("{stem}.png"))).unwrap();
        for (&z, &id) in depth.data.iter().zip(&ids) {
            assert!(z.is_finite() && z >= 0.0);
            if id == 0 && z > 0.0 {
                np_pixels += 1;
            }
        }
    }
    assert!(np_pixels > 1000, "only {np_pixels} non-planar pixels");

    // Energies never rise from the start.
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(on1.join("summary.json")).unwrap()).unwrap();
    for v in summary["views"].as_array().unwrap() {
        let (e0, e) = (
            v["initial_energy"].as_f64().unwrap(),
            v["energy"].as_f64().unwrap(),
        );
        assert!(e <= e0 + 1e-6 * e0.abs(), "{v}");
    }

    // The statues, trees and column are closer to the truth than when forced onto planes.
    let (ok_on, total) = nonplanar_accuracy(&ws, &on1, 0.01);
    let (ok_off, total_off) = nonplanar_accuracy(&ws, &off, 0.01);
    assert_eq!(total, total_off);
    assert!(total > 5000, "{total} non-planar ground-truth pixels");
    assert!(
        ok_on as f64 >= 1.2 * ok_off as f64,
        "non-planar pixels within 1%: {ok_on} with the label, {ok_off} without (of {total})"
    );
    // Measured (4 Dec): 4612 with the label (confirmed by both other views), 4147 without
    // the confirmation, 2264 forced onto planes, of 13737 within 1 %; planar pixels 103614
    // confirmed, 103641 unconfirmed, of 108284.
    let (on5, off5) = (
        nonplanar_accuracy(&ws, &on1, 0.05).0,
        nonplanar_accuracy(&ws, &off, 0.05).0,
    );
    assert!(
        on5 as f64 >= 1.5 * off5 as f64,
        "within 5%: {on5} vs {off5}"
    );
    // The confirmation turns pixels whose sweep depth both other views agree with into
    // non-planar ones: more of the statues within 1 %, planar pixels no worse.
    let (ok_unconfirmed, _) = nonplanar_accuracy(&ws, &unconfirmed, 0.01);
    eprintln!("non-planar within 1 %: {ok_on} confirmed, {ok_unconfirmed} unconfirmed, {ok_off} off (of {total})");
    assert!(
        ok_on as f64 >= 1.05 * ok_unconfirmed as f64,
        "confirmed {ok_on} vs {ok_unconfirmed}"
    );
    let (planar_on, planar_total) = accuracy(&ws, &on1, 0.01, true);
    let (planar_unconfirmed, _) = accuracy(&ws, &unconfirmed, 0.01, true);
    eprintln!("planar within 1 %: {planar_on} confirmed, {planar_unconfirmed} unconfirmed (of {planar_total})");
    assert!(
        planar_on as f64 >= 0.995 * planar_unconfirmed as f64,
        "planar pixels within 1 %: confirmed {planar_on} vs {planar_unconfirmed} of {planar_total}"
    );
}
