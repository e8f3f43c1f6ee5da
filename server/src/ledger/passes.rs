//! Progressive passes of a job with `film.time_budget_s`: the farm's time budget.
//!
//! Such a job is rendered as successive sets of its tiles. Pass `k` of every tile takes each
//! pixel to `min(16 k, film.spp)` samples, continuing from the running sums its pass-`k − 1`
//! result carried ([`spindle_common::passes::TileProgress`], stored with the tile as any result
//! is; a worker fetches it through `GET /v1/leases/{job}/{tile}/previous`). Pass `k + 1` starts
//! only when every tile has finished pass `k`, and only if the budget allows it by the rule of
//! `spindle render --workers 0`: the runnable time since the job started (its first lease)
//! plus the last pass's runnable time is within the budget. Otherwise — or when every pixel has `spp`
//! samples or met `film.target_error` — the job is complete, and its image, assembled from the
//! last pass every tile completed, is bit for bit the one-pass render at `spp` = the reached
//! cap: the job's spec says so from then on (the EXR's `spindle.spp`), and
//! [`spindle_common::protocol::JobInfo::passes`] reports it.
//!
//! Why whole passes with a barrier, rather than tiles running ahead: every tile of the image
//! then ends at the same sample count, so the image is one spp's render (what `--workers 0
//! --no-time-budget --spp N` reproduces), and each tile needs one stored result per pass, which
//! the tile store's one row per tile holds; the cost is the pass's tail, where workers wait for
//! its last tiles.
//!
//! What a restart keeps: the job's pass, when it began and the time the job spent paused
//! ([`PassClock`], the job row's `passes`, written in the commit of every change), each tile's
//! result its current pass continues from (a tile row not done keeps the previous pass's
//! result: [`db::next_pass_tile`]) and, per tile done in the current pass, its pixels still
//! sampling. A restarted coordinator resumes the pass it was in; only a job stored before this
//! was recorded, or one requeued after it failed or was cancelled, is rendered again from pass
//! 1 ([`super::job::Job::restart_passes`]). So is a job past pass 1 one of whose stored results turns
//! out damaged (read for the next pass or at assembly): a tile's pass continues the tile's
//! previous pass, whose result its row no longer keeps, so the tile cannot be rendered again
//! alone ([`super::pass_end`]; the reason goes to the job's recent errors).
//!
//! The budget is wall time while the job is runnable: the intervals it spent paused are
//! subtracted from both the time since its start and the last pass's time (a coordinator that
//! is down is not a pause: that time counts).
//!
//! This module holds a job's passes and their clock; [`super::pass_end`] is the ledger's side:
//! ending a pass, starting the passes again, a tile's previous result.
//!
//! Ending a pass writes to the database; it runs where assembly does ([`crate::assemble`]),
//! after the upload of the pass's last tile was recorded, and an error is retried with the
//! assembly's backoff (each failure logged) until it passes or [`super::pass_end::PASS_END_ATTEMPTS`] failed:
//! then the job fails, with the reason in its `error` and its `job_state` event.

use serde::{Deserialize, Serialize};
use spindle_common::passes::pass_cap;
use spindle_common::protocol::{JobSpec, PassInfo};

use crate::db;
use crate::error::Error;

/// The part of a budgeted job's passes that is stored with the job (`jobs.passes`, JSON).
/// Times are wall-clock ms since the Unix epoch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassClock {
    /// The pass being rendered (from 1).
    pub pass: u32,
    /// When the current pass began; `None` in pass 1, which begins with the job.
    pub started_ms: Option<i64>,
    /// Time spent paused since the job started, in pauses that ended.
    pub paused_ms: i64,
    /// Of that, the time within the current pass.
    pub pass_paused_ms: i64,
    /// When the pause in progress began (the job is paused).
    pub paused_since_ms: Option<i64>,
    /// The last pass ended and no other follows: the job's spec is at the reached `spp`.
    pub complete: bool,
}

impl PassClock {
    /// Time from `from` to `now` that is not part of the pause in progress.
    fn open_pause_ms(&self, from: i64, now: i64) -> i64 {
        self.paused_since_ms
            .map_or(0, |since| (now - since.max(from)).max(0))
    }

    /// The job's runnable seconds since its start `job_start`, and its current pass's, at `now`.
    pub fn runnable_s(&self, job_start: i64, now: i64) -> (f64, f64) {
        let pass_start = self.started_ms.unwrap_or(job_start);
        let job = (now - job_start - self.paused_ms - self.open_pause_ms(job_start, now)).max(0);
        let pass =
            (now - pass_start - self.pass_paused_ms - self.open_pause_ms(pass_start, now)).max(0);
        (job as f64 / 1000.0, pass as f64 / 1000.0)
    }

    /// A pause begins at `at`.
    pub fn pause(&mut self, at: i64) {
        self.paused_since_ms.get_or_insert(at);
    }

