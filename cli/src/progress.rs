//! Following a job until it ends, with a progress bar of its tiles.
//!
//! Used by `spindle submit --wait`, `spindle status --follow` and the local farm of `spindle
//! render`. The job is followed on the coordinator's event stream rather than polled. Progress
//! goes to stderr as [`crate::meter`] says (a bar on a terminal, lines in a log); stdout stays
//! clean for scripts. A
//! coordinator that is briefly unreachable (restarting) does not end the wait: it continues
//! until the coordinator answers again or `unreachable_for` has passed without an answer.

use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use futures_util::StreamExt;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use spindle_common::protocol::{EventKind, JobInfo, JobState};

use crate::api::Api;
use crate::meter::{LINE_EVERY, Lines, RecentRate, Show};

/// How to wait.
#[derive(Debug, Clone, Copy)]
pub struct Wait {
    /// Time between polls when the coordinator offers no event stream.
    pub poll: Duration,
    /// With an event stream, the job is read anyway after this long without an event, in case
    /// the connection died without closing.
    pub quiet: Duration,
    /// Give up after the coordinator has not answered for this long.
    pub unreachable_for: Duration,
    /// Where the job's progress goes.
    pub show: Show,
    /// The job is a local render's own (`spindle render` on its embedded farm): its progress
    /// reads `render`, as with `--workers 0`, not `job N` — the farm is not the user's concern.
    pub local: bool,
}

impl Default for Wait {
    fn default() -> Self {
        Wait {
            poll: Duration::from_millis(250),
            quiet: Duration::from_secs(30),
            unreachable_for: Duration::from_secs(120),
            show: Show::on_stderr(false),
            local: false,
        }
    }
}

/// Follows job `id` until it is done, failed or cancelled, and returns its last state.
///
/// The job is read once, then followed on the coordinator's event stream (`GET /v1/events`):
/// it is read again when its state changes, at most once a second as its tiles land, and after
/// [`Wait::quiet`] without an event. The stream is opened before each read, so no change
/// between the two is missed; a broken stream is reopened from the last event id. Without a
/// stream (an older coordinator, or its cap of streams reached) the job is polled every
/// [`Wait::poll`].
pub async fn wait_for(api: &Api, id: u64, wait: Wait) -> Result<JobInfo> {
    let mut job = Followed {
        api,
        id,
        wait,
        display: JobDisplay::new(id, wait.show, wait.local),
        last_answer: Instant::now(),
        last_read: Instant::now(),
    };
    let mut last_event = None;
    let mut polling_until: Option<Instant> = None;
    loop {
        let events = if polling_until.is_some_and(|t| Instant::now() < t) {
            None
        } else {
            match api.events(last_event).await {
                Ok(events) => Some(events),
                Err(e) => {
                    tracing::debug!("no event stream ({e:#}); polling job {id}");
                    polling_until = Some(Instant::now() + wait.quiet);
                    None
                }
            }
        };
        if let Some(info) = job.read().await? {
            return Ok(info);
        }
        let Some(mut events) = events else {
            tokio::time::sleep(wait.poll).await;
            continue;
        };
        loop {
            // Woken at least every LINE_EVERY, so a log gets its line while no tile lands.
            let wake = wait.quiet.min(LINE_EVERY);
            let event = match tokio::time::timeout(wake, events.next()).await {
                Err(_no_event) => {
                    if job.last_read.elapsed() < wait.quiet {
                        job.display.print_line_if_due(Instant::now());
                        continue;
                    }
                    if let Some(info) = job.read().await? {
                        return Ok(info);
                    }
                    continue;
                }
                Ok(Some(Ok(event))) => event,
                Ok(Some(Err(e))) => {
                    tracing::debug!("{e:#}; reopening the event stream");
                    break;
                }
                Ok(None) => break,
            };
            last_event = Some(event.id);
            let read = match event.kind {
                EventKind::JobState { job: j, .. } => j == id,
                EventKind::TileDone { job: j, .. } if j == id => {
                    job.display.tile_done(Instant::now());
                    job.last_read.elapsed() >= Duration::from_secs(1)
                }
                EventKind::Reset => true,
                _ => false,
            };
            if read && let Some(info) = job.read().await? {
                return Ok(info);
            }
        }
        // The stream ended (a coordinator restarting, a dropped slow reader): reopen it soon.
        tokio::time::sleep(wait.poll).await;
    }
}

