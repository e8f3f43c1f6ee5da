//! `spindle status [JOB]`: one job's progress, or a table of every job.

use anyhow::Result;
use spindle_common::protocol::{JobInfo, format_labels};

use crate::api::Api;

/// `spindle status` options.
#[derive(Debug, clap::Args)]
pub struct StatusArgs {
    /// A job id; without it, every job is listed.
    pub job: Option<u64>,
    /// Print the coordinator's JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Follow the job until it ends (a progress bar on a terminal), then show it; exits
    /// non-zero unless it ended `done`.
    #[arg(long, requires = "job")]
    pub follow: bool,
}

pub async fn run(api: &Api, args: &StatusArgs) -> Result<()> {
    match args.job {
        Some(id) => {
            let info = if args.follow {
                crate::progress::wait_for(api, id, crate::progress::Wait::default()).await?
            } else {
                api.job(id).await?
            };
            if args.json {
                println!("{}", serde_json::to_string_pretty(&info)?);
            } else {
                print!("{}", describe(&info));
            }
            if args.follow {
                crate::progress::require_done(&info)?;
            }
        }
        None => {
            let list = api.jobs().await?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&list)?);
            } else if list.jobs.is_empty() {
                println!("no jobs");
            } else {
                print!("{}", crate::jobs::table(&list.jobs));
            }
        }
    }
    Ok(())
}

/// The job's state, with why nothing moves when no worker is connected or none may take it.
pub fn state_label(j: &JobInfo) -> String {
    let state = j.state.as_str();
    if j.state.is_finished() {
        state.to_string()
    } else if j.workers_live == 0 {
        format!("{state} — no workers connected")
    } else if j.workers_eligible == 0 && !j.requires.is_empty() {
        format!(
            "{state} — no live worker has labels {}",
            format_labels(&j.requires)
        )
    } else if j.workers_eligible == 0 {
        format!("{state} — every live worker is draining")
    } else {
        state.to_string()
    }
}

/// A few lines about one job.
fn describe(j: &JobInfo) -> String {
    let mut s = format!(
        "job {} ({}): {}\n  image     {}x{}{} in tiles of {} px, priority {}\n  tiles     {}/{} done\n  elapsed   {}\n",
        j.id,
        j.name,
        state_label(j),
        j.width,
        j.height,
        j.crop.map_or(String::new(), |c| format!(
            " (crop {},{} {}x{})",
            c.x, c.y, c.width, c.height
        )),
        j.tile_size,
        j.priority,
        j.tiles_done,
        j.tiles_total,
        // A job that never started (cancelled while queued) has no elapsed time.
        if j.elapsed_s > 0.0 {
            format!("{:.1} s", j.elapsed_s)
        } else {
            "-".to_string()
        }
    );
    if let Some(eta) = j.eta_s.filter(|_| !j.state.is_finished()) {
        s.push_str(&format!("  eta       {eta:.1} s\n"));
    }
    if let Some(p) = j.passes {
        s.push_str(&format!(
            "  passes    pass {} ({} spp; tiles count this pass), budget {} s\n",
            p.pass, p.spp, p.budget_s
        ));
    }
    if let Some(noise) = j.relative_error {
        s.push_str(&format!(
            "  noise     {:.2} % (estimated relative RMS error of the tiles done)\n",
            100.0 * noise
        ));
    }
    if let Some(e) = &j.error {
        s.push_str(&format!("  error     {e}\n"));
    }
    if !j.recent_errors.is_empty() {
        s.push_str("  tile errors (newest last):\n");
        for e in &j.recent_errors {
            s.push_str(&format!(
                "    {}  tile {} on {} ({}): {}\n",
                utc_time(e.at_ms),
                e.tile,
                e.worker,
                e.worker_id,
                e.message
            ));
        }
    }
    s
}

