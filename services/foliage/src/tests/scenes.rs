//! Integrated: trunks and walls in simulated grass, pure grass fields, a thin trunk in the clear;
//! and the parameter exploration that chose the defaults.

use super::*;

#[test]
fn trunk_in_grass_alarms_by_second_scan() {
    // With 4-beam windows (see classifier_wide_windows): the default 2-beam windows confirm a
    // trunk a third hidden less reliably (the price of seeing thin trunks out to d_max, below).
    // A 0.3 m trunk 1.5 m ahead-left, inside a grass field (0.5–4 m, 2 m mean free path: a third of
    // the beams toward the trunk stop in the grass in front of it).
    let trunk = (1.5f32 * 0.3f32.cos(), 1.5 * 0.3f32.sin(), 0.15);
    let scene = Scene {
        discs: vec![trunk],
        grass: Some((0.5, 4.0, 2.0)),
        ..Scene::open()
    };
    let trunk_sector = angle_bin(0.3, FoliageParams::default().sector_rad, 36).map(|s| s as usize);
    for seed in 1..=20u64 {
        let mut rng = Rng::new(seed);
        let mut c = classifier_wide_windows();
        let (a, r) = scene.scan(&mut rng);
        let first = c.classify(&a, &r).alarm;
        let (a, r) = scene.scan(&mut rng);
        let v = c.classify(&a, &r);
        assert!(
            v.alarm,
            "seed {seed}: trunk not confirmed on scan 2 (first alarm {first})"
        );
        let s = trunk_sector.unwrap_or(0);
        let nearest = v.nearest_per_sector[s];
        // The trunk's face is at 1.35 m; RELAX-OBST may also take in a grass return a few cm in
        // front of it (within C·(a·R + b) ≈ 0.1 m once the trunk has evidence).
        assert!(
            (1.2..1.45).contains(&nearest),
            "seed {seed}: R_s toward the trunk = {nearest}"
        );
        // The obstacle returns are on the trunk, not in the grass.
        for (i, &k) in v.classes.iter().enumerate() {
            if k == class::OBSTACLE {
                let on_trunk = ray_disc(a[i], trunk.0, trunk.1, 0.2).is_some();
                assert!(
                    on_trunk,
                    "seed {seed}: obstacle at angle {} range {}",
                    a[i], r[i]
                );
            }
        }
        // And it keeps alarming while in view.
        let mut alarms = 0;
        for _ in 0..20 {
            let (a, r) = scene.scan(&mut rng);
            alarms += usize::from(c.classify(&a, &r).alarm);
        }
        assert!(
            alarms >= 19,
            "seed {seed}: trunk alarmed on {alarms}/20 later scans"
        );
    }
}

#[test]
fn wall_behind_grass_alarms() {
    // With 4-beam windows, as above.
    // A wall 2.5 m ahead seen through 2 m of grass (2 m mean free path: 37 % of the beams reach it).
    let scene = Scene {
        segments: vec![((2.5, -1.5), (2.5, 1.5))],
        grass: Some((0.5, 10.0, 2.0)),
        ..Scene::open()
    };
    let mut rng = Rng::new(5);
    let mut c = classifier_wide_windows();
    let mut alarms = 0;
    for _ in 0..10 {
        let (a, r) = scene.scan(&mut rng);
        alarms += usize::from(c.classify(&a, &r).alarm);
    }
    assert!(alarms >= 9, "{alarms}/10");
}

#[test]
fn pure_grass_field_rarely_alarms() {
    for (seed, scene) in [
        (1u64, grass_field()),
        (
            2,
            Scene {
                grass: Some((0.4, 6.0, 0.6)),
                ..Scene::open()
            },
        ),
        (
            3,
            Scene {
                grass: Some((0.5, 3.0, 1.5)),
                ..Scene::open()
            },
        ),
    ] {
        let mut rng = Rng::new(seed);
        let mut c = classifier();
        let mut alarms = 0;
        let mut candidates = 0;
        for _ in 0..200 {
            let (a, r) = scene.scan(&mut rng);
            let v = c.classify(&a, &r);
            alarms += usize::from(v.alarm);
            candidates += v.candidate_count;
        }
        assert!(
            alarms <= 1,
            "seed {seed}: {alarms} false alarms in 200 scans ({candidates} candidates)"
        );
    }
    // The hard case for a max filter: a dense band whose far edge is sharp (1.5 m ± 30–50 %).
    for (seed, jitter) in [(4u64, 0.3f32), (5, 0.5)] {
        let mut rng = Rng::new(seed);
        let mut c = classifier();
        let alarms = (0..200)
            .filter(|_| {
                let (a, r) = grass_band_scan(&mut rng, jitter);
                c.classify(&a, &r).alarm
            })
            .count();
        assert!(
            alarms <= 1,
            "band ±{jitter}: {alarms} false alarms in 200 scans"
        );
    }
}

