//! Worker identity: the secret each worker is given at registration, and the proof of it that
//! every later worker request carries.
//!
//! The shared worker token only says "a worker process"; it cannot tell one worker from
//! another, so without more any holder could heartbeat, fail or upload another worker's lease
//! (ids and epochs are small integers). Registration therefore issues a per-worker secret,
//! `<worker id>.<64 hex digits>` (256 bits from the operating system); the coordinator keeps
//! only its SHA-256 (in the database, so it survives a restart) and compares digests in
//! constant time. The ledger keeps each worker's digest and checks a presented secret
//! (`Ledger::authenticate`); [`crate::auth::require`] turns the [`WORKER_SECRET_HEADER`] of a worker route
//! into a [`WorkerIdentity`]; handlers then refuse a worker id in the path or body that is not
//! that identity (403), so a worker can touch its own leases only.
//!
//! [`WORKER_SECRET_HEADER`]: spindle_common::protocol::WORKER_SECRET_HEADER

use axum::extract::FromRequestParts;
use axum::http::request::Parts;
use sha2::{Digest, Sha256};

use crate::error::Error;

/// A new worker secret and the digest the coordinator keeps of it.
pub struct Issued {
    /// Given to the worker once.
    pub secret: String,
    pub sha256: [u8; 32],
}

/// Issues a secret for `worker`.
pub fn issue(worker: u64) -> Result<Issued, Error> {
    let mut random = [0u8; 32];
    getrandom::fill(&mut random)
        .map_err(|e| anyhow::anyhow!("the operating system gave no random bytes: {e}"))?;
    let hex: String = random.iter().map(|b| format!("{b:02x}")).collect();
    let secret = format!("{worker}.{hex}");
    let sha256 = digest(&secret);
    Ok(Issued { secret, sha256 })
}

/// The SHA-256 of a secret as presented.
pub fn digest(secret: &str) -> [u8; 32] {
    Sha256::digest(secret.as_bytes()).into()
}

/// Is `presented` the secret whose digest is `expected`? Compared in constant time.
pub fn matches(presented: &str, expected: &[u8; 32]) -> bool {
    constant_time_eq::constant_time_eq_32(&digest(presented), expected)
}

/// The worker a request's secret proved it is; put in the request's extensions by
/// [`crate::auth::require`] on every worker route but registration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WorkerIdentity(pub u64);

impl WorkerIdentity {
    /// Refuses a request naming (in `field`) a worker other than the one its secret proves.
    pub fn check(self, field: &str, claimed: u64) -> Result<(), Error> {
        if claimed == self.0 {
            Ok(())
        } else {
            Err(Error::Forbidden(format!(
                "{field}: worker {claimed} is not the worker of this worker secret \
                 ({WORKER_SECRET})"
            )))
        }
    }
}

impl<S: Send + Sync> FromRequestParts<S> for WorkerIdentity {
    type Rejection = Error;

    async fn from_request_parts(parts: &mut Parts, _: &S) -> Result<Self, Error> {
        parts
            .extensions
            .get::<WorkerIdentity>()
            .copied()
            .ok_or_else(|| Error::Forbidden(format!("missing worker secret ({WORKER_SECRET})")))
    }
}

/// How messages name the header.
pub(crate) const WORKER_SECRET: &str = "the Spindle-Worker-Secret header from POST /v1/workers";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_name_their_worker_and_differ() {
        let a = issue(7).unwrap();
        let b = issue(7).unwrap();
        assert!(a.secret.starts_with("7."), "{}", a.secret);
        assert_eq!(a.secret.len(), 2 + 64);
        assert_ne!(a.secret, b.secret);
        assert_eq!(digest(&a.secret), a.sha256);
        assert_ne!(a.sha256, b.sha256);
    }

    #[test]
    fn an_identity_accepts_only_its_own_worker() {
        assert!(WorkerIdentity(3).check("worker_id", 3).is_ok());
        let e = WorkerIdentity(3).check("worker_id", 4).unwrap_err();
        assert!(matches!(e, Error::Forbidden(_)), "{e}");
        assert!(e.to_string().contains("worker secret"), "{e}");
    }
}
