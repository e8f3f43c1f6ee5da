//! `spindle workers [--json]` and `spindle workers drain NAME`: the farm's workers as the
//! coordinator sees them, and asking one to leave.

use anyhow::Result;
use spindle_common::protocol::{WorkerInfo, format_labels};

use crate::api::Api;
use crate::status::utc_time;

/// `spindle workers` options.
#[derive(Debug, clap::Args)]
pub struct WorkersArgs {
    #[command(subcommand)]
    pub action: Option<WorkersAction>,
    /// Print the coordinator's JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

#[derive(Debug, clap::Subcommand)]
pub enum WorkersAction {
    /// Ask a worker (id, or every connected worker with this name) to finish its tile, take
    /// no more and exit.
    Drain {
        /// The worker's id or name.
        name: String,
    },
}

pub async fn run(api: &Api, args: &WorkersArgs) -> Result<()> {
    let list = match &args.action {
        None => api.workers().await?,
        Some(WorkersAction::Drain { name }) => api.drain(name).await?,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&list)?);
    } else if list.workers.is_empty() {
        println!("no workers");
    } else {
        print!("{}", table(&list.workers));
    }
    Ok(())
}

/// One line per worker, under a header. Throughput is tiles per minute over the last 5 minutes.
fn table(workers: &[WorkerInfo]) -> String {
    let mut s = format!(
        "{:>5}  {:<16} {:<9} {:>7}  {:<10} {:<14} {:>9}  {:>6} {:>5} {:>9}  {:<8} {}\n",
        "id",
        "name",
        "state",
        "threads",
        "job/tile",
        "labels",
        "last seen",
        "tiles",
        "fails",
        "tiles/min",
        "version",
        ""
    );
    for w in workers {
        let lease = match (w.job, w.tile) {
            (Some(j), Some(t)) => format!("{j}/{t}"),
            _ => "-".into(),
        };
        let labels = if w.labels.is_empty() {
            "-".to_string()
        } else {
            format_labels(&w.labels)
        };
        s.push_str(&format!(
            "{:>5}  {:<16} {:<9} {:>7}  {:<10} {:<14} {:>9}  {:>6} {:>5} {:>9.1}  {:<8}\n",
            w.id,
            w.name,
            w.state.as_str(),
            w.threads,
            lease,
            labels,
            utc_time(w.last_seen_ms),
            w.tiles_done,
            w.failures,
            w.tiles_per_min,
            w.version,
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use spindle_common::protocol::WorkerState;
    use std::collections::BTreeMap;

    #[test]
    fn the_table_shows_state_lease_labels_and_counts() {
        let w = WorkerInfo {
            id: 7,
            name: "night-1".into(),
            version: "0.1.0".into(),
            threads: 4,
            labels: BTreeMap::from([("pool".into(), "night".into())]),
            state: WorkerState::Rendering,
            job: Some(3),
            tile: Some(12),
            last_seen_ms: 3_723_000,
            tiles_done: 40,
            failures: 1,
            tiles_per_min: 2.5,
        };
        let text = table(&[w]);
        let line = text.lines().nth(1).unwrap();
        for part in [
            "7",
            "night-1",
            "rendering",
            "3/12",
            "pool=night",
            "01:02:03Z",
            "40",
            "2.5",
            "0.1.0",
        ] {
            assert!(line.contains(part), "{part} missing in {line:?}");
        }
    }
}
