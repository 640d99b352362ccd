//! The foliage service's step: everything between receiving a planar scan (and the odometry) and
//! publishing the verdict on `foliage/alarm`, without IPC and without reading a clock (every call
//! is given `now`, monotonic ns). The service, `mimnav foliage-eval`, `mimnav eval` and the
//! lock-step runner drive this type alike.
//!
//! The sensor's motion between scans comes from the odometry (interpretation 17): it is taken only
//! when the odometry is no older than `foliage.odom_max_age_s`; without it (none yet, stale, or
//! `foliage.carry_scans = 0`) the scan is classified as the paper does, with no earlier scan
//! carried. Odometry with a non-finite number is refused where it arrives.

use mimnav_shared::config::Invalid;
use mimnav_shared::hop::Hop;
use mimnav_shared::pose::{
    LidarMount, MountTransform, NonFiniteOdometry, Pose2, check_odometry, pose2,
};
use mimnav_shared::topics::{
    FoliageHeader, FoliageReturn, MAX_FOLIAGE_SECTORS, Odometry, ScanHeader, ScanReturn,
};

use crate::{Classifier, FoliageParams, Motion};

/// Why a classifier cannot be built from its settings.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StepError {
    /// The `[foliage]` parameters do not validate.
    #[error("[foliage]: {0}")]
    Params(Invalid),
    /// More sectors than `foliage/alarm` carries.
    #[error(
        "[foliage]: sector_deg gives {0} sectors, more than the {MAX_FOLIAGE_SECTORS} foliage/alarm carries"
    )]
    Sectors(usize),
}

/// How the odometry served a scan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OdomUse {
    /// `foliage.carry_scans = 0`: the odometry is not asked for.
    Off,
    /// None received yet.
    Missing,
    /// Older than `foliage.odom_max_age_s`.
    Stale,
    /// Fresh: earlier scans are carried with the motion since the previous scan.
    Fresh,
}

/// One scan classified: the header and returns to publish (`processing_us` is the caller's to
/// fill) and how the odometry served it.
#[derive(Debug)]
pub struct Classified<'a> {
    /// The header of `foliage/alarm`.
    pub header: FoliageHeader,
    /// Every return with its class, in the scan's order.
    pub returns: &'a [FoliageReturn],
    /// How the odometry served this scan.
    pub odometry: OdomUse,
}

/// The foliage service's state between messages: the classifier, the latest odometry and the
/// pose at the previous scan.
#[derive(Debug)]
pub struct ScanStep {
    classifier: Classifier,
    mount: Option<MountTransform>,
    carry: bool,
    odom_max_age_ns: u64,
    odom: Option<Odometry>,
    last_pose: Option<Pose2>,
    angles: Vec<f32>,
    ranges: Vec<f32>,
    out: Vec<FoliageReturn>,
    seq: u64,
    scan_hop: Hop,
}

impl ScanStep {
    /// A step classifying with `params`; odometry older than `odom_max_age_ns` is stale.
    pub fn new(params: FoliageParams, odom_max_age_ns: u64) -> Result<Self, StepError> {
        if params.n_sectors() > MAX_FOLIAGE_SECTORS {
            return Err(StepError::Sectors(params.n_sectors()));
        }
        Ok(ScanStep {
            classifier: Classifier::new(params).map_err(StepError::Params)?,
            mount: None,
            carry: params.carry_scans > 0,
            odom_max_age_ns,
            odom: None,
            last_pose: None,
            angles: Vec::new(),
            ranges: Vec::new(),
            out: Vec::new(),
            seq: 0,
            scan_hop: Hop::new(),
        })
    }

    /// The lidar sits at `mount` on the robot: every return is first brought into the frame of
    /// a sensor centred on the robot's axis (its bearing and horizontal range from there), so
    /// the sectors, the carried scans and the planner's obstacles are the robot's.
    pub fn with_mount(mut self, mount: &LidarMount) -> Self {
        self.mount = MountTransform::of(mount);
        self
    }

    /// The classifier's settings.
    pub fn params(&self) -> &FoliageParams {
        self.classifier.params()
    }

    /// The last scan's returns with their classes.
    pub fn returns(&self) -> &[FoliageReturn] {
        &self.out
    }

    /// Verdicts published so far.
    pub fn scans(&self) -> u64 {
        self.seq
    }

    /// The scans taken from `lidar/scan2d` and those that never reached the classifier (gaps in
    /// their sequence).
    pub fn scan_hop(&self) -> &Hop {
        &self.scan_hop
    }

