use spindle_common::protocol::JobState;

use super::*;

fn job(id: u64, state: JobState, tiles_done: u32, eta_s: Option<f64>) -> JobInfo {
    JobInfo {
        id,
        name: format!("j{id}"),
        submitter: Some("ada".into()),
        submitted_at_ms: 0,
        state,
        priority: 0,
        width: 64,
        height: 32,
        tile_size: 8,
        tiles_done,
        tiles_total: 32,
        elapsed_s: 0.0,
        eta_s,
        error: None,
        recent_errors: Vec::new(),
        workers_live: 1,
        requires: Default::default(),
        workers_eligible: 1,
        stats: Default::default(),
        provenance: None,
        relative_error: None,
        crop: None,
        passes: None,
    }
}

/// 8 of 32 tiles is 25 %; a running job shows the coordinator's ETA, a finished one none.
#[test]
fn the_table_shows_progress_and_eta() {
    let text = table(&[
        job(2, JobState::Running, 8, Some(90.4)),
        job(1, JobState::Done, 32, None),
    ]);
    let lines: Vec<&str> = text.lines().collect();
    let columns = |line: &str| {
        line.split_whitespace()
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    let header = columns(lines[0]);
    let at = |name: &str| header.iter().position(|h| h == name).unwrap();
    let running = columns(lines[1]);
    assert_eq!(running[at("tiles")], "8/32");
    assert_eq!(running[at("done")], "25%");
    assert_eq!(running[at("eta")], "90s");
    let done = columns(lines[2]);
    assert_eq!(done[at("done")], "100%");
    assert_eq!(done[at("eta")], "-");
}
