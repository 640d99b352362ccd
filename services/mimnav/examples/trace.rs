//! Debugging a run revolution by revolution: runs one episode of a world through the lock-step
//! runner (the services' own step types, the deployed method) and prints each revolution's pose
//! and command (status, flags as in `command_flags`, v, ω); writes the planner's map (robot at
//! the centre, heading up, goal in blue) every EVERY revolutions and for the last four. How the
//! glass failures of issue 22 were read.
//!
//! ```sh
//! cargo run --release -p mimnav --example trace -- WORLD OUTDIR [EVERY] [--seed N] [--config FILE] [--set KEY=VALUE]…
//! ```
//!
//! Environment: `TRACE_NEAR=K` prints the classes within K cells of the robot and the route's
//! lengths around it every EVERY revolutions; with it, `TRACE_ROUTE=R` the route's lengths and
//! the cost of a metre into each coarse cell on a 0.25 m lattice within R m; `TRACE_AT=X,Y,R`
//! each revolution's class counts within R m of the world point (X, Y); with `TRACE_PLANNER=1`
//! `TRACE_NEAR` prints the planner's copy of the map instead of the mapper's (the foliage
//! obstacles made solid); `TRACE_FOLIAGE=1` each revolution's returns the foliage classifier
//! calls obstacles, in the world frame (the first twelve; `TRACE_FOLIAGE=all`: every one).
use std::path::PathBuf;

use mimnav_config::Config;
use mimnav_mapper::render::{Marks, render_map};
use mimnav_runner::{Lockstep, Options};
use mimnav_shared::pose::Pose2Ext;
use mimnav_sim::world::WorldFile;

const USAGE: &str =
    "usage: trace WORLD OUTDIR [EVERY] [--seed N] [--config FILE] [--set KEY=VALUE]...";

