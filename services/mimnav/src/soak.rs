//! `mimnav soak`: the stack as processes under a long or fast stream (issue 23, the soak).
//!
//! The driver, mapper, foliage classifier and planner run as their own processes
//! ([`crate::stack`]); the simulator streams the VLP-16's UDP packets to the driver at
//! `--time-scale` times real time for `--seconds` of sensor time while the robot patrols between
//! the world's start and goal (a new goal each time one is reached, so it keeps driving and the
//! mapper's memories keep growing). The soak follows every hop from the messages' own sequence
//! numbers — the revolutions the simulator completed, those the driver published, the maps, the
//! commands and the classifier's verdicts — and reads the kernel's count of datagrams dropped on
//! the driver's socket, so that every revolution is accounted for: commanded, or lost on a named
//! hop. It samples each process's resident memory (`VmRSS`) every 250 ms. The services count the
//! same drops themselves, in their periodic statistics and in `STATUS=`.
//!
//! Exit status: 0 when no revolution was lost and no service's memory grew; 3 otherwise; 130
//! when interrupted; 1 on an error.

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Result;
use mimnav_shared::ipc;
use mimnav_shared::topics::{Goal, command_status};
use serde::Serialize;

use crate::demo::{CmdLatency, Latency};
use crate::stack::{self, Resolved, Stack};

/// How often the processes' memory is sampled.
const RSS_EVERY: Duration = Duration::from_millis(250);
/// Growth of a service's resident memory from the end of the warm-up (the first tenth of the
/// run) to the end that still counts as flat, KiB.
const RSS_FLAT_KIB: u64 = 1024;

/// Arguments of `mimnav soak`.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Examples:
  mimnav soak                                  # 60 s of sensor time at 10x real time (6 s)
  mimnav soak --time-scale 1 --seconds 600     # 10 minutes at the sensor's own pace

Exit status: 0 no revolution lost and every service's memory flat, 3 otherwise, 130 \
interrupted, 1 error.")]
pub struct SoakArgs {
    /// The world (default: sim.world of the config).
    #[arg(long, value_name = "FILE")]
    world: Option<PathBuf>,
    /// The robot profile: spot or turtlebot2 (default: the config's).
    #[arg(long, value_name = "NAME")]
    robot: Option<String>,
    /// Sensor time to stream, s.
    #[arg(long, default_value_t = 60.0, value_parser = mimnav_shared::cli::seconds_arg)]
    seconds: f64,
    /// How many times faster than real time the simulator streams (sim.time_scale).
    #[arg(long, default_value_t = 10.0)]
    time_scale: f64,
    /// Seed of the simulation (default: sim.seed).
    #[arg(long)]
    seed: Option<u64>,
    /// The services' log filter (`log.level`); their messages come to this terminal's stderr.
    #[arg(long, value_name = "FILTER", default_value = "warn")]
    log: String,
    /// The SCHED_FIFO priority of the driver (`latency.realtime_priority`; 0: the normal
    /// scheduler); the other processes run lower by their place on the path.
    #[arg(long, value_name = "N", default_value_t = 10, value_parser = clap::value_parser!(i32).range(0..=99))]
    realtime_priority: i32,
    /// Print the report as one JSON object as well.
    #[arg(long)]
    json: bool,
}

/// The last sample of a numbered topic: how many were published (the publisher numbers from
/// 0) and the revolution the last one came from.
#[derive(Debug, Default, Clone, Copy, Serialize)]
struct Last {
    seq: Option<u64>,
    source_seq: Option<u64>,
}

impl Last {
    fn take(&mut self, seq: u64, source_seq: u64) {
        (self.seq, self.source_seq) = (Some(seq), Some(source_seq));
    }
    /// Samples published: one more than the last number.
    fn count(&self) -> u64 {
        self.seq.map_or(0, |s| s + 1)
    }
    /// Revolutions up to the one the last sample came from.
    fn sources(&self) -> u64 {
        self.source_seq.map_or(0, |s| s + 1)
    }
}

