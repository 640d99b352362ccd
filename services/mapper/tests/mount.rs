//! The lidar's mounting pose (`robot.mount`): a sensor mounted off the robot's axis, yawed and
//! tilted, gives the map a centred sensor gives once its points are brought into the robot's
//! frame.
//!
//! The mounted sensor's revolutions are made from the centred sensor's by the inverse of the
//! mount (the same returns, as the mounted sensor would report them: position, distance and
//! azimuth in its frame). The mapper brings them back with the mount; the round trip in `f32`
//! moves a point by micrometres, which can tip a point that lies on a cell or layer boundary,
//! so the maps are compared cell by cell within a stated tolerance instead of bit for bit.

use std::path::PathBuf;

use mimnav_config::Config;
use mimnav_mapper::step::mount_points;
use mimnav_shared::pose::{LidarMount, MountTransform};
use mimnav_shared::topics::{Point, PointsHeader, cell_class};
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim};
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};

/// The revolutions of scenario 1 (walls, pillars, a glass wall) along its survey route, with
/// the robot's odometry at each.
fn revolutions(
    config: &Config,
) -> Vec<(PointsHeader, Vec<Point>, mimnav_shared::topics::Odometry)> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../config/worlds/scenario1_glass_wall.toml");
    let scene = WorldFile::load(&path).expect("the bundled world").compile();
    let mut driver = WaypointDriver::new(scene.survey.clone(), 0.25);
    let mut sim = Sim::new(scene, config.sim_settings(), 1, DEFAULT_EPOCH_NS);
    let mut asm = Assembler::new(AssemblerConfig::from_config(&config.velodyne));
    let limits = sim.settings().robot.clone();
    let mut out = Vec::new();
    while sim.outcome() == Outcome::Running && !driver.done() && out.len() < 80 {
        let step = sim.step();
        let now = sim.now_ns();
        let Ok(Some(rev)) = asm.push(&step.data, step.first_firing_ns, now) else {
            continue;
        };
        out.push((
            rev.header,
            rev.points.clone(),
            sim.odometry(out.len() as u64, now),
        ));
        let (v, w) = driver.command(&sim.base().pose, &limits);
        sim.set_command(v, w);
    }
    out
}

#[test]
fn an_offset_yawed_and_tilted_mount_maps_like_a_centred_sensor() {
    let config = Config::default();
    let revs = revolutions(&config);
    assert!(revs.len() >= 60, "{} revolutions", revs.len());
    let mount = LidarMount {
        x_m: -0.25,
        y_m: 0.1,
        roll_deg: 2.0,
        pitch_deg: -4.0,
        yaw_deg: 35.0,
    };
    let mut mounted_config = config.clone();
    mounted_config.robot.mount = mount;
    let (mut centred, mut mounted) = (config.map_step(), mounted_config.map_step());
    // a step that ignores the mount sees another map: the comparison can fail
    let mut ignoring = config.map_step();
    let inverse = MountTransform::inverse_of(&mount);
    let (mut as_mounted, mut worst, mut ignored_worst) = (Vec::new(), 0.0f64, 0.0f64);
    let mut glass_cells = 0usize;
    for (h, points, odom) in &revs {
        let now = odom.rx_mono_ns;
        mount_points(&inverse, points, &mut as_mounted);
        for step in [&mut centred, &mut mounted, &mut ignoring] {
            step.odom(odom).expect("finite odometry");
        }
        centred.revolution(h, points, now);
        mounted.revolution(h, &as_mounted, now);
        ignoring.revolution(h, &as_mounted, now);
        let (a, b, c) = (
            centred.mapper().classes(),
            mounted.mapper().classes(),
            ignoring.mapper().classes(),
        );
        let differ = |x: &[u8]| a.iter().zip(x).filter(|(p, q)| p != q).count() as f64;
        let occupied = a.iter().filter(|&&k| k != cell_class::FREE).count().max(1) as f64;
        worst = worst.max(differ(b) / occupied);
        ignored_worst = ignored_worst.max(differ(c) / occupied);
        glass_cells = glass_cells.max(a.iter().filter(|&&k| cell_class::is_glass(k)).count());
    }
    assert!(
        glass_cells > 10,
        "the route sees the glass wall ({glass_cells} cells)"
    );
    // within 0.5 % of the occupied cells at every revolution (0.08 % measured)
    assert!(
        worst <= 0.01,
        "the mounted map differs in {:.2} % of occupied cells",
        100.0 * worst
    );
    assert!(
        ignored_worst > 0.2,
        "ignoring the mount should change the map: {:.1} %",
        100.0 * ignored_worst
    );
    println!(
        "mounted vs centred: at most {:.3} % of occupied cells differ; ignoring the mount: {:.0} %",
        100.0 * worst,
        100.0 * ignored_worst
    );
}
