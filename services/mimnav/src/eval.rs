//! `mimnav eval`: the paper's Table I reproduced on the simulator's scenario worlds.
//!
//! Every episode runs in one thread, lock-step and deterministic (a seed gives the same episode
//! every time): the simulator's packets go through the driver's decoder and revolution
//! assembler; each revolution makes a map — the intensity map of the mapper, or one of the
//! paper's baselines that take every return as an obstacle — and the planner turns it into the
//! (v, ω) the simulator drives until the next revolution. Episodes run in parallel, one per core.
//!
//! Metrics (DESIGN §10): success (the goal within the world's time limit, no contact with a solid
//! or glass object), normalised trajectory length (path over the straight start–goal distance,
//! of successful runs; the straight distance ends on the goal circle), the F-score of the map's classes against the ground truth (mean over the
//! classes the world has, cells within 4.5 m, every fifth revolution), and planner time.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_mapper::render::{self, Image};
use mimnav_mapper::score::{MapScore, score};
use mimnav_planner::inflate::Inflation;
use mimnav_runner::{Drive, FoliageUse, Lockstep, MapSource, Options};
use mimnav_shared::grid::GridSpec;
use mimnav_shared::pose::{Pose2, Pose2Ext, pose2};
use mimnav_shared::topics::{cell_class, command_status};
use mimnav_sim::Outcome;
use mimnav_sim::world::{Scene, WorldFile};

/// A way of making the map the planner drives on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    /// The intensity map with adaptive inflation along the goal direction (the paper's method).
    Adaptive,
    /// The intensity map with adaptive inflation and the foliage classifier in the loop: the
    /// obstacles it confirms are solid.
    Foliage,
    /// The intensity map with uniform inflation (the paper's ablation).
    Uniform,
    /// Baseline: DWA on the planar scan of one laser (its strongest returns, whatever
    /// `velodyne.scan_return` says), every return an obstacle.
    LaserScan,
    /// Baseline: DWA on an occupancy map of every return in the robot's height band.
    Occupancy,
}

impl Method {
    /// Name in tables.
    pub fn label(self) -> &'static str {
        match self {
            Method::Adaptive => "intensity map, adaptive inflation",
            Method::Foliage => "intensity map, adaptive, foliage classifier",
            Method::Uniform => "intensity map, uniform inflation",
            Method::LaserScan => "DWA on a laser scan",
            Method::Occupancy => "DWA on an occupancy map",
        }
    }

    /// Name on the command line and in JSON.
    pub fn key(self) -> &'static str {
        match self {
            Method::Adaptive => "adaptive",
            Method::Foliage => "foliage",
            Method::Uniform => "uniform",
            Method::LaserScan => "laser-scan",
            Method::Occupancy => "occupancy",
        }
    }

    /// Colour of its paths in the trajectory plots.
    pub fn colour(self) -> [u8; 3] {
        match self {
            Method::Adaptive => [255, 60, 200],
            Method::Foliage => [160, 90, 255],
            Method::Uniform => [0, 200, 255],
            Method::LaserScan => [255, 150, 0],
            Method::Occupancy => [230, 30, 30],
        }
    }

    fn colour_name(self) -> &'static str {
        match self {
            Method::Adaptive => "magenta",
            Method::Foliage => "violet",
            Method::Uniform => "cyan",
            Method::LaserScan => "orange",
            Method::Occupancy => "red",
        }
    }
}

