//! `mimnav foliage-eval`: the foliage classifier's own evaluation (issue 6) on simulator worlds.
//!
//! Every world × robot profile × motion (standing, or driving straight along the start heading at
//! a constant speed with the simulator's motion model) × seed is one episode of `--scans`
//! revolutions, in-process and deterministic. Each revolution goes the way it goes in the stack:
//! the simulated VLP-16's packets through the driver's revolution assembler (decoder and planar
//! scan of `velodyne.scan_laser` / `velodyne.scan_return`), the planar scan through
//! [`Classifier::classify_moved`] with the `[foliage]` parameters and the sensor's motion since
//! the previous scan, from the simulated pose (what the service takes from `odom`).
//!
//! Ground truth comes from the simulator, never from the classifier: before each packet the
//! simulator hands out the very beams the scan laser fires in it ([`Sim::next_beams`]); each is
//! intersected with the world's obstacles (opaque solid objects: trunks, rocks, walls). A return
//! of the planar scan is *on* an obstacle when the beam's nearest opaque surface is that
//! obstacle and the reported range is within [`ON_OBSTACLE_TOL_M`] of it (so the echo came back
//! from the obstacle, not from a blade in front of it). Per scan and obstacle:
//!
//! * **in range**: the obstacle's footprint is within `[d_min, d_max]` of the sensor;
//! * **out of the beam**: in range, but fewer than `--min-returns` of the laser's beams meet it
//!   in `[d_min, d_max]` even with the grass taken away (a rock below the scan plane);
//! * **hidden**: that many beams would meet it, but fewer returns come back from it — the grass
//!   stops or outshines the beams;
//! * **visible**: at least `--min-returns` returns (default 3) of the scan are on it in
//!   `[d_min, d_max]`. One or two returns on a trunk inside grass cannot be told from a blade by
//!   their range; they are counted apart as *glimpsed*;
//! * **alarmed**: the classifier raised the alarm with at least one obstacle-class return on
//!   this obstacle (an alarm raised by something else does not count for it).
//!
//! A **false alarm** is a scan whose alarm is raised with no obstacle-class return on any
//! obstacle: in pure grass, every alarm. The **delay** of an obstacle in an episode is the
//! number of scans from the first scan in which it is visible to the first in which it is
//! alarmed (0: alarmed in that very scan).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_foliage::ScanSource;
use mimnav_runner::{Drive, FoliageUse, Lockstep, MapSource, Options};
use mimnav_shared::pose::Pose2Ext;
use mimnav_shared::topics::{FoliageReturn, ScanHeader, ScanReturn, cell_class, foliage_class};
use mimnav_sick::device::Device;
use mimnav_sick::session::{Event, Session};
use mimnav_sim::config::SickEcho;
use mimnav_sim::geometry::{footprint_distance, intersect};
use mimnav_sim::lidar::Beam;
use mimnav_sim::sick::{SickScan, SickScanner};
use mimnav_sim::world::{Material, Scene, Shape, WorldFile};
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim};

/// A return is on an obstacle when its range is within this of the beam's true distance to the
/// obstacle's surface, m: 6 standard deviations of the simulator's range noise (1.5 cm) plus the
/// few centimetres a blade just in front pulls a merged echo forward (echoes closer than 0.2 m
/// along the beam arrive as one pulse at their intensity-weighted range).
pub const ON_OBSTACLE_TOL_M: f32 = 0.1;

/// Targets of issue 6.
const TARGET_FALSE_PER_1000: f64 = 1.0;
const TARGET_DETECTION: f64 = 0.99;

/// How the robot moves during an episode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, clap::ValueEnum)]
pub enum Motion {
    /// Standing at the world's start.
    Standing,
    /// Driving straight along the start heading at `--speed` (default: the robot's top speed).
    Moving,
}

impl Motion {
    fn name(self) -> &'static str {
        match self {
            Motion::Standing => "standing",
            Motion::Moving => "moving",
        }
    }
}

/// The planar scanner whose scans are classified.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Sensor {
    /// One laser of the simulated VLP-16 (`velodyne.scan_laser`), through the Velodyne driver.
    #[default]
    Velodyne,
    /// The simulated SICK of `[sick]` (model, mode, mount), through the SICK driver's session
    /// and conversion; the classifier runs as with `foliage.source = "sick"`.
    Sick,
}

impl Sensor {
    fn name(self) -> &'static str {
        match self {
            Sensor::Velodyne => "velodyne",
            Sensor::Sick => "sick",
        }
    }
}

