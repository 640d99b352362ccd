//! The lock-step runner against the services as processes: the same episode gives the same
//! commands.
//!
//! Bit for bit, not within a tolerance: the runner and the services run the very same step
//! types on the very same numbers. The simulator is deterministic for a seed; in lock-step mode
//! it publishes a revolution's odometry before the revolution's last packet and waits for the
//! command answering it before it moves on, and the driver, the mapper and the planner each
//! read their latest inputs before the message that makes them act, so every step type sees
//! the same inputs in the same order as in the runner. The clocks differ (the processes read
//! `CLOCK_MONOTONIC`, the runner the simulator's sensor time), but the step types use time only
//! for freshness (every input here is fresh in both) and as differences of stamps the sensor
//! made. What could tell them apart is what this test watches for: a datagram lost on
//! loopback, a message read out of order, a stale input, a command from the wrong map. The
//! foliage classifier is left out: its verdict races the map to the planner (it is used when
//! it has arrived), so with it the processes are deterministic only in what the runner's
//! order makes certain.

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_config::Config;
use mimnav_runner::{FoliageUse, Lockstep, Options};
use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::VelocityCommand;
use mimnav_sim::world::WorldFile;

use crate::util::{Proc, bin, free_udp_port, root, shipped_config, stack_args};

/// What is compared: (v, ω) as the message carries them (bits), status, flags, and the
/// sequence number of the revolution it answers.
type Answer = (u32, u32, u8, u8, u64);

fn answer(c: &VelocityCommand) -> Answer {
    (
        c.v.to_bits(),
        c.omega.to_bits(),
        c.status,
        c.flags,
        c.source_seq,
    )
}

#[test]
fn the_services_as_processes_command_what_the_lockstep_runner_commands() {
    let world = root().join("config/worlds/open_field.toml");
    let config = Config::load(&shipped_config(), &[]).expect("the shipped config loads");

    // in process
    let scene = WorldFile::load(&world).expect("world").compile();
    let options = Options {
        foliage: FoliageUse::Off,
        ..Options::deployed(&config)
    };
    let mut run = Lockstep::new(&config, scene, config.sim.seed, options).expect("runner");
    run.set_goal(8.0, 0.0, 0.3).expect("goal");
    let mut expected = Vec::new();
    while let Some(turn) = run.next_revolution().expect("no refused packet") {
        expected.push(answer(&turn.command.expect("the planner answers").1));
    }
    let in_process = format!("{:?}", run.sim().outcome());

    // as processes
    let domain = PrivateDomain::new("e2e-equivalence");
    let (dp, pp) = (free_udp_port(), free_udp_port());
    let args = stack_args(&domain, dp, pp);
    let node = ipc::node(&domain.config(), "equivalence-tap").expect("node");
    let cmd = ipc::cmd_vel_subscriber(&node).expect("cmd_vel");
    let _driver = Proc::start(Command::new(bin("mimnav-velodyne")).args(&args));
    let _mapper = Proc::start(Command::new(bin("mimnav-mapper")).args(&args));
    let _planner = Proc::start(Command::new(bin("mimnav-planner")).args(&args));
    std::thread::sleep(Duration::from_millis(500));
    let goal = Command::new(bin("mimnav"))
        .args(&args)
        .args(["goal", "8", "0", "--tolerance", "0.3"])
        .output()
        .expect("mimnav goal");
    assert!(
        goal.status.success(),
        "{}",
        String::from_utf8_lossy(&goal.stderr)
    );
    let mut sim = Proc::start(
        Command::new(bin("mimnav-sim"))
            .args(&args)
            .arg("--world")
            .arg(&world)
            .args(["--lockstep", "--json"])
            .stdout(Stdio::piped()),
    );
    let (until, mut got) = (Instant::now() + Duration::from_secs(120), Vec::new());
    let take = |got: &mut Vec<Answer>| {
        while let Some(c) = cmd.receive().expect("receive") {
            // the planner's stops while no map comes (before the simulator starts) answer no
            // revolution
            if c.source_stamp_ns != 0 {
                got.push(answer(&c));
            }
        }
    };
    let status = loop {
        take(&mut got);
        if let Some(s) = sim.0.try_wait().expect("wait") {
            break s;
        }
        assert!(Instant::now() < until, "the lock-step episode did not end");
        cmd.heard_within(Duration::from_millis(5));
    };
    std::thread::sleep(Duration::from_millis(200));
    take(&mut got);
    let mut out = String::new();
    std::io::Read::read_to_string(&mut sim.0.stdout.take().expect("stdout"), &mut out)
        .expect("read");
    let summary: serde_json::Value = serde_json::from_str(out.trim()).expect("one JSON line");
    assert!(status.success(), "{status}: {out}");
    assert_eq!(summary["lockstep_timeouts"], 0, "{out}");
    assert_eq!(
        summary["outcome"], "goal_reached",
        "{out}; in process: {in_process}"
    );
    assert_eq!(in_process, "GoalReached");
    assert!(expected.len() > 20, "{} revolutions", expected.len());
    // the processes number revolutions from the driver's start, the runner from 0: compare
    // the numbers relative to the first answer
    let rebase = |v: &[Answer]| -> Vec<Answer> {
        let first = v.first().map_or(0, |a| a.4);
        v.iter()
            .map(|a| (a.0, a.1, a.2, a.3, a.4 - first))
            .collect()
    };
    let (got, expected) = (rebase(&got), rebase(&expected));
    if let Some(i) = (0..got.len().min(expected.len())).find(|&i| got[i] != expected[i]) {
        panic!(
            "command {i} of {} differs: processes {:?}, runner {:?}",
            expected.len(),
            got[i],
            expected[i]
        );
    }
    assert_eq!(got.len(), expected.len(), "as many commands as revolutions");
}
