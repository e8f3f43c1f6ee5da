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

/// How far back [`RecentRate`] looks: long enough to span several tiles, short enough that the
/// costly centre of a frame (rendered first) soon drops out of the estimate.
pub const RECENT: Duration = Duration::from_secs(30);

/// The time to go at the pace of the most recent work rather than of the whole run: tiles are
/// rendered centre first, where the objects (and the cost) are, so the rate so far undercounts
/// the cheap outer tiles still to come (a job's whole-run ETA was 25 times too long near its
/// end). The pace is measured over the last [`RECENT`], and over at least [`RecentRate::MIN_STEPS`]
/// steps when fewer came in that time.
#[derive(Debug, Default)]
pub struct RecentRate {
    /// `(when, done)`, oldest first, `done` increasing.
    samples: std::collections::VecDeque<(Instant, u64)>,
}

impl RecentRate {
    /// The fewest completions the pace is measured over.
    pub const MIN_STEPS: u64 = 4;

    /// `done` counted at `now`.
    pub fn record(&mut self, now: Instant, done: u64) {
        if self.samples.back().is_some_and(|&(_, d)| d >= done) {
            return;
        }
        self.samples.push_back((now, done));
        // Drop samples older than the window while the rest still span enough steps.
        while self.samples.len() > 2 {
            let (t1, d1) = self.samples[1];
            if now.saturating_duration_since(t1) < RECENT || done - d1 < Self::MIN_STEPS {
                break;
            }
            self.samples.pop_front();
        }
    }

    /// The time to go until `total`, at the recent pace; unknown before two counts.
    pub fn eta(&self, total: u64) -> Option<Duration> {
        let (&(t0, d0), &(t1, d1)) = (self.samples.front()?, self.samples.back()?);
        if d1 <= d0 {
            return None;
        }
        let per_step = t1.saturating_duration_since(t0).as_secs_f64() / (d1 - d0) as f64;
        Some(Duration::from_secs_f64(
            per_step * total.saturating_sub(d1) as f64,
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
    lines: Option<Mutex<(Lines, RecentRate)>>,
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
        let lines = (show == Show::Lines).then(|| {
            let started = Instant::now();
            let mut recent = RecentRate::default();
            recent.record(started, 0);
            Mutex::new((Lines::new(what, unit, LINE_EVERY, started), recent))
        });
        Meter { bar, lines }
    }

    /// `n` more done.
    pub fn inc(&self, n: u64) {
        self.bar.inc(n);
        if let Some(lines) = &self.lines {
            let total = self.bar.length().unwrap_or(0);
            let mut lines = lines.lock().unwrap_or_else(PoisonError::into_inner);
            let (lines, recent) = &mut *lines;
            let (now, done) = (Instant::now(), self.bar.position());
            recent.record(now, done);
            if let Some(line) = lines.due(now, done, total, recent.eta(total)) {
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

    /// Ten costly tiles over 100 s, then one a second: at 150 s (60 of 100 done) the recent pace
    /// gives the true 40 s to go, where the rate over the whole run says 100 s.
    #[test]
    fn the_eta_follows_the_recent_pace_not_the_costly_start() {
        let t0 = Instant::now();
        let s = Duration::from_secs;
        let mut recent = RecentRate::default();
        recent.record(t0, 0);
        assert_eq!(recent.eta(100), None, "nothing done yet");
        for i in 1..=10 {
            recent.record(t0 + s(10 * i), i);
        }
        assert_eq!(
            recent.eta(100),
            Some(s(900)),
            "10 s a tile so far, 90 to go"
        );
        for i in 11..=60 {
            recent.record(t0 + s(100 + (i - 10)), i);
        }
        assert_eq!(recent.eta(100), Some(s(40)));
        assert_eq!(eta_from_rate(s(150), 60, 100), Some(s(100)));
    }

    /// Fewer than MIN_STEPS completions in the window: the pace spans the last MIN_STEPS.
    #[test]
    fn a_slow_pace_is_measured_over_several_steps() {
        let t0 = Instant::now();
        let s = Duration::from_secs;
        let mut recent = RecentRate::default();
        for i in 0..=6 {
            recent.record(t0 + s(60 * i), i);
        }
        assert_eq!(recent.eta(10), Some(s(4 * 60)), "a minute a step, 4 to go");
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
