//! Byte counts as people read them, for messages about memory (used by the errors and by
//! [`crate::memory`]).

/// Bytes in GB with three significant digits, e.g. "8.29 GB" (MB below 1 GB).
pub fn format_bytes(bytes: u128) -> String {
    let b = bytes as f64;
    if b >= 1e9 {
        format!("{:.3} GB", b * 1e-9)
    } else {
        format!("{:.1} MB", b * 1e-6)
    }
}
