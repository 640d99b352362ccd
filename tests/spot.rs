//! `mimnav-spot` (`clients/python/mimnav_spot.py`, on Boston Dynamics' `bosdyn-client`) as a
//! process against `clients/python/fake_spot.py`, a gRPC server made of `bosdyn-api`'s own
//! servicers that records every request: the velocity commands follow `cmd_vel` and never end
//! after its `valid_until_mono_ns`; the lease is acquired and kept, the E-Stop endpoint checks in;
//! a lost lease, a dead server and an E-Stop stop the velocity commands, `base/state` says so, and
//! the bridge stays up and comes back.

use std::io::Write;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, PrivateDomain};
use mimnav_shared::topics::{BaseState, VelocityCommand, base_halt};
use serde_json::Value;

use crate::util::python_command as python;
use crate::util::{Proc, config_args, lines_of, root};

const ESTOP: u16 = base_halt::ESTOP;
const NO_LEASE: u16 = base_halt::NO_LEASE;
const MOTORS_OFF: u16 = base_halt::MOTORS_OFF;
const LINK_DOWN: u16 = base_halt::LINK_DOWN;
const COMMAND_EXPIRED: u16 = base_halt::COMMAND_EXPIRED;

/// A Python with the SDK and iceoryx2 (`MIMNAV_SPOT_PYTHON`, which `.ci/run` sets, else
/// `target/spot-venv`), or None after a SKIP line.
fn spot_python(test: &str) -> Option<PathBuf> {
    crate::util::python_with(
        test,
        "MIMNAV_SPOT_PYTHON",
        "spot-venv",
        "bosdyn.client, bosdyn.api, iceoryx2",
        "bosdyn-client==5.2.0 bosdyn-api==5.2.0 iceoryx2==0.10.0",
    )
}

/// The fake robot: its process, its stdin (faults) and its records.
struct Fake {
    proc: Proc,
    records: Receiver<String>,
}

impl Fake {
    fn start(py: &Path, dir: &Path, port: u16) -> (Fake, Value) {
        let mut proc = Proc(
            python(py)
                .arg(root().join("clients/python/fake_spot.py"))
                .arg("--cert-dir")
                .arg(dir.join("certs"))
                .args(["--port", &port.to_string()])
                .stdin(Stdio::piped())
                .stdout(Stdio::piped())
                .stderr(Stdio::inherit())
                .spawn()
                .expect("the fake Spot starts"),
        );
        let records = lines_of(proc.0.stdout.take().expect("stdout"));
        let line = records
            .recv_timeout(Duration::from_secs(30))
            .expect("the fake Spot says it is ready");
        let ready: Value = serde_json::from_str(&line).expect("json");
        assert_eq!(ready["t"], "ready", "{line}");
        (Fake { proc, records }, ready)
    }

    fn fault(&mut self, what: &str) {
        let stdin = self.proc.0.stdin.as_mut().expect("stdin");
        writeln!(stdin, "{what}").expect("fault sent");
        stdin.flush().expect("flush");
    }
}

/// Everything one test run saw.
struct Run {
    records: Vec<Value>,
    /// Every command published: (its `v`, its `valid_until_mono_ns`, when it was published).
    sent: Vec<(f32, u64, u64)>,
    states: Vec<BaseState>,
    seq: u64,
}

impl Run {
    fn drain(&mut self, fake: &Fake) {
        for l in fake.records.try_iter() {
            self.records
                .push(serde_json::from_str(&l).unwrap_or_else(|e| panic!("{e}: {l}")));
        }
    }

    fn of<'a>(&'a self, t: &'a str) -> impl Iterator<Item = &'a Value> + 'a {
        self.records.iter().filter(move |r| r["t"] == t)
    }
}

fn mono(r: &Value, key: &str) -> u64 {
    r[key].as_u64().unwrap_or_else(|| panic!("no {key} in {r}"))
}

