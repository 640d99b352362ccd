//! `mimnav-sim`: the scenario simulator service.
//!
//! Wiring only. Three ways to run:
//! - `--pcap OUT`: write a capture of `--seconds` of the sensor (the robot stands at the start);
//! - streaming (default): send the sensor's packets over UDP in real time, as a VLP-16 would,
//!   follow `cmd_vel`, publish `odom` and `sim/truth`;
//! - `--lockstep`: the same, as fast as the machine allows, one revolution at a time, waiting
//!   after each for the stack's command computed from it.

use std::net::{SocketAddr, UdpSocket};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::Parser;
use mimnav_shared::cli::ServiceArgs;
use mimnav_shared::config::Config;
use mimnav_shared::faults::Faults;
use mimnav_shared::ipc::{self, Listening, TruthPublisher, ValuePublisher, ValueSubscriber};
use mimnav_shared::topics::{Odometry, TruthHeader, VelocityCommand};
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim, SimSettings};

/// The scenario simulator: a VLP-16 in a world, streaming packets (UDP), writing a capture, or
/// lock-stepped with the stack.
#[derive(Debug, Parser)]
#[command(name = "mimnav-sim", version)]
struct Args {
    #[command(flatten)]
    service: ServiceArgs,
    /// The world (default: sim.world).
    #[arg(long, value_name = "FILE")]
    world: Option<PathBuf>,
    /// Stop after this much simulated time, s [default: 1 with --pcap, else when the episode
    /// ends].
    #[arg(long)]
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

fn main() -> ExitCode {
    let args = Args::parse();
    let mut set = Vec::new();
    if args.lockstep {
        set.push("sim.lockstep=true".into());
    }
    if let Some(s) = args.seed {
        set.push(format!("sim.seed={s}"));
    }
    let config = match args.service.load_or_exit("mimnav-sim", &set) {
        Ok(c) => c,
        Err(code) => return code,
    };
    if let Some(s) = args.seconds
        && !(s > 0.0 && s <= 86_400.0)
    {
        eprintln!("mimnav-sim: --seconds {s} is out of range: allowed above 0 to 86400");
        return ExitCode::from(2);
    }
    let world_path = args
        .world
        .clone()
        .unwrap_or_else(|| config.sim.world_path(&config.dir()));
    let world = match WorldFile::load(&world_path) {
        Ok(w) => w,
        Err(e) => {
            eprintln!("mimnav-sim: {e}");
            return ExitCode::from(2);
        }
    };
    mimnav_shared::logging::init(&config.log.level);
    let result = match &args.pcap {
        Some(out) => write_capture(&config, &world, out, args.seconds.unwrap_or(1.0)),
        None => run_live(&config, &world, args.seconds, args.json),
    };
    mimnav_shared::cli::finish("mimnav-sim", result)
}

fn write_capture(
    config: &Config,
    world: &WorldFile,
    out: &std::path::Path,
    seconds: f64,
) -> Result<ExitCode> {
    let mut sim = Sim::new(
        world.compile(),
        SimSettings::from_config(config),
        config.sim.seed,
        DEFAULT_EPOCH_NS,
    );
    let file =
        std::fs::File::create(out).with_context(|| format!("cannot create {}", out.display()))?;
    let v = &config.velodyne;
    let ports = (v.data_port, v.position_port);
    let mut w = std::io::BufWriter::new(file);
    let stats = mimnav_sim::write_capture(&mut sim, seconds, ports, &mut w)
        .with_context(|| format!("cannot write {}", out.display()))?;
    use std::io::Write;
    w.flush()
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
}

/// The stack's side of a live simulation.
struct Links {
    udp: UdpSocket,
    data_to: SocketAddr,
    position_to: Option<SocketAddr>,
    cmd: ValueSubscriber<VelocityCommand>,
    odom: ValuePublisher<Odometry>,
    truth: TruthPublisher,
    faults: Faults,
    odom_seq: u64,
    truth_buf: Vec<u8>,
}

impl Links {
    fn send(&mut self, bytes: &[u8], to: SocketAddr) {
        if let Err(e) = self.udp.send_to(bytes, to) {
            self.faults.record(
                "udp_send_failed",
                Instant::now(),
                format_args!("sending to {to}: {e}"),
            );
        }
    }