#[test]
fn thin_trunk_in_the_clear_alarms_out_to_d_max() {
    // A 0.2 m trunk 2.8 m away (4.1°) in front of a grass field from 3.5 m on. GET-OBST-CANDIDATES
    // needs 7 consecutive smooth windows (nad2v(i-2 … i+2) reads v(i-2 … i+4)): 2.8° with the
    // default 0.4° windows, which fit on the trunk; 5.6° with 0.8° windows, which do not (the
    // simulated evaluation, `mimnav foliage-eval`, missed such trunks beyond about 1.8 m with them).
    let (d, bearing) = (2.9f32, -0.4f32);
    let scene = Scene {
        discs: vec![(d * bearing.cos(), d * bearing.sin(), 0.1)],
        grass: Some((3.5, 8.0, 1.0)),
        ..Scene::open()
    };
    for seed in 1..=10u64 {
        let mut rng = Rng::new(seed);
        let mut c = classifier();
        let mut alarms = 0;
        for _ in 0..10 {
            let (a, r) = scene.scan(&mut rng);
            alarms += usize::from(c.classify(&a, &r).alarm);
        }
        // the first scan cannot alarm (REMOVE-NEW-OBST); every later one does
        assert_eq!(alarms, 9, "seed {seed}: {alarms}/10 scans alarmed");
    }
}

