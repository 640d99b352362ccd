//! The Python client (`clients/python`, on PyPI's `iceoryx2==0.10.0`) against the contract and
//! the real processes: its ctypes mirrors and QoS against `docs/topics.md`, a Python subscriber
//! behind the driver replaying a real capture, and a Python publisher read by the Rust side.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_config::Config;
use mimnav_shared::ipc::{self, Listening, PrivateDomain};

use crate::topics_doc::{Layout, documented_layouts, plain, table, tables, topics_md};
use crate::util::python_command as python;
use crate::util::{
    PointsTap, Proc, bin, config_args, lines_of, python_with_iceoryx2, reference_counts, root,
    shipped_config, velodyne_data, wait_until,
};

fn client_dir() -> PathBuf {
    root().join("clients/python")
}

/// `key=value` pairs of a line.
fn fields(line: &str) -> BTreeMap<&str, &str> {
    line.split_whitespace()
        .filter_map(|kv| kv.split_once('='))
        .collect()
}

fn num(m: &BTreeMap<&str, &str>, key: &str) -> u64 {
    m.get(key)
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no number `{key}` in {m:?}"))
}

/// Describes every ctypes mirror and the topic table of `mimnav_client` in lines the test parses.
const DUMP: &str = r#"
import ctypes
import mimnav_client as mc

RUST = {ctypes.c_uint8: "u8", ctypes.c_uint16: "u16", ctypes.c_uint32: "u32",
        ctypes.c_uint64: "u64", ctypes.c_float: "f32", ctypes.c_double: "f64"}

def rust(t):
    if issubclass(t, ctypes.Array):
        return f"[{rust(t._type_)}; {t._length_}]"
    if issubclass(t, mc._Named):
        return t.__name__
    return RUST.get(t, "?" + t.__name__)

def name(t):
    return RUST.get(t) or t.__name__

for cls in mc._Named.__subclasses__():
    used = sum(ctypes.sizeof(t) for _, t in cls._fields_)
    print("type", cls.__name__, cls.type_name(), ctypes.sizeof(cls), ctypes.alignment(cls),
          ctypes.sizeof(cls) - used)
    for f, t in cls._fields_:
        # `class` is a Python keyword: the mirrors call it `class_`
        print("field", cls.__name__, getattr(cls, f).offset, ctypes.sizeof(t), f.rstrip("_"), rust(t))
for t in mc.TOPICS.values():
    payload = f"[{name(t.payload)}]" if t.is_slice else name(t.payload)
    header = name(t.header) if t.header is not None else "—"
    kind = t.kind
    print("topic", t.name, payload, header, kind, t.buffer, t.borrowed)
print("limits", mc.MAX_PUBLISHERS, mc.MAX_SUBSCRIBERS, mc.MAX_NODES)
print("events", mc.EVENT_NEW_DATA, mc.EVENT_END_OF_STREAM)
print("domain", mc.DEFAULT_ROOT_PATH, mc.DEFAULT_PREFIX)
mc.check_layouts()
"#;

