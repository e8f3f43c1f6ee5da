//! Exponential backoff: how long a worker waits before retrying a request that failed for a
//! reason that may pass (the coordinator restarting, a dropped connection, a 5xx).
//!
//! One policy for every retry in the worker, so "the coordinator went away" is handled the same
//! way whether the worker was registering, leasing, downloading or uploading ([`retry`] is
//! the loop every one of them uses). The delay doubles
//! from `initial` up to `max`; a deterministic jitter (a hash of the attempt number and a
//! per-worker salt) spreads workers apart so a restarted coordinator is not hit by all of them
//! in the same millisecond.

use std::time::Duration;

use tokio_util::sync::CancellationToken;

use crate::client::{ClientError, ErrorKind};

/// The retry policy: delays grow as `initial · 2^attempt`, capped at `max`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Backoff {
    pub initial: Duration,
    pub max: Duration,
}

impl Default for Backoff {
    fn default() -> Self {
        Backoff {
            initial: Duration::from_millis(100),
            max: Duration::from_secs(5),
        }
    }
}

impl Backoff {
    /// The delay before retry number `attempt` (0 for the first retry), before jitter.
    pub fn base_delay(&self, attempt: u32) -> Duration {
        // 2^20 · initial already exceeds any sensible cap; clamping the exponent avoids overflow.
        let factor = 1u32 << attempt.min(20);
        self.initial.saturating_mul(factor).min(self.max)
    }

    /// The delay before retry number `attempt`, scaled by a jitter factor in [0.5, 1.0) drawn
    /// from `salt` and `attempt`, so that it never exceeds [`Backoff::base_delay`].
    pub fn delay(&self, attempt: u32, salt: u64) -> Duration {
        let h = splitmix64(salt ^ (u64::from(attempt)).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        // The top 53 bits as a fraction in [0, 1).
        let unit = (h >> 11) as f64 / (1u64 << 53) as f64;
        self.base_delay(attempt).mul_f64(0.5 + 0.5 * unit)
    }

    /// A stateful sequence of delays, for a retry loop.
    pub fn attempts(self, salt: u64) -> Attempts {
        Attempts {
            policy: self,
            salt,
            attempt: 0,
        }
    }
}

/// The running state of one retry loop.
#[derive(Debug, Clone)]
pub struct Attempts {
    policy: Backoff,
    salt: u64,
    attempt: u32,
}

impl Attempts {
    /// The delay to wait before the next retry; each call moves one step further.
    pub fn next_delay(&mut self) -> Duration {
        let d = self.policy.delay(self.attempt, self.salt);
        self.attempt = self.attempt.saturating_add(1);
        d
    }

    /// How many delays have been handed out.
    pub fn count(&self) -> u32 {
        self.attempt
    }

