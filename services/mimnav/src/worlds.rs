//! `mimnav worlds`: generated worlds (issue 22). `generate` writes a set of a family as ordinary
//! world files, `families` lists the families, `check` says whether world files are well-formed
//! and whether the configured robot can reach their goal. The worlds themselves come from
//! `mimnav_sim::generate`, reachability from `mimnav_sim::reach` (the simulator's own collision
//! test); this module only reads arguments and writes files.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result, bail};
use mimnav_config::Config;
use mimnav_shared::config::Body;
use mimnav_sim::generate::{self, Family, REPORT_SEEDS, TUNE_SEEDS};
use mimnav_sim::reach;
use mimnav_sim::world::{Scene, WorldFile};

/// Which seed range a set is drawn from (docs/evaluation.md): parameters are chosen on `tune`
/// worlds, figures reported on `report` worlds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Split {
    /// Set seeds 1–9999.
    Tune,
    /// Set seeds 10000–19999.
    Report,
}

impl Split {
    fn range(self) -> std::ops::RangeInclusive<u64> {
        match self {
            Split::Tune => TUNE_SEEDS,
            Split::Report => REPORT_SEEDS,
        }
    }
}

/// A generated set: families, count, seed, split. Shared by `worlds generate` and `eval`.
#[derive(Debug, Clone, clap::Args)]
pub struct SetArgs {
    /// A family to generate (repeatable; `all`: every family; `mimnav worlds families` lists
    /// them).
    #[arg(long = "family", value_name = "NAME")]
    pub families: Vec<String>,
    /// Worlds per family.
    #[arg(long, default_value_t = 10)]
    pub count: u64,
    /// The set's seed: world i is drawn from seed + i [default: the split's first seed].
    #[arg(long)]
    pub seed: Option<u64>,
    /// The seed range the set must lie in: `tune` (1–9999) to choose parameters on, `report`
    /// (10000–19999) for published figures.
    #[arg(long, value_enum, default_value = "tune")]
    pub split: Split,
}

impl SetArgs {
    /// The families asked for, in table order.
    pub fn families(&self) -> Result<Vec<Family>> {
        let mut out = Vec::new();
        for name in &self.families {
            if name == "all" {
                out.extend(Family::ALL);
                continue;
            }
            match Family::parse(name) {
                Some(f) => out.push(f),
                None => bail!(
                    "--family {name}: no such family; families: all, {}",
                    Family::ALL.map(Family::name).join(", ")
                ),
            }
        }
        out.sort();
        out.dedup();
        Ok(out)
    }

    /// The set's seed, checked against the split: every world's seed (seed + i) inside it.
    pub fn seed(&self) -> Result<u64> {
        let range = self.split.range();
        let seed = self.seed.unwrap_or(*range.start());
        anyhow::ensure!(self.count >= 1, "--count must be at least 1");
        let last = seed.saturating_add(self.count - 1);
        if !range.contains(&seed) || !range.contains(&last) {
            let other = if self.split == Split::Tune {
                Split::Report
            } else {
                Split::Tune
            };
            let hint = if other.range().contains(&seed) {
                format!(" (they are {other:?} seeds: say --split {other:?})").to_lowercase()
            } else {
                String::new()
            };
            bail!(
                "--seed {seed} --count {}: world seeds {seed}–{last} are outside the {:?} range {}–{}{hint}",
                self.count,
                self.split,
                range.start(),
                range.end()
            );
        }
        Ok(seed)
    }

    /// The worlds of the set, family by family.
    pub fn generate(&self) -> Result<Vec<WorldFile>> {
        let seed = self.seed()?;
        let families = self.families()?;
        anyhow::ensure!(
            !families.is_empty(),
            "name a family: --family NAME or --family all"
        );
        Ok(families
            .into_iter()
            .flat_map(|f| generate::generate_set(f, seed, self.count))
            .collect())
    }
}

/// Arguments of `mimnav worlds`.
#[derive(Debug, clap::Args)]
pub struct WorldsArgs {
    #[command(subcommand)]
    command: WorldsCommand,
}

#[derive(Debug, clap::Subcommand)]
enum WorldsCommand {
    /// Write a generated set as world files, FAMILY-sSEED-iINDEX.toml, one line per world with
    /// whether the configured robot can reach its goal.
    Generate {
        #[command(flatten)]
        set: SetArgs,
        /// Folder to write into (created if missing; files of the same name are replaced).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
    },
    /// List the families and what their worlds hold.
    Families,
    /// Check world files (or every *.toml in folders): well-formed, and whether the configured
    /// robot can reach the goal. Exit 1 when one is not well-formed.
    Check {
        /// Files or folders.
        #[arg(required = true)]
        paths: Vec<PathBuf>,
    },
}

