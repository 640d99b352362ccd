//! The pruning: `REMOVE-NEW-OBST`, `REMOVE-THIN-OBST`, `CROP-RANGE`.

use super::*;

#[test]
fn remove_new_obst_needs_evidence_nearby() {
    let n_w = 32;
    let mut hist = History::new(n_w);
    hist.c_prev2[10] = 3.0;
    let windows: Vec<u32> = (5..16).collect();
    let rc = vec![1.0f32; windows.len()];
    let sectors = vec![0u32; windows.len()];
    let scan = Scan {
        ranges: &rc,
        windows: &windows,
        sectors: &sectors,
    };
    let mut rf = vec![];
    remove_new_obst(scan, &hist, &rc, &mut rf);
    let kept: Vec<u32> = windows
        .iter()
        .zip(&rf)
        .filter(|(_, f)| **f > 0.0)
        .map(|(w, _)| *w)
        .collect();
    assert_eq!(kept, vec![8, 9, 10, 11, 12]);
    // Wrap: evidence in window 0 supports window n_w - 1.
    let mut hist = History::new(n_w);
    hist.c_prev1[0] = 1.0;
    assert!(hist.seen_near(n_w - 2) && hist.seen_near(1) && !hist.seen_near(n_w - 3));
}

#[test]
fn obstacle_seen_once_is_held_back_until_seen_again() {
    let mut c = classifier();
    let mut rng = Rng::new(3);
    let (a, r) = wall_scan(&mut rng);
    let v = c.classify(&a, &r);
    assert!(!v.alarm, "new obstacle: held back");
    assert!(v.candidate_count > 50);
    assert_eq!(v.obstacle_count, 0);
    assert!(v.classes.contains(&class::PRUNED));
    // An empty scan in between: the evidence of the first scan is still in C_{k-2}.
    let v = c.classify(&a, &vec![0.0; a.len()]);
    assert!(!v.alarm);
    let (a, r) = wall_scan(&mut rng);
    let v = c.classify(&a, &r);
    assert!(v.alarm, "seen again: confirmed");
    assert!(v.obstacle_count > 50);
    let front = v.nearest_per_sector[18]; // sector [0, 10 deg)
    assert!(front > 1.95 && front < 2.1, "R_s ahead = {front}");
    assert_eq!(v.nearest_per_sector[0], f32::INFINITY);

    // After a reset it is new again.
    c.reset();
    let v = c.classify(&a, &r);
    assert!(!v.alarm);
}

#[test]
fn remove_thin_drops_isolated_hits() {
    // W_s = 5 (d = 2), O_s = 3.
    let mut rf = vec![0.0f32; 20];
    rf[3] = 1.0; // isolated
    for x in &mut rf[8..11] {
        *x = 2.0; // run of 3: every member sees 3 in its 5-window
    }
    rf[14] = 1.5; // pair with a gap: 14, 16 see 2 each
    rf[16] = 1.5;
    rf[19] = 3.0; // run across the wrap: 19, 0, 1
    rf[0] = 3.0;
    rf[1] = 3.0;
    let mut copy = vec![];
    let dropped = remove_thin_obst(&mut rf, 5, 3, &mut copy);
    assert_eq!(dropped, 3);
    let kept: Vec<usize> = (0..20).filter(|&i| rf[i] > 0.0).collect();
    assert_eq!(kept, vec![0, 1, 8, 9, 10, 19]);
    // Counted on the entry copy, no cascade: with W_s = 3, O_s = 3 the middle of a run of three
    // keeps its count of 3 although both ends are dropped.
    let mut run = vec![0.0f32, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(remove_thin_obst(&mut run, 3, 3, &mut copy), 2);
    assert_eq!(run, vec![0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    // Scans shorter than the window count as a whole.
    let mut small = vec![1.0f32, 0.0, 1.0];
    assert_eq!(remove_thin_obst(&mut small, 9, 3, &mut copy), 2);
    let mut small = vec![1.0f32, 1.0, 1.0];
    assert_eq!(remove_thin_obst(&mut small, 9, 3, &mut copy), 0);
    assert_eq!(remove_thin_obst(&mut [], 9, 3, &mut copy), 0);
}

#[test]
fn crop_range_drops_outside_interval() {
    let mut rf = vec![0.2f32, 0.3, 1.0, 3.0, 3.01, 0.0, 50.0];
    assert_eq!(crop_range(&mut rf, 0.3, 3.0), 3);
    assert_eq!(rf, vec![0.0, 0.3, 1.0, 3.0, 0.0, 0.0, 0.0]);
}