/// How a followed job's tiles are shown: a bar, drawn from the first answer about the job (its
/// tile count known: never a full bar of "0/0 tiles"), or lines for a log, or nothing.
struct JobDisplay {
    /// Counts the job's tiles whether or not it is drawn.
    bar: ProgressBar,
    /// Where the bar is to be drawn once the job's tile count is known; `None` once it is drawn
    /// or when it is not to be drawn.
    target: Option<ProgressDrawTarget>,
    lines: Option<Lines>,
    /// The coordinator's estimate of the time to go, from the last answer: its whole-run rate,
    /// used until the recent pace is known.
    eta: Option<Duration>,
    /// The pace of the tiles as they land.
    recent: RecentRate,
}

impl JobDisplay {
    fn new(id: u64, show: Show, local: bool) -> Self {
        let what = if local {
            "render".to_string()
        } else {
            format!("job {id}")
        };
        let target = (show == Show::Bar).then(ProgressDrawTarget::stderr);
        let lines = (show == Show::Lines)
            .then(|| Lines::new(what.clone(), "tiles", LINE_EVERY, Instant::now()));
        Self::drawn_on(what, target, lines)
    }

    fn drawn_on(what: String, target: Option<ProgressDrawTarget>, lines: Option<Lines>) -> Self {
        let bar = ProgressBar::hidden();
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix} {elapsed_precise} [{bar:40}] {pos}/{len} tiles {msg}",
            )
            .expect("a valid template")
            .progress_chars("=> "),
        );
        bar.set_prefix(what);
        JobDisplay {
            bar,
            target,
            lines,
            eta: None,
            recent: RecentRate::default(),
        }
    }

    /// The job as the coordinator last described it.
    fn update(
        &mut self,
        done: u32,
        total: u32,
        state: &str,
        finished: bool,
        eta: Option<Duration>,
    ) {
        if total > 0
            && let Some(target) = self.target.take()
        {
            self.bar.set_draw_target(target);
        }
        self.eta = eta;
        self.bar.set_length(u64::from(total));
        self.bar.set_position(u64::from(done));
        let now = Instant::now();
        self.recent.record(now, u64::from(done));
        let message = match self.eta() {
            Some(eta) if !finished => format!("{state} eta {:.0} s", eta.as_secs_f64()),
            _ => state.to_string(),
        };
        self.bar.set_message(message);
        self.print_line_if_due(now);
    }

    fn tile_done(&mut self, now: Instant) {
        self.bar.inc(1);
        self.recent.record(now, self.bar.position());
        self.print_line_if_due(now);
    }

    /// The time to go: at the recent pace once known, else the coordinator's estimate.
    fn eta(&self) -> Option<Duration> {
        let total = self.bar.length().unwrap_or(0);
        self.recent.eta(total).or(self.eta)
    }

    /// For a log: the progress line, when one is due at `now`.
    fn print_line_if_due(&mut self, now: Instant) {
        let (done, total) = (self.bar.position(), self.bar.length().unwrap_or(0));
        let eta = self.eta();
        if let Some(lines) = &mut self.lines
            && let Some(line) = lines.due(now, done, total, eta)
        {
            eprintln!("{line}");
        }
    }
}

/// The job being waited for, and when the coordinator last answered about it.
struct Followed<'a> {
    api: &'a Api,
    id: u64,
    wait: Wait,
    display: JobDisplay,
    last_answer: Instant,
    last_read: Instant,
}

