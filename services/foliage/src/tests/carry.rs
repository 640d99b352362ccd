//! Carried scans (interpretation 17): the sensor's motion, nothing carried standing still, trunks
//! hidden in grass found sooner while driving, grass strips driven through.

use super::*;

#[test]
fn fast_atan2_is_within_its_bound_of_atan2() {
    let mut worst = 0.0f64;
    for k in 0..20_000 {
        let a = -PI + TAU * (k as f32 + 0.37) / 20_000.0;
        for r in [1.0e-3f32, 0.3, 2.0, 150.0] {
            let (y, x) = (r * a.sin(), r * a.cos());
            let exact = f64::from(y).atan2(f64::from(x));
            worst = worst.max((f64::from(fast_atan2(y, x)) - exact).abs());
        }
    }
    assert!(worst < 1.2e-5, "worst error {worst:e} rad");
    // the axes, the origin and NaN
    assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    assert!((fast_atan2(1.0, 0.0) - PI / 2.0).abs() < 1e-6);
    assert!((fast_atan2(-1.0, 0.0) + PI / 2.0).abs() < 1e-6);
    assert!((fast_atan2(0.0, -1.0) - PI).abs() < 1e-6);
    assert!(fast_atan2(f32::NAN, 1.0).is_nan());
    assert!(fast_atan2(1.0, f32::NAN).is_nan());
}

#[test]
fn motion_between_two_poses_is_in_the_first_pose_frame() {
    // facing +y, then 0.5 m further along +y and turned 10° left: 0.5 m forward
    let from = pose2(1.0, 2.0, std::f64::consts::FRAC_PI_2);
    let to = pose2(1.0, 2.5, std::f64::consts::FRAC_PI_2 + 10f64.to_radians());
    let m = Motion::between(&from, &to);
    assert!((m.dx_m - 0.5).abs() < 1e-6 && m.dy_m.abs() < 1e-6, "{m:?}");
    assert!((m.dtheta_rad - 10f32.to_radians()).abs() < 1e-6, "{m:?}");
    // a step to the robot's left, and a turn across ±π that is 2° and not 358°
    let m = Motion::between(&pose2(0.0, 0.0, 0.0), &pose2(0.0, 0.1, 0.0));
    assert!(m.dx_m.abs() < 1e-6 && (m.dy_m - 0.1).abs() < 1e-6, "{m:?}");
    let m = Motion::between(
        &pose2(0.0, 0.0, 179f64.to_radians()),
        &pose2(0.0, 0.0, -179f64.to_radians()),
    );
    assert!((m.dtheta_rad - 2f32.to_radians()).abs() < 1e-5, "{m:?}");
    assert!(m.is_plausible());
    // jumps and non-finite values are not motion
    let origin = pose2(0.0, 0.0, 0.0);
    assert!(!Motion::between(&origin, &pose2(3.0, 0.0, 0.0)).is_plausible());
    assert!(!Motion::between(&origin, &pose2(0.0, 0.0, 1.0)).is_plausible());
    assert!(!Motion::between(&origin, &pose2(f64::NAN, 0.0, 0.0)).is_plausible());
}

/// Classes and alarms of a classifier fed `scans` with the motion `motion_of(k)` before scan `k`.
fn run_moved(
    params: FoliageParams,
    scans: &[(Vec<f32>, Vec<f32>)],
    motion_of: impl Fn(usize) -> Option<Motion>,
) -> Vec<(bool, Vec<u8>)> {
    let mut c = classifier_with(params);
    scans
        .iter()
        .enumerate()
        .map(|(k, (a, r))| {
            let v = c.classify_moved(a, r, motion_of(k));
            (v.alarm, v.classes.to_vec())
        })
        .collect()
}

