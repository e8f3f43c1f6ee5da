//! How a coordinator is set up: data directory, tokens, lease timing and limits.
//!
//! [`Args`] is the raw command line (clap, every flag also an environment variable);
//! [`Args::into_config`] reads token files and checks the values, giving a [`Config`] that
//! [`crate::run`] trusts. The embedded local farm builds a `Config` directly with
//! [`Config::new`].

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, bail};

use crate::limits::Limits;
use crate::tls::TlsFiles;

/// `spindle-server`: the coordinator of a spindle render farm.
#[derive(Debug, Clone, clap::Parser)]
#[command(name = "spindle-server", version, about)]
pub struct Args {
    /// How log lines are written: `text`, or `json` (one object a line, with the request id of
    /// the request being served).
    #[arg(long, env = "SPINDLE_LOG_FORMAT", value_enum, default_value_t = crate::logging::LogFormat::Text)]
    pub log_format: crate::logging::LogFormat,
    /// Address to listen on. A non-loopback address needs both tokens, each at least 16 bytes.
    #[arg(long, env = "SPINDLE_LISTEN", default_value = "127.0.0.1:7878")]
    pub listen: SocketAddr,
    /// Also serve the web dashboard (at `/`, with the API docs at `/docs`) and the same API on
    /// this address; off when unset. Same rules as --listen (tokens, TLS).
    #[arg(long, env = "SPINDLE_DASHBOARD_LISTEN")]
    pub dashboard_listen: Option<SocketAddr>,
    /// Directory for the database, assets, tile results and images (created if missing).
    #[arg(long, env = "SPINDLE_DATA")]
    pub data: PathBuf,
    /// Bearer token clients must send. Prefer SPINDLE_TOKEN or --token-file: a value on the
    /// command line is visible to every user of the machine (ps), and draws a warning.
    #[arg(long, env = "SPINDLE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// File holding the client token: printable ASCII, at most one final newline.
    #[arg(long, env = "SPINDLE_TOKEN_FILE", conflicts_with = "token")]
    pub token_file: Option<PathBuf>,
    /// Bearer token workers must send; must differ from the client token. Prefer
    /// SPINDLE_WORKER_TOKEN or --worker-token-file (a command-line value draws a warning).
    #[arg(long, env = "SPINDLE_WORKER_TOKEN", hide_env_values = true)]
    pub worker_token: Option<String>,
    /// File holding the worker token: printable ASCII, at most one final newline.
    #[arg(
        long,
        env = "SPINDLE_WORKER_TOKEN_FILE",
        conflicts_with = "worker_token"
    )]
    pub worker_token_file: Option<PathBuf>,
    /// Seconds a lease lives without a heartbeat.
    #[arg(long, env = "SPINDLE_LEASE_TTL", default_value_t = 30.0)]
    pub lease_ttl_s: f64,
    /// Most jobs queued or running at once.
    #[arg(long, env = "SPINDLE_MAX_JOBS", default_value_t = Limits::default().max_active_jobs)]
    pub max_jobs: usize,
    /// Seconds a connection may take to send a request line and headers, or stay idle between
    /// requests; also the longest pause within a body (408). The connection is then closed.
    #[arg(long, env = "SPINDLE_HEADER_TIMEOUT", default_value_t = Timeouts::default().header.as_secs_f64())]
    pub header_timeout_s: f64,
    /// Seconds from a request's headers to its answer, body included (asset uploads too);
    /// past it the answer is 408 and the connection is closed.
    #[arg(long, env = "SPINDLE_REQUEST_TIMEOUT", default_value_t = Timeouts::default().request.as_secs_f64())]
    pub request_timeout_s: f64,
    /// Most client connections open at once; lowered to fit the open-file limit (less 64
    /// descriptors kept for the coordinator itself). Further connections wait to be accepted.
    #[arg(long, env = "SPINDLE_MAX_CONNECTIONS", default_value_t = DEFAULT_MAX_CONNECTIONS)]
    pub max_connections: usize,
    /// Most connections open at once from one IP address; a further one is closed at once, so
    /// one address cannot take every slot. Raise it for many workers behind one NAT address.
    #[arg(long, env = "SPINDLE_MAX_CONNECTIONS_PER_ADDRESS", default_value_t = DEFAULT_MAX_CONNECTIONS_PER_ADDRESS)]
    pub max_connections_per_address: usize,
    /// Requests a second (on average; bursts of twice that) each client address may send to
    /// the client routes; past it, 429 with Retry-After.
    #[arg(long, env = "SPINDLE_CLIENT_RATE", default_value_t = DEFAULT_CLIENT_RATE_PER_S)]
    pub client_rate_per_s: u32,
    /// Leases one worker may hold at once; a lease request past it gets 429 with Retry-After.
    #[arg(long, env = "SPINDLE_MAX_LEASES_PER_WORKER", default_value_t = DEFAULT_MAX_LEASES_PER_WORKER)]
    pub max_leases_per_worker: usize,
    /// Workers registered at once; past it a registration forgets the lost worker heard from
    /// longest ago, or, with none lost, gets 429 with Retry-After.
    #[arg(long, env = "SPINDLE_MAX_WORKERS", default_value_t = DEFAULT_MAX_WORKERS)]
    pub max_workers: usize,
    /// PEM certificate chain (the server's own first): serve HTTPS. Needs --tls-key. SIGHUP
    /// re-reads both files.
    #[arg(long, env = "SPINDLE_TLS_CERT")]
    pub tls_cert: Option<PathBuf>,
    /// PEM private key of the --tls-cert certificate.
    #[arg(long, env = "SPINDLE_TLS_KEY")]
    pub tls_key: Option<PathBuf>,
    /// Serve plain HTTP on a non-loopback address: only behind a TLS-terminating proxy or
    /// ingress, since tokens and tiles would otherwise cross the network unencrypted.
    #[arg(long, env = "SPINDLE_ALLOW_PLAIN_HTTP")]
    pub allow_plain_http: bool,
    /// How long a done, cancelled or failed job is kept (its rows, tiles and image) before the
    /// sweep deletes it: `7d`, `12h`, `30min`, `500ms`…; `0` keeps finished jobs forever.
    #[arg(long, env = "SPINDLE_KEEP_FINISHED", default_value = "7d", value_parser = humantime::parse_duration)]
    pub keep_finished: Duration,
    /// How long an uploaded asset that no job names is kept (so a client can upload its assets,
    /// then submit the job).
    #[arg(long, env = "SPINDLE_ASSET_GRACE", default_value = "1h", value_parser = humantime::parse_duration)]
    pub asset_grace: Duration,
    /// How long a lost worker (not heard from) is kept before it is forgotten; it is listed as
    /// lost meanwhile (at most one hour).
    #[arg(long, env = "SPINDLE_KEEP_LOST_WORKERS", default_value = "1h", value_parser = humantime::parse_duration)]
    pub keep_lost_workers: Duration,
    /// How often the sweep deletes what is kept no longer.
    #[arg(long, env = "SPINDLE_SWEEP_INTERVAL", default_value = "1min", value_parser = humantime::parse_duration)]
    pub sweep_interval: Duration,
    /// The token flags whose value came from the command line (see [`Args::from_process`]).
    #[arg(skip)]
    pub tokens_in_argv: Vec<&'static str>,
}

