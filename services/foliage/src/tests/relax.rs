//! `RELAX-OBST`: candidates grow within the tolerance and stop at a jump.

use super::*;

#[test]
fn relax_extends_within_tolerance_and_stops_at_jump() {
    let p = FoliageParams::default(); // a = 0.01, b = 0.03: T ≈ 0.05 m at 2 m with no evidence
    let ranges = [2.0f32, 2.01, 0.0, 2.03, 2.5, 2.51, 2.52, 1.4, 1.3, 2.02];
    let n = ranges.len();
    let windows = vec![0u32; n];
    let sectors = vec![0u32; n];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    let hist = History::new(8);
    let mut rc = vec![0.0; n];
    rc[0] = 2.0;
    let mut q = RelaxWork::default();
    let added = relax_obst(&p, scan, &hist, &mut rc, &mut q);
    // Joined: 1 (from 0), 9 (r-1 of 0, wrapped), 3 (r+2 of 1, over the no-return at 2).
    // Not joined: 4–6 (0.47 m jump), 7 and 8 (1.4 m, 1.3 m), 2 (no return).
    assert_eq!(
        rc,
        vec![2.0, 2.01, 0.0, 2.03, 0.0, 0.0, 0.0, 0.0, 0.0, 2.02]
    );
    assert_eq!(added, 3);

    // With evidence on the window the tolerance grows by C = 1 + K2·(25 + 0) = 2.25 (≈ 0.113 m):
    // a 0.1 m step is now bridged, the 0.47 m jump still is not.
    let ranges2 = [2.0f32, 2.1, 2.2, 2.67];
    let mut hist = History::new(8);
    let windows2 = [0u32; 4];
    let sectors2 = [0u32; 4];
    let scan2 = Scan {
        ranges: &ranges2,
        windows: &windows2,
        sectors: &sectors2,
    };
    let mut rc = vec![2.0, 0.0, 0.0, 0.0];
    relax_obst(&p, scan2, &hist, &mut rc, &mut q);
    assert_eq!(
        rc,
        vec![2.0, 0.0, 0.0, 0.0],
        "0.1 m > 0.05 m without evidence"
    );
    hist.c_prev1[0] = 25.0;
    let mut rc = vec![2.0, 0.0, 0.0, 0.0];
    relax_obst(&p, scan2, &hist, &mut rc, &mut q);
    assert_eq!(rc, vec![2.0, 2.1, 2.2, 0.0]);
    let t = relax_tolerance(&p, 2.1, 25.0, 0.0);
    assert!((t - 2.25 * (0.01 * 2.1 + 0.03)).abs() < 1e-6);
}