#[test]
fn python_client_mirrors_the_documented_contract() {
    let Some(py) = python_with_iceoryx2("python_client_mirrors_the_documented_contract") else {
        return;
    };
    let out = python(&py)
        .args(["-c", DUMP])
        .output()
        .expect("python runs");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "the dump ran: {}\n{stdout}{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<Vec<&str>> = stdout.lines().map(|l| l.split(' ').collect()).collect();
    let of = |kind: &'static str| rows.iter().filter(move |r| r[0] == kind);
    let n = |s: &str| -> usize { s.parse().unwrap_or_else(|_| panic!("not a number: {s}")) };

    // the ctypes layouts are the documented ones (which tests/topics_doc.rs ties to Rust)
    let mut py_layouts = BTreeMap::new();
    for r in of("type") {
        let fields = of("field")
            .filter(|f| f[1] == r[1])
            .map(|f| (n(f[2]), n(f[3]), f[4].to_string(), f[5..].join(" ")))
            .collect();
        let layout = Layout {
            type_name: r[2].to_string(),
            size: n(r[3]),
            align: n(r[4]),
            padding: n(r[5]),
            fields,
        };
        py_layouts.insert(r[1].to_string(), layout);
    }
    let md = topics_md();
    let doc = documented_layouts(&md);
    assert_eq!(
        py_layouts.keys().collect::<Vec<_>>(),
        doc.keys().collect::<Vec<_>>(),
        "mimnav_client mirrors every documented type"
    );
    for (name, l) in &doc {
        assert_eq!(&py_layouts[name], l, "mimnav_client's {name}");
    }

    // the topic table and the QoS
    let all = tables(&md);
    let (topics, qos, events) = (
        table(&all, "service name"),
        table(&all, "QoS"),
        table(&all, "event service"),
    );
    let py_topics: BTreeMap<&str, &Vec<&str>> = of("topic").map(|r| (r[1], r)).collect();
    assert_eq!(
        py_topics.len(),
        topics.rows.len(),
        "mimnav_client has every documented topic: {py_topics:?}"
    );
    for row in &topics.rows {
        let name = plain(&row[0]);
        let t = py_topics
            .get(name.as_str())
            .unwrap_or_else(|| panic!("mimnav_client has no topic {name}"));
        let kind = plain(&row[3]);
        let q = qos
            .rows
            .iter()
            .find(|r| plain(&r[0]) == kind)
            .expect("QoS row");
        assert_eq!(
            (t[2], t[3], t[4], n(t[5]), n(t[6])),
            (
                plain(&row[1]).as_str(),
                plain(&row[2]).as_str(),
                kind.as_str(),
                n(&q[3]),
                n(&q[4])
            ),
            "{name}: payload, header, QoS kind, subscriber buffer, borrowed samples"
        );
        let limits = of("limits").next().expect("limits");
        assert_eq!(
            (n(limits[1]), n(limits[2]), n(limits[3])),
            (n(&q[5]), n(&q[6]), n(&q[7])),
            "publishers, subscribers, nodes"
        );
        let e = &events.rows[0];
        assert_eq!(
            (n(limits[1]), n(limits[2]), n(limits[3])),
            (n(&e[1]), n(&e[2]), n(&e[3])),
            "the event service: notifiers, listeners, nodes"
        );
    }
    let ev = of("events").next().expect("events");
    assert_eq!(
        (n(ev[1]), n(ev[2])),
        (
            mimnav_shared::topics::EVENT_NEW_DATA,
            mimnav_shared::topics::EVENT_END_OF_STREAM
        ),
        "event ids"
    );
    let config = Config::load(&shipped_config(), &[]).expect("config/mimnav.toml");
    let d = of("domain").next().expect("domain");
    assert_eq!(
        (d[1].to_string(), d[2].to_string()),
        (
            config.iceoryx2.global.root_path().to_string(),
            config.iceoryx2.global.prefix.to_string()
        ),
        "mimnav_client's defaults are the shipped config's domain"
    );
}

/// The driver's own account of a run: `(seq, points)` per revolution from its debug lines, and
/// the totals of its closing line.
#[derive(Debug, Default)]
struct DriverReport {
    revolutions: Vec<(u64, u64)>,
    total_revolutions: u64,
    total_points: u64,
}

fn driver_report(lines: &[String]) -> DriverReport {
    let mut r = DriverReport::default();
    for l in lines {
        let f = fields(l);
        if l.contains("mimnav_velodyne::driver: revolution ") {
            r.revolutions.push((num(&f, "seq"), num(&f, "points")));
        } else if l.contains("replay finished") {
            r.total_revolutions = num(&f, "revolutions");
            r.total_points = num(&f, "points");
        }
    }
    r
}