/// One service's resident memory over the run, KiB: all of it (`VmRSS`), its own heap and
/// stacks (`RssAnon`: a leak shows here) and the shared memory it has touched (`RssShmem`: the
/// iceoryx2 sample pools, which grow until every sample of a pool has been used once).
#[derive(Debug, Clone, Serialize)]
struct Memory {
    service: String,
    after_warm_up_kib: u64,
    half_kib: u64,
    end_kib: u64,
    max_kib: u64,
    heap_after_warm_up_kib: u64,
    heap_end_kib: u64,
    shared_after_warm_up_kib: u64,
    shared_end_kib: u64,
    samples: usize,
    /// CPU time (user and system) from the end of the warm-up to the end, as a share of one
    /// core over that wall time, % (issue 27: the stack at the sensor's rate).
    cpu_percent: f64,
}

impl Memory {
    fn growth_kib(&self) -> i64 {
        self.end_kib as i64 - self.after_warm_up_kib as i64
    }
    fn heap_growth_kib(&self) -> i64 {
        self.heap_end_kib as i64 - self.heap_after_warm_up_kib as i64
    }
    /// Flat: the heap grew by no more than [`RSS_FLAT_KIB`] after the warm-up. The shared
    /// memory touched is not counted: it is bounded by the topics' sample pools, fixed at start,
    /// and grows when a stall makes a publisher use samples it had not used before.
    fn flat(&self) -> bool {
        self.heap_growth_kib() <= RSS_FLAT_KIB as i64
    }
}

/// One sample of a process's memory, KiB.
#[derive(Debug, Clone, Copy)]
struct Sample {
    t: f64,
    rss: u64,
    anon: u64,
    shmem: u64,
    /// CPU time used so far, s.
    cpu_s: f64,
}

/// What the soak measured: every revolution the simulator completed, accounted for hop by hop.
#[derive(Debug, Serialize)]
struct Report {
    world: String,
    sensor_s: f64,
    time_scale: f64,
    wall_s: f64,
    /// Revolutions the simulator completed.
    simulated: u64,
    /// Published by the driver on `lidar/points`.
    published: u64,
    /// Datagrams the kernel dropped on the driver's data socket (receive buffer full).
    kernel_drops: Option<u64>,
    /// Revolutions the simulator completed that the driver never published (beyond the last,
    /// which waits for the next revolution's first packet).
    lost_udp: u64,
    /// Maps made by the mapper.
    maps: u64,
    /// Revolutions published that the mapper never mapped.
    lost_mapper: u64,
    /// Distinct revolutions the planner commanded from.
    commanded: u64,
    /// Maps the planner never planned on.
    lost_planner: u64,
    /// Verdicts of the foliage classifier, and scans it never classified.
    verdicts: u64,
    lost_foliage: u64,
    /// Revolutions completed and never commanded from, end to end.
    lost_end_to_end: u64,
    /// Goals reached on the patrol.
    goals_reached: u64,
    /// From a revolution's last packet to its `cmd_vel`, over the run (as the demo measures it).
    latency_ms: Latency,
    memory: Vec<Memory>,
}

impl Report {
    fn ok(&self) -> bool {
        self.lost_end_to_end == 0
            && self.lost_foliage == 0
            && self.kernel_drops.unwrap_or(0) == 0
            && (self.memory.iter()).all(Memory::flat)
    }
}

/// `VmRSS`, `RssAnon` and `RssShmem` of process `pid` at `t`, KiB, and its CPU time.
fn memory_of(pid: u32, t: f64) -> Option<Sample> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let field = |name: &str| -> Option<u64> {
        let line = status.lines().find(|l| l.starts_with(name))?;
        line.split_whitespace().nth(1)?.parse().ok()
    };
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    Some(Sample {
        t,
        rss: field("VmRSS:")?,
        anon: field("RssAnon:")?,
        shmem: field("RssShmem:")?,
        cpu_s: cpu_seconds(&stat)?,
    })
}

/// User and system CPU time of a `/proc/PID/stat` line, s: fields 14 and 15, counted after the
/// command name's closing parenthesis (the name may hold spaces).
fn cpu_seconds(stat: &str) -> Option<f64> {
    let rest = &stat[stat.rfind(')')? + 1..];
    let mut fields = rest.split_whitespace().skip(11);
    let (utime, stime): (u64, u64) = (fields.next()?.parse().ok()?, fields.next()?.parse().ok()?);
    // SAFETY: sysconf reads a constant of the system and has no precondition
    let ticks = unsafe { libc::sysconf(libc::_SC_CLK_TCK) };
    (ticks > 0).then(|| (utime + stime) as f64 / ticks as f64)
}

