//! Connections held per client address, so that one address cannot take the slots of
//! everyone else ([`crate::serve`]).
//!
//! The global connection cap ([`crate::Config::max_connections`]) keeps the coordinator within
//! its descriptors, but one client that opens connections and lets them idle — or reopens
//! them as fast as the header deadline closes them — would otherwise hold every slot, and
//! `/healthz` would go unanswered. At most [`crate::Config::max_connections_per_address`]
//! connections from one IP address are served at once; a further one is closed as soon as it
//! is accepted, which frees its slot at once.

use std::collections::HashMap;
use std::net::IpAddr;
use std::sync::{Arc, Mutex};

/// Connections open per address.
#[derive(Clone)]
pub struct Peers {
    open: Arc<Mutex<HashMap<IpAddr, usize>>>,
    cap: usize,
}

/// A connection counted against its address until dropped.
pub struct Held {
    peers: Peers,
    ip: IpAddr,
}

impl Peers {
    /// At most `cap` connections per address.
    pub fn new(cap: usize) -> Peers {
        Peers {
            open: Arc::default(),
            cap,
        }
    }

    /// Counts a connection from `ip`, or `None` when the address already holds its share.
    pub fn admit(&self, ip: IpAddr) -> Option<Held> {
        let mut open = self.open.lock().unwrap_or_else(|p| p.into_inner());
        let n = open.entry(ip).or_default();
        if *n >= self.cap {
            return None;
        }
        *n += 1;
        Some(Held {
            peers: self.clone(),
            ip,
        })
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        let mut open = self.peers.open.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(n) = open.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                open.remove(&self.ip);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_address_holds_at_most_its_share_and_gets_it_back() {
        let peers = Peers::new(2);
        let (a, b): (IpAddr, IpAddr) = ("127.0.0.2".parse().unwrap(), "::1".parse().unwrap());
        let first = peers.admit(a).unwrap();
        let _second = peers.admit(a).unwrap();
        assert!(peers.admit(a).is_none(), "a third from the same address");
        let _other = peers.admit(b).expect("another address has its own share");
        drop(first);
        assert!(
            peers.admit(a).is_some(),
            "a closed connection frees its place"
        );
        assert_eq!(peers.open.lock().unwrap().len(), 2);
    }
}