/// Arguments of `mimnav foliage-eval`.
#[derive(Debug, clap::Args)]
pub struct FoliageEvalArgs {
    /// Worlds (default: every *.toml in the foliage/ folder beside the config's world, i.e.
    /// config/worlds/foliage/).
    #[arg(long = "world", value_name = "FILE")]
    worlds: Vec<PathBuf>,
    /// Robot profiles, e.g. spot, turtlebot2 (repeatable; default: the config's robot).
    #[arg(long = "robot", value_name = "NAME")]
    robots: Vec<String>,
    /// standing or moving (repeatable; default: both).
    #[arg(long = "motion", value_enum)]
    motions: Vec<Motion>,
    /// Seeds per world, robot and motion.
    #[arg(long, default_value_t = 5)]
    seeds: u64,
    /// The first seed.
    #[arg(long, default_value_t = 1)]
    first_seed: u64,
    /// Scans (revolutions) per episode.
    #[arg(long, default_value_t = 300)]
    scans: u64,
    /// Speed of the moving runs, m/s (default: the robot's top speed).
    #[arg(long, value_name = "M/S")]
    speed: Option<f64>,
    /// A scan sees an obstacle when at least this many of its returns are on it.
    #[arg(long, default_value_t = 3)]
    min_returns: usize,
    /// A visible scan shows the obstacle as a run when at least this many of its returns on it
    /// are consecutive (neighbouring firings, nothing between them): what the classifier's
    /// windows can see. Reported beside the detection over all visible scans.
    #[arg(long, default_value_t = 3)]
    min_run: usize,
    /// The scanner: velodyne (one laser of the VLP-16) or sick (the `[sick]` ladar).
    #[arg(long, value_enum, default_value_t = Sensor::Velodyne)]
    sensor: Sensor,
    /// Parallel episodes (default: one per core).
    #[arg(long)]
    jobs: Option<usize>,
    /// One JSON line per episode on standard output, after the tables.
    #[arg(long)]
    json: bool,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// What one obstacle did in one episode.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct ObstacleRecord {
    /// Index into the scene's objects.
    pub object: usize,
    /// What it is ("trunk 0.30 m wide, 5.0 m tall").
    pub label: String,
    /// Scans with the obstacle within `[d_min, d_max]`.
    pub in_range: u64,
    /// In range, but fewer than `min_returns` beams meet it even without grass.
    pub out_of_beam: u64,
    /// Enough beams meet it, but fewer than `min_returns` returns come back from it.
    pub hidden: u64,
    /// Hidden scans with 1 to `min_returns − 1` returns on it.
    pub glimpsed: u64,
    /// Scans with at least `min_returns` returns on it in `[d_min, d_max]`.
    pub visible: u64,
    /// Visible scans in which it raised the alarm.
    pub alarmed: u64,
    /// Visible scans with at least `min_run` consecutive returns on it.
    pub visible_run: u64,
    /// Of those, the scans in which it raised the alarm.
    pub alarmed_run: u64,
    /// Scans in which it raised the alarm while not visible (from a glimpse).
    pub alarmed_not_visible: u64,
    /// First visible scan.
    pub first_visible: Option<u64>,
    /// Scans from the first visible scan to the first alarm it raised from then on.
    pub delay_scans: Option<u64>,
}

/// The record of one episode.
#[derive(Debug, Clone)]
pub struct Episode {
    /// World index (in the order given).
    pub world: usize,
    /// Robot profile name.
    pub robot: String,
    /// Motion.
    pub motion: Motion,
    /// Seed.
    pub seed: u64,
    /// Scans classified.
    pub scans: u64,
    /// Scans with the alarm raised.
    pub alarms: u64,
    /// Alarms with no obstacle-class return on an obstacle.
    pub false_alarms: u64,
    /// The robot touched something (moving runs stop there).
    pub contact: bool,
    /// Distance driven, m.
    pub driven_m: f64,
    /// The scanner.
    pub sensor: Sensor,
    /// Seconds per scan (60 / rpm, or the SICK's period).
    pub scan_s: f64,
    /// Classifier time, summed, ns.
    pub classify_ns: u128,
    /// Per obstacle.
    pub obstacles: Vec<ObstacleRecord>,
}

/// One beam's truth: the obstacle whose surface is its nearest opaque surface, and the
/// horizontal distance to it.
#[derive(Debug, Clone, Copy)]
struct BeamTruth {
    obstacle: Option<usize>,
    range_m: f32,
    azimuth_deg: f64,
}

/// Indices of the obstacles (opaque solid objects) and the other opaque objects of a scene.
fn obstacles_of(scene: &Scene) -> Vec<usize> {
    scene
        .objects
        .iter()
        .enumerate()
        .filter(|(_, o)| {
            o.class == cell_class::SOLID && matches!(o.material, Material::Opaque { .. })
        })
        .map(|(i, _)| i)
        .collect()
}

fn label(scene: &Scene, i: usize) -> String {
    match &scene.objects[i].shape {
        Shape::Cylinder { r, z1, .. } => {
            let kind = if *z1 >= 2.0 { "trunk" } else { "rock" };
            format!("{kind} {:.2} m wide, {:.2} m tall", 2.0 * r, z1)
        }
        Shape::Prism { z1, .. } => format!("pillar {z1:.2} m tall"),
        Shape::Sheet { z1, .. } => format!("wall {z1:.2} m tall"),
    }
}