/// Every `*.toml` in `dir`, by name.
pub fn toml_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut v = Vec::new();
    for e in std::fs::read_dir(dir).with_context(|| format!("cannot read {}", dir.display()))? {
        let p = e
            .with_context(|| format!("cannot read {}", dir.display()))?
            .path();
        if p.extension().is_some_and(|x| x == "toml") {
            v.push(p);
        }
    }
    v.sort();
    anyhow::ensure!(!v.is_empty(), "{}: no *.toml world files", dir.display());
    Ok(v)
}

/// Whether the configured robot's body (the simulator's: a circle of `robot.radius_m`, or the
/// `length_m` × `width_m` rectangle) can reach `scene`'s goal circle.
pub fn passable(config: &Config, scene: &Scene) -> reach::Reach {
    reach::reach_body(scene, &config.robot.body(), config.sim.goal_tolerance_m)
}

/// Whether the configured robot's body grown by a map cell (`map.cell_m`) on every side still
/// reaches `scene`'s goal: a world passable only without it asks the robot to pass somewhere
/// with less room each side than one cell of the map it plans on can resolve (a 0.56 m hedge gap
/// leaves Spot's 0.5 m width 3 cm a side; its map drew a 0.71 m gap 0.6 m wide, the bushes' edge
/// cells whole).
pub fn passable_with_a_cell_to_spare(config: &Config, scene: &Scene) -> bool {
    let spare = config.map.cell_m;
    reach::reach_body(
        scene,
        &config.robot.body().grown(spare),
        config.sim.goal_tolerance_m,
    )
    .reachable
}

/// The robot and its body, for headings.
pub fn robot_label(config: &Config) -> String {
    match config.robot.body() {
        Body::Round(r) => format!("{} (round, radius {r:.2} m)", config.robot.name),
        Body::Rectangle { length_m, width_m } => {
            format!(
                "{} (body {length_m:.2} × {width_m:.2} m)",
                config.robot.name
            )
        }
    }
}

fn verdict(r: &reach::Reach) -> String {
    let what = match (r.reachable, r.start_blocked) {
        (true, _) => "passable",
        (false, true) => "impassable (the start touches an object)",
        (false, false) => "impassable",
    };
    // a world too large for the fill's bound is filled at a coarser cell (issue 23 item 2)
    if r.coarsened {
        format!(
            "{what} (on a {:.0} mm grid: the world is too large for a finer one)",
            r.cell_m * 1000.0
        )
    } else {
        what.to_string()
    }
}

/// Runs `mimnav worlds`.
pub fn run(config: &Config, args: &WorldsArgs) -> Result<ExitCode> {
    match &args.command {
        WorldsCommand::Families => {
            for f in Family::ALL {
                outln!("{:<18} {}", f.name(), f.describe())?;
            }
            Ok(ExitCode::SUCCESS)
        }
        WorldsCommand::Generate { set, out } => {
            let worlds = set.generate()?;
            std::fs::create_dir_all(out)
                .with_context(|| format!("cannot create {}", out.display()))?;
            outln!("for {}:", robot_label(config))?;
            for w in &worlds {
                let Some(g) = &w.generated else {
                    bail!("{}: generated without its [generated] record", w.name)
                };
                let family = Family::parse(&g.family)
                    .with_context(|| format!("unknown family {}", g.family))?;
                let path = out.join(generate::file_name(family, g.seed, g.index));
                let text = generate::to_toml(w)
                    .with_context(|| format!("cannot write {} as TOML", w.name))?;
                std::fs::write(&path, text)
                    .with_context(|| format!("cannot write {}", path.display()))?;
                let r = passable(config, &w.compile());
                outln!("{}: {}; {}", path.display(), verdict(&r), w.description)?;
            }
            outln!("{} worlds written to {}", worlds.len(), out.display())?;
            Ok(ExitCode::SUCCESS)
        }
        WorldsCommand::Check { paths } => {
            let mut files = Vec::new();
            for p in paths {
                if p.is_dir() {
                    files.extend(toml_files(p)?);
                } else {
                    files.push(p.clone());
                }
            }
            outln!("for {}:", robot_label(config))?;
            let mut bad = 0;
            for f in &files {
                let w = WorldFile::load(f)?;
                match generate::check(&w) {
                    Ok(()) => {
                        let scene = w.compile();
                        let r = passable(config, &scene);
                        let from = w.generated.as_ref().map_or_else(
                            || "hand-made".to_string(),
                            |g| format!("{} seed {} index {}", g.family, g.seed, g.index),
                        );
                        let room = match r.reachable {
                            false => "",
                            true if passable_with_a_cell_to_spare(config, &scene) => {
                                ", with a map cell to spare each side"
                            }
                            true => ", with less than a map cell to spare somewhere",
                        };
                        outln!(
                            "{}: well-formed, {}{room}; {from}",
                            f.display(),
                            verdict(&r)
                        )?;
                    }
                    Err(e) => {
                        bad += 1;
                        outln!("{}: NOT well-formed: {e}", f.display())?;
                    }
                }
            }
            Ok(if bad == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            })
        }
    }
}
