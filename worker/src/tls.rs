//! Whom spindle's HTTP clients (the worker's and the `spindle` command's) trust as a
//! coordinator over `https://`: the certificates of `--ca-cert FILE` (a private CA) alone when it
//! is given, else the system's roots, read by `rustls-native-certs` (the OS store:
//! `/etc/ssl/certs`, or `SSL_CERT_FILE`/`SSL_CERT_DIR`). rustls with the ring provider; no system
//! proxy (farm traffic is machine to machine).
//!
//! A refused certificate is the most likely first failure of a new deployment, so
//! [`explain`] turns rustls's words into what to do about them.

use std::path::Path;

use anyhow::{Context, anyhow, bail};
use rustls::RootCertStore;
use rustls::pki_types::CertificateDer;
use rustls::pki_types::pem::PemObject;

/// A reqwest client builder that trusts the roots described in the module doc.
pub fn client_builder(ca_cert: Option<&Path>) -> anyhow::Result<reqwest::ClientBuilder> {
    let roots = roots(ca_cert)?;
    let provider = std::sync::Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .context("setting up TLS")?
        .with_root_certificates(roots)
        .with_no_client_auth();
    Ok(reqwest::Client::builder()
        .no_proxy()
        .tls_backend_preconfigured(config))
}

/// Reads `--ca-cert`, or the system's roots.
fn roots(ca_cert: Option<&Path>) -> anyhow::Result<RootCertStore> {
    let mut store = RootCertStore::empty();
    let Some(path) = ca_cert else {
        let found = rustls_native_certs::load_native_certs();
        for e in &found.errors {
            tracing::debug!(error = %e, "a system CA certificate could not be read");
        }
        store.add_parsable_certificates(found.certs);
        return Ok(store);
    };
    let bad = |e: &dyn std::fmt::Display| {
        anyhow!(
            "--ca-cert {}: {e}; expected a PEM file of CA certificates",
            path.display()
        )
    };
    let certs = CertificateDer::pem_file_iter(path)
        .map_err(|e| bad(&e))?
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| bad(&e))?;
    if certs.is_empty() {
        bail!(bad(&"no certificate in the file"));
    }
    for cert in certs {
        store.add(cert).map_err(|e| bad(&e))?;
    }
    Ok(store)
}

/// What to do about a failed request `e`, when the cause is TLS to the coordinator.
pub fn explain(e: &(dyn std::error::Error + 'static)) -> Option<&'static str> {
    let mut chain = e.to_string();
    let mut source = e.source();
    while let Some(inner) = source {
        chain.push_str(": ");
        chain.push_str(&inner.to_string());
        source = inner.source();
    }
    explain_chain(&chain)
}

/// [`explain`] for an error chain as text.
fn explain_chain(chain: &str) -> Option<&'static str> {
    if chain.contains("invalid peer certificate") {
        Some(
            "the coordinator's TLS certificate was refused; if a private CA signed it, give that \
             CA's certificate with --ca-cert FILE (SPINDLE_CA_CERT)",
        )
    } else if chain.contains("InvalidContentType") || chain.contains("corrupt message") {
        Some("the coordinator did not answer TLS; is it serving plain http:// on that port?")
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_ca_file_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ca.pem");
        std::fs::write(&path, "not a certificate").unwrap();
        let err = client_builder(Some(&path)).unwrap_err().to_string();
        assert!(err.starts_with("--ca-cert"), "{err}");
        assert!(err.contains("no certificate"), "{err}");
        let err = client_builder(Some(&dir.path().join("missing.pem")))
            .unwrap_err()
            .to_string();
        assert!(err.starts_with("--ca-cert"), "{err}");
        assert!(client_builder(None).unwrap().build().is_ok());
    }

    #[test]
    fn certificate_failures_point_at_ca_cert() {
        let chain = "error sending request: client error (Connect): invalid peer certificate: \
                     UnknownIssuer";
        assert!(explain_chain(chain).unwrap().contains("--ca-cert"));
        assert_eq!(explain_chain("connection refused"), None);
    }
}
