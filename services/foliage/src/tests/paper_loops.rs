//! The fast routines against literal transcriptions of the paper's "repeat until done" loops.

use super::*;

/// `GET-OBST-CANDIDATES` lines 1–19 as written: passes over the returns in order, thresholds raised
/// as soon as a candidate is found, until a pass changes nothing.
#[allow(clippy::needless_range_loop)] // kept index-based, like the pseudo-code
fn get_candidates_literal(
    p: &FoliageParams,
    scan: Scan<'_>,
    low: &LowFreq,
    hist: &History,
) -> (Vec<f32>, Vec<f32>) {
    let n_w = low.v.len();
    let ne = scan.len();
    let wrap_w = |i: usize, d: isize| (i as isize + d).rem_euclid(n_w as isize) as usize;
    let mut t: Vec<f32> = (0..n_w)
        .map(|i| carry_threshold(p.k1, hist.t_prev1[i], hist.t_prev2[i]))
        .collect();
    let mut rc = vec![0.0f32; ne];
    let mut passes = 0;
    loop {
        passes += 1;
        let mut done = true;
        for r in 0..ne {
            let (range, w) = (scan.ranges[r], scan.windows[r] as usize);
            if range == 0.0 || low.v[w] == 0.0 || rc[r] == range {
                continue;
            }
            let low_freq = (-2..=2).all(|d| low.nad2v[wrap_w(w, d)] < t[wrap_w(w, d)]);
            if range == low.v[w] && low_freq {
                rc[r] = range;
                for (d, x) in [(-2, 0.25), (-1, 0.5), (1, 0.5), (2, 0.25)] {
                    t[wrap_w(w, d)] += x * p.delta;
                }
                done = false;
            }
        }
        if done {
            break;
        }
    }
    assert!(
        passes <= 2,
        "the fixed point is reached in one pass (+1 to see no change)"
    );
    (t, rc)
}

/// `RELAX-OBST` lines 1–11 as written: passes over the returns until nothing changes.
#[allow(clippy::needless_range_loop)] // kept index-based, like the pseudo-code
fn relax_literal(p: &FoliageParams, scan: Scan<'_>, hist: &History, rc: &mut [f32]) {
    let ne = scan.len();
    loop {
        let mut done = true;
        for r in 0..ne {
            let (range, w) = (scan.ranges[r], scan.windows[r] as usize);
            if rc[r] != 0.0 || range <= 0.0 {
                continue;
            }
            let t = (1.0 + p.k2 * (hist.c_prev1[w] + hist.c_prev2[w]))
                * (p.range_error_a * range + p.range_error_b_m);
            let near = (-2isize..=2).any(|j| {
                let n = (r as isize + j).rem_euclid(ne as isize) as usize;
                rc[n] > 0.0 && (range - scan.ranges[n]).abs() < t
            });
            if near {
                rc[r] = range;
                done = false;
            }
        }
        if done {
            break;
        }
    }
}

#[test]
fn get_and_relax_match_the_papers_loops() {
    let p = FoliageParams::default();
    let n_w = p.n_windows();
    let scenes = [
        Scene {
            segments: vec![((2.0, -1.0), (2.0, 1.0)), ((-1.5, 0.5), (0.5, 1.5))],
            discs: vec![(-1.0, -1.0, 0.15)],
            grass: Some((0.5, 4.0, 2.0)),
            ..Scene::open()
        },
        grass_field(),
        Scene {
            segments: vec![((1.0, -3.0), (1.0, 3.0))],
            ..Scene::open()
        },
    ];
    let mut rng = Rng::new(99);
    let (mut found, mut relaxed) = (0, 0);
    for trial in 0..30 {
        let (a, r) = scenes[trial % scenes.len()].scan(&mut rng);
        let (rr, ww, ss) = prepared(&a, &r, &p);
        let scan = Scan {
            ranges: &rr,
            windows: &ww,
            sectors: &ss,
        };
        let mut low = LowFreq::default();
        find_low_freq(scan, n_w, &mut low);
        let mut hist = History::new(n_w);
        for i in 0..n_w {
            hist.t_prev1[i] = rng.uniform(0.0, 0.12);
            hist.t_prev2[i] = rng.uniform(0.0, 0.12);
            hist.c_prev1[i] = if rng.unit() < 0.3 {
                rng.uniform(1.0, 40.0).round()
            } else {
                0.0
            };
            hist.c_prev2[i] = if rng.unit() < 0.3 {
                rng.uniform(1.0, 40.0).round()
            } else {
                0.0
            };
        }
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        found += get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
        let (t_lit, rc_lit) = get_candidates_literal(&p, scan, &low, &hist);
        assert_eq!(rc, rc_lit, "trial {trial}: candidates");
        for (i, (x, y)) in tk.iter().zip(&t_lit).enumerate() {
            assert!((x - y).abs() < 1e-5, "trial {trial}: T_k({i}) {x} vs {y}");
        }
        let mut rc_relax = rc.clone();
        relaxed += relax_obst(&p, scan, &hist, &mut rc_relax, &mut RelaxWork::default());
        let mut rc_relax_lit = rc;
        relax_literal(&p, scan, &hist, &mut rc_relax_lit);
        assert_eq!(rc_relax, rc_relax_lit, "trial {trial}: relaxed candidates");
    }
    assert!(
        found > 1000 && relaxed > 1000,
        "a meaningful comparison: {found} / {relaxed}"
    );
}

