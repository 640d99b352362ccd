//! `FIND-LOW-FREQ`: the window maxima and their differences, exactly.

use super::*;

#[test]
fn find_low_freq_exact_values() {
    // 8 windows of 45 deg; a few returns per window, including non-maxima and non-returns.
    let p = FoliageParams {
        window_rad: PI / 4.0,
        ..Default::default()
    };
    assert_eq!(p.n_windows(), 8);
    let centre = |i: usize, off: f32| -PI + (i as f32 + 0.5 + off) * PI / 4.0;
    let mut angles = vec![];
    let mut ranges = vec![];
    let mut put = |i: usize, off: f32, r: f32| {
        angles.push(centre(i, off));
        ranges.push(r);
    };
    put(0, 0.0, 2.0);
    put(0, 0.2, 1.0);
    put(1, -0.2, 1.5);
    put(1, 0.2, 2.0);
    put(2, 0.0, 2.5);
    put(2, 0.1, f32::NAN);
    put(3, 0.0, 3.0);
    put(3, 0.3, -3.5);
    put(4, 0.0, 0.0);
    put(4, 0.1, f32::INFINITY);
    put(5, 0.0, 1.0);
    put(6, 0.0, 1.0);
    put(6, 0.1, 0.25);
    put(7, 0.0, 1.5);
    let (r, w, s) = prepared(&angles, &ranges, &p);
    let mut low = LowFreq::default();
    find_low_freq(
        Scan {
            ranges: &r,
            windows: &w,
            sectors: &s,
        },
        8,
        &mut low,
    );

    assert_eq!(low.v, vec![2.0, 2.0, 2.5, 3.0, 0.0, 1.0, 1.0, 1.5]);
    // dv(i) = v(i+1) - v(i), wrapped: dv(7) = v(0) - v(7).
    assert_eq!(low.dv, vec![0.0, 0.5, 0.5, -3.0, 1.0, 0.0, 0.5, 0.5]);
    // nad2v(i) = |dv(i+1) - dv(i)| / v(i), 0 where v(i) = 0.
    let expect = [
        0.5f32 / 2.0,
        0.0 / 2.0,
        3.5 / 2.5,
        4.0 / 3.0,
        0.0,
        0.5 / 1.0,
        0.0 / 1.0,
        0.5 / 1.5,
    ];
    assert_eq!(low.nad2v, expect.to_vec());
}