fn main() -> std::process::ExitCode {
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("trace: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}

fn run() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| -> Vec<String> {
        (args.windows(2))
            .filter(|w| w[0] == name)
            .map(|w| w[1].clone())
            .collect()
    };
    let (sets, config_path) = (flag("--set"), flag("--config").pop());
    // the episode seed, as `mimnav eval --first-seed` numbers them
    let seed: u64 = match flag("--seed").pop() {
        Some(s) => s
            .parse()
            .map_err(|_| anyhow::anyhow!("--seed {s}: not a number; {USAGE}"))?,
        None => 1,
    };
    let positional: Vec<&String> = (args.iter().enumerate())
        .filter(|(i, a)| !a.starts_with("--") && (*i == 0 || !args[i - 1].starts_with("--")))
        .map(|(_, a)| a)
        .collect();
    let (Some(world), Some(out)) = (positional.first(), positional.get(1)) else {
        anyhow::bail!("{USAGE}");
    };
    let (world, out) = (PathBuf::from(world), PathBuf::from(out));
    let every: usize = match positional.get(2) {
        Some(s) => s
            .parse()
            .map_err(|_| anyhow::anyhow!("EVERY: {s}: not a count; {USAGE}"))?,
        None => 10,
    };
    let every = every.max(1);
    // TRACE_NEAR=K: the classes within K cells of the robot as text, and the route's lengths
    let near: usize = std::env::var("TRACE_NEAR")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0);
    // TRACE_AT=X,Y,R: each revolution, the classes of the cells within R m of the world point
    // (X, Y) — what the map held of an object the robot met
    let at: Option<[f64; 3]> = std::env::var("TRACE_AT").ok().and_then(|v| {
        let f: Vec<f64> = v.split(',').filter_map(|s| s.trim().parse().ok()).collect();
        (f.len() == 3).then(|| [f[0], f[1], f[2]])
    });
    // TRACE_FOLIAGE=1 (or all): the returns the foliage classifier calls obstacles, which the
    // planner draws solid; TRACE_PLANNER=1: the planner's copy of the map for TRACE_NEAR
    let foliage = std::env::var("TRACE_FOLIAGE").ok();
    let planner_map = std::env::var("TRACE_PLANNER").is_ok_and(|v| v == "1");
    let config_path = config_path.map(PathBuf::from);
    let config =
        Config::resolve(config_path.as_deref(), &sets).map_err(|e| anyhow::anyhow!("{e}"))?;
    std::fs::create_dir_all(&out)?;
    let scene = WorldFile::load(&world)
        .map_err(|e| anyhow::anyhow!("{e}"))?
        .compile();
    let goal = scene.goal;
    let mut run = Lockstep::new(&config, scene, seed, Options::deployed(&config))?;
    run.set_goal(goal[0], goal[1], config.sim.goal_tolerance_m)?;
    let grid = config.map.grid();
    let mut frames: Vec<(usize, mimnav_mapper::render::Image)> = Vec::new();
    let mut n = 0;
    while let Some(turn) = run.next_revolution()? {
        n += 1;
        let pose = run.sim().base().pose;
        let (gx, gy) = pose.to_local(goal[0], goal[1]);
        let img = render_map(
            grid,
            run.classes(),
            &[],
            &Marks {
                robot_radius_m: config.robot.radius_m,
                goal: Some((gx, gy)),
                ..Marks::default()
            },
        );
        let cmd = turn.command.map(|(d, c)| (d.status, d.flags, c.v, c.omega));
        println!(
            "rev {n} pose ({:.2},{:.2},{:.2}) cmd {:?}",
            pose.x(),
            pose.y(),
            pose.rotation.angle(),
            cmd
        );
        if let Some([ax, ay, ar]) = at {
            print_at(grid, run.classes(), pose.to_local(ax, ay), ar);
        }
        if let Some(f) = &foliage {
            print_foliage(&pose, run.verdict(), f == "all");
        }
        if n % every == 0 {
            if near > 0 {
                let classes = if planner_map {
                    run.pilot().classes()
                } else {
                    run.classes()
                };
                print_near(grid, classes, run.pilot().planner().route(), near);
            }
            img.write_png(&out.join(format!("rev{n:04}.png")))?;
        }
        frames.push((n, img));
        if frames.len() > 4 {
            frames.remove(0);
        }
    }
    for (n, img) in &frames {
        img.write_png(&out.join(format!("last{n:04}.png")))?;
    }
    println!("outcome {:?}", run.sim().outcome());
    Ok(())
}

/// The foliage verdict's obstacle returns in the world frame (the sensor frame is the robot's,
/// as the planner draws them): their count and the first twelve (`all`: every one).
fn print_foliage(
    pose: &mimnav_shared::pose::Pose2,
    verdict: &[mimnav_shared::topics::FoliageReturn],
    all: bool,
) {
    use mimnav_shared::topics::foliage_class;
    let points: Vec<String> = (verdict.iter())
        .filter(|r| r.class == foliage_class::OBSTACLE && r.range_m > 0.0)
        .map(|r| {
            let (s, c) = f64::from(r.angle_rad).sin_cos();
            let p = pose.transform_point(&mimnav_shared::pose::Point2::new(
                f64::from(r.range_m) * c,
                f64::from(r.range_m) * s,
            ));
            format!("({:.2},{:.2})", p.x, p.y)
        })
        .collect();
    let shown = if all {
        points.len()
    } else {
        points.len().min(12)
    };
    println!(
        "  foliage obstacles {}: {}",
        points.len(),
        points[..shown].join(" ")
    );
}

