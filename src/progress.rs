//! Progress reporting for long stages: an indicatif bar on a terminal, `tracing` log lines
//! otherwise, nothing when quiet. Library stages take a [`Progress`] so the CLI and library
//! users see the same thing.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Where progress goes: bars on a terminal, log lines otherwise, or nowhere.
#[derive(Clone)]
pub struct Progress {
    multi: Option<MultiProgress>,
    log: bool,
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Progress")
            .field("bars", &self.multi.is_some())
            .field("log", &self.log)
            .finish()
    }
}

impl Progress {
    /// Bars when stderr is a terminal, else `tracing` lines at stage ends. `quiet` silences
    /// both.
    pub fn new(quiet: bool) -> Self {
        if quiet {
            return Self::hidden();
        }
        let terminal = std::io::stderr().is_terminal();
        Progress {
            multi: terminal.then(|| MultiProgress::with_draw_target(ProgressDrawTarget::stderr())),
            log: true,
        }
    }

    /// Reports nothing (tests, library users who do not want output).
    pub fn hidden() -> Self {
        Progress {
            multi: None,
            log: false,
        }
    }

    /// A bar for a stage of `len` steps.
    pub fn bar(&self, len: u64, stage: &str) -> Bar {
        let pb = self.multi.as_ref().map(|m| {
            let pb = m.add(ProgressBar::new(len));
            pb.set_style(
                ProgressStyle::with_template(
                    "{msg:>14} [{bar:32}] {pos}/{len} {elapsed_precise} eta {eta}",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
            );
            pb.set_message(stage.to_string());
            pb.enable_steady_tick(Duration::from_millis(200));
            pb
        });
        Bar {
            pb,
            stage: stage.to_string(),
            log: self.log,
            start: Instant::now(),
        }
    }

    /// Prints a line above the bars (or logs it).
    pub fn println(&self, line: &str) {
        match &self.multi {
            Some(m) => {
                let _ = m.println(line);
            }
            None if self.log => tracing::info!("{line}"),
            None => {}
        }
    }
}

/// One stage's progress; thread-safe (`inc` from rayon workers).
pub struct Bar {
    pb: Option<ProgressBar>,
    stage: String,
    log: bool,
    start: Instant,
}

impl Bar {
    /// Advances by `n` steps.
    pub fn inc(&self, n: u64) {
        if let Some(pb) = &self.pb {
            pb.inc(n);
        }
    }

    /// Ends the stage and returns its wall time.
    pub fn finish(self) -> Duration {
        let elapsed = self.start.elapsed();
        if let Some(pb) = &self.pb {
            pb.finish_and_clear();
        }
        if self.log {
            tracing::info!(stage = %self.stage, seconds = elapsed.as_secs_f64(), "stage done");
        }
        elapsed
    }
}
