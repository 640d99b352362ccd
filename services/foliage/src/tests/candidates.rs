//! `GET-OBST-CANDIDATES`: a wall is a candidate and a grass band is not; thresholds carried,
//! raised, and obstacles held (interpretation 15).

use super::*;

#[test]
fn flat_wall_becomes_candidate_grass_band_does_not() {
    let mut rng = Rng::new(7);
    let (a, r) = wall_scan(&mut rng);
    let rc = candidates_of(&a, &r);
    let on_wall = r.iter().filter(|&&x| x > 0.0).count();
    let cands: Vec<usize> = (0..NE).filter(|&i| rc[i] > 0.0).collect();
    assert!(
        cands.len() >= 20,
        "wall windows become candidates: {} of {on_wall}",
        cands.len()
    );
    assert!(
        cands.iter().all(|&i| r[i] > 1.9 && r[i] < 2.9),
        "candidates lie on the wall"
    );

    // The wall spans 2·atan(1/2) = 53° = 66 windows; nearly all of them hold a candidate.
    let wall_windows = candidate_windows(&a, &rc);
    assert!(
        wall_windows >= 53,
        "wall: only {wall_windows} of 66 windows hold a candidate"
    );

    // The band covers all 450 windows; a max filter over 4 returns can look smooth by chance, so
    // the test is on the rate: over 30 scans at most 0.25 % of the windows, and no scan with more
    // than a tenth of what the (much narrower) wall gives.
    let mut band_windows = 0;
    for seed in 1..=30 {
        let jitter = [0.3, 0.4, 0.5][seed as usize % 3];
        let (a, r) = grass_band_scan(&mut Rng::new(seed), jitter);
        let rc = candidates_of(&a, &r);
        let n = candidate_windows(&a, &rc);
        assert!(
            n * 10 <= wall_windows,
            "seed {seed}: {n} band windows vs {wall_windows} on the wall"
        );
        band_windows += n;
    }
    assert!(
        band_windows * 400 <= 30 * 450,
        "band: {band_windows} candidate windows in 30 scans"
    );
}

/// `GET-OBST-CANDIDATES` on hand-made window values: returns `ranges` in `windows` (one sector),
/// `low` and `hist` as given. Returns the candidate count, `R_c` and `T_k`.
fn candidates_given(
    p: &FoliageParams,
    ranges: &[f32],
    windows: &[u32],
    low: &LowFreq,
    hist: &History,
) -> (usize, Vec<f32>, Vec<f32>) {
    let sectors = vec![0u32; ranges.len()];
    let scan = Scan {
        ranges,
        windows,
        sectors: &sectors,
    };
    let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
    let count = get_obst_candidates(p, scan, low, hist, &mut tk, &mut rc, &mut work);
    (count, rc, tk)
}

#[test]
fn candidate_threshold_carry_and_raise() {
    // 16 windows; nad2v 0 everywhere, one return (the maximum) in window 5 only.
    let p = FoliageParams {
        window_rad: TAU / 16.0,
        ..Default::default()
    };
    let n = 16;
    let low = LowFreq {
        v: {
            let mut v = vec![0.0; n];
            v[5] = 2.0;
            v
        },
        dv: vec![0.0; n],
        nad2v: vec![0.0; n],
    };
    let mut hist = History::new(n);
    hist.t_prev1[3] = 0.1;
    hist.t_prev2[3] = 0.2;
    let (count, rc, tk) = candidates_given(&p, &[1.0, 2.0, 2.0, 2.0], &[5, 5, 5, 9], &low, &hist);
    // Both returns tied at v(5) = 2.0 are candidates; the 1.0 one and window 9 (v = 0) are not.
    assert_eq!(count, 2);
    assert_eq!(rc, vec![0.0, 2.0, 2.0, 0.0]);
    let k1 = p.k1;
    let d = p.delta;
    // T_k = K1 + max(T_{k-1}, T_{k-2}) / 2, then + 2 candidates × (δ/2 at ±1, δ/4 at ±2).
    let expect = |i: usize| -> f32 {
        let base = if i == 3 { k1 + 0.2 / 2.0 } else { k1 };
        base + match i {
            4 | 6 => 2.0 * d / 2.0,
            3 | 7 => 2.0 * d / 4.0,
            _ => 0.0,
        }
    };
    for (i, &t) in tk.iter().enumerate() {
        assert!(
            (t - expect(i)).abs() < 1e-6,
            "T_k({i}) = {t}, expected {}",
            expect(i)
        );
    }
    assert_eq!(carry_threshold(0.025, 0.05, 0.01), 0.025 + 0.025);
}

#[test]
fn raised_threshold_carries_to_next_scan() {
    // nad2v(7) = 0.03 is above K1 = 0.025: window 7 blocks its neighbourhood on a fresh history,
    // but passes once the previous scan raised T(7).
    let p = FoliageParams {
        window_rad: TAU / 16.0,
        ..Default::default()
    };
    let n = 16;
    let mut nad2v = vec![0.0; n];
    nad2v[7] = 0.03;
    let low = LowFreq {
        v: vec![1.0; n],
        dv: vec![0.0; n],
        nad2v,
    };
    let ranges = [1.0f32];
    let windows = [6u32];
    let sectors = [0u32];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
    let mut hist = History::new(n);
    assert_eq!(
        get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work),
        0
    );
    hist.t_prev1[7] = p.k1 + p.delta / 2.0; // as left by a candidate in window 6 or 8
    assert_eq!(
        get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work),
        1
    );
}

/// Interpretation 15: a window passes, blocked neighbourhood or not, when its maximum is near the
/// obstacle confirmed last scan in it or in the window beside it (a bearing that drifted), but
/// not two windows away, not at another range, and not with `hold_obstacles` off.
#[test]
fn held_obstacle_passes_its_own_and_the_neighbouring_windows() {
    let n = 16;
    // every window blocks: nothing passes the paper's test alone
    let mut low = LowFreq {
        v: vec![2.0; n],
        dv: vec![0.0; n],
        nad2v: vec![1.0; n],
    };
    low.v[6] = 2.01;
    low.v[7] = 2.3;
    let (ranges, windows) = ([2.0f32, 2.01, 2.0, 2.3], [5u32, 6, 8, 7]);
    let mut hist = History::free_space(n, 0.02);
    hist.obst_prev[5] = 2.0; // confirmed last scan in window 5 only
    hist.obst_prev[7] = 2.0; // and in window 7, where the maximum is now 0.3 m farther
    for (hold, expect) in [(true, vec![2.0, 2.01, 2.0, 0.0]), (false, vec![0.0; 4])] {
        let p = FoliageParams {
            window_rad: TAU / n as f32,
            hold_obstacles: hold,
            ..Default::default()
        };
        let (_, rc, _) = candidates_given(&p, &ranges, &windows, &low, &hist);
        // window 5 (its own), 6 (beside 5 and 7) and 8 (beside 7) pass; 7 is at another range
        assert_eq!(rc, expect, "hold_obstacles = {hold}");
    }
    // two windows away from anything held: blocked
    hist.obst_prev.fill(0.0);
    hist.obst_prev[3] = 2.0;
    let p = FoliageParams {
        window_rad: TAU / n as f32,
        ..Default::default()
    };
    let (_, rc, _) = candidates_given(&p, &ranges, &windows, &low, &hist);
    assert_eq!(rc, vec![0.0; 4]);
}
