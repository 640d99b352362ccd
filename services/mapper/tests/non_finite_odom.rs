//! Issue 23 item 3: odometry reaching the mapper. A non-finite message is refused (the service
//! counts it as `bad_odom` and logs it at a limited rate) and the last good one ages; finite
//! odometry of any size, however far it jumps, never panics the mapper or puts a non-finite
//! number in its header.

use mimnav_mapper::MapperParams;
use mimnav_mapper::step::MapStep;
use mimnav_shared::topics::{Odometry, Point, PointsHeader};
use proptest::prelude::*;

const S: u64 = 1_000_000_000;

/// A ring of returns 3 m around the sensor, at the sensor's height and above.
fn ring() -> Vec<Point> {
    (0..360)
        .flat_map(|a| {
            let r = (a as f32).to_radians();
            [-0.2f32, 0.5].map(|z| Point {
                x: 3.0 * r.cos(),
                y: 3.0 * r.sin(),
                z,
                distance_raw: 1500,
                azimuth_cdeg: (a * 100) as u16,
                intensity: 60,
                laser_id: 1,
                ring: 1,
                ..Point::default()
            })
        })
        .collect()
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => -50.0f64..50.0,
        1 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::MAX),
        1 => Just(-f64::MAX),
        1 => prop::num::f64::ANY,
    ]
}

#[test]
fn issue23_3_non_finite_values_accepted_odometry_never_breaks_the_mapper() {
    let points = ring();
    proptest!(ProptestConfig::with_cases(64), |(
        poses in prop::collection::vec((any_f64(), any_f64(), any_f64()), 1..4),
    )| {
        let mut step = MapStep::new(MapperParams::default(), S / 2);
        let mut good = None;
        for (i, (x, y, yaw)) in poses.into_iter().enumerate() {
            let t = (10 + i as u64) * S;
            let o = Odometry { seq: i as u64, stamp_ns: t, rx_mono_ns: t, x, y, yaw, ..Odometry::default() };
            let finite = x.is_finite() && y.is_finite() && yaw.is_finite();
            prop_assert_eq!(step.odom(&o).is_ok(), finite, "{:?}", o);
            if finite {
                good = Some((x, y, yaw));
            }
            let h = PointsHeader { seq: i as u64, stamp_ns: t, rx_mono_ns: t, ..PointsHeader::default() };
            let m = step.revolution(&h, &points, t).expect("mapped");
            prop_assert!(m.header.x.is_finite() && m.header.y.is_finite() && m.header.yaw.is_finite());
            if let Some(g) = good {
                // the header carries the last good odometry, never a refused one
                prop_assert_eq!((m.header.x, m.header.y, m.header.yaw), g);
            }
            let grid = MapperParams::default().grid;
            prop_assert_eq!(step.mapper().classes().len(), grid.len());
        }
    });
}
