//! `planemap run`, `sweep`, `bench`, `config` and `classify` on inputs and options that used
//! to go wrong (issue 42, defects 1–5 and 9–12): each test reproduces one defect and asserts
//! the named error or the correct output. The readers' defects (6–8, 11) are in
//! `tests/malformed.rs`.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{clean_failure, planemap, success, synth_tiny_demo, text};

/// The tiny demo with only the text model in `sparse/`, so edits to `images.txt` are read.
fn text_demo(dir: &Path) -> PathBuf {
    synth_tiny_demo(dir);
    for stem in ["cameras", "images", "points3D"] {
        std::fs::remove_file(dir.join("sparse").join(format!("{stem}.bin"))).unwrap();
    }
    dir.join("sparse")
}

/// Renames image `from` to `to` (a relative name, possibly with folders) in the images
/// folder and in `images.txt`.
fn rename_image(dir: &Path, from: &str, to: &str) {
    let images = dir.join("images");
    let target = images.join(to);
    std::fs::create_dir_all(target.parent().unwrap()).unwrap();
    std::fs::rename(images.join(from), &target).unwrap();
    // Ground truth follows the output-name rule: the image's stem, folders kept.
    let (from_stem, to_stem) = (
        from.rsplit_once('.').unwrap().0,
        to.rsplit_once('.').unwrap().0,
    );
    for (kind, ext) in [("depth", "pfm"), ("normals", "pfm"), ("planes", "png")] {
        let src = dir.join(format!("gt/{kind}/{from_stem}.{ext}"));
        if src.exists() {
            let dst = dir.join(format!("gt/{kind}/{to_stem}.{ext}"));
            std::fs::create_dir_all(dst.parent().unwrap()).unwrap();
            std::fs::rename(src, dst).unwrap();
        }
    }
    let txt = dir.join("sparse/images.txt");
    let s = std::fs::read_to_string(&txt).unwrap();
    assert!(s.contains(from));
    std::fs::write(&txt, s.replace(from, to)).unwrap();
}

/// `planemap run` on `dir`'s model with extra arguments; progress to a pipe (not a terminal).
fn run(dir: &Path, out: &Path, extra: &[&str]) -> Output {
    planemap()
        .arg("run")
        .args(extra)
        .arg("--model")
        .arg(dir.join("sparse"))
        .arg("--images")
        .arg(dir.join("images"))
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

/// A depth map's values, read with the project's own PFM reader.
fn read_pfm(path: &Path) -> Vec<f32> {
    planemap::io::pfm::read_pfm_path(path).unwrap().data
}

// --- 1. output names -----------------------------------------------------------------------

#[test]
fn images_in_subfolders_keep_their_names_in_every_output() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    text_demo(&dir);
    rename_image(&dir, "view_0000.png", "cam0/frame.png");
    rename_image(&dir, "view_0001.png", "cam1/frame.png");
    let out = tmp.path().join("out");
    // --views by image name (defect 12: indices are in image-id order, names are unambiguous).
    let stdout = success(&run(
        &dir,
        &out,
        &["-q", "--views", "cam0/frame.png,cam1/frame.png"],
    ));
    assert!(stdout.contains("wrote 2 planemaps"), "{stdout}");
    assert!(stdout.contains("against ground truth"), "{stdout}");
    for cam in ["cam0", "cam1"] {
        assert!(out.join(format!("planemaps/{cam}/frame.png")).is_file());
        assert!(out.join(format!("depth/{cam}/frame.pfm")).is_file());
        // stereo/ keeps COLMAP's full image name, as `colmap stereo_fusion` looks it up.
        for kind in ["depth_maps", "normal_maps"] {
            let f = out.join(format!("stereo/{kind}/{cam}/frame.png.geometric.bin"));
            assert!(f.is_file(), "{} missing", f.display());
        }
    }
    let d0 = std::fs::read(out.join("depth/cam0/frame.pfm")).unwrap();
    let d1 = std::fs::read(out.join("depth/cam1/frame.pfm")).unwrap();
    assert_ne!(
        d0, d1,
        "the two views' depth maps must not overwrite each other"
    );
}