/// `n` things, singular or plural: `count(1, "tile") == "1 tile"`.
pub fn count(n: impl Into<u64>, noun: &str) -> String {
    let n = n.into();
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// `HH:MM:SS` UTC of a time in ms since the Unix epoch.
pub fn utc_time(ms: i64) -> String {
    let s = ms.div_euclid(1000).rem_euclid(86_400);
    format!("{:02}:{:02}:{:02}Z", s / 3600, s / 60 % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;
    use spindle_common::protocol::{JobState, TileError};

    fn job(state: JobState, workers_live: u32) -> JobInfo {
        JobInfo {
            id: 3,
            name: "box".into(),
            submitter: None,
            submitted_at_ms: 0,
            state,
            priority: 0,
            width: 8,
            height: 8,
            tile_size: 8,
            tiles_done: 0,
            tiles_total: 1,
            elapsed_s: 0.0,
            eta_s: None,
            error: None,
            recent_errors: Vec::new(),
            workers_live,
            requires: Default::default(),
            workers_eligible: workers_live,
            stats: Default::default(),
            provenance: None,
            relative_error: None,
            crop: None,
            passes: None,
        }
    }

    #[test]
    fn the_noise_is_shown_in_percent() {
        let text = describe(&JobInfo {
            relative_error: Some(0.01234),
            ..job(JobState::Running, 1)
        });
        assert!(text.contains("  noise     1.23 % (estimated"), "{text}");
        assert!(!describe(&job(JobState::Running, 1)).contains("noise"));
    }

    #[test]
    fn a_budgeted_job_shows_its_pass() {
        let text = describe(&JobInfo {
            passes: Some(spindle_common::protocol::PassInfo {
                pass: 2,
                spp: 32,
                budget_s: 60.0,
            }),
            ..job(JobState::Running, 1)
        });
        assert!(
            text.contains("  passes    pass 2 (32 spp; tiles count this pass), budget 60 s\n"),
            "{text}"
        );
        assert!(!describe(&job(JobState::Running, 1)).contains("passes"));
    }

    #[test]
    fn a_waiting_job_says_when_no_worker_is_connected() {
        let text = describe(&job(JobState::Queued, 0));
        assert!(
            text.starts_with("job 3 (box): queued — no workers connected\n"),
            "{text}"
        );
        let text = describe(&job(JobState::Queued, 2));
        assert!(text.starts_with("job 3 (box): queued\n"), "{text}");
        let text = describe(&job(JobState::Done, 0));
        assert!(text.starts_with("job 3 (box): done\n"), "{text}");
        let text = describe(&job(JobState::Cancelled, 0));
        assert!(text.contains("  elapsed   -\n"), "{text}");
        let mut picky = job(JobState::Queued, 2);
        picky.requires.insert("pool".into(), "night".into());
        picky.workers_eligible = 0;
        let text = describe(&picky);
        assert!(
            text.starts_with("job 3 (box): queued — no live worker has labels pool=night\n"),
            "{text}"
        );
    }

    #[test]
    fn counts_are_singular_or_plural() {
        assert_eq!(count(1u32, "tile"), "1 tile");
        assert_eq!(count(0u32, "tile"), "0 tiles");
        assert_eq!(count(12u64, "tile"), "12 tiles");
    }

    #[test]
    fn tile_errors_are_listed_with_worker_and_time() {
        let mut j = job(JobState::Failed, 1);
        j.error = Some("tile 0 cannot be rendered".into());
        j.recent_errors.push(TileError {
            tile: 0,
            worker_id: 4,
            worker: "w1".into(),
            at_ms: 3_723_000,
            message: "the scene does not build: objects[0]: bad face".into(),
        });
        let text = describe(&j);
        assert!(
            text.contains("  error     tile 0 cannot be rendered\n"),
            "{text}"
        );
        assert!(
            text.contains(
                "    01:02:03Z  tile 0 on w1 (4): the scene does not build: objects[0]: bad face\n"
            ),
            "{text}"
        );
    }
}
