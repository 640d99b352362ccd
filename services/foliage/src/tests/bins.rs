//! The parameters (defaults, checks naming the key) and the binning of returns into windows and
//! sectors, across the ±π seam.

use super::*;

#[test]
fn default_params_are_valid_and_sized_for_vlp16() {
    let p = FoliageParams::default();
    assert_eq!(p.validate(), Ok(()));
    assert_eq!(p.n_windows(), 900, "0.4 deg windows");
    assert_eq!(p.n_sectors(), 36, "10 deg sectors");
}

#[test]
fn validate_names_the_key_and_range() {
    use mimnav_shared::config::{Allowed, ParamError};
    let bad = [
        FoliageParams {
            k1: -1.0,
            ..Default::default()
        },
        FoliageParams {
            k3: 0.0,
            ..Default::default()
        },
        FoliageParams {
            d_max_m: f32::NAN,
            ..Default::default()
        },
        FoliageParams {
            window_rad: 1.0,
            ..Default::default()
        },
        FoliageParams {
            thin_min: 10,
            ..Default::default()
        },
        FoliageParams {
            thin_window: 0,
            ..Default::default()
        },
    ];
    let keys = [
        "foliage.k1",
        "foliage.k3",
        "foliage.d_max_m",
        "foliage.window_deg",
        "foliage.thin_min",
        "foliage.thin_window",
    ];
    for (p, key) in bad.iter().zip(keys) {
        let err = p.validate().expect_err(key);
        assert!(
            matches!(err.get(key), Some(ParamError::OutOfRange { .. })),
            "{err:?} should name {key} and its range"
        );
        assert!(err.to_string().contains("allowed"), "{err}");
        assert!(Classifier::new(*p).is_err());
    }
    assert_eq!(
        bad[1].validate().expect_err("k3").0[0],
        ParamError::OutOfRange {
            key: "foliage.k3".into(),
            value: 0.0,
            allowed: Allowed::above(0.0, 1000.0),
        }
    );
    let err = FoliageParams {
        d_min_m: 2.0,
        d_max_m: 1.0,
        ..Default::default()
    }
    .validate()
    .expect_err("d_min above d_max");
    assert!(err.to_string().contains("foliage.d_max_m"), "{err}");
}

/// The values the config file and the classifier used to disagree on (each had its own checks)
/// are refused by both now, naming the same key: the `[foliage]` section as a file gives it
/// (through its `validate`, which the stack's loader calls), the classifier through
/// [`Classifier::new`].
#[test]
fn the_file_and_the_classifier_refuse_the_same_values() {
    let d = FoliageParams::default();
    let cases = [
        ("k3 = 0", "foliage.k3", FoliageParams { k3: 0.0, ..d }),
        ("k3 = 5000", "foliage.k3", FoliageParams { k3: 5000.0, ..d }),
        (
            "range_error_b_m = 2",
            "foliage.range_error_b_m",
            FoliageParams {
                range_error_b_m: 2.0,
                ..d
            },
        ),
        (
            "d_max_m = 500",
            "foliage.d_max_m",
            FoliageParams {
                d_max_m: 500.0,
                ..d
            },
        ),
        (
            "window_deg = 0.01",
            "foliage.window_deg",
            FoliageParams {
                window_rad: 0.01f32.to_radians(),
                ..d
            },
        ),
        (
            "sector_deg = 1",
            "foliage.sector_deg",
            FoliageParams {
                sector_rad: 1f32.to_radians(),
                ..d
            },
        ),
        (
            "thin_min = 0",
            "foliage.thin_min",
            FoliageParams { thin_min: 0, ..d },
        ),
        (
            "thin_window = 8\nthin_min = 9",
            "foliage.thin_min",
            FoliageParams {
                thin_window: 8,
                thin_min: 9,
                ..d
            },
        ),
        (
            "carry_min_travel_m = 5",
            "foliage.carry_min_travel_m",
            FoliageParams {
                carry_min_travel_m: 5.0,
                ..d
            },
        ),
    ];
    for (line, key, params) in cases {
        let section: FoliageParams = toml::from_str(line).expect(line);
        let e = section.validate().expect_err(line);
        assert!(e.get(key).is_some(), "{line}: {e}");
        let e = Classifier::new(params).expect_err(line);
        assert!(e.get(key).is_some(), "{line}: {e}");
    }
    // the bounds themselves are allowed by both
    let edge = "k3 = 1000\nd_max_m = 200\nwindow_deg = 0.05\nsector_deg = 5\nthin_min = 9\n";
    let section: FoliageParams = toml::from_str(edge).expect("bounds");
    assert_eq!(section.validate(), Ok(()));
    assert!(Classifier::new(section).is_ok());
}

#[test]
fn windows_wrap_around_pi() {
    let p = FoliageParams::default();
    let n = p.n_windows();
    assert_eq!(angle_bin(-PI, p.window_rad, n), Some(0));
    assert_eq!(
        angle_bin(PI, p.window_rad, n),
        Some(0),
        "pi and -pi are the same direction"
    );
    assert_eq!(angle_bin(PI - 1e-4, p.window_rad, n), Some(n as u32 - 1));
    assert_eq!(angle_bin(-PI + 1e-4, p.window_rad, n), Some(0));
    assert_eq!(angle_bin(0.0, p.window_rad, n), Some(n as u32 / 2));
    // Out-of-range angles wrap onto the circle.
    assert_eq!(
        angle_bin(0.1 + TAU, p.window_rad, n),
        angle_bin(0.1, p.window_rad, n)
    );
    assert_eq!(angle_bin(f32::NAN, p.window_rad, n), None);
    assert_eq!(
        bin_count(1.0f32.to_radians()),
        360,
        "no sliver window from f32 rounding"
    );
    assert_eq!(bin_count(0.7), 9);
}

#[test]
fn window_helper_is_consistent() {
    assert_eq!(window_of(-PI), 0);
    assert_eq!(window_of(0.0), 450);
    assert_eq!(window_of(PI), 0);
}

#[test]
fn candidates_and_neighbours_wrap_around_pi() {
    // A wall at 2 m straddling the ±pi seam, angles increasing (counter-clockwise order).
    let angles: Vec<f32> = (0..NE)
        .map(|r| wrap_angle(-PI + (r as f32 + 0.5) * THETA))
        .collect();
    let ranges: Vec<f32> = angles
        .iter()
        .map(|a| if a.abs() > PI - 0.3 { 2.0 } else { 0.0 })
        .collect();
    let rc = candidates_of(&angles, &ranges);
    let near_seam = |a: f32| a.abs() > PI - 0.03;
    assert!(
        angles
            .iter()
            .zip(&rc)
            .any(|(&a, &c)| near_seam(a) && c > 0.0),
        "windows next to the seam see their neighbours across it"
    );
    // RELAX-OBST wraps the slice: the last return joins a candidate at index 0.
    let mut c = classifier();
    let v = c.classify(&angles, &ranges);
    assert_eq!(
        v.classes[0],
        class::PRUNED,
        "first scan: candidate, held back"
    );
    assert_eq!(v.classes[NE - 1], class::PRUNED);
    let v = c.classify(&angles, &ranges);
    assert!(v.alarm);
    assert_eq!(v.classes[0], class::OBSTACLE);
    assert_eq!(v.classes[NE - 1], class::OBSTACLE);
    // Both ends of the seam report in their own sectors (first and last).
    assert_eq!(v.nearest_per_sector[0], 2.0);
    assert_eq!(v.nearest_per_sector[35], 2.0);
}
