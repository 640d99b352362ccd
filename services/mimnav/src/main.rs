//! `mimnav`: the command-line front end. It starts the services as separate processes and shows
//! what they publish; it never runs an algorithm itself.

/// `outln!`: `println!` that returns the write's error instead of panicking, so a closed stdout
/// (`mimnav replay F | head -2`) ends the command quietly (see [`broken_pipe`]).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)
    }};
}

mod check_config;
mod demo;
mod eval;
mod family_eval;
mod foliage_eval;
mod goal;
mod install;
mod pool;
mod procs;
mod record;
mod replay;
mod score_map;
mod sim;
mod snapshot;
mod soak;
mod stack;
mod worlds;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use mimnav_config::Config;

/// mimnav: lidar-intensity navigation for a robot with a Velodyne VLP-16.
#[derive(Debug, Parser)]
#[command(name = "mimnav", version)]
struct Cli {
    /// The stack's config file [default: $MIMNAV_CONFIG, /etc/mimnav/mimnav.toml if it exists,
    /// else config/mimnav.toml in the current folder if it exists, else built-in defaults].
    #[arg(long, global = true, env = "MIMNAV_CONFIG")]
    config: Option<PathBuf>,
    /// Override one config key, e.g. --set velodyne.rpm=900 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE", global = true)]
    set: Vec<String>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Replay a VLP-16 capture through the driver (started as its own process) and print every
    /// revolution it publishes: point count, return-mode mix, rate.
    Replay(replay::ReplayArgs),
    /// Run the simulator: write a capture of a world (--pcap OUT), or stream it over UDP to the
    /// driver in real time (--lockstep: as fast as the stack answers).
    Sim(sim::SimArgs),
    /// Score the mapper on simulated worlds against their ground truth: precision, recall and
    /// F-score per class.
    ScoreMap(score_map::ScoreMapArgs),
    /// The main job: start the driver, mapper and planner as processes with the simulator
    /// streaming UDP packets to the driver, drive from the world's start to its goal, write a PNG
    /// of the map with the driven path and print the figures (exit 0 when the goal is reached).
    Demo(demo::DemoArgs),
    /// The stack as processes under a long or fast stream (issue 23): the simulator streams UDP
    /// at --time-scale times real time for --seconds of sensor time while the robot patrols;
    /// every revolution accounted for hop by hop, the services' memory sampled.
    Soak(soak::SoakArgs),
    /// Reproduce the paper's Table I: the scenario worlds × the intensity map (adaptive and
    /// uniform inflation) and the two baselines × seeds, lock-step in-process; success rate,
    /// normalised trajectory length, F-score, trajectory plots.
    Eval(eval::EvalArgs),
    /// Generated worlds (issue 22): write a set of a family (`generate`), list the families,
    /// check world files and whether the robot can reach their goal (`check`).
    Worlds(worlds::WorldsArgs),
    /// The foliage classifier's own evaluation (issue 6): false alarms per 1000 scans in pure
    /// grass, and the share of scans in which a visible trunk or rock raises the alarm, with the
    /// delay, on simulated worlds, standing and moving, lock-step in-process.
    FoliageEval(foliage_eval::FoliageEvalArgs),
    /// Write the next map the mapper publishes as a PNG, in the paper's colours.
    Snapshot(snapshot::SnapshotArgs),
    /// Record the stack's topics into an MCAP file (JSON messages with Foxglove's schemas) until
    /// --seconds, --max-bytes, SIGINT or SIGTERM.
    Record(record::RecordArgs),
    /// Send a navigation goal (odometry frame) to the running planner.
    Goal(goal::GoalArgs),
    /// Check the config file and print the settings in force.
    CheckConfig,
    /// Install the stack as system services: binaries, systemd units, the system user, the
    /// runtime directory and /etc/mimnav (as root; or --root DIR for a package or an image).
    Install(install::InstallArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let config_path = Config::front_end_path(cli.config.as_deref());
    let config = match Config::resolve(config_path.as_deref(), &cli.set) {
        Ok(c) => c,
        Err(e) => {
            mimnav_shared::cli::stderr_line(format_args!("mimnav: {e}"));
            return ExitCode::from(2);
        }
    };
    mimnav_shared::logging::init(&std::env::var("MIMNAV_LOG").unwrap_or_else(|_| "warn".into()));
    let result = match &cli.command {
        Command::Replay(args) => replay::run(&config, config_path.as_deref(), &cli.set, args),
        Command::Sim(args) => sim::run(config_path.as_deref(), &cli.set, args),
        Command::Demo(args) => demo::run(config_path.as_deref(), &cli.set, args),
        Command::Soak(args) => soak::run(config_path.as_deref(), &cli.set, args),
        Command::ScoreMap(args) => score_map::run(&config, args),
        Command::Eval(args) => eval::run(&config, args),
        Command::Worlds(args) => worlds::run(&config, args),
        Command::FoliageEval(args) => {
            foliage_eval::run(&config, config_path.as_deref(), &cli.set, args)
        }
        Command::Snapshot(args) => snapshot::run(&config, args),
        Command::Record(args) => record::run(&config, args),
        Command::Goal(args) => goal::run(&config, args),
        Command::Install(args) => install::run(args),
        Command::CheckConfig => check_config::run(&config),
    };
    match result {
        Ok(code) => code,
        // the reader of our output went away (`| head`): what it wanted it has; not a failure
        Err(e) if broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            mimnav_shared::cli::stderr_line(format_args!("mimnav: {e:#}"));
            ExitCode::from(1)
        }
    }
}

/// Whether `e` comes from writing to a pipe whose reader has closed it.
fn broken_pipe(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
