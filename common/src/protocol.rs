//! The farm's HTTP API: every request and response body exchanged between the `spindle`
//! command, the coordinator (`spindle-server`) and the workers (`spindle-worker`).
//!
//! The types live here, once, so the three processes cannot drift apart; the coordinator's
//! OpenAPI document (`GET /v1/openapi.json`) is generated from them. Requests reject unknown
//! fields. Every error response has the body [`ApiError`] (`{"error": "..."}`), naming the field
//! or the problem.
//!
//! # Routes
//!
//! Client routes need `Authorization: Bearer $SPINDLE_TOKEN`, worker routes
//! `Authorization: Bearer $SPINDLE_WORKER_TOKEN` (a coordinator on loopback may run without
//! tokens; it refuses a non-loopback address without both). Every worker route but
//! registration also needs the worker's own secret, [`WORKER_SECRET_HEADER`], from
//! [`WorkerRegistered`]: it binds the worker id (in the path or the body) and so the
//! worker's leases (403 otherwise).
//!
//! | method | path | who | body → response |
//! |---|---|---|---|
//! | GET | `/healthz` | anyone | `200 ok` while the process runs |
//! | GET | `/readyz` | anyone | `200 ready` once the database is open, else 503 |
//! | GET | `/v1/openapi.json` | anyone | the OpenAPI 3.1 document |
//! | POST | `/v1/assets/missing` | client | [`MissingAssetsRequest`] → [`MissingAssetsResponse`] |
//! | PUT | `/v1/assets/{hash}` | client | raw bytes (blake3 hex = `hash`, else 400) → [`AssetStored`] |
//! | GET | `/v1/assets/{hash}` | worker | → raw bytes |
//! | POST | `/v1/jobs` | client | [`SubmitJob`] (+ optional [`IDEMPOTENCY_KEY_HEADER`]) → 201 [`JobInfo`] (200 when the key was seen) |
//! | GET | `/v1/jobs` | client | `?state=&name=&limit=&cursor=` → [`JobList`] |
//! | GET | `/v1/jobs/{id}` | client | → [`JobInfo`] |
//! | POST | `/v1/jobs/{id}/cancel` | client | → [`JobInfo`] |
//! | DELETE | `/v1/jobs/{id}` | client | `?force=true` to delete an unfinished job → 204 |
//! | PATCH | `/v1/jobs/{id}` | client | [`JobPatch`] → [`JobInfo`] |
//! | POST | `/v1/jobs/{id}/pause` | client | → [`JobInfo`] |
//! | POST | `/v1/jobs/{id}/resume` | client | → [`JobInfo`] |
//! | POST | `/v1/jobs/{id}/requeue` | client | → [`JobInfo`] (a failed or cancelled job) |
//! | GET | `/v1/jobs/{id}/image.exr` | client | → the final EXR; 409 until the job is done |
//! | GET | `/v1/jobs/{id}/image.png` | client | → a PNG preview of the tiles received so far |
//! | GET | `/v1/jobs/{id}/tiles` | client | → [`JobTiles`]: each tile's rectangle, state and worker |
//! | GET | `/v1/events` | client | Server-Sent Events, each a [`FarmEvent`]; `Last-Event-ID` resumes |
//! | GET | `/v1/workers` | client | → [`WorkerList`] |
//! | POST | `/v1/workers/{id}/drain` | client | (id or name) → [`WorkerList`] of the workers told to drain |
//! | POST | `/v1/workers` | worker | [`RegisterWorker`] → [`WorkerRegistered`] |
//! | POST | `/v1/workers/{id}/lease` | worker | [`LeaseRequest`] (or empty body) → 200 [`Lease`], or 204 after the long poll; 410 when the worker is draining (it exits) |
//! | GET | `/v1/jobs/{id}/spec` | worker | → [`JobSpec`] |
//! | POST | `/v1/leases/{job}/{tile}/heartbeat` | worker | [`Heartbeat`] → [`HeartbeatAck`]; 409 when the lease is no longer yours |
//! | PUT | `/v1/jobs/{job}/tiles/{tile}` | worker | [`TileUpload`] → [`TileAck`]; 409 stale epoch or a different result |
//! | POST | `/v1/leases/{job}/{tile}/fail` | worker | [`TileFailure`] → 204 |
//!
//! # Leases
//!
//! A lease hands one tile of one job to one worker for `ttl_ms`; heartbeats renew it. Each lease
//! of a tile carries a higher `epoch`. The coordinator accepts a tile upload only from the
//! current lease (worker and epoch), or — after the tile is done — an identical result (same
//! [`pixel_hash`]) from anyone, acknowledged as a duplicate. A 409 means: drop this tile and ask
//! for a new lease. A 404 on a job means it was deleted.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::provenance::Provenance;
use crate::scene::SceneDescription;
use crate::stats::RenderStats;
use crate::tile::{TilePixels, TileRect};

/// Tile edge in pixels when a job does not say.
pub const DEFAULT_TILE_SIZE: u32 = 32;

/// Header that makes `POST /v1/jobs` safe to retry: a second submission with the same key
/// returns the job the first one created.
pub const IDEMPOTENCY_KEY_HEADER: &str = "idempotency-key";

/// The longest a `POST /v1/workers/{id}/lease` long poll waits before answering 204.
pub const MAX_LEASE_WAIT_MS: u64 = 20_000;

/// The body of every error response.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ApiError {
    /// What was wrong, naming the field or the problem (`scene.film.width: must be <= 8192`).
    pub error: String,
}

/// Which of these content hashes does the coordinator not have yet?
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MissingAssetsRequest {
    /// blake3 hashes, lowercase hex.
    #[schema(value_type = Vec<Blake3Hash>)]
    pub hashes: Vec<String>,
}

/// The hashes of [`MissingAssetsRequest`] that must be uploaded, in request order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MissingAssetsResponse {
    #[schema(value_type = Vec<Blake3Hash>)]
    pub missing: Vec<String>,
}

/// Answer to an asset upload.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct AssetStored {
    #[schema(value_type = Blake3Hash)]
    pub hash: String,
    /// Size of the stored asset in bytes.
    pub bytes: u64,
}

