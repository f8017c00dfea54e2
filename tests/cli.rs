//! End-to-end tests of the `planemap` binary on tiny synthetic scenes.

use planemap::io::colmap::read_model;
use planemap::io::labelpng::read_label_png;
use planemap::io::pfm::read_pfm_path;

mod common;
use common::{planemap, synth_tiny_demo as synth_demo};

#[test]
fn synth_writes_a_consistent_workspace() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    synth_demo(&dir);
    let model = read_model(&dir.join("sparse")).unwrap();
    let scene = model.to_scene(Some(&dir.join("images"))).unwrap();
    assert!(scene.views.len() >= 4);
    assert!(scene.cloud.len() >= 50, "{} points", scene.cloud.len());
    for view in &scene.views {
        assert_eq!((view.camera.width, view.camera.height), (96, 72));
        let img = view.load_image().unwrap();
        assert_eq!(img.len_pixels(), 96 * 72);
        let stem = view.name.trim_end_matches(".png");
        let depth = read_pfm_path(&dir.join(format!("gt/depth/{stem}.pfm"))).unwrap();
        assert_eq!((depth.width, depth.height, depth.channels), (96, 72, 1));
        let (w, h, ids) = read_label_png(&dir.join(format!("gt/planes/{stem}.png"))).unwrap();
        assert_eq!((w, h, ids.len()), (96, 72, 96 * 72));
        // Textured-surface truth: 0/1, never on background.
        let (w, h, tex) = read_label_png(&dir.join(format!("gt/texture/{stem}.png"))).unwrap();
        assert_eq!((w, h, tex.len()), (96, 72, 96 * 72));
        assert!(tex.iter().all(|&t| t <= 1));
        assert!(tex
            .iter()
            .zip(&depth.data)
            .all(|(&t, &z)| t == 0 || z > 0.0));
        assert!(tex.contains(&1));
    }
    // Sparse points lie on the ground-truth surface of the views that see them (within the
    // configured noise), outliers aside: most of them agree with gt depth to 2%.
    let mut agree = 0usize;
    let mut total = 0usize;
    for (i, p) in scene.cloud.positions.iter().enumerate() {
        let v = &scene.views[scene.cloud.tracks[i][0] as usize];
        let (xy, z) = v.project(p).unwrap();
        let stem = v.name.trim_end_matches(".png");
        let depth = read_pfm_path(&dir.join(format!("gt/depth/{stem}.pfm"))).unwrap();
        let (x, y) = (xy.x as u32, xy.y as u32);
        if x < 96 && y < 72 {
            total += 1;
            let gz = depth.get(x, y, 0) as f64;
            if (gz - z).abs() <= 0.02 * gz {
                agree += 1;
            }
        }
    }
    assert!(agree as f64 >= 0.85 * total as f64, "{agree}/{total}");
    let planes: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("gt/planes.json")).unwrap())
            .unwrap();
    assert!(planes.as_array().unwrap().len() >= 5);
}

#[test]
fn sweep_baseline_writes_depths_and_scores_them() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    synth_demo(&dir);
    let out_dir = tmp.path().join("sweep");
    let out = planemap()
        .args(["-q", "sweep", "--views", "0,3", "-o"])
        .arg(&out_dir)
        .arg("--model")
        .arg(dir.join("sparse"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for stem in ["view_0000", "view_0003"] {
        let depth = read_pfm_path(&out_dir.join(format!("depth/{stem}.pfm"))).unwrap();
        assert_eq!((depth.width, depth.height), (96, 72));
    }
    assert!(!out_dir.join("depth/view_0001.pfm").exists());
    // Both texture splits are reported; on the textured surfaces of the ground truth the
    // 96×72 sweep is within 1 % on about 70 % of the pixels.
    assert!(stdout.contains("textured pixels"), "{stdout}");
    // "textured surfaces X% (of N)", on every textured surface and on the covisible ones.
    let split = |line: &str| -> (f64, u64) {
        let rest = line.split("textured surfaces ").nth(1).unwrap_or("");
        let share = rest.split('%').next().and_then(|v| v.parse().ok());
        let count = rest
            .split("(of ")
            .nth(1)
            .and_then(|r| r.split(')').next())
            .and_then(|v| v.parse().ok());
        share
            .zip(count)
            .unwrap_or_else(|| panic!("unparsable: {line}"))
    };
    let lines: Vec<&str> = stdout
        .lines()
        .filter(|l| l.contains("textured surfaces"))
        .collect();
    assert_eq!(lines.len(), 2, "{stdout}");
    assert!(lines[1].contains("covisible"), "{stdout}");
    let (all, n_all) = split(lines[0]);
    let (seen, n_seen) = split(lines[1]);
    assert!(all >= 60.0, "{stdout}");
    // Covisible pixels are a strict subset, and stereo does better on them.
    assert!(
        n_seen < n_all && n_seen as f64 > 0.5 * n_all as f64,
        "{stdout}"
    );
    assert!(seen >= all, "{stdout}");

    let bad = planemap()
        .args(["-q", "sweep", "--views", "0,42", "-o"])
        .arg(&out_dir)
        .arg("--model")
        .arg(dir.join("sparse"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("view index 42") && err.contains("7 views"),
        "{err}"
    );
}

#[test]
fn info_reports_the_model() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("demo");
    synth_demo(&dir);
    let out = planemap()
        .arg("info")
        .arg(dir.join("sparse"))
        .arg("--images")
        .arg(dir.join("images"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("images: "), "{text}");
    assert!(text.contains("warnings: none"), "{text}");
    // Remove an image: info must warn and name it.
    let first = std::fs::read_dir(dir.join("images"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    std::fs::remove_file(&first).unwrap();
    let out = planemap()
        .arg("info")
        .arg(dir.join("sparse"))
        .arg("--images")
        .arg(dir.join("images"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let name = first.file_name().unwrap().to_string_lossy();
    assert!(text.contains(&*name), "{text}");
}

#[test]
fn bad_scene_file_fails_with_the_line() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("bad.toml");
    let text = std::fs::read_to_string("scenes/demo.toml").unwrap();
    // Break a value somewhere past the first line.
    let broken = text.replacen(" = ", " = = ", 3);
    std::fs::write(&scene, broken).unwrap();
    let out = planemap()
        .arg("synth")
        .arg(&scene)
        .arg("-o")
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.toml"), "{err}");
    assert!(err.contains("line") || err.contains(":"), "{err}");
}

#[test]
fn bad_model_fails_without_panic() {
    let tmp = tempfile::tempdir().unwrap();
    std::fs::write(tmp.path().join("cameras.txt"), "1 FISHEYE 10 10 1 2 3\n").unwrap();
    std::fs::write(tmp.path().join("images.txt"), "").unwrap();
    std::fs::write(tmp.path().join("points3D.txt"), "").unwrap();
    let out = planemap().arg("info").arg(tmp.path()).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("cameras.txt") && err.contains("FISHEYE"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}