impl Followed<'_> {
    /// Reads the job and shows it: its last state once it has ended, `None` while it runs or
    /// while the coordinator is briefly unreachable.
    async fn read(&mut self) -> Result<Option<JobInfo>> {
        self.last_read = Instant::now();
        match self.api.job(self.id).await {
            Ok(info) => {
                self.last_answer = Instant::now();
                let eta = info
                    .eta_s
                    .filter(|s| s.is_finite() && *s >= 0.0)
                    .map(Duration::from_secs_f64);
                self.display.update(
                    info.tiles_done,
                    info.tiles_total,
                    info.state.as_str(),
                    info.state.is_finished(),
                    eta,
                );
                if info.state.is_finished() {
                    self.display.bar.finish_and_clear();
                    return Ok(Some(info));
                }
                Ok(None)
            }
            // A 4xx (job deleted, bad token) will not get better by waiting.
            Err(e) if crate::api::status_of(&e).is_some_and(|s| s.is_client_error()) => {
                self.display.bar.abandon();
                Err(e)
            }
            Err(e) => {
                if self.last_answer.elapsed() > self.wait.unreachable_for {
                    self.display.bar.abandon();
                    return Err(e.context(format!(
                        "no answer about job {} for {} s",
                        self.id,
                        self.wait.unreachable_for.as_secs()
                    )));
                }
                self.display
                    .bar
                    .set_message(format!("waiting for the coordinator: {e:#}"));
                Ok(None)
            }
        }
    }
}

/// An error unless the job ended `done`, naming how it ended instead.
pub fn require_done(info: &JobInfo) -> Result<()> {
    match info.state {
        JobState::Done => Ok(()),
        state => bail!(
            "job {} {}{}",
            info.id,
            state.as_str(),
            info.error
                .as_deref()
                .map(|e| format!(": {e}"))
                .unwrap_or_default()
        ),
    }
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};

    use indicatif::TermLike;

    use super::*;

    /// A terminal that keeps what is written to it.
    #[derive(Debug, Clone, Default)]
    struct Recorded(Arc<Mutex<String>>);

    impl Recorded {
        fn text(&self) -> String {
            self.0.lock().unwrap().clone()
        }
    }

    impl TermLike for Recorded {
        fn width(&self) -> u16 {
            100
        }
        fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn write_line(&self, s: &str) -> std::io::Result<()> {
            self.0.lock().unwrap().push_str(&format!("{s}\n"));
            Ok(())
        }
        fn write_str(&self, s: &str) -> std::io::Result<()> {
            self.0.lock().unwrap().push_str(s);
            Ok(())
        }
        fn clear_line(&self) -> std::io::Result<()> {
            Ok(())
        }
        fn flush(&self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// Before the first answer about the job the bar draws nothing (it used to draw a full bar
    /// of "0/0 tiles"); from it on, the job's real count.
    #[test]
    fn the_bar_is_drawn_only_once_the_tile_count_is_known() {
        let term = Recorded::default();
        let target = ProgressDrawTarget::term_like(Box::new(term.clone()));
        let mut display = JobDisplay::drawn_on("job 3".into(), Some(target), None);
        assert_eq!(term.text(), "", "drawn before the job was read");
        display.update(0, 0, "queued", false, None);
        assert_eq!(term.text(), "", "drawn with no tiles known");
        display.update(0, 12, "running", false, None);
        let text = term.text();
        assert!(
            text.contains("job 3") && text.contains("0/12 tiles"),
            "{text:?}"
        );
        assert!(!text.contains("0/0"), "{text:?}");
    }

    /// A local render's progress says `render`, as `--workers 0` does, not the embedded farm's
    /// job number; a job followed on a farm keeps its number.
    #[test]
    fn a_local_render_is_not_called_a_job() {
        assert_eq!(
            JobDisplay::new(7, Show::Nothing, true).bar.prefix(),
            "render"
        );
        assert_eq!(
            JobDisplay::new(7, Show::Nothing, false).bar.prefix(),
            "job 7"
        );
    }
}