#[test]
fn two_images_with_one_output_name_are_an_error_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    text_demo(&dir);
    // A PNG named .jpg is read by its content; its stem collides with view_0000.png.
    rename_image(&dir, "view_0001.png", "view_0000.jpg");
    let out = tmp.path().join("out");
    let stderr = clean_failure(&run(&dir, &out, &[]));
    assert!(
        stderr.contains("view_0000.png") && stderr.contains("view_0000.jpg"),
        "{stderr}"
    );
    assert!(!stderr.contains("global stages"), "{stderr}");
    assert!(!out.join("planemaps").exists());
}

// --- 2. duplicate views ----------------------------------------------------------------------

#[test]
fn duplicate_views_are_labelled_once() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let out = tmp.path().join("out");
    let stdout = success(&run(&dir, &out, &["-q", "--views", "0,0,view_0000.png,0"]));
    assert!(stdout.contains("wrote 1 planemaps"), "{stdout}");
    let left: Vec<_> = std::fs::read_dir(out.join("planemaps"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
}

// --- 3. --resume ---------------------------------------------------------------------------

#[test]
fn resume_refuses_a_changed_configuration_and_names_the_key() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let out = tmp.path().join("out");
    success(&run(&dir, &out, &["-q", "--views", "0"]));
    let before = std::fs::read(out.join("planemaps/view_0000.png")).unwrap();
    let stderr = clean_failure(&run(
        &dir,
        &out,
        &[
            "-q",
            "--views",
            "0",
            "--resume",
            "--set",
            "planemap.lambda=3.5",
        ],
    ));
    assert!(stderr.contains("planemap.lambda"), "{stderr}");
    assert_eq!(
        std::fs::read(out.join("planemaps/view_0000.png")).unwrap(),
        before,
        "a refused resume must not touch the folder"
    );
    // The same configuration resumes.
    success(&run(&dir, &out, &["-q", "--views", "0", "--resume"]));
}

#[test]
fn resume_refuses_changed_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let out = tmp.path().join("out");
    success(&run(&dir, &out, &["-q", "--views", "0"]));
    // Another image content under the same name.
    std::fs::copy(
        dir.join("images/view_0001.png"),
        dir.join("images/view_0000.png"),
    )
    .unwrap();
    let stderr = clean_failure(&run(&dir, &out, &["-q", "--views", "0", "--resume"]));
    assert!(stderr.contains("input"), "{stderr}");
}

#[test]
fn resume_recomputes_crease_hypotheses_voted_by_other_views() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let out = tmp.path().join("out");
    success(&run(&dir, &out, &["-q", "--views", "0,1"]));
    let voters = |out: &Path| -> serde_json::Value {
        let f: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("fingerprint.json")).unwrap()).unwrap();
        f["crease_voters"].clone()
    };
    let creases = |out: &Path| std::fs::read(out.join("crease_hypotheses.json")).unwrap();
    assert_eq!(voters(&out).as_array().map(Vec::len), Some(2));
    success(&run(&dir, &out, &["-q", "--resume"]));
    // All views voted this time, and the hypotheses equal a fresh run's on all views.
    assert_eq!(voters(&out).as_array().map(Vec::len), Some(7));
    let fresh = tmp.path().join("fresh");
    success(&run(&dir, &fresh, &["-q"]));
    assert_eq!(creases(&out), creases(&fresh));
}

// --- 4. ground truth of the wrong shape ------------------------------------------------------

