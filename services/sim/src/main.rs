//! `mimnav-sim`: the scenario simulator service.
//!
//! Wiring only. Three ways to run:
//! - `--pcap OUT`: write a capture of `--seconds` of the sensor (the robot stands at the start);
//! - streaming (default): send the sensor's packets over UDP in real time, as a VLP-16 would,
//!   follow `cmd_vel`, publish `odom` and `sim/truth`;
//! - `--lockstep`: the same, as fast as the machine allows, one revolution at a time, waiting
//!   after each for the stack's command computed from it.

use std::io::Write;
use std::net::{SocketAddr, UdpSocket};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use mimnav_shared::config::Config;
use mimnav_shared::ipc::{self, Listening, ValueSubscriber};
use mimnav_shared::service::{self, Health, Service, ServiceCli};
use mimnav_shared::topics::{TruthHeader, VelocityCommand};
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim, SimSettings};

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
    #[arg(long, value_parser = seconds)]
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

fn seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v > 0.0 && v <= 86_400.0 => Ok(v),
        _ => Err(format!("{s} is out of range: allowed above 0 to 86400")),
    }
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
    service::main("mimnav-sim", |args: Args, config| {
        let path = (args.world.clone()).unwrap_or_else(|| config.sim.world_path(&config.dir()));
        let world = match WorldFile::load(&path) {
            Ok(w) => w,
            Err(e) => {
                eprintln!("mimnav-sim: {e}");
                return Ok(ExitCode::from(2));
            }
        };
        let sim = |epoch_ns| {
            Sim::new(
                world.compile(),
                SimSettings::from_config(&config),
                config.sim.seed,
                epoch_ns,
            )
        };
        let Some(out) = &args.pcap else {
            return run_live(&config, sim, args.seconds, args.json);
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
        println!(
            "{}: {} data packets, {} revolutions, {seconds} s of {} (seed {})",
            out.display(),
            stats.packets,
            stats.revolutions,
            world.name,
            config.sim.seed
        );
        Ok(ExitCode::SUCCESS)
    })
}