/// Arguments of `mimnav eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Worlds (default: the four Table I scenarios in the config's worlds folder).
    #[arg(long = "world", value_name = "FILE")]
    pub(crate) worlds: Vec<PathBuf>,
    /// Every *.toml world in this folder (repeatable), e.g. a set `mimnav worlds generate` wrote:
    /// the table is per family, each world judged passable or not for the robot first.
    #[arg(long = "worlds", value_name = "DIR")]
    pub(crate) world_dirs: Vec<PathBuf>,
    /// A generated set, evaluated per family like `--worlds` (`--family`, `--count`, `--seed`,
    /// `--split` as for `mimnav worlds generate`).
    #[command(flatten)]
    pub(crate) set: crate::worlds::SetArgs,
    /// Cap every world's time limit at this many seconds (short test runs).
    #[arg(long, value_name = "S")]
    pub(crate) time_limit_s: Option<f64>,
    /// Methods (default: all five).
    #[arg(long = "method", value_enum)]
    methods: Vec<Method>,
    /// Seeds per world and method (the simulator's noise; not the worlds' seeds).
    #[arg(long, default_value_t = 20)]
    pub(crate) seeds: u64,
    /// The first seed.
    #[arg(long, default_value_t = 1)]
    pub(crate) first_seed: u64,
    /// Parallel episodes (default: one per core).
    #[arg(long)]
    pub(crate) jobs: Option<usize>,
    /// Folder for the trajectory plots (one PNG per world); none written without it.
    #[arg(long, value_name = "DIR")]
    plots: Option<PathBuf>,
    /// One JSON line per episode on standard output, after the table.
    #[arg(long)]
    pub(crate) json: bool,
    /// No progress bar.
    #[arg(long)]
    pub(crate) quiet: bool,
}

/// How an episode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ending {
    /// Reached the goal without contact.
    Success,
    /// Touched a solid or glass object.
    Contact,
    /// Ran out of time standing (moved less than 0.2 m in its last 10 s): froze.
    Froze,
    /// Ran out of time while moving.
    Timeout,
}

impl Ending {
    /// Name in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Ending::Success => "success",
            Ending::Contact => "contact",
            Ending::Froze => "froze",
            Ending::Timeout => "timeout",
        }
    }
}

/// What a contact touched (issue 22), to tell the contacts a map built from the sensor's
/// returns could have prevented from those it could not.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Touched {
    /// A glass pane the sensor had faced ([`mimnav_sim::truth::faces_pane`]) this many seconds
    /// before the contact, at the first revolution that faced it.
    Glass {
        /// Seconds from the first revolution that faced the pane to the contact.
        faced_s: f64,
    },
    /// A glass pane no revolution before the contact faced, but another pane joined to it end to
    /// end on its line ([`mimnav_sim::truth::pane_line`]) was, this many seconds before: the map
    /// holds the touched one only by extending that one's line.
    GlassLineFaced {
        /// Seconds from the first revolution that faced a pane of the line to the contact.
        faced_s: f64,
    },
    /// A glass pane neither it nor any pane of its line faced by a revolution before the contact:
    /// no beam could have returned from it.
    GlassNeverFaced,
    /// A solid hidden in grass ([`mimnav_sim::world::Scene::hidden_in_grass`]).
    HiddenInGrass,
    /// Any other solid obstacle (walls, pillars, trunks, rocks in the open, bushes).
    Solid,
}

impl Touched {
    /// Name in JSON and tables.
    pub fn name(self) -> &'static str {
        match self {
            Touched::Glass { .. } => "glass",
            Touched::GlassLineFaced { .. } => "glass, only its line faced",
            Touched::GlassNeverFaced => "glass never faced",
            Touched::HiddenInGrass => "hidden in grass",
            Touched::Solid => "solid",
        }
    }
}

/// The record of one episode.
#[derive(Debug, Clone)]
pub struct Episode {
    /// World name.
    pub world: String,
    /// Method.
    pub method: Method,
    /// Seed.
    pub seed: u64,
    /// How it ended.
    pub ending: Ending,
    /// Path driven, m.
    pub path_m: f64,
    /// Straight distance from the start to the goal circle (sim.goal_tolerance_m), m.
    pub straight_m: f64,
    /// Straight distance from where the robot ended to the goal circle, m (0 on reaching it):
    /// how near a run that timed out, froze or touched came.
    pub goal_left_m: f64,
    /// Simulated time, s.
    pub elapsed_s: f64,
    /// Map scores, summed.
    pub score: MapScore,
    /// Revolutions.
    pub revolutions: u64,
    /// Revolutions the planner found no feasible motion.
    pub blocked: u64,
    /// Scans the foliage classifier alarmed on (with the classifier in the loop).
    pub alarms: u64,
    /// Planner time, summed, ns.
    pub plan_ns: u128,
    /// Mapper (or baseline map) time, summed, ns.
    pub map_ns: u128,
    /// The robot's (x, y) once a revolution.
    pub trajectory: Vec<(f64, f64)>,
    /// With a contact: the centre of the object touched (its bounding circle's), world frame.
    pub touched: Option<[f64; 2]>,
    /// With a contact: what was touched.
    pub touched_kind: Option<Touched>,
}

