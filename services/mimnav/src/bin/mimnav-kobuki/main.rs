//! `mimnav-kobuki`: the Turtlebot 2's base (Kobuki) on its USB serial port.
//!
//! Wiring only: the port's bytes go into the library's [`Driver`], whose odometry and state go
//! out on `odom` and `base/state`; `cmd_vel` goes in, and the driver's Base Control goes to the
//! port with every feedback frame (50 Hz), at once on a new command, and at least every 20 ms.
//! Every rule (expiry, bumpers, cliffs, wheel drops, stale feedback) is the driver's. A device
//! that is missing, fails or falls silent for `kobuki.silence_s` is closed, named in the log
//! and in `STATUS=`, and opened again every `kobuki.reconnect_s`; nothing moves meanwhile.

use std::io::{ErrorKind, Write};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use mimnav_config::Config;
use mimnav_kobuki::driver::{Driver, Update};
use mimnav_shared::faults::Faults;
use mimnav_shared::ipc::{self, Listening, ValuePublisher};
use mimnav_shared::service::{self, Service, ServiceCli};
use mimnav_shared::topics::{self, BaseState, Odometry, base_halt};
use serialport::SerialPort;

/// The Kobuki base: cmd_vel → the base; the base → odom and base/state.
#[derive(Debug, clap::Parser)]
#[command(name = "mimnav-kobuki", version)]
struct Args {
    #[command(flatten)]
    service: mimnav_shared::cli::ServiceArgs,
}

impl ServiceCli for Args {
    fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs {
        &self.service
    }
}

/// The Kobuki's serial speed (its protocol specification: 115200 8N1).
const BAUD: u32 = 115_200;
/// Base Control is written at least this often (the base's feedback period).
const COMMAND_PERIOD: Duration = Duration::from_millis(20);
/// The loop's tick: the latency from a feedback frame to the command that answers it.
const TICK: Duration = Duration::from_millis(2);
/// How often the counters are logged.
const STATS_INTERVAL: Duration = Duration::from_secs(10);

fn main() -> ExitCode {
    service::main("mimnav-kobuki", |_args: Args, config: Config| {
        run(&config).map(|()| ExitCode::SUCCESS)
    })
}

/// The port and when it last said anything.
struct Link {
    port: Box<dyn SerialPort>,
    heard: Instant,
    written: Instant,
}

/// The topics the service writes.
struct Out {
    odom: ValuePublisher<Odometry>,
    state: ValuePublisher<BaseState>,
}

impl Out {
    fn state(&self, s: BaseState, faults: &mut Faults, now: Instant) {
        if let Err(e) = self.state.publish(s) {
            faults.record("publish_failed", now, e);
        }
    }
}

