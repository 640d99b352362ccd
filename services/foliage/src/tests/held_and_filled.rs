//! Beyond the paper: held obstacles (interpretation 15) and filled notches (interpretation 16),
//! on a wall that blades break into single windows.

use super::*;

/// The wall of [`wall_scan`] with a blade 1 m away in every fourth window: each blade window
/// blocks the smooth-window test of the windows within 2 of it, so no window of the wall passes
/// `GET-OBST-CANDIDATES` on its own.
fn broken_wall_scan(rng: &mut Rng) -> (Vec<f32>, Vec<f32>) {
    let (a, mut r) = wall_scan(rng);
    for (&angle, range) in a.iter().zip(r.iter_mut()) {
        if *range > 0.0 && window_of(angle).is_multiple_of(4) {
            *range = 1.0;
        }
    }
    (a, r)
}

/// Beyond the paper (interpretation 15): a confirmed obstacle stays confirmed when blades break
/// every run of smooth windows in front of it, and only the returns on it are obstacles; with
/// `hold_obstacles` off, the paper's test alone loses it.
#[test]
fn confirmed_obstacle_is_held_through_broken_windows() {
    for hold in [true, false] {
        let mut rng = Rng::new(5);
        let mut c = classifier_with(FoliageParams {
            hold_obstacles: hold,
            fill_notches: false,
            ..Default::default()
        });
        for _ in 0..3 {
            let (a, r) = wall_scan(&mut rng);
            c.classify(&a, &r);
        }
        let (a, r) = wall_scan(&mut rng);
        assert!(c.classify(&a, &r).alarm, "the wall is confirmed");
        let (a, r) = broken_wall_scan(&mut rng);
        let v = c.classify(&a, &r);
        assert_eq!(v.alarm, hold, "hold_obstacles = {hold}");
        let on_wall = v
            .classes
            .iter()
            .zip(&r)
            .filter(|&(&k, _)| k == class::OBSTACLE)
            .inspect(|&(_, &range)| assert!(range > 1.9, "a blade at {range} m is no obstacle"))
            .count();
        if hold {
            assert!(on_wall > 50, "{on_wall} obstacle returns on the wall");
        }
    }
}

/// Only confirmed obstacles are held: broken scans of a wall never confirmed raise no alarm
/// (with the notches left as they are, which would otherwise confirm it).
#[test]
fn nothing_is_held_before_it_is_confirmed() {
    let mut rng = Rng::new(6);
    let mut c = classifier_with(FoliageParams {
        fill_notches: false,
        ..Default::default()
    });
    for k in 0..10 {
        let (a, r) = broken_wall_scan(&mut rng);
        let v = c.classify(&a, &r);
        assert!(!v.alarm, "scan {k}: {} obstacle returns", v.obstacle_count);
    }
}

/// Interpretation 16: a window nearer than both neighbours takes the nearer neighbour's maximum;
/// peaks, slopes, two-window notches and the circle's seam are handled as stated.
#[test]
fn fill_notches_fills_single_window_dips_only() {
    let p = FoliageParams::default();
    // the tolerance at 3 m: 0.01 · 3 + 0.03 = 0.06 m
    let mut low = LowFreq {
        //       0    1    2    3     4     5    6    7    8    9    10   11   12   13
        v: vec![
            1.0, 3.0, 3.0, 1.0, 3.02, 3.04, 1.0, 3.0, 3.2, 3.2, 0.0, 0.0, 3.0, 3.0,
        ],
        dv: vec![0.0; 14],
        nad2v: vec![0.0; 14],
    };
    // window 3 is a notch with 3.0, 3.0 before and 3.02, 3.04 after, all agreeing: it takes 3.0;
    // window 6 is a notch whose windows after (3.0, 3.2) disagree, as at a grass band's far
    // edge: it stays; windows 10–11 are a two-window dip and stay; window 0 is a notch across
    // the seam (3.0, 3.0 before, 3.0, 3.0 after): it takes 3.0
    assert_eq!(fill_notches(&p, &mut low), 2);
    assert_eq!(
        low.v,
        vec![
            3.0, 3.0, 3.0, 3.0, 3.02, 3.04, 1.0, 3.0, 3.2, 3.2, 0.0, 0.0, 3.0, 3.0
        ]
    );
    // the differences are those of the filled maxima
    let mut expect = low.clone();
    differences(&mut expect);
    assert_eq!(low, expect);
    assert!((low.dv[3] - 0.02).abs() < 1e-6 && low.nad2v[1] == 0.0);
    // a second pass finds nothing more to fill
    assert_eq!(fill_notches(&p, &mut low), 0);
    // too few windows to have neighbours on both sides: left alone
    let mut tiny = LowFreq {
        v: vec![1.0, 2.0],
        dv: vec![0.0; 2],
        nad2v: vec![0.0; 2],
    };
    assert_eq!(fill_notches(&p, &mut tiny), 0);
}

/// Interpretation 16 in the whole classifier: a wall that only blades reach in every fourth
/// window is confirmed from scratch on its second scan with `fill_notches`, and never without;
/// the blades themselves are never obstacles.
#[test]
fn notch_filling_confirms_a_wall_behind_single_blade_windows() {
    for fill in [true, false] {
        let mut rng = Rng::new(7);
        let mut c = classifier_with(FoliageParams {
            fill_notches: fill,
            ..Default::default()
        });
        let alarms: Vec<bool> = (0..4)
            .map(|_| {
                let (a, r) = broken_wall_scan(&mut rng);
                let v = c.classify(&a, &r);
                for (&k, &range) in v.classes.iter().zip(&r) {
                    assert!(
                        k != class::OBSTACLE || range > 1.9,
                        "a blade at {range} m is no obstacle"
                    );
                }
                v.alarm
            })
            .collect();
        let expect = if fill {
            // held back on the first scan (REMOVE-NEW-OBST), confirmed from the second on
            vec![false, true, true, true]
        } else {
            vec![false; 4]
        };
        assert_eq!(alarms, expect, "fill_notches = {fill}");
    }
}

/// Blades in two neighbouring windows are not a notch: a wall broken that way is not confirmed
/// from scratch even with `fill_notches` (the paper's test, unchanged).
#[test]
fn two_window_dips_are_not_filled() {
    let mut rng = Rng::new(8);
    let mut c = classifier();
    for k in 0..6 {
        let (a, mut r) = wall_scan(&mut rng);
        for (&angle, range) in a.iter().zip(r.iter_mut()) {
            if *range > 0.0 && window_of(angle) % 4 < 2 {
                *range = 1.0;
            }
        }
        let v = c.classify(&a, &r);
        assert!(!v.alarm, "scan {k}: {} obstacle returns", v.obstacle_count);
    }
}