impl Method {
    /// The stack this method runs: the deployed step types, put together by the runner.
    pub fn options(self) -> Options {
        let (map, foliage, inflation) = match self {
            Method::Adaptive => (MapSource::Intensity, FoliageUse::Off, Inflation::Adaptive),
            Method::Foliage => (
                MapSource::Intensity,
                FoliageUse::InLoop,
                Inflation::Adaptive,
            ),
            Method::Uniform => (MapSource::Intensity, FoliageUse::Off, Inflation::Uniform),
            // the baselines use the usual costmap: uniform inflation
            Method::LaserScan => (MapSource::LaserScan, FoliageUse::Off, Inflation::Uniform),
            Method::Occupancy => (MapSource::Occupancy, FoliageUse::Off, Inflation::Uniform),
        };
        Options {
            map,
            foliage,
            inflation: Some(inflation),
            drive: Drive::Planner,
        }
    }
}

/// Runs one episode of `scene` with `method` and `seed`, through the lock-step runner.
pub fn run_episode(config: &Config, scene: &Scene, method: Method, seed: u64) -> Result<Episode> {
    let grid = config.map.grid();
    let goal = scene.goal;
    // the shortest drive ends on the goal circle
    let straight_m = ((goal[0] - scene.start[0]).hypot(goal[1] - scene.start[1])
        - config.sim.goal_tolerance_m)
        .max(0.01);
    let mut run = Lockstep::new(config, scene.clone(), seed, method.options())?;
    // the simulator ends the episode on the goal circle; the planner's own goal check is the
    // same circle
    run.set_goal(goal[0], goal[1], config.sim.goal_tolerance_m)?;
    let mut truth = Vec::new();
    let mut episode = Episode {
        world: scene.name.clone(),
        method,
        seed,
        ending: Ending::Timeout,
        path_m: 0.0,
        straight_m,
        goal_left_m: 0.0,
        elapsed_s: 0.0,
        score: MapScore::default(),
        revolutions: 0,
        blocked: 0,
        alarms: 0,
        plan_ns: 0,
        map_ns: 0,
        trajectory: vec![(scene.start[0], scene.start[1])],
        touched: None,
        touched_kind: None,
    };
    // when each glass pane was first faced (issue 22: contacts with panes never faced)
    let specular = config.sim.glass_specular_deg;
    let mut first_faced: Vec<Option<f64>> = vec![None; scene.objects.len()];
    while let Some(turn) = run.next_revolution()? {
        episode.revolutions += 1;
        episode.map_ns += u128::from(turn.bin_ns + turn.map_ns + turn.classify_ns);
        episode.plan_ns += u128::from(turn.plan_ns);
        episode.alarms += u64::from(turn.foliage.is_some_and(|f| f.alarm != 0));
        if let Some((_, c)) = turn.command
            && c.status == command_status::BLOCKED
        {
            episode.blocked += 1;
        }
        if episode.revolutions.is_multiple_of(5) {
            run.sim().truth(grid, &mut truth);
            episode.score.add(&score(run.classes(), &truth, grid, 4.5));
        }
        let p = run.sim().base().pose;
        episode.trajectory.push((p.x(), p.y()));
        let sensor = run.sim().sensor_position();
        for (faced, o) in first_faced.iter_mut().zip(&scene.objects) {
            if faced.is_none() && mimnav_sim::truth::faces_pane(o, sensor, specular) {
                *faced = Some(run.sim().elapsed_s());
            }
        }
    }
    let sim = run.sim();
    episode.path_m = sim.path_length_m();
    let end = sim.base().pose;
    episode.goal_left_m =
        ((goal[0] - end.x()).hypot(goal[1] - end.y()) - config.sim.goal_tolerance_m).max(0.0);
    episode.elapsed_s = sim.elapsed_s();
    episode.ending = match sim.outcome() {
        Outcome::GoalReached => Ending::Success,
        Outcome::Contact(i) => {
            episode.touched = scene.objects.get(i).map(|o| o.bound.0);
            episode.touched_kind = scene.objects.get(i).map(|o| {
                if o.class == cell_class::GLASS {
                    // faced at the revolution that ended at the contact is faced too late
                    let before = |k: usize| {
                        first_faced
                            .get(k)
                            .copied()
                            .flatten()
                            .filter(|&t| t < episode.elapsed_s - 1e-6)
                    };
                    let line = mimnav_sim::truth::pane_line(scene, i);
                    let line_faced = line.iter().filter_map(|&k| before(k)).reduce(f64::min);
                    match (before(i), line_faced) {
                        (Some(t), _) => Touched::Glass {
                            faced_s: episode.elapsed_s - t,
                        },
                        (None, Some(t)) => Touched::GlassLineFaced {
                            faced_s: episode.elapsed_s - t,
                        },
                        (None, None) => Touched::GlassNeverFaced,
                    }
                } else if scene.hidden_in_grass().contains(&i) {
                    Touched::HiddenInGrass
                } else {
                    Touched::Solid
                }
            });
            Ending::Contact
        }
        _ => {
            // revolutions in the last 10 s
            let revs = (10.0 * config.velodyne.rpm / 60.0) as usize;
            let t = &episode.trajectory;
            let from = t[t.len().saturating_sub(revs.max(1))];
            let to = t[t.len() - 1];
            if (to.0 - from.0).hypot(to.1 - from.1) < 0.2 {
                Ending::Froze
            } else {
                Ending::Timeout
            }
        }
    };
    Ok(episode)
}

