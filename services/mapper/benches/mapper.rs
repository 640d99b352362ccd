//! One revolution through the whole mapper (binning into n = 200, m = 4 layers, classes, glass
//! detection and memory, plan cost), one core:
//! - the real dual-return capture's revolutions, and a simulated revolution of scenario 1 (glass
//!   in view) for comparison, at a fixed odometry; each also with the surface cue off
//!   (`mapper.surface_min_returns = 0`) and with tall cells not kept (`mapper.tall_memory_s = 0`),
//!   to show what each costs (mean and best over 1 s);
//! - *drives*: scenario 4 and scenario 1 along their survey routes; the densest generated world
//!   of every family (the most points a revolution along its route, among tune seeds 1–8 whose
//!   route the waypoint driver drives without contact) along its survey route; and 105 m through
//!   generated tall grass, its first and last 100 revolutions printed apart, and the median of
//!   every 100, so that a cost growing with the distance driven shows. The
//!   simulator's base follows the waypoint driver and the mapper gets every revolution with the
//!   true odometry of its end and its stamp, as the mapper service does, so every memory (glass
//!   panes, surface and tall cells) grows as it does on a drive. Each prints p50 / p99 / max of
//!   `Mapper::update` per revolution (p99: nearest rank; over ~150 revolutions, the second
//!   largest), and of the work left after the revolution's last packet when the mapper bins it
//!   slice by slice as it arrives (issue 27: its last slice of at most 4 packets, the classes,
//!   glass, memories and cost).
//!
//! Revolutions are simulated and assembled in chunks of [`CHUNK`] before any of them is timed, so
//! only `Mapper::update` is. Each revolution goes through [`RUNS`] mappers in turn (fed the same
//! revolutions, they hold the same state); a revolution's cost is the least of its [`RUNS`]
//! times — on a shared machine the other processes' interference only ever adds time — and the
//! line ends with the percentiles of all the samples as well. The mappers take turns, so each
//! update starts with caches another mapper has used, much as the service's does.
//!
//! `cargo bench -p mimnav-mapper --bench mapper` (about two minutes on the development machine,
//! most of it simulating the long drive). `MAPPER_BENCH=fixed` runs the fixed-odometry cases
//! only, `drives` the drives only, `scenario4` or `long` one drive, `digest` prints a hash of
//! every map of a few drives (an optimisation must leave it unchanged);
//! `MAPPER_BENCH_RUNS` sets the mappers a revolution goes through (3), `MAPPER_BENCH_MAX` caps a
//! drive along a survey route (300 revolutions).

use std::path::PathBuf;
use std::time::Instant;

use mimnav_mapper::glass::Pose2;
use mimnav_mapper::{Deskew, Mapper, MapperParams, Odom, OdomInput, UpdateStats};
use mimnav_shared::config::RobotProfile;
use mimnav_shared::pose::pose2;
use mimnav_shared::topics::Point;
use mimnav_sim::generate::{Family, generate};
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::{Grass, Scene, WorldFile};
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim, SimSettings};
use mimnav_velodyne::capture::CaptureReader;
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};

#[path = "support/slices.rs"]
mod slices;
use slices::slice_starts;

/// Revolutions simulated before they are timed (a grass revolution holds ~30 000 points).
const CHUNK: usize = 100;
/// Mappers each revolution goes through; its cost is the least of their times
/// (`MAPPER_BENCH_RUNS` overrides it).
const RUNS: usize = 3;