#[test]
fn three_channel_ground_truth_depth_is_an_error_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let gt = dir.join("gt/depth/view_0000.pfm");
    let depth = read_pfm(&gt);
    let rgb = planemap::ImageF32 {
        width: 96,
        height: 72,
        channels: 3,
        data: depth.iter().flat_map(|&d| [d; 3]).collect(),
    };
    planemap::io::pfm::write_pfm_path(&gt, &rgb).unwrap();
    let stderr = clean_failure(&run(&dir, &tmp.path().join("out"), &["-q", "--views", "0"]));
    assert!(stderr.contains("view_0000.pfm"), "{stderr}");
    assert!(
        stderr.contains("96×72×3") || stderr.contains("96x72x3"),
        "{stderr}"
    );
}

// --- 5. bench scene names ------------------------------------------------------------------

#[test]
fn bench_refuses_a_scene_name_that_leaves_the_output_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = std::fs::read_to_string("scenes/tiny.toml").unwrap();
    for bad in ["../escape", "/tmp/escape", "a/b"] {
        let renamed = spec.replacen("name = \"tiny\"", &format!("name = {bad:?}"), 1);
        assert_ne!(renamed, spec, "scenes/tiny.toml has no name line to edit");
        let file = tmp.path().join("bad.toml");
        std::fs::write(&file, renamed).unwrap();
        let out = tmp.path().join("bench");
        let stderr = clean_failure(
            &planemap()
                .args(["-q", "bench"])
                .arg(&file)
                .args(["--methods", "sweep", "-o"])
                .arg(&out)
                .output()
                .unwrap(),
        );
        assert!(
            stderr.contains("bad.toml") && stderr.contains(bad),
            "{stderr}"
        );
        assert!(!tmp.path().join("escape").exists());
    }
}

// --- 9. cheap checks come first ---------------------------------------------------------------

#[test]
fn an_unwritable_output_or_a_missing_view_is_reported_before_the_global_stages() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    // -v: the (piped) progress lines and logs show whether any stage started.
    let stderr = clean_failure(&run(
        &dir,
        &tmp.path().join("out"),
        &["-v", "--views", "99"],
    ));
    assert!(
        stderr.contains("99") && stderr.contains("7 views"),
        "{stderr}"
    );
    assert!(!stderr.contains("global stages"), "{stderr}");
    assert!(!stderr.contains("dominant directions"), "{stderr}");
    assert!(
        !stderr.contains('\u{1b}'),
        "ANSI codes in a piped log: {stderr:?}"
    );

    let file = tmp.path().join("a-file");
    std::fs::write(&file, "").unwrap();
    let stderr = clean_failure(&run(&dir, &file.join("out"), &[]));
    assert!(stderr.contains("a-file"), "{stderr}");
    assert!(!stderr.contains("global stages"), "{stderr}");
}

// --- 10. --set --------------------------------------------------------------------------------

fn config_check(set: &str) -> Output {
    planemap()
        .args(["config", "--check", "Cargo.toml", "--set", set])
        .output()
        .unwrap()
}

fn config_set(set: &str) -> Output {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("c.toml");
    std::fs::write(&file, "").unwrap();
    planemap()
        .arg("config")
        .arg("--check")
        .arg(&file)
        .args(["--set", set])
        .output()
        .unwrap()
}

#[test]
fn set_accepts_keys_whose_default_is_empty() {
    let stdout = success(&config_set("nonplanar.model=my-model.json"));
    assert!(stdout.contains("my-model.json"), "{stdout}");
}

#[test]
fn set_type_errors_name_the_key_and_the_expected_type() {
    let stderr = clean_failure(&config_set("planemap.lambda=abc"));
    assert!(
        stderr.contains("planemap.lambda") && stderr.contains("f64"),
        "{stderr}"
    );
    let stderr = clean_failure(&config_set("planemap.max_labels=18446744073709551616"));
    assert!(stderr.contains("planemap.max_labels"), "{stderr}");
    // A file that is not a configuration at all is named.
    let stderr = clean_failure(&config_check("planemap.lambda=1"));
    assert!(stderr.contains("Cargo.toml"), "{stderr}");
}

