//! `mimnav eval` over generated worlds (issue 22): the table per family instead of per world.
//!
//! Each world is first checked against the ground truth for the configured robot
//! (`mimnav_sim::reach`: the simulator's own contact test, a circle of `robot.radius_m`, grass
//! and curtains passable). Then every world × method × seed runs as one episode through the same
//! lock-step runner as Table I ([`crate::eval::run_episode`]). A *passable* world counts as a
//! success when the goal is reached without contact; an *impassable* one when the robot has
//! touched nothing by the time limit (it stopped, froze or wandered, but did not hit).

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_sim::generate::Family;
use mimnav_sim::world::{Scene, WorldFile};

use crate::eval::{Ending, EvalArgs, Method, Touched, run_episode};

/// One world of the set and its verdict for the configured robot.
struct World {
    /// Family (the file's `[generated]` record; else "hand-made").
    family: String,
    /// The file it came from, or the generated name.
    source: String,
    scene: Scene,
    passable: bool,
    /// Passable with the body grown by a map cell on every side too
    /// ([`crate::worlds::passable_with_a_cell_to_spare`]); false when impassable.
    roomy: bool,
}

/// Per family and method: what the table shows.
#[derive(Debug, Default, Clone, serde::Serialize)]
struct Row {
    family: String,
    method: String,
    robot: String,
    worlds_passable: usize,
    worlds_impassable: usize,
    episodes: usize,
    successes: usize,
    passable_episodes: usize,
    reached: usize,
    /// Episodes on passable worlds with a map cell to spare each side, and those that reached
    /// the goal.
    roomy_episodes: usize,
    reached_roomy: usize,
    contacts_passable: usize,
    froze_passable: usize,
    timeout_passable: usize,
    impassable_episodes: usize,
    stopped_without_contact: usize,
    contacts_impassable: usize,
    /// Contacts (passable and impassable worlds) by what was touched ([`Touched`]); a pane
    /// faced in time was faced at least [`stop_s`] before the contact.
    contacts_glass_faced: usize,
    contacts_glass_faced_late: usize,
    contacts_glass_line_faced: usize,
    contacts_glass_never_faced: usize,
    contacts_hidden_in_grass: usize,
    contacts_solid: usize,
}

fn pct(n: usize, d: usize) -> String {
    if d == 0 {
        "–".into()
    } else {
        format!("{:.0} % ({n}/{d})", 100.0 * n as f64 / d as f64)
    }
}

/// The least time before a contact at which facing a pane still lets the robot stop short of
/// it: braking from the top speed at the largest deceleration, and one revolution for the map.
fn stop_s(config: &Config) -> f64 {
    let r = &config.robot;
    r.max_linear_mps / r.max_linear_accel + 60.0 / config.velodyne.rpm
}

/// The worlds the arguments name: `--worlds DIR` folders, `--world FILE`s and a generated set.
fn worlds(config: &Config, args: &EvalArgs) -> Result<Vec<World>> {
    let mut files: Vec<PathBuf> = Vec::new();
    for d in &args.world_dirs {
        files.extend(crate::worlds::toml_files(d)?);
    }
    files.extend(args.worlds.iter().cloned());
    let mut loaded: Vec<(String, WorldFile)> = Vec::new();
    for f in &files {
        loaded.push((f.display().to_string(), WorldFile::load(f)?));
    }
    if !args.set.families.is_empty() {
        for w in args.set.generate()? {
            loaded.push((w.name.clone(), w));
        }
    }
    anyhow::ensure!(!loaded.is_empty(), "no worlds");
    let workers = crate::pool::workers(args.jobs);
    let verdicts = crate::pool::run_all(&loaded, workers, true, |(_, w), _| {
        let mut scene = w.compile();
        if let Some(cap) = args.time_limit_s {
            scene.time_limit_s = scene.time_limit_s.min(cap);
        }
        let passable = crate::worlds::passable(config, &scene).reachable;
        let roomy = passable && crate::worlds::passable_with_a_cell_to_spare(config, &scene);
        (scene, passable, roomy)
    });
    Ok(loaded
        .into_iter()
        .zip(verdicts)
        .map(|((source, w), (scene, passable, roomy))| World {
            family: w
                .generated
                .as_ref()
                .map_or_else(|| "hand-made".to_string(), |g| g.family.clone()),
            source,
            scene,
            passable,
            roomy,
        })
        .collect())
}

