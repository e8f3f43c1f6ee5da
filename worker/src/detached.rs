//! Work the worker can walk away from: a scene build or a tile render runs on a thread of its
//! own while the worker waits for whichever comes first — the result, the lease lost (or the
//! shutdown deadline), or the work's time limit.
//!
//! A thread cannot be killed, so walking away means: the work is told to stop (an
//! [`Interrupt`], which a tile render checks between bands of rows; a scene build cannot check
//! and runs to its end), its result will be dropped, and the worker goes on to its next lease.
//! Each such thread holds a [`Slot`] of the worker's [`Gate`] until it really ends, and the
//! worker asks for a lease only with a slot in hand. The gate has [`SLOTS`] = 2 slots — the
//! work in hand and one piece of work walked away from — so abandoned work never piles up
//! more than one extra thread: with two abandoned threads still running, the worker waits for
//! one of them before it takes more work.
//!
//! The threads are plain `std` threads, not the runtime's blocking pool, so one that was
//! walked away from never holds up the runtime's shutdown when the worker returns.

use std::panic::AssertUnwindSafe;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio_util::sync::CancellationToken;

/// Slots of a [`Gate`]: the work in hand and one piece of abandoned work still running.
pub const SLOTS: usize = 2;

/// The worker's bound on threads doing work for it, finished with or not.
#[derive(Debug, Clone)]
pub struct Gate(Arc<Semaphore>);

/// A place in the [`Gate`], held by the worker while it works on a lease and by every thread
/// it started for that lease; free again when the last of them lets go.
#[derive(Debug, Clone)]
pub struct Slot {
    _permit: Arc<OwnedSemaphorePermit>,
}

impl Gate {
    pub fn new() -> Gate {
        Gate(Arc::new(Semaphore::new(SLOTS)))
    }

    /// Waits until a slot is free and takes it.
    pub async fn slot(&self) -> Slot {
        let permit = self
            .0
            .clone()
            .acquire_owned()
            .await
            .expect("the gate's semaphore is never closed");
        Slot {
            _permit: Arc::new(permit),
        }
    }

    /// Slots free now.
    pub fn free(&self) -> usize {
        self.0.available_permits()
    }
}

impl Default for Gate {
    fn default() -> Gate {
        Gate::new()
    }
}

/// Set when the worker has walked away from the work: the work should stop at its next
/// check, since its result will not be used.
#[derive(Debug, Clone, Default)]
pub struct Interrupt(Arc<AtomicBool>);

impl Interrupt {
    pub fn is_set(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    pub(crate) fn set(&self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// How a piece of detached work ended, as far as the worker is concerned.
#[derive(Debug)]
pub enum Ended<T> {
    Done(T),
    /// The work broke: "panicked: …" or "could not start a thread: …", to follow the name
    /// of what was being done.
    Broke(String),
    /// `stop` fired first: the lease is lost or the worker is leaving.
    Stopped,
    /// The time limit passed first.
    OverLimit,
}

/// Runs `work` on a thread of its own holding `slot`, and waits for its result, `stop` or
/// `limit`, whichever comes first; in the last two cases the work's [`Interrupt`] is set and
/// the thread is left to end by itself.
pub async fn run<T: Send + 'static>(
    slot: &Slot,
    name: &str,
    limit: Duration,
    stop: &CancellationToken,
    work: impl FnOnce(&Interrupt) -> T + Send + 'static,
) -> Ended<T> {
    let interrupt = Interrupt::default();
    let (sender, result) = tokio::sync::oneshot::channel();
    let (held, flag) = (slot.clone(), interrupt.clone());
    let spawned = std::thread::Builder::new()
        .name(name.to_string())
        .spawn(move || {
            let outcome = std::panic::catch_unwind(AssertUnwindSafe(|| work(&flag)));
            // The worker may have walked away: nobody may be listening.
            let _ = sender.send(outcome.map_err(panic_message));
            drop(held);
        });
    if let Err(e) = spawned {
        return Ended::Broke(format!("could not start a thread: {e}"));
    }
    let ended = tokio::select! {
        outcome = result => match outcome {
            Ok(Ok(value)) => Ended::Done(value),
            Ok(Err(message)) => Ended::Broke(format!("panicked: {message}")),
            Err(_) => Ended::Broke("ended without a result".to_string()),
        },
        _ = stop.cancelled() => Ended::Stopped,
        _ = sleep_at_most(limit) => Ended::OverLimit,
    };
    if !matches!(ended, Ended::Done(_)) {
        interrupt.set();
    }
    ended
}

/// `tokio::time::sleep`, for any duration however long.
async fn sleep_at_most(limit: Duration) {
    // About 30 years: beyond it tokio's timer cannot count, and nobody waits that long.
    const FOREVER: Duration = Duration::from_secs(1 << 30);
    tokio::time::sleep(limit.min(FOREVER)).await;
}

/// The message of a caught panic.
fn panic_message(payload: Box<dyn std::any::Any + Send>) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(no message)".to_string())
}

#[cfg(test)]
mod tests;