/// Shortest token accepted for a non-loopback address (bytes).
pub const MIN_TOKEN_BYTES: usize = 16;

/// Default of `--client-rate-per-s`.
pub const DEFAULT_CLIENT_RATE_PER_S: u32 = 50;
/// Default of `--max-leases-per-worker` (a worker renders one tile at a time).
pub const DEFAULT_MAX_LEASES_PER_WORKER: usize = 4;

/// Default of `--max-workers`.
pub const DEFAULT_MAX_WORKERS: usize = 1024;

/// Default of `--max-connections`.
pub const DEFAULT_MAX_CONNECTIONS: usize = 1024;
/// [`Args::max_connections_per_address`] by default: a sixteenth of the default cap, several
/// times what a worker (a lease poll and an upload) or a dashboard holds.
pub const DEFAULT_MAX_CONNECTIONS_PER_ADDRESS: usize = 64;

/// How long a connection may take over each part of a request (see [`crate::serve`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timeouts {
    /// Request line and headers; the idle time of a keep-alive connection; the longest pause
    /// within a body.
    pub header: Duration,
    /// From the headers to the answer, body included.
    pub request: Duration,
}

impl Default for Timeouts {
    fn default() -> Self {
        Timeouts {
            header: Duration::from_secs(10),
            request: Duration::from_secs(300),
        }
    }
}