fn runs() -> usize {
    std::env::var("MAPPER_BENCH_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(RUNS)
        .max(1)
}
/// Candidate worlds per family when looking for the densest (tune seeds 1..=this, world 0).
const CANDIDATES: u64 = 8;
/// A drive along a survey route stops after this many revolutions at most.
const MAX_REVOLUTIONS: usize = 300;
/// The long grass drive: this far along the lane, m (the robot drives ≥ 100 m of it).
const LONG_M: f64 = 105.0;

fn time(name: &str, revs: &[Vec<Point>]) {
    time_with(name, MapperParams::default(), revs);
    let mut off = MapperParams::default();
    off.mapper.surface_min_returns = 0;
    time_with(&format!("{name}, surface cue off"), off, revs);
    let mut off = MapperParams::default();
    off.mapper.tall_memory_s = 0.0;
    time_with(&format!("{name}, tall cells not kept"), off, revs);
}

fn time_with(name: &str, params: MapperParams, revs: &[Vec<Point>]) {
    let mut mapper = Mapper::new(params);
    let odom = OdomInput::Fresh(Odom {
        pose: Pose2::default(),
        v: 0.3,
        omega: 0.2,
    });
    for r in revs {
        mapper.update(r, odom, 0);
    }
    let mut best = f64::INFINITY;
    let mut total = 0.0;
    let mut n = 0;
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < 1.0 {
        for r in revs {
            let t = Instant::now();
            mapper.update(r, odom, 0);
            let us = t.elapsed().as_secs_f64() * 1e6;
            best = best.min(us);
            total += us;
            n += 1;
        }
    }
    let points = revs.iter().map(Vec::len).sum::<usize>() / revs.len().max(1);
    let stats = revs
        .last()
        .map(|r| mapper.update(r, odom, 0))
        .unwrap_or_default();
    println!(
        "{name}: {points} points a revolution: mean {:.0} µs, best {best:.0} µs ({n} revolutions); \
         glass cells detected {}, in memory {}, extrapolated {}; surface cells found {}, in memory {}; tall cells in memory {}",
        total / n as f64,
        stats.glass_detected,
        stats.glass_memory,
        stats.glass_extended,
        stats.surface_found,
        stats.surface_memory,
        stats.tall_memory
    );
}

/// One revolution as the mapper service gets it: the points, the odometry at its end (as the
/// base publishes it) and its stamp.
struct Rev {
    points: Vec<Point>,
    odom: Odom,
    stamp_ns: u64,
}

/// The simulator's base driven through waypoints, its packets assembled into revolutions.
struct Drive {
    sim: Sim,
    asm: Assembler,
    driver: WaypointDriver,
    limits: RobotProfile,
}

impl Drive {
    fn new(scene: Scene, route: Vec<[f64; 2]>) -> Self {
        let sim = Sim::new(scene, SimSettings::default(), 1, DEFAULT_EPOCH_NS);
        Drive {
            limits: sim.settings().robot.clone(),
            sim,
            asm: Assembler::new(AssemblerConfig::default()),
            driver: WaypointDriver::new(route, 0.25),
        }
    }

    /// The next revolution, with the true odometry at its end; then the base is commanded
    /// towards the next waypoint. None once the route is done or the episode is over (goal,
    /// contact, time limit).
    fn next(&mut self) -> Option<Rev> {
        loop {
            if self.driver.done() || self.sim.outcome() != Outcome::Running {
                return None;
            }
            let step = self.sim.step();
            let now = self.sim.now_ns();
            if let Ok(Some(rev)) = self.asm.push(&step.data, step.first_firing_ns, now) {
                // the numbers the mapper service gets on `odom` (`MapStep` converts them so)
                let o = self.sim.odometry(0, now);
                let odom = Odom {
                    pose: pose2(o.x, o.y, o.yaw),
                    v: f64::from(o.v),
                    omega: f64::from(o.omega),
                };
                let out = Rev {
                    points: rev.points.clone(),
                    odom,
                    stamp_ns: rev.header.stamp_ns,
                };
                let pose = self.sim.base().pose;
                let (v, w) = self.driver.command(&pose, &self.limits);
                self.sim.set_command(v, w);
                return Some(out);
            }
        }
    }
}

/// Nearest-rank percentile of sorted `v`.
fn pct(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let k = ((p / 100.0 * v.len() as f64).ceil() as usize).clamp(1, v.len());
    v[k - 1]
}

/// "p50 / p99 / max" of `v`, µs.
fn percentiles(v: &[f64]) -> String {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    format!(
        "p50 {:.0} µs, p99 {:.0} µs, max {:.0} µs",
        pct(&s, 50.0),
        pct(&s, 99.0),
        pct(&s, 100.0)
    )
}

/// What one drive measured, per revolution in order.
#[derive(Default)]
struct Measured {
    /// The least of the [`RUNS`] times, µs.
    best: Vec<f64>,
    /// Every sample, µs.
    all: Vec<f64>,
    /// The least of the [`RUNS`] times of the work after the revolution's last packet (its
    /// last slice binned, and the map), µs.
    tail_best: Vec<f64>,
    points: Vec<usize>,
    stats: Vec<UpdateStats>,
    /// Distance driven at each revolution, m.
    driven: Vec<f64>,
    /// Wall time simulating, and mapping, s.
    wall: (f64, f64),
}

/// Drives `drive` to its end (or `max` revolutions), [`CHUNK`] revolutions simulated at a time
/// and then mapped by [`RUNS`] mappers, each revolution timed.
fn measure(drive: &mut Drive, max: usize) -> Measured {
    let mut mappers: Vec<Mapper> = (0..runs())
        .map(|_| Mapper::new(MapperParams::default()))
        .collect();
    let mut m = Measured::default();
    let mut chunk = Vec::with_capacity(CHUNK);
    let mut driven = Vec::with_capacity(CHUNK);
    loop {
        chunk.clear();
        driven.clear();
        let t = Instant::now();
        while chunk.len() < CHUNK && m.best.len() + chunk.len() < max {
            let Some(r) = drive.next() else { break };
            chunk.push(r);
            driven.push(drive.sim.path_length_m());
        }
        m.wall.0 += t.elapsed().as_secs_f64();
        if chunk.is_empty() {
            break;
        }
        let t = Instant::now();
        for (r, &d) in chunk.iter().zip(&driven) {
            let odom = OdomInput::Fresh(r.odom);
            let mut best = f64::INFINITY;
            let mut stats = UpdateStats::default();
            let starts = slice_starts(&r.points);
            let t_end = r.points.last().map_or(0, |p| p.time_offset_ns);
            let mut tail_best = f64::INFINITY;
            for mapper in &mut mappers {
                // `Mapper::update` as the service runs it from lidar/slices: the revolution's
                // slices binned as they come, then its last slice and the map
                let t = Instant::now();
                mapper.begin(Deskew::of(odom, t_end));
                for w in starts.windows(2) {
                    mapper.bin_slice(&r.points[w[0]..w[1]]);
                }
                let t_last = Instant::now();
                mapper.bin_slice(&r.points[starts[starts.len() - 1]..]);
                stats = std::hint::black_box(mapper.finish(odom, r.stamp_ns));
                let us = t.elapsed().as_secs_f64() * 1e6;
                tail_best = tail_best.min(t_last.elapsed().as_secs_f64() * 1e6);
                best = best.min(us);
                m.all.push(us);
            }
            m.best.push(best);
            m.tail_best.push(tail_best);
            m.points.push(r.points.len());
            m.stats.push(stats);
            m.driven.push(d);
        }
        m.wall.1 += t.elapsed().as_secs_f64();
    }
    m
}

/// One line for a drive: per-revolution percentiles, points, distance and the memories' sizes.
fn report(name: &str, m: &Measured, outcome: &str) {
    if m.best.is_empty() {
        println!("{name}: no revolution");
        return;
    }
    let n = m.best.len();
    let points = m.points.iter().sum::<usize>() / n;
    let most = m.points.iter().max().copied().unwrap_or(0);
    let peak = |f: fn(&UpdateStats) -> u32| m.stats.iter().map(f).max().unwrap_or(0);
    println!(
        "{name}: {n} revolutions, {points} points a revolution (at most {most}), {:.1} m driven ({outcome}): \
         {} (best of {} per revolution); after the last slice {}; all {} samples: {}; memories at most: glass {}, surface {}, tall {}",
        m.driven.last().copied().unwrap_or(0.0),
        percentiles(&m.best),
        runs(),
        percentiles(&m.tail_best),
        m.all.len(),
        percentiles(&m.all),
        peak(|s| s.glass_memory),
        peak(|s| s.surface_memory),
        peak(|s| s.tall_memory),
    );
    eprintln!(
        "  ({:.0} s simulating, {:.0} s mapping)",
        m.wall.0, m.wall.1
    );
}

fn outcome(o: Outcome) -> String {
    match o {
        Outcome::Running => "route done".into(),
        Outcome::GoalReached => "goal reached".into(),
        Outcome::Contact(i) => format!("contact with object {i}"),
        Outcome::Timeout => "time limit".into(),
    }
}

/// Drives `world` along its survey route and prints the line.
fn drive_world(name: &str, world: &WorldFile) {
    let scene = world.compile();
    let route = scene.survey.clone();
    let mut drive = Drive::new(scene, route);
    let max = std::env::var("MAPPER_BENCH_MAX")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(MAX_REVOLUTIONS);
    let m = measure(&mut drive, max);
    report(name, &m, &outcome(drive.sim.outcome()));
}

/// The poses along `world`'s route (its start, then straight at each waypoint, as the waypoint
/// driver goes), every `step_m`.
fn along_route(world: &WorldFile, step_m: f64) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    let mut from = [world.start[0], world.start[1]];
    for &to in &world.survey {
        let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
        let len = dx.hypot(dy);
        let yaw = dy.atan2(dx);
        let n = (len / step_m).ceil() as usize;
        for k in 0..n {
            let t = k as f64 / n as f64;
            out.push([from[0] + t * dx, from[1] + t * dy, yaw]);
        }
        from = to;
    }
    if out.is_empty() {
        out.push(world.start);
    }
    out
}

