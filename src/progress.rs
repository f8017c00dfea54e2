//! Progress reporting for long stages: an indicatif bar on a terminal, plain lines on
//! stderr otherwise (one per step and per stage), nothing when quiet. Library stages take a
//! [`Progress`] so the CLI and library users see the same thing.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Where progress goes: bars on a terminal, plain lines otherwise, or nowhere.
#[derive(Clone)]
pub struct Progress {
    mode: Mode,
}

#[derive(Clone)]
enum Mode {
    /// indicatif bars on stderr (a terminal).
    Bars(MultiProgress),
    /// One line on stderr per step and per stage (a log file, a batch job).
    Lines,
    /// Nothing.
    Hidden,
}

impl std::fmt::Debug for Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mode = match self.mode {
            Mode::Bars(_) => "bars",
            Mode::Lines => "lines",
            Mode::Hidden => "hidden",
        };
        f.debug_struct("Progress").field("mode", &mode).finish()
    }
}

impl Progress {
    /// Bars when stderr is a terminal; otherwise one plain line per step (a view) and per
    /// stage, so that a batch job's log shows where a long run is. `quiet` silences both.
    pub fn new(quiet: bool) -> Self {
        if quiet {
            return Self::hidden();
        }
        if std::io::stderr().is_terminal() {
            Progress {
                mode: Mode::Bars(MultiProgress::with_draw_target(ProgressDrawTarget::stderr())),
            }
        } else {
            Self::lines()
        }
    }

    /// Plain lines on stderr, whatever stderr is.
    pub fn lines() -> Self {
        Progress { mode: Mode::Lines }
    }

    /// Reports nothing (tests, library users who do not want output).
    pub fn hidden() -> Self {
        Progress { mode: Mode::Hidden }
    }

    /// A bar for a stage of `len` steps.
    pub fn bar(&self, len: u64, stage: &str) -> Bar {
        let pb = match &self.mode {
            Mode::Bars(m) => {
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
                Some(pb)
            }
            _ => None,
        };
        Bar {
            pb,
            stage: stage.to_string(),
            lines: matches!(self.mode, Mode::Lines),
            len,
            pos: AtomicU64::new(0),
            last_line_ms: AtomicU64::new(0),
            start: Instant::now(),
        }
    }

    /// Prints a line above the bars, or as a line of the log.
    pub fn println(&self, line: &str) {
        match &self.mode {
            Mode::Bars(m) => {
                let _ = m.println(line);
            }
            Mode::Lines => eprintln!("{line}"),
            Mode::Hidden => {}
        }
    }
}

/// One stage's progress; thread-safe (`inc` from rayon workers).
pub struct Bar {
    pb: Option<ProgressBar>,
    stage: String,
    lines: bool,
    len: u64,
    pos: AtomicU64,
    last_line_ms: AtomicU64,
    start: Instant,
}

/// Stages of more steps than this print at most a line a second in line mode.
const LINES_UNTHROTTLED: u64 = 200;

impl Bar {
    /// Advances by `n` steps.
    pub fn inc(&self, n: u64) {
        if let Some(pb) = &self.pb {
            pb.inc(n);
        }
        if self.lines {
            let pos = self.pos.fetch_add(n, Ordering::Relaxed) + n;
            let ms = self.start.elapsed().as_millis() as u64;
            let last = self.last_line_ms.load(Ordering::Relaxed);
            if self.len <= LINES_UNTHROTTLED || pos >= self.len || ms >= last + 1000 {
                self.last_line_ms.store(ms, Ordering::Relaxed);
                eprintln!(
                    "{}: {pos}/{} ({:.1} s)",
                    self.stage,
                    self.len,
                    ms as f64 / 1000.0
                );
            }
        }
    }

    /// Ends the stage and returns its wall time.
    pub fn finish(self) -> Duration {
        let elapsed = self.start.elapsed();
        if let Some(pb) = &self.pb {
            pb.finish_and_clear();
        }
        if self.lines {
            eprintln!("{}: done in {:.1} s", self.stage, elapsed.as_secs_f64());
        }
        tracing::debug!(stage = %self.stage, seconds = elapsed.as_secs_f64(), "stage done");
        elapsed
    }
}