/// How many cells of each class lie within `r` m of `(x, y)` (the robot's frame).
fn print_at(grid: mimnav_shared::grid::GridSpec, classes: &[u8], (x, y): (f64, f64), r: f64) {
    use mimnav_shared::topics::cell_class;
    let mut counts = [0usize; 7];
    let names = [
        "free",
        "solid",
        "passable",
        "glass",
        "suspected",
        "unknown",
        "outside",
    ];
    let steps = (r / grid.cell_m as f64).ceil() as i32;
    for i in -steps..=steps {
        for j in -steps..=steps {
            let (dx, dy) = (
                f64::from(i) * grid.cell_m as f64,
                f64::from(j) * grid.cell_m as f64,
            );
            if dx.hypot(dy) > r {
                continue;
            }
            let k = match grid.cell_of((x + dx) as f32, (y + dy) as f32) {
                None => 6,
                Some((rr, cc)) => match classes[grid.index(rr, cc)] {
                    cell_class::FREE => 0,
                    cell_class::SOLID => 1,
                    cell_class::PASSABLE => 2,
                    cell_class::GLASS => 3,
                    cell_class::SUSPECTED_GLASS => 4,
                    _ => 5,
                },
            };
            counts[k] += 1;
        }
    }
    let text: Vec<String> = (0..7)
        .filter(|&k| counts[k] > 0)
        .map(|k| format!("{} {}", names[k], counts[k]))
        .collect();
    println!("  at ({x:.2},{y:.2}) r {r}: {}", text.join(", "));
}

/// The classes within `near` cells of the robot (the map's centre; x, forward, up), one
/// character a cell: `.` free, `#` solid, `,` passable, `G` glass, `s` suspected glass, blank
/// unknown, `@` the robot's cell; then the route's length to the goal at the robot and 0.5 m
/// from it every 45° (0°: ahead, 90°: left).
fn print_near(
    grid: mimnav_shared::grid::GridSpec,
    classes: &[u8],
    route: &mimnav_planner::route::Route,
    near: usize,
) {
    use mimnav_shared::topics::cell_class;
    let Some((r0, c0)) = grid.cell_of(0.0, 0.0) else {
        return;
    };
    // rows run along x (forward), columns along y: print x decreasing down, y decreasing right
    for r in (r0.saturating_sub(near)..=(r0 + near).min(grid.cells - 1)).rev() {
        let line: String = (c0.saturating_sub(near)..=(c0 + near).min(grid.cells - 1))
            .rev()
            .map(|c| match classes[grid.index(r, c)] {
                _ if (r, c) == (r0, c0) => '@',
                cell_class::FREE => '.',
                cell_class::SOLID => '#',
                cell_class::PASSABLE => ',',
                cell_class::GLASS => 'G',
                cell_class::SUSPECTED_GLASS => 's',
                _ => ' ',
            })
            .collect();
        println!("  |{line}|");
    }
    let ring: Vec<String> = (0..8)
        .map(|k| {
            let a = f32::from(k as u8) * std::f32::consts::FRAC_PI_4;
            format!("{:.2}", route.value(0.5 * a.cos(), 0.5 * a.sin()))
        })
        .collect();
    println!(
        "  route {:.2}; at 0.5 m, 0°..315°: {}",
        route.value(0.0, 0.0),
        ring.join(" ")
    );
    // TRACE_ROUTE=R: on a 0.25 m lattice within R m (forward up, left to the left), the
    // route's lengths ("    -": none), then what a metre entering each cell costs ("   #": closed)
    if let Some(r) = std::env::var("TRACE_ROUTE")
        .ok()
        .and_then(|v| v.parse::<f32>().ok())
    {
        let k = (r / 0.25).round() as i32;
        let lattice = |cell: &dyn Fn(f32, f32) -> String| {
            for i in (-k..=k).rev() {
                let row: Vec<String> = (-k..=k)
                    .rev()
                    .map(|j| cell(0.25 * i as f32, 0.25 * j as f32))
                    .collect();
                println!("  {}", row.join(""));
            }
        };
        lattice(&|x, y| match route.value(x, y) {
            v if v.is_finite() => format!("{v:5.1}"),
            _ => "    -".into(),
        });
        lattice(&|x, y| match route.step_at(x, y) {
            Some(s) => format!("{s:4.1}"),
            None => "   #".into(),
        });
    }
}