/// Whether the waypoint driver's straight lines through `world`'s route keep the robot clear of
/// every blocking object (it does not avoid them: a drive into one ends at the contact).
fn route_clear(world: &WorldFile) -> bool {
    let scene = world.compile();
    let body = SimSettings::default().robot.body();
    along_route(world, 0.05).iter().skip(1).all(|p| {
        mimnav_sim::motion::body_contact(&scene, &pose2(p[0], p[1], p[2]), &body).is_none()
    })
}

/// Points in a revolution seen from a quarter, half and three quarters of the way along
/// `world`'s route, the most of the three (the second revolution at each: the first may be cut
/// short).
fn points_along_route(world: &WorldFile) -> usize {
    let poses = along_route(world, 0.05);
    [1, 2, 3]
        .iter()
        .map(|q| {
            let mut w = world.clone();
            w.start = poses[(poses.len() * q / 4).min(poses.len() - 1)];
            let mut drive = Drive::new(w.compile(), vec![[1e9, 1e9]]);
            drive.next();
            drive.next().map_or(0, |r| r.points.len())
        })
        .max()
        .unwrap_or(0)
}

/// The world of `family` with the most points a revolution along its route among tune seeds
/// 1..=[`CANDIDATES`] (world 0) whose route the waypoint driver can drive without contact (any
/// candidate when none can).
fn densest(family: Family) -> (WorldFile, usize) {
    let worlds: Vec<WorldFile> = (1..=CANDIDATES)
        .map(|seed| generate(family, seed, 0))
        .collect();
    let clear: Vec<&WorldFile> = worlds.iter().filter(|w| route_clear(w)).collect();
    let pool = if clear.is_empty() {
        worlds.iter().collect()
    } else {
        clear
    };
    pool.into_iter()
        .map(|w| (w.clone(), points_along_route(w)))
        .max_by_key(|(_, n)| *n)
        .expect("candidates")
}

