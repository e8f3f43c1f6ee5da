//! `spindle fetch JOB [-o OUT.exr]`: download a finished job's image (without `-o`, to
//! `<job name>.exr` in the current directory).
//!
//! The file is written with `atomic_write::write`, so a reader never sees half an image and an
//! interrupted download leaves the old file alone.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use reqwest::StatusCode;
use spindle_common::atomic_write;

use crate::api::{Api, ImageFile, status_of};

/// `spindle fetch` options.
#[derive(Debug, clap::Args)]
pub struct FetchArgs {
    /// The job id.
    pub job: u64,
    /// Where to write the OpenEXR image (default: `<job name>.exr` in the current directory).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Also write the coordinator's PNG preview beside it (OUT.png).
    #[arg(long)]
    pub preview: bool,
}

pub async fn run(api: &Api, args: &FetchArgs) -> Result<()> {
    download(api, args.job, args.output.as_deref(), args.preview).await
}

/// Writes job `job`'s final EXR to `output` (default `<name>.exr` here), and its PNG preview
/// beside it if `preview`.
pub async fn download(api: &Api, job: u64, output: Option<&Path>, preview: bool) -> Result<()> {
    let args = FetchArgs {
        job,
        output: output.map(Path::to_path_buf),
        preview,
    };
    let bytes = match api.image(args.job, ImageFile::Exr).await {
        Ok(bytes) => bytes,
        Err(e) if status_of(&e) == Some(StatusCode::CONFLICT) => {
            let state = api
                .job(args.job)
                .await
                .map(|j| {
                    format!(
                        "{} ({} of {} done)",
                        j.state.as_str(),
                        j.tiles_done,
                        crate::status::count(j.tiles_total, "tile")
                    )
                })
                .unwrap_or_else(|_| "not done".into());
            bail!("job {} has no final image yet: it is {state}", args.job);
        }
        Err(e) => return Err(e.context(format!("fetching the image of job {}", args.job))),
    };
    let output = match &args.output {
        Some(path) => path.clone(),
        None => PathBuf::from(format!(
            "{}.exr",
            file_stem(&api.job(args.job).await?.name, args.job)
        )),
    };
    atomic_write::write(&output, &bytes)?;
    println!("wrote {} ({} bytes)", output.display(), bytes.len());
    if args.preview {
        let png = api.image(args.job, ImageFile::Png).await?;
        let path = output.with_extension("png");
        atomic_write::write(&path, &png)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// A job name as a file name: letters, digits, `-`, `_`, `.` kept, anything else `_`; a name
/// that would be empty or hidden becomes `job-<id>`.
fn file_stem(name: &str, id: u64) -> String {
    let stem: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if stem.is_empty() || stem.starts_with('.') {
        format!("job-{id}")
    } else {
        stem
    }
}

#[cfg(test)]
mod tests {
    use super::file_stem;

    #[test]
    fn a_job_name_becomes_a_safe_file_name() {
        assert_eq!(file_stem("box", 3), "box");
        assert_eq!(file_stem("../etc/passwd", 3), "job-3");
        assert_eq!(file_stem("a b/c", 3), "a_b_c");
        assert_eq!(file_stem("", 3), "job-3");
    }
}
