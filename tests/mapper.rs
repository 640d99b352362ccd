use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use mimnav_shared::grid::GridSpec;
use mimnav_shared::ipc::{self, Listening, PrivateDomain};
use mimnav_shared::topics::{Point, cell_class, map_status};

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
    let (slices, points) = (
        ipc::slices_subscriber(&node).expect("slices"),
        ipc::points_subscriber(&node).expect("points"),
    );
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
    let (mut maps, mut whole, mut sliced) = (Vec::new(), Vec::new(), Vec::new());
    let mut building: Vec<Point> = Vec::new();
    let until = Instant::now() + Duration::from_secs(20);
    // the mapper maps a revolution from its last slice before the driver sends it whole: the
    // whole one may still be on its way when the last map is in
    while (maps.len() < revolutions || whole.len() < revolutions) && Instant::now() < until {
        plan.heard_within(Duration::from_millis(20));
        while let Some(s) = plan.receive().expect("receive") {
            let classes: Vec<u8> = s.payload().iter().map(|c| c.class).collect();
            maps.push((*s.user_header(), classes));
        }
        // the slices put together, revolution by revolution, and the revolutions whole
        while let Some(s) = slices.receive().expect("receive") {
            let h = *s.user_header();
            assert_eq!(h.first_point as usize, building.len(), "slice {h:?}");
            building.extend_from_slice(s.payload());
            if h.last != 0 {
                sliced.push((h.revolution, std::mem::take(&mut building)));
            }
        }
        while let Some(s) = points.receive().expect("receive") {
            whole.push((*s.user_header(), s.payload().to_vec()));
        }
    }
    let _ = driver.terminate(Duration::from_secs(1));
    let status = mapper
        .terminate(Duration::from_secs(1))
        .expect("the mapper stops within 1 s of SIGTERM");
    assert!(status.success(), "{status}");
    assert_eq!(maps.len(), revolutions, "one map per revolution");
    // issue 27: the driver handed each revolution out in slices as it arrived, and the mapper
    // mapped every one from them
    assert_eq!(sliced.len(), whole.len(), "every revolution in slices");
    for ((hs, ps), (hw, pw)) in sliced.iter().zip(&whole) {
        assert_eq!(hs, hw, "the last slice carries the revolution's header");
        assert!(ps == pw, "revolution {}: its slices put together", hw.seq);
    }
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
    let stopped = err
        .lines()
        .find(|l| l.contains("mapper stopped"))
        .unwrap_or_else(|| panic!("the closing line: {err}"));
    assert!(
        stopped.contains(&format!("from_slices={revolutions}"))
            && stopped.contains("broken_slices=0"),
        "every map from its slices: {stopped}"
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

/// Issue 25 item 4: `mimnav snapshot` writes the map with a legend panel, a scale bar, the goal
/// and the robot's body (Spot's rectangle), decoded here with the png crate.
#[test]
fn a_snapshot_has_its_legend_scale_goal_and_robot() {
    let domain = PrivateDomain::new("e2e-snapshot");
    let args = config_args(&domain);
    let spot = ["--set", "robot.profile=\"spot\""];
    let mut mapper = Proc::start(
        Command::new(bin("mimnav-mapper"))
            .args(&args)
            .args(spot)
            .stderr(Stdio::null()),
    );
    std::thread::sleep(Duration::from_millis(300));
    let mut driver = Proc::start(
        Command::new(bin("mimnav-velodyne"))
            .args(&args)
            .arg("--pcap")
            .arg(root().join("captures/scenario2_curtain_door.pcap"))
            .args(["--set", "velodyne.replay_loop=true"])
            .stderr(Stdio::null()),
    );
    let file = crate::util::TempFile(
        std::env::temp_dir().join(format!("mimnav-snapshot-{}.png", std::process::id())),
    );
    let out = Command::new(bin("mimnav"))
        .args(&args)
        .args(spot)
        .args(["snapshot", "--goal", "3", "-1", "--out"])
        .arg(&file.0)
        .output()
        .expect("run mimnav snapshot");
    let _ = driver.terminate(Duration::from_secs(1));
    let _ = mapper.terminate(Duration::from_secs(1));
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(
        std::fs::File::open(&file.0).expect("the PNG"),
    ));
    let mut reader = decoder.read_info().expect("a PNG");
    let mut rgb = vec![0; reader.output_buffer_size().expect("size")];
    let info = reader.next_frame(&mut rgb).expect("its pixels");
    // the 600 px map (200 cells of 3 px) and the 200 px legend on its right
    assert_eq!((info.width, info.height), (800, 600));
    let at = |x: u32, y: u32| {
        let o = ((y * info.width + x) * 3) as usize;
        [rgb[o], rgb[o + 1], rgb[o + 2]]
    };
    let count = |xs: std::ops::Range<u32>, c: [u8; 3]| {
        xs.flat_map(|x| (0..info.height).map(move |y| (x, y)))
            .filter(|&(x, y)| at(x, y) == c)
            .count()
    };
    let (robot, goal, ink) = ([255, 105, 180], [40, 110, 255], [235, 235, 235]);
    // the goal 3 m ahead, 1 m right of where the map was made (the robot stands at the origin)
    assert!(count(0..600, goal) > 20, "the goal's disc on the map");
    assert!(count(600..800, goal) > 50, "and its swatch in the legend");
    assert!(count(0..600, robot) > 100, "Spot's 1.1 × 0.5 m outline");
    // the labels and a 2 m scale bar (0.05 m cells: 60 px a metre) in ink
    assert!(count(600..800, ink) > 1000, "the legend's text");
    let longest = (0..info.height)
        .map(|y| (600..800).filter(|&x| at(x, y) == ink).count())
        .max()
        .unwrap_or(0);
    assert_eq!(longest, 120, "the scale bar: 2 m at 60 px a metre");
}