/// A render job as submitted by a client.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct SubmitJob {
    /// The scene, as in a scene file.
    pub scene: SceneDescription,
    /// For each `obj` shape's `path` in the scene, the blake3 hash of the uploaded file.
    #[serde(default)]
    #[schema(value_type = BTreeMap<String, Blake3Hash>)]
    pub assets: BTreeMap<String, String>,
    /// Tile edge in pixels (default 32).
    #[serde(default = "default_tile_size")]
    #[schema(minimum = 4, maximum = 256)]
    pub tile_size: u32,
    /// Higher runs first; equal priorities run in submission order.
    #[serde(default)]
    pub priority: i32,
    /// Worker labels the job needs (`{"pool": "night"}`): it is leased only to workers whose
    /// labels include every one of these. Checked with [`check_labels`].
    #[serde(default)]
    #[schema(value_type = Labels)]
    pub requires: BTreeMap<String, String>,
    /// A name for people (`spindle submit` sends the scene file's stem); `job-<id>` when absent.
    /// 1 to [`MAX_NAME_LEN`] characters, no control characters.
    #[serde(default)]
    #[schema(
        min_length = 1,
        max_length = 128,
        pattern = "^[^\\x00-\\x1f\\x7f-\\x9f]*$"
    )]
    pub name: Option<String>,
    /// Who submitted the job (`spindle submit` sends `$USER`); a label, not an identity.
    /// 1 to [`MAX_NAME_LEN`] characters, no control characters.
    #[serde(default)]
    #[schema(
        min_length = 1,
        max_length = 128,
        pattern = "^[^\\x00-\\x1f\\x7f-\\x9f]*$"
    )]
    pub submitter: Option<String>,
    /// Render only this window of the film (`spindle submit --crop x,y,w,h`), in film pixels;
    /// the job's EXR then holds the window as its data window inside the film's display
    /// window. It must be non-empty and inside the film ([`check_crop`]). Absent: the whole
    /// film.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crop: Option<TileRect>,
    /// The frame of the scene's `animation` the job renders: each worker makes the still
    /// with [`SceneDescription::at_frame`] (`spindle submit --frames N`). Required for a scene
    /// with `animation`; 0 … 999999.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schema(maximum = 999999)]
    pub frame: Option<u32>,
}

/// Checks a crop window against the film it cuts: at least one pixel, and inside the
/// `width` × `height` film. The error names the field `crop`.
pub fn check_crop(crop: &TileRect, width: u32, height: u32) -> Result<(), String> {
    if crop.width == 0 || crop.height == 0 {
        return Err(format!(
            "crop: must cover at least one pixel (width and height >= 1), got {}x{}",
            crop.width, crop.height
        ));
    }
    // u64 so that a hostile x + width cannot wrap around.
    let right = u64::from(crop.x) + u64::from(crop.width);
    let bottom = u64::from(crop.y) + u64::from(crop.height);
    if right > u64::from(width) || bottom > u64::from(height) {
        return Err(format!(
            "crop: the window {},{} {}x{} is not inside the {width}x{height} film (x + width \
             must be <= {width} and y + height <= {height})",
            crop.x, crop.y, crop.width, crop.height
        ));
    }
    Ok(())
}

/// Longest job name or submitter, in characters.
pub const MAX_NAME_LEN: usize = 128;

/// Checks a job name or submitter: 1 to [`MAX_NAME_LEN`] characters, no control characters.
pub fn check_name(field: &str, value: &str) -> Result<(), String> {
    if value.is_empty() || value.chars().count() > MAX_NAME_LEN {
        return Err(format!("{field}: must be 1 to {MAX_NAME_LEN} characters"));
    }
    if value.chars().any(char::is_control) {
        return Err(format!("{field}: must not contain control characters"));
    }
    Ok(())
}

/// A change to a submitted job (`PATCH /v1/jobs/{id}`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobPatch {
    /// The new priority: higher runs first.
    pub priority: i32,
}

/// Jobs a `GET /v1/jobs` page holds when the query does not say.
pub const DEFAULT_JOB_PAGE: usize = 100;
/// Most jobs one `GET /v1/jobs` page holds.
pub const MAX_JOB_PAGE: usize = 1000;

/// The order of `GET /v1/jobs` (`?order=`): by id, oldest first (`asc`, the default) or newest
/// first (`desc`, as the dashboard and `spindle jobs` show them).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobOrder {
    #[default]
    Asc,
    Desc,
}

impl JobOrder {
    /// The query value.
    pub fn as_str(self) -> &'static str {
        match self {
            JobOrder::Asc => "asc",
            JobOrder::Desc => "desc",
        }
    }

    /// The order a query value names, if any.
    pub fn parse(s: &str) -> Option<JobOrder> {
        match s {
            "asc" => Some(JobOrder::Asc),
            "desc" => Some(JobOrder::Desc),
            _ => None,
        }
    }
}

fn default_tile_size() -> u32 {
    DEFAULT_TILE_SIZE
}

/// Where a job is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum JobState {
    /// Waiting: no tile leased yet.
    Queued,
    /// Tiles are being rendered (or the final image is being assembled).
    Running,
    /// Every tile is in and the final EXR is written.
    Done,
    /// It cannot finish (see `error`): a tile failed deterministically, on three different
    /// workers, or on every connected worker; too many tiles failed; the image could not be
    /// assembled.
    Failed,
    /// Cancelled by a client.
    Cancelled,
    /// Paused by a client: no new tiles are leased; tiles already leased finish and are kept.
    Paused,
}

impl JobState {
    /// Done, failed or cancelled: the job will not change again.
    pub fn is_finished(self) -> bool {
        matches!(
            self,
            JobState::Done | JobState::Failed | JobState::Cancelled
        )
    }

    /// The lowercase name used on the wire and in the database.
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Done => "done",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
            JobState::Paused => "paused",
        }
    }

    /// Inverse of [`JobState::as_str`].
    pub fn parse(name: &str) -> Option<JobState> {
        [
            JobState::Queued,
            JobState::Running,
            JobState::Done,
            JobState::Failed,
            JobState::Cancelled,
            JobState::Paused,
        ]
        .into_iter()
        .find(|s| s.as_str() == name)
    }
}