impl Timeouts {
    /// The longest a lease request may wait for work: half the request deadline, so the
    /// answer (204) always comes before the 408.
    pub fn long_poll_cap(&self) -> Duration {
        self.request / 2
    }
}

/// A checked coordinator configuration.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where the database (`spindle.db`), `assets/` and `jobs/` live.
    pub data_dir: PathBuf,
    /// Token for client routes; `None` leaves them open (loopback only).
    pub client_token: Option<String>,
    /// Token for worker routes; `None` leaves them open (loopback only).
    pub worker_token: Option<String>,
    /// A lease lapses this long after it was granted or last renewed.
    pub lease_ttl: Duration,
    /// After a restart, leases found in the database live this long before they can expire,
    /// so workers that kept rendering can still report.
    pub restart_grace: Duration,
    pub limits: Limits,
    /// Deadlines of a connection's requests.
    pub timeouts: Timeouts,
    /// Most connections open at once (lowered at start to fit the open-file limit).
    pub max_connections: usize,
    /// Most connections open at once from one IP address ([`crate::peers`]).
    pub max_connections_per_address: usize,
    /// Requests a second each client address may send to client routes (bursts of twice).
    pub client_rate_per_s: std::num::NonZeroU32,
    /// Leases one worker may hold at once.
    pub max_leases_per_worker: usize,
    /// Workers registered at once.
    pub max_workers: usize,
    /// Serve HTTPS with these files; `None` serves plain HTTP.
    pub tls: Option<TlsFiles>,
    /// Plain HTTP on a non-loopback address was asked for (a TLS-terminating proxy in front).
    pub allow_plain_http: bool,
    /// What is kept, and for how long (see [`crate::retention`]).
    pub retention: Retention,
}

/// How long finished jobs, unreferenced assets and lost workers are kept.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Retention {
    /// Finished jobs, from when they finished; `None`: forever.
    pub keep_finished: Option<Duration>,
    /// Assets no job names, from their upload (or last admission of a job naming them).
    pub asset_grace: Duration,
    /// Lost workers, from when they were last heard from.
    pub keep_lost_workers: Duration,
    /// The period of the sweep.
    pub sweep_interval: Duration,
}

impl Default for Retention {
    fn default() -> Self {
        Retention {
            keep_finished: Some(Duration::from_secs(7 * 24 * 3600)),
            asset_grace: Duration::from_secs(3600),
            keep_lost_workers: Duration::from_secs(3600),
            sweep_interval: Duration::from_secs(60),
        }
    }
}

impl Config {
    /// A configuration with default timing and limits and no tokens (for loopback use).
    pub fn new(data_dir: impl Into<PathBuf>) -> Config {
        Config {
            data_dir: data_dir.into(),
            client_token: None,
            worker_token: None,
            lease_ttl: Duration::from_secs(30),
            restart_grace: Duration::from_secs(30),
            limits: Limits::default(),
            timeouts: Timeouts::default(),
            max_connections: DEFAULT_MAX_CONNECTIONS,
            max_connections_per_address: DEFAULT_MAX_CONNECTIONS_PER_ADDRESS,
            client_rate_per_s: std::num::NonZeroU32::new(DEFAULT_CLIENT_RATE_PER_S)
                .expect("a positive default"),
            max_leases_per_worker: DEFAULT_MAX_LEASES_PER_WORKER,
            max_workers: DEFAULT_MAX_WORKERS,
            tls: None,
            allow_plain_http: false,
            retention: Retention::default(),
        }
    }

