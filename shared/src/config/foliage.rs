//! `[foliage]`: the foliage classifier.

use serde::Deserialize;

use super::check::{Checks, Invalid};

/// The foliage classifier (`[foliage]`): the parameters of
/// `foliage-discrimination-rotating-ladar.txt`, scaled for a VLP-16 (the paper's values in the
/// README).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FoliageConfig {
    /// K1: the threshold's constant part.
    pub k1: f64,
    /// δ: how much a new candidate raises its neighbouring windows' thresholds.
    pub delta: f64,
    /// K2: how much the last two scans' evidence widens RELAX-OBST's tolerance.
    pub k2: f64,
    /// K3: the evidence a window with a candidate gets.
    pub k3: f64,
    /// a: range error per metre of range.
    pub range_error_a: f64,
    /// b: range error at zero range, m.
    pub range_error_b_m: f64,
    /// d_min: nearer obstacles are cropped, m.
    pub d_min_m: f64,
    /// d_max: farther obstacles are cropped, m.
    pub d_max_m: f64,
    /// α: window of FIND-LOW-FREQ, degrees.
    pub window_deg: f64,
    /// Sector of R_s, degrees.
    pub sector_deg: f64,
    /// W_s: returns around a return that REMOVE-THIN-OBST counts.
    pub thin_window: usize,
    /// O_s: obstacle returns among them that keep it.
    pub thin_min: usize,
    /// Beyond the paper: a window that held a confirmed obstacle in the previous scan seeds a
    /// candidate when its maximum is within RELAX-OBST's tolerance of that range.
    pub hold_obstacles: bool,
    /// Beyond the paper: a window whose maximum is nearer than both neighbours' takes the nearer
    /// neighbour's maximum before FIND-LOW-FREQ's differences (blades in front of a surface).
    pub fill_notches: bool,
    /// Beyond the paper: earlier scans whose window maxima, moved with the odometry into the
    /// present scan's frame, join the max filter's smoothness test (0: the paper).
    pub carry_scans: usize,
    /// How far, m, the sensor must have moved from where an earlier scan was taken to carry it.
    pub carry_min_travel_m: f64,
    /// Odometry older than this when a scan arrives is not used to carry earlier scans, s.
    pub odom_max_age_s: f64,
}

impl Default for FoliageConfig {
    fn default() -> Self {
        FoliageConfig {
            k1: 0.02,
            delta: 0.03,
            k2: 0.05,
            k3: 25.0,
            range_error_a: 0.01,
            range_error_b_m: 0.03,
            d_min_m: 0.3,
            d_max_m: 3.0,
            window_deg: 0.4,
            sector_deg: 10.0,
            thin_window: 9,
            thin_min: 3,
            hold_obstacles: true,
            fill_notches: true,
            carry_scans: 2,
            carry_min_travel_m: 0.03,
            odom_max_age_s: 0.5,
        }
    }
}

impl FoliageConfig {
    /// Checks every key of `[foliage]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        r.check("foliage.k1", self.k1, 0.0, 10.0);
        r.check("foliage.delta", self.delta, 0.0, 10.0);
        r.check("foliage.k2", self.k2, 0.0, 10.0);
        r.check("foliage.k3", self.k3, 0.0, 1000.0);
        r.check("foliage.range_error_a", self.range_error_a, 0.0, 1.0);
        r.check("foliage.range_error_b_m", self.range_error_b_m, 0.0, 1.0);
        r.check("foliage.d_min_m", self.d_min_m, 0.0, 100.0);
        r.check("foliage.d_max_m", self.d_max_m, 0.0, 200.0);
        r.require(
            self.d_min_m < self.d_max_m,
            "foliage.d_min_m",
            format!(
                "foliage.d_min_m = {} must be below foliage.d_max_m = {}",
                self.d_min_m, self.d_max_m
            ),
        );
        r.check("foliage.window_deg", self.window_deg, 0.05, 45.0);
        r.check("foliage.sector_deg", self.sector_deg, 5.0, 180.0);
        r.check("foliage.thin_window", self.thin_window as f64, 1.0, 1001.0);
        r.check("foliage.carry_scans", self.carry_scans as f64, 0.0, 8.0);
        r.check(
            "foliage.carry_min_travel_m",
            self.carry_min_travel_m,
            0.0,
            1.0,
        );
        r.check("foliage.odom_max_age_s", self.odom_max_age_s, 0.01, 60.0);
        r.check(
            "foliage.thin_min",
            self.thin_min as f64,
            0.0,
            self.thin_window as f64,
        );
        r.finish()
    }
}
