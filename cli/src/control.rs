//! `spindle pause|resume|requeue|delete JOB` and `spindle priority JOB N`: steering a job after
//! it was submitted.

use anyhow::{Result, bail};
use reqwest::StatusCode;

use crate::api::{Api, StatusError};

/// `spindle pause|resume|requeue JOB` options.
#[derive(Debug, clap::Args)]
pub struct JobArg {
    /// The job id.
    pub job: u64,
}

/// `spindle delete` options.
#[derive(Debug, clap::Args)]
pub struct DeleteArgs {
    /// The job id.
    pub job: u64,
    /// Delete a job that has not finished (the coordinator cancels it first).
    #[arg(long)]
    pub force: bool,
}

/// `spindle priority` options.
#[derive(Debug, clap::Args)]
pub struct PriorityArgs {
    /// The job id.
    pub job: u64,
    /// The new priority: higher runs first.
    #[arg(allow_negative_numbers = true)]
    pub priority: i32,
}

/// Which change `spindle pause|resume|requeue` asks for.
#[derive(Debug, Clone, Copy)]
pub enum Change {
    Pause,
    Resume,
    Requeue,
}

pub async fn change(api: &Api, args: &JobArg, change: Change) -> Result<()> {
    let action = match change {
        Change::Pause => "pause",
        Change::Resume => "resume",
        Change::Requeue => "requeue",
    };
    let info = api.job_action(args.job, action).await?;
    println!("job {}: {}", info.id, info.state.as_str());
    Ok(())
}

pub async fn delete(api: &Api, args: &DeleteArgs) -> Result<()> {
    if let Err(e) = api.delete(args.job, args.force).await {
        // The coordinator's refusal names its query parameter; here the flag is what to use.
        let unfinished = e
            .downcast_ref::<StatusError>()
            .is_some_and(|s| s.status == StatusCode::CONFLICT);
        if unfinished && !args.force {
            bail!(
                "job {id} has not finished: cancel it first (spindle cancel {id}), or delete it \
                 anyway with spindle delete {id} --force",
                id = args.job
            );
        }
        return Err(e);
    }
    println!("job {}: deleted", args.job);
    Ok(())
}

pub async fn priority(api: &Api, args: &PriorityArgs) -> Result<()> {
    let info = api.set_priority(args.job, args.priority).await?;
    println!("job {}: priority {}", info.id, info.priority);
    Ok(())
}
