//! `spindle jobs [--state S] [--name N] [--limit N]`: the coordinator's jobs, oldest first,
//! fetched a page at a time.

use anyhow::Result;
use spindle_common::protocol::{JobInfo, JobState, MAX_JOB_PAGE};

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
    /// At most this many jobs (default: all).
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
    loop {
        let want = args
            .limit
            .map_or(MAX_JOB_PAGE, |l| (l - jobs.len()).min(MAX_JOB_PAGE));
        if want == 0 {
            break;
        }
        let query = JobQuery {
            state: args.state,
            name: args.name.clone(),
            limit: Some(want),
            cursor: cursor.take(),
        };
        let page = api.jobs_page(&query).await?;
        jobs.extend(page.jobs);
        match page.next_cursor {
            Some(next) => cursor = Some(next),
            None => break,
        }
    }
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
        "{:>6}  {:<20} {:<12} {:<10} {:>5}  {:>13}  {:>9}  {:>9}  {}\n",
        "job", "name", "submitter", "submitted", "prio", "tiles", "size", "elapsed", "state"
    );
    for j in jobs {
        let elapsed = if j.elapsed_s > 0.0 {
            format!("{:.1}s", j.elapsed_s)
        } else {
            "-".into()
        };
        s.push_str(&format!(
            "{:>6}  {:<20} {:<12} {:<10} {:>5}  {:>13}  {:>9}  {:>9}  {}\n",
            j.id,
            j.name,
            j.submitter.as_deref().unwrap_or("-"),
            utc_time(j.submitted_at_ms),
            j.priority,
            format!("{}/{}", j.tiles_done, j.tiles_total),
            format!("{}x{}", j.width, j.height),
            elapsed,
            state_label(j),
        ));
    }
    s
}
