//! Progress on long runs: a bar on a terminal, plain periodic lines otherwise.

use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// Counts poses done and shows it in whichever way suits stderr.
struct Progress {
    bar: Option<ProgressBar>,
    total: u64,
    start: Instant,
    log: Mutex<(Instant, u64)>,
    quiet: bool,
}

const LOG_EVERY: Duration = Duration::from_secs(10);

impl Progress {
    /// `quiet` shows nothing (benchmarks, tests).
    fn new(total: u64, already_done: u64, quiet: bool) -> Self {
        let now = Instant::now();
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr_with_hz(4));
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:40.cyan/blue} {human_pos}/{human_len} poses  {per_sec}  ETA {eta}  {msg}",
                )
                .expect("a valid template")
                .progress_chars("=> "),
            );
            bar.set_position(already_done);
            bar
        });
        Self { bar, total, start: now, log: Mutex::new((now, already_done)), quiet }
    }
}

/// The engine's progress, on stderr; nothing when `quiet`.
pub struct Display {
    quiet: bool,
    progress: Mutex<Option<Progress>>,
}

impl Display {
    pub fn new(quiet: bool) -> Self {
        Self { quiet, progress: Mutex::new(None) }
    }

    fn with(&self, f: impl FnOnce(&Progress)) {
        if let Some(p) = self.progress.lock().expect("progress lock").as_ref() {
            f(p);
        }
    }
}

impl clearance_engine::Progress for Display {
    fn start(&self, total: u64, done: u64) {
        *self.progress.lock().expect("progress lock") = Some(Progress::new(total, done, self.quiet));
    }

    fn stage(&self, what: &str) {
        self.with(|p| {
            if let Some(bar) = &p.bar {
                bar.set_message(what.to_string());
            }
        });
    }

    fn advance(&self, n: u64, done: u64) {
        self.with(|p| p.advance(n, done));
    }

    fn finish(&self) {
        self.with(|p| p.finish());
    }

    fn searching(&self) {
        self.with(|p| p.finish());
        if !self.quiet {
            eprintln!("searching for discontinuities and summarising ...");
        }
    }
}

impl Progress {
    /// Adds `n` finished poses; `done` is the new total.
    fn advance(&self, n: u64, done: u64) {
        if let Some(bar) = &self.bar {
            bar.inc(n);
            return;
        }
        if self.quiet {
            return;
        }
        let mut log = self.log.lock().expect("progress lock");
        let now = Instant::now();
        if now.duration_since(log.0) >= LOG_EVERY || done == self.total {
            let elapsed = now.duration_since(self.start).as_secs_f64();
            let rate = (done - log.1) as f64 / now.duration_since(log.0).as_secs_f64().max(1e-9);
            let eta = if rate > 0.0 { (self.total - done) as f64 / rate } else { f64::INFINITY };
            eprintln!(
                "progress: {done}/{} poses ({:.1}%), {:.0} poses/s, elapsed {:.0} s, ETA {:.0} s",
                self.total,
                100.0 * done as f64 / self.total.max(1) as f64,
                rate,
                elapsed,
                eta
            );
            *log = (now, done);
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}
