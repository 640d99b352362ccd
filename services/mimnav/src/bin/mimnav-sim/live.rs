//! The simulator streaming to the stack (part of the `mimnav-sim` binary, not of the library):
//! packets over UDP as a VLP-16 sends them, `odom` and `sim/truth` published, `cmd_vel`
//! followed; in real time, or lock-stepped with the stack one revolution at a time; with
//! `sim.sick`, a simulated SICK served over TCP beside it ([`crate::sick`]).

use std::net::{SocketAddr, UdpSocket};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use mimnav_config::Config;
use mimnav_shared::cli::stdout_line;
use mimnav_shared::ipc::{self, Listening, ValueSubscriber};
use mimnav_shared::pose::Pose2Ext;
use mimnav_shared::service::{Health, Service};
use mimnav_shared::topics::{TruthHeader, VelocityCommand};
use mimnav_sim::config::SimBase;
use mimnav_sim::{Outcome, Sim};

use crate::kobuki::PtyBase;
use crate::sick::SickServer;

/// Runs the episode (or `seconds` of it) against the stack; prints the summary (as JSON with
/// `json`).
pub fn run(
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
    // sim.base = "kobuki": a simulated Kobuki on a pty moves the robot; mimnav-kobuki publishes
    // odom and follows cmd_vel
    let mut kobuki = match config.sim.base {
        SimBase::Kobuki => Some(PtyBase::open(&config.sim.kobuki_link, &config.robot)?),
        SimBase::Ideal => None,
    };
    // the sensor's clock is the host's, as with a GPS-synchronised sensor, so the driver resolves
    // the hour of its timestamps the same way
    let epoch_ns = ipc::realtime_ns() / 1000 * 1000;
    let mut sim = sim(epoch_ns);
    // sim.sick: the simulated SICK on TCP, polled after every packet
    let mut sick = match config.sim.sick {
        true => Some(SickServer::open(config)?),
        false => None,
    };
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
        let due = Duration::from_nanos(step.send_ns - epoch_ns).div_f64(config.sim.time_scale);
        if !lockstep && !svc.sleep_until(&mut h, anchor + due) {
            stopped = true;
            break;
        }
        if let (Some((pos, _)), Some(to)) = (step.position, position_to) {
            send(&mut h, &pos, to);
        }
        // the pose that goes with a revolution is published before its last packet, so that the
        // mapper and the planner planning on it see it (lock-step runs are then reproducible)
        if let Some(k) = kobuki.as_mut() {
            let (v, omega) = k.step(step.send_ns, &mut h);
            sim.set_command(v, omega);
        } else if step.completes_revolution || !lockstep && step.send_ns >= next_odom_ns {
            if let Err(e) = odom.publish(sim.odometry(odom_seq, ipc::monotonic_ns())) {
                h.faults.record("publish_failed", Instant::now(), e);
            }
            (odom_seq, next_odom_ns) = (odom_seq + 1, step.send_ns + 20_000_000);
        }
        send(&mut h, &step.data, data_to);
        if let Some(s) = sick.as_mut() {
            s.poll(&sim, &mut h);
        }
        if !lockstep && kobuki.is_none() {
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
                x: p.x(),
                y: p.y(),
                yaw: p.yaw(),
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
    // a closed stdout does not change how the run ended (issue 23 item 4)
    match json {
        true => stdout_line(format_args!("{}", serde_json::to_string(&summary)?)),
        false => stdout_line(format_args!("{summary}")),
    }
    if let Some(s) = &sick {
        let (clients, dropped, scans) = s.stats;
        tracing::info!(clients, dropped, scans, "simulated SICK");
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
