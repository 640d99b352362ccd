//! `[foliage]`: the foliage classifier's parameters (`foliage-discrimination-rotating-ladar.txt`,
//! scaled for a VLP-16). The classifier (`mimnav-foliage`) takes this type as it is: the keys
//! are its fields, except the two angles, which the file gives in degrees (`window_deg`,
//! `sector_deg`) and the classifier keeps in radians.

use serde::{Deserialize, Deserializer};

use mimnav_shared::config::{Allowed, Checks, Invalid};

/// The largest [`FoliageParams::carry_scans`].
pub const MAX_CARRY_SCANS: usize = 8;

/// Parameters of the classifier.
///
/// Defaults are for one VLP-16 laser (1800 returns per turn, 0.2° spacing at 600 rpm, range noise
/// about ±3 cm, 2 mm range resolution) on a Spot or a Turtlebot 2; the paper's values are for an
/// Acuity AccuRange 4000 on the Urbie robot (512 returns per turn, 12.2 mrad spacing, error
/// `0.015·d + 12.3 mm`, range of interest 0.3–2 m).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FoliageParams {
    /// `K1`, the constant part of the `GET-OBST-CANDIDATES` threshold on `nad2v`
    /// (`T_k = K1 + max(T_{k-1}, T_{k-2}) / 2`, so the threshold settles at `2·K1` far from obstacles).
    /// Paper: 0.025. Default: **0.02**. Chosen with 4-return windows (the maximum of more returns
    /// from a dense grass band sits closer to the band's far edge, so the band looks smoother and
    /// needs a slightly tighter threshold: in the synthetic tests, 0.025 gave 3 alarms in 600 scans
    /// of a ±30–50 % grass band, 0.02 none, with nearly the same trunk detection); kept with the
    /// present 2-return windows (no false alarm in 4800 scans of simulated grass in
    /// `mimnav foliage-eval`). Smooth surfaces still pass: with 1.5 cm range noise every trunk and
    /// boulder in the clear was confirmed on the scan after it first showed.
    pub k1: f32,
    /// `δ`, the threshold raise given to the neighbouring windows of each new candidate
    /// (`δ/2` at `i±1`, `δ/4` at `i±2`). Paper: 0.03. Default: **0.03** (kept; unit-free).
    pub delta: f32,
    /// `K2`, the gain of past evidence on the `RELAX-OBST` tolerance
    /// (`C = 1 + K2·(C_{k-1} + C_{k-2})`). Paper: 0.05. Default: **0.05** (kept; with `K3 = 25` a
    /// window seen in the last scans relaxes about 2.25×).
    pub k2: f32,
    /// `K3`, the evidence written for a window holding a candidate (`UPDATE-AND-ARCHIVE`).
    /// Paper: 25. Default: **25** (kept; `K2·K3` is unit-free, and with the ceiling reading of the
    /// forget step it expires 5 scans after the obstacle vanished, 0.5 s at 10 Hz).
    pub k3: f32,
    /// `a` of the range error model `a·d + b` (Eq. 1), used by `RELAX-OBST`. Paper: 0.015.
    /// Default: **0.01**: the VLP-16 error is nearly constant with range; the slope only covers the
    /// beam footprint and the range step between adjacent beams on oblique surfaces.
    pub range_error_a: f32,
    /// `b` of the range error model (Eq. 1), metres. Paper: 12.3 mm (0.0123 m).
    /// Default: **0.03 m**, the VLP-16's specified accuracy (±3 cm).
    pub range_error_b_m: f32,
    /// `d_min`, metres: obstacles nearer are cropped (`CROP-RANGE`). Paper: 0.3 m.
    /// Default: **0.3 m** (kept): near enough for either robot to still stop, far enough to skip
    /// the sensor's own mount; raise it if the robot's mast, payload or arm appears in the scan.
    pub d_min_m: f32,
    /// `d_max`, metres: obstacles farther are cropped (`CROP-RANGE`). Paper: 2 m.
    /// Default: **3 m**: Spot (up to 1.6 m/s) and the Turtlebot are faster than Urbie; 3 m is about
    /// 2 s of travel for Spot. Beyond it the 7 windows `GET-OBST-CANDIDATES` needs (5.6°) are wider
    /// than a 0.3 m trunk, and the error model no longer holds for grass-filtered returns; the
    /// costmap, not this classifier, handles far obstacles.
    pub d_max_m: f32,
    /// `α`, the window of the max filter, radians. Paper: not given (its figure uses `α ≈ 2θ`, i.e.
    /// about 24 mrad, ~2 returns). Default: **0.4° (2 beams, 6.98 mrad, 900 windows)**, the paper's
    /// `α ≈ 2θ`. `GET-OBST-CANDIDATES` needs 7 consecutive smooth windows (`nad2v(i-2 … i+2)`
    /// reaches `v(i-2 … i+4)`): 2.8° here, so a 0.2 m trunk is a candidate out to `d_max` = 3 m
    /// (4.1° there) and a 10 cm post out to about 1.7 m. The earlier default, 0.8° (4 beams, 5.6°),
    /// was chosen on synthetic planar scans; the simulated evaluation on the real pipeline
    /// (`mimnav foliage-eval`, VLP-16 packets through the driver) showed it missing 0.2 m trunks in
    /// the clear beyond about 1.8 m: 88 % of the scans with a visible trunk or rock alarmed while
    /// driving, against 99.7 % with 0.4°, with no false alarm in 4800 scans of grass either way.
    /// The price: with a scan whose returns on a partly hidden obstacle are the farthest ones (the
    /// last return, `velodyne.scan_return = "last"`), fewer beams per window reach it behind grass
    /// (91–92 % of such scans alarmed standing against 94–97 % with 0.8°). With the default
    /// strongest return the blades in front outshine a hidden trunk and neither width sees it.
    #[serde(rename = "window_deg", deserialize_with = "degrees")]
    pub window_rad: f32,
    /// Sector size for `R_s`, radians. Paper: not given (`N_s = Ω/α_s`). Default: **10°** (36
    /// sectors), enough for a planner to slow down or steer by sector.
    #[serde(rename = "sector_deg", deserialize_with = "degrees")]
    pub sector_rad: f32,
    /// `W_s`, the number of returns (centred, wrapped) looked at by `REMOVE-THIN-OBST`; the window is
    /// `2⌊W_s/2⌋+1` returns. Paper: not given (`W_s ≪ Ne`). Default: **9** returns (±0.8°, the
    /// width of one window on each side).
    pub thin_window: usize,
    /// `O_s`, the minimum number of obstacle returns (itself included) in that window for an obstacle
    /// return to survive. Paper: not given. Default: **3**: behind grass only 40–65 % of a trunk's
    /// beams reach it and `RELAX-OBST` cannot bridge two missing returns in a row, so a partly
    /// hidden obstacle shows as short runs; 3 of 9 keeps those and drops isolated hits and pairs
    /// (4 of 9 lowered trunk detection in grass in the simulated tests).
    pub thin_min: usize,
    /// **Beyond the paper** (interpretation 15): a window at or beside one that held a confirmed
    /// obstacle (`R_f`) in the previous scan passes `GET-OBST-CANDIDATES` when its maximum lies
    /// within `RELAX-OBST`'s tolerance of that obstacle's range, smooth neighbours or not. Behind
    /// grass a blade in one window breaks the run of smooth windows the paper's test needs, and
    /// the alarm dropped out in about one scan in 14 on a trunk that had been confirmed all
    /// along. Only confirmed obstacles are held, so in grass that never raised an alarm nothing
    /// changes. Default **true**.
    pub hold_obstacles: bool,
    /// **Beyond the paper** (interpretation 16, `fill_notches` in the classifier): a window whose maximum is
    /// nearer than both neighbouring windows', which agree with each other within `RELAX-OBST`'s
    /// tolerance, takes the nearer neighbour's maximum before the differences. Behind grass, a
    /// window whose every beam met a blade is such a notch, and one of them among the 7 windows
    /// `GET-OBST-CANDIDATES` needs blocks the obstacle; while driving towards a trunk hidden in
    /// grass this held its first alarm back by 7.7 scans on average. Default **true**.
    pub fill_notches: bool,
    /// **Beyond the paper** (interpretation 17, the classifier's `Motion`): how many earlier scans, moved into
    /// this scan's frame with the sensor's motion, add their window maxima to the max filter's
    /// smoothness test. A scan is carried only once the sensor has moved at least
    /// `carry_min_travel_m` from where it was taken, and never without a known motion
    /// (the classifier's `classify_moved`). Behind grass, a window reaches an obstacle when any of its
    /// beams does; each carried scan adds the beams of another viewpoint. Driving toward trunks
    /// hidden in grass, the scans alarmed went from 92–94 % to 98–99 % with 2. Default **2**;
    /// 0 is the paper.
    pub carry_scans: usize,
    /// The distance, metres, the sensor must have moved since an earlier scan before that scan
    /// is carried (interpretation 17). Standing still, an earlier scan sees the same blades from
    /// the same place and adds no view, and in a band of grass with a sharp far edge the maxima of
    /// more beams line up along the edge like a wall (the tests' synthetic band: 137 false alarms
    /// in 200 scans standing with 2 carried scans, against 1 without). Default **0.03 m** (a
    /// robot driving at 0.3 m/s or faster carries every scan at 10 Hz).
    pub carry_min_travel_m: f32,
    /// Odometry older than this when a scan arrives is not used to carry earlier scans, s (the
    /// service's step, not the classifier, reads it). Default **0.5 s**.
    pub odom_max_age_s: f64,
    /// Where the planar scan on `lidar/scan2d` comes from: `"velodyne"` (one laser of the
    /// VLP-16, `velodyne.scan_laser`; the default) or `"sick"` (a SICK planar ladar through
    /// `mimnav-sick`, the sensor of the paper). With `"sick"` the VLP-16 driver does not publish
    /// `lidar/scan2d`, and the scan arrives with the scanner's mounting pose (`sick.mount`)
    /// already applied, so `robot.mount` is not applied to it.
    pub source: ScanSource,
}

