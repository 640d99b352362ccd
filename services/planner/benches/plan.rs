//! Planner time per map (inflation, clearance, route and the dynamic window), one core, on the
//! intensity maps of simulated revolutions: scenario 1 (walls and glass) and scenario 4 (grass,
//! bushes and trees), driven along their survey routes; the Turtlebot 2 (round) with both
//! inflations, and Spot (a rectangular body) with adaptive inflation.
//!
//! `cargo bench -p mimnav-planner --bench plan`
//!
//! Each case runs its maps round after round for 3 s and prints the mean, median and p99 over
//! every plan, then over each map's least time of its rounds (its own cost, with less of what
//! other work on the machine added), then the stages alone; for Spot, the way-out search
//! ([`Planner::maneuver`]) on every map too.
//!
//! `PLAN_BENCH=digest` plans each map once per case and prints a digest of the outcomes (a
//! speed-up must leave them the same) — short enough to count instructions under
//! `valgrind --tool=callgrind`; `PLAN_BENCH_ADAPTIVE=1` leaves out the uniform baseline. With
//! `PLAN_BENCH_MAPS=DIR` the maps are kept in DIR after the first run and read back after, so a
//! run under callgrind simulates nothing:
//!
//! ```sh
//! PLAN_BENCH=digest PLAN_BENCH_MAPS=$PWD/target/plan-maps cargo bench -p mimnav-planner --bench plan
//! PLAN_BENCH=digest PLAN_BENCH_MAPS=$PWD/target/plan-maps valgrind --tool=callgrind \
//!     --collect-atstart=no '--toggle-collect=*Planner*plan_as*' target/release/deps/plan-HASH --bench
//! ```

use std::path::PathBuf;
use std::time::Instant;

use mimnav_config::Config;
use mimnav_planner::Planner;
use mimnav_planner::inflate::Inflation;
use mimnav_runner::{Drive, FoliageUse, Lockstep, MapSource, Options};
use mimnav_shared::pose::Pose2Ext;
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::WorldFile;

/// A map with the robot's speed, turn rate and goal (robot frame).
type Case = (Vec<u8>, f64, f64, (f64, f64));

/// The maps of every fifth revolution along `world`'s survey, with the robot's state and goal.
fn maps(config: &Config, world: &str) -> Vec<Case> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/worlds")
        .join(world);
    let scene = match WorldFile::load(&path) {
        Ok(w) => w.compile(),
        Err(e) => {
            eprintln!("cannot load {}: {e}", path.display());
            std::process::exit(1);
        }
    };
    let goal = scene.goal;
    let mut driver = WaypointDriver::new(scene.survey.clone(), 0.25);
    // the deployed driver's and mapper's steps, through the lock-step runner
    let options = Options {
        map: MapSource::Intensity,
        foliage: FoliageUse::Off,
        inflation: None,
        drive: Drive::External,
    };
    let mut stack = match Lockstep::new(config, scene, 1, options) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("cannot run {}: {e}", path.display());
            std::process::exit(1);
        }
    };
    let limits = stack.sim().settings().robot.clone();
    let mut out = Vec::new();
    let mut k = 0;
    while !driver.done() {
        let Ok(Some(_)) = stack.next_revolution() else {
            break;
        };
        let b = *stack.sim().base();
        k += 1;
        if k % 5 == 0 {
            let goal_robot = b.pose.to_local(goal[0], goal[1]);
            out.push((stack.classes().to_vec(), b.v, b.omega, goal_robot));
        }
        let (v, w) = driver.command(&b.pose, &limits);
        stack.sim_mut().set_command(v, w);
    }
    out
}

/// The maps of `world` for `robot` from `PLAN_BENCH_MAPS`'s directory, made and kept there
/// when it does not hold them (or when the variable is unset, just made). Each case: the
/// robot's speed, turn rate, goal x and y (f64, little-endian), the cell count (u64), the
/// cells.
fn kept(world: &str, robot: &str, make: impl FnOnce() -> Vec<Case>) -> Vec<Case> {
    let Some(dir) = std::env::var_os("PLAN_BENCH_MAPS").map(PathBuf::from) else {
        return make();
    };
    let path = dir.join(format!("{world}.{robot}.maps"));
    if let Ok(bytes) = std::fs::read(&path) {
        let mut out = Vec::new();
        let mut rest = &bytes[..];
        let f = |b: &[u8], i: usize| {
            f64::from_le_bytes(b[i * 8..i * 8 + 8].try_into().unwrap_or([0; 8]))
        };
        while rest.len() >= 40 {
            let n = u64::from_le_bytes(rest[32..40].try_into().unwrap_or([0; 8])) as usize;
            if rest.len() < 40 + n {
                break;
            }
            out.push((
                rest[40..40 + n].to_vec(),
                f(rest, 0),
                f(rest, 1),
                (f(rest, 2), f(rest, 3)),
            ));
            rest = &rest[40 + n..];
        }
        return out;
    }
    let maps = make();
    let mut bytes = Vec::new();
    for (classes, v, w, goal) in &maps {
        for x in [*v, *w, goal.0, goal.1] {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
        bytes.extend_from_slice(&(classes.len() as u64).to_le_bytes());
        bytes.extend_from_slice(classes);
    }
    if let Err(e) = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, bytes)) {
        eprintln!("cannot keep the maps in {}: {e}", path.display());
    }
    maps
}

