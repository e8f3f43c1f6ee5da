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

/// `spindle-server`: the coordinator of a spindle render farm.
#[derive(Debug, Clone, clap::Parser)]
#[command(name = "spindle-server", version, about)]
pub struct Args {
    /// Address to listen on. A non-loopback address needs both tokens.
    #[arg(long, env = "SPINDLE_LISTEN", default_value = "127.0.0.1:7878")]
    pub listen: SocketAddr,
    /// Directory for the database, assets, tile results and images (created if missing).
    #[arg(long, env = "SPINDLE_DATA")]
    pub data: PathBuf,
    /// Bearer token clients must send.
    #[arg(long, env = "SPINDLE_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// File holding the client token (instead of `--token`).
    #[arg(long, env = "SPINDLE_TOKEN_FILE", conflicts_with = "token")]
    pub token_file: Option<PathBuf>,
    /// Bearer token workers must send.
    #[arg(long, env = "SPINDLE_WORKER_TOKEN", hide_env_values = true)]
    pub worker_token: Option<String>,
    /// File holding the worker token (instead of `--worker-token`).
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
        }
    }

    /// Refuses to serve a non-loopback address without both tokens.
    pub fn check_listen_address(&self, addr: SocketAddr) -> anyhow::Result<()> {
        if !addr.ip().is_loopback() && (self.client_token.is_none() || self.worker_token.is_none())
        {
            bail!(
                "refusing to listen on {addr} without tokens: set SPINDLE_TOKEN and \
                 SPINDLE_WORKER_TOKEN (or --token-file / --worker-token-file), or listen on 127.0.0.1"
            );
        }
        Ok(())
    }
}

impl Args {
    /// Reads token files and checks values.
    pub fn into_config(self) -> anyhow::Result<Config> {
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
        };
        config.check_listen_address(self.listen)?;
        Ok(config)
    }
}

fn token(value: Option<String>, file: Option<&Path>, flag: &str) -> anyhow::Result<Option<String>> {
    let raw = match (value, file) {
        (Some(v), _) => v,
        (None, Some(path)) => std::fs::read_to_string(path)
            .with_context(|| format!("reading {flag}-file {}", path.display()))?,
        (None, None) => return Ok(None),
    };
    let token = raw.trim().to_string();
    if token.is_empty() {
        bail!("{flag}: the token is empty");
    }
    if !token.bytes().all(|b| b.is_ascii_graphic()) {
        bail!("{flag}: the token must be printable ASCII without spaces");
    }
    Ok(Some(token))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[test]
    fn non_loopback_needs_both_tokens() {
        let parse = |extra: &[&str]| {
            let mut argv = vec!["spindle-server", "--data", "/tmp/x"];
            argv.extend_from_slice(extra);
            Args::try_parse_from(argv).unwrap().into_config()
        };
        assert!(parse(&[]).is_ok(), "loopback default needs no tokens");
        let err = parse(&["--listen", "0.0.0.0:7878"])
            .unwrap_err()
            .to_string();
        assert!(err.contains("refusing to listen on 0.0.0.0:7878"), "{err}");
        assert!(parse(&["--listen", "0.0.0.0:7878", "--token", "a"]).is_err());
        let ok = parse(&[
            "--listen",
            "0.0.0.0:1",
            "--token",
            "a",
            "--worker-token",
            "b",
        ])
        .unwrap();
        assert_eq!(ok.client_token.as_deref(), Some("a"));
    }

    #[test]
    fn token_file_is_read_and_trimmed() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("token");
        std::fs::write(&path, "s3cret\n").unwrap();
        let args = Args::try_parse_from([
            "spindle-server",
            "--data",
            "/tmp/x",
            "--token-file",
            path.to_str().unwrap(),
        ])
        .unwrap();
        assert_eq!(
            args.into_config().unwrap().client_token.as_deref(),
            Some("s3cret")
        );
        std::fs::write(&path, "  \n").unwrap();
        let args = Args::try_parse_from([
            "spindle-server",
            "--data",
            "/tmp/x",
            "--token-file",
            path.to_str().unwrap(),
        ])
        .unwrap();
        assert!(
            args.into_config()
                .unwrap_err()
                .to_string()
                .contains("empty")
        );
    }
}
