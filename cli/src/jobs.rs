//! `spindle jobs [--state S] [--name N] [--limit N]`: the coordinator's jobs, newest first as
//! the dashboard lists them, with each one's progress and ETA.
//!
//! The coordinator's pages are asked for newest first (`order=desc`), so `--limit N` reads
//! only the pages that hold the newest N.

use anyhow::Result;
use spindle_common::protocol::{JobInfo, JobOrder, JobState, MAX_JOB_PAGE};

use crate::api::{Api, JobQuery};
use crate::status::{state_label, utc_time};

/// `spindle jobs` options.
#[derive(Debug, clap::Args)]
pub struct JobsArgs {
    /// Only jobs in this state (queued, running, paused, done, failed, cancelled).
    #[arg(long, value_parser = parse_state)]
    pub state: Option<JobState>,
    /// Only jobs whose name contains this.
    #[arg(long)]
    pub name: Option<String>,
    /// At most this many jobs, the newest (default: all).
    #[arg(long)]
    pub limit: Option<usize>,
    /// Print the jobs as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

fn parse_state(s: &str) -> Result<JobState, String> {
    JobState::parse(s).ok_or_else(|| {
        format!("{s:?} is not one of queued, running, paused, done, failed, cancelled")
    })
}

pub async fn run(api: &Api, args: &JobsArgs) -> Result<()> {
    let mut jobs = Vec::new();
    let mut cursor = None;
    let wanted = args.limit.unwrap_or(usize::MAX);
    while jobs.len() < wanted {
        let query = JobQuery {
            state: args.state,
            name: args.name.clone(),
            limit: Some(MAX_JOB_PAGE.min(wanted - jobs.len()).max(1)),
            cursor: cursor.take(),
            order: Some(JobOrder::Desc),
        };
        let page = api.jobs_page(&query).await?;
        jobs.extend(page.jobs);
        match page.next_cursor {
            Some(next) => cursor = Some(next),
            None => break,
        }
    }
    jobs.truncate(wanted);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&jobs)?);
    } else if jobs.is_empty() {
        println!("no jobs");
    } else {
        print!("{}", table(&jobs));
    }
    Ok(())
}

/// One line per job, under a header.
pub fn table(jobs: &[JobInfo]) -> String {
    let mut s = format!(
        "{:>6}  {:<20} {:<12} {:<10} {:>5}  {:>13}  {:>4}  {:>9}  {:>9}  {:>9}  {}\n",
        "job",
        "name",
        "submitter",
        "submitted",
        "prio",
        "tiles",
        "done",
        "eta",
        "size",
        "elapsed",
        "state"
    );
    for j in jobs {
        let elapsed = if j.elapsed_s > 0.0 {
            format!("{:.1}s", j.elapsed_s)
        } else {
            "-".into()
        };
        let done = if j.tiles_total > 0 {
            format!(
                "{:.0}%",
                100.0 * f64::from(j.tiles_done) / f64::from(j.tiles_total)
            )
        } else {
            "-".into()
        };
        let eta = match j.eta_s {
            Some(eta) if eta.is_finite() && eta >= 0.0 && !j.state.is_finished() => {
                format!("{eta:.0}s")
            }
            _ => "-".into(),
        };
        s.push_str(&format!(
            "{:>6}  {:<20} {:<12} {:<10} {:>5}  {:>13}  {:>4}  {:>9}  {:>9}  {:>9}  {}\n",
            j.id,
            j.name,
            j.submitter.as_deref().unwrap_or("-"),
            utc_time(j.submitted_at_ms),
            j.priority,
            format!("{}/{}", j.tiles_done, j.tiles_total),
            done,
            eta,
            format!("{}x{}", j.width, j.height),
            elapsed,
            state_label(j),
        ));
    }
    s
}

#[cfg(test)]
mod tests;
