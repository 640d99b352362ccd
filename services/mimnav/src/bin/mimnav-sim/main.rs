//! `mimnav-sim`: the scenario simulator service.
//!
//! Wiring only. Three ways to run:
//! - `--pcap OUT`: write a capture of `--seconds` of the sensor (the robot stands at the start);
//! - streaming (default): send the sensor's packets over UDP in real time, as a VLP-16 would,
//!   follow `cmd_vel`, publish `odom` and `sim/truth` (with `sim.base = "kobuki"`, a simulated
//!   Kobuki on a pseudo-terminal moves the robot instead, driven by `mimnav-kobuki`; with
//!   `sim.sick = true`, a simulated SICK 2D ladar serves `mimnav-sick` over TCP as well);
//! - `--lockstep`: the same, as fast as the machine allows, one revolution at a time, waiting
//!   after each for the stack's command computed from it.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use mimnav_config::Config;
use mimnav_shared::service::{self, ServiceCli};
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Sim};

mod kobuki;
mod live;
mod sick;

/// The scenario simulator: a VLP-16 in a world, streaming packets (UDP), writing a capture, or
/// lock-stepped with the stack.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-sim", version)]
struct Args {
    #[command(flatten)]
    service: mimnav_shared::cli::ServiceArgs,
    /// The world (default: sim.world).
    #[arg(long, value_name = "FILE")]
    world: Option<PathBuf>,
    /// Stop after this much simulated time, s [default: 1 with --pcap, else when the episode
    /// ends].
    #[arg(long, value_parser = mimnav_shared::cli::seconds_arg)]
    seconds: Option<f64>,
    /// Write a capture here instead of streaming.
    #[arg(long, value_name = "OUT")]
    pcap: Option<PathBuf>,
    /// One revolution at a time, waiting for the stack's answer (sets sim.lockstep).
    #[arg(long)]
    lockstep: bool,
    /// Seed of the random draws (sets sim.seed).
    #[arg(long)]
    seed: Option<u64>,
    /// Print the episode's summary as one JSON line.
    #[arg(long)]
    json: bool,
}

impl ServiceCli for Args {
    fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs {
        &self.service
    }
    fn overrides(&self) -> Vec<String> {
        let lockstep = self.lockstep.then(|| "sim.lockstep=true".to_string());
        lockstep
            .into_iter()
            .chain(self.seed.map(|s| format!("sim.seed={s}")))
            .collect()
    }
}

fn main() -> ExitCode {
    service::main("mimnav-sim", |args: Args, config: Config| {
        let path = (args.world.clone()).unwrap_or_else(|| config.sim.world_path(&config.dir()));
        let world = match WorldFile::load(&path) {
            Ok(w) => w,
            Err(e) => {
                mimnav_shared::cli::stderr_line(format_args!("mimnav-sim: {e}"));
                return Ok(ExitCode::from(2));
            }
        };
        let sim = |epoch_ns| {
            Sim::new(
                world.compile(),
                config.sim_settings(),
                config.sim.seed,
                epoch_ns,
            )
        };
        let Some(out) = &args.pcap else {
            return live::run(&config, sim, args.seconds, args.json);
        };
        let seconds = args.seconds.unwrap_or(1.0);
        let file = std::fs::File::create(out)
            .with_context(|| format!("cannot create {}", out.display()))?;
        let (v, mut w) = (&config.velodyne, std::io::BufWriter::new(file));
        let stats = mimnav_sim::write_capture(
            &mut sim(DEFAULT_EPOCH_NS),
            seconds,
            (v.data_port, v.position_port),
            &mut w,
        )
        .map_err(anyhow::Error::from)
        .and_then(|s| w.flush().map(|()| s).map_err(anyhow::Error::from))
        .with_context(|| format!("cannot write {}", out.display()))?;
        // a closed stdout does not undo the capture written (issue 23 item 4)
        mimnav_shared::cli::stdout_line(format_args!(
            "{}: {} data packets, {} revolutions, {seconds} s of {} (seed {})",
            out.display(),
            stats.packets,
            stats.revolutions,
            world.name,
            config.sim.seed
        ));
        Ok(ExitCode::SUCCESS)
    })
}
