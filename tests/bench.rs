//! End-to-end test of `planemap bench` on the tiny scene (96×72, five views).

use std::path::PathBuf;

mod common;
use common::planemap;

fn results(dir: &std::path::Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("results.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn bench_runs_methods_on_the_tiny_scene_and_caches_the_render() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bench");
    let cache = tmp.path().join("cache");
    let run = || {
        let o = planemap()
            .args(["-q", "bench", "scenes/tiny.toml", "-o"])
            .arg(&out)
            .arg("--cache")
            .arg(&cache)
            .args(["--methods", "planemap,delaunay"])
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "bench failed: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8(o.stdout).unwrap()
    };
    let stdout = run();
    // The table is printed and written.
    assert!(stdout.contains("| tiny | test | 96×72 | 5 |"), "{stdout}");
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(md.contains("| tiny | planemap |") && md.contains("| tiny | delaunay |"));
    for f in ["accuracy.png", "time.png", "maps/tiny/view_0000.png"] {
        let img = image::open(out.join(f)).unwrap();
        assert!(img.width() > 96, "{f}");
    }
    let r = results(&out);
    let scene = &r["scenes"][0];
    assert_eq!(scene["name"], "tiny");
    assert_eq!(scene["views"], 5);
    assert_eq!(scene["cache_hit"], false);
    let methods = scene["methods"].as_array().unwrap();
    assert_eq!(methods.len(), 2);
    let acc = |m: &serde_json::Value, k: usize| {
        m["depth"]["within"][k].as_f64().unwrap() / m["depth"]["gt_pixels"].as_f64().unwrap()
    };
    let (pm, dl) = (&methods[0], &methods[1]);
    assert_eq!(pm["method"], "planemap");
    assert!(pm["error"].is_null() && dl["error"].is_null());
    // Thresholds nest, and planemap beats the interpolated sparse points on the plain walls.
    for m in methods {
        assert!(acc(m, 0) <= acc(m, 1) && acc(m, 1) <= acc(m, 2));
    }
    assert!(acc(pm, 1) > 0.6, "planemap depth within 1%: {}", acc(pm, 1));
    assert!(acc(pm, 1) > acc(dl, 1) + 0.2);
    // planemap labels every pixel with a plane; Delaunay covers only the points' hull.
    assert_eq!(pm["depth"]["predicted"], pm["depth"]["gt_pixels"]);
    assert!(dl["depth"]["predicted"].as_u64() < dl["depth"]["gt_pixels"].as_u64());
    assert!(pm["segmentation"]["correct"].as_u64().unwrap() > 0);
    assert!(dl["segmentation"].is_null());
    let f = pm["cloud"]["f_score"].as_f64().unwrap();
    assert!(f > 0.5 && f <= 1.0, "F = {f}");
    assert!(!pm["stages"].as_array().unwrap().is_empty());

    // A second run reuses the render and reproduces the scores exactly.
    let before = r.clone();
    run();
    let again = results(&out);
    assert_eq!(again["scenes"][0]["cache_hit"], true);
    for k in 0..2 {
        assert_eq!(
            again["scenes"][0]["methods"][k]["depth"],
            before["scenes"][0]["methods"][k]["depth"]
        );
    }
}

#[test]
fn bench_rejects_unknown_methods_and_sizes() {
    let tmp = tempfile::tempdir().unwrap();
    let out: PathBuf = tmp.path().join("b");
    for args in [["--methods", "colmap"], ["--size", "huge"]] {
        let o = planemap()
            .args(["-q", "bench", "scenes/tiny.toml", "-o"])
            .arg(&out)
            .args(args)
            .output()
            .unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(args[1]), "{err}");
    }
}
