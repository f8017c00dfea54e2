//! Generated scenes end to end: `planemap synth --generate` writes a scene file that
//! reproduces its workspace byte for byte, on any number of threads, and `planemap bench
//! --generated` scores generated scenes under their own heading.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod common;
use common::planemap;

/// Every file under `dir` (relative path → bytes).
fn files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                out.insert(
                    p.strip_prefix(root).unwrap().to_path_buf(),
                    std::fs::read(&p).unwrap(),
                );
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

fn run(args: &[&str], out: &Path, threads: Option<&str>) -> String {
    let mut cmd = planemap();
    cmd.arg("-q").args(args).arg("-o").arg(out);
    if let Some(t) = threads {
        cmd.env("RAYON_NUM_THREADS", t);
    }
    let o = cmd.output().unwrap();
    assert!(
        o.status.success(),
        "{args:?} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

const TINY: [&str; 4] = ["--width", "96", "--height", "72"];

#[test]
fn the_written_scene_renders_the_same_workspace() {
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    let stdout = run(
        &[
            &["synth", "--generate", "pavilion", "--seed", "3"],
            &TINY[..],
        ]
        .concat(),
        &a,
        None,
    );
    assert!(
        stdout.contains("generated pavilion seed 3 (development split)"),
        "{stdout}"
    );
    let scene = a.join("scene.toml");
    let text = std::fs::read_to_string(&scene).unwrap();
    assert!(text.starts_with("# pavilion-0003: a generated pavilion scene"));
    assert!(text.contains("type = \"polygon\""), "a pavilion has gables");
    run(&["synth", scene.to_str().unwrap()], &b, None);
    let (mut fa, fb) = (files(&a), files(&b));
    assert!(fa.remove(Path::new("scene.toml")).is_some());
    assert_eq!(
        fa.keys().collect::<Vec<_>>(),
        fb.keys().collect::<Vec<_>>(),
        "the same files"
    );
    for (path, bytes) in &fa {
        assert!(bytes == &fb[path], "{} differs", path.display());
    }
    assert!(fa.contains_key(Path::new("gt/depth/view_0000.pfm")));
}

#[test]
fn generation_and_rendering_do_not_depend_on_the_thread_count() {
    let tmp = tempfile::tempdir().unwrap();
    let args = [&["synth", "--generate", "plaza", "--seed", "1"], &TINY[..]].concat();
    let one = tmp.path().join("one");
    let two = tmp.path().join("two");
    run(&args, &one, Some("1"));
    run(&args, &two, Some("2"));
    let (f1, f2) = (files(&one), files(&two));
    assert_eq!(f1.len(), f2.len());
    for (path, bytes) in &f1 {
        assert!(bytes == &f2[path], "{} differs", path.display());
    }
    // Another seed is another scene.
    let other = tmp.path().join("other");
    let args = [&["synth", "--generate", "plaza", "--seed", "2"], &TINY[..]].concat();
    run(&args, &other, None);
    assert_ne!(
        f1[Path::new("scene.toml")],
        files(&other)[Path::new("scene.toml")]
    );
}

/// The first row of the per-kind table for `kind` and `method`, as cells.
fn kind_row(md: &str, kind: &str, method: &str) -> Vec<String> {
    let line = md
        .lines()
        .find(|l| l.starts_with(&format!("| {kind} |")) && l.contains(&format!("| {method} |")))
        .unwrap_or_else(|| panic!("no {kind}/{method} row in {md}"));
    line.trim_matches('|')
        .split(" | ")
        .map(|c| c.trim().to_string())
        .collect()
}

#[test]
fn bench_scores_generated_scenes_under_their_own_heading() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bench");
    let stdout = run(
        &[
            "bench",
            "--generated",
            "interior:1@5",
            "--size",
            "96x72",
            "--methods",
            "sweep",
            "--no-maps",
        ],
        &out,
        None,
    );
    let md = std::fs::read_to_string(out.join("results.md")).unwrap();
    assert!(
        stdout.starts_with(&md),
        "the table printed is the one written"
    );
    assert!(
        md.starts_with("## Generated scenes: development split (seeds below 1000, for tuning)\n"),
        "only generated scenes ran, of the development split: {md}"
    );
    assert!(!md.contains("## Scene files"), "{md}");
    assert!(
        md.contains("| interior-0005 | manhattan-interior | 96×72 |"),
        "{md}"
    );
    // kind | seeds | split | method | scenes | mean | F | 10th pct | worst (name) | collapsed
    let row = kind_row(&md, "interior", "sweep");
    assert_eq!(row.len(), 10, "{row:?}");
    assert_eq!(&row[..5], ["interior", "5", "development", "sweep", "1"]);
    let num = |c: &str| -> f64 {
        c.split(' ')
            .next()
            .unwrap()
            .parse()
            .unwrap_or_else(|_| panic!("{c:?} is not a number: {md}"))
    };
    let (mean, p10, worst) = (num(&row[5]), num(&row[7]), num(&row[8]));
    assert!(
        (0.0..=100.0).contains(&mean) && worst <= p10 && p10 <= 100.0,
        "{row:?}"
    );
    assert!(
        row[8].contains("(interior-0005/view_"),
        "the worst view is named: {row:?}"
    );
    assert_eq!(row[9], "–", "the sweep has no plane labels to collapse");

    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 1);
    assert_eq!(scenes[0]["generated"]["kind"], "interior");
    assert_eq!(scenes[0]["generated"]["seed"], 5);
    assert_eq!(scenes[0]["generated"]["split"], "development");
    // Per-view figures for the percentile and worst-view columns.
    let views = scenes[0]["methods"][0]["views"].as_array().unwrap();
    assert_eq!(views.len() as u64, scenes[0]["views"].as_u64().unwrap());
    // The same summary in results.json, under its own key.
    let kind = &json["generated"]["kinds"][0];
    assert_eq!(
        (kind["kind"].as_str(), kind["method"].as_str()),
        (Some("interior"), Some("sweep"))
    );
    let json_mean = 100.0 * kind["mean_within_1pct"].as_f64().unwrap();
    assert!((json_mean - mean).abs() <= 0.05, "{json_mean} vs {mean}");
    assert!(kind["collapses"].is_null());
    assert!(out.join("generated/interior-0005.toml").is_file());
}