/// The kernel's drops on the UDP sockets bound to `port`.
fn kernel_drops(port: u16) -> Option<u64> {
    let tables = ["/proc/net/udp", "/proc/net/udp6"].map(std::fs::read_to_string);
    (tables.iter().flatten())
        .filter_map(|t| mimnav_velodyne::udp::drops_on_port(t, port))
        .reduce(|a, b| a + b)
}

/// Runs the soak.
pub fn run(config_path: Option<&Path>, sets: &[String], args: &SoakArgs) -> Result<ExitCode> {
    // the robot patrols: reaching the goal or the world's time limit must not stop it
    let extra = [
        format!("sim.time_scale={}", args.time_scale),
        "sim.endless=true".into(),
    ];
    let (robot, world) = (args.robot.as_deref(), args.world.as_deref());
    let Resolved {
        config,
        sets,
        world_path,
        world,
    } = stack::resolve(config_path, sets, robot, &extra, world)?;
    let stack = Stack::new(
        "soak",
        &config,
        config_path,
        &sets,
        &args.log,
        args.realtime_priority,
    )?;
    let node = ipc::node(&stack.local, "mimnav-soak")?;
    let points = ipc::points_subscriber(&node)?;
    let plans = ipc::plan_subscriber(&node)?;
    let commands = ipc::cmd_vel_subscriber(&node)?;
    let alarms = ipc::foliage_subscriber(&node)?;
    let goal_pub = ipc::goal_publisher(&node)?;
    let _ = outln!(
        "{}: {} s of sensor time at {}× real time with a {}; driver, mapper, foliage classifier and planner as processes, the simulator streaming UDP to 127.0.0.1:{}; the robot patrols between ({:.1}, {:.1}) and ({:.1}, {:.1})",
        world.name,
        args.seconds,
        args.time_scale,
        config.robot.name,
        stack.data_port,
        world.start[0],
        world.start[1],
        world.goal[0],
        world.goal[1],
    );
    let mut children = stack.start_services()?;
    if !children.wait_for_planner(&node, &commands)? {
        return Ok(ExitCode::from(130));
    }
    let ends = [world.goal, [world.start[0], world.start[1]]];
    let goal = |seq: u64| Goal {
        seq,
        stamp_mono_ns: ipc::monotonic_ns(),
        x: ends[(seq % 2) as usize][0],
        y: ends[(seq % 2) as usize][1],
        tolerance_m: config.sim.goal_tolerance_m,
        ..Goal::default()
    };
    let (mut goal_seq, mut goal_taken) = (0u64, false);
    goal_pub.publish(goal(goal_seq))?;

    let mut sim_args: Vec<String> = ["--world", &world_path.display().to_string(), "--json"]
        .map(String::from)
        .into();
    sim_args.extend(["--seconds".into(), args.seconds.to_string()]);
    if let Some(s) = args.seed {
        sim_args.extend(["--seed".into(), s.to_string()]);
    }
    stack.start_sim(&mut children, &sim_args)?;
    let started = Instant::now();

    let (mut last_points, mut last_map, mut last_alarm) =
        (Last::default(), Last::default(), Last::default());
    let mut commanded: HashSet<u64> = HashSet::new();
    let mut latency = CmdLatency::default();
    let mut rss: BTreeMap<String, Vec<Sample>> = BTreeMap::new();
    let (mut next_rss, mut drops, mut interrupted) = (started, None, false);
    let mut sim_ended_at: Option<Instant> = None;
    // after the simulator ends, the last revolution's map and command still come
    while sim_ended_at.is_none_or(|t| t.elapsed() < Duration::from_millis(300)) {
        if sim_ended_at.is_none() && children.sim_exited() {
            sim_ended_at = Some(Instant::now());
        }
        if !ipc::sleep(&node, Duration::from_millis(5)) {
            interrupted = true;
            break;
        }
        while let Some(s) = points.receive()? {
            let h = s.user_header();
            last_points.take(h.seq, h.seq);
        }
        while let Some(s) = plans.receive()? {
            let h = s.user_header();
            last_map.take(h.seq, h.source_seq);
            latency.map(h.source_seq, h.rx_mono_ns);
        }
        while let Some(s) = alarms.receive()? {
            let h = s.user_header();
            last_alarm.take(h.seq, h.source_seq);
        }
        while let Some(c) = commands.receive()? {
            // a command planned on a map names its revolution's stamp; a stop for want of a map
            // names none
            if c.source_stamp_ns != 0 {
                commanded.insert(c.source_seq);
            }
            latency.command(&c);
            match c.status {
                command_status::NO_GOAL if !goal_taken => _ = goal_pub.publish(goal(goal_seq))?,
                command_status::DRIVING | command_status::BLOCKED => goal_taken = true,
                // patrol: the other end, once the planner has taken the goal just reached
                command_status::GOAL_REACHED if goal_taken => {
                    (goal_seq, goal_taken) = (goal_seq + 1, false);
                    _ = goal_pub.publish(goal(goal_seq))?;
                }
                _ => {}
            }
        }
        if Instant::now() >= next_rss {
            let t = started.elapsed().as_secs_f64();
            for (name, pid) in children.pids() {
                if let Some(sample) = memory_of(pid, t) {
                    rss.entry(name).or_default().push(sample);
                }
            }
            // read while the driver's socket is open
            drops = kernel_drops(stack.data_port).or(drops);
            next_rss += RSS_EVERY;
        }
    }
    let halted = match interrupted {
        true => {
            let (stop, odom) = (ipc::cmd_vel_publisher(&node)?, ipc::odom_subscriber(&node)?);
            Some(children.halt_robot(&node, &stop, &odom))
        }
        false => None,
    };
    let (_, summary) = children.stop_sim();
    let wall_s = (sim_ended_at.unwrap_or_else(Instant::now) - started).as_secs_f64();
    children.stop_rest();
    if let Some(h) = &halted {
        let _ = outln!("{}", h.describe());
    }
    if interrupted {
        return Ok(ExitCode::from(130));
    }
    let ended: Option<mimnav_sim::Summary> = summary
        .lines()
        .rev()
        .find_map(|l| serde_json::from_str(l).ok());
    let simulated = ended.as_ref().map_or(0, |e| e.revolutions);
    let published = last_points.count();
    // the simulator's last revolution is published by the driver only when the next one's
    // first packet comes: it may be missing without a loss
    let expected = published.max(simulated.saturating_sub(1));
    let lost_udp = expected - published;
    let maps = last_map.count();
    let lost_mapper = published.saturating_sub(maps);
    let commanded_n = commanded.len() as u64;
    let report = Report {
        world: world.name.clone(),
        sensor_s: args.seconds,
        time_scale: args.time_scale,
        wall_s,
        simulated,
        published,
        kernel_drops: drops,
        lost_udp,
        maps,
        lost_mapper,
        commanded: commanded_n,
        lost_planner: maps.saturating_sub(commanded_n),
        verdicts: last_alarm.count(),
        lost_foliage: last_alarm.sources().saturating_sub(last_alarm.count()),
        lost_end_to_end: expected.saturating_sub(commanded_n),
        goals_reached: goal_seq,
        latency_ms: latency.summary(),
        memory: memory(&rss),
    };
    print(&report);
    if args.json {
        let _ = outln!("{}", serde_json::to_string(&report)?);
    }
    Ok(match report.ok() {
        true => ExitCode::SUCCESS,
        false => ExitCode::from(3),
    })
}

