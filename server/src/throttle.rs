//! Per-caller allowances, so one caller cannot crowd out the rest: a request rate per client
//! address (a `governor` GCRA limiter keyed by IP) and a number of leases per worker.
//!
//! Both answer 429 with `Retry-After` ([`Error::RateLimited`]). The client rate applies to the
//! client routes only: workers are paced by their leases, and a local farm's workers share
//! one loopback address. A request without a peer address (the in-process router of tests)
//! is not rate-limited.

use std::net::{IpAddr, SocketAddr};
use std::num::NonZeroU32;
use std::time::Duration;

use axum::extract::{ConnectInfo, Request, State};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use governor::clock::Clock;
use governor::{DefaultKeyedRateLimiter, Quota};

use crate::AppState;
use crate::error::Error;
use crate::ledger::Ledger;

/// Addresses remembered before forgetting those whose allowance is full again.
const REMEMBERED_ADDRESSES: usize = 4096;

/// The request rate allowed per client address.
pub struct ClientRate {
    limiter: DefaultKeyedRateLimiter<IpAddr>,
}

impl ClientRate {
    /// `per_second` requests a second on average, in bursts of up to twice that.
    pub fn new(per_second: NonZeroU32) -> ClientRate {
        let burst = per_second.saturating_mul(NonZeroU32::new(2).expect("2 > 0"));
        let quota = Quota::per_second(per_second).allow_burst(burst);
        ClientRate {
            limiter: DefaultKeyedRateLimiter::dashmap(quota),
        }
    }

    /// `Ok` if `ip` may send a request now, else how long until it may.
    pub fn check(&self, ip: IpAddr) -> Result<(), Duration> {
        if self.limiter.len() > REMEMBERED_ADDRESSES {
            self.limiter.retain_recent();
        }
        self.limiter
            .check_key(&ip)
            .map_err(|not_until| not_until.wait_time_from(self.limiter.clock().now()))
    }
}

/// Middleware of the client routes: 429 past the address's rate.
pub async fn client_rate(State(state): State<AppState>, request: Request, next: Next) -> Response {
    let peer = request
        .extensions()
        .get::<ConnectInfo<SocketAddr>>()
        .map(|c| c.0.ip());
    if let Some(ip) = peer
        && let Err(wait) = state.client_rate().check(ip)
    {
        return Error::RateLimited {
            message: format!(
                "too many requests from {ip}: at most {} a second on average",
                state.config().client_rate_per_s
            ),
            retry_after: wait,
        }
        .into_response();
    }
    next.run(request).await
}

/// Leases `worker` holds now.
pub fn leases_held(ledger: &Ledger, worker: u64) -> usize {
    ledger
        .jobs
        .values()
        .flat_map(|job| job.leased.iter().map(move |&i| &job.tiles[i as usize]))
        .filter(|tile| tile.worker == Some(worker))
        .count()
}

/// Refuses a lease to a worker already holding `max` (429: finish or give back one first).
pub fn check_lease_cap(ledger: &Ledger, worker: u64, max: usize) -> Result<(), Error> {
    let held = leases_held(ledger, worker);
    if held >= max {
        return Err(Error::RateLimited {
            message: format!(
                "worker {worker} holds {held} leases, the most one worker may hold \
                 (--max-leases-per-worker); deliver or fail one first"
            ),
            retry_after: Duration::from_secs(1),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_address_gets_its_burst_then_waits_and_others_are_unaffected() {
        let rate = ClientRate::new(NonZeroU32::new(2).unwrap());
        let a: IpAddr = [10, 0, 0, 1].into();
        let b: IpAddr = [10, 0, 0, 2].into();
        for _ in 0..4 {
            assert!(rate.check(a).is_ok());
        }
        let wait = rate.check(a).unwrap_err();
        assert!(
            wait > Duration::ZERO && wait <= Duration::from_millis(500),
            "{wait:?}"
        );
        assert!(rate.check(b).is_ok());
    }
}