/// The truth of `beam`: its range is the horizontal distance along the beam (from the sensor,
/// as the VLP-16's driver reports it) or, with `from`, the horizontal distance of the hit from
/// that point (the robot's axis, where the SICK's driver puts its returns).
fn beam_truth(scene: &Scene, opaque: &[usize], beam: &Beam, from: Option<[f64; 2]>) -> BeamTruth {
    let (o, d) = (beam.origin, beam.dir);
    let mut best = (f64::INFINITY, None);
    for &i in opaque {
        let obj = &scene.objects[i];
        let (c, r) = obj.bound;
        // quick reject on the bounding circle
        let (dx, dy) = (c[0] - o[0], c[1] - o[1]);
        let h = d[0].hypot(d[1]).max(1e-12);
        let (ux, uy) = (d[0] / h, d[1] / h);
        if (dx * uy - dy * ux).abs() > r + 0.01 || dx * ux + dy * uy < -r {
            continue;
        }
        if let Some(hit) = intersect(&obj.shape, o, d)
            && hit.t_in > 0.0
            && hit.t_in < best.0
        {
            best = (hit.t_in, Some(i));
        }
    }
    // the ground ends every downward beam
    if d[2] < -1e-9 && -o[2] / d[2] < best.0 {
        best = (-o[2] / d[2], None);
    }
    let range_m = match from {
        Some(p) if best.0.is_finite() => {
            (o[0] + best.0 * d[0] - p[0]).hypot(o[1] + best.0 * d[1] - p[1])
        }
        _ => best.0 * d[0].hypot(d[1]),
    };
    BeamTruth {
        obstacle: best.1,
        range_m: range_m as f32,
        azimuth_deg: beam.azimuth_deg,
    }
}

/// The per-scan scoring of an episode, shared by both scanners: the obstacles, their slots,
/// and the buffers reused from scan to scan.
struct Scorer {
    obstacles: Vec<usize>,
    opaque: Vec<usize>,
    /// Scene object → index into `obstacles` (`usize::MAX`: not an obstacle).
    slot: Vec<usize>,
    d_min: f32,
    d_max: f32,
    min_returns: usize,
    min_run: usize,
    los: Vec<usize>,
    on: Vec<usize>,
    hits: Vec<usize>,
    /// Per obstacle: the longest run of consecutive returns on it.
    longest: Vec<usize>,
    on_return: Vec<Option<usize>>,
}

impl Scorer {
    fn new(config: &Config, scene: &Scene, min_returns: usize, min_run: usize) -> Self {
        let obstacles = obstacles_of(scene);
        let opaque: Vec<usize> = scene
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| matches!(o.material, Material::Opaque { .. }))
            .map(|(i, _)| i)
            .collect();
        let mut slot = vec![usize::MAX; scene.objects.len()];
        for (k, &i) in obstacles.iter().enumerate() {
            slot[i] = k;
        }
        let n = obstacles.len();
        Scorer {
            obstacles,
            opaque,
            slot,
            d_min: config.foliage.d_min_m,
            d_max: config.foliage.d_max_m,
            min_returns,
            min_run,
            los: vec![0; n],
            on: vec![0; n],
            hits: vec![0; n],
            longest: vec![0; n],
            on_return: Vec::new(),
        }
    }

    /// An episode's record before its first scan.
    fn episode(
        &self,
        scene: &Scene,
        world: usize,
        robot: &str,
        motion: Motion,
        seed: u64,
    ) -> Episode {
        Episode {
            world,
            robot: robot.to_string(),
            motion,
            seed,
            scans: 0,
            alarms: 0,
            false_alarms: 0,
            contact: false,
            driven_m: 0.0,
            sensor: Sensor::Velodyne,
            scan_s: 0.0,
            classify_ns: 0,
            obstacles: self
                .obstacles
                .iter()
                .map(|&i| ObstacleRecord {
                    object: i,
                    label: label(scene, i),
                    ..ObstacleRecord::default()
                })
                .collect(),
        }
    }

    /// Scores one classified scan: `scan[i]` was measured along the beam whose truth is
    /// `truth[i]` and classed `verdict[i]`; `alarm` is the verdict's flag and `pose` the robot's
    /// position when the scan was taken.
    #[allow(clippy::too_many_arguments)]
    fn score(
        &mut self,
        episode: &mut Episode,
        scene: &Scene,
        scan: &[ScanReturn],
        truth: &[BeamTruth],
        verdict: &[FoliageReturn],
        alarm: bool,
        pose: [f64; 2],
    ) {
        let (d_min, d_max) = (self.d_min, self.d_max);
        self.on_return.clear();
        self.los.fill(0);
        self.on.fill(0);
        self.hits.fill(0);
        self.longest.fill(0);
        // the run going on: (obstacle, returns so far); a return is on one obstacle at most
        let mut run: Option<(usize, usize)> = None;
        for (r, t) in scan.iter().zip(truth) {
            let k = t
                .obstacle
                .map(|i| self.slot[i])
                .filter(|&k| k != usize::MAX);
            let near = |x: f32| x >= d_min && x <= d_max;
            if let Some(k) = k
                && near(t.range_m)
            {
                self.los[k] += 1;
            }
            let is_on =
                k.filter(|_| r.range_m > 0.0 && (r.range_m - t.range_m).abs() <= ON_OBSTACLE_TOL_M);
            let counted = is_on.filter(|_| near(r.range_m));
            if let Some(k) = counted {
                self.on[k] += 1;
            }
            run = counted.map(|k| match run {
                Some((j, len)) if j == k => (k, len + 1),
                _ => (k, 1),
            });
            if let Some((k, len)) = run {
                self.longest[k] = self.longest[k].max(len);
            }
            self.on_return.push(is_on);
        }
        let mut on_any = false;
        for (c, o) in verdict.iter().zip(&self.on_return) {
            if c.class == foliage_class::OBSTACLE
                && let Some(k) = *o
            {
                self.hits[k] += 1;
                on_any = true;
            }
        }
        episode.alarms += u64::from(alarm);
        episode.false_alarms += u64::from(alarm && !on_any);
        let (min_returns, min_run) = (self.min_returns, self.min_run);
        for (k, rec) in episode.obstacles.iter_mut().enumerate() {
            let dist = footprint_distance(&scene.objects[rec.object].shape, pose) as f32;
            let in_range = dist >= d_min && dist <= d_max;
            let visible = self.on[k] >= min_returns;
            let alarmed = self.hits[k] > 0;
            if in_range {
                rec.in_range += 1;
                if self.los[k] < min_returns && !visible {
                    rec.out_of_beam += 1;
                } else if !visible {
                    rec.hidden += 1;
                    rec.glimpsed += u64::from(self.on[k] > 0);
                }
            }
            if visible {
                rec.visible += 1;
                rec.alarmed += u64::from(alarmed);
                if self.longest[k] >= min_run {
                    rec.visible_run += 1;
                    rec.alarmed_run += u64::from(alarmed);
                }
                if rec.first_visible.is_none() {
                    rec.first_visible = Some(episode.scans);
                }
            } else {
                rec.alarmed_not_visible += u64::from(alarmed);
            }
            if alarmed
                && rec.delay_scans.is_none()
                && let Some(f) = rec.first_visible
            {
                rec.delay_scans = Some(episode.scans - f);
            }
        }
        episode.scans += 1;
    }
}

