use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::{VelocityCommand, command_status};

use crate::util::{PointsTap, Proc, bin, free_tcp_port, free_udp_port, root, stack_args};

#[test]
fn the_simulator_streams_to_the_driver_like_a_sensor() {
    let domain = PrivateDomain::new("e2e-sim");
    let (dp, pp) = (free_udp_port(), free_udp_port());
    let args = stack_args(&domain, dp, pp);
    let tap = PointsTap::open(&domain);
    let mut driver = Proc::start(
        Command::new(bin("mimnav-velodyne"))
            .args(&args)
            .env("MIMNAV_LOG", "info")
            .stderr(Stdio::piped()),
    );
    std::thread::sleep(Duration::from_millis(300));
    let world = root().join("config/worlds/one_wall.toml");
    let mut sim = Proc::start(
        Command::new(bin("mimnav-sim"))
            .args(&args)
            .arg("--world")
            .arg(&world)
            .args(["--seconds", "1.5"]),
    );
    let got = tap.collect(Duration::from_secs(20), |c| c.counts.len() >= 12);
    let status = sim
        .wait(Duration::from_secs(20))
        .expect("the simulator ends after 1.5 s");
    assert!(status.success(), "{status}");
    assert!(
        got.counts.len() >= 12,
        "revolutions at 10 Hz: {:?}",
        got.counts
    );
    for (h, n) in got.headers.iter().zip(&got.counts) {
        assert!((148..=153).contains(&h.packet_count), "{h:?}");
        assert!(*n > 10_000, "{n} points");
        assert_eq!(h.return_mode, 0x39, "dual return");
    }
    // the stamps are the simulated sensor's clock, in step with the host's
    let now = ipc::realtime_ns();
    let stamp = got.headers.last().expect("header").stamp_ns;
    assert!(
        now.abs_diff(stamp) < 10_000_000_000,
        "sensor time {stamp} vs host {now}"
    );
    let _ = driver.terminate(Duration::from_secs(1));
    let mut err = String::new();
    std::io::Read::read_to_string(&mut driver.0.stderr.take().expect("stderr"), &mut err)
        .expect("read");
    assert!(
        err.contains("faults: none"),
        "no decode fault on simulated packets: {err}"
    );
    assert!(
        err.contains("position packet: PPS Locked"),
        "position packets arrive: {err}"
    );
}

#[test]
fn lockstep_waits_for_the_stack_and_follows_its_commands() {
    let domain = PrivateDomain::new("e2e-lockstep");
    let (dp, pp) = (free_udp_port(), free_udp_port());
    let args = stack_args(&domain, dp, pp);
    // a stand-in planner: answers every revolution with 0.3 m/s straight ahead
    let node = ipc::node(&domain.config(), "fake-planner").expect("node");
    let points = ipc::points_subscriber(&node).expect("points");
    let cmd = ipc::cmd_vel_publisher(&node).expect("cmd_vel");
    let _driver = Proc::start(Command::new(bin("mimnav-velodyne")).args(&args));
    std::thread::sleep(Duration::from_millis(300));
    let world = root().join("config/worlds/open_field.toml");
    let mut sim = Proc::start(
        Command::new(bin("mimnav-sim"))
            .args(&args)
            .arg("--world")
            .arg(&world)
            .args(["--lockstep", "--seconds", "3", "--json"])
            .stdout(Stdio::piped()),
    );
    let until = Instant::now() + Duration::from_secs(60);
    let mut answered = 0u64;
    let status = loop {
        if let Some(s) = sim.0.try_wait().expect("wait") {
            break s;
        }
        assert!(Instant::now() < until, "lock-step run did not finish");
        points.heard_within(Duration::from_millis(20));
        while let Some(sample) = points.receive().expect("receive") {
            let h = *sample.user_header();
            let c = VelocityCommand {
                seq: answered,
                stamp_mono_ns: ipc::monotonic_ns(),
                source_stamp_ns: h.stamp_ns,
                source_seq: h.seq,
                valid_until_mono_ns: u64::MAX,
                v: 0.3,
                omega: 0.0,
                status: command_status::DRIVING,
                flags: 0,
                reserved: [0; 6],
            };
            cmd.publish(c).expect("publish");
            answered += 1;
        }
    };
    assert!(status.success(), "{status}");
    let mut out = String::new();
    std::io::Read::read_to_string(&mut sim.0.stdout.take().expect("stdout"), &mut out)
        .expect("read");
    let field = |k: &str| -> f64 {
        let at = out
            .find(&format!("\"{k}\":"))
            .unwrap_or_else(|| panic!("{k} in {out}"));
        out[at + k.len() + 3..]
            .split([',', '}'])
            .next()
            .expect("value")
            .parse()
            .expect("number")
    };
    assert_eq!(
        field("lockstep_timeouts"),
        0.0,
        "every revolution answered in time: {out}"
    );
    assert!(field("revolutions") >= 28.0, "{out}");
    // 3 s at up to 0.3 m/s after accelerating at 0.6 m/s², one revolution of command lag
    let x = field("x");
    assert!(
        (0.6..0.9).contains(&x),
        "the robot followed the commands: x = {x}: {out}"
    );
    assert!(answered >= 28, "{answered}");
}

