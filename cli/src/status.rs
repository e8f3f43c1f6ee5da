//! `spindle status [JOB]`: one job's progress, or a table of every job.

use anyhow::Result;
use spindle_common::protocol::JobInfo;

use crate::api::Api;

/// `spindle status` options.
#[derive(Debug, clap::Args)]
pub struct StatusArgs {
    /// A job id; without it, every job is listed.
    pub job: Option<u64>,
    /// Print the coordinator's JSON instead of text.
    #[arg(long)]
    pub json: bool,
}

pub async fn run(api: &Api, args: &StatusArgs) -> Result<()> {
    match args.job {
        Some(id) => {
            let info = api.job(id).await?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&info)?);
            } else {
                print!("{}", describe(&info));
            }
        }
        None => {
            let list = api.jobs().await?;
            if args.json {
                println!("{}", serde_json::to_string_pretty(&list)?);
            } else if list.jobs.is_empty() {
                println!("no jobs");
            } else {
                println!(
                    "{:>6}  {:<10} {:>5}  {:>13}  {:>9}  {:>8}",
                    "job", "state", "prio", "tiles", "size", "elapsed"
                );
                for j in &list.jobs {
                    println!(
                        "{:>6}  {:<10} {:>5}  {:>13}  {:>9}  {:>7.1}s",
                        j.id,
                        j.state.as_str(),
                        j.priority,
                        format!("{}/{}", j.tiles_done, j.tiles_total),
                        format!("{}x{}", j.width, j.height),
                        j.elapsed_s
                    );
                }
            }
        }
    }
    Ok(())
}

/// A few lines about one job.
fn describe(j: &JobInfo) -> String {
    let mut s = format!(
        "job {}: {}\n  image     {}x{} in tiles of {} px, priority {}\n  tiles     {}/{} done\n  elapsed   {:.1} s\n",
        j.id,
        j.state.as_str(),
        j.width,
        j.height,
        j.tile_size,
        j.priority,
        j.tiles_done,
        j.tiles_total,
        j.elapsed_s
    );
    if let Some(eta) = j.eta_s.filter(|_| !j.state.is_finished()) {
        s.push_str(&format!("  eta       {eta:.1} s\n"));
    }
    if let Some(e) = &j.error {
        s.push_str(&format!("  error     {e}\n"));
    }
    s
}