/// Per world and method: what the table shows.
#[derive(Debug, Clone, Default)]
pub struct Summary {
    /// Episodes.
    pub runs: usize,
    /// Successes.
    pub successes: usize,
    /// Contacts, freezes, timeouts.
    pub contacts: usize,
    /// Froze.
    pub froze: usize,
    /// Timed out moving.
    pub timeouts: usize,
    /// Normalised lengths of successful runs.
    pub lengths: Vec<f64>,
    /// Map scores.
    pub score: MapScore,
    /// Planner and map time, ns, and revolutions.
    pub plan_ns: u128,
    /// Map time, ns.
    pub map_ns: u128,
    /// Revolutions.
    pub revolutions: u64,
}

impl Summary {
    fn add(&mut self, e: &Episode) {
        self.runs += 1;
        match e.ending {
            Ending::Success => {
                self.successes += 1;
                self.lengths.push(e.path_m / e.straight_m.max(1e-9));
            }
            Ending::Contact => self.contacts += 1,
            Ending::Froze => self.froze += 1,
            Ending::Timeout => self.timeouts += 1,
        }
        self.score.add(&e.score);
        self.plan_ns += e.plan_ns;
        self.map_ns += e.map_ns;
        self.revolutions += e.revolutions;
    }

    /// Success rate, 0–1.
    pub fn success_rate(&self) -> f64 {
        self.successes as f64 / self.runs.max(1) as f64
    }

    /// Mean normalised length of the successful runs.
    pub fn mean_length(&self) -> Option<f64> {
        (!self.lengths.is_empty())
            .then(|| self.lengths.iter().sum::<f64>() / self.lengths.len() as f64)
    }

    /// Mean F-score over the classes the world has (solid, passable, glass).
    pub fn f_score(&self) -> f64 {
        let s = &self.score;
        let present: Vec<f64> = [&s.solid, &s.passable, &s.glass]
            .into_iter()
            .filter(|c| c.tp + c.fn_ > 0)
            .map(|c| c.f_score())
            .collect();
        present.iter().sum::<f64>() / present.len().max(1) as f64
    }
}

