//! The simulated SICK 2D ladar (issue 26): a planar scanner at its mount (`sick.mount`: x, y,
//! yaw, upside down, and the scan plane's height `z_m` above the ground; the beams are level)
//! with the configured model's field, step, range and rate. What a scan carries on the wire
//! (the `LMDscandata` telegram, the login, the modes) is the emulated scanner's,
//! [`mimnav_sick::device::Device`]; this module measures what it sends.
//!
//! **Beam physics.** Every measurement is cast with the very material model of the simulated
//! VLP-16 ([`crate::physics::BeamCaster::cast`], DESIGN §9), prefiltered the same way, so grass,
//! glass and strands behave as they do for the VLP-16. Only the range noise is the SICK's: a
//! solid surface's range is drawn with the standard deviation [`range_noise_m`] of the model's
//! statistical error (LMS1xx and LMS5xx: 12 mm, TiM: 20 mm, from their operating instructions'
//! technical data; the systematic error, ±30 mm on an LMS1xx, is left out), in place of
//! `sim.range_noise_m`; the distances are sent in whole millimetres.
//!
//! **Echoes.** A model with one echo (LMS1xx, TiM) reports the beam's last echo
//! (`sim.sick_echo`, `"last"` by default: SICK's telegram listing gives the last echo as the
//! echo filter's default, `FREchoFilter` 2; `"first"` or `"strongest"` instead; through grass
//! it decides what is seen behind the blades: with the strongest, a trunk hidden in grass was
//! alarmed in 1 % of the scans standing, with the last in 99.5 %). An LMS5xx reports up to five, nearest first: the
//! nearest four and the last (so the surface behind foliage is always among them), and the
//! device sends them all or the last as its echo filter says. Remission is the echo's intensity
//! (the material model's 0–255 reflectivity units) as an 8-bit value. A measurement without an
//! echo, or whose echo lies beyond the model's range (`SickConfig::max_range`), is 0: no echo.
//!
//! **Time.** A scan is cast from one pose of the robot, the one at its start: the mirror turns
//! once per period and measures 270° of it, so the robot moves at most `v · 0.75 / f` during a
//! real scan (3 cm at 1 m/s on a 25 Hz LMS1xx, 5 cm at 15 Hz on a TiM), which the driver and the
//! classifier ignore as well (they take a scan as one instant). Each measurement is cast at its
//! own instant for what moves in the world (the grass's sway): the scan's start plus the
//! mirror's turn to its angle.
//!
//! **Angles.** Device angles count counter-clockwise seen from above with 90° straight ahead
//! ([`mimnav_sick::convert`]); the bearing on the robot is `yaw + (angle − 90°)`, the sign of
//! `angle − 90°` flipped when the scanner hangs upside down.

use mimnav_shared::pose::{Pose2, Pose2Ext, pose2};
use mimnav_sick::device::Geometry;
use mimnav_sick::{Model, SickConfig};

use crate::config::{SickEcho, SimConfig};
use crate::lidar::Beam;
use crate::physics::{BeamCaster, Echo, last, strongest};
use crate::world::Scene;

/// How far off a beam may pass an object's bounding circle and still be tested, m.
const PREFILTER_MARGIN_M: f64 = 0.05;

/// The standard deviation of a model's range noise (its statistical error), m.
pub fn range_noise_m(model: Model) -> f64 {
    match model {
        Model::Lms1xx | Model::Lms5xx => 0.012,
        Model::Tim5xx | Model::Tim7xx => 0.020,
    }
}

/// One scan's measurements, as [`mimnav_sick::device::Device::scan_telegram`] takes them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SickScan {
    /// Distances of each echo, mm, nearest first: `echoes[k][i]` is echo `k` of measurement
    /// `i` (0: none). One channel per echo the model reports.
    pub echoes: Vec<Vec<u16>>,
    /// The remission (8-bit) of each echo, in the same layout.
    pub remission: Vec<Vec<u16>>,
}

/// The simulated scanner: its mount, model and random draws.
#[derive(Debug)]
pub struct SickScanner {
    config: SickConfig,
    physics: SimConfig,
    rng: fastrand::Rng,
    caster: BeamCaster,
    candidates: Vec<usize>,
    echoes: Vec<Echo>,
}