/// Runs one episode with the VLP-16.
#[allow(clippy::too_many_arguments)]
pub fn run_episode(
    config: &Config,
    scene: &Scene,
    world: usize,
    motion: Motion,
    speed: f64,
    seed: u64,
    scans: u64,
    min_returns: usize,
    min_run: usize,
) -> Result<Episode> {
    let mut scene = scene.clone();
    // the episode ends after `scans` revolutions, not at the world's time limit
    scene.time_limit_s = f64::INFINITY;
    let mut scorer = Scorer::new(config, &scene, min_returns, min_run);
    // the deployed classifier's step, on the driver's scans, with the simulator's odometry
    let options = Options {
        map: MapSource::None,
        foliage: FoliageUse::Classify,
        inflation: None,
        drive: Drive::External,
    };
    let mut stack = Lockstep::new(config, scene.clone(), seed, options)?;
    if motion == Motion::Moving {
        stack.sim_mut().set_command(speed, 0.0);
    }
    let laser = usize::from(config.velodyne.scan_laser);
    let mut episode = scorer.episode(&scene, world, &config.robot.name, motion, seed);
    episode.scan_s = 60.0 / config.velodyne.rpm;
    let (mut beams, mut truth) = (Vec::new(), Vec::<BeamTruth>::new());
    while episode.scans < scans {
        if stack.sim().outcome() != Outcome::Running {
            episode.contact = matches!(stack.sim().outcome(), Outcome::Contact(_));
            break;
        }
        stack.sim().next_beams(laser, &mut beams);
        truth.extend(
            beams
                .iter()
                .map(|b| beam_truth(&scene, &scorer.opaque, b, None)),
        );
        let Some(turn) = stack.step()? else {
            continue;
        };
        episode.classify_ns += u128::from(turn.classify_ns);
        let (scan, verdict) = (stack.scan(), stack.verdict());
        anyhow::ensure!(
            truth.len() >= scan.len(),
            "internal: the scan has {} returns but the laser fired {} beams",
            scan.len(),
            truth.len()
        );
        // the planar scan holds one return per firing of the laser, in firing order
        for (r, t) in scan.iter().zip(&truth) {
            let az = -f64::from(r.angle_rad).to_degrees();
            let off = (az - t.azimuth_deg).rem_euclid(360.0);
            anyhow::ensure!(
                off.min(360.0 - off) < 0.05,
                "internal: scan return at {az:.2}° against the beam at {:.2}°",
                t.azimuth_deg
            );
        }
        let alarm = turn.foliage.is_some_and(|h| h.alarm != 0);
        let p = stack.sim().base().pose;
        scorer.score(
            &mut episode,
            &scene,
            scan,
            &truth[..scan.len()],
            verdict,
            alarm,
            [p.x(), p.y()],
        );
        truth.drain(..scan.len());
    }
    episode.driven_m = stack.sim().path_length_m();
    Ok(episode)
}

