//! The `planemap` binary on malformed or hostile inputs (issue 42): every case must end with
//! a clear error naming the file and what was expected (or a warning from `info`), never a
//! panic, an abort or a silent run that writes garbage.

use std::process::Output;

mod common;
use common::planemap;

fn text(out: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A failure the program reported itself: an exit code (not a signal such as SIGABRT), no
/// panic. Returns stderr.
fn clean_failure(out: &Output) -> String {
    let (stdout, stderr) = text(out);
    assert!(
        !out.status.success(),
        "expected a failure\nstdout: {stdout}\nstderr: {stderr}"
    );
    assert!(
        out.status.code().is_some(),
        "killed by a signal ({:?}), not an error\nstderr: {stderr}",
        out.status
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

// --- 7. synth sizes --------------------------------------------------------------------

#[test]
fn synth_with_a_huge_width_is_an_error_not_an_abort() {
    let tmp = tempfile::tempdir().unwrap();
    let out = planemap()
        .args(["-q", "synth", "scenes/demo.toml", "--width", "100000", "-o"])
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    let err = clean_failure(&out);
    assert!(
        err.contains("requested width 100000") && err.contains("limit of 16384"),
        "{err}"
    );
}

#[test]
fn synth_with_a_billion_cameras_is_an_error_not_an_abort() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = tmp.path().join("many.toml");
    let text = std::fs::read_to_string("scenes/demo.toml").unwrap();
    std::fs::write(&scene, text.replacen("count = 7", "count = 1000000000", 1)).unwrap();
    let out = planemap()
        .args(["-q", "synth"])
        .arg(&scene)
        .arg("-o")
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    let err = clean_failure(&out);
    assert!(
        err.contains("many.toml")
            && err.contains("rigs[0]")
            && err.contains("1000000000 views")
            && err.contains("limit of 10000"),
        "{err}"
    );
}
