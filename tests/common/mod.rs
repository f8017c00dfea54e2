//! Shared helpers of the integration tests.
#![allow(dead_code)]

use std::path::Path;
use std::process::Command;

/// The `planemap` binary under test.
pub fn planemap() -> Command {
    Command::new(env!("CARGO_BIN_EXE_planemap"))
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