/// Each service's memory: after the warm-up (the first tenth of the run), at half time, at the
/// end, at most.
fn memory(rss: &BTreeMap<String, Vec<Sample>>) -> Vec<Memory> {
    (rss.iter())
        .filter_map(|(name, samples)| {
            let end = *samples.last()?;
            let at = |share: f64| {
                *samples
                    .iter()
                    .find(|s| s.t >= end.t * share)
                    .unwrap_or(&end)
            };
            let (warm, half) = (at(0.1), at(0.5));
            Some(Memory {
                service: name.clone(),
                after_warm_up_kib: warm.rss,
                half_kib: half.rss,
                end_kib: end.rss,
                max_kib: samples.iter().map(|s| s.rss).max().unwrap_or(end.rss),
                heap_after_warm_up_kib: warm.anon,
                heap_end_kib: end.anon,
                shared_after_warm_up_kib: warm.shmem,
                shared_end_kib: end.shmem,
                samples: samples.len(),
                cpu_percent: 100.0 * (end.cpu_s - warm.cpu_s) / (end.t - warm.t).max(1e-9),
            })
        })
        .collect()
}

fn print(r: &Report) {
    let drops = r
        .kernel_drops
        .map_or("not readable".into(), |d| d.to_string());
    let _ = outln!(
        "{}: {:.0} s of sensor time in {:.1} s wall ({:.1}× real time)",
        r.world,
        r.sensor_s,
        r.wall_s,
        r.sensor_s / r.wall_s.max(1e-9)
    );
    let _ = outln!(
        "  simulator → driver (UDP):    {} revolutions completed, {} published; {} lost; datagrams the kernel dropped: {drops}",
        r.simulated,
        r.published,
        r.lost_udp
    );
    let _ = outln!(
        "  driver → mapper:             {} maps, {} revolutions lost",
        r.maps,
        r.lost_mapper
    );
    let _ = outln!(
        "  mapper → planner:            {} revolutions commanded from, {} maps lost",
        r.commanded,
        r.lost_planner
    );
    let _ = outln!(
        "  driver → foliage classifier: {} verdicts, {} scans lost",
        r.verdicts,
        r.lost_foliage
    );
    let _ = outln!(
        "  end to end: {} revolutions lost (the last one in flight not counted); {} goals reached on the patrol",
        r.lost_end_to_end,
        r.goals_reached
    );
    let l = &r.latency_ms;
    let _ = outln!(
        "  latency from a revolution's last packet to its cmd_vel over {} revolutions: p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
        l.revolutions,
        l.p50,
        l.p99,
        l.max
    );
    let mb = |kib: u64| kib as f64 / 1024.0;
    for m in &r.memory {
        let _ = outln!(
            "  {:16} CPU {:5.2} % of a core; RSS {:5.1} MB after the warm-up, {:5.1} at half time, {:5.1} at the end ({:+.1}), {:5.1} at most; heap {:5.1} → {:5.1} MB ({:+.1}), shared memory {:5.1} → {:5.1} MB ({} samples){}",
            m.service,
            m.cpu_percent,
            mb(m.after_warm_up_kib),
            mb(m.half_kib),
            mb(m.end_kib),
            m.growth_kib() as f64 / 1024.0,
            mb(m.max_kib),
            mb(m.heap_after_warm_up_kib),
            mb(m.heap_end_kib),
            m.heap_growth_kib() as f64 / 1024.0,
            mb(m.shared_after_warm_up_kib),
            mb(m.shared_end_kib),
            m.samples,
            if m.flat() { "" } else { "  GREW" }
        );
    }
    let stack: f64 = (r.memory.iter())
        .filter(|m| m.service != "mimnav-sim")
        .map(|m| m.cpu_percent)
        .sum();
    let _ = outln!(
        "  the stack without the simulator: CPU {stack:.2} % of a core ({:.1}× real time)",
        r.sensor_s / r.wall_s.max(1e-9)
    );
    let _ = outln!(
        "{}",
        match r.ok() {
            true => "soak passed: every revolution commanded, every service's memory flat",
            false => "soak FAILED: see the lost revolutions or the memory above",
        }
    );
}

#[cfg(test)]
mod tests {
    use super::cpu_seconds;

    #[test]
    fn cpu_time_is_read_after_a_command_name_with_spaces_and_parentheses() {
        // SAFETY: as in cpu_seconds
        let ticks = unsafe { libc::sysconf(libc::_SC_CLK_TCK) } as f64;
        let line = "4242 (mimnav (x) y) S 1 4242 4242 0 -1 4194560 900 0 0 0 250 50 0 0 20 0 3 0";
        let s = cpu_seconds(line).expect("parsed");
        assert!((s - 300.0 / ticks).abs() < 1e-9, "{s}");
        assert_eq!(cpu_seconds("4242 (cut"), None);
        // the kernel's own line for this process reads
        let own = std::fs::read_to_string("/proc/self/stat").expect("/proc/self/stat");
        assert!(cpu_seconds(&own).is_some_and(|s| s >= 0.0));
    }
}