/// A job's progress, as the coordinator sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobInfo {
    pub id: u64,
    /// The job's name ([`SubmitJob::name`], or `job-<id>`).
    pub name: String,
    pub submitter: Option<String>,
    /// When the job was submitted, in ms since the Unix epoch.
    pub submitted_at_ms: i64,
    pub state: JobState,
    pub priority: i32,
    pub width: u32,
    pub height: u32,
    pub tile_size: u32,
    pub tiles_done: u32,
    pub tiles_total: u32,
    /// Seconds since the first tile was leased (0 while queued), up to the end of the job.
    pub elapsed_s: f64,
    /// Estimated seconds left, from the rate so far; absent until a tile is done.
    pub eta_s: Option<f64>,
    /// Why the job failed.
    pub error: Option<String>,
    /// The latest tile failures of this job, oldest first (at most [`RECENT_TILE_ERRORS`]).
    pub recent_errors: Vec<TileError>,
    /// Workers connected to the coordinator now (in a lease poll, holding a lease, or heard
    /// from within one lease TTL): 0 means nobody will render a queued job until one connects.
    pub workers_live: u32,
    /// The worker labels the job needs ([`SubmitJob::requires`]).
    #[schema(value_type = Labels)]
    pub requires: BTreeMap<String, String>,
    /// Connected workers that may take this job's tiles now: not draining, and labelled with
    /// every one of `requires`. With `workers_live > 0` and this 0, the job waits for an
    /// eligible worker.
    pub workers_eligible: u32,
    /// Counters of the tiles received so far.
    pub stats: RenderStats,
    /// What the job's scene builds to — renderer version, objects, triangles, lights, warnings
    /// and the single-scattering plan — as the first worker to deliver a tile reported it
    /// (absent until then); written into the job's EXR header.
    #[serde(default)]
    pub provenance: Option<Provenance>,
    /// The image's estimated relative RMS error over the tiles done so far,
    /// `sqrt(Σ stderr²) / sqrt(Σ total²)` over their pixels and channels (the `stderr` layer
    /// against the `total` layer; [`crate::noise::NoiseSums`]); absent — unknown — until a tile
    /// that is not black is in, and at 1 spp, where no pixel has two samples to estimate its
    /// error from.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relative_error: Option<f64>,
    /// The window of the film the job renders ([`SubmitJob::crop`]); absent: the whole film
    /// (`width` × `height`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crop: Option<TileRect>,
    /// A job with `film.time_budget_s`: the progressive pass being rendered (`tiles_done`
    /// counts this pass's tiles) or, once the job is done, the last one, whose sample cap is the
    /// image's `spp` (`spindle render --workers 0 --no-time-budget --spp N` reproduces it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub passes: Option<PassInfo>,
}

/// Where a budgeted job's progressive passes stand ([`JobInfo::passes`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct PassInfo {
    /// The pass (from 1).
    pub pass: u32,
    /// Its sample cap, `min(16 · pass, film.spp)`: the samples every pixel has after it (or
    /// fewer, where a pixel met `film.target_error`).
    pub spp: u32,
    /// `film.time_budget_s`.
    pub budget_s: f64,
}

/// How many tile failures a [`JobInfo`] keeps (the newest).
pub const RECENT_TILE_ERRORS: usize = 5;

/// One tile a worker could not render, as reported in [`JobInfo::recent_errors`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TileError {
    /// The tile's index in the job.
    pub tile: u32,
    pub worker_id: u64,
    /// The worker's name as it registered.
    pub worker: String,
    /// When the failure was reported, in ms since the Unix epoch.
    pub at_ms: i64,
    /// The worker's reason.
    pub message: String,
}

/// Where one tile of a job is, as `GET /v1/jobs/{id}/tiles` shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum TileState {
    /// Not leased (never, or its lease lapsed or failed).
    Queued,
    /// A worker holds its lease.
    Leased,
    /// Its result is in.
    Done,
    /// Not done, and at least one worker reported a failure for it.
    Failed,
}

/// One tile of a job, for the dashboard's tile map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TileInfo {
    /// The tile's index in the job (tiles are numbered centre first).
    pub index: u32,
    pub rect: TileRect,
    pub state: TileState,
    /// The worker holding the lease (leased), or the one that rendered it (done), when known.
    pub worker: Option<String>,
    /// Workers that reported a failure of this tile.
    pub failures: u32,
    /// A done tile's render time as its worker reported it, in seconds, when known.
    #[serde(default)]
    pub render_seconds: Option<f64>,
}

/// Every tile of a job, by index.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobTiles {
    pub job: u64,
    pub tiles: Vec<TileInfo>,
}

/// A page of jobs, oldest first.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobList {
    pub jobs: Vec<JobInfo>,
    /// Pass as `cursor` for the next page; absent on the last page. Opaque.
    pub next_cursor: Option<String>,
}

/// A worker introduces itself.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct RegisterWorker {
    /// A human-readable name (host name, …), for logs: 1 to 200 characters.
    #[schema(min_length = 1, max_length = 200)]
    pub name: String,
    /// Render threads the worker runs: 1 to [`MAX_WORKER_THREADS`].
    #[schema(minimum = 1, maximum = 65536)]
    pub threads: u32,
    /// The worker's version (`spindle-worker --version`): at most 64 characters.
    #[serde(default)]
    #[schema(max_length = 64)]
    pub version: String,
    /// `key=value` labels (`--label pool=night`) that jobs can require; see [`check_labels`].
    #[serde(default)]
    #[schema(value_type = Labels)]
    pub labels: BTreeMap<String, String>,
}

impl RegisterWorker {
    /// Checks the fields the document bounds; the error names the field.
    pub fn check(&self) -> Result<(), String> {
        if self.name.is_empty() || self.name.chars().count() > 200 {
            return Err("name: must be 1 to 200 characters".into());
        }
        if !(1..=MAX_WORKER_THREADS).contains(&self.threads) {
            return Err(format!(
                "threads: must be 1 to {MAX_WORKER_THREADS}, got {}",
                self.threads
            ));
        }
        if self.version.chars().count() > 64 {
            return Err("version: must be at most 64 characters".into());
        }
        check_labels("labels", &self.labels)
    }
}

