//! How much memory one file may make us allocate, decided before allocating.
//!
//! A header can declare far more than its file holds (a 1.7 MB PNG declaring
//! 30000x30000 pixels, a PCD declaring 2^40 points). Readers ask [`check`] with the
//! number of items the header declares and the bytes each will take, and refuse the
//! file, naming it and the limit, when the total is over the budget.
//!
//! The budget is `SOFTSENSE_MAX_MEMORY` (bytes, with an optional `K`, `M` or `G`
//! suffix) when set, else half the memory the system reports available, else 4 GiB.

use std::path::Path;
use std::sync::OnceLock;

/// The environment variable that overrides the memory budget.
pub const MAX_MEMORY_ENV: &str = "SOFTSENSE_MAX_MEMORY";

/// The budget when neither the environment nor the system says: 4 GiB.
pub const FALLBACK_BYTES: u64 = 4 << 30;

/// A file declares more than the budget allows.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "declares {count} {what} ({needed} bytes), over the memory limit of {limit} bytes \
     (set {MAX_MEMORY_ENV} to raise it)"
)]
pub struct TooLarge {
    /// What the header declares (`pixels`, `points`, `vertices`).
    pub what: &'static str,
    /// How many it declares.
    pub count: u64,
    /// Bytes they would take.
    pub needed: u64,
    /// The budget in bytes.
    pub limit: u64,
}

/// The memory budget in bytes for one file's contents (see the module docs).
pub fn max_bytes() -> u64 {
    static BUDGET: OnceLock<u64> = OnceLock::new();
    *BUDGET.get_or_init(|| {
        std::env::var(MAX_MEMORY_ENV)
            .ok()
            .and_then(|v| parse_bytes(&v))
            .or_else(|| available_bytes().map(|b| b / 2))
            .unwrap_or(FALLBACK_BYTES)
    })
}

/// Refuses `count` items of `bytes_each` bytes when they exceed [`max_bytes`].
pub fn check(what: &'static str, count: u64, bytes_each: u64) -> Result<(), TooLarge> {
    check_against(what, count, bytes_each, max_bytes())
}

/// [`check`] against an explicit budget (for tests and callers with their own limit).
pub fn check_against(
    what: &'static str,
    count: u64,
    bytes_each: u64,
    limit: u64,
) -> Result<(), TooLarge> {
    // An overflowing product is over any budget (saturating would equal u64::MAX).
    let needed = count.saturating_mul(bytes_each);
    if count.checked_mul(bytes_each).is_none_or(|n| n > limit) {
        return Err(TooLarge {
            what,
            count,
            needed,
            limit,
        });
    }
    Ok(())
}

/// Parses `123`, `512K`, `400M`, `2G` (binary multiples) into bytes.
pub fn parse_bytes(text: &str) -> Option<u64> {
    let t = text.trim();
    let (digits, shift) = match t.char_indices().last()? {
        (i, 'k' | 'K') => (&t[..i], 10),
        (i, 'm' | 'M') => (&t[..i], 20),
        (i, 'g' | 'G') => (&t[..i], 30),
        _ => (t, 0),
    };
    let n: u64 = digits.trim().parse().ok()?;
    n.checked_mul(1u64 << shift).filter(|&b| b > 0)
}

/// `MemAvailable` from `/proc/meminfo` in bytes, where the system has it.
fn available_bytes() -> Option<u64> {
    let text = std::fs::read_to_string(Path::new("/proc/meminfo")).ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_binary_suffixes() {
        assert_eq!(parse_bytes("123"), Some(123));
        assert_eq!(parse_bytes("512K"), Some(512 << 10));
        assert_eq!(parse_bytes(" 400m "), Some(400 << 20));
        assert_eq!(parse_bytes("2G"), Some(2 << 30));
        assert_eq!(parse_bytes("0"), None);
        assert_eq!(parse_bytes("lots"), None);
        assert_eq!(parse_bytes("99999999999999G"), None);
    }

    #[test]
    fn a_declared_size_over_the_budget_is_refused_and_one_under_passes() {
        assert!(check_against("pixels", 1000, 2, 2000).is_ok());
        let e = check_against("pixels", 1001, 2, 2000).unwrap_err();
        assert_eq!(e.needed, 2002);
        assert!(e.to_string().contains(MAX_MEMORY_ENV));
        assert!(check_against("points", u64::MAX, 16, u64::MAX).is_err());
    }
}