    /// Refuses equal client and worker tokens, and a non-loopback address without both tokens,
    /// with a token shorter than [`MIN_TOKEN_BYTES`], or without TLS unless plain HTTP was
    /// asked for.
    pub fn check_listen_address(&self, addr: SocketAddr) -> anyhow::Result<()> {
        for (setting, token) in [
            ("--token (SPINDLE_TOKEN)", &self.client_token),
            ("--worker-token (SPINDLE_WORKER_TOKEN)", &self.worker_token),
        ] {
            if let Some(token) = token
                && is_placeholder(token)
            {
                bail!(
                    "{setting}: `{token}` is the placeholder deploy/ ships, a token anyone can \
                     read; generate one (openssl rand -hex 32) and put it in the secret or \
                     environment file"
                );
            }
        }
        if let (Some(client), Some(worker)) = (&self.client_token, &self.worker_token)
            && client == worker
        {
            bail!(
                "the client and worker tokens are equal: a worker could act as a client; \
                 generate two (openssl rand -hex 32)"
            );
        }
        if addr.ip().is_loopback() {
            return Ok(());
        }
        let (Some(client), Some(worker)) = (&self.client_token, &self.worker_token) else {
            bail!(
                "refusing to listen on {addr} without tokens: set SPINDLE_TOKEN and \
                 SPINDLE_WORKER_TOKEN (or --token-file / --worker-token-file), or listen on 127.0.0.1"
            );
        };
        for (flag, token) in [("--token", client), ("--worker-token", worker)] {
            if token.len() < MIN_TOKEN_BYTES {
                bail!(
                    "{flag}: {} bytes is too short to listen on {addr}; a non-loopback address \
                     needs tokens of at least {MIN_TOKEN_BYTES} bytes (openssl rand -hex 32)",
                    token.len()
                );
            }
        }
        if self.tls.is_none() && !self.allow_plain_http {
            bail!(
                "refusing plain HTTP on {addr}: tokens and tiles would cross the network \
                 unencrypted; give --tls-cert and --tls-key (SPINDLE_TLS_CERT, SPINDLE_TLS_KEY), \
                 or --allow-plain-http when a TLS-terminating proxy or ingress is in front"
            );
        }
        Ok(())
    }
}

/// Is `token` one of the placeholders deploy/ ships (`REPLACE-with-…` in the Kubernetes secret,
/// `change-me-…` in the systemd environment files), or made like one? An unedited deployment's
/// token is public, so it is refused on any address.
fn is_placeholder(token: &str) -> bool {
    let t = token.trim().to_ascii_lowercase();
    ["replace", "change-me", "changeme", "change_me"]
        .iter()
        .any(|p| t.starts_with(p))
}

impl Args {
    /// The process's command line and environment, noting which tokens were given as
    /// arguments (readable by anyone through `ps`), so [`Args::into_config`] can warn.
    pub fn from_process() -> Args {
        use clap::{CommandFactory, FromArgMatches};
        let matches = Args::command().get_matches();
        let mut args = Args::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
        for (id, flag) in [("token", "--token"), ("worker_token", "--worker-token")] {
            if matches.value_source(id) == Some(clap::parser::ValueSource::CommandLine) {
                args.tokens_in_argv.push(flag);
            }
        }
        args
    }

