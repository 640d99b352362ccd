use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::grid::GridSpec;
use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::{cell_class, map_status};

use crate::util::{Proc, bin, config_args, free_udp_port, reference_counts, root, velodyne_data};

#[test]
fn the_mapper_maps_every_revolution_of_the_real_capture() {
    let Some(data) = velodyne_data("the_mapper_maps_every_revolution") else {
        return;
    };
    let revolutions = reference_counts(&data, "vlp16_dual_nebula").len();
    let domain = PrivateDomain::new("e2e-mapper");
    let args = config_args(&domain);
    let node = ipc::node(&domain.config(), "e2e-map-tap").expect("node");
    let plan = ipc::plan_subscriber(&node).expect("plan");
    let mut mapper = Proc::start(
        Command::new(bin("mimnav-mapper"))
            .args(&args)
            .args(["--set", "robot.profile=\"spot\""])
            .stderr(Stdio::piped()),
    );
    std::thread::sleep(Duration::from_millis(300));
    let mut driver = Proc::start(
        Command::new(bin("mimnav-velodyne"))
            .args(&args)
            .arg("--pcap")
            .arg(data.join("vlp16_dual_nebula.pcap"))
            .args(["--set", "velodyne.replay_linger_s=3"]),
    );
    let mut maps = Vec::new();
    let until = Instant::now() + Duration::from_secs(20);
    while maps.len() < revolutions && Instant::now() < until {
        plan.heard_within(Duration::from_millis(50));
        while let Some(s) = plan.receive().expect("receive") {
            let classes: Vec<u8> = s.payload().iter().map(|c| c.class).collect();
            maps.push((*s.user_header(), classes));
        }
    }
    let _ = driver.terminate(Duration::from_secs(1));
    let status = mapper
        .terminate(Duration::from_secs(1))
        .expect("the mapper stops within 1 s of SIGTERM");
    assert!(status.success(), "{status}");
    assert_eq!(maps.len(), revolutions, "one map per revolution");
    for (k, (h, classes)) in maps.iter().enumerate() {
        assert_eq!(h.source_seq, k as u64, "each map names its revolution");
        assert_ne!(
            h.status & map_status::ODOM_MISSING,
            0,
            "no odometry in a replay: the status says so"
        );
        assert_eq!(classes.len(), 200 * 200);
        let count = |c| classes.iter().filter(|&&x| x == c).count();
        assert!(
            count(cell_class::SOLID) > 300,
            "a room has walls: {}",
            count(cell_class::SOLID)
        );
        assert!(
            count(cell_class::FREE) > 10_000,
            "and free floor: {}",
            count(cell_class::FREE)
        );
    }
    let mut err = String::new();
    std::io::Read::read_to_string(&mut mapper.0.stderr.take().expect("stderr"), &mut err)
        .expect("read");
    assert!(
        !err.contains("receive_failed") && !err.contains("publish_failed"),
        "{err}"
    );
}

#[test]
fn simulator_driver_and_mapper_put_a_wall_where_it_stands() {
    let domain = PrivateDomain::new("e2e-sim-map");
    let (dp, pp) = (free_udp_port(), free_udp_port());
    let mut args = config_args(&domain);
    for s in [
        "velodyne.bind_address=\"127.0.0.1\"".to_string(),
        format!("velodyne.data_port={dp}"),
        format!("velodyne.position_port={pp}"),
    ] {
        args.extend(["--set".into(), s]);
    }
    let node = ipc::node(&domain.config(), "e2e-map-tap").expect("node");
    let plan = ipc::plan_subscriber(&node).expect("plan");
    let _mapper = Proc::start(Command::new(bin("mimnav-mapper")).args(&args));
    let _driver = Proc::start(Command::new(bin("mimnav-velodyne")).args(&args));
    std::thread::sleep(Duration::from_millis(400));
    let mut sim = Proc::start(
        Command::new(bin("mimnav-sim"))
            .args(&args)
            .arg("--world")
            .arg(root().join("config/worlds/one_wall.toml"))
            .args(["--seconds", "1.5"]),
    );
    let mut last = None;
    let until = Instant::now() + Duration::from_secs(20);
    while Instant::now() < until {
        plan.heard_within(Duration::from_millis(50));
        while let Some(s) = plan.receive().expect("receive") {
            last = Some((
                *s.user_header(),
                s.payload().iter().map(|c| c.class).collect::<Vec<u8>>(),
            ));
        }
        if sim.0.try_wait().expect("wait").is_some() && last.is_some() {
            break;
        }
    }
    let (h, classes) = last.expect("maps arrive");
    assert_eq!(h.status, 0, "odometry from the simulator is fresh");
    let grid = GridSpec {
        cells: h.cells as usize,
        cell_m: h.cell_m,
    };
    let at = |x: f32, y: f32| {
        let (r, c) = grid.cell_of(x, y).expect("inside");
        // the wall is thin: look one cell either side along x
        (r.saturating_sub(1)..=r + 1)
            .map(|rr| classes[grid.index(rr, c)])
            .collect::<Vec<u8>>()
    };
    for y in [-2.0f32, -1.0, 0.0, 1.0, 2.0] {
        assert!(
            at(4.0, y).contains(&cell_class::SOLID),
            "the wall 4 m ahead at y = {y}: {:?}",
            at(4.0, y)
        );
    }
    assert_eq!(
        at(2.0, 0.0),
        vec![cell_class::FREE; 3],
        "free between the robot and the wall"
    );
}