fn run(config: &Config) -> Result<()> {
    let svc = Service::open(config, "kobuki")?;
    let k = &config.kobuki;
    let node = svc.node();
    let cmd_sub = ipc::cmd_vel_subscriber(node)?;
    let out = Out {
        odom: ipc::odom_publisher(node)?,
        state: ipc::base_state_publisher(node)?,
    };
    let _cmd = svc.on_data(&cmd_sub)?;
    let _tick = svc.every(TICK)?;
    let device = k.device.display().to_string();
    let (silence, reconnect) = (
        Duration::from_secs_f64(k.silence_s),
        Duration::from_secs_f64(k.reconnect_s),
    );
    let mut driver = Driver::new(k.driver());
    let mut link: Option<Link> = None;
    let (mut next_try, mut last_report) = (Instant::now(), Instant::now());
    let mut buf = vec![0u8; k.read_bytes];
    let mut status = String::new();
    let mut status_key = (u16::MAX, false, i32::MIN);
    let (mut commands_in, mut feedback_in) = (0u64, 0u64);
    let mut health = svc.health();
    tracing::info!(%device, "topics open: {}, {}, {}", topics::CMD_VEL, topics::ODOM, topics::BASE_STATE);
    out.state(*driver.state(), &mut health.faults, Instant::now());
    svc.run(
        &mut health,
        &format!("waiting for the base on {device}"),
        |turn, h| {
            let _ = cmd_sub.heard();
            let mut new_command = false;
            h.take_latest(&cmd_sub, turn.now, "bad_cmd_vel", |c| {
                driver.set_command(c);
                new_command = true;
                commands_in += 1;
                Ok::<_, std::convert::Infallible>(())
            });
            if link.is_none() && turn.now >= next_try {
                next_try = turn.now + reconnect;
                match open(&device) {
                    Ok(mut port) => {
                        let hello = driver.connected();
                        match port.write_all(hello) {
                            Ok(()) => {
                                tracing::info!(%device, "base connected");
                                link = Some(Link {
                                    port,
                                    heard: turn.now,
                                    written: turn.now,
                                });
                            }
                            Err(e) => {
                                let what = format_args!("{device}: writing the first command: {e}");
                                h.faults.record("device_failed", turn.now, what);
                            }
                        }
                    }
                    Err(e) => {
                        let what =
                            format_args!("{device}: {e}; trying again every {:?}", reconnect);
                        h.faults.record("device_unavailable", turn.now, what);
                        // said again with every try, so a late subscriber hears it
                        out.state(
                            driver.link_down(ipc::monotonic_ns()),
                            &mut h.faults,
                            turn.now,
                        );
                    }
                }
            }
            let mut lost: Option<String> = None;
            if let Some(l) = link.as_mut() {
                let (mono, real) = (ipc::monotonic_ns(), ipc::realtime_ns());
                let mut feedback = 0;
                match read_available(l.port.as_mut(), &mut buf) {
                    Ok(0) => {}
                    Ok(n) => {
                        l.heard = turn.now;
                        feedback = driver.receive(&buf[..n], mono, real, |u| match u {
                            Update::Odom(o) => {
                                if let Err(e) = out.odom.publish(o) {
                                    h.faults.record("publish_failed", turn.now, e);
                                }
                            }
                            Update::State(s) => out.state(s, &mut h.faults, turn.now),
                            Update::Rejected(e) => {
                                h.faults.record(
                                    "bad_frame",
                                    turn.now,
                                    format_args!("{device}: {e}"),
                                );
                            }
                            Update::Malformed(e) => {
                                let what = format_args!("{device}: {e}");
                                h.faults.record("bad_subpayload", turn.now, what);
                            }
                            Update::Identified {
                                hardware,
                                firmware,
                                id,
                            } => tracing::info!(
                                %device,
                                hardware = ?hardware,
                                firmware = ?firmware,
                                id = format_args!("{:08x}-{:08x}-{:08x}", id[0], id[1], id[2]),
                                "base identified"
                            ),
                        });
                        feedback_in += feedback as u64;
                    }
                    Err(e) => lost = Some(format!("{device}: reading: {e}")),
                }
                if lost.is_none() && turn.now.duration_since(l.heard) >= silence {
                    lost = Some(format!("{device}: silent for {silence:?}"));
                }
                let due = turn.now.duration_since(l.written) >= COMMAND_PERIOD;
                if lost.is_none() && (feedback > 0 || new_command || due) {
                    let (_, bytes) = driver.command(ipc::monotonic_ns());
                    match l.port.write_all(bytes) {
                        Ok(()) => l.written = turn.now,
                        Err(e) => lost = Some(format!("{device}: writing: {e}")),
                    }
                }
            }
            if let Some(why) = lost {
                link = None;
                next_try = turn.now + reconnect;
                h.faults.record("link_lost", turn.now, &why);
                tracing::warn!("base link lost ({why}); nothing moves until it is back");
                out.state(
                    driver.link_down(ipc::monotonic_ns()),
                    &mut h.faults,
                    turn.now,
                );
            }
            // the STATUS= line is rebuilt only when what it says changes, not every 2 ms turn
            let s = driver.state();
            let key = (
                s.halted,
                link.is_some(),
                (s.battery_v * 10.0).round() as i32,
            );
            if key != status_key {
                status_key = key;
                status = describe(s, link.is_some(), &device);
                tracing::info!(status = %status, "base");
                h.sd.status(&status);
            }
            if last_report.elapsed() >= STATS_INTERVAL {
                let s = driver.frame_stats();
                tracing::info!(
                    commands = commands_in,
                    feedback = feedback_in,
                    garbage_bytes = s.garbage_bytes,
                    bad_checksum = s.bad_checksum,
                    link_losses = driver.state().link_losses,
                    "base: {status}; faults: {}",
                    h.faults.summary()
                );
                last_report = Instant::now();
            }
        },
    )?;
    // leave the base stopped
    if let Some(mut l) = link {
        let (_, bytes) = driver.command(u64::MAX);
        let _ = l.port.write_all(bytes);
    }
    let s = driver.frame_stats();
    tracing::info!(
        commands = commands_in,
        feedback = feedback_in,
        frames = s.frames,
        garbage_bytes = s.garbage_bytes,
        bad_checksum = s.bad_checksum,
        link_losses = driver.state().link_losses,
        "kobuki stopped"
    );
    Ok(())
}

/// Opens the base's port without blocking reads.
fn open(device: &str) -> serialport::Result<Box<dyn SerialPort>> {
    serialport::new(device, BAUD).timeout(Duration::ZERO).open()
}

/// Reads what the port holds now (up to `buf`'s size): 0 when nothing; an error when the
/// device is gone (a hang-up, end of file, an I/O error).
fn read_available(port: &mut dyn SerialPort, buf: &mut [u8]) -> std::io::Result<usize> {
    match port.read(buf) {
        Ok(0) => Err(std::io::Error::new(
            ErrorKind::UnexpectedEof,
            "end of file (the device hung up)",
        )),
        Ok(n) => Ok(n),
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
            ) =>
        {
            Ok(0)
        }
        Err(e) => Err(e),
    }
}

/// The `STATUS=` line.
fn describe(s: &BaseState, open: bool, device: &str) -> String {
    if !open {
        return format!("waiting for the base on {device}");
    }
    let names = [
        (base_halt::WHEEL_DROP, "wheel dropped"),
        (base_halt::BUMPER, "bumper pressed"),
        (base_halt::CLIFF, "cliff"),
        (base_halt::OVER_CURRENT, "over current"),
        (base_halt::LINK_DOWN, "no feedback"),
        (base_halt::COMMAND_EXPIRED, "no valid cmd_vel"),
    ];
    let halts: Vec<&str> = names
        .iter()
        .filter(|(bit, _)| s.halted & bit != 0)
        .map(|(_, n)| *n)
        .collect();
    match halts.is_empty() {
        true => format!("following cmd_vel; battery {:.1} V", s.battery_v),
        false => format!(
            "stopped: {}; battery {:.1} V",
            halts.join(", "),
            s.battery_v
        ),
    }
}