#[test]
fn relax_matches_the_papers_loop_on_random_small_scans() {
    // Few range levels, so that joins, zigzags (r+2 then r-1) and joins across the slice ends are
    // all common; sizes on both sides of the sweep path's 8-return threshold.
    let p = FoliageParams::default();
    let mut rng = Rng::new(2024);
    let mut joined = 0;
    for trial in 0..2000 {
        let ne = 1 + (rng.next_u64() % 40) as usize;
        let levels = [0.0f32, 1.0, 1.04, 1.08, 1.5, 1.55, 3.0];
        let ranges: Vec<f32> = (0..ne)
            .map(|_| levels[(rng.next_u64() % 7) as usize])
            .collect();
        let windows: Vec<u32> = (0..ne).map(|r| (r / 3) as u32).collect();
        let sectors = vec![0u32; ne];
        let scan = Scan {
            ranges: &ranges,
            windows: &windows,
            sectors: &sectors,
        };
        let mut hist = History::new(16);
        for c in hist.c_prev1.iter_mut() {
            *c = if rng.unit() < 0.3 { 25.0 } else { 0.0 };
        }
        let rc0: Vec<f32> = ranges
            .iter()
            .map(|&x| if rng.unit() < 0.15 { x } else { 0.0 })
            .collect();
        let mut fast = rc0.clone();
        joined += relax_obst(&p, scan, &hist, &mut fast, &mut RelaxWork::default());
        let mut literal = rc0;
        relax_literal(&p, scan, &hist, &mut literal);
        assert_eq!(fast, literal, "trial {trial}: ranges {ranges:?}");
    }
    assert!(joined > 2000, "{joined}");
}

#[test]
fn get_candidates_matches_the_papers_loop_on_random_small_scans() {
    // Few windows (down to 1, so neighbourhoods fold onto themselves), quantised ranges (ties at
    // the window maximum), random thresholds carried from "previous scans".
    let p = FoliageParams::default();
    let mut rng = Rng::new(77);
    let mut found = 0;
    for trial in 0..2000 {
        let n_w = 1 + (rng.next_u64() % 20) as usize;
        let ne = (rng.next_u64() % 60) as usize;
        let ranges: Vec<f32> = (0..ne)
            .map(|_| {
                if rng.unit() < 0.1 {
                    0.0
                } else {
                    2.0 + 0.02 * (rng.next_u64() % 4) as f32
                }
            })
            .collect();
        let windows: Vec<u32> = (0..ne)
            .map(|_| (rng.next_u64() % n_w as u64) as u32)
            .collect();
        let sectors = vec![0u32; ne];
        let scan = Scan {
            ranges: &ranges,
            windows: &windows,
            sectors: &sectors,
        };
        let mut low = LowFreq::default();
        find_low_freq(scan, n_w, &mut low);
        let mut hist = History::new(n_w);
        for i in 0..n_w {
            hist.t_prev1[i] = rng.uniform(0.0, 0.1);
            hist.t_prev2[i] = rng.uniform(0.0, 0.1);
        }
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        found += get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
        let (t_lit, rc_lit) = get_candidates_literal(&p, scan, &low, &hist);
        assert_eq!(rc, rc_lit, "trial {trial}");
        for (x, y) in tk.iter().zip(&t_lit) {
            assert!((x - y).abs() < 1e-5, "trial {trial}: {x} vs {y}");
        }
    }
    assert!(found > 2000, "{found}");
}
