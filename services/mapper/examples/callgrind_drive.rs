//! A small, repeatable driver for counting the mapper's instructions with callgrind (wall-clock
//! timings on a shared machine move by tens of per cent; instruction counts do not):
//! scenario 4 (tall grass, the costliest drive of the bench) along its survey route, the
//! simulator's base following the waypoint driver as in `benches/mapper.rs`, every revolution
//! simulated first and then mapped slice by slice as the mapper service maps `lidar/slices`
//! (4 packets a slice, then the map). Only [`map_revolutions`] is the mapper's work, so callgrind
//! collects that alone:
//!
//! ```sh
//! cargo build --release -p mimnav-mapper --example callgrind_drive
//! valgrind --tool=callgrind --toggle-collect='*map_revolutions*' \
//!     target/release/examples/callgrind_drive 20
//! ```
//!
//! The argument is the number of revolutions (20 by default). It prints a hash of every map (classes, cost, layers, stats), the same as long as
//! the maps are bit for bit the same: an optimisation must leave it unchanged.

use std::path::PathBuf;

use mimnav_mapper::{Deskew, Mapper, MapperParams, Odom, OdomInput};
use mimnav_shared::pose::pose2;
use mimnav_shared::topics::Point;
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim, SimSettings};
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};

#[path = "../benches/support/slices.rs"]
mod slices;
use slices::slice_starts;

/// One revolution as the mapper service gets it: points, the odometry at its end, its stamp.
struct Rev {
    points: Vec<Point>,
    odom: Odom,
    stamp_ns: u64,
}

/// Simulates up to `max` revolutions of scenario 4 along its survey route.
fn simulate(max: usize) -> Vec<Rev> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/worlds/scenario4_grass_intertwined.toml");
    let world = match WorldFile::load(&path) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("cannot load {}: {e}", path.display());
            std::process::exit(2);
        }
    };
    let scene = world.compile();
    let route = scene.survey.clone();
    let mut sim = Sim::new(scene, SimSettings::default(), 1, DEFAULT_EPOCH_NS);
    let limits = sim.settings().robot.clone();
    let mut asm = Assembler::new(AssemblerConfig::default());
    let mut driver = WaypointDriver::new(route, 0.25);
    let mut revs = Vec::new();
    while revs.len() < max && !driver.done() && sim.outcome() == Outcome::Running {
        let step = sim.step();
        let now = sim.now_ns();
        if let Ok(Some(rev)) = asm.push(&step.data, step.first_firing_ns, now) {
            let o = sim.odometry(0, now);
            revs.push(Rev {
                points: rev.points.clone(),
                odom: Odom {
                    pose: pose2(o.x, o.y, o.yaw),
                    v: f64::from(o.v),
                    omega: f64::from(o.omega),
                },
                stamp_ns: rev.header.stamp_ns,
            });
            let (v, w) = driver.command(&sim.base().pose, &limits);
            sim.set_command(v, w);
        }
    }
    revs
}

/// The mapper's work alone (callgrind's `--toggle-collect` names it): one revolution binned
/// slice by slice and mapped. Out of line so that the hashing after it is not counted.
#[inline(never)]
fn map_revolutions(mapper: &mut Mapper, rev: &Rev, starts: &[usize]) -> mimnav_mapper::UpdateStats {
    let odom = OdomInput::Fresh(rev.odom);
    let t_end = rev.points.last().map_or(0, |p| p.time_offset_ns);
    mapper.begin(Deskew::of(odom, t_end));
    for w in starts.windows(2) {
        mapper.bin_slice(&rev.points[w[0]..w[1]]);
    }
    if let Some(&last) = starts.last() {
        mapper.bin_slice(&rev.points[last..]);
    }
    mapper.finish(odom, rev.stamp_ns)
}

fn main() {
    let max = match std::env::args().nth(1) {
        None => 20,
        Some(a) => match a.parse::<usize>() {
            Ok(n) => n,
            Err(e) => {
                eprintln!("revolutions: {a}: {e}");
                std::process::exit(2);
            }
        },
    };
    let revs = simulate(max);
    let mut mapper = Mapper::new(MapperParams::default());
    // FNV-1a over every map, as the bench's `MAPPER_BENCH=digest`
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    let mut eat = |b: &[u8]| {
        for &x in b {
            h = (h ^ u64::from(x)).wrapping_mul(0x100_0000_01b3);
        }
    };
    let mut points = 0;
    for r in &revs {
        let starts = slice_starts(&r.points);
        let s = map_revolutions(&mut mapper, r, &starts);
        eat(mapper.classes());
        eat(mapper.cost());
        for v in mapper.layers() {
            eat(&v.to_bits().to_le_bytes());
        }
        eat(format!("{s:?}").as_bytes());
        points += r.points.len();
    }
    println!(
        "{} revolutions, {} points a revolution, digest {h:016x}",
        revs.len(),
        points / revs.len().max(1)
    );
}
