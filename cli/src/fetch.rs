//! `spindle fetch JOB -o OUT.exr`: download a finished job's image.
//!
//! The file is written with `atomic_write::write`, so a reader never sees half an image and an
//! interrupted download leaves the old file alone.

use std::path::PathBuf;

use anyhow::{Result, bail};
use reqwest::StatusCode;
use spindle_common::atomic_write;

use crate::api::{Api, ImageFile, status_of};

/// `spindle fetch` options.
#[derive(Debug, clap::Args)]
pub struct FetchArgs {
    /// The job id.
    pub job: u64,
    /// Where to write the OpenEXR image.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write the coordinator's PNG preview beside it (OUT.png).
    #[arg(long)]
    pub preview: bool,
}

pub async fn run(api: &Api, args: &FetchArgs) -> Result<()> {
    let bytes = match api.image(args.job, ImageFile::Exr).await {
        Ok(bytes) => bytes,
        Err(e) if status_of(&e) == Some(StatusCode::CONFLICT) => {
            let state = api
                .job(args.job)
                .await
                .map(|j| {
                    format!(
                        "{} ({}/{} tiles)",
                        j.state.as_str(),
                        j.tiles_done,
                        j.tiles_total
                    )
                })
                .unwrap_or_else(|_| "not done".into());
            bail!("job {} has no final image yet: it is {state}", args.job);
        }
        Err(e) => return Err(e.context(format!("fetching the image of job {}", args.job))),
    };
    atomic_write::write(&args.output, &bytes)?;
    println!("wrote {} ({} bytes)", args.output.display(), bytes.len());
    if args.preview {
        let png = api.image(args.job, ImageFile::Png).await?;
        let path = args.output.with_extension("png");
        atomic_write::write(&path, &png)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}
