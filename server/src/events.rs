//! Live events for operators and dashboards (`GET /v1/events`, Server-Sent Events): job state
//! changes, finished tiles, workers joining, draining and lost.
//!
//! Every event gets the next id (1, 2, …). The newest [`EVENT_RING`] are kept in memory so a
//! client reconnecting with `Last-Event-ID` gets what it missed; one whose id has left the ring,
//! or is past the newest (it counted on a coordinator before this one started: ids begin again
//! at 1 with every start), gets a `reset` event instead and refetches the state. Subscribers are fed through a bounded
//! broadcast channel ([`EVENT_CHANNEL`]): one that falls that far behind is dropped (its stream
//! ends; it reconnects with its last id), never buffered without bound. At most
//! [`MAX_EVENT_SUBSCRIBERS`] streams are open at once, and at most
//! [`MAX_EVENT_STREAMS_PER_ADDRESS`] from one client address, so one address cannot take every
//! place (the dashboard of another is never locked out).
//!
//! A subscriber that stops reading must give its place back within seconds, not once the
//! buffers between it and the coordinator are full: a stream's connection keeps at most
//! [`EVENT_SEND_BUFFER`] in its send buffer and a write to it may wait at most
//! [`EVENT_SEND_WAIT`] ([`crate::send_bound`]), past which the connection, the stream and its
//! place end. What the client's own receive buffer holds (tens to hundreds of kilobytes) is what
//! a non-reader takes before that; a stream with nothing to send costs its place only.

use std::collections::{HashMap, VecDeque};
use std::net::IpAddr;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use spindle_common::protocol::{EventKind, FarmEvent};
use tokio::sync::broadcast;

use crate::clock::now_ms;
use crate::error::Error;

/// Events kept for reconnecting clients.
pub const EVENT_RING: usize = 1024;
/// Events a subscriber may fall behind before it is dropped.
pub const EVENT_CHANNEL: usize = 256;
/// Event streams open at once.
pub const MAX_EVENT_SUBSCRIBERS: usize = 32;
/// Event streams open at once from one client address.
pub const MAX_EVENT_STREAMS_PER_ADDRESS: usize = 4;
/// The longest a write to an event stream's connection may wait for its reader.
pub const EVENT_SEND_WAIT: Duration = Duration::from_secs(2);
/// An event stream's socket send buffer: what the coordinator holds for a slow reader.
pub const EVENT_SEND_BUFFER: usize = 16 * 1024;

/// The event log and its subscribers.
pub struct Events {
    ring: Mutex<Ring>,
    sender: broadcast::Sender<Arc<FarmEvent>>,
    subscribers: Arc<AtomicUsize>,
    by_address: StreamsByAddress,
    capacity: usize,
}

struct Ring {
    last_id: u64,
    events: VecDeque<Arc<FarmEvent>>,
}

/// A new subscriber: the events it missed (or a `reset`), then the live ones.
pub struct Subscription {
    pub backlog: Vec<Arc<FarmEvent>>,
    pub live: broadcast::Receiver<Arc<FarmEvent>>,
    /// Counts the subscriber until dropped.
    pub slot: SubscriberSlot,
}

/// Event streams open per client address (addresses with none are not kept).
type StreamsByAddress = Arc<Mutex<HashMap<IpAddr, usize>>>;

/// One of the [`MAX_EVENT_SUBSCRIBERS`] places, and of its address's
/// [`MAX_EVENT_STREAMS_PER_ADDRESS`], given back on drop.
pub struct SubscriberSlot {
    total: Arc<AtomicUsize>,
    address: Option<(StreamsByAddress, IpAddr)>,
}

impl Drop for SubscriberSlot {
    fn drop(&mut self) {
        self.total.fetch_sub(1, Ordering::SeqCst);
        if let Some((counts, ip)) = &self.address {
            let mut counts = counts.lock().unwrap_or_else(|p| p.into_inner());
            if let Some(n) = counts.get_mut(ip) {
                *n -= 1;
                if *n == 0 {
                    counts.remove(ip);
                }
            }
        }
    }
}

