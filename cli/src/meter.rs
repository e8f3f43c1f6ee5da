//! How a long render shows its progress to a person: a bar redrawn in place when stderr is a
//! terminal, a line of percent done and ETA every [`LINE_EVERY`] when it is not (a log file, a
//! pipe, a CI job), and nothing with `--quiet`.
//!
//! A log gets lines rather than silence so that a render run under `nohup` or in a job
//! scheduler can be seen to be alive and how far along it is. [`Lines`] decides when a line is
//! due from the times it is given, never from a clock of its own, so its cadence is a pure
//! function of its inputs.

use std::io::IsTerminal;
use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// How often a log gets a progress line.
pub const LINE_EVERY: Duration = Duration::from_secs(10);

/// Where progress goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Show {
    /// A bar redrawn in place on stderr, a terminal.
    Bar,
    /// A line on stderr every [`LINE_EVERY`]: stderr is a file or a pipe.
    Lines,
    /// Nothing (`--quiet`).
    Nothing,
}

impl Show {
    /// What stderr can show: a bar on a terminal, else lines; nothing when `quiet`.
    pub fn on_stderr(quiet: bool) -> Show {
        if quiet {
            Show::Nothing
        } else if std::io::stderr().is_terminal() {
            Show::Bar
        } else {
            Show::Lines
        }
    }
}

/// Progress lines for a log: the first [`Lines::every`] after the start, then at most one per
/// `every`; none while the total is not known (0).
#[derive(Debug)]
pub struct Lines {
    /// What progresses (`render`, `job 3`): the start of each line.
    what: String,
    /// What is counted (`rows`, `tiles`).
    unit: &'static str,
    every: Duration,
    started: Instant,
    /// When the last line was due (the start before the first).
    last: Instant,
}

impl Lines {
    pub fn new(
        what: impl Into<String>,
        unit: &'static str,
        every: Duration,
        started: Instant,
    ) -> Self {
        Lines {
            what: what.into(),
            unit,
            every,
            started,
            last: started,
        }
    }

    /// The line to print at `now`, with `done` of `total` counted, if one is due. `eta` is the
    /// time still to go when the caller knows it better than the rate so far, which is used
    /// otherwise.
    pub fn due(
        &mut self,
        now: Instant,
        done: u64,
        total: u64,
        eta: Option<Duration>,
    ) -> Option<String> {
        if total == 0 || now.saturating_duration_since(self.last) < self.every {
            return None;
        }
        self.last = now;
        let elapsed = now.saturating_duration_since(self.started);
        let eta = eta.or_else(|| eta_from_rate(elapsed, done, total));
        let percent = 100.0 * done.min(total) as f64 / total as f64;
        Some(format!(
            "{}: {percent:.0}% ({done}/{total} {}), {} elapsed, eta {}",
            self.what,
            self.unit,
            duration(elapsed),
            eta.map_or_else(|| "unknown".to_string(), duration)
        ))
    }
}

/// The time to go if the rest goes at the rate so far; unknown before anything is done.
fn eta_from_rate(elapsed: Duration, done: u64, total: u64) -> Option<Duration> {
    if done == 0 {
        return None;
    }
    let rest = total.saturating_sub(done) as f64 / done as f64;
    Some(elapsed.mul_f64(rest))
}

/// `7 s`, `3 min 05 s`, `1 h 02 min`.
fn duration(d: Duration) -> String {
    let s = d.as_secs_f64().round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, s % 3600 / 60),
    }
}

/// Progress of a count toward a known total (the rows of an in-process render), shown as a
/// [`Show`] says. Shared by the threads that do the work.
pub struct Meter {
    bar: ProgressBar,
    lines: Option<Mutex<Lines>>,
}

impl Meter {
    pub fn new(show: Show, total: u64, what: &str, unit: &'static str) -> Meter {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden());
        if show == Show::Bar {
            bar.set_style(
                ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {percent}% eta {eta}")
                    .expect("a valid template")
                    .progress_chars("=> "),
            );
            bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        let lines = (show == Show::Lines)
            .then(|| Mutex::new(Lines::new(what, unit, LINE_EVERY, Instant::now())));
        Meter { bar, lines }
    }

    /// `n` more done.
    pub fn inc(&self, n: u64) {
        self.bar.inc(n);
        if let Some(lines) = &self.lines {
            let total = self.bar.length().unwrap_or(0);
            let mut lines = lines.lock().unwrap_or_else(PoisonError::into_inner);
            if let Some(line) = lines.due(Instant::now(), self.bar.position(), total, None) {
                eprintln!("{line}");
            }
        }
    }

    /// Removes the bar (a log keeps its lines).
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The clock is the test's: each line is due exactly `every` after the last one.
    #[test]
    fn a_log_gets_a_line_every_interval_with_percent_and_eta() {
        let t0 = Instant::now();
        let s = Duration::from_secs;
        let mut lines = Lines::new("render", "rows", s(10), t0);
        assert_eq!(
            lines.due(t0 + s(3), 10, 100, None),
            None,
            "before the interval"
        );
        assert_eq!(
            lines.due(t0 + s(10), 25, 100, None).as_deref(),
            Some("render: 25% (25/100 rows), 10 s elapsed, eta 30 s")
        );
        assert_eq!(
            lines.due(t0 + s(19), 50, 100, None),
            None,
            "9 s after the last"
        );
        assert_eq!(
            lines.due(t0 + s(20), 50, 100, Some(s(95))).as_deref(),
            Some("render: 50% (50/100 rows), 20 s elapsed, eta 1 min 35 s"),
            "the caller's ETA is used when it has one"
        );
        assert_eq!(
            lines.due(t0 + s(3725), 99, 100, None).as_deref(),
            Some("render: 99% (99/100 rows), 1 h 02 min elapsed, eta 38 s")
        );
    }

    /// Nothing done yet: the ETA is unknown, not infinite or zero; a total of 0 (not yet known)
    /// gives no line at all rather than "0/0".
    #[test]
    fn no_line_claims_progress_that_is_not_known() {
        let t0 = Instant::now();
        let s = Duration::from_secs;
        let mut lines = Lines::new("job 3", "tiles", s(10), t0);
        assert_eq!(lines.due(t0 + s(30), 0, 0, None), None);
        assert_eq!(
            lines.due(t0 + s(31), 0, 12, None).as_deref(),
            Some("job 3: 0% (0/12 tiles), 31 s elapsed, eta unknown")
        );
    }
}