/// A lane [`LONG_M`] long through tall grass at the grass family's densest parameters (1.0 m
/// high, 6 blade hits a metre, reflectivity 20, 10 m wide), holding the trunks, bushes and
/// rocks of generated grass worlds (seed 1, worlds 0, 1, ...) laid end to end along it, those
/// that would block the lane (within 0.6 m of its centre line) left out (their grass patches
/// too: the field is as dense already, and the simulator's cost grows with the objects). The
/// robot drives along the centre line from x = 0.
fn long_grass() -> WorldFile {
    let mut w = generate(Family::Grass, 1, 0);
    w.name = format!("long grass drive, {LONG_M} m");
    w.start = [0.0, 0.0, 0.0];
    w.goal = [LONG_M + 50.0, 0.0];
    w.time_limit_s = 1e6;
    w.survey = vec![[LONG_M, 0.0]];
    w.ground.reflectivity = 10.0;
    (w.wall, w.pillar, w.glass, w.curtain) = Default::default();
    (w.grass, w.trunk, w.bush, w.rock) = Default::default();
    w.grass.push(Grass {
        center: [LONG_M / 2.0, 0.0],
        size: [LONG_M + 10.0, 10.0],
        yaw_deg: 0.0,
        height: 1.0,
        density: 6.0,
        reflectivity: 20.0,
    });
    let lane = 0.6;
    let mut x0 = 1.5;
    let mut index = 0;
    while x0 < LONG_M {
        let g = generate(Family::Grass, 1, index);
        index += 1;
        let shift = |c: [f64; 2]| [c[0] + x0, c[1]];
        let clear = |c: [f64; 2], r: f64| c[1].abs() > r + lane;
        for mut t in g.trunk.into_iter().filter(|t| clear(t.center, t.radius)) {
            t.center = shift(t.center);
            w.trunk.push(t);
        }
        for mut b in g.bush.into_iter().filter(|b| clear(b.center, b.radius)) {
            b.center = shift(b.center);
            w.bush.push(b);
        }
        for mut r in g.rock.into_iter().filter(|r| clear(r.center, r.radius)) {
            r.center = shift(r.center);
            w.rock.push(r);
        }
        x0 += g.goal[0] + 1.0;
    }
    w.description = format!(
        "{} trunks, {} bushes, {} rocks from {index} generated grass worlds",
        w.trunk.len(),
        w.bush.len(),
        w.rock.len()
    );
    w
}