/// Most render threads a worker may report.
pub const MAX_WORKER_THREADS: u32 = 65536;

/// Most labels a worker may carry or a job may require.
pub const MAX_LABELS: usize = 16;
/// Longest label key or value, in bytes.
pub const MAX_LABEL_LEN: usize = 63;

/// Checks one label key or value: 1 to [`MAX_LABEL_LEN`] ASCII letters, digits, `_`, `-`, `.`.
fn check_label_part(what: &str, s: &str) -> Result<(), String> {
    if s.is_empty() || s.len() > MAX_LABEL_LEN {
        return Err(format!("{what} {s:?}: must be 1 to {MAX_LABEL_LEN} bytes"));
    }
    if let Some(c) = s
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.')))
    {
        return Err(format!(
            "{what} {s:?}: {c:?} is not allowed (letters, digits, _ - . only)"
        ));
    }
    Ok(())
}

/// The API document's shape of a set of labels ([`check_labels`]): at most [`MAX_LABELS`]
/// entries, keys and values of 1 to [`MAX_LABEL_LEN`] letters, digits, `_`, `-`, `.`.
pub struct Labels;

impl utoipa::PartialSchema for Labels {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{ObjectBuilder, Type};
        let part = || {
            ObjectBuilder::new()
                .schema_type(Type::String)
                .pattern(Some(format!("^[A-Za-z0-9_.-]{{1,{MAX_LABEL_LEN}}}$")))
        };
        ObjectBuilder::new()
            .schema_type(Type::Object)
            .property_names(Some(part()))
            .additional_properties(Some(part()))
            .max_properties(Some(MAX_LABELS))
            .description(Some(
                "key=value labels: letters, digits, _ - . (1 to 63 each)",
            ))
            .into()
    }
}

impl ToSchema for Labels {
    fn name() -> std::borrow::Cow<'static, str> {
        "Labels".into()
    }
}

/// Checks a set of labels (a worker's, or a job's requirements); `field` names them in the
/// error (`labels: key "a b": ' ' is not allowed …`).
pub fn check_labels(field: &str, labels: &BTreeMap<String, String>) -> Result<(), String> {
    if labels.len() > MAX_LABELS {
        return Err(format!(
            "{field}: {} labels, at most {MAX_LABELS} are allowed",
            labels.len()
        ));
    }
    for (k, v) in labels {
        check_label_part("key", k).map_err(|e| format!("{field}: {e}"))?;
        check_label_part("value", v).map_err(|e| format!("{field}.{k}: {e}"))?;
    }
    Ok(())
}

/// Parses one `key=value` label as given on a command line, checked like [`check_labels`].
pub fn parse_label(s: &str) -> Result<(String, String), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("{s:?}: expected key=value"))?;
    check_label_part("key", k)?;
    check_label_part("value", v)?;
    Ok((k.to_string(), v.to_string()))
}

/// `k=v,k2=v2`, for messages.
pub fn format_labels(labels: &BTreeMap<String, String>) -> String {
    labels
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// What a worker is doing, as the coordinator sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum WorkerState {
    /// Connected, holding no lease.
    Idle,
    /// Holding a lease.
    Rendering,
    /// Told to drain: it finishes the tile in hand, takes no more and exits.
    Draining,
    /// Not heard from (no lease poll, heartbeat or upload) for longer than the lease TTL.
    Lost,
}

impl WorkerState {
    /// The lowercase name used on the wire.
    pub fn as_str(self) -> &'static str {
        match self {
            WorkerState::Idle => "idle",
            WorkerState::Rendering => "rendering",
            WorkerState::Draining => "draining",
            WorkerState::Lost => "lost",
        }
    }
}

/// One worker, as listed by `GET /v1/workers`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WorkerInfo {
    pub id: u64,
    pub name: String,
    pub version: String,
    pub threads: u32,
    #[schema(value_type = Labels)]
    pub labels: BTreeMap<String, String>,
    pub state: WorkerState,
    /// The job and tile of a lease the worker holds (the lowest, if it holds several).
    pub job: Option<u64>,
    pub tile: Option<u32>,
    /// When the worker was last heard from (lease poll, heartbeat, upload, failure), in ms
    /// since the Unix epoch.
    pub last_seen_ms: i64,
    /// Tiles the coordinator accepted from this worker, ever.
    pub tiles_done: u64,
    /// Tile failures this worker reported, ever.
    pub failures: u64,
    /// Tiles accepted in the last [`THROUGHPUT_WINDOW_S`] seconds, divided by that window in
    /// minutes.
    pub tiles_per_min: f64,
}

/// The window of [`WorkerInfo::tiles_per_min`], in seconds.
pub const THROUGHPUT_WINDOW_S: u64 = 300;

/// Registered workers, by id: every connected one, and the lost ones heard from within
/// [`LOST_WORKERS_LISTED_S`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WorkerList {
    pub workers: Vec<WorkerInfo>,
}

/// One event of `GET /v1/events` (Server-Sent Events): the SSE `id:` is `id`, the SSE
/// `event:` is `type`, and `data:` is this object as JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct FarmEvent {
    /// Grows by one with every event.
    pub id: u64,
    /// When it happened, in ms since the Unix epoch.
    pub at_ms: i64,
    #[serde(flatten)]
    pub kind: EventKind,
}

/// The API document's shape of one Server-Sent Event of `GET /v1/events`, as a client parses
/// it: `id` and `event` as text, `data` a [`FarmEvent`] as JSON.
pub struct SseFarmEvent;

impl utoipa::PartialSchema for SseFarmEvent {
    fn schema() -> utoipa::openapi::RefOr<utoipa::openapi::schema::Schema> {
        use utoipa::openapi::schema::{ObjectBuilder, Type};
        let text = |description: &str| {
            ObjectBuilder::new()
                .schema_type(Type::String)
                .description(Some(description))
        };
        ObjectBuilder::new()
            .schema_type(Type::Object)
            .property(
                "id",
                text("the event's `id`").pattern(Some("^[0-9]{1,19}$")),
            )
            .property("event", text("the event's `type`"))
            .property(
                "data",
                text("the FarmEvent, as JSON").content_media_type("application/json"),
            )
            .property("retry", ObjectBuilder::new().schema_type(Type::Integer))
            .required("id")
            .required("event")
            .required("data")
            .into()
    }
}