fn run_live(
    config: &Config,
    sim: impl Fn(u64) -> Sim,
    seconds: Option<f64>,
    json: bool,
) -> Result<ExitCode> {
    let svc = Service::open(config, "sim")?;
    let (v, target, mut h) = (&config.velodyne, config.sim.udp_target, svc.health());
    let bind: SocketAddr = if target.is_ipv4() {
        "0.0.0.0:0".parse()?
    } else {
        "[::]:0".parse()?
    };
    let udp = UdpSocket::bind(bind).context("cannot open the sending UDP socket")?;
    let (data_to, position_to) = (
        SocketAddr::new(target, v.data_port),
        (v.position_port != 0).then(|| SocketAddr::new(target, v.position_port)),
    );
    let cmd = ipc::cmd_vel_subscriber(svc.node())?;
    let odom = ipc::odom_publisher(svc.node())?;
    let truth = ipc::truth_publisher(svc.node(), config.map.grid().len())?;
    let lockstep = config.sim.lockstep;
    // the sensor's clock is the host's, as with a GPS-synchronised sensor, so the driver resolves
    // the hour of its timestamps the same way
    let epoch_ns = ipc::realtime_ns() / 1000 * 1000;
    let mut sim = sim(epoch_ns);
    tracing::info!(world = %sim.scene().name, to = %data_to, lockstep, seed = config.sim.seed, "simulating");
    let send = |h: &mut Health, bytes: &[u8], to: SocketAddr| {
        if let Err(e) = udp.send_to(bytes, to) {
            h.faults.record(
                "udp_send_failed",
                Instant::now(),
                format_args!("sending to {to}: {e}"),
            );
        }
    };
    let (anchor, limit_s, mut truth_buf) =
        (Instant::now(), seconds.unwrap_or(f64::INFINITY), Vec::new());
    let (mut next_odom_ns, mut odom_seq, mut rev_stamp) = (epoch_ns, 0u64, sim.now_ns());
    let (mut stopped, mut waits_timed_out, mut valid_until) = (false, 0u64, 0u64);
    while sim.elapsed_s() < limit_s {
        let step = sim.step();
        if !lockstep
            && !svc.sleep_until(
                &mut h,
                anchor + Duration::from_nanos(step.send_ns - epoch_ns),
            )
        {
            stopped = true;
            break;
        }
        if let (Some((pos, _)), Some(to)) = (step.position, position_to) {
            send(&mut h, &pos, to);
        }
        // the pose that goes with a revolution is published before its last packet, so that the
        // mapper and the planner planning on it see it (lock-step runs are then reproducible)
        if step.completes_revolution || !lockstep && step.send_ns >= next_odom_ns {
            if let Err(e) = odom.publish(sim.odometry(odom_seq, ipc::monotonic_ns())) {
                h.faults.record("publish_failed", Instant::now(), e);
            }
            (odom_seq, next_odom_ns) = (odom_seq + 1, step.send_ns + 20_000_000);
        }
        send(&mut h, &step.data, data_to);
        if !lockstep {
            match cmd.latest() {
                Ok(Some(c)) => {
                    sim.set_command(f64::from(c.v), f64::from(c.omega));
                    valid_until = c.valid_until_mono_ns;
                }
                Ok(None) => {}
                Err(e) => _ = h.faults.record("receive_failed", Instant::now(), e),
            }
            // a real base stops when its command expires
            if valid_until != 0 && ipc::monotonic_ns() > valid_until {
                sim.set_command(0.0, 0.0);
                valid_until = 0;
            }
        }
        if step.completes_revolution {
            let completed = std::mem::replace(&mut rev_stamp, sim.revolution_start().0);
            let grid = config.map.grid();
            sim.truth(grid, &mut truth_buf);
            let p = sim.base().pose;
            let header = TruthHeader {
                seq: sim.revolutions(),
                stamp_ns: completed,
                x: p.x,
                y: p.y,
                yaw: p.yaw,
                cells: grid.cells as u32,
                cell_m: grid.cell_m,
            };
            if let Err(e) = truth.publish(header, &truth_buf) {
                h.faults.record("publish_failed", Instant::now(), e);
            }
            if lockstep {
                match wait_for_answer(&svc, &mut h, &cmd, completed, config.sim.lockstep_timeout_s)
                {
                    Some(Some(c)) => sim.set_command(f64::from(c.v), f64::from(c.omega)),
                    Some(None) => {
                        waits_timed_out += 1;
                        let what = format_args!(
                            "no command for revolution {} within {} s",
                            sim.revolutions(),
                            config.sim.lockstep_timeout_s
                        );
                        h.faults.record("lockstep_timeout", Instant::now(), what);
                    }
                    None => {
                        stopped = true;
                        break;
                    }
                }
            }
        }
        if sim.outcome() != Outcome::Running && seconds.is_none() {
            break;
        }
    }
    let summary = sim.summary(stopped, waits_timed_out);
    match json {
        true => println!("{}", serde_json::to_string(&summary)?),
        false => println!("{summary}"),
    }
    tracing::info!(faults = %h.faults.summary(), "simulation ended");
    Ok(match sim.outcome() {
        Outcome::GoalReached | Outcome::Running => ExitCode::SUCCESS,
        _ => ExitCode::from(3),
    })
}

/// Waits for a command computed from the revolution stamped `stamp_ns` or later: `Some(None)`
/// when `timeout_s` passed first, `None` when SIGTERM or SIGINT asked the process to stop.
fn wait_for_answer(
    svc: &Service,
    h: &mut Health,
    cmd: &ValueSubscriber<VelocityCommand>,
    stamp_ns: u64,
    timeout_s: f64,
) -> Option<Option<VelocityCommand>> {
    let until = Instant::now() + Duration::from_secs_f64(timeout_s);
    loop {
        while let Ok(Some(c)) = cmd.receive() {
            // the driver's stamp is the revolution's first firing, truncated to the µs
            if c.source_stamp_ns + 1000 >= stamp_ns {
                return Some(Some(c));
            }
        }
        let now = Instant::now();
        if now >= until {
            return Some(None);
        }
        h.sd.alive(now);
        if !ipc::sleep(svc.node(), Duration::ZERO) {
            return None;
        }
        cmd.heard_within((until - now).min(Duration::from_millis(50)));
    }
}
