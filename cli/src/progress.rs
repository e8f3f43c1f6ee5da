//! Following a job until it ends, with a progress bar of its tiles.
//!
//! Used by `spindle submit --wait`, `spindle status --follow` and the local farm of `spindle
//! render`. The job is followed on the coordinator's event stream rather than polled. The bar
//! goes to stderr and only when stderr is a terminal; stdout stays clean for scripts. A
//! coordinator that is briefly unreachable (restarting) does not end the wait: it continues
//! until the coordinator answers again or `unreachable_for` has passed without an answer.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use futures_util::StreamExt;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use spindle_common::protocol::{EventKind, JobInfo, JobState};

use crate::api::Api;

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
}

impl Default for Wait {
    fn default() -> Self {
        Wait {
            poll: Duration::from_millis(250),
            quiet: Duration::from_secs(30),
            unreachable_for: Duration::from_secs(120),
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
        bar: job_bar(id),
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
            let event = match tokio::time::timeout(wait.quiet, events.next()).await {
                Err(_quiet) => {
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
                    job.bar.inc(1);
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

/// A progress bar of a job's tiles on stderr, drawn only when stderr is a terminal.
fn job_bar(id: u64) -> ProgressBar {
    let bar = ProgressBar::new(0);
    if std::io::stderr().is_terminal() {
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix} {elapsed_precise} [{bar:40}] {pos}/{len} tiles {msg}",
            )
            .expect("a valid template")
            .progress_chars("=> "),
        );
    } else {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_prefix(format!("job {id}"));
    bar
}

/// The job being waited for, and when the coordinator last answered about it.
struct Followed<'a> {
    api: &'a Api,
    id: u64,
    wait: Wait,
    bar: ProgressBar,
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
                self.bar.set_length(u64::from(info.tiles_total));
                self.bar.set_position(u64::from(info.tiles_done));
                self.bar.set_message(match info.eta_s {
                    Some(eta) if !info.state.is_finished() => {
                        format!("{} eta {eta:.0} s", info.state.as_str())
                    }
                    _ => info.state.as_str().to_string(),
                });
                if info.state.is_finished() {
                    self.bar.finish_and_clear();
                    return Ok(Some(info));
                }
                Ok(None)
            }
            // A 4xx (job deleted, bad token) will not get better by waiting.
            Err(e) if crate::api::status_of(&e).is_some_and(|s| s.is_client_error()) => {
                self.bar.abandon();
                Err(e)
            }
            Err(e) => {
                if self.last_answer.elapsed() > self.wait.unreachable_for {
                    self.bar.abandon();
                    return Err(e.context(format!(
                        "no answer about job {} for {} s",
                        self.id,
                        self.wait.unreachable_for.as_secs()
                    )));
                }
                self.bar
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