/// Parameter exploration used to choose the defaults (not a test):
/// `BEAMS=3,4,5 K1S=0.02,0.025 INITS=0,2 THINS=9/3,9/4 BS=0.03 \
///  cargo test --release tune_grid -- --ignored --nocapture`
/// (beams per window, K1, initial thresholds in units of K1, W_s/O_s, b). Per setting it prints,
/// for the simulated scenes: trunk in grass (alarm on scan 2 out of 20 runs, alarms on later
/// scans), a trunk at 2.5 m, a wall behind grass, false alarms in 5 grass fields (400 scans each),
/// clear walls at 0.5/1/2/3 m, grass-band candidates and alarms, noisy (σ = 2 cm) walls, 10 cm posts.
#[test]
#[ignore]
fn tune_grid() {
    fn list<T: std::str::FromStr>(var: &str, default: &str) -> Vec<T> {
        std::env::var(var)
            .unwrap_or(default.to_string())
            .split(',')
            .filter_map(|x| x.parse().ok())
            .collect()
    }
    let trunk = (1.5f32 * 0.3f32.cos(), 1.5 * 0.3f32.sin(), 0.15);
    let trunk1 = Scene {
        discs: vec![trunk],
        grass: Some((0.5, 4.0, 1.0)),
        ..Scene::open()
    };
    let trunk2 = Scene {
        discs: vec![trunk],
        grass: Some((0.5, 4.0, 2.0)),
        ..Scene::open()
    };
    let far_trunk = Scene {
        discs: vec![(2.5, 0.0, 0.15)],
        grass: Some((0.5, 4.0, 2.0)),
        ..Scene::open()
    };
    let wall_scene = Scene {
        segments: vec![((2.5, -1.5), (2.5, 1.5))],
        grass: Some((0.5, 10.0, 2.0)),
        ..Scene::open()
    };
    let grasses = [
        grass_field(),
        Scene {
            grass: Some((0.4, 6.0, 0.6)),
            ..Scene::open()
        },
        Scene {
            grass: Some((0.5, 3.0, 1.5)),
            ..Scene::open()
        },
        Scene {
            grass: Some((0.3, 8.0, 2.5)),
            ..Scene::open()
        },
        Scene {
            grass: Some((0.3, 2.5, 0.3)),
            ..Scene::open()
        },
    ];
    let beams: Vec<usize> = list("BEAMS", "4,5,6");
    let k1s: Vec<f32> = list("K1S", "0.025,0.04");
    let inits: Vec<f32> = list("INITS", "0,2");
    let thins: Vec<String> = list("THINS", "9/3,7/2");
    let bs: Vec<f32> = list("BS", "0.03");
    for &nb in &beams {
        for &k1 in &k1s {
            for &init in &inits {
                for th in &thins {
                    for &b in &bs {
                        let mut it = th.split('/').filter_map(|x| x.parse::<usize>().ok());
                        let (ws, os) = (it.next().unwrap_or(9), it.next().unwrap_or(3));
                        let p = FoliageParams {
                            window_rad: nb as f32 * 0.2f32.to_radians(),
                            k1,
                            thin_window: ws,
                            thin_min: os,
                            range_error_b_m: b,
                            ..Default::default()
                        };
                        let Ok(_) = Classifier::new(p) else { continue };
                        let fresh = || {
                            let mut c = Classifier::new(p).unwrap_or_else(|e| panic!("{e}"));
                            c.history.t_prev1.fill(init * k1);
                            c.history.t_prev2.fill(init * k1);
                            c
                        };
                        let run =
                            |scene: &Scene, seeds: u64, scans: usize| -> (usize, usize, usize) {
                                let (mut second, mut later, mut total) = (0, 0, 0);
                                for seed in 1..=seeds {
                                    let mut rng = Rng::new(seed * 7919);
                                    let mut c = fresh();
                                    for k in 0..scans {
                                        let (a, r) = scene.scan(&mut rng);
                                        let al = c.classify(&a, &r).alarm;
                                        if k == 1 {
                                            second += usize::from(al);
                                        }
                                        if k >= 2 {
                                            later += usize::from(al);
                                            total += 1;
                                        }
                                    }
                                }
                                (second, later, total)
                            };
                        let t1 = run(&trunk1, 20, 12);
                        let t2 = run(&trunk2, 20, 12);
                        let ft = run(&far_trunk, 20, 12);
                        let w = run(&wall_scene, 10, 12);
                        let fa: Vec<usize> = grasses.iter().map(|g| run(g, 1, 402).1).collect();
                        let clear: Vec<usize> = [0.5f32, 1.0, 2.0, 3.0]
                            .iter()
                            .map(|&d| {
                                run(
                                    &Scene {
                                        segments: vec![((d, -d), (d, d))],
                                        ..Scene::open()
                                    },
                                    5,
                                    2,
                                )
                                .0
                            })
                            .collect();
                        let noisy: Vec<usize> = [0.5f32, 1.0, 2.0, 3.0]
                            .iter()
                            .map(|&d| {
                                run(
                                    &Scene {
                                        segments: vec![((d, -d), (d, d))],
                                        sigma: 0.02,
                                        ..Scene::open()
                                    },
                                    5,
                                    2,
                                )
                                .0
                            })
                            .collect();
                        let post: Vec<usize> = [0.7f32, 1.0, 1.5]
                            .iter()
                            .map(|&d| {
                                run(
                                    &Scene {
                                        discs: vec![(d, 0.0, 0.05)],
                                        ..Scene::open()
                                    },
                                    5,
                                    4,
                                )
                                .1
                            })
                            .collect();
                        let mut band_alarms = 0;
                        for seed in 0..3u64 {
                            let mut rng = Rng::new(seed + 100);
                            let j = [0.3f32, 0.4, 0.5][seed as usize % 3];
                            let mut c = fresh();
                            for _ in 0..200 {
                                let phase = rng.unit();
                                let angles: Vec<f32> = (0..NE)
                                    .map(|r| wrap_angle(PI - (r as f32 + phase) * THETA))
                                    .collect();
                                let ranges: Vec<f32> =
                                    (0..NE).map(|_| 1.5 * (1.0 + rng.uniform(-j, j))).collect();
                                band_alarms += usize::from(c.classify(&angles, &ranges).alarm);
                            }
                        }
                        let mut band = 0;
                        let mut band_steady = 0;
                        for seed in 0..20u64 {
                            let mut rng = Rng::new(seed);
                            let j = [0.3f32, 0.4, 0.5][seed as usize % 3];
                            let angles: Vec<f32> =
                                (0..NE).map(|r| wrap_angle(PI - r as f32 * THETA)).collect();
                            let mut c = fresh();
                            for k in 0..10 {
                                let ranges: Vec<f32> =
                                    (0..NE).map(|_| 1.5 * (1.0 + rng.uniform(-j, j))).collect();
                                let n = c.classify(&angles, &ranges).candidate_count.min(1);
                                if k == 0 { band += n } else { band_steady += n }
                            }
                        }
                        eprintln!(
                            "beams {nb} k1 {k1:.3} init {init} thin {ws}/{os} b {b}: trunk(mfp1) {}/20 {}/{} | trunk(mfp2) {}/20 {}/{} | far {}/20 {}/{} | wall {}/10 {}/{} | FA {:?}/400 | clear {:?}/5 | band {}/20 {}/180 | band alarms {}/600 | noisy {:?}/5 | post(10cm) {:?}/10",
                            t1.0,
                            t1.1,
                            t1.2,
                            t2.0,
                            t2.1,
                            t2.2,
                            ft.0,
                            ft.1,
                            ft.2,
                            w.0,
                            w.1,
                            w.2,
                            fa,
                            clear,
                            band,
                            band_steady,
                            band_alarms,
                            noisy,
                            post
                        );
                    }
                }
            }
        }
    }
}
