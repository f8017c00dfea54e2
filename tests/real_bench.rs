//! Real-photograph scoring end to end, on a synthetic scene dressed as a real set: `planemap
//! bench --real` runs the methods and scores them on held-out points, `planemap diag heldout`
//! scores the same run to the same figures, the sky gets no depth, and a bad held-out file is
//! an error naming it.

use std::path::Path;

use planemap::io::colmap::read_model;

mod common;
use common::planemap;

/// Renders the exterior scene at 96×72 into `ws` and writes `ws/heldout.json` from every
/// third sparse point seen by two views or more (their projections as observations): a
/// real set's layout, with held-out points whose depth is known exactly.
fn real_set(ws: &Path) -> usize {
    let o = planemap()
        .args([
            "-q",
            "synth",
            "scenes/exterior.toml",
            "--width",
            "96",
            "--height",
            "72",
            "-o",
        ])
        .arg(ws)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let scene = read_model(&ws.join("sparse"))
        .unwrap()
        .to_scene(None)
        .unwrap();
    let mut points = Vec::new();
    let mut observations = 0;
    for (i, x) in scene.cloud.positions.iter().enumerate().step_by(3) {
        let track = &scene.cloud.tracks[i];
        if track.len() < 2 {
            continue;
        }
        let obs: Vec<serde_json::Value> = track
            .iter()
            .filter_map(|&v| {
                let view = &scene.views[v as usize];
                let (xy, _) = view.project(x)?;
                view.camera
                    .contains(&xy)
                    .then(|| serde_json::json!([view.name, xy.x, xy.y]))
            })
            .collect();
        observations += obs.len();
        points.push(serde_json::json!({"id": i, "xyz": [x.x, x.y, x.z], "obs": obs}));
    }
    std::fs::write(
        ws.join("heldout.json"),
        serde_json::to_string(&points).unwrap(),
    )
    .unwrap();
    observations
}

#[test]
fn bench_real_scores_held_out_points_and_diag_agrees() {
    let tmp = tempfile::tempdir().unwrap();
    let ws = tmp.path().join("exterior");
    let observations = real_set(&ws);
    assert!(observations > 50, "{observations} observations");
    let out = tmp.path().join("out");
    let o = planemap()
        .args(["-q", "bench", "--methods", "planemap,delaunay", "--real"])
        .arg(&ws)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("Real photographs"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("real.json")).unwrap()).unwrap();
    let set = &json[0];
    assert_eq!(set["name"], "exterior");
    assert_eq!(
        set["heldout_observations"].as_u64().unwrap() as usize,
        observations
    );
    let planemap_result = &set["methods"][0];
    assert_eq!(planemap_result["method"], "planemap");
    let h = &planemap_result["heldout"];
    let within = |k: usize| h["within"][k].as_f64().unwrap() / h["observations"].as_f64().unwrap();
    // The points lie on the building and the ground, which planemap gets right.
    assert!(within(2) > 0.85, "within 5 %: {h}");
    assert!(within(0) <= within(1) && within(1) <= within(2));
    // The sky has no depth: coverage below 100 %, and the picture sheets are written.
    let coverage = planemap_result["coverage"].as_f64().unwrap();
    assert!(coverage < 0.95 && coverage > 0.3, "coverage {coverage}");
    assert!(planemap_result["planes_used"].as_u64().unwrap() >= 3);
    let agreement = &planemap_result["agreement"];
    let share = agreement["agree"].as_f64().unwrap() / agreement["overlap"].as_f64().unwrap();
    assert!(share > 0.7, "agreement {agreement}");
    assert!(out.join("real/exterior/view_0000.png").is_file());
    // diag heldout on the same run folder prints the same figures.
    let o = planemap()
        .args(["diag", "heldout"])
        .arg(&ws)
        .arg(out.join("runs/exterior/planemap"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = String::from_utf8_lossy(&o.stdout);
    let expected = format!(
        "within 1/2/5 %: {:.1} / {:.1} / {:.1}",
        100.0 * within(0),
        100.0 * within(1),
        100.0 * within(2)
    );
    assert!(text.contains(&expected), "{text}\nexpected {expected}");
}

#[test]
fn a_bad_heldout_file_is_named_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let ws = tmp.path().join("exterior");
    real_set(&ws);
    std::fs::write(ws.join("heldout.json"), "[{\"id\": 1,\n \"xyz\": [0, 0]}]").unwrap();
    let o = planemap()
        .args(["-q", "bench", "--real"])
        .arg(&ws)
        .arg("-o")
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("heldout.json") && err.contains("line 2"),
        "{err}"
    );
    assert!(!tmp.path().join("out/runs").exists(), "work started: {err}");
    // A folder without heldout.json is not a real set.
    std::fs::remove_file(ws.join("heldout.json")).unwrap();
    let o = planemap()
        .args(["-q", "diag", "heldout"])
        .arg(&ws)
        .arg(tmp.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("not a real set"),
        "{err}"
    );
}
