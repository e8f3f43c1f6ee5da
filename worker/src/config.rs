//! The worker's settings: raw values from the command line or the environment become a
//! validated [`Config`], so the rest of the worker never sees a malformed URL or zero threads.

use std::collections::BTreeMap;
use std::time::Duration;

use spindle_common::protocol::check_labels;

use crate::backoff::Backoff;

/// A setting that cannot be used, naming it.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{field}: {problem}")]
pub struct ConfigError {
    pub field: &'static str,
    pub problem: String,
}

/// Everything [`crate::run`] needs.
#[derive(Debug, Clone)]
pub struct Config {
    /// The coordinator's base URL, `http(s)://host:port` (no trailing slash).
    pub coordinator: String,
    /// PEM file of the CA certificates to trust for an https coordinator instead of the
    /// system's (`--ca-cert`, see [`crate::tls`]).
    pub ca_cert: Option<std::path::PathBuf>,
    /// The worker token (`SPINDLE_WORKER_TOKEN`); `None` for a coordinator without tokens.
    pub token: Option<String>,
    /// The name the worker registers under, for the coordinator's logs.
    pub name: String,
    /// `key=value` labels jobs can require (`--label pool=night`); none by default.
    pub labels: BTreeMap<String, String>,
    /// The version it reports when registering.
    pub version: String,
    /// Render threads: the size of the worker's own rayon pool.
    pub threads: usize,
    /// How long one lease request may wait at the coordinator for work.
    pub lease_wait: Duration,
    /// Retry policy for requests that failed for a reason that may pass.
    pub backoff: Backoff,
    /// After a shutdown request, how long the worker keeps trying to upload the tile it
    /// finished before giving up (its lease then lapses and the tile is rendered elsewhere).
    pub shutdown_grace: Duration,
    /// The longest a job's scene may take to build (`--build-time-limit-s`); past it the build
    /// is given up and the tile reported as failed.
    pub build_time_limit: Duration,
    /// The longest one tile's render may take (`--tile-time-limit-s`); past it the render is
    /// given up and the tile reported as failed.
    pub tile_time_limit: Duration,
}

/// Default of [`Config::build_time_limit`], seconds.
pub const DEFAULT_BUILD_TIME_LIMIT_S: f64 = 600.0;
/// Default of [`Config::tile_time_limit`], seconds.
pub const DEFAULT_TILE_TIME_LIMIT_S: f64 = 3600.0;
/// The longest time limit a worker accepts, seconds (a year).
pub const MAX_TIME_LIMIT_S: f64 = 365.0 * 24.0 * 3600.0;