fn scenario_worlds(config: &Config) -> Result<Vec<PathBuf>> {
    let v = crate::score_map::bundled_worlds(config, "scenario")?;
    anyhow::ensure!(
        !v.is_empty(),
        "no scenario*.toml worlds beside {}: name them with --world",
        config.sim.world_path(&config.dir()).display()
    );
    Ok(v)
}

/// Runs the evaluation and prints the table.
pub fn run(config: &Config, args: &EvalArgs) -> Result<ExitCode> {
    let methods = if args.methods.is_empty() {
        vec![
            Method::Adaptive,
            Method::Foliage,
            Method::Uniform,
            Method::LaserScan,
            Method::Occupancy,
        ]
    } else {
        args.methods.clone()
    };
    anyhow::ensure!(args.seeds > 0, "--seeds must be at least 1");
    if !args.world_dirs.is_empty() || !args.set.families.is_empty() {
        anyhow::ensure!(
            args.plots.is_none(),
            "--plots draws Table I worlds; not with --worlds or --family"
        );
        return crate::family_eval::run(config, args, &methods);
    }
    let paths = if args.worlds.is_empty() {
        scenario_worlds(config)?
    } else {
        args.worlds.clone()
    };
    let mut scenes = Vec::new();
    for p in &paths {
        let mut scene = WorldFile::load(p)?.compile();
        if let Some(cap) = args.time_limit_s {
            scene.time_limit_s = scene.time_limit_s.min(cap);
        }
        scenes.push(scene);
    }
    let mut jobs = Vec::new();
    for (w, _) in scenes.iter().enumerate() {
        for &m in &methods {
            for s in 0..args.seeds {
                jobs.push((w, m, args.first_seed + s));
            }
        }
    }
    let workers = crate::pool::workers(args.jobs);
    let started = std::time::Instant::now();
    let results = crate::pool::run_all(&jobs, workers, args.quiet, |&(w, m, seed), bar| {
        let e = run_episode(config, &scenes[w], m, seed)
            .with_context(|| format!("{}, {}, seed {seed}", scenes[w].name, m.label()));
        if let Ok(ep) = &e
            && ep.ending != Ending::Success
        {
            bar.set_message(format!(
                "(last failure: {}, {}, seed {}: {})",
                ep.world,
                m.label(),
                seed,
                ep.ending.name()
            ));
        }
        e
    });
    let mut episodes = results.into_iter().collect::<Result<Vec<_>>>()?;
    episodes.sort_by_key(|e| (e.world.clone(), e.method as u8, e.seed));
    let wall = started.elapsed().as_secs_f64();
    outln!(
        "{} seeds per world and method (from seed {}), lock-step; F-score: mean over the classes the world has, cells within 4.5 m, every fifth revolution\n",
        args.seeds,
        args.first_seed
    )?;
    outln!(
        "| scenario | method | success | normalised length | length / shortest | F-score | contact / froze / timeout | planner µs/rev | map µs/rev |"
    )?;
    outln!("|---|---|---|---|---|---|---|---|---|")?;
    // the summary line's method: the paper's, or the first one run without it
    let headline = if methods.contains(&Method::Adaptive) {
        Method::Adaptive
    } else {
        methods.first().copied().unwrap_or(Method::Adaptive)
    };
    let mut all = Summary::default();
    for scene in &scenes {
        let shortest = shortest_m(config, scene);
        for &m in &methods {
            let mut s = Summary::default();
            for e in episodes
                .iter()
                .filter(|e| e.world == scene.name && e.method == m)
            {
                s.add(e);
                if m == headline {
                    all.add(e);
                }
            }
            let straight = episodes
                .iter()
                .find(|e| e.world == scene.name)
                .map_or(1.0, |e| e.straight_m);
            outln!(
                "| {} | {} | {:.0} % ({}/{}) | {} | {} | {:.3} | {} / {} / {} | {:.0} | {:.0} |",
                scene.name,
                m.label(),
                100.0 * s.success_rate(),
                s.successes,
                s.runs,
                s.mean_length()
                    .map_or_else(|| "–".to_string(), |l| format!("{l:.3}")),
                match (s.mean_length(), shortest) {
                    (Some(l), Some(sh)) => format!("{:.3} ({sh:.2} m)", l * straight / sh),
                    _ => "–".to_string(),
                },
                s.f_score(),
                s.contacts,
                s.froze,
                s.timeouts,
                s.plan_ns as f64 / 1e3 / s.revolutions.max(1) as f64,
                s.map_ns as f64 / 1e3 / s.revolutions.max(1) as f64,
            )?;
        }
    }
    if let Some(dir) = &args.plots {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for (w, scene) in scenes.iter().enumerate() {
            let stem = paths[w]
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("world");
            let path = dir.join(format!("{stem}.png"));
            let eps: Vec<&Episode> = episodes.iter().filter(|e| e.world == scene.name).collect();
            crate::snapshot::write_png(&path, &plot(scene, &eps))?;
            outln!("\nwrote {}", path.display())?;
        }
        let legend: Vec<String> = methods
            .iter()
            .map(|m| format!("{} {}", m.colour_name(), m.label()))
            .collect();
        outln!("paths: {}; start white, goal blue", legend.join(", "))?;
    }
    if args.json {
        for e in &episodes {
            let line = serde_json::json!({
                "world": e.world,
                "method": e.method.key(),
                "seed": e.seed,
                "ending": e.ending.name(),
                "path_m": e.path_m,
                "straight_m": e.straight_m,
                "goal_left_m": e.goal_left_m,
                "elapsed_s": e.elapsed_s,
                "revolutions": e.revolutions,
                "blocked": e.blocked,
                "alarms": e.alarms,
                "f_solid": e.score.solid.f_score(),
                "f_passable": e.score.passable.f_score(),
                "f_glass": e.score.glass.f_score(),
                "planner_us_per_rev": e.plan_ns as f64 / 1e3 / e.revolutions.max(1) as f64,
                "touched": e.touched,
                "touched_kind": e.touched_kind.map(Touched::name),
            });
            outln!("{line}")?;
        }
    }
    outln!(
        "\n{} episodes in {:.0} s on {} threads; {}: {:.1} % success over {} episodes, normalised length {}",
        episodes.len(),
        wall,
        workers,
        headline.label(),
        100.0 * all.success_rate(),
        all.runs,
        all.mean_length()
            .map_or_else(|| "–".to_string(), |l| format!("{l:.3}"))
    )?;
    Ok(ExitCode::SUCCESS)
}