    /// Reads token files and checks values.
    pub fn into_config(self) -> anyhow::Result<Config> {
        for flag in &self.tokens_in_argv {
            tracing::warn!(
                "{flag} on the command line is visible to every user of this machine (ps); \
                 use the environment or {flag}-file"
            );
        }
        let client_token = token(self.token, self.token_file.as_deref(), "--token")?;
        let worker_token = token(
            self.worker_token,
            self.worker_token_file.as_deref(),
            "--worker-token",
        )?;
        if !(self.lease_ttl_s.is_finite() && (0.1..=3600.0).contains(&self.lease_ttl_s)) {
            bail!("--lease-ttl-s: must be between 0.1 and 3600 seconds");
        }
        let lease_ttl = Duration::from_secs_f64(self.lease_ttl_s);
        let seconds = |flag: &str, value: f64| {
            if value.is_finite() && (0.01..=86_400.0).contains(&value) {
                Ok(Duration::from_secs_f64(value))
            } else {
                Err(anyhow::anyhow!(
                    "{flag}: must be between 0.01 and 86400 seconds, not {value}"
                ))
            }
        };
        let timeouts = Timeouts {
            header: seconds("--header-timeout-s", self.header_timeout_s)?,
            request: seconds("--request-timeout-s", self.request_timeout_s)?,
        };
        if self.max_connections == 0 {
            bail!("--max-connections: must be at least 1");
        }
        if self.max_connections_per_address == 0 {
            bail!("--max-connections-per-address: must be at least 1");
        }
        let Some(client_rate_per_s) = std::num::NonZeroU32::new(self.client_rate_per_s) else {
            bail!("--client-rate-per-s: must be at least 1");
        };
        if self.max_leases_per_worker == 0 {
            bail!("--max-leases-per-worker: must be at least 1");
        }
        if self.max_workers == 0 {
            bail!("--max-workers: must be at least 1");
        }
        if self.sweep_interval < Duration::from_millis(10) {
            bail!("--sweep-interval: must be at least 10ms");
        }
        let retention = Retention {
            keep_finished: (!self.keep_finished.is_zero()).then_some(self.keep_finished),
            asset_grace: self.asset_grace,
            keep_lost_workers: self.keep_lost_workers,
            sweep_interval: self.sweep_interval,
        };
        let limits = Limits {
            max_active_jobs: self.max_jobs,
            ..Limits::default()
        };
        let config = Config {
            data_dir: self.data,
            client_token,
            worker_token,
            lease_ttl,
            restart_grace: lease_ttl,
            limits,
            timeouts,
            max_connections: self.max_connections,
            max_connections_per_address: self.max_connections_per_address,
            client_rate_per_s,
            max_leases_per_worker: self.max_leases_per_worker,
            max_workers: self.max_workers,
            tls: crate::tls::files(self.tls_cert, self.tls_key)?,
            allow_plain_http: self.allow_plain_http,
            retention,
        };
        config.check_listen_address(self.listen)?;
        Ok(config)
    }
}