impl ToSchema for SseFarmEvent {
    fn name() -> std::borrow::Cow<'static, str> {
        "SseFarmEvent".into()
    }
}

/// What a [`FarmEvent`] says.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum EventKind {
    /// A job entered `state` (submitted: `queued`).
    JobState {
        job: u64,
        state: JobState,
        error: Option<String>,
    },
    /// A tile was accepted; `seconds` from its lease to its upload (absent when the lease was
    /// granted before a coordinator restart), `render_seconds` the worker's own render time
    /// (absent when it did not report one).
    TileDone {
        job: u64,
        tile: u32,
        worker_id: u64,
        worker: String,
        seconds: Option<f64>,
        #[serde(default)]
        render_seconds: Option<f64>,
    },
    WorkerJoined {
        worker_id: u64,
        worker: String,
    },
    WorkerDraining {
        worker_id: u64,
        worker: String,
    },
    /// Not heard from for longer than the lease TTL.
    WorkerLost {
        worker_id: u64,
        worker: String,
    },
    /// The `Last-Event-ID` a client reconnected with is older than the events kept: refetch
    /// the state (`GET /v1/jobs`, `GET /v1/workers`), then follow on from this event's id.
    Reset,
}

impl EventKind {
    /// The SSE event name (the `type` field).
    pub fn name(&self) -> &'static str {
        match self {
            EventKind::JobState { .. } => "job_state",
            EventKind::TileDone { .. } => "tile_done",
            EventKind::WorkerJoined { .. } => "worker_joined",
            EventKind::WorkerDraining { .. } => "worker_draining",
            EventKind::WorkerLost { .. } => "worker_lost",
            EventKind::Reset => "reset",
        }
    }
}

/// How long a lost worker stays in [`WorkerList`], in seconds.
pub const LOST_WORKERS_LISTED_S: u64 = 3600;

/// The id a worker uses in every later request, and the secret that proves it is that worker.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WorkerRegistered {
    pub worker_id: u64,
    /// Sent back as the [`WORKER_SECRET_HEADER`] of every later request of this worker;
    /// `<worker id>.<64 hex digits>` (256 random bits). Shown once: the coordinator keeps only
    /// its SHA-256.
    #[schema(pattern = "^[0-9]{1,20}\\.[0-9a-f]{64}$")]
    pub worker_secret: String,
}

/// The header carrying a worker's secret ([`WorkerRegistered::worker_secret`]) on every worker
/// route but registration; missing or wrong, the answer is 403.
pub const WORKER_SECRET_HEADER: &str = "spindle-worker-secret";

/// The header of a tile upload naming the epoch of the lease it answers
/// ([`TileUpload::epoch`]), so the coordinator can refuse an upload for a lease that is not
/// the worker's before reading its body (409). Optional; when given it must match the body's.
pub const LEASE_EPOCH_HEADER: &str = "spindle-lease-epoch";

/// Options of a lease request; an empty body means the defaults.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(default, deny_unknown_fields)]
pub struct LeaseRequest {
    /// How long to wait for work before answering 204, in ms (default and maximum
    /// [`MAX_LEASE_WAIT_MS`]).
    pub wait_ms: Option<u64>,
}

/// One tile of one job, handed to one worker until `ttl_ms` passes without a heartbeat.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Lease {
    pub job_id: u64,
    /// The tile's index in the job's centre-first order ([`JobSpec::tiles`]: the film, or the
    /// job's crop window, split by the job's tile size).
    pub tile_index: u32,
    pub rect: TileRect,
    /// Grows with every lease of this tile; quote it in heartbeats, uploads and failures.
    pub epoch: u64,
    /// The lease lapses this long after it was granted or last renewed.
    pub ttl_ms: u64,
    /// A job with `film.time_budget_s` renders in progressive passes, numbered from 1: render
    /// this pass of the tile, continuing from the previous pass's result
    /// (`GET /v1/leases/{job}/{tile}/previous`), and upload it with its `pixels.progress`.
    /// Absent: render the tile in one pass.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pass: Option<u32>,
}

/// What a worker needs to render a job's tiles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobSpec {
    pub scene: SceneDescription,
    /// `obj` path in the scene → blake3 hash; fetch each with `GET /v1/assets/{hash}`.
    #[schema(value_type = BTreeMap<String, Blake3Hash>)]
    pub assets: BTreeMap<String, String>,
    pub tile_size: u32,
    /// Only this window of the film is rendered ([`SubmitJob::crop`]); absent: the whole film.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub crop: Option<TileRect>,
    /// The frame of the scene's `animation` rendered ([`SubmitJob::frame`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<u32>,
}

impl JobSpec {
    /// The still the job renders: the scene at its frame ([`SceneDescription::at_frame`], the
    /// one function every process that renders a frame calls), or the scene itself.
    pub fn still(&self) -> SceneDescription {
        match self.frame {
            Some(frame) => self.scene.at_frame(frame),
            None => self.scene.clone(),
        }
    }

    /// The rectangle of the film the job renders: the crop, or the whole film at (0, 0).
    pub fn window(&self) -> TileRect {
        self.crop.unwrap_or(TileRect {
            x: 0,
            y: 0,
            width: self.scene.film.width,
            height: self.scene.film.height,
        })
    }

    /// The job's tiles by index, in film coordinates: [`crate::tile::split_window_centre_first`]
    /// of [`JobSpec::window`] and the tile size. Leases, the tile map and assembly all number
    /// tiles this way.
    pub fn tiles(&self) -> Vec<TileRect> {
        crate::tile::split_window_centre_first(self.window(), self.tile_size)
    }
}

/// "I am still rendering this tile."
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Heartbeat {
    pub worker_id: u64,
    pub epoch: u64,
}

/// The lease was renewed for another `ttl_ms`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct HeartbeatAck {
    pub ttl_ms: u64,
    /// The worker is draining: finish this tile, deliver it, ask for no more and exit.
    #[serde(default)]
    pub drain: bool,
}

