//! The latency settings of the services on a revolution's path (`[latency]`): a CPU wake-up
//! latency request and real-time scheduling.
//!
//! A revolution crosses three processes (driver → mapper → planner), and each hop wakes a
//! process that sleeps on its WaitSet.
//!
//! * **CPU wake-up latency.** On an idle CPU the wake-up waits for the CPU to leave its idle
//!   state: tens of µs on a laptop in a deep C-state, 100–250 µs per hop on this project's
//!   2-core virtual machine, whose halted virtual CPUs the host deschedules. While a process
//!   holds `/dev/cpu_dma_latency` open with a value written to it (a Linux PM QoS request), the
//!   kernel keeps every CPU out of the idle states slower to leave than that value (0: the CPUs
//!   poll when idle); closing it ends the request, and the kernel applies the smallest request
//!   held. `cyclictest` and tuned's `latency-performance` profile do the same. The price is
//!   power: CPUs that poll instead of sleeping draw more (`latency.cpu_wakeup_us = -1` leaves
//!   them alone). Under the systemd units, `tmpfiles.d/mimnav.conf` gives the `mimnav` group
//!   write access to the device and the units bind it into their private `/dev`.
//! * **Real-time scheduling.** Under the normal scheduler a woken service may wait behind, or be
//!   preempted by, whatever else runs (the simulator, a compiler). A positive
//!   `latency.realtime_priority` puts the service under `SCHED_FIFO`: the drivers at that
//!   priority and each other process a step lower the further it stands from the command
//!   ([`priority_of`]): the planner, then the mapper, then the foliage classifier (its alarm is
//!   taken when it comes, the command never waits for it), then everything else (the
//!   simulator, the Zenoh bridge). With one priority for all, a process that is running can
//!   never be preempted by another, so on two cores the mapper, the classifier and the planner
//!   queued behind each other on one core while the simulator held the other (seen with
//!   `perf sched timehist`: 0.4–0.6 ms of scheduling delay each at a revolution's end). Off by
//!   default: a real-time process that never sleeps starves the rest of its CPU, and a capture
//!   replayed at full speed never sleeps. `mimnav demo` turns it on (`--realtime-priority`); the
//!   systemd units allow it (`LimitRTPRIO=`).

use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// The kernel's PM QoS device for the CPU wake-up latency.
pub const DEVICE: &str = "/dev/cpu_dma_latency";

