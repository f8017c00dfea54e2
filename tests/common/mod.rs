//! Shared helpers of the integration tests.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// The `planemap` binary under test: this crate's, or the one `PLANEMAP_BIN` names (to run a
/// regression suite against an older build and see its tests fail there).
pub fn planemap() -> Command {
    match std::env::var_os("PLANEMAP_BIN") {
        Some(bin) => Command::new(bin),
        None => Command::new(env!("CARGO_BIN_EXE_planemap")),
    }
}

/// Renders the demo scene at 96×72 into `dir` with `planemap synth`.
pub fn synth_tiny_demo(dir: &Path) {
    let out = planemap()
        .args([
            "-q",
            "synth",
            "scenes/demo.toml",
            "--width",
            "96",
            "--height",
            "72",
            "-o",
        ])
        .arg(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "synth failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

pub fn text(out: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A failure the program reported itself: an exit code (not a signal such as SIGABRT), no
/// panic. Returns stderr.
pub fn clean_failure(out: &Output) -> String {
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

pub fn success(out: &Output) -> String {
    let (stdout, stderr) = text(out);
    assert!(
        out.status.success(),
        "expected success\nstdout: {stdout}\nstderr: {stderr}"
    );
    stdout
}
