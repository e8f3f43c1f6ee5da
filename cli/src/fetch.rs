//! `spindle fetch JOB -o OUT.exr`: download a finished job's image.
//!
//! The file is written atomically (a temporary file beside it, then a rename), so a reader
//! never sees half an image and an interrupted download leaves the old file alone.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use reqwest::StatusCode;

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
    write_atomically(&args.output, &bytes)?;
    println!("wrote {} ({} bytes)", args.output.display(), bytes.len());
    if args.preview {
        let png = api.image(args.job, ImageFile::Png).await?;
        let path = args.output.with_extension("png");
        write_atomically(&path, &png)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file in the same directory.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let mut tmp = tempfile::NamedTempFile::new_in(dir)
        .with_context(|| format!("cannot create a file in {}", dir.display()))?;
    tmp.write_all(bytes)
        .and_then(|()| tmp.as_file().sync_all())
        .with_context(|| format!("cannot write {}", path.display()))?;
    tmp.persist(path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}