/// Why a latency setting is not in force: what failed, on which device or at which priority.
#[derive(Debug, thiserror::Error)]
pub enum LatencyError {
    /// The PM QoS device cannot be opened for writing.
    #[error("cannot open {}: {source}", device.display())]
    Open {
        /// The device.
        device: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The request cannot be written to the device.
    #[error("cannot write {us} µs to {}: {source}", device.display())]
    Write {
        /// The device.
        device: PathBuf,
        /// The latency asked for, µs.
        us: i32,
        /// Why.
        source: std::io::Error,
    },
    /// The device cannot be read.
    #[error("cannot read {}: {source}", device.display())]
    Read {
        /// The device.
        device: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The kernel refused the real-time policy (no CAP_SYS_NICE, RLIMIT_RTPRIO too low).
    #[error("cannot switch to SCHED_FIFO at priority {priority}: {source}")]
    Fifo {
        /// The priority asked for.
        priority: i32,
        /// Why.
        source: std::io::Error,
    },
}

/// A CPU wake-up latency request, in force while this value lives.
#[derive(Debug)]
pub struct CpuLatencyRequest {
    _file: File,
    us: i32,
}

impl CpuLatencyRequest {
    /// The requested limit, µs.
    pub fn us(&self) -> i32 {
        self.us
    }
}

/// Requests a CPU wake-up latency of at most `us` µs through `device` (normally [`DEVICE`]);
/// `us < 0` requests nothing. The error names the device and what failed.
pub fn request_at(device: &Path, us: i32) -> Result<Option<CpuLatencyRequest>, LatencyError> {
    if us < 0 {
        return Ok(None);
    }
    let mut file = OpenOptions::new()
        .write(true)
        .open(device)
        .map_err(|source| LatencyError::Open {
            device: device.into(),
            source,
        })?;
    // the device takes a native-endian s32 (or an ASCII hex string)
    file.write_all(&us.to_ne_bytes())
        .map_err(|source| LatencyError::Write {
            device: device.into(),
            us,
            source,
        })?;
    Ok(Some(CpuLatencyRequest { _file: file, us }))
}

/// The CPU wake-up latency the kernel applies now, µs (the smallest request held), read from
/// `device`.
pub fn current_at(device: &Path) -> Result<i32, LatencyError> {
    let mut buf = [0u8; 4];
    File::open(device)
        .and_then(|mut f| f.read_exact(&mut buf))
        .map_err(|source| LatencyError::Read {
            device: device.into(),
            source,
        })?;
    Ok(i32::from_ne_bytes(buf))
}

/// Puts the calling thread (and the threads it starts later) under `SCHED_FIFO` at `priority`;
/// `priority` ≤ 0 leaves the scheduling alone. Returns whether the thread now runs under a
/// real-time policy: one already real-time (set by systemd's `CPUSchedulingPolicy=`) is left as
/// it is.
pub fn set_fifo(priority: i32) -> Result<bool, LatencyError> {
    if priority <= 0 {
        return Ok(false);
    }
    // SAFETY: sched_getscheduler on the calling thread (0) has no preconditions
    let current = unsafe { libc::sched_getscheduler(0) } & !libc::SCHED_RESET_ON_FORK;
    if current == libc::SCHED_FIFO || current == libc::SCHED_RR {
        return Ok(true);
    }
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: `param` is a valid sched_param that outlives the call; 0 is the calling thread.
    // Children (none are started) would not inherit the policy (SCHED_RESET_ON_FORK).
    let rc = unsafe {
        libc::sched_setscheduler(0, libc::SCHED_FIFO | libc::SCHED_RESET_ON_FORK, &param)
    };
    if rc != 0 {
        return Err(LatencyError::Fifo {
            priority,
            source: std::io::Error::last_os_error(),
        });
    }
    Ok(true)
}

/// How many steps below `latency.realtime_priority` each process runs: the order of the path
/// from the sensor to the command. A process not named here runs [`OFF_PATH`] steps below.
const STEPS_BELOW: &[(&str, i32)] = &[
    // the drivers: a packet or a telegram not read in time is lost; their work is short
    ("mimnav-velodyne", 0),
    ("mimnav-sick", 0),
    ("mimnav-kobuki", 0),
    // the end of the path: once its map is in, nothing should come before the command
    ("mimnav-planner", 1),
    ("mimnav-mapper", 2),
    // off the command's path: the planner takes the newest alarm when it comes
    ("mimnav-foliage", 3),
];

/// Steps below for everything else: the simulator (standing in for the sensor and the base,
/// which on a robot take no CPU of the computer) and the bridges.
pub const OFF_PATH: i32 = 4;

/// The SCHED_FIFO priority process `name` asks for when `latency.realtime_priority` is `base`:
/// `base` less its steps below ([`STEPS_BELOW`]), never below 1; 0 (the normal scheduler) when
/// `base` ≤ 0.
pub fn priority_of(name: &str, base: i32) -> i32 {
    if base <= 0 {
        return 0;
    }
    let below = STEPS_BELOW
        .iter()
        .find(|(n, _)| *n == name)
        .map_or(OFF_PATH, |&(_, b)| b);
    (base - below).max(1)
}

/// Applies `[latency]` for service `name`'s lifetime: logged once each, as info when in force
/// and as a warning (naming what failed and the way out) when not; the service runs either way.
/// The CPU wake-up latency request returned holds while it lives.
pub fn apply(name: &str, config: &crate::config::Common) -> Option<CpuLatencyRequest> {
    let priority = priority_of(name, config.latency.realtime_priority);
    match set_fifo(priority) {
        Ok(true) => tracing::info!(priority, "real-time scheduling (SCHED_FIFO) in force"),
        Ok(false) => {}
        Err(e) => {
            tracing::warn!(
                "latency.realtime_priority = {priority}: {e}; running under the normal \
                 scheduler (give the process CAP_SYS_NICE or an RLIMIT_RTPRIO of at least \
                 {priority}, as the systemd units' LimitRTPRIO= does, or set \
                 latency.realtime_priority = 0)"
            );
        }
    }
    hold_cpu_latency(config.latency.cpu_wakeup_us)
}

fn hold_cpu_latency(us: i32) -> Option<CpuLatencyRequest> {
    match request_at(Path::new(DEVICE), us) {
        Ok(Some(r)) => {
            tracing::info!(
                cpu_wakeup_us = us,
                "CPU wake-up latency held at {us} µs while running ({DEVICE})"
            );
            Some(r)
        }
        Ok(None) => None,
        Err(e) => {
            tracing::warn!(
                "latency.cpu_wakeup_us = {us}: {e}; the CPUs' idle states stay as they are, so \
                 each hop of a revolution may wait longer for its CPU to wake (give the service \
                 write access to {DEVICE}, as tmpfiles.d/mimnav.conf does for the mimnav group, \
                 or set latency.cpu_wakeup_us = -1)"
            );
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir =
            std::env::temp_dir().join(format!("mimnav-cpu-latency-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    }

    #[test]
    fn negative_requests_nothing_and_touches_nothing() {
        let dir = scratch("negative");
        let device = dir.join("missing");
        let r = request_at(&device, -1).expect("no request, no error");
        assert!(r.is_none());
        assert!(!device.exists(), "nothing may be created");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn writes_the_value_as_a_native_s32() {
        let dir = scratch("writes");
        let device = dir.join("device");
        std::fs::write(&device, b"").expect("stand-in device");
        let r = request_at(&device, 25).expect("opens").expect("a request");
        assert_eq!(r.us(), 25);
        assert_eq!(std::fs::read(&device).expect("read"), 25i32.to_ne_bytes());
        assert_eq!(current_at(&device).expect("readable"), 25);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_missing_device_is_an_error_naming_it() {
        let dir = scratch("missing");
        let device = dir.join("no-such-device");
        let e = request_at(&device, 0).expect_err("no device");
        assert!(matches!(e, LatencyError::Open { .. }), "{e}");
        let e = e.to_string();
        assert!(e.starts_with("cannot open "), "{e}");
        assert!(e.contains("no-such-device"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn the_path_to_the_command_goes_first() {
        let p = |name| priority_of(name, 10);
        assert_eq!(p("mimnav-velodyne"), 10);
        assert_eq!(p("mimnav-sick"), 10);
        assert!(p("mimnav-planner") < p("mimnav-velodyne"));
        assert!(p("mimnav-mapper") < p("mimnav-planner"));
        assert!(p("mimnav-foliage") < p("mimnav-mapper"));
        assert!(p("mimnav-sim") < p("mimnav-foliage"));
        assert_eq!(p("mimnav-sim"), p("mimnav-zenoh"));
        // never below 1, and off stays off
        assert_eq!(priority_of("mimnav-sim", 2), 1);
        assert_eq!(priority_of("mimnav-velodyne", 0), 0);
        assert_eq!(priority_of("mimnav-planner", -3), 0);
    }

    #[test]
    fn priority_zero_leaves_the_scheduling_alone() {
        // SAFETY: no preconditions
        let before = unsafe { libc::sched_getscheduler(0) };
        assert!(matches!(set_fifo(0), Ok(false)));
        assert_eq!(unsafe { libc::sched_getscheduler(0) }, before);
    }

    /// On a thread of its own (the policy is per thread), where this process may: the thread
    /// runs under SCHED_FIFO at the priority asked for.
    #[test]
    fn fifo_is_in_force_where_allowed() {
        std::thread::spawn(|| match set_fifo(3) {
            Ok(on) => {
                assert!(on);
                // SAFETY: no preconditions; `p` is written by the call
                let policy = unsafe { libc::sched_getscheduler(0) } & !libc::SCHED_RESET_ON_FORK;
                assert_eq!(policy, libc::SCHED_FIFO);
                let mut p = libc::sched_param { sched_priority: 0 };
                assert_eq!(unsafe { libc::sched_getparam(0, &mut p) }, 0);
                assert_eq!(p.sched_priority, 3);
                // a second call leaves a real-time thread as it is
                assert!(matches!(set_fifo(5), Ok(true)));
                assert_eq!(unsafe { libc::sched_getparam(0, &mut p) }, 0);
                assert_eq!(p.sched_priority, 3);
            }
            Err(e) => {
                assert!(e.to_string().contains("SCHED_FIFO at priority 3"), "{e}");
                println!("SKIP fifo_is_in_force_where_allowed: {e}");
            }
        })
        .join()
        .expect("the thread's checks");
    }

    /// The real device, where this process may write it: while the request is held, the kernel's
    /// limit is at most the value requested (other holders may ask for less, never more).
    #[test]
    fn the_kernel_applies_the_request_while_held() {
        let device = Path::new(DEVICE);
        let r = match request_at(device, 7) {
            Ok(r) => r.expect("a request"),
            Err(e) => {
                println!("SKIP the_kernel_applies_the_request_while_held: {e}");
                return;
            }
        };
        let now = current_at(device).expect("readable");
        assert!(
            now <= 7,
            "the kernel's limit is {now} µs with 7 µs requested"
        );
        drop(r);
    }
}
