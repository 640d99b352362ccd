//! The skeleton every mimnav service runs on, so that a service's `main.rs` is only its wiring.
//!
//! [`main`] does what every service does before and after its work: parse the command line, load
//! the config (a bad one is exit status 2 with the file, key and range named), set up logging and
//! the latency settings, run, and turn an error into a logged, printed exit status 1 that systemd's
//! `Restart=on-failure` acts on.
//!
//! [`Service`] is the event loop: the process's iceoryx2 node and one `WaitSet` that the service
//! attaches its subscribers' listeners to (with or without a deadline) plus an interval. Its
//! [`Service::run`] pings the systemd watchdog on every turn, sends `READY=1` before the first
//! wait and `STOPPING=1` after the last, and ends cleanly on SIGTERM or SIGINT. The state a
//! turn may change — the sd_notify [`Notifier`] and the rate-limited [`Faults`] — is kept apart
//! in [`Health`], so the loop's attachments (which borrow the `Service`) and the turn's mutable
//! state never borrow the same value.
//!
//! ```no_run
//! use std::process::ExitCode;
//! use mimnav_shared::service::{self, Service, ServiceCli};
//!
//! #[derive(clap::Parser)]
//! struct Args {
//!     #[command(flatten)]
//!     service: mimnav_shared::cli::ServiceArgs,
//! }
//! impl ServiceCli for Args {
//!     fn service_args(&self) -> &mimnav_shared::cli::ServiceArgs { &self.service }
//! }
//!
//! fn main() -> ExitCode {
//!     service::main("mimnav-example", |_args: Args, config: mimnav_config::Config| {
//!         let svc = Service::open(&config, "example")?;
//!         let odom = mimnav_shared::ipc::odom_subscriber(svc.node())?;
//!         let _odom_guard = svc.on_data(&odom)?;
//!         let _tick = svc.every(std::time::Duration::from_secs(1))?;
//!         let mut health = svc.health();
//!         svc.run(&mut health, "waiting for odom", |_turn, _health| {
//!             while let Ok(Some(_o)) = odom.receive() {}
//!         })?;
//!         Ok::<_, service::ServiceError>(ExitCode::SUCCESS)
//!     })
//! }
//! ```

use std::fmt::Display;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use iceoryx2::prelude::*;
use iceoryx2::waitset::{WaitSetAttachmentId, WaitSetGuard};

use crate::cli::ServiceArgs;
use crate::config::{Common, Load};
use crate::faults::Faults;
use crate::ipc::{self, IpcError, Listening, Svc};
use crate::systemd::Notifier;

/// How often a fault kind may be logged again (each one is counted every time).
pub const FAULT_LOG_INTERVAL: Duration = Duration::from_secs(5);

/// A service's command line: the shared `--config` / `--set` options and any overrides its own
/// flags imply.
pub trait ServiceCli: clap::Parser {
    /// The shared options (`#[command(flatten)]`).
    fn service_args(&self) -> &ServiceArgs;

    /// `KEY=VALUE` overrides the service's own flags stand for (applied after `--set`).
    fn overrides(&self) -> Vec<String> {
        Vec::new()
    }
}

