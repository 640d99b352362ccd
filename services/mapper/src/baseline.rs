//! The paper's two baselines (Table I of `mim-lidar-intensity-navigation.txt`), as maps the same
//! planner can drive on: "DWA on a laser scan" and "DWA on an occupancy map". Both ignore
//! intensity: every return is an obstacle. They are what the evaluation compares the intensity
//! map against, and they fail the way the paper reports: they freeze before grass and curtains
//! (every blade is a wall) and drive into glass (beams pass through it).

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::{Point, ScanReturn, cell_class};

/// "DWA on a laser scan": the cells of a planar scan's returns are solid, every other cell free.
pub fn scan_occupancy(scan: &[ScanReturn], grid: GridSpec, out: &mut Vec<u8>) {
    out.clear();
    out.resize(grid.len(), cell_class::FREE);
    for s in scan {
        if s.range_m > 0.0 && s.range_m.is_finite() {
            let (sin, cos) = s.angle_rad.sin_cos();
            if let Some((r, c)) = grid.cell_of(s.range_m * cos, s.range_m * sin) {
                out[grid.index(r, c)] = cell_class::SOLID;
            }
        }
    }
}

/// "DWA on an occupancy map": the cells of every return between `low_m` and `high_m` above the
/// ground (the height band the robot sweeps) are solid, every other cell free. `sensor_height_m`
/// places the ground.
pub fn cloud_occupancy(
    points: &[Point],
    grid: GridSpec,
    sensor_height_m: f32,
    low_m: f32,
    high_m: f32,
    out: &mut Vec<u8>,
) {
    out.clear();
    out.resize(grid.len(), cell_class::FREE);
    for p in points {
        let h = p.z + sensor_height_m;
        if h >= low_m
            && h <= high_m
            && let Some((r, c)) = grid.cell_of(p.x, p.y)
        {
            out[grid.index(r, c)] = cell_class::SOLID;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRID: GridSpec = GridSpec {
        cells: 40,
        cell_m: 0.25,
    };

    #[test]
    fn every_scan_return_is_an_obstacle_and_no_return_is_none() {
        let scan = [
            ScanReturn {
                angle_rad: 0.0,
                range_m: 2.0,
                intensity: 3,
                ..Default::default()
            },
            ScanReturn {
                angle_rad: std::f32::consts::FRAC_PI_2,
                range_m: 0.0,
                ..Default::default()
            },
            ScanReturn {
                angle_rad: std::f32::consts::PI,
                range_m: f32::NAN,
                ..Default::default()
            },
        ];
        let mut out = Vec::new();
        scan_occupancy(&scan, GRID, &mut out);
        let (r, c) = GRID.cell_of(2.0, 0.0).expect("inside");
        assert_eq!(out[GRID.index(r, c)], cell_class::SOLID);
        assert_eq!(
            out.iter().filter(|&&c| c == cell_class::SOLID).count(),
            1,
            "a faint grass blade counts as much as a wall; no return is nothing"
        );
    }

    #[test]
    fn the_occupancy_map_keeps_returns_within_the_robot_height_band() {
        let at = |x: f32, h: f32| Point {
            x,
            y: 0.0,
            z: h - 0.5,
            ..Default::default()
        };
        let points = [at(1.0, 0.02), at(2.0, 0.3), at(3.0, 2.5)];
        let mut out = Vec::new();
        cloud_occupancy(&points, GRID, 0.5, 0.08, 1.0, &mut out);
        let class = |x: f32| {
            let (r, c) = GRID.cell_of(x, 0.0).expect("inside");
            out[GRID.index(r, c)]
        };
        assert_eq!(class(1.0), cell_class::FREE, "ground");
        assert_eq!(class(2.0), cell_class::SOLID);
        assert_eq!(class(3.0), cell_class::FREE, "above the robot");
    }
}