/// Runs one episode with the simulated SICK of `config.sick`: the base drives without the
/// VLP-16 ([`Sim::idle`]); every period of the scanner a scan is cast from the robot's pose
/// ([`Sim::sick_scan`]), written as the emulated device's `LMDscandata` telegram in
/// `sick.protocol`, read by the driver's [`Session`] (whose start-up exchange with the device
/// ran once at the episode's start: login, scan mode, output, echoes, stream), converted with
/// `sick.converter()` and classified by `config.scan_step()` with the simulator's odometry of
/// the scan's instant, as the foliage service gets them. The truth of each measurement is its
/// beam's ([`Sim::sick_beams`]), measured from the robot's axis as the converted returns are.
#[allow(clippy::too_many_arguments)]
pub fn run_sick_episode(
    config: &Config,
    scene: &Scene,
    world: usize,
    motion: Motion,
    speed: f64,
    seed: u64,
    scans: u64,
    min_returns: usize,
    min_run: usize,
) -> Result<Episode> {
    let mut config = config.clone();
    config.foliage.source = ScanSource::Sick;
    let sick = &config.sick;
    sick.mode().map_err(|e| anyhow::anyhow!("[sick]: {e}"))?;
    let mut scene = scene.clone();
    scene.time_limit_s = f64::INFINITY;
    let mut scorer = Scorer::new(&config, &scene, min_returns, min_run);
    let mut sim = Sim::new(scene.clone(), config.sim_settings(), seed, DEFAULT_EPOCH_NS);
    if motion == Motion::Moving {
        sim.set_command(speed, 0.0);
    }
    // the driver's start-up exchange with the emulated scanner, as over TCP
    let mut device = Device::new(sick.model, sick.protocol, seed as u32);
    let mut session = Session::new(sick.session());
    let (mut to_device, mut to_driver) = (Vec::new(), Vec::new());
    let mono = |sim: &Sim| sim.now_ns() - DEFAULT_EPOCH_NS;
    session.begin(mono(&sim), &mut to_device);
    let mut refused = None;
    for _ in 0..64 {
        if session.streaming() || to_device.is_empty() {
            break;
        }
        device.receive(&to_device, &mut to_driver);
        to_device.clear();
        session.receive(&to_driver, mono(&sim), &mut to_device, |e| {
            if let Event::Refused { request, why } = e {
                refused = Some(format!("{request:?}: {why}"));
            }
        });
        to_driver.clear();
    }
    if let Some(r) = refused {
        anyhow::bail!("the simulated {} refused {r}", sick.model.spec().name);
    }
    anyhow::ensure!(
        session.streaming() && device.streaming(),
        "internal: the SICK session did not start streaming"
    );
    let g = device.geometry();
    let period_ns = (1e9 / g.frequency_hz).round() as u64;
    let mut scanner = SickScanner::new(sick, &config.sim, seed);
    let mut step = config.scan_step()?;
    let converter = sick.converter();
    let mut episode = scorer.episode(&scene, world, &config.robot.name, motion, seed);
    (episode.sensor, episode.scan_s) = (Sensor::Sick, 1.0 / g.frequency_hz);
    let (mut beams, mut truth) = (Vec::new(), Vec::<BeamTruth>::new());
    let (mut measured, mut wire, mut returns) = (SickScan::default(), Vec::new(), Vec::new());
    while episode.scans < scans {
        if sim.outcome() != Outcome::Running {
            episode.contact = matches!(sim.outcome(), Outcome::Contact(_));
            break;
        }
        let p = sim.base().pose;
        let axis = [p.x(), p.y()];
        sim.sick_beams(&scanner, &g, &mut beams);
        truth.clear();
        truth.extend(
            beams
                .iter()
                .map(|b| beam_truth(&scene, &scorer.opaque, b, Some(axis))),
        );
        sim.sick_scan(&mut scanner, &g, &mut measured);
        wire.clear();
        let time_us = (mono(&sim) / 1000) as u32;
        device.scan_telegram(time_us, &measured.echoes, &measured.remission, &mut wire);
        let now = mono(&sim);
        let (mut got, mut failed) = (false, None);
        session.receive(&wire, now, &mut to_device, |e| match e {
            Event::Scan(sd) => match converter.convert(sd, &mut returns) {
                Ok(_) => got = true,
                Err(e) => failed = Some(e.to_string()),
            },
            Event::BadScan(e) => failed = Some(e.to_string()),
            Event::Frame(e) => failed = Some(format!("{e:?}")),
            _ => {}
        });
        if let Some(f) = failed {
            anyhow::bail!("internal: the SICK driver refused the simulated scan: {f}");
        }
        anyhow::ensure!(got, "internal: the SICK driver made no scan of a telegram");
        anyhow::ensure!(
            returns.len() == truth.len(),
            "internal: the scan has {} returns but the scanner measured {}",
            returns.len(),
            truth.len()
        );
        step.odom(&sim.odometry(episode.scans, now))
            .map_err(|e| anyhow::anyhow!("internal: {e}"))?;
        let header = ScanHeader {
            seq: episode.scans,
            stamp_ns: sim.now_ns(),
            rx_mono_ns: now,
            count: returns.len() as u32,
            return_select: converter.echo.return_type(),
            ..ScanHeader::default()
        };
        let t0 = std::time::Instant::now();
        let classified = step.scan(&header, &returns, now);
        episode.classify_ns += t0.elapsed().as_nanos();
        let alarm = classified.header.alarm != 0;
        scorer.score(
            &mut episode,
            &scene,
            &returns,
            &truth,
            classified.returns,
            alarm,
            axis,
        );
        sim.idle(period_ns);
    }
    episode.driven_m = sim.path_length_m();
    Ok(episode)
}

