//! The device status bytes of a scan (`LMDscandata`'s third field).
//!
//! The listing gives the second byte: 0 the device is fine, 1 an error, 2 a pollution (dirty
//! window) warning, 4 a pollution error; the first byte is reserved. A scan with a status
//! other than fine is still published (its distances are the device's) and the status is named
//! in the log and in `STATUS=`.

/// What the status bytes say, or `None` when the device is fine.
pub fn describe(status: [u8; 2]) -> Option<String> {
    if status == [0, 0] {
        return None;
    }
    let s = status[1];
    let mut parts = Vec::new();
    if s & 1 != 0 {
        parts.push("device error");
    }
    if s & 2 != 0 {
        parts.push("pollution warning (clean the window)");
    }
    if s & 4 != 0 {
        parts.push("pollution error (clean the window)");
    }
    if s & !7 != 0 || status[0] != 0 {
        parts.push("undocumented status bits");
    }
    Some(format!(
        "device status {:02X} {:02X}: {}",
        status[0],
        status[1],
        parts.join(", ")
    ))
}

#[cfg(test)]
mod tests {
    #[test]
    fn statuses_are_named() {
        assert_eq!(super::describe([0, 0]), None);
        let e = super::describe([0, 1]).expect("error");
        assert!(e.contains("device error"), "{e}");
        let w = super::describe([0, 2]).expect("warning");
        assert!(w.contains("pollution warning"), "{w}");
    }
}
