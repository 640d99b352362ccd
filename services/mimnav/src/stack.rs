//! The stack as processes on this machine, for `mimnav demo` and `mimnav soak`: the driver,
//! mapper, foliage classifier and planner in a private iceoryx2 domain (they never meet a stack
//! already running on the machine), then the simulator streaming the VLP-16's UDP packets to the
//! driver over loopback, as a real sensor would.
//!
//! Stopping (issue 23, item 9). The children never outlive the front end: each is started with a
//! parent-death signal (SIGTERM, see [`crate::procs`]), so even a SIGKILL of it ends them and
//! the simulated robot with them. They run in process groups of their own, so a Ctrl-C on the
//! terminal reaches the front end alone, which stops them in an order that halts the robot
//! first ([`Children::halt_robot`]): it stops the planner, commands zero velocity on `cmd_vel`
//! itself and waits (up to [`HALT_WITHIN`]) until the odometry shows the robot at rest, then
//! stops the simulator, then the driver, mapper and classifier, and waits for each.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use mimnav_config::Config;
use mimnav_shared::config::toml_quote;
use mimnav_shared::ipc::{self, PrivateDomain};
use mimnav_shared::topics::{Odometry, VelocityCommand, command_status};
use mimnav_sim::config::SimBase;
use mimnav_sim::world::WorldFile;

use crate::procs::{Options, Service, service_binary};

/// How long the front end waits, once interrupted, for the odometry to show the robot at rest before
/// it stops the simulator anyway.
pub const HALT_WITHIN: Duration = Duration::from_secs(3);
/// How long a child has to end after SIGTERM before it is killed.
pub const STOP_GRACE: Duration = Duration::from_secs(2);
/// Below these speeds (m/s, rad/s) the robot is at rest.
pub const AT_REST: (f32, f32) = (1e-3, 1e-3);

/// A loopback UDP port nobody uses right now.
fn free_port() -> Result<u16> {
    let s = std::net::UdpSocket::bind("127.0.0.1:0").context("cannot find a free UDP port")?;
    Ok(s.local_addr()
        .context("cannot find a free UDP port")?
        .port())
}

/// What the front end's own settings resolve to: the config of `config_path` with `sets`, the
/// robot profile `robot` and the `extra` sets (the settings the services get too), and the world
/// (`world`, else `sim.world`) with its path.
pub struct Resolved {
    /// The config.
    pub config: Config,
    /// Every `--set` the services get.
    pub sets: Vec<String>,
    /// The world file's path.
    pub world_path: PathBuf,
    /// The world.
    pub world: WorldFile,
}

/// Resolves the settings of `mimnav demo` or `mimnav soak` ([`Resolved`]).
pub fn resolve(
    config_path: Option<&Path>,
    sets: &[String],
    robot: Option<&str>,
    extra: &[String],
    world: Option<&Path>,
) -> Result<Resolved> {
    let mut sets = sets.to_vec();
    if let Some(r) = robot {
        sets.push(format!("robot.profile={}", toml_quote(r)));
    }
    sets.extend_from_slice(extra);
    let config = Config::resolve(config_path, &sets).map_err(|e| anyhow::anyhow!("{e}"))?;
    let world_path = world.map_or_else(|| config.sim.world_path(&config.dir()), Path::to_path_buf);
    let world = WorldFile::load(&world_path)?;
    Ok(Resolved {
        config,
        sets,
        world_path,
        world,
    })
}

/// The stack's settings, before anything is started.
pub struct Stack {
    /// The config as the front end's own node uses it: in the private domain.
    pub local: Config,
    /// The loopback port the driver listens on for data packets.
    pub data_port: u16,
    // keeps the domain's folder for as long as the stack runs
    _domain: PrivateDomain,
    child_args: Vec<String>,
}

/// Started from the main thread (their parent-death signal is tied to it), in process groups of
/// their own.
const OWN_GROUP: Options = Options {
    own_process_group: true,
    piped_stdout: false,
};

