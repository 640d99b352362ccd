//! What the mapper bench and the callgrind driver (`examples/callgrind_drive.rs`) share.

use mimnav_shared::topics::Point;

/// Where a revolution's `lidar/slices` samples start: every 4 packets of 384 points
/// (`velodyne.slice_packets`, dual return) counted back from its end, each on a firing's
/// boundary. The last one starts at most 4 packets before the end.
pub(crate) fn slice_starts(points: &[Point]) -> Vec<usize> {
    let mut starts = Vec::new();
    let mut end = points.len();
    while end > 0 {
        let mut at = end.saturating_sub(4 * 384);
        while at > 0 && at < end && points[at].time_offset_ns == points[at - 1].time_offset_ns {
            at += 1;
        }
        if at >= end {
            break;
        }
        starts.push(at);
        end = at;
    }
    if starts.last() != Some(&0) {
        starts.push(0);
    }
    starts.reverse();
    starts
}