/// `PLAN_BENCH=digest`: each map planned once and the outcomes' digest printed, no timing.
fn digest_only() -> bool {
    std::env::var("PLAN_BENCH").is_ok_and(|v| v == "digest")
}

/// `PLAN_BENCH_ADAPTIVE=1`: the deployed inflation only (the uniform baseline's 169 taps would
/// otherwise dominate an instruction count of the inflation).
fn adaptive_only() -> bool {
    std::env::var_os("PLAN_BENCH_ADAPTIVE").is_some()
}

fn time(name: &str, config: &Config, inflation: Inflation, maps: &[Case]) {
    let mut params = config.planner_params();
    params.planner.inflation = inflation;
    let mut planner = Planner::new(params);
    let grid = config.map.grid();
    if digest_only() {
        // FNV-1a over every outcome's debug text: any change of a speed, a turn or a score shows
        let mut h = 0xcbf2_9ce4_8422_2325u64;
        for (classes, v, w, goal) in maps {
            let out = planner.plan(classes, grid, *v, *w, *goal);
            for b in format!("{out:?}").bytes() {
                h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
            }
        }
        println!(
            "{name}, {inflation:?} inflation: digest {h:016x} over {} maps",
            maps.len()
        );
        return;
    }
    let mut times = Vec::new();
    // each map's least time over the rounds: its own cost, with less of what the machine's
    // other work (another VM's thread on the same core) added to some rounds
    let mut least = vec![f64::INFINITY; maps.len()];
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < 3.0 {
        for ((classes, v, w, goal), least) in maps.iter().zip(least.iter_mut()) {
            let t = Instant::now();
            std::hint::black_box(planner.plan(classes, grid, *v, *w, *goal));
            let us = t.elapsed().as_secs_f64() * 1e6;
            times.push(us);
            *least = least.min(us);
        }
    }
    times.sort_by(f64::total_cmp);
    least.sort_by(f64::total_cmp);
    let mean = times.iter().sum::<f64>() / times.len() as f64;
    let p99 = times[(times.len() * 99 / 100).min(times.len() - 1)];
    let p = &planner.params().planner;
    println!(
        "{name}, {inflation:?} inflation: mean {mean:.0} µs, median {:.0} µs, p99 {p99:.0} µs per map ({} maps of {} cells, {} samples × {} steps)",
        times[times.len() / 2],
        times.len(),
        grid.len(),
        p.v_samples * p.omega_samples,
        (p.horizon_s / p.dt_s).ceil()
    );
    if !least.is_empty() {
        println!(
            "  each map's least of its {} rounds: mean {:.0} µs, median {:.0} µs, p99 {:.0} µs, max {:.0} µs",
            times.len() / least.len(),
            least.iter().sum::<f64>() / least.len() as f64,
            least[least.len() / 2],
            least[(least.len() * 99 / 100).min(least.len() - 1)],
            least[least.len() - 1]
        );
    }
}

/// A long body's way-out search ([`Planner::maneuver`]) on every map after its plan, as the
/// pilot runs it once a body is held still (and after each map that shows its way blocked):
/// µs per search, and on how many maps it found a way. The maps are of a drive nothing held,
/// so most searches run until they find a place to turn headed the route's way — a bound, not
/// the pilot's usual case.
fn maneuvers(name: &str, config: &Config, maps: &[Case]) {
    let mut planner = Planner::new(config.planner_params());
    let grid = config.map.grid();
    let (mut times, mut found) = (Vec::new(), 0);
    for _ in 0..3 {
        for (classes, v, w, goal) in maps {
            std::hint::black_box(planner.plan(classes, grid, *v, *w, *goal));
            let t = Instant::now();
            found += usize::from(std::hint::black_box(planner.maneuver(grid, None)).is_some());
            times.push(t.elapsed().as_secs_f64() * 1e6);
        }
    }
    if times.is_empty() {
        return;
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{name}: maneuver search mean {:.0} µs, median {:.0} µs, p99 {:.0} µs, max {:.0} µs; a way found on {} of {} maps",
        times.iter().sum::<f64>() / times.len() as f64,
        times[times.len() / 2],
        times[(times.len() * 99 / 100).min(times.len() - 1)],
        times[times.len() - 1],
        found / 3,
        times.len() / 3
    );
}

