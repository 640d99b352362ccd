//! The lock-step runner: the simulator and the services' own step types in one process.
//!
//! A deployed stack is four processes: the simulator (or a robot) sends packets and `odom`, the
//! driver ([`Driver`]) assembles revolutions, the mapper ([`MapStep`]) maps each, the foliage
//! classifier ([`ScanStep`]) classifies its planar scan, and the planner ([`Pilot`]) turns the
//! map into the command the base follows. Each service's `main.rs` only moves messages between
//! topics and these types. [`Lockstep`] moves the same messages between the same types in one
//! thread, in the order the simulator's lock-step mode (`mimnav-sim --lockstep`) makes the
//! processes see them:
//!
//! 1. the simulator casts one packet and moves the base for one packet period;
//! 2. when that packet completes a revolution, the base's odometry goes to the mapper, the
//!    classifier and the planner first (the simulator publishes it before the packet);
//! 3. the packet goes through the driver; the slice of packets it completes goes to the mapper,
//!    which bins it at once (`lidar/slices`, `velodyne.slice_packets`); a revolution it finishes
//!    is mapped from its last slice and its planar scan goes to the classifier;
//! 4. the map goes to the planner, whose command the simulator follows from the next packet on.
//!
//! The clock every step type is given is the simulator's (sensor time, ns): all inputs are
//! fresh when they should be and the run is deterministic for a seed. `mimnav eval`,
//! `mimnav score-map` and `mimnav foliage-eval` run their episodes through this type, so their
//! figures certify the code the services run; `tests/lockstep.rs` checks the processes give
//! the same commands.

use std::time::{Duration, Instant};

use mimnav_config::Config;
use mimnav_foliage::step::{ScanStep, StepError};
use mimnav_mapper::baseline::{cloud_occupancy, scan_occupancy};
use mimnav_mapper::step::{MapStep, Mapped};
use mimnav_planner::inflate::Inflation;
use mimnav_planner::pilot::{Decision, Pilot, Refused};
use mimnav_shared::faults::Faults;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::{
    FoliageHeader, FoliageReturn, Goal, MapHeader, PointsHeader, ScanReturn, VelocityCommand,
};
use mimnav_sim::world::Scene;
use mimnav_sim::{Outcome, Sim};
use mimnav_velodyne::decode::ScanReturnSelect;
use mimnav_velodyne::driver::{Driver, Kind};
use mimnav_velodyne::revolution::AssemblerConfig;

/// What the planner plans on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MapSource {
    /// The mapper's intensity map (what the services run).
    Intensity,
    /// Baseline: the planar scan of one laser, its strongest returns, every return solid.
    LaserScan,
    /// Baseline: every return in the robot's height band solid.
    Occupancy,
    /// No map at all (the foliage evaluation, which drives by itself).
    None,
}

/// What becomes of the foliage classifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FoliageUse {
    /// Not run.
    Off,
    /// Run on every revolution's planar scan; its verdicts do not reach the planner.
    Classify,
    /// Run, and the obstacles it confirms are solid for the planner (`planner.use_foliage`).
    InLoop,
}

/// Who commands the base.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Drive {
    /// The planner, toward the goal ([`Lockstep::set_goal`]).
    Planner,
    /// The caller, through [`Lockstep::sim_mut`] (a survey route, a fixed speed).
    External,
}

/// How a run is put together.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// The planner's map.
    pub map: MapSource,
    /// The foliage classifier.
    pub foliage: FoliageUse,
    /// `Some`: this inflation instead of `planner.inflation`.
    pub inflation: Option<Inflation>,
    /// Who commands the base.
    pub drive: Drive,
}

impl Options {
    /// The stack as the config deploys it: the intensity map, the planner driving, the foliage
    /// classifier in the loop when `planner.use_foliage` is set.
    pub fn deployed(config: &Config) -> Self {
        Options {
            map: MapSource::Intensity,
            foliage: match config.planner.use_foliage {
                true => FoliageUse::InLoop,
                false => FoliageUse::Off,
            },
            inflation: None,
            drive: Drive::Planner,
        }
    }
}

