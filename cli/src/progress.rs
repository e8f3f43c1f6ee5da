//! Following a job until it ends, with a progress bar of its tiles.
//!
//! Used by `spindle submit --wait` and by the local farm of `spindle render`. The bar goes to
//! stderr and only when stderr is a terminal; stdout stays clean for scripts. A coordinator
//! that is briefly unreachable (restarting) does not end the wait: polling continues until it
//! answers again or `unreachable_for` has passed without an answer.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use spindle_common::protocol::{JobInfo, JobState};

use crate::api::Api;

/// How to wait.
#[derive(Debug, Clone, Copy)]
pub struct Wait {
    /// Time between polls.
    pub poll: Duration,
    /// Give up after the coordinator has not answered for this long.
    pub unreachable_for: Duration,
}

impl Default for Wait {
    fn default() -> Self {
        Wait {
            poll: Duration::from_millis(250),
            unreachable_for: Duration::from_secs(120),
        }
    }
}

/// Polls job `id` until it is done, failed or cancelled, and returns its last state.
pub async fn wait_for(api: &Api, id: u64, wait: Wait) -> Result<JobInfo> {
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
    let mut last_answer = Instant::now();
    loop {
        match api.job(id).await {
            Ok(info) => {
                last_answer = Instant::now();
                bar.set_length(u64::from(info.tiles_total));
                bar.set_position(u64::from(info.tiles_done));
                bar.set_message(match info.eta_s {
                    Some(eta) if !info.state.is_finished() => {
                        format!("{} eta {eta:.0} s", info.state.as_str())
                    }
                    _ => info.state.as_str().to_string(),
                });
                if info.state.is_finished() {
                    bar.finish_and_clear();
                    return Ok(info);
                }
            }
            // A 4xx (job deleted, bad token) will not get better by waiting.
            Err(e) if crate::api::status_of(&e).is_some_and(|s| s.is_client_error()) => {
                bar.abandon();
                return Err(e);
            }
            Err(e) => {
                if last_answer.elapsed() > wait.unreachable_for {
                    bar.abandon();
                    return Err(e.context(format!(
                        "no answer about job {id} for {} s",
                        wait.unreachable_for.as_secs()
                    )));
                }
                bar.set_message(format!("waiting for the coordinator: {e:#}"));
            }
        }
        tokio::time::sleep(wait.poll).await;
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
