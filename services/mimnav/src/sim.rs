//! `mimnav sim`: runs the simulator as its own process.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Result;

use crate::procs::{Service, service_binary};

/// Arguments of `mimnav sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    /// The world (default: sim.world of the config).
    #[arg(long, value_name = "FILE")]
    world: Option<PathBuf>,
    /// Simulated seconds [default: 1 with --pcap, else until the episode ends].
    #[arg(long)]
    seconds: Option<f64>,
    /// Write a capture here instead of streaming.
    #[arg(long, value_name = "OUT")]
    pcap: Option<PathBuf>,
    /// One revolution at a time, waiting for the stack's command after each.
    #[arg(long)]
    lockstep: bool,
    /// Seed of the random draws.
    #[arg(long)]
    seed: Option<u64>,
    /// Print the episode's summary as one JSON line.
    #[arg(long)]
    json: bool,
}

/// Starts `mimnav-sim` with the same config and waits for it; its exit status is ours.
pub fn run(config_path: Option<&Path>, sets: &[String], args: &SimArgs) -> Result<ExitCode> {
    let binary = service_binary("mimnav-sim")?;
    let mut a: Vec<String> = Vec::new();
    if let Some(p) = config_path {
        a.extend(["--config".into(), p.display().to_string()]);
    }
    for s in sets {
        a.extend(["--set".into(), s.clone()]);
    }
    if let Some(w) = &args.world {
        a.extend(["--world".into(), w.display().to_string()]);
    }
    if let Some(s) = args.seconds {
        a.extend(["--seconds".into(), s.to_string()]);
    }
    if let Some(p) = &args.pcap {
        a.extend(["--pcap".into(), p.display().to_string()]);
    }
    if let Some(s) = args.seed {
        a.extend(["--seed".into(), s.to_string()]);
    }
    if args.lockstep {
        a.push("--lockstep".into());
    }
    if args.json {
        a.push("--json".into());
    }
    let mut sim = Service::start(&binary, &a)?;
    // Ctrl-C reaches the child too (same process group); wait for it to finish
    let status = loop {
        if let Some(s) = sim.exited() {
            break s;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Ok(match status.code() {
        Some(0) => ExitCode::SUCCESS,
        Some(c) => ExitCode::from(c.clamp(1, 255) as u8),
        None => ExitCode::from(1),
    })
}