/// Where the time goes: each stage alone, mean µs per map.
fn breakdown(config: &Config, maps: &[Case]) {
    if digest_only() {
        return;
    }
    use mimnav_planner::dwa;
    use mimnav_planner::inflate::{KernelCache, plan_cost};
    use mimnav_planner::route::Route;
    let params = config.planner_params();
    let grid = config.map.grid();
    let p = &params.planner;
    let mut kernels = KernelCache::new(p.kernel_cells, p.padding_cells, p.kernel_angles);
    let mut scratch = mimnav_planner::inflate::Scratch::default();
    let (mut cost, mut clear, mut route) = (
        Vec::new(),
        mimnav_planner::clearance::Clearance::default(),
        Route::default(),
    );
    let reach = params.reach_m() as f32 + 2.0 * grid.cell_m;
    let mut t = [0.0f64; 5];
    let mut all: [Vec<f64>; 5] = Default::default();
    let mut n = 0;
    // the route's memory (`planner.route_memory_m`) as the pilot keeps it, the robot taken 0.1 m
    // on along x each map (the maps' contents do not move with it, so the memory holds more
    // than on a drive: an upper bound)
    let mut memory = mimnav_planner::memory::Memory::default();
    let (memory_m, memory_ns) = (p.route_memory_m, params.route_memory_ns());
    for (k, (classes, v, w, goal)) in maps.iter().cycle().take(maps.len() * 20).enumerate() {
        let s = Instant::now();
        let pose = mimnav_shared::pose::pose2(0.1 * k as f64, 0.0, 0.0);
        let now = k as u64 * 100_000_000;
        memory.take_in(&pose, classes, grid, now, memory_ns, memory_m);
        // a goal fixed in the odometry frame, 12 m on from where the drive starts, as the
        // pilot's: the lengths are searched again once a second or a metre, a search spread
        // over a few maps
        let fixed = (12.0, 0.0);
        let local = pose.to_local(fixed.0, fixed.1);
        let local = (local.0 as f32, local.1 as f32);
        let beyond = memory.beyond(
            &pose,
            fixed,
            local,
            now,
            memory_m,
            p.route_suspect_weight as f32,
            mimnav_planner::memory::SEARCH_CELLS_PER_MAP,
        );
        route.set_beyond(beyond);
        all[4].push(s.elapsed().as_secs_f64());
        t[4] += s.elapsed().as_secs_f64();
        let s = Instant::now();
        plan_cost(
            classes,
            grid,
            kernels.get(p.inflation, goal.1.atan2(goal.0)),
            params.passable_cost,
            &mut cost,
            &mut scratch,
        );
        all[0].push(s.elapsed().as_secs_f64());
        t[0] += s.elapsed().as_secs_f64();
        let s = Instant::now();
        clear.compute(classes, grid, reach, 5.0);
        all[1].push(s.elapsed().as_secs_f64());
        t[1] += s.elapsed().as_secs_f64();
        let s = Instant::now();
        route.build(
            &params.route_params(reach),
            grid,
            classes,
            &cost,
            (goal.0 as f32, goal.1 as f32),
        );
        all[2].push(s.elapsed().as_secs_f64());
        t[2] += s.elapsed().as_secs_f64();
        let s = Instant::now();
        std::hint::black_box(dwa::plan(
            &params,
            grid,
            &cost,
            &clear,
            *v,
            *w,
            *goal,
            Some(&route),
        ));
        all[3].push(s.elapsed().as_secs_f64());
        t[3] += s.elapsed().as_secs_f64();
        n += 1;
    }
    let us = |x: f64| x * 1e6 / n as f64;
    let p99 = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() * 99 / 100).map_or(0.0, |x| x * 1e6)
    };
    let [a, b, c, d, e] = &mut all;
    println!(
        "  stages, mean (p99): inflation {:.0} ({:.0}) µs, clearance {:.0} ({:.0}) µs, route {:.0} ({:.0}) µs, dynamic window {:.0} ({:.0}) µs, route memory {:.0} ({:.0}) µs",
        us(t[0]),
        p99(a),
        us(t[1]),
        p99(b),
        us(t[2]),
        p99(c),
        us(t[3]),
        p99(d),
        us(t[4]),
        p99(e)
    );
}

fn main() {
    let mut config = Config::default();
    if let Some(v) = std::env::var("ROUTE_CELL")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        config.planner.route_cell_m = v;
    }
    for world in [
        "scenario1_glass_wall.toml",
        "scenario4_grass_intertwined.toml",
    ] {
        let maps = kept(world, "turtlebot2", || maps(&config, world));
        for inflation in [Inflation::Adaptive, Inflation::Uniform] {
            if inflation == Inflation::Uniform && adaptive_only() {
                continue;
            }
            time(world, &config, inflation, &maps);
        }
        breakdown(&config, &maps);
    }
    // Spot: its body is a 1.1 × 0.5 m rectangle, tested along every rollout
    let shipped = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../config/mimnav.toml");
    let spot = match Config::load(&shipped, &["robot.profile=\"spot\"".into()]) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("cannot load Spot's profile: {e}");
            std::process::exit(1);
        }
    };
    for world in [
        "scenario1_glass_wall.toml",
        "scenario4_grass_intertwined.toml",
    ] {
        let maps = kept(world, "spot", || maps(&spot, world));
        time(&format!("{world}, Spot"), &spot, Inflation::Adaptive, &maps);
        breakdown(&spot, &maps);
        if !digest_only() {
            maneuvers(&format!("{world}, Spot"), &spot, &maps);
        }
    }
}