/// Why a run cannot start or go on.
#[derive(Debug, thiserror::Error)]
pub enum RunnerError {
    /// The foliage classifier's settings do not validate.
    #[error(transparent)]
    Foliage(#[from] StepError),
    /// The planner refused an input (a non-finite goal or odometry).
    #[error(transparent)]
    Refused(#[from] Refused),
    /// The driver refused a packet the simulator made: a simulator or driver defect.
    #[error("the driver refused simulated packet {packet}: {faults}")]
    Packet {
        /// The packet's number in the run.
        packet: u64,
        /// The driver's fault counts.
        faults: String,
    },
}

/// What the stack did with one revolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Turn {
    /// The driver's header of the revolution.
    pub points: PointsHeader,
    /// The mapper's result (with [`MapSource::Intensity`]).
    pub mapped: Option<Mapped>,
    /// The classifier's verdict header (with the classifier running).
    pub foliage: Option<FoliageHeader>,
    /// The planner's decision and the command sent for it (with [`Drive::Planner`]).
    pub command: Option<(Decision, VelocityCommand)>,
    /// Time the map took after the revolution's last packet (the mapper's last slice and the
    /// map, or a baseline), ns.
    pub map_ns: u64,
    /// Time the mapper spent binning the revolution's slices before its last packet, ns.
    pub bin_ns: u64,
    /// Time the classifier took, ns.
    pub classify_ns: u64,
    /// Time the planner took, ns.
    pub plan_ns: u64,
}

/// The simulator and the stack in one thread (see the crate's documentation).
#[derive(Debug)]
pub struct Lockstep {
    sim: Sim,
    options: Options,
    driver: Driver,
    faults: Faults,
    map: MapStep,
    scan: Option<ScanStep>,
    pilot: Pilot,
    grid: GridSpec,
    /// The occupancy baseline's height band: sensor height, low, high (m).
    band: (f32, f32, f32),
    baseline: Vec<u8>,
    last_scan: Vec<ScanReturn>,
    odom_seq: u64,
    packets: u64,
    /// `velodyne.slice_packets`: the mapper bins the revolution in slices as it arrives.
    slice_packets: u32,
    /// Binning of the revolution under way so far, ns.
    bin_ns: u64,
}

fn elapsed_ns(since: Instant) -> u64 {
    since.elapsed().as_nanos().min(u128::from(u64::MAX)) as u64
}

impl Lockstep {
    /// A run of `scene` with the config's settings and `seed`, put together by `options`.
    /// The sensor's clock starts at [`mimnav_sim::DEFAULT_EPOCH_NS`].
    pub fn new(
        config: &Config,
        scene: Scene,
        seed: u64,
        options: Options,
    ) -> Result<Self, RunnerError> {
        let mut asm = AssemblerConfig::from_config(&config.velodyne);
        if options.map == MapSource::LaserScan {
            // the paper's baseline is a single-return planar scanner: the strongest echo, which
            // in grass is a blade (the last return would see through the grass)
            asm.velodyne.scan_return = ScanReturnSelect::Strongest;
        }
        let v = &config.velodyne;
        let mut planner = config.planner_params();
        if let Some(inflation) = options.inflation {
            planner.planner.inflation = inflation;
        }
        planner.planner.use_foliage = options.foliage == FoliageUse::InLoop;
        let scan = match options.foliage {
            FoliageUse::Off => None,
            FoliageUse::Classify | FoliageUse::InLoop => Some(config.scan_step()?),
        };
        let r = &config.robot;
        Ok(Lockstep {
            sim: Sim::new(
                scene,
                config.sim_settings(),
                seed,
                mimnav_sim::DEFAULT_EPOCH_NS,
            ),
            options,
            driver: Driver::new(asm, v.data_port, v.position_port),
            faults: Faults::new(Duration::from_secs(10)),
            map: config.map_step(),
            scan,
            pilot: Pilot::new(planner),
            grid: config.map.grid(),
            band: (
                r.sensor_height_m as f32,
                config.mapper.ground_clearance_m as f32,
                r.height_m.max(r.sensor_height_m) as f32 + 0.1,
            ),
            baseline: Vec::new(),
            last_scan: Vec::new(),
            odom_seq: 0,
            packets: 0,
            slice_packets: v.slice_packets,
            bin_ns: 0,
        })
    }

    /// Gives the planner the goal (x, y) in the odometry frame, reached within `tolerance_m`,
    /// stamped now: what `mimnav goal X Y --tolerance T` sends.
    pub fn set_goal(&mut self, x: f64, y: f64, tolerance_m: f64) -> Result<(), RunnerError> {
        let seq = self.pilot.current_goal().map_or(0, |g| g.seq + 1);
        self.pilot.goal(&Goal {
            seq,
            stamp_mono_ns: self.sim.now_ns(),
            x,
            y,
            tolerance_m,
            ..Goal::default()
        })?;
        Ok(())
    }

    /// The simulator.
    pub fn sim(&self) -> &Sim {
        &self.sim
    }

    /// The pilot: its planner's cost and route of the last map (debugging, `examples/trace.rs`).
    pub fn pilot(&self) -> &Pilot {
        &self.pilot
    }

    /// The simulator, to command the base with [`Drive::External`].
    pub fn sim_mut(&mut self) -> &mut Sim {
        &mut self.sim
    }

    /// The classes of the map the last revolution made: what the planner planned on (with the
    /// foliage classifier's obstacles in the loop), else the map source's own.
    pub fn classes(&self) -> &[u8] {
        match (self.options.drive, self.options.map) {
            (Drive::Planner, _) => self.pilot.classes(),
            (Drive::External, MapSource::Intensity) => self.map.mapper().classes(),
            (Drive::External, _) => &self.baseline,
        }
    }

    /// The last revolution's planar scan, as the driver published it.
    pub fn scan(&self) -> &[ScanReturn] {
        &self.last_scan
    }

    /// The classifier's last verdict, one class per return of [`Lockstep::scan`] (empty without
    /// the classifier).
    pub fn verdict(&self) -> &[FoliageReturn] {
        self.scan.as_ref().map_or(&[], |s| s.returns())
    }

