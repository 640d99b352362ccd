//! The [`Classifier`](crate::Classifier): robustness to bad input, no reallocation, and `classify`
//! against the public routines run in order.

use super::*;

#[test]
fn robust_to_empty_mismatched_nan_and_zero_scans() {
    let mut c = classifier();
    let v = c.classify(&[], &[]);
    assert!(!v.alarm);
    assert!(v.classes.is_empty());
    assert_eq!(v.nearest_per_sector.len(), 36);

    let v = c.classify(&[0.0, 0.1, 0.2], &[1.0]);
    assert_eq!(v.classes.len(), 1, "min of the two lengths");
    let v = c.classify(&[0.0], &[1.0, 2.0, 3.0]);
    assert_eq!(v.classes.len(), 1);

    let angles: Vec<f32> = (0..NE).map(|r| wrap_angle(PI - r as f32 * THETA)).collect();
    for _ in 0..3 {
        let v = c.classify(&angles, &vec![0.0; NE]);
        assert!(!v.alarm);
        assert!(v.classes.iter().all(|&k| k == class::NO_RETURN));
        assert!(v.nearest_per_sector.iter().all(|x| x.is_infinite()));
    }
    let weird = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        -1.0,
        0.0,
        f32::MAX,
        f32::MIN_POSITIVE,
    ];
    for _ in 0..3 {
        let ranges: Vec<f32> = (0..NE).map(|i| weird[i % weird.len()]).collect();
        let v = c.classify(&angles, &ranges);
        assert!(
            v.classes
                .iter()
                .enumerate()
                .all(|(i, &k)| (k == class::NO_RETURN) == (i % 7 < 5))
        );
        let ranges = vec![f32::NAN; NE];
        let v = c.classify(&angles, &ranges);
        assert!(!v.alarm);
        let bad_angles: Vec<f32> = (0..NE)
            .map(|i| if i % 2 == 0 { f32::NAN } else { 1e30 })
            .collect();
        let v = c.classify(&bad_angles, &vec![2.0; NE]);
        assert!(v.classes.iter().step_by(2).all(|&k| k == class::NO_RETURN));
    }
    // A flat "scan" of identical returns at one angle, and tiny scans, must not panic either.
    for n in 0..8 {
        let _ = c.classify(&vec![0.3; n], &vec![2.0; n]);
        let _ = c.classify(&vec![0.3; n], &vec![2.0; n]);
    }
}

#[test]
fn no_reallocation_after_first_scan() {
    let mut c = classifier();
    let mut rng = Rng::new(11);
    let scene = Scene {
        discs: vec![(1.5, 0.2, 0.15)],
        ..grass_field()
    };
    let (a, r) = scene.scan(&mut rng);
    c.classify(&a, &r);
    let ptrs = |c: &Classifier| {
        [
            c.ranges.as_ptr() as usize,
            c.windows.as_ptr() as usize,
            c.rc.as_ptr() as usize,
            c.rf.as_ptr() as usize,
            c.classes.as_ptr() as usize,
            c.thin_copy.as_ptr() as usize,
            c.relax_work.stack.as_ptr() as usize,
            c.relax_work.can_join.as_ptr() as usize,
            c.work.pass.as_ptr() as usize,
        ]
    };
    let caps = |c: &Classifier| {
        [
            c.ranges.capacity(),
            c.rc.capacity(),
            c.relax_work.stack.capacity(),
        ]
    };
    let (p0, c0) = (ptrs(&c), caps(&c));
    for _ in 0..20 {
        let (a, r) = scene.scan(&mut rng);
        c.classify(&a, &r);
        c.classify(&a[..900], &r[..900]);
        assert_eq!(ptrs(&c), p0);
        assert_eq!(caps(&c), c0);
    }
}

