//! HTTPS for the coordinator: the certificate and key files (`--tls-cert`, `--tls-key`) become a
//! rustls acceptor for [`crate::serve`], and SIGHUP re-reads them so a renewed certificate
//! (cert-manager, certbot) is taken without a restart or a dropped connection.
//!
//! Invariant: the certificate in use is always a chain whose first certificate matches the key
//! and had not expired when it was read; a reload that fails (missing file, bad PEM, mismatched
//! key, an expired certificate) keeps the previous pair and logs why, and a certificate that
//! expires within [`EXPIRY_WARNING`] is taken with a warning. Only HTTP/1.1 is offered (ALPN), the one protocol the accept loop serves.

use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};
use std::time::{Duration, SystemTime};

use anyhow::{Context, anyhow, bail};
use rustls::crypto::CryptoProvider;
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use rustls::server::{ClientHello, ResolvesServerCert};
use rustls::sign::CertifiedKey;
use tokio_rustls::TlsAcceptor;

/// The PEM files of the coordinator's certificate chain and private key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TlsFiles {
    /// The certificate chain, the server's own certificate first (`--tls-cert`).
    pub cert: PathBuf,
    /// The private key of the first certificate: PKCS#8, PKCS#1 or SEC1 (`--tls-key`).
    pub key: PathBuf,
}

/// The one crypto provider of the coordinator's TLS (ring: no C toolchain beyond `cc`).
fn provider() -> Arc<CryptoProvider> {
    Arc::new(rustls::crypto::ring::default_provider())
}

/// How long before its end a certificate is taken with a warning.
pub const EXPIRY_WARNING: Duration = Duration::from_secs(14 * 24 * 3600);

/// Reads and checks the certificate chain and key of `files`, now.
pub fn load(files: &TlsFiles) -> anyhow::Result<CertifiedKey> {
    load_at(files, SystemTime::now())
}

/// [`load`] as at `now`: the server's certificate must not have expired by then.
fn load_at(files: &TlsFiles, now: SystemTime) -> anyhow::Result<CertifiedKey> {
    let chain = read_chain(&files.cert)?;
    if let Lifetime::EndsSoon { not_after, left } = lifetime(&files.cert, &chain[0], now)? {
        tracing::warn!(
            cert = %files.cert.display(),
            %not_after,
            days_left = left.as_secs() / (24 * 3600),
            "the TLS certificate expires soon: renew it, then send the coordinator SIGHUP"
        );
    }
    let key = PrivateKeyDer::from_pem_file(&files.key).map_err(|e| {
        anyhow!(
            "--tls-key {}: no private key read ({e}); expected a PEM file with a PKCS#8, \
             PKCS#1 or SEC1 key",
            files.key.display()
        )
    })?;
    CertifiedKey::from_der(chain, key, &provider()).map_err(|e| {
        anyhow!(
            "--tls-key {} does not fit --tls-cert {}: {e}",
            files.key.display(),
            files.cert.display()
        )
    })
}

fn read_chain(path: &Path) -> anyhow::Result<Vec<CertificateDer<'static>>> {
    let bad = |e: &dyn std::fmt::Display| {
        anyhow!(
            "--tls-cert {}: {e}; expected a PEM file of certificates, the server's first",
            path.display()
        )
    };
    let chain = CertificateDer::pem_file_iter(path)
        .map_err(|e| bad(&e))?
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| bad(&e))?;
    if chain.is_empty() {
        return Err(bad(&"no certificate in the file"));
    }
    Ok(chain)
}

/// What is left of a certificate's validity.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Lifetime {
    /// More than [`EXPIRY_WARNING`].
    Long,
    /// Ends at `not_after`, `left` from now.
    EndsSoon { not_after: String, left: Duration },
}

/// The lifetime of `cert`, read from `path`, at `now`; an error if it has expired (or cannot
/// be read as X.509).
fn lifetime(path: &Path, cert: &CertificateDer<'_>, now: SystemTime) -> anyhow::Result<Lifetime> {
    let (_, parsed) = x509_parser::parse_x509_certificate(cert).map_err(|e| {
        anyhow!(
            "--tls-cert {}: the first certificate cannot be read ({e})",
            path.display()
        )
    })?;
    let not_after = parsed.validity().not_after;
    let now_s = match now.duration_since(SystemTime::UNIX_EPOCH) {
        Ok(d) => i64::try_from(d.as_secs()).unwrap_or(i64::MAX),
        Err(_) => 0,
    };
    let left_s = not_after.timestamp().saturating_sub(now_s);
    // X.509 validity includes its notAfter second.
    if left_s < 0 {
        bail!(
            "--tls-cert {}: the certificate expired on {not_after} ({} days ago); renew it",
            path.display(),
            left_s.unsigned_abs() / (24 * 3600)
        );
    }
    let left = Duration::from_secs(left_s.unsigned_abs());
    Ok(if left <= EXPIRY_WARNING {
        Lifetime::EndsSoon {
            not_after: not_after.to_string(),
            left,
        }
    } else {
        Lifetime::Long
    })
}

