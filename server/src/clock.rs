//! Wall-clock time as the coordinator stores it: milliseconds since the Unix epoch.
//!
//! Times kept in the database and shown to clients (a job's submission, start and end, a
//! worker's last contact, an event's time) are wall-clock, so they mean the same across a
//! restart; durations that only this process measures (leases, polls) use
//! `tokio::time::Instant` instead. One function, so every module reads the clock the same way
//! and none has to reach into the ledger for it.

/// Milliseconds since the Unix epoch (0 on a clock set before it).
pub fn now_ms() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_millis() as i64)
        .unwrap_or(0)
}
