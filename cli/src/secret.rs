//! Random secrets for the `spindle` command: idempotency keys, and the tokens of the local
//! farm's coordinator: 256 bits from the operating system (`getrandom`, as the coordinator's
//! worker secrets), in lowercase hex.

/// 64 random lowercase hex digits.
pub fn random_hex() -> anyhow::Result<String> {
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes)
        .map_err(|e| anyhow::anyhow!("the operating system gave no random bytes: {e}"))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secrets_are_hex_and_distinct() {
        let a: Vec<String> = (0..100).map(|_| random_hex().unwrap()).collect();
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