/// Which sensor the planar scan comes from (`foliage.source`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ScanSource {
    /// One laser of the VLP-16 (`mimnav-velodyne`).
    #[default]
    Velodyne,
    /// A SICK planar ladar (`mimnav-sick`).
    Sick,
}

impl Default for FoliageParams {
    fn default() -> Self {
        Self {
            k1: 0.02,
            delta: 0.03,
            k2: 0.05,
            k3: 25.0,
            range_error_a: 0.01,
            range_error_b_m: 0.03,
            d_min_m: 0.3,
            d_max_m: 3.0,
            window_rad: 0.4_f32.to_radians(),
            sector_rad: 10.0_f32.to_radians(),
            thin_window: 9,
            thin_min: 3,
            hold_obstacles: true,
            fill_notches: true,
            carry_scans: 2,
            carry_min_travel_m: 0.03,
            odom_max_age_s: 0.5,
            source: ScanSource::Velodyne,
        }
    }
}

/// An angle written in degrees, kept in radians (as `(degrees as f32).to_radians()`).
fn degrees<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
    f32::deserialize(d).map(f32::to_radians)
}

/// An `f32` as the decimal it prints as (so `0.1` is reported as 0.1, not 0.100000001).
fn shown(v: f32) -> f64 {
    v.to_string().parse().unwrap_or(f64::NAN)
}

