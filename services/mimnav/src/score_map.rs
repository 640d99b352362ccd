//! `mimnav score-map`: how well the mapper classifies each bundled world, against the
//! simulator's ground truth.
//!
//! Runs in one process, lock-step and deterministic: the simulator drives the world's survey
//! route, its packets go through the driver's decoder and revolution assembler, each revolution
//! through the mapper with the simulator's exact odometry, and each map is scored against the
//! truth of the same instant (protocol in `mimnav_mapper::score`).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_mapper::score::{ClassScore, MapScore, score, score_excluding};
use mimnav_runner::{Drive, FoliageUse, Lockstep, MapSource, Options};
use mimnav_sim::Outcome;
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::WorldFile;

/// Arguments of `mimnav score-map`.
#[derive(Debug, clap::Args)]
pub struct ScoreMapArgs {
    /// Worlds to score (default: every world in the config's worlds folder).
    #[arg(long = "world", value_name = "FILE")]
    worlds: Vec<PathBuf>,
    /// Score cells within this distance of the sensor, m.
    #[arg(long, default_value_t = 4.5)]
    range: f32,
    /// Seed of the simulation (default: sim.seed).
    #[arg(long)]
    seed: Option<u64>,
    /// Revolutions at the start that are not scored (the map needs one to fill).
    #[arg(long, default_value_t = 2)]
    warmup: u64,
}

/// The result of one world.
#[derive(Debug, Clone)]
pub struct WorldScore {
    /// World name.
    pub name: String,
    /// Summed over the scored revolutions.
    pub total: MapScore,
    /// The last revolution alone (what the map holds at the end of the route).
    pub last: MapScore,
    /// Summed over the scored revolutions, leaving out the cells of obstacles hidden in grass.
    pub visible: MapScore,
    /// Summed over the scored revolutions, leaving out the glass of panes that no beam has
    /// faced yet, neither they nor a pane joined to them on their line
    /// ([`mimnav_sim::truth::faces_pane`], [`mimnav_sim::truth::pane_line`]): what a map built
    /// from the returns can hold. Only its glass class is meaningful.
    pub faced: MapScore,
    /// Obstacles hidden in grass (no taller than the grass they stand in).
    pub hidden: usize,
    /// Revolutions scored.
    pub revolutions: u64,
    /// How the survey ended.
    pub outcome: Outcome,
    /// Mean time the mapper took per revolution, µs.
    pub mapper_us: f64,
}