    /// Takes the latest odometry; refuses (and keeps the previous one) when a number is not
    /// finite.
    pub fn odom(&mut self, o: &Odometry) -> Result<(), NonFiniteOdometry> {
        check_odometry(o)?;
        self.odom = Some(*o);
        Ok(())
    }

    /// Classifies the scan `returns` (with its header) that arrived at `now`.
    pub fn scan(&mut self, h: &ScanHeader, returns: &[ScanReturn], now: u64) -> Classified<'_> {
        self.scan_hop.see(h.seq);
        self.angles.clear();
        self.ranges.clear();
        for r in returns {
            let (angle, range) = match &self.mount {
                // no return stays no return
                Some(t) if r.range_m > 0.0 => {
                    let (s, c) = r.angle_rad.sin_cos();
                    let [x, y, _] = t.apply([r.range_m * c, r.range_m * s, 0.0]);
                    (y.atan2(x), x.hypot(y))
                }
                _ => (r.angle_rad, r.range_m),
            };
            self.angles.push(angle);
            self.ranges.push(range);
        }
        let (pose, odometry) = match self.odom {
            _ if !self.carry => (None, OdomUse::Off),
            None => (None, OdomUse::Missing),
            Some(o) if now.saturating_sub(o.rx_mono_ns) > self.odom_max_age_ns => {
                (None, OdomUse::Stale)
            }
            Some(o) => (Some(pose2(o.x, o.y, o.yaw)), OdomUse::Fresh),
        };
        let motion = (self.last_pose.zip(pose)).map(|(from, to)| Motion::between(&from, &to));
        self.last_pose = pose;
        let verdict = self
            .classifier
            .classify_moved(&self.angles, &self.ranges, motion);
        self.out.clear();
        let classed = self.angles.iter().zip(&self.ranges).zip(verdict.classes);
        self.out.extend(
            classed.map(|((&angle_rad, &range_m), &class)| FoliageReturn {
                angle_rad,
                range_m,
                class,
                reserved: [0; 3],
            }),
        );
        let mut header = FoliageHeader {
            seq: self.seq,
            source_seq: h.seq,
            stamp_ns: h.stamp_ns,
            rx_mono_ns: h.rx_mono_ns,
            count: self.out.len() as u32,
            sectors: verdict.nearest_per_sector.len().min(MAX_FOLIAGE_SECTORS) as u32,
            obstacles: verdict.obstacle_count as u32,
            processing_us: 0,
            alarm: u8::from(verdict.alarm),
            laser_id: h.laser_id,
            ..FoliageHeader::default()
        };
        for (slot, &r) in header.nearest_m.iter_mut().zip(verdict.nearest_per_sector) {
            *slot = r;
        }
        self.seq += 1;
        Classified {
            header,
            returns: &self.out,
            odometry,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mimnav_shared::topics::foliage_class;

    const S: u64 = 1_000_000_000;

    fn step() -> ScanStep {
        ScanStep::new(FoliageParams::default(), S / 2).expect("the defaults validate")
    }

    /// A wall 2 m ahead across ±30°, nothing elsewhere: 1 800 returns a turn.
    fn wall() -> (ScanHeader, Vec<ScanReturn>) {
        let returns: Vec<ScanReturn> = (0..1800)
            .map(|i| {
                let angle_rad = -std::f32::consts::PI + i as f32 * std::f32::consts::TAU / 1800.0;
                let range_m = if angle_rad.abs() < 0.5 {
                    2.0 / angle_rad.cos()
                } else {
                    0.0
                };
                ScanReturn {
                    angle_rad,
                    range_m,
                    ..ScanReturn::default()
                }
            })
            .collect();
        let h = ScanHeader {
            seq: 40,
            stamp_ns: 3 * S,
            rx_mono_ns: 4 * S,
            count: returns.len() as u32,
            laser_id: 7,
            ..ScanHeader::default()
        };
        (h, returns)
    }

    fn odom(at: u64, x: f64) -> Odometry {
        Odometry {
            seq: 1,
            rx_mono_ns: at,
            x,
            ..Odometry::default()
        }
    }

    #[test]
    fn the_verdict_names_its_scan_and_classes_every_return() {
        let mut s = step();
        let (h, r) = wall();
        let mut last = None;
        for k in 0..4 {
            let c = s.scan(&h, &r, 10 * S + k * S / 10);
            assert_eq!(c.returns.len(), r.len());
            let hd = c.header;
            assert_eq!(
                (hd.seq, hd.source_seq, hd.stamp_ns, hd.rx_mono_ns),
                (k, 40, 3 * S, 4 * S)
            );
            assert_eq!((hd.count as usize, hd.laser_id), (r.len(), 7));
            let obstacles = (c.returns.iter())
                .filter(|x| x.class == foliage_class::OBSTACLE)
                .count();
            assert_eq!(obstacles, hd.obstacles as usize);
            last = Some(hd);
        }
        // a wall seen scan after scan is an obstacle in range: the alarm
        let hd = last.expect("four scans");
        assert_eq!(hd.alarm, 1, "{hd:?}");
        assert!(hd.nearest_m[..hd.sectors as usize].iter().any(|&m| m < 2.5));
        assert_eq!(s.scans(), 4);
    }

    /// Issue 23, the soak: a scan overwritten in the classifier's subscriber buffer is counted
    /// as dropped on the hop from the driver.
    #[test]
    fn scans_that_never_reached_the_classifier_are_counted_dropped() {
        let mut s = step();
        let (h, r) = wall();
        for seq in [40, 41, 45] {
            s.scan(&ScanHeader { seq, ..h }, &r, 10 * S);
        }
        assert_eq!((s.scan_hop().received(), s.scan_hop().dropped()), (3, 3));
    }

    #[test]
    fn a_mounted_sensor_classifies_like_a_centred_one() {
        // the sensor 0.3 m behind the axis and turned 40° left: its returns, as it reports them
        let mount = LidarMount {
            x_m: -0.3,
            yaw_deg: 40.0,
            ..LidarMount::default()
        };
        let (h, centred) = wall();
        let inverse = MountTransform::inverse_of(&mount);
        let as_mounted: Vec<ScanReturn> = (centred.iter())
            .map(|r| {
                if r.range_m <= 0.0 {
                    return *r;
                }
                let (sn, cs) = r.angle_rad.sin_cos();
                let [x, y, _] = inverse.apply([r.range_m * cs, r.range_m * sn, 0.0]);
                ScanReturn {
                    angle_rad: y.atan2(x),
                    range_m: x.hypot(y),
                    ..*r
                }
            })
            .collect();
        let (mut a, mut b) = (step(), step().with_mount(&mount));
        let mut ignoring = step();
        for k in 0..4 {
            let now = 10 * S + k * S / 10;
            let ca = a.scan(&h, &centred, now);
            let (ha, ra) = (ca.header, ca.returns.to_vec());
            let cb = b.scan(&h, &as_mounted, now);
            assert_eq!(
                (cb.header.alarm, cb.header.obstacles),
                (ha.alarm, ha.obstacles)
            );
            for (x, y) in ra.iter().zip(cb.returns) {
                assert_eq!(x.class, y.class);
                assert!(
                    (x.range_m - y.range_m).abs() < 1e-4
                        && (x.angle_rad - y.angle_rad).abs() < 1e-4
                );
            }
            // the same returns taken as a centred sensor's put the wall elsewhere
            let ci = ignoring.scan(&h, &as_mounted, now);
            let hits = ra.iter().filter(|x| x.range_m > 0.0).count();
            let moved = (ra.iter().zip(ci.returns))
                .filter(|(x, y)| x.range_m > 0.0 && (x.angle_rad - y.angle_rad).abs() > 0.5)
                .count();
            assert!(hits > 100 && moved == hits, "{moved} of {hits}");
        }
    }

    #[test]
    fn odometry_is_used_only_when_fresh_finite_and_asked_for() {
        let (h, r) = wall();
        let mut s = step();
        assert_eq!(s.scan(&h, &r, 10 * S).odometry, OdomUse::Missing);
        s.odom(&odom(10 * S, 0.0)).expect("good odometry");
        assert_eq!(s.scan(&h, &r, 10 * S + S / 2).odometry, OdomUse::Fresh);
        assert_eq!(s.scan(&h, &r, 10 * S + S / 2 + 1).odometry, OdomUse::Stale);
        let bad = Odometry {
            yaw: f64::NAN,
            ..odom(11 * S, 0.0)
        };
        assert_eq!(s.odom(&bad), Err(NonFiniteOdometry(1)));
        assert_eq!(
            s.scan(&h, &r, 11 * S).odometry,
            OdomUse::Stale,
            "the NaN was refused"
        );
        let off = FoliageParams {
            carry_scans: 0,
            ..FoliageParams::default()
        };
        let mut s = ScanStep::new(off, S).expect("valid");
        s.odom(&odom(10 * S, 0.0)).expect("good odometry");
        assert_eq!(s.scan(&h, &r, 10 * S).odometry, OdomUse::Off);
    }

    #[test]
    fn settings_the_topic_cannot_carry_are_refused() {
        let fine = FoliageParams {
            sector_rad: 1f32.to_radians(),
            ..FoliageParams::default()
        };
        assert!(matches!(
            ScanStep::new(fine, S),
            Err(StepError::Sectors(360))
        ));
    }
}