/// Refuses `value` unless it lies in `allowed`.
fn check(r: &mut Checks, key: &str, value: f32, allowed: Allowed) {
    r.range(key, shown(value), allowed);
}

/// Refuses an angle kept in radians unless its degrees lie in `lo_deg..=hi_deg`; compared in
/// radians, converted as the file's value was, so the bounds themselves are allowed.
fn check_deg(r: &mut Checks, key: &str, rad: f32, lo_deg: f32, hi_deg: f32) {
    let ok = rad >= lo_deg.to_radians() && rad <= hi_deg.to_radians();
    if !ok {
        // the value outside the range, in the file's unit
        r.range(
            key,
            shown(rad.to_degrees()),
            Allowed::closed(f64::from(lo_deg), f64::from(hi_deg)),
        );
    }
}

impl FoliageParams {
    /// Checks every key of `[foliage]`: each value refused names its key and what is allowed.
    pub fn validate(&self) -> Result<(), Invalid> {
        let mut r = Checks::default();
        let closed = Allowed::closed;
        check(&mut r, "foliage.k1", self.k1, closed(0.0, 10.0));
        check(&mut r, "foliage.delta", self.delta, closed(0.0, 10.0));
        check(&mut r, "foliage.k2", self.k2, closed(0.0, 10.0));
        // 0 would give no window any evidence, and REMOVE-NEW-OBST would confirm nothing
        check(&mut r, "foliage.k3", self.k3, Allowed::above(0.0, 1000.0));
        check(
            &mut r,
            "foliage.range_error_a",
            self.range_error_a,
            closed(0.0, 1.0),
        );
        check(
            &mut r,
            "foliage.range_error_b_m",
            self.range_error_b_m,
            closed(0.0, 1.0),
        );
        check(&mut r, "foliage.d_min_m", self.d_min_m, closed(0.0, 100.0));
        check(
            &mut r,
            "foliage.d_max_m",
            self.d_max_m,
            Allowed::above(0.0, 200.0),
        );
        r.require(
            self.d_min_m < self.d_max_m,
            "foliage.d_min_m",
            format!(
                "foliage.d_min_m = {} must be below foliage.d_max_m = {}",
                self.d_min_m, self.d_max_m
            ),
        );
        // at least 8 windows, so that the i±4 worklist neighbourhood never folds onto itself
        check_deg(&mut r, "foliage.window_deg", self.window_rad, 0.05, 45.0);
        // at most 72 sectors, what foliage/alarm carries
        check_deg(&mut r, "foliage.sector_deg", self.sector_rad, 5.0, 180.0);
        r.check("foliage.thin_window", self.thin_window as f64, 1.0, 1001.0);
        r.check(
            "foliage.thin_min",
            self.thin_min as f64,
            1.0,
            self.thin_window as f64,
        );
        r.check(
            "foliage.carry_scans",
            self.carry_scans as f64,
            0.0,
            MAX_CARRY_SCANS as f64,
        );
        check(
            &mut r,
            "foliage.carry_min_travel_m",
            self.carry_min_travel_m,
            closed(0.0, 1.0),
        );
        r.check("foliage.odom_max_age_s", self.odom_max_age_s, 0.01, 60.0);
        r.finish()
    }

    /// Number of angular windows, `⌈2π / α⌉` (interpretation 14 of the classifier).
    pub fn n_windows(&self) -> usize {
        bin_count(self.window_rad)
    }

    /// Number of sectors of `R_s`, `⌈2π / sector⌉` (`N_s = Ω / α_s` in the paper).
    pub fn n_sectors(&self) -> usize {
        bin_count(self.sector_rad)
    }
}

/// Number of bins of width `bin_rad` that cover the circle: `⌈2π / bin_rad⌉`, at least 1.
///
/// Interpretation (14): a remainder below 0.1 % of a bin is rounding of `bin_rad`, not a sliver bin.
/// Non-finite or non-positive widths give 1 bin.
pub fn bin_count(bin_rad: f32) -> usize {
    if !(bin_rad.is_finite() && bin_rad > 0.0) {
        return 1;
    }
    let ratio = std::f64::consts::TAU / f64::from(bin_rad);
    // Interpretation (14): a remainder below 0.1 % of a bin is rounding of `bin_rad`, not a bin.
    let n = (ratio - 1.0e-3).ceil();
    if n < 1.0 {
        1
    } else if n > 1.0e9 {
        1_000_000_000
    } else {
        n as usize
    }
}