/// Drives the SICK driver's session over `stream` until `want` scans came (or `within`
/// passed): the ranges straight ahead (bearing within ±0.5°) of each scan.
fn sick_scans(
    stream: &mut std::net::TcpStream,
    sick: &mimnav_sick::SickConfig,
    want: usize,
    within: Duration,
) -> Vec<Vec<f32>> {
    use mimnav_sick::session::{Event, Session};
    use std::io::{Read, Write};
    let t0 = Instant::now();
    let now = || t0.elapsed().as_nanos() as u64;
    let mut session = Session::new(sick.session());
    let mut out = Vec::new();
    session.begin(now(), &mut out);
    let (conv, mut returns, mut ahead) = (sick.converter(), Vec::new(), Vec::new());
    let mut buf = vec![0u8; 64 * 1024];
    stream
        .set_read_timeout(Some(Duration::from_millis(100)))
        .expect("timeout");
    while ahead.len() < want && t0.elapsed() < within {
        if !out.is_empty() {
            stream.write_all(&out).expect("write the requests");
            out.clear();
        }
        let n = match stream.read(&mut buf) {
            Ok(0) => panic!("the simulator closed the connection"),
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                continue;
            }
            Err(e) => panic!("read: {e}"),
        };
        session.receive(&buf[..n], now(), &mut out, |e| match e {
            Event::Scan(sd) => {
                conv.convert(sd, &mut returns).expect("converts");
                let r: Vec<f32> = (returns.iter())
                    .filter(|r| r.angle_rad.to_degrees().abs() <= 0.5)
                    .map(|r| r.range_m)
                    .collect();
                let g = sick.mode().expect("a mode");
                let spec = sick.model.spec();
                let count = ((spec.field_deg.1 - spec.field_deg.0) / g.1) as usize + 1;
                assert!(
                    returns.len().abs_diff(count) <= 1,
                    "{} returns",
                    returns.len()
                );
                ahead.push(r);
            }
            Event::Refused { request, why } => panic!("{request:?} refused: {why}"),
            Event::BadScan(e) => panic!("bad scan: {e}"),
            _ => {}
        });
    }
    ahead
}

#[test]
fn the_simulator_serves_a_sick_to_the_drivers_session_over_tcp() {
    // the simulated LMS1xx of sim.sick on a loopback port; the SICK driver's session (the
    // library mimnav-sick runs) logs in, configures the scan and streams over a real socket
    let domain = PrivateDomain::new("e2e-sick");
    let (dp, pp, port) = (free_udp_port(), free_udp_port(), free_tcp_port());
    let mut args = stack_args(&domain, dp, pp);
    for s in ["sim.sick=true".to_string(), format!("sim.sick_port={port}")] {
        args.extend(["--set".to_string(), s]);
    }
    let world = root().join("config/worlds/one_wall.toml");
    let mut sim = Proc::start(
        Command::new(bin("mimnav-sim"))
            .args(&args)
            .arg("--world")
            .arg(&world)
            .args(["--seconds", "8"]),
    );
    let connect = || {
        let until = Instant::now() + Duration::from_secs(10);
        loop {
            match std::net::TcpStream::connect(("127.0.0.1", port)) {
                Ok(s) => return s,
                Err(e) if Instant::now() < until => {
                    let _ = e;
                    std::thread::sleep(Duration::from_millis(50));
                }
                Err(e) => panic!("the simulated SICK does not listen on {port}: {e}"),
            }
        }
    };
    let sick = mimnav_sick::SickConfig::default();
    let mut first = connect();
    let scans = sick_scans(&mut first, &sick, 10, Duration::from_secs(6));
    assert!(scans.len() >= 10, "{} scans", scans.len());
    // the wall across the path 4 m ahead, straight ahead (bearing 0 in REP-103)
    for ahead in &scans {
        assert!(!ahead.is_empty());
        for r in ahead {
            assert!((r - 4.0).abs() < 0.08, "{r} m ahead, the wall is at 4 m");
        }
    }
    // a client that goes away mid-stream does not stop the simulator; the next one logs in
    // and streams afresh
    drop(first);
    std::thread::sleep(Duration::from_millis(200));
    let mut second = connect();
    let again = sick_scans(&mut second, &sick, 5, Duration::from_secs(5));
    assert!(
        again.len() >= 5,
        "{} scans on the second connection",
        again.len()
    );
    drop(second);
    let status = sim
        .wait(Duration::from_secs(20))
        .expect("the simulator ends after 8 s");
    assert!(status.success(), "{status}");
}

