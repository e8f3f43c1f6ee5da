//! `spindle cancel JOB`: stop a job, so no more of its tiles are handed to workers.

use anyhow::Result;

use crate::api::Api;

/// `spindle cancel` options.
#[derive(Debug, clap::Args)]
pub struct CancelArgs {
    /// The job id.
    pub job: u64,
}

pub async fn run(api: &Api, args: &CancelArgs) -> Result<()> {
    let info = api.cancel(args.job).await?;
    println!("job {}: {}", info.id, info.state.as_str());
    Ok(())
}