/// A rendered tile.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TileUpload {
    pub worker_id: u64,
    pub epoch: u64,
    /// [`pixel_hash`] of `pixels`; the coordinator recomputes it (400 on mismatch).
    #[schema(value_type = Blake3Hash)]
    pub hash: String,
    pub pixels: TilePixels,
    /// Wall-clock seconds the worker spent rendering the tile (finite, 0 to
    /// [`MAX_RENDER_SECONDS`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render_seconds: Option<f64>,
    /// What the worker built from the job's scene ([`Provenance::check`] bounds it); the
    /// coordinator keeps the first one a job receives and writes it into the job's EXR header.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

/// The largest [`TileUpload::render_seconds`] accepted: a week.
pub const MAX_RENDER_SECONDS: f64 = 7.0 * 24.0 * 3600.0;

impl TileUpload {
    /// Checks the fields a worker reports about its render (not the pixels); the error names
    /// the field.
    pub fn check_report(&self) -> Result<(), String> {
        if let Some(s) = self.render_seconds
            && !(s.is_finite() && (0.0..=MAX_RENDER_SECONDS).contains(&s))
        {
            return Err(format!(
                "render_seconds: must be finite, 0 to {MAX_RENDER_SECONDS}, got {s}"
            ));
        }
        match &self.provenance {
            Some(p) => p.check(),
            None => Ok(()),
        }
    }
}

impl TileUpload {
    /// The most bytes the MessagePack form ([`crate::tile_encoding`], before compression) of
    /// an upload of `rect` can take: every layer value as an f64 (9 bytes; a worker writes
    /// f32, 5 bytes), a progressive pass's sums for every pixel, and a provenance of
    /// [`crate::provenance::MAX_LINES`] lines of the longest length. The coordinator refuses an
    /// upload whose body inflates past it before parsing anything, so what one upload can
    /// cost in memory is set by the tile's size, not by the body.
    pub fn max_packed_bytes(rect: TileRect) -> usize {
        const VALUE: usize = 9;
        // A pixel's `PixelSums`: 15 numbers, its field names and headers (about 205 bytes as
        // written, every number as an f64 or u64), and the passes' 8 sums (about 110 more).
        const PIXEL_SUMS: usize = 384;
        let values = rect.pixel_count() * MAX_VALUES_PER_PIXEL;
        values * VALUE + rect.pixel_count() * PIXEL_SUMS + UPLOAD_FIXED_BYTES
    }

    /// The most bytes the JSON form of an upload of `rect` can take (`serde_json`'s writing:
    /// at most 24 characters and a comma per number).
    pub fn max_json_bytes(rect: TileRect) -> usize {
        const VALUE: usize = 32;
        const PIXEL_SUMS: usize = 768;
        let values = rect.pixel_count() * MAX_VALUES_PER_PIXEL;
        // A provenance line's characters written as `\u00XX` escapes take 6 bytes each.
        values * VALUE + rect.pixel_count() * PIXEL_SUMS + 6 * UPLOAD_FIXED_BYTES
    }
}

/// The most values a pixel of an upload can have: every layer's and every optional pass's.
const MAX_VALUES_PER_PIXEL: usize =
    crate::tile::VALUES_PER_PIXEL + crate::aov::MAX_VALUES_PER_PIXEL;

/// The bytes of an upload beside its pixel values: the provenance (two lists of
/// [`crate::provenance::MAX_LINES`] lines of [`crate::provenance::MAX_LINE_BYTES`], and the
/// renderer's name), the statistics, the hash and the field names, with room to spare.
const UPLOAD_FIXED_BYTES: usize =
    (2 * crate::provenance::MAX_LINES + 1) * (crate::provenance::MAX_LINE_BYTES + 8) + 16 * 1024;

/// How the coordinator took a tile upload.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "snake_case")]
pub enum TileOutcome {
    /// Stored: this upload completed the tile.
    Accepted,
    /// The tile was already done with an identical result; nothing changed.
    Duplicate,
}

/// Acknowledgement of a tile upload; stop retrying once received.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TileAck {
    pub outcome: TileOutcome,
}

/// "I could not render this tile."
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TileFailure {
    pub worker_id: u64,
    pub epoch: u64,
    pub reason: String,
    /// The failure depends only on the job, not on the worker (the scene does not build, the
    /// pixels overflow f32): no other worker can do better, so the job fails at once.
    #[serde(default)]
    pub deterministic: bool,
}

/// The canonical bytes of a tile's pixels: the rectangle (`x, y, width, height` as u32
/// little-endian), then each layer in [`crate::tile::LAYERS`] order as f32 little-endian
/// bits, then the optional passes' values if there are any (their count as u64, then each as f32
/// bits), then a progressive pass's state if there is one ([`crate::passes::TileProgress::canonical_bytes`]).
/// Statistics are not part of it.
pub fn canonical_pixel_bytes(pixels: &TilePixels) -> Vec<u8> {
    let floats: usize = pixels.layers().iter().map(|l| l.len()).sum();
    let mut bytes = Vec::with_capacity(16 + 4 * floats);
    let r = pixels.rect;
    for v in [r.x, r.y, r.width, r.height] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for layer in pixels.layers() {
        for v in layer {
            bytes.extend_from_slice(&v.to_bits().to_le_bytes());
        }
    }
    if !pixels.aov.is_empty() {
        bytes.extend_from_slice(&(pixels.aov.len() as u64).to_le_bytes());
        for v in &pixels.aov {
            bytes.extend_from_slice(&v.to_bits().to_le_bytes());
        }
    }
    if let Some(progress) = &pixels.progress {
        progress.canonical_bytes(&mut bytes);
    }
    bytes
}

/// blake3 of [`canonical_pixel_bytes`], lowercase hex: the `hash` of a [`TileUpload`].
pub fn pixel_hash(pixels: &TilePixels) -> String {
    blake3::hash(&canonical_pixel_bytes(pixels))
        .to_hex()
        .to_string()
}