/// The length of the shortest way from the start to the goal circle that the footprint (radius
/// and margin) fits along, m, on the true map: the route search of the planner (16 neighbours,
/// within 3 % of the true length) on a 5 cm grid of the whole world. None when there is no way.
pub fn shortest_m(config: &Config, scene: &Scene) -> Option<f64> {
    let (grid, centre, classes) = world_truth(scene, &[], 2000);
    // the goal and the start in the grid's frame
    let goal = centre.to_local(scene.goal[0], scene.goal[1]);
    let start = centre.to_local(scene.start[0], scene.start[1]);
    let p = config.planner_params();
    let mut route = mimnav_planner::route::Route::default();
    route.build(
        &mimnav_planner::route::RouteParams {
            cell_m: 0.1,
            radius_m: p.footprint_m() as f32,
            cost_weight: 0.0,
            // the geometric shortest way: no preference for room to turn
            swing_m: 0.0,
            swing_weight: 0.0,
            suspect_weight: 0.0,
            end_m: 0.0,
            settle_within_m: 0.0,
        },
        grid,
        &classes,
        &vec![0; classes.len()],
        (goal.0 as f32, goal.1 as f32),
    );
    let v = route.value(start.0 as f32, start.1 as f32);
    v.is_finite()
        .then(|| (f64::from(v) - config.sim.goal_tolerance_m).max(0.01))
}

