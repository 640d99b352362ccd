//! A topic's bytes as docs/topics.md lays them out: the user header, then the payload's
//! elements one after the other, in the machine's byte order (little-endian on x86-64 and arm64).
//!
//! [`Plain`] is implemented only for the `#[repr(C)]` types whose layout table in
//! docs/topics.md says "padding 0" (checked against `offset_of!`/`size_of` by
//! `tests/topics_doc.rs`): every byte of such a value is a field's byte, so viewing it as bytes
//! reads no uninitialised padding. `RawPacket` (2 bytes of padding) is not one of them.

use mimnav_shared::topics::{
    BaseState, FoliageHeader, FoliageReturn, Goal, MapHeader, Odometry, PlanCell, Point,
    PointsHeader, ScanHeader, ScanReturn, TruthHeader, VelocityCommand,
};

mod sealed {
    pub trait Sealed {}
}

/// A `#[repr(C)]` type without padding bytes, whose values may be read as bytes.
///
/// # Safety
/// Every byte of the type's representation belongs to a field, and every field is an integer,
/// a float or an array of them (no pointers, no padding).
pub unsafe trait Plain: Copy + sealed::Sealed {}

macro_rules! plain {
    ($($t:ty),*) => {$(
        impl sealed::Sealed for $t {}
        // SAFETY: docs/topics.md gives the type padding 0 and only integer, float and array
        // fields; tests/topics_doc.rs checks both against the type.
        unsafe impl Plain for $t {}
    )*};
}

plain!(
    u8,
    f32,
    Point,
    PointsHeader,
    ScanReturn,
    ScanHeader,
    VelocityCommand,
    Odometry,
    Goal,
    BaseState,
    TruthHeader,
    MapHeader,
    PlanCell,
    FoliageReturn,
    FoliageHeader
);

/// The bytes of `items` as they lie in memory.
pub fn bytes_of<T: Plain>(items: &[T]) -> &[u8] {
    // SAFETY: `T: Plain` has no padding, so all `size_of_val(items)` bytes are initialised; u8
    // has alignment 1 and the slice lives as long as the returned borrow.
    unsafe { std::slice::from_raw_parts(items.as_ptr().cast::<u8>(), size_of_val(items)) }
}

/// Appends `header`'s bytes, then `items`' bytes, to `out`.
pub fn put<H: Plain, T: Plain>(out: &mut Vec<u8>, header: &H, items: &[T]) {
    out.extend_from_slice(bytes_of(std::slice::from_ref(header)));
    out.extend_from_slice(bytes_of(items));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes are the fields at docs/topics.md's offsets, little-endian.
    #[test]
    fn a_goal_is_its_fields_at_the_documented_offsets() {
        let g = Goal {
            seq: 7,
            stamp_mono_ns: 9,
            x: 1.5,
            y: -2.0,
            tolerance_m: 0.25,
            flags: 1,
            reserved: [0; 7],
        };
        let b = bytes_of(std::slice::from_ref(&g));
        assert_eq!(b.len(), 48);
        assert_eq!(b[0..8], 7u64.to_le_bytes());
        assert_eq!(b[8..16], 9u64.to_le_bytes());
        assert_eq!(b[16..24], 1.5f64.to_le_bytes());
        assert_eq!(b[24..32], (-2.0f64).to_le_bytes());
        assert_eq!(b[32..40], 0.25f64.to_le_bytes());
        assert_eq!(b[40], 1);
    }

    #[test]
    fn header_then_items() {
        let h = PointsHeader {
            seq: 3,
            point_count: 2,
            ..Default::default()
        };
        let p = [
            Point {
                x: 1.0,
                intensity: 5,
                ..Default::default()
            },
            Point {
                ring: 15,
                ..Default::default()
            },
        ];
        let mut out = Vec::new();
        put(&mut out, &h, &p);
        assert_eq!(out.len(), 56 + 2 * 24);
        assert_eq!(out[36..40], 2u32.to_le_bytes());
        assert_eq!(out[56..60], 1.0f32.to_le_bytes());
        assert_eq!(out[56 + 20], 5);
        assert_eq!(out[56 + 24 + 22], 15);
    }
}