impl Config {
    /// Validates the raw settings. `threads: None` means every core of the machine.
    pub fn new(
        coordinator: &str,
        token: Option<String>,
        name: Option<String>,
        threads: Option<usize>,
    ) -> Result<Config, ConfigError> {
        let coordinator = validate_url(coordinator)?;
        let token = match token {
            Some(t) if t.trim().is_empty() => {
                return Err(ConfigError {
                    field: "token",
                    problem: "is empty (unset it to run without a token)".into(),
                });
            }
            Some(t) => Some(t.trim().to_string()),
            None => None,
        };
        let threads = match threads {
            Some(0) => {
                return Err(ConfigError {
                    field: "threads",
                    problem: "must be >= 1".into(),
                });
            }
            Some(n) => n,
            None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        };
        let name = match name {
            Some(n) if n.trim().is_empty() => {
                return Err(ConfigError {
                    field: "name",
                    problem: "must not be empty".into(),
                });
            }
            Some(n) => n,
            None => default_name(),
        };
        Ok(Config {
            coordinator,
            ca_cert: None,
            token,
            name,
            labels: BTreeMap::new(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            threads,
            lease_wait: Duration::from_secs(10),
            backoff: Backoff::default(),
            shutdown_grace: Duration::from_secs(30),
            build_time_limit: Duration::from_secs_f64(DEFAULT_BUILD_TIME_LIMIT_S),
            tile_time_limit: Duration::from_secs_f64(DEFAULT_TILE_TIME_LIMIT_S),
        })
    }
}

impl Config {
    /// Sets the worker's labels, each parsed `key=value` already; checks their count and form
    /// and refuses a key given twice.
    pub fn with_labels(mut self, labels: Vec<(String, String)>) -> Result<Config, ConfigError> {
        let mut map = BTreeMap::new();
        for (k, v) in labels {
            if map.insert(k.clone(), v).is_some() {
                return Err(ConfigError {
                    field: "label",
                    problem: format!("key {k:?} given twice"),
                });
            }
        }
        check_labels("label", &map).map_err(|problem| ConfigError {
            field: "label",
            problem: problem
                .trim_start_matches("label")
                .trim_start_matches(": ")
                .into(),
        })?;
        self.labels = map;
        Ok(self)
    }
}

impl Config {
    /// Sets the time limits of a scene build and of a tile's render, in seconds, each more
    /// than 0 and at most [`MAX_TIME_LIMIT_S`].
    pub fn with_time_limits(mut self, build_s: f64, tile_s: f64) -> Result<Config, ConfigError> {
        self.build_time_limit = time_limit("build-time-limit-s", build_s)?;
        self.tile_time_limit = time_limit("tile-time-limit-s", tile_s)?;
        Ok(self)
    }
}

fn time_limit(field: &'static str, seconds: f64) -> Result<Duration, ConfigError> {
    if !(seconds > 0.0 && seconds <= MAX_TIME_LIMIT_S) {
        return Err(ConfigError {
            field,
            problem: format!(
                "{seconds} s is not a time limit: give seconds, more than 0 and at most \
                 {MAX_TIME_LIMIT_S} (a year)"
            ),
        });
    }
    Ok(Duration::from_secs_f64(seconds))
}

/// Accepts `http://host[:port][/]` and `https://host[:port][/]`.
fn validate_url(raw: &str) -> Result<String, ConfigError> {
    let bad = |problem: String| ConfigError {
        field: "coordinator",
        problem,
    };
    let url = reqwest::Url::parse(raw.trim()).map_err(|e| {
        bad(format!(
            "`{raw}` is not a URL ({e}); expected http://HOST:PORT"
        ))
    })?;
    if !matches!(url.scheme(), "http" | "https") {
        return Err(bad(format!(
            "scheme `{}` is not supported; expected https://HOST:PORT or http://HOST:PORT",
            url.scheme()
        )));
    }
    if url.host_str().is_none_or(str::is_empty) {
        return Err(bad(format!("`{raw}` has no host")));
    }
    if url.query().is_some() || url.fragment().is_some() {
        return Err(bad(format!("`{raw}` must not have a query or fragment")));
    }
    Ok(url.as_str().trim_end_matches('/').to_string())
}

/// `HOSTNAME-PID`, or `worker-PID` where the host name is unknown.
fn default_name() -> String {
    let host = std::env::var("HOSTNAME")
        .ok()
        .filter(|h| !h.is_empty())
        .or_else(|| {
            std::fs::read_to_string("/etc/hostname")
                .ok()
                .map(|h| h.trim().to_string())
                .filter(|h| !h.is_empty())
        })
        .unwrap_or_else(|| "worker".to_string());
    format!("{host}-{}", std::process::id())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_plain_http_urls_and_strips_the_slash() {
        let c = Config::new("http://127.0.0.1:7878/", None, Some("w".into()), Some(3)).unwrap();
        assert_eq!(c.coordinator, "http://127.0.0.1:7878");
        assert_eq!(c.threads, 3);
        assert_eq!(c.name, "w");
        let c = Config::new("http://farm.local:80", Some(" t ".into()), None, None).unwrap();
        assert_eq!(c.token.as_deref(), Some("t"));
        assert!(c.threads >= 1);
        assert!(!c.name.is_empty());
        let c = Config::new("https://farm.example:7878/", None, None, None).unwrap();
        assert_eq!(c.coordinator, "https://farm.example:7878");
    }

    #[test]
    fn rejects_bad_settings_naming_the_field() {
        for (url, token, threads, field) in [
            ("127.0.0.1:7878", None, None, "coordinator"),
            ("ftp://host:1", None, None, "coordinator"),
            ("http://host:1/?x=1", None, None, "coordinator"),
            ("not a url", None, None, "coordinator"),
            ("http://host:1", Some("  "), None, "token"),
            ("http://host:1", None, Some(0), "threads"),
        ] {
            let err = Config::new(url, token.map(String::from), None, threads).unwrap_err();
            assert_eq!(err.field, field, "{url}: {err}");
            assert!(err.to_string().starts_with(field));
        }
        let err = Config::new("http://h:1", None, Some(String::new()), None).unwrap_err();
        assert_eq!(err.field, "name");
        let c = Config::new("http://h:1", None, None, None).unwrap();
        let pair = |k: &str| (k.to_string(), "x".to_string());
        let err = c
            .clone()
            .with_labels(vec![pair("a"), pair("a")])
            .unwrap_err();
        assert_eq!(err.field, "label");
        let err = c
            .clone()
            .with_labels((0..17).map(|i| pair(&format!("k{i}"))).collect());
        assert_eq!(err.unwrap_err().field, "label");
        for (build, tile, field) in [
            (0.0, 1.0, "build-time-limit-s"),
            (f64::NAN, 1.0, "build-time-limit-s"),
            (1.0, -3.0, "tile-time-limit-s"),
            (1.0, 1e12, "tile-time-limit-s"),
        ] {
            let err = c.clone().with_time_limits(build, tile).unwrap_err();
            assert_eq!(err.field, field, "{err}");
        }
        let limited = c.clone().with_time_limits(0.001, 2.5).unwrap();
        assert_eq!(limited.build_time_limit, Duration::from_millis(1));
        assert_eq!(limited.tile_time_limit, Duration::from_millis(2500));
        assert_eq!(c.build_time_limit, Duration::from_secs(600));
        assert_eq!(c.tile_time_limit, Duration::from_secs(3600));
        let ok = c.with_labels(vec![pair("pool")]).unwrap();
        assert_eq!(ok.labels.get("pool").map(String::as_str), Some("x"));
    }
}
