//! Random secrets for the `spindle` command: idempotency keys, and the tokens of the local
//! farm's coordinator.
//!
//! The standard library's `RandomState` is seeded from the operating system's random source
//! once per process and varies per instance; hashing a counter, the time and the process id
//! through fresh instances gives unpredictable 256-bit values without another dependency.
//! blake3 mixes the parts into uniform hex.

use std::collections::hash_map::RandomState;
use std::hash::{BuildHasher, Hasher};
use std::sync::atomic::{AtomicU64, Ordering};

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// 64 random lowercase hex digits.
pub fn random_hex() -> String {
    let mut hasher = blake3::Hasher::new();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    for i in 0..4u64 {
        let mut h = RandomState::new().build_hasher();
        h.write_u64(n);
        h.write_u64(i);
        h.write_u128(nanos);
        h.write_u32(std::process::id());
        hasher.update(&h.finish().to_le_bytes());
    }
    hasher.update(&nanos.to_le_bytes());
    hasher.finalize().to_hex().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_hex_and_distinct() {
        let a: Vec<String> = (0..100).map(|_| random_hex()).collect();
        for s in &a {
            assert_eq!(s.len(), 64);
            assert!(
                s.bytes()
                    .all(|b| b.is_ascii_hexdigit() && !b.is_ascii_uppercase())
            );
        }
        let unique: std::collections::BTreeSet<&String> = a.iter().collect();
        assert_eq!(unique.len(), a.len());
    }
}