/// The certificate the coordinator presents, replaceable while it serves.
#[derive(Debug)]
pub struct ReloadableCert {
    files: TlsFiles,
    current: RwLock<Arc<CertifiedKey>>,
}

impl ReloadableCert {
    /// Loads `files`; an error names the flag and the problem.
    pub fn open(files: TlsFiles) -> anyhow::Result<ReloadableCert> {
        let key = load(&files)?;
        Ok(ReloadableCert {
            files,
            current: RwLock::new(Arc::new(key)),
        })
    }

    /// Re-reads the files; on error the previous certificate stays in use.
    pub fn reload(&self) -> anyhow::Result<()> {
        let key = load(&self.files)?;
        *self.current.write().unwrap_or_else(|p| p.into_inner()) = Arc::new(key);
        Ok(())
    }

    /// The certificate chain now presented.
    pub fn chain(&self) -> Vec<CertificateDer<'static>> {
        self.current
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .cert
            .clone()
    }
}

impl ResolvesServerCert for ReloadableCert {
    fn resolve(&self, _hello: ClientHello<'_>) -> Option<Arc<CertifiedKey>> {
        Some(
            self.current
                .read()
                .unwrap_or_else(|p| p.into_inner())
                .clone(),
        )
    }
}

/// A TLS acceptor presenting `cert`'s current certificate, offering HTTP/1.1 only.
pub fn acceptor(cert: Arc<ReloadableCert>) -> anyhow::Result<TlsAcceptor> {
    let mut config = rustls::ServerConfig::builder_with_provider(provider())
        .with_safe_default_protocol_versions()
        .context("setting up TLS")?
        .with_no_client_auth()
        .with_cert_resolver(cert);
    config.alpn_protocols = vec![b"http/1.1".to_vec()];
    Ok(TlsAcceptor::from(Arc::new(config)))
}

/// Re-reads the certificate at every SIGHUP, for as long as the task runs.
pub async fn reload_on_sighup(cert: Arc<ReloadableCert>) {
    #[cfg(unix)]
    {
        use tokio::signal::unix::{SignalKind, signal};
        let mut hangups = match signal(SignalKind::hangup()) {
            Ok(s) => s,
            Err(e) => {
                tracing::warn!(error = %e, "cannot listen for SIGHUP; the certificate will not be reloaded");
                return;
            }
        };
        while hangups.recv().await.is_some() {
            match cert.reload() {
                Ok(()) => {
                    tracing::info!(cert = %cert.files.cert.display(), "TLS certificate reloaded")
                }
                Err(e) => {
                    tracing::error!(error = %format!("{e:#}"), "TLS certificate not reloaded; the previous one stays in use")
                }
            }
        }
    }
    #[cfg(not(unix))]
    {
        let _ = cert;
        std::future::pending::<()>().await
    }
}