#[test]
fn spot_bridge_follows_cmd_vel_and_stops_on_every_fault() {
    let test = "spot_bridge_follows_cmd_vel_and_stops_on_every_fault";
    let Some(py) = spot_python(test) else {
        return;
    };
    let started = Instant::now();
    let dir = std::env::temp_dir().join(format!("mimnav-spot-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (mut fake, ready) = Fake::start(&py, &dir, 0);
    let port = ready["port"].as_u64().expect("port") as u16;

    // credentials the bridge accepts only while no one else may read them
    let creds = dir.join("spot-credentials");
    std::fs::write(
        &creds,
        format!(
            "{}\n{}\n",
            ready["username"].as_str().expect("username"),
            ready["password"].as_str().expect("password")
        ),
    )
    .expect("credentials");
    std::fs::set_permissions(&creds, std::fs::Permissions::from_mode(0o644)).expect("chmod");
    let domain = PrivateDomain::new("e2e-spot");
    let mut args = config_args(&domain);
    for s in [
        "spot.hostname=\"127.0.0.1\"".to_string(),
        format!("spot.port={port}"),
        format!("spot.ca_cert=\"{}\"", ready["ca"].as_str().expect("ca")),
        format!("spot.credentials_file=\"{}\"", creds.display()),
        "spot.estop_timeout_s=3".into(),
        "spot.command_validity_cap_s=0.25".into(),
        "spot.odom_rate_hz=20".into(),
    ] {
        args.extend(["--set".into(), s]);
    }
    let bridge = |args: &[String]| {
        python(&py)
            .args(["-m", "mimnav_spot", "--stand"])
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the bridge starts")
    };
    let refused = bridge(&args).wait_with_output().expect("the bridge ends");
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(
        refused.status.code() == Some(2) && err.contains("refusing the Spot credentials"),
        "credentials readable by others are refused: {:?} {err}",
        refused.status
    );
    std::fs::set_permissions(&creds, std::fs::Permissions::from_mode(0o600)).expect("chmod");

    let node = ipc::node(&domain.config(), "e2e-spot").expect("node");
    let cmd = ipc::cmd_vel_publisher(&node).expect("cmd_vel");
    let state = ipc::base_state_subscriber(&node).expect("base/state");
    let odom = ipc::odom_subscriber(&node).expect("odom");
    let mut p = Proc(bridge(&args));
    let log = lines_of(p.0.stderr.take().expect("stderr"));
    let mut log_lines = Vec::new();
    let mut run = Run {
        records: Vec::new(),
        sent: Vec::new(),
        states: Vec::new(),
        seq: 0,
    };

    // Publishes a command every 100 ms for `secs` (valid 300 ms; `v` tells them apart), runs
    // `during` halfway, and collects base/state.
    let drive = |run: &mut Run,
                 fake: &mut Fake,
                 secs: f64,
                 v0: f32,
                 status: u8,
                 during: &mut dyn FnMut(&mut Fake)| {
        let until = Instant::now() + Duration::from_secs_f64(secs);
        let half = Instant::now() + Duration::from_secs_f64(secs / 2.0);
        let mut done = false;
        while Instant::now() < until {
            if !done && Instant::now() >= half {
                during(fake);
                done = true;
            }
            run.seq += 1;
            let now = ipc::monotonic_ns();
            let v = if v0.is_nan() {
                v0
            } else {
                v0 + 0.001 * (run.seq % 100) as f32
            };
            let c = VelocityCommand {
                seq: run.seq,
                stamp_mono_ns: now,
                valid_until_mono_ns: now + 300_000_000,
                v,
                omega: 0.2,
                status,
                ..VelocityCommand::default()
            };
            cmd.publish(c).expect("publish");
            if status == 0 && v.is_finite() {
                run.sent.push((v, c.valid_until_mono_ns, now));
            }
            std::thread::sleep(Duration::from_millis(100));
            while let Ok(Some(s)) = state.receive() {
                run.states.push(s);
            }
            run.drain(fake);
        }
    };
    let idle = |run: &mut Run, fake: &Fake, secs: f64| {
        let until = Instant::now() + Duration::from_secs_f64(secs);
        while Instant::now() < until {
            std::thread::sleep(Duration::from_millis(50));
            while let Ok(Some(s)) = state.receive() {
                run.states.push(s);
            }
            run.drain(fake);
        }
    };
    let ready_state =
        |s: &BaseState| s.link == 0 && s.halted & (ESTOP | NO_LEASE | MOTORS_OFF) == 0;
    let wait_state = |run: &mut Run, fake: &Fake, ok: &dyn Fn(&BaseState) -> bool, secs: u64| {
        let until = Instant::now() + Duration::from_secs(secs);
        while Instant::now() < until {
            idle(run, fake, 0.05);
            if run.states.last().is_some_and(ok) {
                return true;
            }
        }
        false
    };
    let context = |run: &Run, log: &Receiver<String>, lines: &mut Vec<String>| {
        lines.extend(log.try_iter());
        format!(
            "\nbridge log: {lines:#?}\nlast records: {:#?}",
            &run.records[run.records.len().saturating_sub(30)..]
        )
    };

    // connected: authenticated, E-Stop endpoint allowing motion, lease, motors on
    let up = wait_state(&mut run, &fake, &ready_state, 30);
    assert!(
        up,
        "the bridge connects and stands{}",
        context(&run, &log, &mut log_lines)
    );
    assert_eq!(run.states.last().map(|s| s.base), Some(2), "base 2: Spot");

    // 1. it follows cmd_vel; then the commands stop coming (stale)
    let t1 = ipc::monotonic_ns();
    drive(&mut run, &mut fake, 2.0, 0.4, 0, &mut |_| {});
    let last_valid = run.sent.last().expect("sent").1;
    idle(&mut run, &fake, 1.0);
    let t1_end = ipc::monotonic_ns();
    let phase1: Vec<&Value> = run
        .of("velocity")
        .filter(|r| (t1..t1_end).contains(&mono(r, "mono_ns")))
        .collect();
    assert!(
        phase1.len() >= 10,
        "a velocity command for (nearly) every cmd_vel: {} for 20{}",
        phase1.len(),
        context(&run, &log, &mut log_lines)
    );
    let mut worst_ns = i64::MIN;
    for r in &phase1 {
        let v = r["v_x"].as_f64().expect("v_x") as f32;
        let (_, valid_until, published) = *run
            .sent
            .iter()
            .find(|s| (s.0 - v).abs() < 1e-5)
            .unwrap_or_else(|| panic!("a velocity command follows a cmd_vel: {r}"));
        let end = mono(r, "end_mono_ns");
        worst_ns = worst_ns.max(end as i64 - valid_until as i64);
        assert!(
            end <= valid_until,
            "ends {} ns after valid_until: {r}",
            end - valid_until
        );
        assert!(mono(r, "mono_ns") >= published, "{r}");
        assert!(
            (r["v_rot"].as_f64().expect("v_rot") - 0.2).abs() < 1e-6,
            "{r}"
        );
        assert_eq!(r["status"], "STATUS_OK", "{r}");
    }
    println!(
        "spot: {} velocity commands for 20 cmd_vel; the latest end relative to its valid_until: \
         {:.1} ms",
        phase1.len(),
        worst_ns as f64 / 1e6
    );
    assert!(
        run.of("velocity")
            .all(|r| mono(r, "mono_ns") < last_valid || mono(r, "mono_ns") > t1_end),
        "no velocity command after the last cmd_vel expired"
    );
    assert!(
        run.of("stop").any(|r| mono(r, "mono_ns") >= last_valid),
        "a stop once the last command expired{}",
        context(&run, &log, &mut log_lines)
    );
    assert!(
        run.states
            .iter()
            .rev()
            .take(3)
            .all(|s| s.halted & COMMAND_EXPIRED != 0),
        "base/state: command expired"
    );
    let lease_ok = run.of("lease_acquire").filter(|r| r["ok"] == true).count();
    let retained = run
        .of("lease_retain")
        .filter(|r| r["status"] == "STATUS_OK")
        .count();
    let checkins = run
        .of("estop_checkin")
        .filter(|r| r["level"] == "ESTOP_LEVEL_NONE" && r["status"] == "STATUS_OK")
        .count();
    assert_eq!(lease_ok, 1, "the body lease acquired once");
    assert!(retained >= 4, "the lease retained: {retained}");
    assert!(
        checkins >= 2,
        "E-Stop check-ins allowing motion: {checkins}"
    );
    let mut last_odom = None;
    while let Ok(Some(o)) = odom.receive() {
        last_odom = Some(o);
    }
    let o = last_odom.expect("odom published");
    assert!(
        o.x > 0.5 && o.yaw > 0.2 && o.v.abs() < 1e-6,
        "odom: the robot drove forward and turned left, now stopped: {o:?}"
    );

    // 2. a status other than driving, and a non-finite command: no velocity command
    let t2 = ipc::monotonic_ns();
    drive(&mut run, &mut fake, 0.6, 0.0, 2, &mut |_| {});
    drive(&mut run, &mut fake, 0.6, f32::NAN, 0, &mut |_| {});
    idle(&mut run, &fake, 0.3);
    assert_eq!(
        run.of("velocity")
            .filter(|r| mono(r, "mono_ns") > t2)
            .count(),
        0,
        "blocked or non-finite commands move nothing"
    );

    // 3. the lease revoked (the tablet takes it): velocity commands stop, base/state says so;
    //    given back, the bridge acquires it again and drives
    let mut t_revoke = 0;
    drive(&mut run, &mut fake, 2.0, 0.3, 0, &mut |f| {
        t_revoke = ipc::monotonic_ns();
        f.fault("revoke_lease");
    });
    let t3 = ipc::monotonic_ns();
    let after: Vec<&Value> = run
        .of("velocity")
        .filter(|r| mono(r, "mono_ns") > t_revoke)
        .collect();
    assert!(
        after.iter().all(|r| r["lease"] != "STATUS_OK"),
        "nothing accepted once the lease was revoked"
    );
    assert!(
        after.len() <= 2,
        "at most the commands in flight after a revoked lease: {after:#?}"
    );
    assert!(
        run.states
            .iter()
            .rev()
            .take(5)
            .all(|s| s.halted & NO_LEASE != 0),
        "base/state: no lease{}",
        context(&run, &log, &mut log_lines)
    );
    fake.fault("release_lease");
    drive(&mut run, &mut fake, 2.0, 0.35, 0, &mut |_| {});
    assert!(
        run.of("lease_acquire").filter(|r| r["ok"] == true).count() == 2
            && run
                .of("velocity")
                .any(|r| mono(r, "mono_ns") > t3 && r["status"] == "STATUS_OK"),
        "the lease acquired again once free, and driving again{}",
        context(&run, &log, &mut log_lines)
    );

    // 4. the server dies: the bridge stays up and says link down; a new one is found again
    let _ = fake.proc.0.kill();
    let _ = fake.proc.0.wait();
    let t_kill = ipc::monotonic_ns();
    drive(&mut run, &mut fake, 1.0, 0.3, 0, &mut |_| {});
    assert!(
        wait_state(
            &mut run,
            &fake,
            &|s| s.link == 1 && s.halted & LINK_DOWN != 0,
            5
        ),
        "base/state: link down{}",
        context(&run, &log, &mut log_lines)
    );
    assert!(
        p.0.try_wait().expect("try_wait").is_none(),
        "the bridge survives the dead server"
    );
    let losses = run.states.last().map(|s| s.link_losses).unwrap_or(0);
    assert!(losses >= 1, "link losses counted: {losses}");
    let (fake2, _) = Fake::start(&py, &dir, port);
    fake = fake2;
    assert!(
        wait_state(&mut run, &fake, &ready_state, 20),
        "the bridge reconnects to the robot that is back{}",
        context(&run, &log, &mut log_lines)
    );
    let t4 = ipc::monotonic_ns();
    drive(&mut run, &mut fake, 1.0, 0.3, 0, &mut |_| {});
    assert!(
        run.of("velocity")
            .any(|r| mono(r, "mono_ns") > t4 && r["status"] == "STATUS_OK"),
        "driving again after the reconnection{}",
        context(&run, &log, &mut log_lines)
    );
    assert!(t_kill < t4);

    // 5. an E-Stop from another endpoint: velocity commands stop, base/state says so
    let mut t_estop = 0;
    drive(&mut run, &mut fake, 2.0, 0.3, 0, &mut |f| {
        t_estop = ipc::monotonic_ns();
        f.fault("estop");
    });
    // the bridge sees the E-Stop in the next robot state (50 ms); a command sent before is refused
    let late: Vec<&Value> = run
        .of("velocity")
        .filter(|r| {
            mono(r, "mono_ns") > t_estop
                && (r["status"] == "STATUS_OK" || mono(r, "mono_ns") > t_estop + 500_000_000)
        })
        .collect();
    assert!(
        late.is_empty(),
        "no velocity command once e-stopped: {late:#?}"
    );
    assert!(
        run.states
            .iter()
            .rev()
            .take(5)
            .all(|s| s.halted & ESTOP != 0 && s.halted & MOTORS_OFF != 0 && s.link == 0),
        "base/state: e-stopped, motors off{}",
        context(&run, &log, &mut log_lines)
    );

    assert!(
        p.0.try_wait().expect("try_wait").is_none(),
        "the bridge is still up"
    );
    let status = p.terminate(Duration::from_secs(10));
    assert!(
        status.is_some_and(|s| s.success()),
        "the bridge exits 0 on SIGTERM: {status:?}{}",
        context(&run, &log, &mut log_lines)
    );
    fake.fault("quit");
    log_lines.extend(log.try_iter());
    println!("spot: the bridge's log:\n{}", log_lines.join("\n"));
    let _ = std::fs::remove_dir_all(&dir);
    println!(
        "spot: scenario took {:.1} s",
        started.elapsed().as_secs_f64()
    );
}