impl Stack {
    /// The stack of `config` (read from `config_path` with `sets`) in a private domain tagged
    /// `tag`, on free loopback ports, its services logging at `log` with SCHED_FIFO priority
    /// `realtime_priority` (0: the normal scheduler).
    pub fn new(
        tag: &str,
        config: &Config,
        config_path: Option<&Path>,
        sets: &[String],
        log: &str,
        realtime_priority: i32,
    ) -> Result<Stack> {
        let domain = PrivateDomain::new(tag);
        let local = domain.apply(config.clone());
        let (data_port, position_port) = (free_port()?, free_port()?);
        let mut child_args: Vec<String> = Vec::new();
        if let Some(p) = config_path {
            child_args.extend(["--config".into(), p.display().to_string()]);
        }
        for s in sets {
            child_args.extend(["--set".into(), s.clone()]);
        }
        child_args.extend(domain.set_args());
        for s in [
            format!("velodyne.input={}", toml_quote("udp")),
            format!("velodyne.bind_address={}", toml_quote("127.0.0.1")),
            format!("velodyne.data_port={data_port}"),
            format!("velodyne.position_port={position_port}"),
            format!("sim.udp_target={}", toml_quote("127.0.0.1")),
            format!("log.level={}", toml_quote(log)),
            format!("latency.realtime_priority={realtime_priority}"),
        ] {
            child_args.extend(["--set".into(), s]);
        }
        Ok(Stack {
            local,
            data_port,
            _domain: domain,
            child_args,
        })
    }

    /// Starts the driver, mapper, foliage classifier and planner, and with `sim.base = "kobuki"`
    /// the Kobuki's service. Call from the main thread.
    pub fn start_services(&self) -> Result<Children> {
        let mut children = Children::default();
        let kobuki = (self.local.sim.base == SimBase::Kobuki).then_some("mimnav-kobuki");
        let names = [
            "mimnav-velodyne",
            "mimnav-mapper",
            "mimnav-foliage",
            "mimnav-planner",
        ];
        for name in names.into_iter().chain(kobuki) {
            let s = Service::start_with(&service_binary(name)?, &self.child_args, OWN_GROUP)?;
            if name == "mimnav-planner" {
                children.planner = Some(s);
            } else {
                children.others.push(s);
            }
        }
        Ok(children)
    }

    /// Starts the Foxglove live view on 127.0.0.1:`port` (it takes no real-time priority,
    /// whatever the stack's). Call from the main thread.
    pub fn start_view(&self, children: &mut Children, port: u16) -> Result<()> {
        let mut all = self.child_args.clone();
        all.extend([
            "--set".into(),
            format!("view.bind={}", toml_quote("127.0.0.1")),
            "--set".into(),
            format!("view.port={port}"),
        ]);
        let s = Service::start_with(&service_binary("mimnav-view")?, &all, OWN_GROUP)?;
        children.others.push(s);
        Ok(())
    }

    /// Starts the simulator with `args` after the stack's own (its stdout piped: read it with
    /// [`Children::stop_sim`]). Call from the main thread.
    pub fn start_sim(&self, children: &mut Children, args: &[String]) -> Result<()> {
        let mut all = self.child_args.clone();
        all.extend_from_slice(args);
        let options = Options {
            piped_stdout: true,
            ..OWN_GROUP
        };
        children.sim = Some(Service::start_with(
            &service_binary("mimnav-sim")?,
            &all,
            options,
        )?);
        Ok(())
    }
}

/// The stack's processes. They stop in the order that halts the robot first — the planner, the
/// simulator, then the rest — also when this value is dropped on an error.
#[derive(Default)]
pub struct Children {
    // dropped in declaration order
    planner: Option<Service>,
    sim: Option<Service>,
    others: Vec<Service>,
}

/// How the robot came to rest after an interruption.
pub struct Halted {
    /// The last odometry received after the stop command went out.
    last: Option<Odometry>,
    /// It showed the robot at rest.
    at_rest: bool,
    /// From the start of the halt (the signal) to the odometry at rest, or to giving up.
    after: Duration,
}

impl Halted {
    /// Where and how the robot stopped, in a sentence.
    pub fn describe(&self) -> String {
        let secs = self.after.as_secs_f64();
        match (self.at_rest, &self.last) {
            (true, Some(o)) => format!(
                "interrupted: the robot stopped at ({:.2}, {:.2}) {secs:.2} s after the signal \
                 (planner stopped, zero velocity commanded); services stopped",
                o.x, o.y
            ),
            (false, Some(o)) => format!(
                "interrupted: the robot was not at rest {secs:.2} s after the signal \
                 (v {:.2} m/s, ω {:.2} rad/s at ({:.2}, {:.2})); the simulator was stopped anyway",
                o.v, o.omega, o.x, o.y
            ),
            (_, None) => format!(
                "interrupted: no odometry within {secs:.2} s of the signal; the simulator was \
                 stopped anyway"
            ),
        }
    }
}