#[test]
fn cost_scale_has_an_upper_bound() {
    let stderr = clean_failure(&config_set("solver.cost_scale=1e300"));
    assert!(
        stderr.contains("solver.cost_scale") && stderr.contains("1e300"),
        "{stderr}"
    );
    success(&config_set("solver.cost_scale=1e6"));
}

// --- 11. messages -----------------------------------------------------------------------------

#[test]
fn error_chains_are_printed_once() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let config = tmp.path().join("bad.toml");
    std::fs::write(&config, "lambda\n").unwrap();
    let config_arg = config.to_str().unwrap();
    let stderr = clean_failure(&run(
        &dir,
        &tmp.path().join("out"),
        &["--config", config_arg],
    ));
    assert!(stderr.contains("bad.toml:1"), "{stderr}");
    assert_eq!(
        stderr.matches("expected `=`").count(),
        1,
        "a cause printed more than once:\n{stderr}"
    );
}

#[test]
fn classify_train_refuses_data_with_one_class() {
    // The demo scene is all planar: no non-planar cell to learn from.
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let model = tmp.path().join("model.json");
    let stderr = clean_failure(
        &planemap()
            .args(["-q", "classify", "train"])
            .arg(&dir)
            .arg("-o")
            .arg(&model)
            .output()
            .unwrap(),
    );
    assert!(stderr.contains("non-planar"), "{stderr}");
    assert!(!model.exists());
}

// --- 12. real-capture needs: progress lines, the undistorted model, one no-depth value -------

#[test]
fn piped_progress_prints_a_line_per_stage_and_view() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let out = run(&dir, &tmp.path().join("out"), &["--views", "0,1"]);
    success(&out);
    let (_, stderr) = text(&out);
    assert!(!stderr.contains('\u{1b}'), "{stderr:?}");
    for expected in [
        "global stages: 1/4",
        "global stages: done",
        "planemaps: 1/2",
        "planemaps: 2/2",
    ] {
        assert!(stderr.contains(expected), "no {expected:?} in\n{stderr}");
    }
    // The hypothesis counts the progress reports agree with the final line.
    assert!(stderr.contains("plane hypotheses"), "{stderr}");
}

#[test]
fn run_writes_the_undistorted_camera_model_beside_stereo() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    text_demo(&dir);
    let out = tmp.path().join("out");
    success(&run(&dir, &out, &["-q", "--views", "0"]));
    let cams = std::fs::read_to_string(out.join("sparse/cameras.txt")).unwrap();
    let line = cams.lines().find(|l| !l.starts_with('#')).unwrap();
    let fields: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(fields[1], "PINHOLE", "{cams}");
    assert_eq!(&fields[2..4], ["96", "72"]);
    for f in ["cameras.bin", "images.bin", "points3D.bin"] {
        assert!(out.join("sparse").join(f).is_file());
    }
    // The written model is read back by the project's own reader with the same view count.
    let info = planemap()
        .arg("info")
        .arg(out.join("sparse"))
        .arg("--images")
        .arg(dir.join("images"))
        .output()
        .unwrap();
    let stdout = success(&info);
    assert!(stdout.contains("images: 7"), "{stdout}");
}

#[test]
fn sweep_and_run_mark_missing_depth_with_zero() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("scene");
    synth_tiny_demo(&dir);
    let out = tmp.path().join("sweep");
    success(
        &planemap()
            // View 6 has pixels no neighbour sees: the sweep has no depth there.
            .args(["-q", "sweep", "--views", "6", "--model"])
            .arg(dir.join("sparse"))
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap(),
    );
    let depth = read_pfm(&out.join("depth/view_0006.pfm"));
    assert_eq!(depth.len(), 96 * 72);
    assert!(depth.iter().all(|d| d.is_finite() && *d >= 0.0));
    assert!(depth.contains(&0.0), "no pixel without depth?");
}
