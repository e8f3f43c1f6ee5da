//! HTTPS for the coordinator: the certificate and key files (`--tls-cert`, `--tls-key`) become a
//! rustls acceptor for [`crate::serve`], and SIGHUP re-reads them so a renewed certificate
//! (cert-manager, certbot) is taken without a restart or a dropped connection.
//!
//! Invariant: the certificate in use is always a chain whose first certificate matches the key;
//! a reload that fails (missing file, bad PEM, mismatched key) keeps the previous pair and logs
//! why. Only HTTP/1.1 is offered (ALPN), the one protocol the accept loop serves.

use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};

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

/// Reads and checks the certificate chain and key of `files`.
pub fn load(files: &TlsFiles) -> anyhow::Result<CertifiedKey> {
    let chain = read_chain(&files.cert)?;
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
}