#[test]
fn pure_routines_tolerate_mismatched_inputs() {
    let p = FoliageParams::default();
    let ranges = [1.0f32, 2.0, f32::NAN, 3.0, 1.0];
    let windows = [0u32, 7, NO_BIN, 2, 1_000];
    let sectors = [0u32, 99, NO_BIN];
    let scan = Scan {
        ranges: &ranges,
        windows: &windows,
        sectors: &sectors,
    };
    assert_eq!(scan.len(), 3);
    let mut low = LowFreq::default();
    for n in [0usize, 1, 3, 8] {
        find_low_freq(scan, n, &mut low);
        let hist = History::new(n / 2);
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
        rc.truncate(1);
        let mut q = RelaxWork::default();
        relax_obst(&p, scan, &hist, &mut rc, &mut q);
        let mut rf = vec![];
        remove_new_obst(scan, &hist, &rc, &mut rf);
        remove_thin_obst(&mut rf, 0, 0, &mut vec![]);
        crop_range(&mut rf, f32::NAN, f32::NAN);
        let mut hist = History::new(n);
        hist.c_prev2.truncate(n / 2);
        let mut ck = vec![];
        update_and_archive(&p, scan, &[1.0; 5], &[1.0; 5], &mut hist, &mut ck, &mut []);
    }
}

/// `Classifier::classify` against the paper's `CLASSIFY` written out with the public routines, one
/// after the other, on a history of its own: the classifier fuses and skips work for speed, and
/// must give the same classes, alarm, `R_s` and temporal state, scan after scan (trunks in and
/// out of grass, a wall, empty stretches, both rules beyond the paper on and off).
#[test]
fn classify_matches_the_public_routines_in_order() {
    fn reference(
        p: &FoliageParams,
        hist: &mut History,
        angles: &[f32],
        ranges: &[f32],
    ) -> (bool, Vec<u8>, Vec<f32>) {
        let (r, w, s) = prepared(angles, ranges, p);
        let scan = Scan {
            ranges: &r,
            windows: &w,
            sectors: &s,
        };
        let mut low = LowFreq::default();
        find_low_freq(scan, p.n_windows(), &mut low);
        if p.fill_notches {
            fill_notches(p, &mut low);
        }
        let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
        get_obst_candidates(p, scan, &low, hist, &mut tk, &mut rc, &mut work);
        hist.archive_thresholds(&mut tk);
        relax_obst(p, scan, hist, &mut rc, &mut RelaxWork::default());
        let mut rf = vec![];
        remove_new_obst(scan, hist, &rc, &mut rf);
        remove_thin_obst(&mut rf, p.thin_window, p.thin_min, &mut vec![]);
        crop_range(&mut rf, p.d_min_m, p.d_max_m);
        let mut nearest = vec![0.0; p.n_sectors()];
        let alarm = update_and_archive(p, scan, &rc, &rf, hist, &mut vec![], &mut nearest);
        let classes = (0..r.len())
            .map(|i| match (r[i] > 0.0, rc[i] > 0.0, rf[i] > 0.0) {
                (_, _, true) => class::OBSTACLE,
                (_, true, false) => class::PRUNED,
                (true, false, false) => class::FOLIAGE,
                (false, _, _) => class::NO_RETURN,
            })
            .collect();
        (alarm, classes, nearest)
    }
    let scenes = [
        Scene {
            discs: vec![(1.5, 0.5, 0.15), (-2.0, -1.0, 0.25)],
            ..grass_field()
        },
        Scene {
            discs: vec![(2.5, -0.5, 0.1)],
            segments: vec![((-2.0, -1.0), (-2.0, 1.0))],
            ..Scene::open()
        },
        grass_field(),
        Scene::open(),
    ];
    for (hold, fill) in [(true, true), (false, false), (true, false)] {
        let p = FoliageParams {
            hold_obstacles: hold,
            fill_notches: fill,
            ..Default::default()
        };
        let mut c = classifier_with(p);
        let mut hist = History::free_space(p.n_windows(), p.k1);
        let mut rng = Rng::new(11);
        let mut alarms = 0;
        for k in 0..80 {
            let (a, r) = scenes[(k / 10) % scenes.len()].scan(&mut rng);
            let (alarm, classes, nearest) = reference(&p, &mut hist, &a, &r);
            let v = c.classify(&a, &r);
            assert_eq!(v.alarm, alarm, "scan {k} (hold {hold}, fill {fill}): alarm");
            assert_eq!(v.classes, &classes[..], "scan {k}: classes");
            assert_eq!(v.nearest_per_sector, &nearest[..], "scan {k}: R_s");
            assert_eq!(c.history(), &hist, "scan {k}: temporal state");
            alarms += usize::from(alarm);
        }
        // the scenes exercise the alarm path, not only grass
        assert!(alarms >= 20, "only {alarms} alarms in 80 scans");
    }
}