/// Runs the evaluation per family and prints the table (and JSON lines with `--json`).
pub fn run(config: &Config, args: &EvalArgs, methods: &[Method]) -> Result<ExitCode> {
    let started = std::time::Instant::now();
    let worlds = worlds(config, args)?;
    let mut jobs = Vec::new();
    for w in 0..worlds.len() {
        for &m in methods {
            for s in 0..args.seeds {
                jobs.push((w, m, args.first_seed + s));
            }
        }
    }
    let workers = crate::pool::workers(args.jobs);
    let results = crate::pool::run_all(&jobs, workers, args.quiet, |&(w, m, seed), _| {
        run_episode(config, &worlds[w].scene, m, seed)
            .with_context(|| format!("{}, {}, seed {seed}", worlds[w].source, m.label()))
    });
    let episodes = results.into_iter().collect::<Result<Vec<_>>>()?;
    let robot = config.robot.name.clone();
    // family → method → row, families in the order met
    let mut order: Vec<String> = Vec::new();
    let mut rows: BTreeMap<(usize, u8), Row> = BTreeMap::new();
    for w in &worlds {
        if !order.contains(&w.family) {
            order.push(w.family.clone());
        }
    }
    // the families in table order, then the others as met
    order.sort_by_key(|f| {
        Family::ALL
            .iter()
            .position(|x| x.name() == f)
            .unwrap_or(Family::ALL.len())
    });
    let stop = stop_s(config);
    for (&(w, m, _), e) in jobs.iter().zip(&episodes) {
        let world = &worlds[w];
        let f = order.iter().position(|x| *x == world.family).unwrap_or(0);
        let row = rows.entry((f, m as u8)).or_insert_with(|| Row {
            family: world.family.clone(),
            method: m.key().into(),
            robot: robot.clone(),
            ..Row::default()
        });
        row.episodes += 1;
        match e.touched_kind {
            Some(Touched::Glass { faced_s }) if faced_s >= stop => row.contacts_glass_faced += 1,
            Some(Touched::Glass { .. }) => row.contacts_glass_faced_late += 1,
            Some(Touched::GlassLineFaced { .. }) => row.contacts_glass_line_faced += 1,
            Some(Touched::GlassNeverFaced) => row.contacts_glass_never_faced += 1,
            Some(Touched::HiddenInGrass) => row.contacts_hidden_in_grass += 1,
            Some(Touched::Solid) => row.contacts_solid += 1,
            None => {}
        }
        if world.roomy {
            row.roomy_episodes += 1;
            row.reached_roomy += usize::from(e.ending == Ending::Success);
        }
        if world.passable {
            row.passable_episodes += 1;
            match e.ending {
                Ending::Success => row.reached += 1,
                Ending::Contact => row.contacts_passable += 1,
                Ending::Froze => row.froze_passable += 1,
                Ending::Timeout => row.timeout_passable += 1,
            }
        } else {
            row.impassable_episodes += 1;
            if e.ending == Ending::Contact {
                row.contacts_impassable += 1;
            } else {
                row.stopped_without_contact += 1;
            }
        }
    }
    for ((f, _), row) in rows.iter_mut() {
        let of_family = worlds.iter().filter(|w| w.family == order[*f]);
        row.worlds_passable = of_family.clone().filter(|w| w.passable).count();
        row.worlds_impassable = of_family.filter(|w| !w.passable).count();
        row.successes = row.reached + row.stopped_without_contact;
    }
    outln!(
        "{} worlds, {} seeds each (from seed {}), {}, lock-step; passable worlds succeed on reaching the goal, impassable ones on touching nothing by the time limit\n",
        worlds.len(),
        args.seeds,
        args.first_seed,
        crate::worlds::robot_label(config),
    )?;
    outln!(
        "| family | method | worlds passable / impassable | success | passable: goal reached | ... with a map cell to spare each side | passable: contact / froze / timeout | impassable: no contact | impassable: contact |"
    )?;
    outln!("|---|---|---|---|---|---|---|---|---|")?;
    for row in rows.values() {
        outln!(
            "| {} | {} | {} / {} | {} | {} | {} | {} / {} / {} | {} | {} |",
            row.family,
            row.method,
            row.worlds_passable,
            row.worlds_impassable,
            pct(row.successes, row.episodes),
            pct(row.reached, row.passable_episodes),
            pct(row.reached_roomy, row.roomy_episodes),
            row.contacts_passable,
            row.froze_passable,
            row.timeout_passable,
            pct(row.stopped_without_contact, row.impassable_episodes),
            row.contacts_impassable,
        )?;
    }
    if rows
        .values()
        .any(|r| r.contacts_passable + r.contacts_impassable > 0)
    {
        outln!(
            "\nContacts by what was touched: a pane *faced* had a beam within `sim.glass_specular_deg` of its normal at some revolution before the contact, *late* when first less than {stop:.2} s before it (braking from the top speed, and one revolution); *only its line faced*: not the pane, but one joined to it on its line; *never faced*: neither, so no map built from the returns could hold it:\n"
        )?;
        outln!(
            "| family | method | contacts | glass, faced in time | glass, faced late | glass, only its line faced | glass never faced | hidden in grass | other solid |"
        )?;
        outln!("|---|---|---|---|---|---|---|---|---|")?;
        for row in rows.values() {
            let contacts = row.contacts_passable + row.contacts_impassable;
            if contacts > 0 {
                outln!(
                    "| {} | {} | {contacts} | {} | {} | {} | {} | {} | {} |",
                    row.family,
                    row.method,
                    row.contacts_glass_faced,
                    row.contacts_glass_faced_late,
                    row.contacts_glass_line_faced,
                    row.contacts_glass_never_faced,
                    row.contacts_hidden_in_grass,
                    row.contacts_solid,
                )?;
            }
        }
    }
    if args.json {
        for (&(w, m, seed), e) in jobs.iter().zip(&episodes) {
            let world = &worlds[w];
            let success = if world.passable {
                e.ending == Ending::Success
            } else {
                e.ending != Ending::Contact
            };
            let line = serde_json::json!({
                "kind": "episode",
                "family": world.family,
                "world": e.world,
                "source": world.source,
                "robot": robot,
                "passable": world.passable,
                "cell_to_spare": world.roomy,
                "method": m.key(),
                "seed": seed,
                "ending": e.ending.name(),
                "success": success,
                "path_m": e.path_m,
                "goal_left_m": e.goal_left_m,
                "elapsed_s": e.elapsed_s,
                "revolutions": e.revolutions,
                "blocked": e.blocked,
                "touched": e.touched,
                "touched_kind": e.touched_kind.map(Touched::name),
                "touched_faced_s": match e.touched_kind {
                    Some(Touched::Glass { faced_s } | Touched::GlassLineFaced { faced_s }) => {
                        Some(faced_s)
                    }
                    _ => None,
                },
            });
            outln!("{line}")?;
        }
        for row in rows.values() {
            let mut v = serde_json::to_value(row)?;
            if let Some(o) = v.as_object_mut() {
                o.insert("kind".into(), "family".into());
            }
            outln!("{v}")?;
        }
    }
    outln!(
        "\n{} episodes in {:.0} s on {} threads",
        episodes.len(),
        started.elapsed().as_secs_f64(),
        workers
    )?;
    Ok(ExitCode::SUCCESS)
}