#[test]
fn bench_record_keeps_the_readme_table_to_the_scene_files() {
    let tmp = tempfile::tempdir().unwrap();
    let root = tmp.path();
    let readme = "# x\n\n<!-- results:begin (generated by planemap bench --record) -->\nPREVIOUS-TABLE\n<!-- results:end -->\n";
    std::fs::write(root.join("README.md"), readme).unwrap();
    let tiny = std::fs::canonicalize("scenes/tiny.toml").unwrap();
    let o = planemap()
        .current_dir(root)
        .args(["-q", "bench"])
        .arg(&tiny)
        .args([
            "--generated",
            "interior:1@5",
            "--size",
            "tiny",
            "--methods",
            "sweep",
            "--no-maps",
            "--record",
            "--results-dir",
            "runs",
            "-o",
            "out",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let md = std::fs::read_to_string(root.join("out/results.md")).unwrap();
    assert!(md.starts_with("## Scene files") && md.contains("## Generated scenes: "));
    let after = std::fs::read_to_string(root.join("README.md")).unwrap();
    assert!(after.contains("| tiny | test | 96×72 |"), "{after}");
    assert!(
        !after.contains("interior-0005") && !after.contains("PREVIOUS-TABLE"),
        "{after}"
    );
}

#[test]
fn bad_generated_specs_are_clear_errors() {
    let tmp = tempfile::tempdir().unwrap();
    for (spec, why) in [
        ("foo:3", "unknown kind \"foo\""),
        ("all:0", "COUNT must be at least 1"),
        ("interior:2@abc", "FIRST_SEED \"abc\" is not a number"),
        ("interior", "no ':'"),
    ] {
        let o = planemap()
            .args(["-q", "bench", "--generated", spec, "-o"])
            .arg(tmp.path().join("x"))
            .output()
            .unwrap();
        assert!(!o.status.success(), "{spec} was accepted");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(&format!("bad --generated \"{spec}\"")) && err.contains(why),
            "{spec}: {err}"
        );
        // The error says what is expected.
        assert!(
            err.contains("KIND:COUNT[@FIRST_SEED]") && err.contains("interior, hall, street"),
            "{err}"
        );
    }
    // Nothing was run, nor drawn.
    assert!(!tmp.path().join("x/generated").exists());
}

#[test]
fn a_scene_file_named_like_a_generated_scene_is_refused_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string("scenes/tiny.toml")
        .unwrap()
        .replacen("name = \"tiny\"", "name = \"hall-0002\"", 1);
    assert!(text.contains("name = \"hall-0002\""));
    let file = tmp.path().join("mine.toml");
    std::fs::write(&file, text).unwrap();
    let o = planemap()
        .args(["-q", "bench"])
        .arg(&file)
        .args(["--generated", "hall:2@1", "--methods", "sweep", "-o"])
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("mine.toml") && err.contains("hall-0002"),
        "{err}"
    );
    assert!(!tmp
        .path()
        .join("out/cache")
        .read_dir()
        .unwrap()
        .any(|_| true));
}

#[test]
fn unknown_kinds_are_errors_that_list_the_kinds() {
    let tmp = tempfile::tempdir().unwrap();
    for args in [
        vec!["synth", "--generate", "castle"],
        vec!["bench", "--generated", "castle:2"],
    ] {
        let o = planemap()
            .arg("-q")
            .args(&args)
            .arg("-o")
            .arg(tmp.path().join("x"))
            .output()
            .unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains("castle") && err.contains("pavilion"), "{err}");
    }
}