/// Drives `world`'s survey and scores every revolution.
pub fn score_world(
    config: &Config,
    path: &Path,
    seed: u64,
    range: f32,
    warmup: u64,
) -> Result<WorldScore> {
    let world = WorldFile::load(path)?;
    let scene = world.compile();
    let hidden = scene.only(&scene.hidden_in_grass());
    let mut hidden_cells = Vec::new();
    let mut exclude = Vec::new();
    let survey = scene.survey.clone();
    // the deployed mapper's step on the driver's revolutions, the simulator's odometry
    let options = Options {
        map: MapSource::Intensity,
        foliage: FoliageUse::Off,
        inflation: None,
        drive: Drive::External,
    };
    let mut stack = Lockstep::new(config, scene, seed, options)?;
    // the panes of each pane's line, and whether each pane has been faced yet
    let lines: Vec<Vec<usize>> = {
        let scene = stack.sim().scene();
        (0..scene.objects.len())
            .map(|i| mimnav_sim::truth::pane_line(scene, i))
            .collect()
    };
    let mut faced = vec![false; lines.len()];
    let specular = config.sim.glass_specular_deg;
    let (mut unfaced_cells, mut unfaced_mask) = (Vec::new(), Vec::new());
    let mut faced_score = MapScore::default();
    let mut driver = WaypointDriver::new(survey, 0.25);
    let grid = config.map.grid();
    let mut truth = Vec::new();
    let (mut total, mut last) = (MapScore::default(), MapScore::default());
    let mut visible = MapScore::default();
    let (mut revolutions, mut seen) = (0u64, 0u64);
    let mut mapper_ns = 0u128;
    let limits = stack.sim().settings().robot.clone();
    while !driver.done() {
        let Some(turn) = stack.next_revolution()? else {
            break;
        };
        seen += 1;
        mapper_ns += u128::from(turn.bin_ns + turn.map_ns);
        let (sim, classes) = (stack.sim(), stack.classes());
        let pose = sim.base().pose;
        sim.truth(grid, &mut truth);
        let sensor = sim.sensor_position();
        let panes = sim.scene();
        for (f, o) in faced.iter_mut().zip(&panes.objects) {
            *f = *f || mimnav_sim::truth::faces_pane(o, sensor, specular);
        }
        if seen > warmup {
            last = score(classes, &truth, grid, range);
            total.add(&last);
            if hidden.objects.is_empty() {
                visible.add(&last);
            } else {
                mimnav_sim::truth::truth_grid(&hidden, &pose, grid, &mut hidden_cells);
                exclude.clear();
                exclude.extend(
                    hidden_cells
                        .iter()
                        .map(|&c| c != mimnav_shared::topics::cell_class::FREE),
                );
                visible.add(&score_excluding(
                    classes,
                    &truth,
                    grid,
                    range,
                    Some(&exclude),
                ));
            }
            // the glass of the panes not faced yet, on their line or themselves, left out
            let unfaced: Vec<usize> = lines
                .iter()
                .enumerate()
                .filter(|(_, line)| !line.is_empty() && !line.iter().any(|&k| faced[k]))
                .map(|(i, _)| i)
                .collect();
            if unfaced.is_empty() {
                faced_score.add(&last);
            } else {
                mimnav_sim::truth::truth_grid(
                    &panes.only(&unfaced),
                    &pose,
                    grid,
                    &mut unfaced_cells,
                );
                unfaced_mask.clear();
                unfaced_mask.extend(unfaced_cells.iter().zip(&truth).map(|(&u, &t)| {
                    u == mimnav_shared::topics::cell_class::GLASS
                        && t == mimnav_shared::topics::cell_class::GLASS
                }));
                faced_score.add(&score_excluding(
                    classes,
                    &truth,
                    grid,
                    range,
                    Some(&unfaced_mask),
                ));
            }
            revolutions += 1;
        }
        let (v, w) = driver.command(&pose, &limits);
        stack.sim_mut().set_command(v, w);
    }
    let sim = stack.sim();
    Ok(WorldScore {
        name: world.name,
        total,
        last,
        visible,
        faced: faced_score,
        hidden: hidden.objects.len(),
        revolutions,
        outcome: sim.outcome(),
        mapper_us: mapper_ns as f64 / 1e3 / seen.max(1) as f64,
    })
}

fn cell(s: &ClassScore) -> String {
    if s.is_empty() {
        return "     –     ".into();
    }
    if s.tp + s.fn_ == 0 {
        // the class is not in this world: only wrong claims can be counted
        return format!("– ({} cells claimed)", s.fp);
    }
    format!("{:.3} {:.3} {:.3}", s.precision(), s.recall(), s.f_score())
}

/// The mean F-score of one column over the worlds that hold its class (the mean row of a run
/// over several worlds: what the evaluation reports a family by).
#[derive(Debug, Clone, Copy, Default)]
struct MeanF {
    sum: f64,
    worlds: usize,
}

impl MeanF {
    /// Takes one world's score of the class; a world without the class does not count.
    fn add(&mut self, s: &ClassScore) {
        if s.tp + s.fn_ > 0 {
            self.sum += s.f_score();
            self.worlds += 1;
        }
    }

    /// "F (of N)", or – where no world held the class.
    fn cell(&self) -> String {
        if self.worlds == 0 {
            return "     –     ".into();
        }
        format!(
            "F {:.3} (of {})",
            self.sum / self.worlds as f64,
            self.worlds
        )
    }
}

/// The worlds in the folder of the config's `sim.world` whose file names start with `prefix`,
/// sorted.
pub fn bundled_worlds(config: &Config, prefix: &str) -> Result<Vec<PathBuf>> {
    let dir = config.sim.world_path(&config.dir());
    let dir = dir
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| format!("cannot list the worlds in {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|e| e == "toml")
                && p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with(prefix))
        })
        .collect();
    v.sort();
    Ok(v)
}