    fn publish_odom(&mut self, sim: &Sim) {
        let b = sim.base();
        let odom = Odometry {
            seq: self.odom_seq,
            stamp_ns: sim.now_ns(),
            rx_mono_ns: ipc::monotonic_ns(),
            x: b.pose.x,
            y: b.pose.y,
            yaw: b.pose.yaw,
            v: b.v as f32,
            omega: b.omega as f32,
        };
        self.odom_seq += 1;
        if let Err(e) = self.odom.publish(odom) {
            self.faults.record("publish_failed", Instant::now(), e);
        }
    }

    fn publish_truth(&mut self, sim: &Sim, config: &Config, stamp_ns: u64) {
        let grid = config.map.grid();
        sim.truth(grid, &mut self.truth_buf);
        let p = sim.base().pose;
        let header = TruthHeader {
            seq: sim.revolutions(),
            stamp_ns,
            x: p.x,
            y: p.y,
            yaw: p.yaw,
            cells: grid.cells as u32,
            cell_m: grid.cell_m,
        };
        if let Err(e) = self.truth.publish(header, &self.truth_buf) {
            self.faults.record("publish_failed", Instant::now(), e);
        }
    }
}

fn run_live(
    config: &Config,
    world: &WorldFile,
    seconds: Option<f64>,
    json: bool,
) -> Result<ExitCode> {
    let node = ipc::node(config, "sim")?;
    let v = &config.velodyne;
    let target = config.sim.udp_target;
    let bind: SocketAddr = if target.is_ipv4() {
        "0.0.0.0:0".parse()?
    } else {
        "[::]:0".parse()?
    };
    let mut links = Links {
        udp: UdpSocket::bind(bind).context("cannot open the sending UDP socket")?,
        data_to: SocketAddr::new(target, v.data_port),
        position_to: (v.position_port != 0).then(|| SocketAddr::new(target, v.position_port)),
        cmd: ipc::cmd_vel_subscriber(&node)?,
        odom: ipc::odom_publisher(&node)?,
        truth: ipc::truth_publisher(&node, config.map.grid().len())?,
        faults: Faults::new(Duration::from_secs(5)),
        odom_seq: 0,
        truth_buf: Vec::new(),
    };
    let lockstep = config.sim.lockstep;
    // the sensor's clock is the host's, as with a GPS-synchronised sensor, so the driver resolves
    // the hour of its timestamps the same way
    let epoch_ns = ipc::realtime_ns() / 1000 * 1000;
    let mut sim = Sim::new(
        world.compile(),
        SimSettings::from_config(config),
        config.sim.seed,
        epoch_ns,
    );
    tracing::info!(
        world = %world.name,
        to = %links.data_to,
        lockstep,
        seed = config.sim.seed,
        "simulating: topics open: {}, {}, {}",
        mimnav_shared::topics::CMD_VEL,
        mimnav_shared::topics::ODOM,
        mimnav_shared::topics::SIM_TRUTH
    );
    let anchor = Instant::now();
    let limit_s = seconds.unwrap_or(f64::INFINITY);
    let mut next_odom_ns = epoch_ns;
    let mut rev_stamp = sim.now_ns();
    let mut stopped = false;
    let mut waits_timed_out = 0u64;
    let mut valid_until = 0u64;
    while sim.elapsed_s() < limit_s {
        let step = sim.step();
        if !lockstep {
            let due = anchor + Duration::from_nanos(step.send_ns - epoch_ns);
            let now = Instant::now();
            if due > now && !ipc::sleep(&node, due - now) {
                stopped = true;
                break;
            }
        }
        if let Some((pos, _)) = step.position
            && let Some(to) = links.position_to
        {
            links.send(&pos, to);
        }
        links.send(&step.data, links.data_to);
        if !lockstep {
            match links.cmd.latest() {
                Ok(Some(cmd)) => {
                    sim.set_command(f64::from(cmd.v), f64::from(cmd.omega));
                    valid_until = cmd.valid_until_mono_ns;
                }
                Ok(None) => {}
                Err(e) => {
                    links.faults.record("receive_failed", Instant::now(), e);
                }
            }
            // a real base stops when its command expires
            if valid_until != 0 && ipc::monotonic_ns() > valid_until {
                sim.set_command(0.0, 0.0);
                valid_until = 0;
            }
            if step.send_ns >= next_odom_ns {
                links.publish_odom(&sim);
                next_odom_ns = step.send_ns + 20_000_000;
            }
        }
        if step.completes_revolution {
            let completed = rev_stamp;
            rev_stamp = sim.revolution_start().0;
            links.publish_truth(&sim, config, completed);
            links.publish_odom(&sim);
            if lockstep {
                match wait_for_answer(&node, &links.cmd, completed, config.sim.lockstep_timeout_s) {
                    Answer::Command(cmd) => sim.set_command(f64::from(cmd.v), f64::from(cmd.omega)),
                    Answer::TimedOut => {
                        waits_timed_out += 1;
                        links.faults.record(
                            "lockstep_timeout",
                            Instant::now(),
                            format_args!(
                                "no command for revolution {} within {} s",
                                sim.revolutions(),
                                config.sim.lockstep_timeout_s
                            ),
                        );
                    }
                    Answer::Stop => {
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
    let summary = summary(&sim, world, stopped, waits_timed_out);
    if json {
        println!("{}", summary.1);
    } else {
        println!("{}", summary.0);
    }
    tracing::info!(faults = %links.faults.summary(), "simulation ended");
    Ok(match sim.outcome() {
        Outcome::GoalReached | Outcome::Running => ExitCode::SUCCESS,
        _ => ExitCode::from(3),
    })
}

enum Answer {
    Command(VelocityCommand),
    TimedOut,
    Stop,
}

/// Waits for a command computed from the revolution stamped `stamp_ns` or later.
fn wait_for_answer(
    node: &iceoryx2::prelude::Node<ipc::Svc>,
    cmd: &ValueSubscriber<VelocityCommand>,
    stamp_ns: u64,
    timeout_s: f64,
) -> Answer {
    let until = Instant::now() + Duration::from_secs_f64(timeout_s);
    loop {
        while let Ok(Some(c)) = cmd.receive() {
            // the driver's stamp is the revolution's first firing, truncated to the µs
            if c.source_stamp_ns + 1000 >= stamp_ns {
                return Answer::Command(c);
            }
        }
        let now = Instant::now();
        if now >= until {
            return Answer::TimedOut;
        }
        if !ipc::sleep(node, Duration::ZERO) {
            return Answer::Stop;
        }
        cmd.heard_within((until - now).min(Duration::from_millis(50)));
    }
}

/// (human line, JSON line).
fn summary(sim: &Sim, world: &WorldFile, stopped: bool, waits_timed_out: u64) -> (String, String) {
    let straight = (world.goal[0] - world.start[0]).hypot(world.goal[1] - world.start[1]);
    let outcome = match sim.outcome() {
        Outcome::Running if stopped => "stopped".to_string(),
        Outcome::Running => "running".to_string(),
        Outcome::GoalReached => "goal_reached".to_string(),
        Outcome::Contact(i) => format!("contact:{i}"),
        Outcome::Timeout => "timeout".to_string(),
    };
    let p = sim.base().pose;
    let human = format!(
        "{}: {outcome} after {:.1} s; driven {:.2} m (straight line {:.2} m, ratio {:.2}); at ({:.2}, {:.2}), {:.2} m from the goal; {} revolutions",
        world.name,
        sim.elapsed_s(),
        sim.path_length_m(),
        straight,
        sim.path_length_m() / straight.max(1e-9),
        p.x,
        p.y,
        sim.distance_to_goal(),
        sim.revolutions()
    );
    let json = format!(
        "{{\"world\":{:?},\"outcome\":{:?},\"time_s\":{:.3},\"path_length_m\":{:.3},\"straight_m\":{:.3},\"distance_to_goal_m\":{:.3},\"x\":{:.3},\"y\":{:.3},\"revolutions\":{},\"lockstep_timeouts\":{}}}",
        world.name,
        outcome,
        sim.elapsed_s(),
        sim.path_length_m(),
        straight,
        sim.distance_to_goal(),
        p.x,
        p.y,
        sim.revolutions(),
        waits_timed_out
    );
    (human, json)
}