/// A service's `main`: parses `A`, loads the config (exit 2 on a bad one, naming the file, the
/// key and its range), sets up logging and the latency settings, then calls `run`. An error from
/// `run` is logged and printed as `name: error: cause: …` with exit status 1.
pub fn main<A, C, E>(name: &'static str, run: impl FnOnce(A, C) -> Result<ExitCode, E>) -> ExitCode
where
    A: ServiceCli,
    C: Load,
    E: Display,
{
    let args = A::parse();
    let config: C = match args.service_args().load_or_exit(name, &args.overrides()) {
        Ok(c) => c,
        Err(code) => return code,
    };
    crate::logging::init(&config.log.level);
    if !config.from_file() {
        tracing::info!("no config file: running on the built-in defaults");
    }
    // held until the service ends
    let _cpu_latency = crate::realtime::apply(name, &config);
    crate::cli::finish(name, run(args, config))
}

/// Why the event loop could not be set up or ended with an error.
#[derive(Debug, thiserror::Error)]
pub enum ServiceError {
    /// The node or a topic could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// The WaitSet could not be created, or an attachment could not be made.
    #[error("event loop: {0}")]
    WaitSet(String),
}

/// The state a turn of the loop may change: systemd's notifier and the fault counters.
#[derive(Debug)]
pub struct Health {
    /// READY, WATCHDOG and STATUS for systemd (a no-op outside it).
    pub sd: Notifier,
    /// Runtime faults, counted and logged at a limited rate.
    pub faults: Faults,
}

impl Health {
    /// Hands the newest value waiting on `sub` (if any) to `take`: a failed receive is counted
    /// as `receive_failed`, a value `take` refuses as `refused`, each logged at a limited rate.
    pub fn take_latest<T, E>(
        &mut self,
        sub: &ipc::ValueSubscriber<T>,
        now: Instant,
        refused: &'static str,
        take: impl FnOnce(&T) -> Result<(), E>,
    ) where
        T: std::fmt::Debug + ZeroCopySend + Copy + 'static,
        E: Display,
    {
        match sub.latest() {
            Ok(Some(v)) => {
                if let Err(e) = take(&v) {
                    self.faults.record(refused, now, e);
                }
            }
            Ok(None) => {}
            Err(e) => _ = self.faults.record("receive_failed", now, e),
        }
    }
}

/// One wake-up of the loop: what woke it and when.
#[derive(Debug)]
pub struct Turn {
    /// The attachment that woke the loop (compare with a guard: [`Turn::from`],
    /// [`Turn::missed`]).
    pub id: WaitSetAttachmentId<Svc>,
    /// When the turn started.
    pub now: Instant,
}

impl Turn {
    /// Whether this turn was woken by `guard`'s attachment.
    pub fn from(&self, guard: &WaitSetGuard<'_, '_, Svc>) -> bool {
        self.id.has_event_from(guard)
    }

    /// Whether `guard`'s deadline passed without an event.
    pub fn missed(&self, guard: &WaitSetGuard<'_, '_, Svc>) -> bool {
        self.id.has_missed_deadline(guard)
    }
}

/// A socket's descriptor, so the WaitSet can wait on it beside iceoryx2's own events.
#[derive(Debug)]
pub struct SocketFd(FileDescriptor);

impl SocketFd {
    /// Wraps `fd` without taking ownership; `None` for an invalid descriptor.
    pub fn borrowed(fd: std::os::fd::RawFd) -> Option<SocketFd> {
        FileDescriptor::non_owning_new(fd).map(SocketFd)
    }
}

impl FileDescriptorBased for SocketFd {
    fn file_descriptor(&self) -> &FileDescriptor {
        &self.0
    }
}

impl SynchronousMultiplexing for SocketFd {}

/// A service's node and event loop.
#[derive(Debug)]
pub struct Service {
    name: &'static str,
    node: Node<Svc>,
    waitset: WaitSet<Svc>,
    tick: Duration,
}

impl Service {
    /// Opens the node `name` in the config's iceoryx2 domain and the loop's WaitSet.
    pub fn open(config: &Common, name: &'static str) -> Result<Service, ServiceError> {
        let node = ipc::node(config, name)?;
        let waitset = WaitSetBuilder::new()
            .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
            .create::<Svc>()
            .map_err(|e| ServiceError::WaitSet(format!("cannot create the WaitSet: {e:?}")))?;
        Ok(Service {
            name,
            node,
            waitset,
            tick: Notifier::from_env().tick(),
        })
    }

    /// The process's iceoryx2 node, to open topics on.
    pub fn node(&self) -> &Node<Svc> {
        &self.node
    }

    /// The node's name.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// A fresh [`Health`]: the notifier from the environment, fault counters at zero.
    pub fn health(&self) -> Health {
        Health {
            sd: Notifier::from_env(),
            faults: Faults::new(FAULT_LOG_INTERVAL),
        }
    }

    /// Wakes the loop whenever `topic` hears new data.
    pub fn on_data<'a, L: Listening>(
        &'a self,
        topic: &'a L,
    ) -> Result<WaitSetGuard<'a, 'a, Svc>, ServiceError> {
        self.waitset
            .attach_notification(topic.listener())
            .map_err(|e| ServiceError::WaitSet(format!("cannot wait on a topic: {e:?}")))
    }

    /// Wakes the loop whenever `topic` hears new data, and once `deadline` passes without any
    /// ([`Turn::missed`]): a silent upstream is noticed at once, not at the next interval.
    pub fn on_deadline<'a, L: Listening>(
        &'a self,
        topic: &'a L,
        deadline: Duration,
    ) -> Result<WaitSetGuard<'a, 'a, Svc>, ServiceError> {
        self.waitset
            .attach_deadline(topic.listener(), deadline)
            .map_err(|e| ServiceError::WaitSet(format!("cannot wait on a topic: {e:?}")))
    }

    /// Wakes the loop at least every `interval`, and never less often than the watchdog needs.
    pub fn every(
        &self,
        interval: Duration,
    ) -> Result<WaitSetGuard<'_, 'static, Svc>, ServiceError> {
        self.waitset
            .attach_interval(interval.min(self.tick))
            .map_err(|e| ServiceError::WaitSet(format!("cannot attach an interval: {e:?}")))
    }

    /// Wakes the loop whenever one of `fds` (sockets the service reads, non-blocking) is
    /// readable. The descriptors stay owned by the caller and must outlive the guards.
    pub fn on_fds<'a>(
        &'a self,
        fds: &'a [SocketFd],
    ) -> Result<Vec<WaitSetGuard<'a, 'a, Svc>>, ServiceError> {
        (fds.iter())
            .map(|fd| self.waitset.attach_notification(fd))
            .collect::<Result<_, _>>()
            .map_err(|e| ServiceError::WaitSet(format!("cannot wait on a socket: {e:?}")))
    }

    /// Sleeps until `until`, pinging the watchdog meanwhile; false once SIGTERM or SIGINT asked
    /// the process to stop (for loops paced by something other than the WaitSet: a replay).
    pub fn sleep_until(&self, health: &mut Health, until: Instant) -> bool {
        loop {
            let now = Instant::now();
            health.sd.alive(now);
            if now >= until {
                return true;
            }
            if !ipc::sleep(&self.node, (until - now).min(self.tick)) {
                return false;
            }
        }
    }

    /// Runs the loop until SIGTERM or SIGINT: `READY=1` with `ready` first; on every turn the
    /// watchdog ping, then `turn`; `STOPPING=1` and a closing log line with every fault counted
    /// at the end.
    pub fn run(
        &self,
        health: &mut Health,
        ready: &str,
        mut turn: impl FnMut(&Turn, &mut Health),
    ) -> Result<(), ServiceError> {
        health.sd.ready(ready);
        let result = ipc::run_waitset(&self.waitset, |id| {
            let t = Turn {
                id,
                now: Instant::now(),
            };
            health.sd.alive(t.now);
            turn(&t, health);
            CallbackProgression::Continue
        });
        health.sd.stopping("stopping");
        match result {
            Ok(r) => {
                tracing::info!("stopping ({r:?}); faults: {}", health.faults.summary());
                Ok(())
            }
            Err(e) => Err(ServiceError::WaitSet(format!("the WaitSet failed: {e:?}"))),
        }
    }
}