impl SickScanner {
    /// A scanner set up as `sick` says, casting with the beam physics of `sim` (its range noise
    /// replaced by the model's), every random draw following `seed`.
    pub fn new(sick: &SickConfig, sim: &SimConfig, seed: u64) -> Self {
        SickScanner {
            physics: SimConfig {
                range_noise_m: range_noise_m(sick.model),
                ..sim.clone()
            },
            config: sick.clone(),
            // apart from the VLP-16's draws of the same seed
            rng: fastrand::Rng::with_seed(seed ^ 0x7369_636b_5f72_6e67),
            caster: BeamCaster::new(seed ^ 0x6772_6173_735f_6669),
            candidates: Vec::with_capacity(64),
            echoes: Vec::with_capacity(8),
        }
    }

    /// The `[sick]` it was built from.
    pub fn config(&self) -> &SickConfig {
        &self.config
    }

    /// Echo channels a scan carries: the model's echoes.
    pub fn channels(&self) -> usize {
        usize::from(self.config.model.spec().echoes.max(1))
    }

    /// The scanner's pose on the ground plane when the base is at `base`.
    pub fn sensor_pose(&self, base: &Pose2) -> Pose2 {
        let m = &self.config.mount;
        base * pose2(m.x_m, m.y_m, m.yaw_deg.to_radians())
    }

    /// The heading on the robot (rad, counter-clockwise from the sensor's forward) of the
    /// measurement at device angle `device_deg`.
    fn bearing(&self, device_deg: f64) -> f64 {
        let flip = if self.config.mount.upside_down {
            -1.0
        } else {
            1.0
        };
        flip * (device_deg - 90.0).to_radians()
    }

    /// The beams of a scan with geometry `g` from a base at `base`, in measurement order: the
    /// very rays [`SickScanner::scan`] casts (for ground truth). `azimuth_deg` is the beam's
    /// heading clockwise from the robot's forward, in [0, 360), as for the VLP-16. `out` is
    /// cleared first.
    pub fn beams(&self, base: &Pose2, g: &Geometry, out: &mut Vec<Beam>) {
        out.clear();
        let pose = self.sensor_pose(base);
        let (origin, yaw) = ([pose.x(), pose.y(), self.config.mount.z_m], pose.yaw());
        let mount_yaw = self.config.mount.yaw_deg.to_radians();
        for i in 0..g.count {
            let b = self.bearing(g.start_deg + i as f64 * g.step_deg);
            let (s, c) = (yaw + b).sin_cos();
            out.push(Beam {
                origin,
                dir: [c, s, 0.0],
                azimuth_deg: (-(mount_yaw + b).to_degrees()).rem_euclid(360.0),
            });
        }
    }

    /// Casts a scan with geometry `g` (the device's current mode) from a base at `base`, the
    /// scan starting at `time_s` (simulated seconds, for the grass's sway); the measurements go
    /// to `out` (its buffers reused).
    pub fn scan(
        &mut self,
        scene: &Scene,
        base: &Pose2,
        time_s: f64,
        g: &Geometry,
        out: &mut SickScan,
    ) {
        let channels = self.channels();
        out.echoes.resize_with(channels, Vec::new);
        out.remission.resize_with(channels, Vec::new);
        for c in out.echoes.iter_mut().chain(out.remission.iter_mut()) {
            c.clear();
            c.resize(g.count, 0);
        }
        let pose = self.sensor_pose(base);
        let (origin, yaw) = ([pose.x(), pose.y(), self.config.mount.z_m], pose.yaw());
        let max_range = self.config.max_range();
        // the mirror turns once a period; a measurement is taken when it points at its angle
        let s_per_deg = 1.0 / (g.frequency_hz.max(1e-3) * 360.0);
        for i in 0..g.count {
            let along = i as f64 * g.step_deg;
            let heading = yaw + self.bearing(g.start_deg + along);
            let (uy, ux) = heading.sin_cos();
            self.prefilter(scene, origin, ux, uy, max_range);
            let echoes = self.caster.cast(
                scene,
                &self.candidates,
                origin,
                [ux, uy, 0.0],
                time_s + along * s_per_deg,
                &self.physics,
                &mut self.rng,
            );
            self.echoes.clear();
            self.echoes.extend(
                echoes
                    .iter()
                    .filter(|e| e.range > 0.0 && e.range <= max_range)
                    .copied(),
            );
            if channels == 1 {
                let pick = match self.physics.sick_echo {
                    SickEcho::Strongest => strongest(&self.echoes),
                    SickEcho::Last => last(&self.echoes),
                    SickEcho::First => self
                        .echoes
                        .iter()
                        .copied()
                        .min_by(|a, b| a.range.total_cmp(&b.range)),
                };
                if let Some(e) = pick {
                    (out.echoes[0][i], out.remission[0][i]) = record(&e);
                }
                continue;
            }
            self.echoes
                .sort_unstable_by(|a, b| a.range.total_cmp(&b.range));
            if self.echoes.len() > channels {
                // the nearest ones and the last
                let last = self.echoes[self.echoes.len() - 1];
                self.echoes.truncate(channels - 1);
                self.echoes.push(last);
            }
            for (k, e) in self.echoes.iter().enumerate() {
                (out.echoes[k][i], out.remission[k][i]) = record(e);
            }
        }
    }