#[test]
fn nothing_is_carried_standing_still_or_without_a_plausible_motion() {
    // The synthetic sharp-edged band, where carrying earlier scans standing still would line the
    // maxima up along its edge: standing, below carry_min_travel_m, with no motion, or with a
    // jump or NaN, the verdicts are exactly the paper's pipeline (carry_scans = 0).
    let mut rng = Rng::new(21);
    let scans: Vec<_> = (0..60).map(|_| grass_band_scan(&mut rng, 0.3)).collect();
    let paper = run_moved(
        FoliageParams {
            carry_scans: 0,
            ..FoliageParams::default()
        },
        &scans,
        |_| None,
    );
    let p = FoliageParams::default();
    assert!(p.carry_scans > 0);
    let creep = Motion {
        dx_m: p.carry_min_travel_m / (p.carry_scans as f32 + 1.0),
        ..Motion::default()
    };
    type MotionOf = Box<dyn Fn(usize) -> Option<Motion>>;
    let cases: [(&str, MotionOf); 5] = [
        ("standing", Box::new(|_| Some(Motion::default()))),
        ("creeping", Box::new(move |_| Some(creep))),
        ("no odometry", Box::new(|_| None)),
        (
            "jumping",
            Box::new(|_| {
                Some(Motion {
                    dx_m: 5.0,
                    ..Motion::default()
                })
            }),
        ),
        (
            "NaN",
            Box::new(|_| {
                Some(Motion {
                    dtheta_rad: f32::NAN,
                    ..Motion::default()
                })
            }),
        ),
    ];
    for (name, motion_of) in cases {
        assert!(
            run_moved(p, &scans, motion_of) == paper,
            "{name}: the verdicts differ from the paper's"
        );
    }
    // and driving, they do differ (the test above could not fail otherwise)
    let driving = run_moved(p, &scans, |_| {
        Some(Motion {
            dx_m: 0.05,
            ..Motion::default()
        })
    });
    assert!(driving != paper, "driving carried nothing");
}

/// Scans alarmed, and the first alarm, driving at `step` m a scan from x = −1 m toward a 0.2 m
/// trunk at x = 3.2 m inside a grass strip from 0.5 to 4 m (mean free path `mfp`): 50 scans, the
/// trunk within `d_max` from the 23rd, 1.75 m away at the end.
fn trunk_in_grass_drive(
    params: FoliageParams,
    seed: u64,
    step: f32,
    mfp: f32,
) -> (usize, Option<usize>) {
    let mut rng = Rng::new(seed);
    let mut c = classifier_with(params);
    let (mut alarms, mut first) = (0, None);
    for k in 0..50 {
        let x = -1.0 + step * k as f32;
        let (a, r) = strip_scan(&mut rng, x, (0.5, 4.0), Some(mfp), Some((3.2, 0.0, 0.1)));
        let m = Motion {
            dx_m: step,
            ..Motion::default()
        };
        if c.classify_moved(&a, &r, (k > 0).then_some(m)).alarm {
            alarms += 1;
            first.get_or_insert(k);
        }
    }
    (alarms, first)
}

#[test]
fn carried_scans_find_a_trunk_hidden_in_grass_sooner_while_driving() {
    let paper = FoliageParams {
        carry_scans: 0,
        ..FoliageParams::default()
    };
    let (mut with, mut without, mut earlier, mut later) = (0, 0, 0, 0);
    for seed in 1..=10 {
        let (a0, f0) = trunk_in_grass_drive(paper, seed, 0.05, 1.5);
        let (a2, f2) = trunk_in_grass_drive(FoliageParams::default(), seed, 0.05, 1.5);
        without += a0;
        with += a2;
        match (f0, f2) {
            (Some(x), Some(y)) if y < x => earlier += 1,
            (None, Some(_)) => earlier += 1,
            (Some(x), Some(y)) if y > x => later += 1,
            (Some(_), None) => later += 1,
            _ => {}
        }
    }
    eprintln!(
        "scans alarmed: {without} without carried scans, {with} with; first alarm earlier in {earlier}, later in {later} of 10 drives"
    );
    // (measured: 3 scans alarmed without, 103 with; the first alarm earlier in all 10 drives)
    assert!(
        with >= 5 * without.max(10),
        "alarmed scans: {with} with, {without} without"
    );
    assert!(
        earlier >= 5 && later == 0,
        "first alarm earlier in {earlier}, later in {later}"
    );
}