    /// Starts again from the shortest delay (after a success).
    pub fn reset(&mut self) {
        self.attempt = 0;
    }
}

/// How a [`retry`] loop ended without a result.
#[derive(Debug)]
pub enum RetryEnd {
    /// `stop` was cancelled first.
    Stopped,
    /// The request failed in a way retrying cannot fix (anything but [`ErrorKind::Transient`]).
    Failed(ClientError),
}

/// Runs `op` until it succeeds, waiting per `policy` after each transient failure (logged with
/// `what`), and giving up when `stop` is cancelled or a failure is not transient.
pub async fn retry<T, F, Fut>(
    policy: Backoff,
    salt: u64,
    stop: &CancellationToken,
    what: &str,
    mut op: F,
) -> Result<T, RetryEnd>
where
    F: FnMut() -> Fut,
    Fut: Future<Output = Result<T, ClientError>>,
{
    let mut attempts = policy.attempts(salt);
    loop {
        let err = tokio::select! {
            _ = stop.cancelled() => return Err(RetryEnd::Stopped),
            r = op() => match r {
                Ok(v) => return Ok(v),
                Err(e) => e,
            },
        };
        if err.kind() != ErrorKind::Transient {
            return Err(RetryEnd::Failed(err));
        }
        let delay = attempts.next_delay();
        tracing::warn!(error = %err, ?delay, "{what} failed; retrying");
        tokio::select! {
            _ = stop.cancelled() => return Err(RetryEnd::Stopped),
            _ = tokio::time::sleep(delay) => {}
        }
    }
}

/// The splitmix64 finaliser: a bijective, well-mixing hash of a 64-bit value.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base_delays_double_then_stop_at_the_cap() {
        let b = Backoff {
            initial: Duration::from_millis(100),
            max: Duration::from_millis(1000),
        };
        let got: Vec<u128> = (0..7).map(|a| b.base_delay(a).as_millis()).collect();
        assert_eq!(got, [100, 200, 400, 800, 1000, 1000, 1000]);
        // Huge attempt numbers neither overflow nor exceed the cap.
        assert_eq!(b.base_delay(u32::MAX), Duration::from_millis(1000));
    }

    #[test]
    fn jitter_stays_within_half_to_full_base_delay() {
        let b = Backoff::default();
        for salt in 0..50u64 {
            for attempt in 0..12 {
                let base = b.base_delay(attempt);
                let d = b.delay(attempt, salt);
                assert!(
                    d >= base / 2 && d <= base,
                    "attempt {attempt} salt {salt}: {d:?} vs {base:?}"
                );
            }
        }
    }

    #[test]
    fn jitter_differs_between_salts() {
        let b = Backoff::default();
        let a: Vec<Duration> = (0..8).map(|i| b.delay(i, 1)).collect();
        let c: Vec<Duration> = (0..8).map(|i| b.delay(i, 2)).collect();
        assert_ne!(a, c);
    }

    #[tokio::test(start_paused = true)]
    async fn retry_retries_transient_failures_then_returns_the_value() {
        let stop = CancellationToken::new();
        let mut calls = 0;
        let start = tokio::time::Instant::now();
        let got = retry(Backoff::default(), 1, &stop, "test", || {
            calls += 1;
            let n = calls;
            async move {
                if n < 4 {
                    Err(ClientError::Unreachable("refused".into()))
                } else {
                    Ok(n)
                }
            }
        })
        .await;
        assert!(matches!(got, Ok(4)));
        // Three waits of at most 100, 200 and 400 ms, at least half of each.
        let waited = start.elapsed();
        assert!(
            waited >= Duration::from_millis(350) && waited <= Duration::from_millis(700),
            "{waited:?}"
        );
    }

    #[tokio::test(start_paused = true)]
    async fn retry_gives_up_on_a_permanent_failure_or_a_stop() {
        let stop = CancellationToken::new();
        let got: Result<(), _> = retry(Backoff::default(), 1, &stop, "test", || async {
            Err(ClientError::Status {
                status: reqwest::StatusCode::CONFLICT,
                message: "stale".into(),
            })
        })
        .await;
        assert!(matches!(got, Err(RetryEnd::Failed(e)) if e.kind() == ErrorKind::Conflict));

        let stopper = stop.clone();
        tokio::spawn(async move {
            tokio::time::sleep(Duration::from_secs(60)).await;
            stopper.cancel();
        });
        let got: Result<(), _> = retry(Backoff::default(), 1, &stop, "test", || async {
            Err(ClientError::Unreachable("refused".into()))
        })
        .await;
        assert!(matches!(got, Err(RetryEnd::Stopped)));
    }

    #[test]
    fn attempts_advance_and_reset() {
        let b = Backoff {
            initial: Duration::from_millis(8),
            max: Duration::from_secs(1),
        };
        let mut s = b.attempts(7);
        let first = s.next_delay();
        let second = s.next_delay();
        assert_eq!(s.count(), 2);
        assert!(first <= Duration::from_millis(8) && second >= Duration::from_millis(8));
        s.reset();
        assert_eq!(s.count(), 0);
        assert_eq!(s.next_delay(), first);
    }
}