#[test]
fn python_client_receives_every_revolution_the_driver_reports() {
    let test = "python_client_receives_every_revolution_the_driver_reports";
    let Some(data) = velodyne_data(test) else {
        return;
    };
    let Some(py) = python_with_iceoryx2(test) else {
        return;
    };
    let domain = PrivateDomain::new("e2e-py");
    let config = Config::load(&shipped_config(), &[]).expect("config/mimnav.toml");

    // the Python subscriber first: the topics keep no history
    let mut client = Proc::start(
        python(&py)
            .arg(client_dir().join("mimnav_points.py"))
            .arg("--root-path")
            .arg(domain.root_str())
            .args(["--prefix", &domain.prefix, "--timeout", "90"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped()),
    );
    let out = lines_of(client.0.stdout.take().expect("stdout"));
    let err = lines_of(client.0.stderr.take().expect("stderr"));
    let mut seen = Vec::new();
    assert!(
        wait_until(&out, |l| l == "READY", Duration::from_secs(30), &mut seen),
        "the Python client subscribed: {seen:#?} {:#?}",
        err.try_iter().collect::<Vec<_>>()
    );

    // half speed: a slow test machine's Python still keeps up with 5 revolutions a second, and a
    // slice topic's subscriber buffer holds only two
    let mut driver = Proc::start(
        Command::new(bin("mimnav-velodyne"))
            .args(config_args(&domain))
            .arg("--pcap")
            .arg(data.join("vlp16_dual_nebula.pcap"))
            .args(["--set", "velodyne.replay_speed=0.5"])
            .args(["--set", "velodyne.replay_linger_s=10"])
            .env("MIMNAV_LOG", "info,mimnav_velodyne::driver=debug")
            .stderr(Stdio::piped()),
    );
    let driver_err = lines_of(driver.0.stderr.take().expect("stderr"));
    let mut driver_lines = Vec::new();
    let until = Instant::now() + Duration::from_secs(60);
    let mut ended = false;
    while !ended && Instant::now() < until {
        let end = |l: &str| l == "END" || l == "TIMEOUT";
        ended = wait_until(&out, end, Duration::from_millis(200), &mut seen);
        driver_lines.extend(driver_err.try_iter());
    }
    // the driver logs its closing line before it sends the end of stream: it is in the pipe
    let finished = |l: &str| l.contains("replay finished");
    let driver_done = driver_lines.iter().any(|l| finished(l))
        || wait_until(
            &driver_err,
            finished,
            Duration::from_secs(5),
            &mut driver_lines,
        );
    let status = driver.terminate(Duration::from_secs(2));
    driver_lines.extend(driver_err.try_iter());
    let client_status = client.wait(Duration::from_secs(5));
    let py_err: Vec<String> = err.try_iter().collect();
    let context = format!(
        "\nPython stdout: {seen:#?}\nPython stderr: {py_err:#?}\ndriver: {driver_lines:#?}"
    );
    assert!(driver_done, "the driver finished the replay{context}");
    assert!(
        status.is_some_and(|s| s.success()),
        "the driver exits cleanly{context}"
    );
    assert!(
        seen.iter().any(|l| l == "END"),
        "the Python client heard the end of stream on both topics{context}"
    );
    assert!(
        client_status.is_some_and(|s| s.success()),
        "the Python client exits 0{context}"
    );

    // what the driver says it published: every revolution of the capture
    let report = driver_report(&driver_lines);
    let expected = reference_counts(&data, "vlp16_dual_nebula");
    let driver_counts: Vec<u64> = report.revolutions.iter().map(|r| r.1).collect();
    assert_eq!(
        driver_counts,
        expected.iter().map(|&n| u64::from(n)).collect::<Vec<_>>(),
        "the driver reports the reference revolutions{context}"
    );

    // what Python received, counted from the payload: the same revolutions, point for point
    let points: Vec<BTreeMap<&str, &str>> = seen
        .iter()
        .filter_map(|l| l.strip_prefix("points "))
        .map(fields)
        .collect();
    let got: Vec<(u64, u64)> = points
        .iter()
        .map(|p| (num(p, "seq"), num(p, "n")))
        .collect();
    assert_eq!(
        got, report.revolutions,
        "(seq, points) of every revolution as Python received it, against the driver's own \
         report{context}"
    );
    assert_eq!(
        (got.len() as u64, got.iter().map(|g| g.1).sum::<u64>()),
        (report.total_revolutions, report.total_points),
        "totals against the driver's closing line{context}"
    );
    for p in &points {
        let seq = num(p, "seq");
        assert_eq!(
            num(p, "n"),
            num(p, "point_count"),
            "rev {seq}: header and payload agree"
        );
        for k in ["strongest", "last", "both"] {
            assert_eq!(
                num(p, k),
                num(p, &format!("h_{k}")),
                "rev {seq}: {k} returns counted in the payload against the header"
            );
        }
        assert!(
            num(p, "max_ring") <= 15 && num(p, "max_laser") <= 15,
            "rev {seq}: {p:?}"
        );
        assert!(
            num(p, "min_distance_raw") > 0,
            "rev {seq}: no zero distance: {p:?}"
        );
        let err_mm: f64 = p["max_range_error_mm"].parse().expect("number");
        assert!(
            err_mm < 1.0,
            "rev {seq}: x, y, z read through ctypes agree with the raw distance: {p:?}"
        );
    }

    // the planar scan of every revolution, with its documented header
    let scans: Vec<BTreeMap<&str, &str>> = seen
        .iter()
        .filter_map(|l| l.strip_prefix("scan "))
        .map(fields)
        .collect();
    assert_eq!(
        scans.iter().map(|s| num(s, "seq")).collect::<Vec<_>>(),
        got.iter().map(|g| g.0).collect::<Vec<_>>(),
        "a scan per revolution{context}"
    );
    for s in &scans {
        assert_eq!(
            num(s, "n"),
            num(s, "count"),
            "scan {s:?}: header and payload agree"
        );
        assert!(num(s, "n") > 0, "scan {s:?}");
        assert_eq!(
            num(s, "laser"),
            u64::from(config.velodyne.scan_laser),
            "scan {s:?}"
        );
    }
}

/// Publishes a goal and a three-point revolution from Python, then waits for stdin to close.
const PUBLISH: &str = r#"
import sys
import mimnav_client as mc

node = mc.node("py-publisher", sys.argv[1], sys.argv[2])
goals = mc.Publisher(node, mc.GOAL)
points = mc.Publisher(node, mc.LIDAR_POINTS, max_elements=16)
goals.publish(mc.Goal(seq=7, stamp_mono_ns=123, x=1.5, y=-2.25, tolerance_m=0.3))
pts = [mc.Point(x=i + 0.5, y=-i, z=0.25 * i, time_offset_ns=1000 * i, distance_raw=500 + i,
                azimuth_cdeg=35999 - i, intensity=200 + i, laser_id=i, ring=15 - i,
                return_type=1 + i) for i in range(3)]
header = mc.PointsHeader(seq=42, stamp_ns=1 << 60, point_count=3, strongest_count=1,
                         last_count=1, both_count=1, return_mode=0x39, product=0x22, cut_reason=4)
points.publish(header=header, items=pts)
points.end_of_stream()
print("SENT", flush=True)
sys.stdin.read()
"#;

#[test]
fn python_client_publishes_what_the_rust_side_reads() {
    let Some(py) = python_with_iceoryx2("python_client_publishes_what_the_rust_side_reads") else {
        return;
    };
    let domain = PrivateDomain::new("e2e-pypub");
    let tap = PointsTap::open(&domain);
    let node = ipc::node(&domain.config(), "e2e-goals").expect("node");
    let goals = ipc::goal_subscriber(&node).expect("goal subscriber");

    // stdin piped: the script keeps its publishers until the test closes it
    let mut p = Proc(
        python(&py)
            .args(["-c", PUBLISH])
            .arg(domain.root_str())
            .arg(&domain.prefix)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("python starts"),
    );
    let stdin = p.0.stdin.take();
    let out = lines_of(p.0.stdout.take().expect("stdout"));
    let err = lines_of(p.0.stderr.take().expect("stderr"));
    let mut seen = Vec::new();
    assert!(
        wait_until(&out, |l| l == "SENT", Duration::from_secs(30), &mut seen),
        "the Python publisher ran: {seen:#?} {:#?}",
        err.try_iter().collect::<Vec<_>>()
    );

    let goal = goals.receive().expect("receive").expect("a goal");
    assert_eq!(
        (
            goal.seq,
            goal.stamp_mono_ns,
            goal.x,
            goal.y,
            goal.tolerance_m
        ),
        (7, 123, 1.5, -2.25, 0.3),
        "the goal, field for field"
    );
    let sample = tap.sub.receive().expect("receive").expect("a revolution");
    let h = *sample.user_header();
    assert_eq!(
        (
            h.seq,
            h.stamp_ns,
            h.point_count,
            h.strongest_count,
            h.last_count,
            h.both_count,
            h.return_mode,
            h.product,
            h.cut_reason
        ),
        (42, 1 << 60, 3, 1, 1, 1, 0x39, 0x22, 4),
        "the header, field for field"
    );
    assert_eq!(sample.payload().len(), 3, "three points");
    for (i, q) in sample.payload().iter().enumerate() {
        let i32 = i as u32;
        assert_eq!(
            (
                q.x,
                q.y,
                q.z,
                q.time_offset_ns,
                q.distance_raw,
                q.azimuth_cdeg,
                q.intensity,
                q.laser_id,
                q.ring,
                q.return_type
            ),
            (
                i as f32 + 0.5,
                -(i as f32),
                0.25 * i as f32,
                1000 * i32,
                500 + i as u16,
                35999 - i as u16,
                200 + i as u8,
                i as u8,
                15 - i as u8,
                1 + i as u8
            ),
            "point {i}, field for field"
        );
    }
    drop(sample);
    assert!(tap.sub.heard().end_of_stream, "the end of stream event");
    drop(stdin);
    let status = p.wait(Duration::from_secs(10));
    assert!(
        status.is_some_and(|s| s.success()),
        "the Python publisher exits 0"
    );
}