    /// The pause in progress ends at `at`; it counts from the job's start (`None`: the job
    /// has not started, and nothing counts).
    pub fn resume(&mut self, at: i64, job_start: Option<i64>) {
        let (Some(since), Some(job_start)) = (self.paused_since_ms.take(), job_start) else {
            return;
        };
        let pass_start = self.started_ms.unwrap_or(job_start);
        self.paused_ms += (at - since.max(job_start)).max(0);
        self.pass_paused_ms += (at - since.max(pass_start)).max(0);
    }

    fn to_json(&self) -> Result<String, Error> {
        Ok(serde_json::to_string(self).map_err(anyhow::Error::from)?)
    }
}

/// Where a budgeted job's passes stand.
#[derive(Debug, Clone, PartialEq)]
pub struct Passes {
    /// `film.time_budget_s`, counted from the job's start.
    budget_s: f64,
    /// What is stored with the job.
    pub clock: PassClock,
    /// Each tile's result of the previous pass (its hash), from which its current pass goes
    /// on; all `None` in pass 1.
    previous: Vec<Option<String>>,
    /// Per tile done in this pass: its pixels that would take more samples in another pass.
    sampling: Vec<u32>,
}

impl Passes {
    /// The passes of a job whose scene has a time budget, at pass 1.
    pub fn of(spec: &JobSpec) -> Option<Passes> {
        let budget_s = spec.scene.film.time_budget_s?;
        let tiles = spec.tiles().len();
        Some(Passes {
            budget_s,
            clock: PassClock {
                pass: 1,
                started_ms: None,
                paused_ms: 0,
                pass_paused_ms: 0,
                paused_since_ms: None,
                complete: false,
            },
            previous: vec![None; tiles],
            sampling: vec![0; tiles],
        })
    }

    /// The pass being rendered (from 1).
    pub fn pass(&self) -> u32 {
        self.clock.pass
    }

    /// Has the last pass ended, with no other to follow?
    pub fn complete(&self) -> bool {
        self.clock.complete
    }

    /// The stored form of a new job's passes (pass 1).
    pub fn json_of(spec: &JobSpec) -> Result<Option<String>, Error> {
        Passes::of(spec).map(|p| p.clock.to_json()).transpose()
    }

    /// The passes of job `id` as stored: its clock (`json`, the job row's `passes`) and its
    /// tile rows ([`db::pass_rows`]); `None` when the job has no budget.
    pub(crate) fn restore(
        spec: &JobSpec,
        json: &str,
        rows: &[db::PassRow],
    ) -> anyhow::Result<Option<Passes>> {
        let Some(mut passes) = Passes::of(spec) else {
            return Ok(None);
        };
        passes.clock = serde_json::from_str(json)
            .map_err(|e| anyhow::anyhow!("stored passes {json:?}: {e}"))?;
        for (index, previous, sampling) in rows {
            let i = *index as usize;
            anyhow::ensure!(
                i < passes.previous.len(),
                "stored tile {index} out of range"
            );
            if passes.clock.pass > 1 {
                passes.previous[i] = previous.clone();
            }
            passes.sampling[i] = sampling.unwrap_or(0);
        }
        Ok(Some(passes))
    }

    /// The result tile `index`'s current pass continues from.
    pub fn previous(&self, index: u32) -> Option<&str> {
        self.previous.get(index as usize)?.as_deref()
    }

    /// Forgets the per-tile state of a finished job (its pass stays, for [`Passes::info`]).
    pub(crate) fn release(&mut self) {
        self.previous = Vec::new();
        self.sampling = Vec::new();
    }

    /// `film.time_budget_s`.
    pub fn budget_s(&self) -> f64 {
        self.budget_s
    }

    /// Pixels of the tiles done in this pass that would take more samples in another.
    pub fn pixels_sampling(&self) -> u64 {
        self.sampling.iter().map(|&n| u64::from(n)).sum()
    }

    /// Notes tile `index` done in this pass with `sampling` pixels still sampling.
    pub(crate) fn tile_done(&mut self, index: u32, sampling: u32) {
        self.sampling[index as usize] = sampling;
    }

    /// The clock, changed by `change`, and its stored form; the passes are unchanged.
    pub(crate) fn clock_with(
        &self,
        change: impl FnOnce(&mut PassClock),
    ) -> Result<(PassClock, String), Error> {
        let mut clock = self.clock.clone();
        change(&mut clock);
        let json = clock.to_json()?;
        Ok((clock, json))
    }

    /// The next pass begins (its clock already stored): each tile goes on from `results`, its
    /// result of the pass that ended (`(index, hash)`), over `tiles` tiles.
    pub(crate) fn begin_next(&mut self, tiles: usize, results: Vec<(u32, String)>) {
        self.previous = vec![None; tiles];
        for (index, hash) in results {
            self.previous[index as usize] = Some(hash);
        }
        self.sampling.fill(0);
    }

    /// The pass and its sample cap, as clients see them.
    pub fn info(&self, spp: u32) -> PassInfo {
        PassInfo {
            pass: self.clock.pass,
            spp: pass_cap(self.clock.pass, spp),
            budget_s: self.budget_s,
        }
    }
}