/// Refuses a configuration with only one of the two files.
pub fn files(cert: Option<PathBuf>, key: Option<PathBuf>) -> anyhow::Result<Option<TlsFiles>> {
    match (cert, key) {
        (Some(cert), Some(key)) => Ok(Some(TlsFiles { cert, key })),
        (None, None) => Ok(None),
        (Some(_), None) => {
            bail!("--tls-cert needs --tls-key (SPINDLE_TLS_KEY): the certificate's private key")
        }
        (None, Some(_)) => {
            bail!("--tls-key needs --tls-cert (SPINDLE_TLS_CERT): the certificate chain")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A self-signed certificate for `localhost` and its key, as PEM.
    fn self_signed() -> (String, String) {
        let c = rcgen::generate_simple_self_signed(vec!["localhost".into()]).unwrap();
        (c.cert.pem(), c.signing_key.serialize_pem())
    }

    fn write(dir: &Path, cert: &str, key: &str) -> TlsFiles {
        let files = TlsFiles {
            cert: dir.join("cert.pem"),
            key: dir.join("key.pem"),
        };
        std::fs::write(&files.cert, cert).unwrap();
        std::fs::write(&files.key, key).unwrap();
        files
    }

    #[test]
    fn reload_takes_the_new_certificate_and_a_bad_one_keeps_the_old() {
        let dir = tempfile::tempdir().unwrap();
        let (cert_a, key_a) = self_signed();
        let files = write(dir.path(), &cert_a, &key_a);
        let reloadable = ReloadableCert::open(files.clone()).unwrap();
        let a = reloadable.chain();

        let (cert_b, key_b) = self_signed();
        write(dir.path(), &cert_b, &key_b);
        reloadable.reload().unwrap();
        let b = reloadable.chain();
        assert_ne!(a, b);

        // B's certificate with A's key: refused, B stays.
        write(dir.path(), &cert_b, &key_a);
        let err = reloadable.reload().unwrap_err().to_string();
        assert!(err.contains("does not fit --tls-cert"), "{err}");
        assert_eq!(reloadable.chain(), b);
    }

    #[test]
    fn bad_files_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let (cert, key) = self_signed();
        let err = load(&write(dir.path(), "not pem", &key)).unwrap_err();
        assert!(err.to_string().starts_with("--tls-cert"), "{err}");
        let err = load(&write(dir.path(), &cert, "not pem")).unwrap_err();
        assert!(err.to_string().starts_with("--tls-key"), "{err}");
        assert!(files(Some("c".into()), None).is_err());
        assert!(files(None, Some("k".into())).is_err());
        assert_eq!(files(None, None).unwrap(), None);
    }

    /// A certificate for `localhost` valid until the start of `year`-01-01 (UTC), and its key.
    fn valid_until(year: i32) -> (String, String) {
        let mut params = rcgen::CertificateParams::new(vec!["localhost".into()]).unwrap();
        params.not_before = rcgen::date_time_ymd(1999, 1, 1);
        params.not_after = rcgen::date_time_ymd(year, 1, 1);
        let key = rcgen::KeyPair::generate().unwrap();
        let cert = params.self_signed(&key).unwrap();
        (cert.pem(), key.serialize_pem())
    }

    /// Seconds since the epoch of `year`-01-01 less `days`.
    fn days_before_new_year(year: i32, days: u64) -> SystemTime {
        let new_year = rcgen::date_time_ymd(year, 1, 1).unix_timestamp() as u64;
        SystemTime::UNIX_EPOCH + Duration::from_secs(new_year) - Duration::from_secs(days * 86400)
    }

    #[test]
    fn an_expired_certificate_is_refused_at_start_and_on_reload_keeping_the_old() {
        let dir = tempfile::tempdir().unwrap();
        let (expired, expired_key) = valid_until(2001);
        let err = ReloadableCert::open(write(dir.path(), &expired, &expired_key))
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("--tls-cert")
                && err.contains("the certificate expired on Jan  1 00:00:00 2001")
                && err.contains("renew it"),
            "{err}"
        );

        let (good, good_key) = valid_until(2200);
        let files = write(dir.path(), &good, &good_key);
        let reloadable = ReloadableCert::open(files).unwrap();
        let before = reloadable.chain();
        write(dir.path(), &expired, &expired_key);
        let err = reloadable.reload().unwrap_err().to_string();
        assert!(err.contains("expired"), "{err}");
        assert_eq!(reloadable.chain(), before, "the valid pair stays in use");
    }

    #[test]
    fn a_certificate_ending_within_fourteen_days_is_taken_with_a_warning() {
        let dir = tempfile::tempdir().unwrap();
        let (cert, key) = valid_until(2030);
        let files = write(dir.path(), &cert, &key);
        let chain = read_chain(&files.cert).unwrap();
        let at = |days| lifetime(&files.cert, &chain[0], days_before_new_year(2030, days));
        assert_eq!(at(15).unwrap(), Lifetime::Long);
        let Lifetime::EndsSoon { not_after, left } = at(13).unwrap() else {
            panic!("13 days before the end is soon");
        };
        assert_eq!(left, Duration::from_secs(13 * 86400));
        assert!(not_after.contains("2030"), "{not_after}");
        assert!(load_at(&files, days_before_new_year(2030, 1)).is_ok());
        assert!(
            load_at(&files, days_before_new_year(2030, 0)).is_ok(),
            "the last second"
        );
        let after = days_before_new_year(2030, 0) + Duration::from_secs(1);
        let err = load_at(&files, after).unwrap_err();
        assert!(err.to_string().contains("expired"), "{err}");
    }
}