/// Per world, robot and motion: the sums the tables show.
#[derive(Debug, Clone, Default)]
struct Summary {
    episodes: usize,
    scans: u64,
    alarms: u64,
    false_alarms: u64,
    contacts: usize,
    obstacles: usize,
    in_range: u64,
    out_of_beam: u64,
    hidden: u64,
    glimpsed: u64,
    visible: u64,
    alarmed: u64,
    visible_run: u64,
    alarmed_run: u64,
    /// Obstacle-episodes that became visible, and of those never alarmed.
    onsets: u64,
    never: u64,
    delays: Vec<u64>,
    classify_ns: u128,
    scan_s: f64,
}

impl Summary {
    fn add(&mut self, e: &Episode) {
        self.episodes += 1;
        self.scans += e.scans;
        self.alarms += e.alarms;
        self.false_alarms += e.false_alarms;
        self.contacts += usize::from(e.contact);
        self.classify_ns += e.classify_ns;
        self.scan_s = e.scan_s;
        self.obstacles = e.obstacles.len();
        for o in &e.obstacles {
            self.in_range += o.in_range;
            self.out_of_beam += o.out_of_beam;
            self.hidden += o.hidden;
            self.glimpsed += o.glimpsed;
            self.visible += o.visible;
            self.alarmed += o.alarmed;
            self.visible_run += o.visible_run;
            self.alarmed_run += o.alarmed_run;
            if o.first_visible.is_some() {
                self.onsets += 1;
                match o.delay_scans {
                    Some(d) => self.delays.push(d),
                    None => self.never += 1,
                }
            }
        }
    }

    fn per_1000(&self) -> f64 {
        1000.0 * self.false_alarms as f64 / self.scans.max(1) as f64
    }

    fn detection(&self) -> Option<f64> {
        (self.visible > 0).then(|| self.alarmed as f64 / self.visible as f64)
    }

    fn detection_run_text(&self) -> String {
        if self.visible_run == 0 {
            return "–".into();
        }
        format!(
            "{} → {:.1} % ({})",
            self.visible_run,
            100.0 * self.alarmed_run as f64 / self.visible_run as f64,
            self.alarmed_run
        )
    }

    fn delay_text(&self) -> String {
        if self.delays.is_empty() {
            return "–".into();
        }
        let mean = self.delays.iter().sum::<u64>() as f64 / self.delays.len() as f64;
        let max = self.delays.iter().copied().max().unwrap_or(0);
        format!(
            "{mean:.2} / {max} ({:.2} s / {:.1} s)",
            mean * self.scan_s,
            max as f64 * self.scan_s
        )
    }
}