/// blake3 of an asset's bytes, lowercase hex: the name assets are stored and fetched by.
pub fn asset_hash(bytes: &[u8]) -> String {
    blake3::hash(bytes).to_hex().to_string()
}

/// The API document's name for a blake3 hash in lowercase hex (the Rust fields are `String`s
/// checked with [`is_hash`]).
#[derive(ToSchema)]
#[schema(pattern = "^[0-9a-f]{64}$")]
pub struct Blake3Hash(#[allow(dead_code)] String);

/// Is `s` a well-formed hash (64 lowercase hex digits)?
pub fn is_hash(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest upload a worker can honestly send (the largest tile, with a pass's sums,
    /// numbers of the longest written form that do not compress, every statistic at
    /// `u64::MAX`, the longest provenance) fits both bounds, in each form and compressed.
    #[test]
    fn the_largest_honest_upload_fits_the_bounds() {
        let rect = TileRect {
            x: 0,
            y: 0,
            width: 256,
            height: 256,
        };
        let mut pixels = TilePixels::black(rect);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for layer in [
            &mut pixels.total,
            &mut pixels.surface,
            &mut pixels.single_scatter,
            &mut pixels.multiple_scatter,
            &mut pixels.stderr,
        ] {
            for v in layer.iter_mut() {
                *v = -f32::from_bits((next() as u32 & 0x007f_ffff) | 0x0080_0000);
            }
        }
        pixels.aov = (0..rect.pixel_count() * crate::aov::MAX_VALUES_PER_PIXEL)
            .map(|_| -f32::from_bits((next() as u32 & 0x007f_ffff) | 0x0080_0000))
            .collect();
        let mut stats = serde_json::to_value(RenderStats::default()).unwrap();
        for v in stats.as_object_mut().unwrap().values_mut() {
            *v = serde_json::Value::from(u64::MAX);
        }
        pixels.stats = serde_json::from_value(stats).unwrap();
        let mut long_f64 = || -f64::from_bits((next() & 0x000f_ffff_ffff_ffff) | 1 << 52);
        let sums = (0..rect.pixel_count())
            .map(|_| crate::passes::PixelSums {
                surface: [long_f64(), long_f64(), long_f64()],
                single_scatter: [long_f64(), long_f64(), long_f64()],
                multiple_scatter: [long_f64(), long_f64(), long_f64()],
                mean: [long_f64(), long_f64(), long_f64()],
                m2: [long_f64(), long_f64(), long_f64()],
                mean_y: long_f64(),
                m2_y: long_f64(),
                taken: u32::MAX,
                hits: u32::MAX,
                converged: true,
                aov: Some(crate::aov::AovSums {
                    depth: long_f64(),
                    normal: [long_f64(), long_f64(), long_f64()],
                    albedo: [long_f64(), long_f64(), long_f64()],
                    id: u32::MAX,
                }),
            })
            .collect();
        pixels.progress = Some(crate::passes::TileProgress {
            pass: u32::MAX,
            spp: u32::MAX,
            pixels: sums,
        });
        // Quotes and backslashes: two bytes each in JSON.
        let line = "\"\\".repeat(crate::provenance::MAX_LINE_BYTES / 2);
        let lines = vec![line.clone(); crate::provenance::MAX_LINES];
        let provenance = Provenance::new(&line, u64::MAX, u64::MAX, u64::MAX, &lines, &lines);
        provenance.check().unwrap();
        let upload = TileUpload {
            worker_id: u64::MAX,
            epoch: u64::MAX,
            hash: pixel_hash(&pixels),
            pixels,
            render_seconds: Some(MAX_RENDER_SECONDS / 3.0),
            provenance: Some(provenance),
        };
        let packed = rmp_serde::to_vec_named(&upload).unwrap().len();
        let compressed = crate::tile_encoding::encode(&upload).unwrap().len();
        let json = serde_json::to_vec(&upload).unwrap().len();
        let (max_packed, max_json) = (
            TileUpload::max_packed_bytes(rect),
            TileUpload::max_json_bytes(rect),
        );
        assert!(packed <= max_packed, "{packed} > {max_packed}");
        assert!(compressed <= max_packed, "{compressed} > {max_packed}");
        assert!(json <= max_json, "{json} > {max_json}");
        // And the bounds are not loose by more than the f64 allowance: a fraction of the 16 MiB
        // route limit they replace.
        assert!(max_packed < 2 * packed, "{max_packed} vs {packed}");
        assert!(max_json < 2 * json, "{max_json} vs {json}");
    }

    fn tile() -> TilePixels {
        let mut t = TilePixels::black(TileRect {
            x: 3,
            y: 4,
            width: 2,
            height: 1,
        });
        t.total[0] = 1.0;
        t
    }

    #[test]
    fn canonical_bytes_follow_the_documented_layout() {
        let t = tile();
        let b = canonical_pixel_bytes(&t);
        // Five RGB layers of two pixels, then alpha's two values.
        assert_eq!(b.len(), 16 + 4 * (5 * 6 + 2));
        assert_eq!(&b[0..4], &3u32.to_le_bytes());
        assert_eq!(&b[12..16], &1u32.to_le_bytes());
        assert_eq!(&b[16..20], &1.0f32.to_bits().to_le_bytes());
        assert_eq!(
            pixel_hash(&t),
            blake3::hash(&b).to_hex().to_string(),
            "pixel_hash is blake3 of the canonical bytes"
        );
    }

    #[test]
    fn hash_changes_with_one_pixel_and_ignores_stats() {
        let a = tile();
        let mut b = a.clone();
        b.single_scatter[5] = f32::from_bits(1);
        assert_ne!(pixel_hash(&a), pixel_hash(&b));
        let mut c = a.clone();
        c.stats.camera_rays = 7;
        assert_eq!(pixel_hash(&a), pixel_hash(&c));
    }

    #[test]
    fn known_blake3_vector() {
        // blake3 of the empty input, from the BLAKE3 specification's test vectors.
        assert_eq!(
            asset_hash(b""),
            "af1349b9f5f9a1a6a0404dea36dcc9499bcb25c9adc112b7cc9a93cae41f3262"
        );
        assert!(is_hash(&asset_hash(b"x")));
        assert!(!is_hash(
            "AF1349b9f5f9a1a6a0404dea36dcc9499bcb25c9adc112b7cc9a93cae41f3262"
        ));
        assert!(!is_hash("../etc/passwd"));
    }

    /// Tiles travel as JSON numbers: every finite f32 must survive the round trip bit for bit,
    /// or farm images would differ from single-process ones.
    #[test]
    fn f32_pixels_survive_json_exactly() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut values = vec![0.0f32, -0.0, f32::MIN_POSITIVE, f32::MAX, f32::from_bits(1)];
        while values.len() < 200_000 {
            // xorshift64*: a fixed pseudo-random sweep over bit patterns.
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            let v = f32::from_bits((state.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 32) as u32);
            if v.is_finite() {
                values.push(v);
            }
        }
        let json = serde_json::to_string(&values).unwrap();
        let back: Vec<f32> = serde_json::from_str(&json).unwrap();
        for (a, b) in values.iter().zip(&back) {
            assert_eq!(a.to_bits(), b.to_bits(), "{a:e} came back as {b:e}");
        }
    }

    #[test]
    fn requests_reject_unknown_fields_and_fill_defaults() {
        let scene = r#"{"camera":{"position":[0,0,5],"look_at":[0,0,0],"fov_y":40},
                        "film":{"width":8,"height":8}}"#;
        let ok: SubmitJob = serde_json::from_str(&format!(r#"{{"scene":{scene}}}"#)).unwrap();
        assert_eq!((ok.tile_size, ok.priority), (32, 0));
        assert!(ok.assets.is_empty() && ok.requires.is_empty());
        let bad = serde_json::from_str::<SubmitJob>(&format!(r#"{{"scene":{scene},"spp":3}}"#));
        assert!(bad.unwrap_err().to_string().contains("unknown field `spp`"));
        let lease: LeaseRequest = serde_json::from_str("{}").unwrap();
        assert_eq!(lease.wait_ms, None);
        for s in ["queued", "running", "done", "failed", "cancelled", "paused"] {
            let state = JobState::parse(s).unwrap();
            assert_eq!(serde_json::to_value(state).unwrap(), s);
        }
    }

    #[test]
    fn a_crop_must_be_non_empty_and_inside_the_film_and_its_error_names_crop() {
        let rect = |x, y, width, height| TileRect {
            x,
            y,
            width,
            height,
        };
        // The film is 40 x 24: its last pixel is (39, 23).
        for ok in [rect(0, 0, 40, 24), rect(39, 23, 1, 1), rect(10, 5, 30, 19)] {
            assert_eq!(check_crop(&ok, 40, 24), Ok(()), "{ok:?}");
        }
        for bad in [
            rect(0, 0, 0, 5),
            rect(3, 3, 5, 0),
            rect(0, 0, 41, 24),
            rect(0, 0, 40, 25),
            rect(40, 0, 1, 1),
            rect(u32::MAX, 0, 2, 1),
            rect(0, u32::MAX, 1, u32::MAX),
        ] {
            let err = check_crop(&bad, 40, 24).unwrap_err();
            assert!(err.starts_with("crop: "), "{bad:?}: {err}");
        }
    }

    #[test]
    fn a_job_without_a_crop_reads_and_writes_as_before_and_its_window_is_the_film() {
        let scene = r#"{"camera":{"position":[0,0,5],"look_at":[0,0,0],"fov_y":40},
                        "film":{"width":8,"height":6}}"#;
        let spec: JobSpec = serde_json::from_str(&format!(
            r#"{{"scene":{scene},"assets":{{}},"tile_size":4}}"#
        ))
        .unwrap();
        assert_eq!(spec.crop, None);
        assert!(!serde_json::to_string(&spec).unwrap().contains("crop"));
        assert_eq!(
            spec.window(),
            TileRect {
                x: 0,
                y: 0,
                width: 8,
                height: 6
            }
        );
        assert_eq!(spec.tiles().len(), 4);
        let cropped = JobSpec {
            crop: Some(TileRect {
                x: 5,
                y: 1,
                width: 3,
                height: 5,
            }),
            ..spec
        };
        let tiles = cropped.tiles();
        // Columns 5..8 and rows 1..6 in 4-px tiles: rows 1..5 and 5..6.
        assert_eq!(tiles.len(), 2);
        assert!(tiles.iter().all(|t| t.x == 5 && t.width == 3));
        assert_eq!(tiles.iter().map(|t| t.height).sum::<u32>(), 5);
    }

    #[test]
    fn events_are_flat_json_with_their_type() {
        let e = FarmEvent {
            id: 7,
            at_ms: 1,
            kind: EventKind::JobState {
                job: 3,
                state: JobState::Running,
                error: None,
            },
        };
        let v = serde_json::to_value(&e).unwrap();
        assert_eq!(
            v,
            serde_json::json!({"id": 7, "at_ms": 1, "type": "job_state", "job": 3,
                               "state": "running", "error": null})
        );
        assert_eq!(e.kind.name(), v["type"]);
        assert_eq!(serde_json::from_value::<FarmEvent>(v).unwrap(), e);
    }

    #[test]
    fn labels_are_checked_naming_the_field() {
        assert_eq!(
            parse_label("pool=night"),
            Ok(("pool".into(), "night".into()))
        );
        let long = format!("k={}", "v".repeat(64));
        for bad in [
            "pool",
            "=night",
            "pool=",
            "po ol=x",
            "pool=a/b",
            long.as_str(),
        ] {
            assert!(parse_label(bad).is_err(), "{bad}");
        }
        let mut labels: BTreeMap<String, String> = (0..MAX_LABELS)
            .map(|i| (format!("k{i}"), "v".into()))
            .collect();
        assert_eq!(check_labels("labels", &labels), Ok(()));
        labels.insert("one-more".into(), "v".into());
        assert!(
            check_labels("labels", &labels)
                .unwrap_err()
                .starts_with("labels: 17 labels")
        );
        let bad = BTreeMap::from([("pool".to_string(), "a b".to_string())]);
        let err = check_labels("requires", &bad).unwrap_err();
        assert!(err.starts_with("requires.pool: value \"a b\""), "{err}");
    }
}