    /// Objects whose bounding circle the level beam from `origin` along (`ux`, `uy`) passes near.
    fn prefilter(&mut self, scene: &Scene, origin: [f64; 3], ux: f64, uy: f64, max_range: f64) {
        self.candidates.clear();
        for (i, obj) in scene.objects.iter().enumerate() {
            let (c, r) = obj.bound;
            let (dx, dy) = (c[0] - origin[0], c[1] - origin[1]);
            let along = dx * ux + dy * uy;
            let r = r + PREFILTER_MARGIN_M;
            if along < -r || along > max_range + r {
                continue;
            }
            if (dx * uy - dy * ux).abs() <= r {
                self.candidates.push(i);
            }
        }
    }
}

/// An echo as the scanner sends it: (distance mm, at least 1; remission 0–255).
fn record(e: &Echo) -> (u16, u16) {
    (
        (e.range * 1000.0).round().clamp(1.0, 65535.0) as u16,
        e.intensity.round().clamp(0.0, 255.0) as u16,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::WorldFile;
    use mimnav_shared::topics::ScanReturn;
    use mimnav_sick::convert::SickMount;
    use mimnav_sick::device::Device;
    use mimnav_sick::session::{Event, Session};

    fn scene(extra: &str) -> Scene {
        let text = format!(
            "name = 't'\nstart = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\ntime_limit_s = 10.0\n{extra}"
        );
        WorldFile::parse(&text, "inline").expect("valid").compile()
    }

    /// One scan of `scene` from the start, through the emulated device's telegram and the
    /// driver's session (after its start-up exchange) and conversion.
    fn returns(sick: &SickConfig, scene: &Scene, seed: u64) -> Vec<ScanReturn> {
        returns_with(sick, scene, seed, SickEcho::Strongest)
    }

    fn returns_with(
        sick: &SickConfig,
        scene: &Scene,
        seed: u64,
        echo: SickEcho,
    ) -> Vec<ScanReturn> {
        let mut dev = Device::new(sick.model, sick.protocol, 1);
        let mut session = Session::new(sick.session());
        let (mut to_dev, mut to_drv) = (Vec::new(), Vec::new());
        session.begin(0, &mut to_dev);
        for _ in 0..20 {
            dev.receive(&to_dev, &mut to_drv);
            to_dev.clear();
            session.receive(&to_drv, 0, &mut to_dev, |_| {});
            to_drv.clear();
        }
        assert!(session.streaming() && dev.streaming());
        let g = dev.geometry();
        let sim = SimConfig {
            sick_echo: echo,
            ..SimConfig::default()
        };
        let mut scanner = SickScanner::new(sick, &sim, seed);
        let mut scan = SickScan::default();
        scanner.scan(scene, &pose2(0.0, 0.0, 0.0), 0.0, &g, &mut scan);
        assert_eq!(scan.echoes.len(), scanner.channels());
        assert!(scan.echoes.iter().all(|c| c.len() == g.count));
        let mut wire = Vec::new();
        dev.scan_telegram(0, &scan.echoes, &scan.remission, &mut wire);
        let mut out = Vec::new();
        let mut scans = 0;
        session.receive(&wire, 1, &mut to_dev, |e| {
            if let Event::Scan(sd) = e {
                scans += 1;
                sick.converter().convert(sd, &mut out).expect("converts");
            }
        });
        assert_eq!(scans, 1);
        assert_eq!(out.len(), g.count);
        out
    }

    fn at(out: &[ScanReturn], bearing_deg: f32) -> &ScanReturn {
        out.iter()
            .min_by(|a, b| {
                let d = |r: &ScanReturn| (r.angle_rad.to_degrees() - bearing_deg).abs();
                d(a).total_cmp(&d(b))
            })
            .expect("returns")
    }

    #[test]
    fn a_wall_ahead_is_at_bearing_zero_whatever_the_mount() {
        let wall = scene("[[wall]]\nfrom = [5.0, -20.0]\nto = [5.0, 20.0]\n");
        let mounts = [
            SickMount::default(),
            SickMount {
                yaw_deg: 90.0,
                ..SickMount::default()
            },
            SickMount {
                upside_down: true,
                ..SickMount::default()
            },
            SickMount {
                x_m: 0.2,
                y_m: 0.1,
                yaw_deg: -60.0,
                upside_down: true,
                ..SickMount::default()
            },
        ];
        for model in [Model::Lms1xx, Model::Lms5xx, Model::Tim5xx, Model::Tim7xx] {
            for mount in mounts {
                let sick = SickConfig {
                    model,
                    mount: SickMount { z_m: 0.4, ..mount },
                    ..SickConfig::default()
                };
                let out = returns(&sick, &wall, 3);
                let spec = model.spec();
                let field = spec.field_deg.1 - spec.field_deg.0;
                assert_eq!(
                    out.len(),
                    Device::new(model, sick.protocol, 1).geometry().count
                );
                let ahead = at(&out, 0.0);
                assert!(
                    ahead.angle_rad.to_degrees().abs() < 1.0,
                    "{model:?} {mount:?}: nearest bearing {}",
                    ahead.angle_rad.to_degrees()
                );
                let want = 5.0 / ahead.angle_rad.cos();
                assert!(
                    (ahead.range_m - want).abs() < 0.08,
                    "{model:?} {mount:?}: {} m ahead, want {want}",
                    ahead.range_m
                );
                // 30° to the left, when the field covers it
                if field >= 180.0 && mount.yaw_deg == 0.0 {
                    let left = at(&out, 30.0);
                    let want = 5.0 / left.angle_rad.cos();
                    assert!((left.range_m - want).abs() < 0.08, "{model:?} {mount:?}");
                }
                // nothing behind: the wall is the only thing in the world
                let behind = out
                    .iter()
                    .filter(|r| r.range_m > 0.0 && r.angle_rad.cos() < -0.1)
                    .count();
                assert_eq!(behind, 0, "{model:?} {mount:?}");
            }
        }
    }

    #[test]
    fn beyond_the_models_range_is_no_echo() {
        // a TiM5xx reaches 10 m: a wall at 12 m is not seen, at 8 m it is
        let far = scene("[[wall]]\nfrom = [12.0, -2.0]\nto = [12.0, 2.0]\n");
        let near = scene("[[wall]]\nfrom = [8.0, -2.0]\nto = [8.0, 2.0]\n");
        let sick = SickConfig {
            model: Model::Tim5xx,
            ..SickConfig::default()
        };
        assert_eq!(at(&returns(&sick, &far, 1), 0.0).range_m, 0.0);
        assert!((at(&returns(&sick, &near, 1), 0.0).range_m - 8.0).abs() < 0.1);
    }

    #[test]
    fn grass_gives_varied_ranges_and_the_lms5xx_sees_through_it() {
        let grass = scene(
            "[[grass]]\ncenter = [4.0, 0.0]\nsize = [6.0, 20.0]\nheight = 1.0\ndensity = 3.0\nreflectivity = 20\n\
             [[wall]]\nfrom = [9.0, -30.0]\nto = [9.0, 30.0]\n",
        );
        let sick = SickConfig::default();
        let out = returns(&sick, &grass, 5);
        let ahead: Vec<f32> = out
            .iter()
            .filter(|r| r.angle_rad.abs() < 0.3 && r.range_m > 0.0)
            .map(|r| r.range_m)
            .collect();
        assert!(ahead.len() > 30, "{} returns ahead", ahead.len());
        let mean = ahead.iter().sum::<f32>() / ahead.len() as f32;
        let sd =
            (ahead.iter().map(|r| (r - mean).powi(2)).sum::<f32>() / ahead.len() as f32).sqrt();
        assert!(sd > 0.3, "grass ranges spread {sd} m around {mean} m");
        assert!(
            ahead.iter().any(|&r| r > 1.0 && r < 7.0),
            "blades in the grass"
        );
        // an LMS5xx sends every echo; the driver's last echo is the wall behind the grass more
        // often than the LMS1xx's strongest one is
        let lms5 = SickConfig {
            model: Model::Lms5xx,
            ..SickConfig::default()
        };
        let wall_share = |out: &[ScanReturn]| {
            let ahead: Vec<&ScanReturn> = out.iter().filter(|r| r.angle_rad.abs() < 0.3).collect();
            let on = ahead
                .iter()
                .filter(|r| (r.range_m * r.angle_rad.cos() - 9.0).abs() < 0.1)
                .count();
            on as f64 / ahead.len() as f64
        };
        let (s1, s5) = (wall_share(&out), wall_share(&returns(&lms5, &grass, 5)));
        assert!(s5 > s1, "last echo on the wall {s5}, strongest {s1}");
        // a one-echo scanner set to its last echo sees the wall as often as the LMS5xx's last
        let last = returns_with(&sick, &grass, 5, SickEcho::Last);
        let first = returns_with(&sick, &grass, 5, SickEcho::First);
        let (sl, sf) = (wall_share(&last), wall_share(&first));
        assert!(sl > s1 && sf < s1, "last {sl}, strongest {s1}, first {sf}");
    }

    #[test]
    fn the_sim_idles_without_the_vlp16_and_scans_from_its_pose() {
        let wall = scene("[[wall]]\nfrom = [5.0, -20.0]\nto = [5.0, 20.0]\n");
        let mut sim = crate::Sim::new(wall, crate::SimSettings::default(), 1, 0);
        sim.set_command(0.5, 0.0);
        for _ in 0..50 {
            sim.idle(40_000_000);
        }
        // 2 s at up to 0.5 m/s, from rest
        let x = sim.base().pose.x();
        assert!((0.5..=1.0).contains(&x), "{x}");
        assert_eq!(sim.now_ns(), 2_000_000_000);
        assert_eq!(sim.revolutions(), 0);
        let sick = SickConfig::default();
        let g = Device::new(sick.model, sick.protocol, 1).geometry();
        let mut scanner = SickScanner::new(&sick, &sim.settings().sim, 1);
        let mut scan = SickScan::default();
        sim.sick_scan(&mut scanner, &g, &mut scan);
        let mut beams = Vec::new();
        sim.sick_beams(&scanner, &g, &mut beams);
        assert_eq!(beams.len(), g.count);
        // straight ahead: the middle measurement (device 90°)
        let mid = g.count / 2;
        assert!(beams[mid].dir[0] > 0.9999 && beams[mid].azimuth_deg.abs() < 1e-9);
        let r = f64::from(scan.echoes[0][mid]) / 1000.0;
        assert!(
            (r - (5.0 - x)).abs() < 0.06,
            "{r} m, the wall is {} m ahead",
            5.0 - x
        );
    }

    #[test]
    fn scans_follow_the_seed() {
        let grass = scene(
            "[[grass]]\ncenter = [4.0, 0.0]\nsize = [6.0, 20.0]\nheight = 1.0\ndensity = 3.0\nreflectivity = 20\n",
        );
        let sick = SickConfig::default();
        assert_eq!(returns(&sick, &grass, 9), returns(&sick, &grass, 9));
        assert_ne!(returns(&sick, &grass, 9), returns(&sick, &grass, 10));
    }
}
