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

#[test]
fn bench_scores_generated_scenes_under_their_own_heading() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("bench");
    let stdout = run(
        &[
            "bench",
            "--generated",
            "interior:1@0",
            "--size",
            "tiny",
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
        md.starts_with("## Generated scenes"),
        "only generated scenes ran: {md}"
    );
    assert!(
        md.contains("| interior | 0 | development | sweep | 1 |"),
        "{md}"
    );
    assert!(
        md.contains("| interior-0000 | manhattan-interior | 96×72 |"),
        "{md}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 1);
    assert_eq!(scenes[0]["generated"]["kind"], "interior");
    assert_eq!(scenes[0]["generated"]["split"], "development");
    // Per-view figures for the percentile and worst-view columns.
    let views = scenes[0]["methods"][0]["views"].as_array().unwrap();
    assert_eq!(views.len() as u64, scenes[0]["views"].as_u64().unwrap());
    assert!(out.join("generated/interior-0000.toml").is_file());
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
