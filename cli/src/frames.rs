//! `--frames FIRST-LAST` and the `####` of an output path: which frames a command renders or
//! fetches, and the file each frame goes to.
//!
//! The convention of Blender, Nuke and Deadline: the last run of `#` in the file name is the
//! frame number, zero-padded to the run's length (`shot.####.exr` → `shot.0007.exr`; a number
//! longer than the run is written whole). A sequence of more than one frame needs one, so no
//! frame overwrites another.

use std::path::{Path, PathBuf};

use anyhow::{Result, bail};
use spindle_common::scene::FrameRange;
use spindle_common::validate::MAX_FRAME;

/// Parses `--frames N` or `--frames FIRST-LAST` (both included, FIRST ≤ LAST ≤ 999999).
pub fn parse_frames(text: &str) -> Result<FrameRange, String> {
    let number = |part: &str| -> Result<u32, String> {
        let n: u32 = part
            .trim()
            .parse()
            .map_err(|_| format!("{part:?} is not a frame number (0 … {MAX_FRAME})"))?;
        if n > MAX_FRAME {
            return Err(format!("frame {n} is past the last frame, {MAX_FRAME}"));
        }
        Ok(n)
    };
    let (start, end) = match text.split_once('-') {
        Some((first, last)) => (number(first)?, number(last)?),
        None => {
            let n = number(text)?;
            (n, n)
        }
    };
    if end < start {
        return Err(format!(
            "{text:?}: the last frame ({end}) is before the first ({start})"
        ));
    }
    Ok(FrameRange { start, end })
}

/// `FIRST-LAST`, or `N` for one frame.
pub fn describe(range: FrameRange) -> String {
    if range.start == range.end {
        range.start.to_string()
    } else {
        format!("{}-{}", range.start, range.end)
    }
}

/// The file of `frame`: the last run of `#` in `pattern`'s file name replaced by the frame
/// number, zero-padded to the run's length; `pattern` itself when its name has no `#`.
pub fn frame_path(pattern: &Path, frame: u32) -> PathBuf {
    let Some(name) = pattern.file_name().and_then(|n| n.to_str()) else {
        return pattern.to_path_buf();
    };
    let Some(end) = name.rfind('#').map(|i| i + 1) else {
        return pattern.to_path_buf();
    };
    let start = name[..end].trim_end_matches('#').len();
    let width = end - start;
    let named = format!("{}{frame:0width$}{}", &name[..start], &name[end..]);
    pattern.with_file_name(named)
}

/// Whether `pattern`'s file name has a `#` for the frame number.
pub fn has_frame_number(pattern: &Path) -> bool {
    pattern
        .file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.contains('#'))
}

/// Refuses, before anything is rendered, an output that `range`'s frames would overwrite
/// one another in: more than one frame and no `#` in the file name. `asked` says where the
/// frames came from (`--frames 1-48`, `the scene's animation.frames 1-48`).
pub fn check_output(flag: &str, pattern: &Path, range: FrameRange, asked: &str) -> Result<()> {
    if range.len() > 1 && !has_frame_number(pattern) {
        bail!(
            "{flag} {}: {asked} asks for {} frames, each written to a file of its own: put a run \
             of # in the file name for the frame number, zero-padded to its length (e.g. \
             shot.####.exr)",
            pattern.display(),
            range.len()
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests;
