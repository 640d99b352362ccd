//! `UPDATE-AND-ARCHIVE`: evidence grows fast and decays slowly; alarm and `R_s` from `R_f`.

use super::*;

#[test]
fn evidence_step_values() {
    assert_eq!(evidence_step(25.0, 0.0), 25.0, "learn: C_k + C_{{k-1}}");
    assert_eq!(
        evidence_step(25.0, 12.0),
        37.0,
        "learn fast on top of old evidence"
    );
    assert_eq!(evidence_step(0.0, 25.0), 12.0, "forget: 25 - ceil(12.5)");
    assert_eq!(
        evidence_step(25.0, 25.0),
        0.0,
        "equal evidence: 25 - ceil(25), the literal rule"
    );
    assert_eq!(evidence_step(0.0, 0.5), 0.0, "never below 0");
    assert_eq!(evidence_step(0.0, 0.0), 0.0);
}

#[test]
fn evidence_grows_fast_and_decays_slowly() {
    let p = FoliageParams {
        window_rad: TAU / 16.0,
        ..Default::default()
    };
    let mut hist = History::new(16);
    let ranges = [1.0f32];
    let windows = [4u32];
    let sectors = [0u32];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    let mut ck = vec![];
    let mut nearest = vec![0.0; p.n_sectors()];
    // Candidate pattern per scan for window 4, and the expected (C_{k-1}, C_{k-2}) after each.
    let seen = [
        true, false, false, false, false, false, false, true, false, true, true, true,
    ];
    let expect = [
        (25.0, 0.0),
        (12.0, 25.0),
        (6.0, 12.0),
        (3.0, 6.0),
        (1.0, 3.0),
        (0.0, 1.0), // expired after 5 scans without it
        (0.0, 0.0),
        (25.0, 0.0),
        (12.0, 25.0),
        (37.0, 12.0), // seen again soon: learns fast, above K3
        (6.0, 37.0),  // 37 - ceil((25 + 37) / 2)
        (31.0, 6.0),
    ];
    for (k, (&s, &(e1, e2))) in seen.iter().zip(&expect).enumerate() {
        let rc = [if s { 1.0 } else { 0.0 }];
        let rf = [0.0f32];
        let alarm = update_and_archive(&p, scan, &rc, &rf, &mut hist, &mut ck, &mut nearest);
        assert!(!alarm, "alarm comes from R_f, which is empty");
        assert_eq!(ck[4], if s { p.k3 } else { 0.0 }, "C_k from R_c, scan {k}");
        assert_eq!((hist.c_prev1[4], hist.c_prev2[4]), (e1, e2), "scan {k}");
        assert_eq!(hist.c_prev1[3], 0.0, "other windows untouched");
    }
    // R_s and alarm from R_f.
    let rf = [1.0f32];
    let alarm = update_and_archive(&p, scan, &[1.0], &rf, &mut hist, &mut ck, &mut nearest);
    assert!(alarm);
    assert_eq!(nearest[0], 1.0);
    assert!(nearest[1..].iter().all(|x| x.is_infinite()));
}