/// Scores the worlds and prints a table.
pub fn run(config: &Config, args: &ScoreMapArgs) -> Result<ExitCode> {
    let worlds = if args.worlds.is_empty() {
        bundled_worlds(config, "")?
    } else {
        args.worlds.clone()
    };
    let seed = args.seed.unwrap_or(config.sim.seed);
    outln!(
        "cells within {} m, one cell of tolerance; precision recall F-score per class (– where the class is not in the world)\n",
        args.range
    )?;
    outln!(
        "| world | solid P R F | passable P R F | glass P R F | glass at the end (P R F) | glass of the panes faced (P R F) | solid, obstacles hidden in grass left out | revolutions | route | mapper µs/rev |"
    )?;
    outln!("|---|---|---|---|---|---|---|---|---|---|")?;
    // solid, passable, glass, glass at the end, glass of the panes faced, solid visible
    let mut means = [MeanF::default(); 6];
    for path in &worlds {
        let s = score_world(config, path, seed, args.range, args.warmup)?;
        for (m, c) in means.iter_mut().zip([
            &s.total.solid,
            &s.total.passable,
            &s.total.glass,
            &s.last.glass,
            &s.faced.glass,
            &s.visible.solid,
        ]) {
            m.add(c);
        }
        let outcome = match s.outcome {
            Outcome::Running | Outcome::GoalReached => "done".to_string(),
            Outcome::Contact(i) => format!("contact with object {i}"),
            Outcome::Timeout => "timeout".to_string(),
        };
        outln!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.0} |",
            s.name,
            cell(&s.total.solid),
            cell(&s.total.passable),
            cell(&s.total.glass),
            cell(&s.last.glass),
            cell(&s.faced.glass),
            if s.hidden == 0 {
                "(none hidden)".to_string()
            } else {
                format!("{} ({} hidden)", cell(&s.visible.solid), s.hidden)
            },
            s.revolutions,
            outcome,
            s.mapper_us
        )?;
    }
    if worlds.len() > 1 {
        let [solid, passable, glass, end, faced, visible] = means.map(|m| m.cell());
        outln!(
            "| mean F of the {} worlds holding the class | {solid} | {passable} | {glass} | {end} | {faced} | {visible} | | | |",
            worlds.len()
        )?;
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mean row averages a column's F-score over the worlds that hold its class: a world
    /// without it (no true cells) is left out, not counted as 0.
    #[test]
    fn the_mean_f_leaves_out_worlds_without_the_class() {
        let score = |tp, fp, fn_| ClassScore { tp, fp, fn_ };
        let mut m = MeanF::default();
        assert_eq!(m.cell().trim(), "–");
        m.add(&score(8, 2, 0)); // P 0.8, R 1: F 0.889
        m.add(&score(0, 5, 0)); // the class not in this world
        m.add(&score(5, 0, 5)); // P 1, R 0.5: F 0.667
        assert_eq!(m.worlds, 2);
        assert_eq!(m.cell(), "F 0.778 (of 2)");
    }

    /// A drive along x beside one pane it faces (its perpendicular's foot slides along it) and
    /// towards one it never faces (on a line parallel to the drive, beyond its end): the glass of
    /// the second is in all revolutions' truth, not in the faced panes'.
    #[test]
    fn a_pane_never_faced_is_left_out_of_the_faced_score_only() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let config = Config::load(&root.join("config/mimnav.toml"), &[]).expect("shipped config");
        let dir = std::env::temp_dir().join(format!("mimnav-score-faced-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("faced.toml");
        std::fs::write(
            &path,
            r#"name = "faced and not"
start = [0.0, 0.0, 0.0]
goal = [4.5, 0.0]
time_limit_s = 60.0
survey = [[4.5, 0.0]]

[ground]
reflectivity = 12

[[glass]]
from = [0.5, -1.5]
to = [3.5, -1.5]
bottom = 0.0
top = 2.5

[[glass]]
from = [6.5, 1.2]
to = [9.0, 1.2]
bottom = 0.0
top = 2.5
"#,
        )
        .expect("world written");
        let s = score_world(&config, &path, 1, 4.5, 2).expect("scored");
        let _ = std::fs::remove_dir_all(&dir);
        let (all, faced) = (s.total.glass, s.faced.glass);
        eprintln!("all {all:?}\nfaced {faced:?}");
        // the far pane is within 4.5 m at the end of the drive and never found
        assert!(all.fn_ > faced.fn_, "{all:?} {faced:?}");
        assert!(
            faced.tp + faced.fn_ > 0,
            "the faced pane is scored: {faced:?}"
        );
        assert!(
            faced.recall() > all.recall() && faced.recall() >= 0.9,
            "{all:?} {faced:?}"
        );
    }
}