/// A token from its value or its file. A file may end in one newline (`\n` or `\r\n`); nothing
/// else is trimmed, so a token is used exactly as written or refused.
fn token(value: Option<String>, file: Option<&Path>, flag: &str) -> anyhow::Result<Option<String>> {
    let token = match (value, file) {
        (Some(v), _) => v,
        (None, Some(path)) => {
            let raw = std::fs::read_to_string(path)
                .with_context(|| format!("reading {flag}-file {}", path.display()))?;
            let line = raw.strip_suffix('\n').unwrap_or(&raw);
            line.strip_suffix('\r').unwrap_or(line).to_string()
        }
        (None, None) => return Ok(None),
    };
    if token.is_empty() {
        bail!("{flag}: the token is empty");
    }
    if token.bytes().any(|b| b.is_ascii_whitespace()) {
        bail!(
            "{flag}: the token contains whitespace (a file may only end in one newline); \
             tokens are used exactly as written"
        );
    }
    if !token.bytes().all(|b| b.is_ascii_graphic()) {
        bail!("{flag}: the token must be printable ASCII");
    }
    Ok(Some(token))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    const CLIENT: &str = "client-0123456789abcdef";
    const WORKER: &str = "worker-0123456789abcdef";

    fn parse(extra: &[&str]) -> anyhow::Result<Config> {
        let mut argv = vec!["spindle-server", "--data", "/tmp/x"];
        argv.extend_from_slice(extra);
        Args::try_parse_from(argv).unwrap().into_config()
    }

    fn from_file(contents: &str) -> anyhow::Result<Config> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("token");
        std::fs::write(&path, contents).unwrap();
        parse(&["--token-file", path.to_str().unwrap()])
    }

    #[test]
    fn non_loopback_needs_both_tokens() {
        assert!(parse(&[]).is_ok(), "loopback default needs no tokens");
        let err = parse(&["--listen", "0.0.0.0:7878"])
            .unwrap_err()
            .to_string();
        assert!(err.contains("refusing to listen on 0.0.0.0:7878"), "{err}");
        assert!(parse(&["--listen", "0.0.0.0:7878", "--token", CLIENT]).is_err());
        let ok = parse(&[
            "--listen",
            "0.0.0.0:1",
            "--token",
            CLIENT,
            "--worker-token",
            WORKER,
            "--allow-plain-http",
        ])
        .unwrap();
        assert_eq!(ok.client_token.as_deref(), Some(CLIENT));
    }

    #[test]
    fn non_loopback_plain_http_needs_to_be_asked_for() {
        let tokens = ["--token", CLIENT, "--worker-token", WORKER];
        let mut argv = vec!["--listen", "0.0.0.0:1"];
        argv.extend(tokens);
        let err = parse(&argv).unwrap_err().to_string();
        assert!(err.contains("refusing plain HTTP on 0.0.0.0:1"), "{err}");
        assert!(
            err.contains("--tls-cert") && err.contains("--allow-plain-http"),
            "{err}"
        );
        let tls = ["--tls-cert", "/c.pem", "--tls-key", "/k.pem"];
        let with_tls = parse(&[argv.clone(), tls.to_vec()].concat()).unwrap();
        assert_eq!(with_tls.tls.unwrap().cert, PathBuf::from("/c.pem"));
        argv.push("--allow-plain-http");
        assert!(parse(&argv).is_ok());
        // Loopback needs neither.
        assert!(parse(&tokens).is_ok());
        let err = parse(&["--tls-cert", "/c.pem"]).unwrap_err().to_string();
        assert!(err.contains("--tls-cert needs --tls-key"), "{err}");
    }

    #[test]
    fn the_shipped_placeholder_tokens_are_refused_naming_the_setting() {
        // The values deploy/ ships, read from its files: the test follows them if they change.
        let deploy = concat!(env!("CARGO_MANIFEST_DIR"), "/../deploy");
        let read = |p: &str| std::fs::read_to_string(format!("{deploy}/{p}")).unwrap();
        let mut shipped: Vec<String> = Vec::new();
        for line in read("kubernetes/base/secrets.yaml").lines() {
            if let Some(v) = line.trim().strip_prefix("client-token:") {
                shipped.push(v.trim().into());
            }
            if let Some(v) = line.trim().strip_prefix("worker-token:") {
                shipped.push(v.trim().into());
            }
        }
        for file in ["systemd/server.env.example", "systemd/worker.env.example"] {
            for line in read(file).lines() {
                if let Some(v) = line.strip_prefix("SPINDLE_TOKEN=") {
                    shipped.push(v.into());
                }
                if let Some(v) = line.strip_prefix("SPINDLE_WORKER_TOKEN=") {
                    shipped.push(v.into());
                }
            }
        }
        assert!(shipped.len() >= 5, "{shipped:?}");
        for placeholder in &shipped {
            assert!(placeholder.len() >= MIN_TOKEN_BYTES, "{placeholder}");
            for (listen, client, worker, setting) in [
                (
                    "0.0.0.0:1",
                    placeholder.as_str(),
                    WORKER,
                    "--token (SPINDLE_TOKEN)",
                ),
                (
                    "127.0.0.1:1",
                    CLIENT,
                    placeholder.as_str(),
                    "--worker-token (SPINDLE_WORKER_TOKEN)",
                ),
            ] {
                let argv = [
                    "--listen",
                    listen,
                    "--token",
                    client,
                    "--worker-token",
                    worker,
                    "--allow-plain-http",
                ];
                let err = parse(&argv).unwrap_err().to_string();
                assert!(
                    err.starts_with(&format!("{setting}: `{placeholder}` is the placeholder")),
                    "{err}"
                );
            }
        }
    }

    #[test]
    fn non_loopback_needs_long_tokens() {
        let short = "a".repeat(MIN_TOKEN_BYTES - 1);
        for (client, worker, flag) in [
            (short.as_str(), WORKER, "--token:"),
            (CLIENT, short.as_str(), "--worker-token:"),
        ] {
            let argv = [
                "--listen",
                "0.0.0.0:1",
                "--token",
                client,
                "--worker-token",
                worker,
            ];
            let err = parse(&argv).unwrap_err().to_string();
            assert!(err.starts_with(flag), "{err}");
            assert!(err.contains("at least 16 bytes"), "{err}");
        }
        // On loopback a short token is allowed (the local farm, tests).
        assert!(parse(&["--token", "a", "--worker-token", "b"]).is_ok());
    }

    #[test]
    fn client_and_worker_tokens_must_differ() {
        for listen in ["127.0.0.1:1", "0.0.0.0:1"] {
            let argv = [
                "--listen",
                listen,
                "--token",
                CLIENT,
                "--worker-token",
                CLIENT,
            ];
            let err = parse(&argv).unwrap_err().to_string();
            assert!(err.contains("tokens are equal"), "{listen}: {err}");
        }
    }

    #[test]
    fn a_token_file_may_end_in_one_newline_and_nothing_else() {
        let token = |contents: &str| from_file(contents).map(|c| c.client_token.unwrap());
        assert_eq!(token("s3cret\n").unwrap(), "s3cret");
        assert_eq!(token("s3cret\r\n").unwrap(), "s3cret");
        assert_eq!(token("s3cret").unwrap(), "s3cret");
        for bad in ["s3cret \n", " s3cret", "s3cret\n\n", "s3cret\t", "s3 cret"] {
            let err = token(bad).unwrap_err().to_string();
            assert!(err.contains("whitespace"), "{bad:?}: {err}");
        }
        assert!(
            token("  \n")
                .unwrap_err()
                .to_string()
                .contains("whitespace")
        );
        assert!(token("\n").unwrap_err().to_string().contains("empty"));
    }

    #[test]
    fn a_token_value_is_not_trimmed() {
        let err = parse(&["--token", "s3cret "]).unwrap_err().to_string();
        assert!(err.contains("whitespace"), "{err}");
    }

    #[test]
    fn deadlines_are_checked() {
        let ok = parse(&["--header-timeout-s", "0.3", "--request-timeout-s", "2"]).unwrap();
        assert_eq!(ok.timeouts.header, Duration::from_millis(300));
        assert_eq!(ok.timeouts.request, Duration::from_secs(2));
        for flag in ["--header-timeout-s", "--request-timeout-s"] {
            for bad in ["0", "NaN", "1e9"] {
                let err = parse(&[flag, bad]).unwrap_err().to_string();
                assert!(err.starts_with(flag), "{err}");
            }
        }
        assert!(parse(&["--max-connections", "0"]).is_err());
    }

    #[test]
    fn retention_durations_parse_and_zero_keeps_forever() {
        let default = parse(&[]).unwrap().retention;
        assert_eq!(default, Retention::default());
        assert_eq!(default.keep_finished, Some(Duration::from_secs(7 * 86_400)));
        let r = parse(&[
            "--keep-finished",
            "0",
            "--asset-grace",
            "300ms",
            "--keep-lost-workers",
            "2h",
            "--sweep-interval",
            "200ms",
        ])
        .unwrap()
        .retention;
        assert_eq!(r.keep_finished, None, "0 keeps finished jobs forever");
        assert_eq!(r.asset_grace, Duration::from_millis(300));
        assert_eq!(r.keep_lost_workers, Duration::from_secs(7200));
        assert_eq!(r.sweep_interval, Duration::from_millis(200));
        assert!(parse(&["--sweep-interval", "0"]).is_err());
        assert!(Args::try_parse_from(["s", "--data", "/x", "--keep-finished", "soon"]).is_err());
    }
}