impl Default for Events {
    fn default() -> Self {
        Events::with_capacity(EVENT_RING)
    }
}

impl Events {
    /// An empty log keeping the newest `capacity` events.
    pub fn with_capacity(capacity: usize) -> Events {
        Events {
            ring: Mutex::new(Ring {
                last_id: 0,
                events: VecDeque::new(),
            }),
            sender: broadcast::channel(EVENT_CHANNEL).0,
            subscribers: Arc::new(AtomicUsize::new(0)),
            by_address: Arc::default(),
            capacity: capacity.max(1),
        }
    }

    fn ring(&self) -> std::sync::MutexGuard<'_, Ring> {
        self.ring.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Records an event and sends it to every subscriber.
    pub fn publish(&self, kind: EventKind) {
        let mut ring = self.ring();
        ring.last_id += 1;
        let event = Arc::new(FarmEvent {
            id: ring.last_id,
            at_ms: now_ms(),
            kind,
        });
        if ring.events.len() == self.capacity {
            ring.events.pop_front();
        }
        ring.events.push_back(event.clone());
        // Sent under the ring's lock, so subscribers see ids in order and a new subscriber's
        // backlog and live events neither overlap nor leave a gap. No subscriber: nothing to do.
        let _ = self.sender.send(event);
    }

    /// Subscribes; `last_id` is the `Last-Event-ID` of a reconnecting client, `peer` its
    /// address (none in the in-process router of tests). 429 past
    /// [`MAX_EVENT_STREAMS_PER_ADDRESS`] from `peer`, 503 past [`MAX_EVENT_SUBSCRIBERS`].
    pub fn subscribe(
        &self,
        last_id: Option<u64>,
        peer: Option<IpAddr>,
    ) -> Result<Subscription, Error> {
        let taken = self.subscribers.fetch_add(1, Ordering::SeqCst);
        let mut slot = SubscriberSlot {
            total: self.subscribers.clone(),
            address: None,
        };
        if let Some(ip) = peer {
            let mut counts = self.by_address.lock().unwrap_or_else(|p| p.into_inner());
            let held = counts.entry(ip).or_default();
            if *held >= MAX_EVENT_STREAMS_PER_ADDRESS {
                return Err(Error::RateLimited {
                    message: format!(
                        "{ip} has {MAX_EVENT_STREAMS_PER_ADDRESS} event streams open, the most \
                         one address may; close one"
                    ),
                    retry_after: std::time::Duration::from_secs(5),
                });
            }
            *held += 1;
            slot.address = Some((self.by_address.clone(), ip));
        }
        if taken >= MAX_EVENT_SUBSCRIBERS {
            return Err(Error::Unavailable(
                "too many event streams are open; try again later",
            ));
        }
        let ring = self.ring();
        let live = self.sender.subscribe();
        let reset = || {
            vec![Arc::new(FarmEvent {
                id: ring.last_id,
                at_ms: now_ms(),
                kind: EventKind::Reset,
            })]
        };
        let backlog = match last_id {
            None => Vec::new(),
            Some(id) if id == ring.last_id => Vec::new(),
            // An id this log never gave: whatever the client holds is of another log.
            Some(id) if id > ring.last_id => reset(),
            Some(id) => {
                let oldest = ring.events.front().map_or(ring.last_id + 1, |e| e.id);
                if id + 1 < oldest {
                    reset()
                } else {
                    ring.events.iter().filter(|e| e.id > id).cloned().collect()
                }
            }
        };
        Ok(Subscription {
            backlog,
            live,
            slot,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joined(n: u64) -> EventKind {
        EventKind::WorkerJoined {
            worker_id: n,
            worker: format!("w{n}"),
        }
    }

    #[test]
    fn a_reconnecting_client_gets_what_it_missed_or_a_reset() {
        let events = Events::with_capacity(3);
        for n in 1..=5 {
            events.publish(joined(n));
        }
        // The ring holds 3, 4, 5.
        let ids = |s: Subscription| s.backlog.iter().map(|e| e.id).collect::<Vec<_>>();
        assert_eq!(ids(events.subscribe(Some(2), None).unwrap()), vec![3, 4, 5]);
        assert_eq!(ids(events.subscribe(Some(4), None).unwrap()), vec![5]);
        assert_eq!(
            ids(events.subscribe(Some(5), None).unwrap()),
            Vec::<u64>::new()
        );
        assert_eq!(
            ids(events.subscribe(None, None).unwrap()),
            Vec::<u64>::new()
        );
        let reset = events.subscribe(Some(1), None).unwrap();
        assert_eq!(reset.backlog.len(), 1);
        assert_eq!(reset.backlog[0].kind, EventKind::Reset);
        assert_eq!(
            reset.backlog[0].id, 5,
            "resume after the reset from the newest id"
        );
    }

    #[test]
    fn an_id_from_the_future_gets_a_reset_not_silence() {
        // A client that followed a coordinator before this one started: its id is past ours.
        let events = Events::with_capacity(3);
        let fresh = events.subscribe(Some(41), None).unwrap();
        assert_eq!(fresh.backlog.len(), 1);
        assert_eq!(fresh.backlog[0].kind, EventKind::Reset);
        assert_eq!(fresh.backlog[0].id, 0);
        events.publish(joined(1));
        events.publish(joined(2));
        let later = events.subscribe(Some(3), None).unwrap();
        assert_eq!(later.backlog.len(), 1);
        assert_eq!(later.backlog[0].kind, EventKind::Reset);
        assert_eq!(later.backlog[0].id, 2, "resume from the newest id");
    }

    #[tokio::test]
    async fn live_events_follow_in_order_and_subscribers_are_capped() {
        let events = Events::default();
        let mut sub = events.subscribe(None, None).unwrap();
        events.publish(joined(1));
        events.publish(joined(2));
        assert_eq!(sub.live.recv().await.unwrap().id, 1);
        assert_eq!(sub.live.recv().await.unwrap().id, 2);
        let held: Vec<_> = (1..MAX_EVENT_SUBSCRIBERS)
            .map(|_| events.subscribe(None, None).unwrap())
            .collect();
        assert!(matches!(
            events.subscribe(None, None),
            Err(Error::Unavailable(_))
        ));
        drop(held);
        assert!(events.subscribe(None, None).is_ok(), "slots come back");
    }

    #[test]
    fn one_address_holds_a_few_streams_and_leaves_the_rest_to_others() {
        let events = Events::default();
        let (a, b): (IpAddr, IpAddr) = ([10, 0, 0, 1].into(), [10, 0, 0, 2].into());
        let mut held: Vec<_> = (0..MAX_EVENT_STREAMS_PER_ADDRESS)
            .map(|_| events.subscribe(None, Some(a)).unwrap())
            .collect();
        assert!(matches!(
            events.subscribe(None, Some(a)),
            Err(Error::RateLimited { .. })
        ));
        assert!(events.subscribe(None, Some(b)).is_ok(), "another address");
        held.pop();
        assert!(
            events.subscribe(None, Some(a)).is_ok(),
            "a place comes back"
        );
    }

    #[tokio::test]
    async fn a_subscriber_that_falls_behind_is_dropped_not_buffered() {
        let events = Events::default();
        let mut sub = events.subscribe(None, None).unwrap();
        for n in 0..(EVENT_CHANNEL as u64 + 10) {
            events.publish(joined(n));
        }
        assert!(matches!(
            sub.live.recv().await,
            Err(broadcast::error::RecvError::Lagged(_))
        ));
    }
}