/// The long grass drive: the per-revolution cost over the first and the last 100 revolutions,
/// and the median by 100 revolutions in between.
fn long_drive() {
    let world = long_grass();
    let scene = world.compile();
    let route = scene.survey.clone();
    let mut drive = Drive::new(scene, route);
    let m = measure(&mut drive, usize::MAX);
    let name = format!("{} ({})", world.name, world.description);
    report(&name, &m, &outcome(drive.sim.outcome()));
    let n = m.best.len();
    let k = 100.min(n);
    for (what, range) in [("first", 0..k), ("last", n - k..n)] {
        let s = &m.stats[range.clone()];
        let peak = |f: fn(&UpdateStats) -> u32| s.iter().map(f).max().unwrap_or(0);
        println!(
            "  {what} {k} revolutions ({:.1}–{:.1} m): {}; memories at most: glass {}, surface {}, tall {}",
            if range.start == 0 {
                0.0
            } else {
                m.driven[range.start - 1]
            },
            m.driven[range.end - 1],
            percentiles(&m.best[range.clone()]),
            peak(|s| s.glass_memory),
            peak(|s| s.surface_memory),
            peak(|s| s.tall_memory),
        );
    }
    let medians: Vec<String> = m
        .best
        .chunks(100)
        .map(|c| {
            let mut c = c.to_vec();
            c.sort_by(f64::total_cmp);
            format!("{:.0}", pct(&c, 50.0))
        })
        .collect();
    println!("  p50 by 100 revolutions, µs: {}", medians.join(" "));
}