/// Alarms in 200 scans driving at `step` m a scan over a static grass strip ([`strip_scan`]),
/// from x = −2 m to 0.5 m and again from −2 m with the classifier reset.
fn strip_drive_alarms(
    params: FoliageParams,
    seed: u64,
    step: f32,
    strip: (f32, f32),
    mfp: Option<f32>,
) -> usize {
    let mut rng = Rng::new(seed);
    let mut c = classifier_with(params);
    let mut x = -2.0f32;
    let mut alarms = 0;
    for _ in 0..200 {
        let (a, r) = strip_scan(&mut rng, x, strip, mfp, None);
        let m = Motion {
            dx_m: step,
            ..Motion::default()
        };
        alarms += usize::from(c.classify_moved(&a, &r, Some(m)).alarm);
        x += step;
        if x > 0.5 {
            x = -2.0;
            c.reset();
        }
    }
    alarms
}

#[test]
fn carried_scans_driving_through_grass_rarely_alarm() {
    // Static grass strips whose blades stop each beam an exponential distance in (Beer–Lambert,
    // as in the simulator): driving inside one toward its far edge, and toward one from outside.
    for (name, strip, mfp) in [
        ("inside, dense", (-4.0f32, 2.0f32), 0.6f32),
        ("inside, sparse", (-4.0, 2.0), 1.5),
        ("toward, dense", (1.0, 3.0), 0.6),
        ("toward, sparse", (1.0, 3.0), 1.5),
    ] {
        for step in [0.03f32, 0.05, 0.1] {
            let alarms = strip_drive_alarms(FoliageParams::default(), 11, step, strip, Some(mfp));
            assert!(
                alarms <= 1,
                "{name} at {step} m a scan: {alarms} false alarms in 200 scans"
            );
        }
    }
}

/// The price of interpretation 17, measured (run it with `cargo test -p mimnav-foliage --release
/// -- --ignored carried_scans_price --nocapture`): the false alarms in 200 scans of two hard cases
/// that neither simulated nor Beer–Lambert grass produces, with 0 and 2 carried scans: standing in
/// the synthetic sharp-edged band with the standing-still rule off (`carry_min_travel_m = 0`), and
/// driving toward a strip from 1 to 2 m that stops every beam uniformly before its far edge.
#[test]
#[ignore = "a measurement: prints the figures in docs/commands.md"]
fn carried_scans_price() {
    for carry in [0usize, 2] {
        let params = FoliageParams {
            carry_scans: carry,
            carry_min_travel_m: 0.0,
            ..FoliageParams::default()
        };
        let mut band = Vec::new();
        for (seed, jitter) in [(4u64, 0.3f32), (5, 0.5)] {
            let mut rng = Rng::new(seed);
            let mut c = classifier_with(params);
            let alarms = (0..200)
                .filter(|_| {
                    let (a, r) = grass_band_scan(&mut rng, jitter);
                    c.classify_moved(&a, &r, Some(Motion::default())).alarm
                })
                .count();
            band.push(format!("±{jitter}: {alarms}"));
        }
        let params = FoliageParams {
            carry_scans: carry,
            ..FoliageParams::default()
        };
        let mut strip = Vec::new();
        for step in [0.03f32, 0.05, 0.1] {
            let mut counts = Vec::new();
            for seed in 11..16 {
                counts.push(strip_drive_alarms(params, seed, step, (1.0, 2.0), None));
            }
            strip.push(format!("{step} m a scan: {counts:?}"));
        }
        println!(
            "carry_scans = {carry}: standing in the band (alarms in 200 scans) {}; driving toward the sharp strip (5 seeds × 200 scans) {}",
            band.join(", "),
            strip.join("; ")
        );
    }
}