/// The true classes of the whole world (and the episodes' paths) on a 5 cm grid of at most
/// `max_cells` a side, centred on the world: the grid, its centre and the classes.
fn world_truth(
    scene: &Scene,
    episodes: &[&Episode],
    max_cells: usize,
) -> (GridSpec, Pose2, Vec<u8>) {
    let (x0, y0, x1, y1) = extent(scene, episodes);
    let cell_m = 0.05f32;
    let cells = ((x1 - x0).max(y1 - y0) / f64::from(cell_m))
        .ceil()
        .clamp(10.0, max_cells as f64) as usize;
    let grid = GridSpec { cells, cell_m };
    let centre = pose2(0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.0);
    let mut classes = Vec::new();
    mimnav_sim::truth::truth_grid(scene, &centre, grid, &mut classes);
    (grid, centre, classes)
}

/// The world's extent (objects, start, goal and the episodes' paths): x0, y0, x1, y1.
fn extent(scene: &Scene, episodes: &[&Episode]) -> (f64, f64, f64, f64) {
    let (mut x0, mut y0, mut x1, mut y1) = (
        scene.start[0],
        scene.start[1],
        scene.start[0],
        scene.start[1],
    );
    let mut grow = |x: f64, y: f64, r: f64| {
        x0 = x0.min(x - r);
        y0 = y0.min(y - r);
        x1 = x1.max(x + r);
        y1 = y1.max(y + r);
    };
    grow(scene.goal[0], scene.goal[1], 0.5);
    for o in &scene.objects {
        let (c, r) = o.bound;
        grow(c[0], c[1], r.min(12.0));
    }
    for e in episodes {
        for &(x, y) in &e.trajectory {
            grow(x, y, 0.5);
        }
    }
    (x0, y0, x1, y1)
}

/// A top view of `scene` (the true classes) with every episode's path.
fn plot(scene: &Scene, episodes: &[&Episode]) -> Image {
    let (grid, centre, classes) = world_truth(scene, episodes, 600);
    let (cells, cell) = (grid.cells, grid.cell_m);
    // x to the right, y up
    let px = 2usize;
    let mut img = Image::new(cells * px, cells * px);
    let h = f64::from(grid.half_extent_m());
    let to_px = |x: f64, y: f64| {
        let (x, y) = centre.to_local(x, y);
        (
            (x + h) / f64::from(cell) * px as f64,
            (h - y) / f64::from(cell) * px as f64,
        )
    };
    for v in 0..img.height {
        for u in 0..img.width {
            let x = (u as f64 + 0.5) / px as f64 * f64::from(cell) - h;
            let y = h - (v as f64 + 0.5) / px as f64 * f64::from(cell);
            let class = grid
                .cell_of(x as f32, y as f32)
                .map_or(cell_class::FREE, |(r, c)| classes[grid.index(r, c)]);
            let colour = match class {
                cell_class::SOLID => [200, 200, 200],
                cell_class::PASSABLE => render::PASSABLE,
                cell_class::GLASS => render::GLASS,
                cell_class::SUSPECTED_GLASS => render::SUSPECTED_GLASS,
                _ => [0, 0, 0],
            };
            img.put(u as i64, v as i64, colour);
        }
    }
    for e in episodes {
        for w in e.trajectory.windows(2) {
            img.line(
                to_px(w[0].0, w[0].1),
                to_px(w[1].0, w[1].1),
                e.method.colour(),
            );
        }
        if e.ending == Ending::Contact
            && let Some(&(x, y)) = e.trajectory.last()
        {
            let (u, v) = to_px(x, y);
            img.disc(u, v, 3.0, [255, 0, 0]);
        }
    }
    let (u, v) = to_px(scene.start[0], scene.start[1]);
    img.disc(u, v, 4.0, [255, 255, 255]);
    let (u, v) = to_px(scene.goal[0], scene.goal[1]);
    img.disc(u, v, 5.0, render::GOAL);
    img
}