fn foliage_worlds(config: &Config) -> Result<Vec<PathBuf>> {
    let dir = config
        .sim
        .world_path(&config.dir())
        .parent()
        .map_or_else(|| PathBuf::from("foliage"), |p| p.join("foliage"));
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| {
            format!(
                "cannot list the foliage worlds in {}: name worlds with --world",
                dir.display()
            )
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    v.sort();
    anyhow::ensure!(
        !v.is_empty(),
        "no *.toml worlds in {}: name worlds with --world",
        dir.display()
    );
    Ok(v)
}

fn toml_quote(s: &str) -> String {
    format!("\"{}\"", s.replace('\\', "\\\\").replace('"', "\\\""))
}

/// Runs the evaluation and prints the tables.
pub fn run(
    config: &Config,
    config_path: Option<&Path>,
    sets: &[String],
    args: &FoliageEvalArgs,
) -> Result<ExitCode> {
    anyhow::ensure!(args.seeds > 0, "--seeds must be at least 1");
    anyhow::ensure!(
        (1..=1_000_000).contains(&args.scans),
        "--scans {} is out of range: allowed 1 to 1000000",
        args.scans
    );
    anyhow::ensure!(args.min_returns >= 1, "--min-returns must be at least 1");
    anyhow::ensure!(args.min_run >= 1, "--min-run must be at least 1");
    if let Some(s) = args.speed {
        anyhow::ensure!(
            s.is_finite() && s > 0.0,
            "--speed {s} is out of range: a speed above 0 m/s"
        );
    }
    // one config per robot profile
    let mut configs = Vec::new();
    if args.robots.is_empty() {
        configs.push(config.clone());
    } else {
        for r in &args.robots {
            let mut s = sets.to_vec();
            s.push(format!("robot.profile={}", toml_quote(r)));
            let c = Config::resolve(config_path, &s)
                .map_err(|e| anyhow::anyhow!("--robot {r}: {e}"))?;
            configs.push(c);
        }
    }
    // the classifier runs as the stack with this scanner runs it (foliage.source)
    for c in &mut configs {
        c.foliage.source = match args.sensor {
            Sensor::Velodyne => ScanSource::Velodyne,
            Sensor::Sick => ScanSource::Sick,
        };
    }
    let mut speeds = Vec::new();
    for c in &configs {
        let top = c.robot.max_linear_mps;
        let v = args.speed.unwrap_or(top);
        anyhow::ensure!(
            v <= top + 1e-9,
            "--speed {v} is above {}'s top speed, {top} m/s",
            c.robot.name
        );
        speeds.push(v);
        c.foliage
            .validate()
            .map_err(|e| anyhow::anyhow!("[foliage]: {e}"))?;
    }
    let sick_mode = match args.sensor {
        Sensor::Sick => config
            .sick
            .mode()
            .map_err(|e| anyhow::anyhow!("[sick]: {e}"))?,
        Sensor::Velodyne => (0.0, 0.0),
    };
    let paths = if args.worlds.is_empty() {
        foliage_worlds(config)?
    } else {
        args.worlds.clone()
    };
    let mut scenes = Vec::new();
    for p in &paths {
        scenes.push(WorldFile::load(p)?.compile());
    }
    let motions = if args.motions.is_empty() {
        vec![Motion::Standing, Motion::Moving]
    } else {
        let mut m = args.motions.clone();
        m.sort();
        m.dedup();
        m
    };
    let mut jobs = Vec::new();
    for w in 0..scenes.len() {
        for r in 0..configs.len() {
            for &m in &motions {
                for s in 0..args.seeds {
                    jobs.push((w, r, m, args.first_seed + s));
                }
            }
        }
    }
    let workers = crate::pool::workers(args.jobs);
    let started = std::time::Instant::now();
    let episode = match args.sensor {
        Sensor::Velodyne => run_episode,
        Sensor::Sick => run_sick_episode,
    };
    let results = crate::pool::run_all(&jobs, workers, args.quiet, |&(w, r, m, seed), _| {
        episode(
            &configs[r],
            &scenes[w],
            w,
            m,
            speeds[r],
            seed,
            args.scans,
            args.min_returns,
            args.min_run,
        )
        .with_context(|| {
            format!(
                "{}, {}, {}, seed {seed}",
                scenes[w].name,
                configs[r].robot.name,
                m.name()
            )
        })
    });
    let mut episodes = results.into_iter().collect::<Result<Vec<_>>>()?;
    episodes.sort_by(|a, b| {
        (a.world, &a.robot, a.motion, a.seed).cmp(&(b.world, &b.robot, b.motion, b.seed))
    });
    let wall = started.elapsed().as_secs_f64();

    let robots: Vec<String> = configs.iter().map(|c| c.robot.name.clone()).collect();
    let mut rows = Vec::new();
    for (w, scene) in scenes.iter().enumerate() {
        for (r, robot) in robots.iter().enumerate() {
            for &m in &motions {
                let mut s = Summary::default();
                for e in episodes
                    .iter()
                    .filter(|e| e.world == w && &e.robot == robot && e.motion == m)
                {
                    s.add(e);
                }
                rows.push((scene, r, m, s));
            }
        }
    }
    let p = configs[0].foliage_params();
    let scanner = match args.sensor {
        Sensor::Velodyne => format!(
            "VLP-16 laser {} ({})",
            config.velodyne.scan_laser,
            match config.velodyne.scan_return {
                mimnav_velodyne::config::ScanReturnSelect::Strongest => "strongest return",
                mimnav_velodyne::config::ScanReturnSelect::Last => "last return",
            }
        ),
        Sensor::Sick => {
            let (k, (f, step)) = (&config.sick, sick_mode);
            // what the scanner measures (one echo: sim.sick_echo) and what the driver takes
            let measured = match (k.model.spec().echoes, config.sim.sick_echo) {
                (2.., _) => "every echo",
                (_, SickEcho::Strongest) => "the strongest echo",
                (_, SickEcho::First) => "the first echo",
                (_, SickEcho::Last) => "the last echo",
            };
            format!(
                "SICK {} at {f} Hz, {step:.4}° steps, sending {measured}, the driver taking the {} echo, {} m up",
                k.model.spec().name,
                match k.echo {
                    mimnav_sick::convert::Echo::First => "first",
                    mimnav_sick::convert::Echo::Last => "last",
                },
                k.mount.z_m
            )
        }
    };
    outln!(
        "{} seeds (from seed {}) × {} scans per world, robot and motion; {scanner}, d = [{}, {}] m, window {:.2}°; moving: straight at {}",
        args.seeds,
        args.first_seed,
        args.scans,
        p.d_min_m,
        p.d_max_m,
        p.window_rad.to_degrees(),
        robots
            .iter()
            .zip(&speeds)
            .map(|(r, v)| format!("{v} m/s ({r})"))
            .collect::<Vec<_>>()
            .join(", ")
    )?;
    outln!("\nFalse alarms (an alarm with no obstacle-class return on an obstacle):\n")?;
    outln!(
        "| world | robot | motion | scans | alarms | false alarms | per 1000 scans | classifier µs/scan |"
    )?;
    outln!("|---|---|---|---|---|---|---|---|")?;
    let (mut grass, mut all) = (Summary::default(), Summary::default());
    for (scene, r, m, s) in &rows {
        outln!(
            "| {} | {} | {} | {} | {} | {} | {:.2} | {:.0} |",
            scene.name,
            robots[*r],
            m.name(),
            s.scans,
            s.alarms,
            s.false_alarms,
            s.per_1000(),
            s.classify_ns as f64 / 1e3 / s.scans.max(1) as f64
        )?;
        let target = if s.obstacles == 0 {
            &mut grass
        } else {
            &mut all
        };
        target.scans += s.scans;
        target.false_alarms += s.false_alarms;
    }
    let with_obstacles: Vec<_> = rows.iter().filter(|r| r.3.obstacles > 0).collect();
    let mut det = Summary::default();
    if !with_obstacles.is_empty() {
        outln!(
            "\nDetection (obstacle-scans: one obstacle in one scan; visible: ≥ {} returns on it within [d_min, d_max]; alarmed: an obstacle-class return on it; as a run: visible with ≥ {} of those returns consecutive):\n",
            args.min_returns,
            args.min_run
        )?;
        outln!(
            "| world | robot | motion | in range | out of the beam | hidden by grass (glimpsed) | visible | alarmed | visible as a run → alarmed | delay mean / max, scans (s) | visible, never alarmed | alarmed from a glimpse |"
        )?;
        outln!("|---|---|---|---|---|---|---|---|---|---|---|---|")?;
        for (scene, r, m, s) in with_obstacles {
            let glimpse_alarms: u64 = episodes
                .iter()
                .filter(|e| {
                    scenes[e.world].name == scene.name && e.robot == robots[*r] && e.motion == *m
                })
                .flat_map(|e| &e.obstacles)
                .map(|o| o.alarmed_not_visible)
                .sum();
            outln!(
                "| {} | {} | {} | {} | {} | {} ({}) | {} | {} | {} | {} | {} of {} | {} |",
                scene.name,
                robots[*r],
                m.name(),
                s.in_range,
                s.out_of_beam,
                s.hidden,
                s.glimpsed,
                s.visible,
                s.detection().map_or_else(
                    || "–".to_string(),
                    |d| format!("{:.1} % ({})", 100.0 * d, s.alarmed)
                ),
                s.detection_run_text(),
                s.delay_text(),
                s.never,
                s.onsets,
                glimpse_alarms,
            )?;
            det.visible += s.visible;
            det.alarmed += s.alarmed;
            det.visible_run += s.visible_run;
            det.alarmed_run += s.alarmed_run;
            det.delays.extend_from_slice(&s.delays);
            det.never += s.never;
            det.onsets += s.onsets;
            det.scan_s = s.scan_s;
        }
    }
    let contacts: usize = rows.iter().map(|r| r.3.contacts).sum();
    if contacts > 0 {
        outln!("\n{contacts} moving episodes touched an obstacle and stopped there")?;
    }
    if args.json {
        outln!()?;
        for e in &episodes {
            let line = serde_json::json!({
                "world": scenes[e.world].name,
                "robot": e.robot,
                "motion": e.motion.name(),
                "seed": e.seed,
                "sensor": e.sensor.name(),
                "scans": e.scans,
                "alarms": e.alarms,
                "false_alarms": e.false_alarms,
                "contact": e.contact,
                "driven_m": e.driven_m,
                "obstacles": e.obstacles,
            });
            outln!("{line}")?;
        }
    }
    all.scans += grass.scans;
    all.false_alarms += grass.false_alarms;
    outln!(
        "\n{} episodes in {wall:.0} s on {workers} threads",
        episodes.len()
    )?;
    let verdict = |ok: bool| if ok { "met" } else { "MISSED" };
    if grass.scans > 0 {
        outln!(
            "pure grass: {} false alarms in {} scans, {:.2} per 1000 (target ≤ {TARGET_FALSE_PER_1000}: {}); all worlds: {} in {}, {:.2} per 1000",
            grass.false_alarms,
            grass.scans,
            grass.per_1000(),
            verdict(grass.per_1000() <= TARGET_FALSE_PER_1000),
            all.false_alarms,
            all.scans,
            all.per_1000()
        )?;
    }
    if let Some(d) = det.detection() {
        outln!(
            "visible obstacles: alarmed in {} of {} obstacle-scans, {:.2} % (target ≥ {:.0} %: {}); delay mean / max {} scans; {} of {} never alarmed",
            det.alarmed,
            det.visible,
            100.0 * d,
            100.0 * TARGET_DETECTION,
            verdict(d >= TARGET_DETECTION),
            det.delay_text(),
            det.never,
            det.onsets
        )?;
        outln!(
            "  of those, visible as a run (≥ {} consecutive returns on it): {}",
            args.min_run,
            det.detection_run_text()
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