fn fixed() {
    let path = match std::env::var_os("MIMNAV_SHARED_DATA") {
        Some(d) => PathBuf::from(d).join("velodyne/vlp16_dual_nebula.pcap"),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/data/velodyne/vlp16_dual_nebula.pcap"),
    };
    let mut asm = Assembler::new(AssemblerConfig::default());
    let mut revs = Vec::new();
    match CaptureReader::open(&path) {
        Ok(mut r) => {
            while let Ok(Some(d)) = r.next() {
                if let Ok(Some(rev)) = asm.push(d.payload, d.ts_ns, 0) {
                    revs.push(rev.points.clone());
                }
            }
            time("real dual capture", &revs);
        }
        Err(e) => println!("SKIP real capture: {e}"),
    }
    let world = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/worlds/scenario1_glass_wall.toml");
    let scene = WorldFile::load(&world).expect("world").compile();
    let mut sim = Sim::new(scene, SimSettings::default(), 1, DEFAULT_EPOCH_NS);
    let mut asm = Assembler::new(AssemblerConfig::default());
    let mut revs = Vec::new();
    while revs.len() < 5 {
        let s = sim.step();
        if let Ok(Some(rev)) = asm.push(&s.data, s.first_firing_ns, 0) {
            revs.push(rev.points.clone());
        }
    }
    time("simulated scenario 1", &revs);
}

fn drives() {
    let worlds = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds");
    for file in [
        "scenario4_grass_intertwined.toml",
        "scenario1_glass_wall.toml",
    ] {
        let world = WorldFile::load(&worlds.join(file)).expect("a bundled world");
        drive_world(&format!("{file}, driven along its survey"), &world);
    }
    for family in Family::ALL {
        let (world, points) = densest(family);
        drive_world(
            &format!(
                "{}, densest of tune seeds 1–{CANDIDATES} (up to {points} points a revolution on its route), driven along its survey",
                world.name
            ),
            &world,
        );
    }
    long_drive();
}

/// FNV-1a over every revolution's classes, cost, layers and stats, on scenario 4, scenario 1 and
/// the first 300 revolutions of the long grass drive: an optimisation must leave it unchanged
/// (`MAPPER_BENCH=digest`).
fn digest() {
    let worlds = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/worlds");
    let mut cases: Vec<(String, WorldFile, usize)> = [
        "scenario4_grass_intertwined.toml",
        "scenario1_glass_wall.toml",
    ]
    .iter()
    .map(|f| {
        (
            f.to_string(),
            WorldFile::load(&worlds.join(f)).expect("a bundled world"),
            usize::MAX,
        )
    })
    .collect();
    cases.push(("long grass".into(), long_grass(), 300));
    cases.push((
        "glass-corridor s10 i0".into(),
        generate(Family::GlassCorridor, 10, 0),
        usize::MAX,
    ));
    for (name, world, max) in cases {
        let scene = world.compile();
        let route = scene.survey.clone();
        let mut drive = Drive::new(scene, route);
        let mut mapper = Mapper::new(MapperParams::default());
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        let mut eat = |b: &[u8]| {
            for &x in b {
                h = (h ^ u64::from(x)).wrapping_mul(0x100_0000_01b3);
            }
        };
        let mut n = 0;
        while n < max {
            let Some(r) = drive.next() else { break };
            let s = mapper.update(&r.points, OdomInput::Fresh(r.odom), r.stamp_ns);
            eat(mapper.classes());
            eat(mapper.cost());
            for v in mapper.layers() {
                eat(&v.to_bits().to_le_bytes());
            }
            eat(format!("{s:?}").as_bytes());
            n += 1;
        }
        println!("{name}: {n} revolutions, digest {h:016x}");
    }
}

fn main() {
    let which = std::env::var("MAPPER_BENCH").unwrap_or_default();
    let start = Instant::now();
    match which.as_str() {
        "fixed" => fixed(),
        "drives" => drives(),
        "scenario4" => {
            let world = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
                .join("../../config/worlds/scenario4_grass_intertwined.toml");
            let world = WorldFile::load(&world).expect("a bundled world");
            drive_world("scenario 4, driven along its survey", &world);
        }
        "long" => long_drive(),
        "digest" => digest(),
        _ => {
            fixed();
            drives();
        }
    }
    eprintln!("({:.0} s)", start.elapsed().as_secs_f64());
}