#[test]
fn a_sick_client_that_stops_reading_is_dropped_and_the_simulator_goes_on() {
    // an LMS5xx at 100 Hz with all its echoes in CoLa-A (about 0.65 MB/s): a client that logs
    // in, starts the stream and then takes nothing fills the socket's buffers; it is dropped
    // after sim.sick_stall_s, and the next client is served
    let domain = PrivateDomain::new("e2e-sick-stall");
    let (dp, pp, port) = (free_udp_port(), free_udp_port(), free_tcp_port());
    let mut args = stack_args(&domain, dp, pp);
    let sets = [
        "sick.model=\"lms5xx\"".to_string(),
        "sick.frequency_hz=100".into(),
        "sick.resolution_deg=0.6667".into(),
        "sick.protocol=\"cola_a\"".into(),
    ];
    for s in sets.iter().cloned().chain([
        "sim.sick=true".to_string(),
        format!("sim.sick_port={port}"),
        "sim.sick_stall_s=0.2".into(),
    ]) {
        args.extend(["--set".to_string(), s]);
    }
    let world = root().join("config/worlds/one_wall.toml");
    let mut sim = Proc::start(
        Command::new(bin("mimnav-sim"))
            .args(&args)
            .arg("--world")
            .arg(&world)
            .args(["--seconds", "24"])
            .env("MIMNAV_LOG", "info")
            .stderr(Stdio::piped()),
    );
    let config =
        mimnav_config::Config::load(&crate::util::shipped_config(), &sets).expect("config");
    let connect = || {
        let until = Instant::now() + Duration::from_secs(10);
        loop {
            match std::net::TcpStream::connect(("127.0.0.1", port)) {
                Ok(s) => return s,
                Err(_) if Instant::now() < until => std::thread::sleep(Duration::from_millis(50)),
                Err(e) => panic!("the simulated SICK does not listen on {port}: {e}"),
            }
        }
    };
    let mut stalled = small_window_client(port);
    assert!(!sick_scans(&mut stalled, &config.sick, 1, Duration::from_secs(5)).is_empty());
    // take nothing for a while (the simulator's kernel buffer grows to a few MB on loopback:
    // about 6 s of this stream), then drain: the connection must end (dropped), not stream on
    std::thread::sleep(Duration::from_secs(10));
    let mut buf = vec![0u8; 1 << 16];
    let drain_until = Instant::now() + Duration::from_secs(3);
    let (mut ended, mut drained) = (false, 0usize);
    while Instant::now() < drain_until {
        match std::io::Read::read(&mut stalled, &mut buf) {
            Ok(0) => {
                ended = true;
                break;
            }
            Ok(n) => drained += n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(_) => {
                ended = true;
                break;
            }
        }
    }
    if !ended {
        drop(stalled);
        let _ = sim.terminate(Duration::from_secs(5));
        let mut err = String::new();
        let _ = std::io::Read::read_to_string(&mut sim.0.stderr.take().expect("stderr"), &mut err);
        panic!("the stalled client is still served ({drained} bytes drained): {err}");
    }
    let mut next = connect();
    let scans = sick_scans(&mut next, &config.sick, 5, Duration::from_secs(5));
    assert!(
        scans.len() >= 5,
        "{} scans for the next client",
        scans.len()
    );
    drop(next);
    let status = sim
        .wait(Duration::from_secs(30))
        .expect("the simulator ends");
    assert!(status.success(), "{status}");
    let mut err = String::new();
    std::io::Read::read_to_string(&mut sim.0.stderr.take().expect("stderr"), &mut err)
        .expect("read");
    assert!(
        err.contains("took nothing") || err.contains("untaken"),
        "the drop is logged: {err}"
    );
}

/// A loopback TCP client whose receive buffer is 4 KiB, set before connecting (so its window
/// stays small and a sender's buffers fill within a second when it stops reading).
fn small_window_client(port: u16) -> std::net::TcpStream {
    use std::os::fd::FromRawFd;
    let until = Instant::now() + Duration::from_secs(10);
    loop {
        // SAFETY: socket(2), setsockopt(2), connect(2) and close(2) on a descriptor this
        // function owns; the address and option are valid for the sizes given.
        let fd = unsafe { libc::socket(libc::AF_INET, libc::SOCK_STREAM, 0) };
        assert!(fd >= 0, "socket");
        let size: libc::c_int = 4096;
        let ok = unsafe {
            libc::setsockopt(
                fd,
                libc::SOL_SOCKET,
                libc::SO_RCVBUF,
                (&size as *const libc::c_int).cast(),
                std::mem::size_of::<libc::c_int>() as libc::socklen_t,
            )
        };
        assert_eq!(ok, 0, "SO_RCVBUF");
        let addr = libc::sockaddr_in {
            sin_family: libc::AF_INET as libc::sa_family_t,
            sin_port: port.to_be(),
            sin_addr: libc::in_addr {
                s_addr: u32::from(std::net::Ipv4Addr::LOCALHOST).to_be(),
            },
            sin_zero: [0; 8],
        };
        let r = unsafe {
            libc::connect(
                fd,
                (&addr as *const libc::sockaddr_in).cast(),
                std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t,
            )
        };
        if r == 0 {
            // SAFETY: a connected stream socket this function owns
            return unsafe { std::net::TcpStream::from_raw_fd(fd) };
        }
        unsafe { libc::close(fd) };
        assert!(
            Instant::now() < until,
            "the simulated SICK does not listen on {port}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}