impl Children {
    /// Waits (up to 10 s) until the planner speaks — a stale-input stop every 100 ms while no
    /// map comes — watching `commands`. `Ok(false)`: a signal came first.
    pub fn wait_for_planner(
        &mut self,
        node: &iceoryx2::prelude::Node<ipc::Svc>,
        commands: &ipc::ValueSubscriber<VelocityCommand>,
    ) -> Result<bool> {
        let until = Instant::now() + Duration::from_secs(10);
        loop {
            if commands.receive()?.is_some() {
                return Ok(true);
            }
            if let Some((name, status)) = self.exited_early() {
                bail!("{name} exited at start ({status}); see its messages above");
            }
            if Instant::now() > until {
                bail!("the planner did not publish on cmd_vel within 10 s");
            }
            if !ipc::sleep(node, Duration::from_millis(20)) {
                return Ok(false);
            }
        }
    }

    /// The process ids and names of the running services, the simulator last.
    pub fn pids(&mut self) -> Vec<(String, u32)> {
        (self
            .planner
            .iter_mut()
            .chain(self.others.iter_mut())
            .chain(self.sim.iter_mut()))
        .filter_map(|s| s.exited().is_none().then_some(s))
        .map(|s| (s.name().to_string(), s.id()))
        .collect()
    }

    /// A service that has exited, with its status (while starting, none should have).
    pub fn exited_early(&mut self) -> Option<(String, std::process::ExitStatus)> {
        self.planner
            .iter_mut()
            .chain(self.others.iter_mut())
            .find_map(|s| s.exited().map(|e| (s.name().to_string(), e)))
    }

    /// The simulator has exited (or was never started).
    pub fn sim_exited(&mut self) -> bool {
        self.sim.as_mut().is_none_or(|s| s.exited().is_some())
    }

    /// Stops the planner (no more driving commands), then commands zero velocity on `cmd_vel`
    /// every 100 ms until the odometry, published after the first of them, shows the robot at
    /// rest, or [`HALT_WITHIN`] passes, or a second signal comes.
    pub fn halt_robot(
        &mut self,
        node: &iceoryx2::prelude::Node<ipc::Svc>,
        stop: &ipc::ValuePublisher<VelocityCommand>,
        odom: &ipc::ValueSubscriber<Odometry>,
    ) -> Halted {
        let began = Instant::now();
        // the request that began the halt does not end it; the next one does
        let asked = mimnav_shared::signals::count();
        if let Some(mut planner) = self.planner.take() {
            planner.stop(STOP_GRACE);
        }
        let first_stop_ns = ipc::monotonic_ns();
        let (mut seq, mut next_stop, mut last) = (0u64, began, None);
        loop {
            let now = Instant::now();
            if now >= next_stop {
                let cmd = VelocityCommand {
                    seq,
                    stamp_mono_ns: ipc::monotonic_ns(),
                    status: command_status::NO_GOAL,
                    ..VelocityCommand::default()
                };
                if let Err(e) = stop.publish(cmd) {
                    tracing::warn!("cannot command the robot to stop: {e}");
                }
                (seq, next_stop) = (seq + 1, now + Duration::from_millis(100));
            }
            while let Ok(Some(o)) = odom.receive() {
                if o.rx_mono_ns < first_stop_ns {
                    continue;
                }
                last = Some(o);
                if o.v.abs() < AT_REST.0 && o.omega.abs() < AT_REST.1 {
                    return Halted {
                        last,
                        at_rest: true,
                        after: began.elapsed(),
                    };
                }
            }
            if self.sim_exited()
                || began.elapsed() > HALT_WITHIN
                || !ipc::sleep_unless_asked(node, Duration::from_millis(5), asked)
            {
                return Halted {
                    last,
                    at_rest: false,
                    after: began.elapsed(),
                };
            }
        }
    }

    /// Stops the simulator (if it still runs) and returns its exit status and its stdout.
    pub fn stop_sim(&mut self) -> (Option<std::process::ExitStatus>, String) {
        match self.sim.as_mut() {
            Some(sim) => (sim.stop(STOP_GRACE), sim.read_stdout()),
            None => (None, String::new()),
        }
    }

    /// Stops the planner, then the driver, mapper and classifier together, and waits for each.
    pub fn stop_rest(&mut self) {
        if let Some(planner) = self.planner.as_mut() {
            planner.stop(STOP_GRACE);
        }
        for s in &mut self.others {
            s.terminate();
        }
        for s in &mut self.others {
            s.stop(STOP_GRACE);
        }
    }
}

impl Drop for Children {
    fn drop(&mut self) {
        // an early return or an error: the same order, without the stop command
        if let Some(mut sim) = self.sim.take() {
            if let Some(planner) = self.planner.as_mut() {
                planner.stop(STOP_GRACE);
            }
            sim.stop(STOP_GRACE);
        }
        self.stop_rest();
    }
}