    /// One packet: casts it, moves the base, and runs the stack on it; returns what the stack
    /// did when the packet finished a revolution.
    pub fn step(&mut self) -> Result<Option<Turn>, RunnerError> {
        let step = self.sim.step();
        self.packets += 1;
        let now = self.sim.now_ns();
        if step.completes_revolution {
            let odom = self.sim.odometry(self.odom_seq, now);
            self.odom_seq += 1;
            // the simulator's odometry is finite: a refusal here is a simulator defect
            self.map.odom(&odom).map_err(Refused::from)?;
            if let Some(s) = &mut self.scan {
                s.odom(&odom).map_err(Refused::from)?;
            }
            self.pilot.odom(&odom)?;
        }
        let before = self.faults.total();
        let source = || format!("simulated packet {}", self.packets);
        let completed = (self.driver)
            .on_datagram(
                &step.data,
                Kind::Data,
                (step.first_firing_ns, now),
                Instant::now(),
                &mut self.faults,
                &source,
            )
            .is_some();
        if self.faults.total() != before {
            return Err(RunnerError::Packet {
                packet: self.packets,
                faults: self.faults.summary(),
            });
        }
        // the mapper bins the revolution as it arrives, as the service does from lidar/slices
        let (mut mapped, mut last_slice_ns) = (None, 0);
        if self.options.map == MapSource::Intensity && self.slice_packets > 0 {
            let (map, bin_ns) = (&mut self.map, &mut self.bin_ns);
            self.driver.take_slices(self.slice_packets, |h, points| {
                let started = Instant::now();
                let m = map.slice(h, points, now);
                match h.last {
                    0 => *bin_ns += elapsed_ns(started),
                    _ => last_slice_ns = elapsed_ns(started),
                }
                mapped = mapped.or(m);
            });
        }
        if !completed {
            return Ok(None);
        }
        let rev = self.driver.revolution();
        let mut turn = Turn {
            points: rev.header,
            mapped: None,
            foliage: None,
            command: None,
            map_ns: 0,
            bin_ns: std::mem::take(&mut self.bin_ns),
            classify_ns: 0,
            plan_ns: 0,
        };
        self.last_scan.clear();
        self.last_scan.extend_from_slice(&rev.scan);
        let started = Instant::now();
        match self.options.map {
            MapSource::Intensity => {
                turn.mapped = mapped.or_else(|| self.map.revolution(&rev.header, &rev.points, now))
            }
            MapSource::LaserScan => scan_occupancy(&rev.scan, self.grid, &mut self.baseline),
            MapSource::Occupancy => {
                let (sensor, low, high) = self.band;
                cloud_occupancy(
                    &rev.points,
                    self.grid,
                    sensor,
                    low,
                    high,
                    &mut self.baseline,
                )
            }
            MapSource::None => {}
        }
        turn.map_ns = elapsed_ns(started) + last_slice_ns;
        let scan_header = rev.scan_header;
        if let Some(s) = &mut self.scan {
            let started = Instant::now();
            let verdict = s.scan(&scan_header, &self.last_scan, now);
            turn.foliage = Some(verdict.header);
            turn.classify_ns = elapsed_ns(started);
            if self.options.foliage == FoliageUse::InLoop {
                self.pilot.foliage(&verdict.header, verdict.returns);
            }
        }
        if self.options.drive == Drive::Planner && self.options.map != MapSource::None {
            let started = Instant::now();
            let decision = match &turn.mapped {
                Some(m) => {
                    let mapper = self.map.mapper();
                    self.pilot
                        .on_map(&m.header, mapper.classes().iter().copied(), now)
                }
                None => {
                    let header = self.baseline_header(&turn.points);
                    self.pilot
                        .on_map(&header, self.baseline.iter().copied(), now)
                }
            };
            let command = self.pilot.command(&decision, now);
            turn.plan_ns = elapsed_ns(started);
            // the base follows the command as the message carries it (f32)
            (self.sim).set_command(f64::from(command.v), f64::from(command.omega));
            turn.command = Some((decision, command));
        }
        Ok(Some(turn))
    }

    /// Steps until a revolution is done and returns it; `None` once the episode has ended
    /// (the goal reached, a contact, or the world's time limit).
    pub fn next_revolution(&mut self) -> Result<Option<Turn>, RunnerError> {
        while self.sim.outcome() == Outcome::Running {
            if let Some(turn) = self.step()? {
                return Ok(Some(turn));
            }
        }
        Ok(None)
    }

    /// A baseline map's header, as a mapper would stamp it.
    fn baseline_header(&self, h: &PointsHeader) -> MapHeader {
        MapHeader {
            seq: h.seq,
            source_seq: h.seq,
            stamp_ns: h.stamp_ns,
            rx_mono_ns: h.rx_mono_ns,
            cells: self.grid.cells as u32,
            cell_m: self.grid.cell_m,
            ..MapHeader::default()
        }
    }
}

#[cfg(test)]
mod tests;
