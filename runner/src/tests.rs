use super::*;
use mimnav_shared::topics::{cell_class, command_status};
use mimnav_sim::world::WorldFile;
use std::path::Path;

fn config() -> Config {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/mimnav.toml");
    Config::load(&path, &[]).expect("the bundled config loads")
}

/// Flat ground, the goal 8 m ahead; with `wall`, a wall across the way 3 m ahead.
fn scene(wall: bool) -> Scene {
    let mut text = String::from(
        "name = \"runner test\"\nstart = [0.0, 0.0, 0.0]\ngoal = [8.0, 0.0]\n\
         time_limit_s = 40.0\n[ground]\nreflectivity = 12\n",
    );
    if wall {
        text += "[[wall]]\nfrom = [3.0, -4.0]\nto = [3.0, 4.0]\nreflectivity = 60\n";
    }
    WorldFile::parse(&text, "runner test")
        .expect("the test world parses")
        .compile()
}

fn planner_run(config: &Config, scene: Scene, seed: u64) -> Lockstep {
    let mut run = Lockstep::new(config, scene, seed, Options::deployed(config)).expect("starts");
    let g = run.sim().scene().goal;
    run.set_goal(g[0], g[1], config.sim.goal_tolerance_m)
        .expect("a finite goal");
    run
}

/// Every command of the run, as the bits of (v, ω) and the status.
fn commands(run: &mut Lockstep, revolutions: usize) -> Vec<(u32, u32, u8)> {
    let mut out = Vec::new();
    while out.len() < revolutions {
        let Some(turn) = run.next_revolution().expect("no refused packet") else {
            break;
        };
        let (_, c) = turn.command.expect("the planner drives");
        out.push((c.v.to_bits(), c.omega.to_bits(), c.status));
    }
    out
}

#[test]
fn a_seed_gives_the_same_commands_every_time() {
    let config = config();
    let a = commands(&mut planner_run(&config, scene(true), 7), 25);
    let b = commands(&mut planner_run(&config, scene(true), 7), 25);
    assert_eq!(a.len(), 25);
    assert_eq!(a, b);
    assert!(a.iter().any(|c| c.2 == command_status::DRIVING));
}

#[test]
fn the_planner_drives_the_open_field_to_its_goal() {
    let config = config();
    let mut run = planner_run(&config, scene(false), 1);
    let mut driving = 0;
    while let Some(turn) = run.next_revolution().expect("no refused packet") {
        let (d, c) = turn.command.expect("the planner drives");
        assert!(c.v.is_finite() && c.omega.is_finite(), "{c:?}");
        assert!(c.valid_until_mono_ns > c.stamp_mono_ns);
        assert_eq!(
            d.source_seq, turn.points.seq,
            "the command names its revolution"
        );
        driving += usize::from(c.status == command_status::DRIVING);
    }
    assert_eq!(run.sim().outcome(), Outcome::GoalReached);
    assert!(driving > 10, "{driving} driving commands");
}

#[test]
fn without_a_goal_the_robot_stands() {
    let config = config();
    let mut run = Lockstep::new(&config, scene(false), 1, Options::deployed(&config)).unwrap();
    for _ in 0..10 {
        let turn = run.next_revolution().unwrap().expect("the episode goes on");
        let (_, c) = turn.command.expect("the planner answers every map");
        assert_eq!(
            (c.v, c.omega, c.status),
            (0.0, 0.0, command_status::NO_GOAL)
        );
    }
    assert_eq!(run.sim().path_length_m(), 0.0);
}

#[test]
fn a_wall_across_the_way_is_in_the_planners_map() {
    let config = config();
    for map in [
        MapSource::Intensity,
        MapSource::LaserScan,
        MapSource::Occupancy,
    ] {
        let options = Options {
            map,
            ..Options::deployed(&config)
        };
        let mut run = Lockstep::new(&config, scene(true), 3, options).unwrap();
        let g = run.sim().scene().goal;
        run.set_goal(g[0], g[1], 0.3).unwrap();
        for _ in 0..3 {
            run.next_revolution().unwrap().expect("the episode goes on");
        }
        let grid = config.map.grid();
        let (r, c) = grid.cell_of(2.9, 0.0).expect("3 m ahead is on the map");
        let near = (r.saturating_sub(2)..=r + 2)
            .flat_map(|r| (c.saturating_sub(2)..=c + 2).map(move |c| (r, c)))
            .any(|(r, c)| run.classes()[grid.index(r, c)] == cell_class::SOLID);
        assert!(near, "{map:?}: no solid cell at the wall");
    }
}

#[test]
fn an_external_drive_gets_no_command_and_the_classifier_sees_every_scan() {
    let config = config();
    let options = Options {
        map: MapSource::None,
        foliage: FoliageUse::Classify,
        inflation: None,
        drive: Drive::External,
    };
    let mut run = Lockstep::new(&config, scene(true), 1, options).unwrap();
    run.sim_mut().set_command(0.3, 0.0);
    for _ in 0..20 {
        let turn = run.next_revolution().unwrap().expect("the episode goes on");
        assert!(turn.command.is_none() && turn.mapped.is_none());
        let h = turn.foliage.expect("the classifier ran");
        assert_eq!(h.count as usize, run.scan().len());
        assert_eq!(run.verdict().len(), run.scan().len());
        assert!(!run.scan().is_empty());
    }
    assert!(
        run.sim().path_length_m() > 0.1,
        "the caller's command drove the base"
    );
}

#[test]
fn a_non_finite_goal_is_refused() {
    let config = config();
    let mut run = Lockstep::new(&config, scene(false), 1, Options::deployed(&config)).unwrap();
    assert!(matches!(
        run.set_goal(f64::NAN, 0.0, 0.3),
        Err(RunnerError::Refused(_))
    ));
}

#[test]
fn a_sensor_mounted_off_the_axis_yawed_and_tilted_still_finds_the_glass_and_the_goal() {
    // the simulator mounts its sensor as robot.mount says; the mapper and the classifier bring
    // its returns back to the robot's axis
    let mut config = config();
    config.robot.mount = mimnav_shared::pose::LidarMount {
        x_m: -0.3,
        y_m: 0.05,
        roll_deg: 1.0,
        pitch_deg: 3.0,
        yaw_deg: 25.0,
    };
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/worlds/scenario1_glass_wall.toml");
    let scene = WorldFile::load(&path).expect("the bundled world").compile();
    let mut run = planner_run(&config, scene, 2);
    let mut glass = 0;
    while run.next_revolution().expect("no refused packet").is_some() {
        glass = glass.max(
            run.classes()
                .iter()
                .filter(|&&c| c == cell_class::GLASS)
                .count(),
        );
    }
    assert_eq!(run.sim().outcome(), Outcome::GoalReached);
    assert!(glass > 10, "the glass wall is on the map ({glass} cells)");
}

/// Issue 23 item 3: with a NaN start the planner turned at −1.5 rad/s for the whole episode.
/// World files refuse a NaN start now; a scene built around the loader (start x, y or heading
/// NaN) still never drives: its odometry is refused and the run ends with the refusal, the base
/// never commanded.
#[test]
fn issue23_3_non_finite_values_accepted_a_nan_start_never_drives() {
    let config = config();
    for k in 0..3 {
        let mut w = WorldFile::parse(
            "name = \"n\"\nstart = [0.0, 0.0, 0.0]\ngoal = [8.0, 0.0]\ntime_limit_s = 40.0\n",
            "n",
        )
        .expect("parses");
        w.start[k] = f64::NAN;
        assert!(
            WorldFile::parse(
                &format!(
                    "name = \"n\"\nstart = [{:?}, {:?}, {:?}]\ngoal = [8.0, 0.0]\ntime_limit_s = 40.0\n",
                    w.start[0], w.start[1], w.start[2]
                )
                .replace("NaN", "nan"),
                "n"
            )
            .is_err(),
            "the loader refuses start[{k}] = nan"
        );
        let mut run =
            Lockstep::new(&config, w.compile(), 1, Options::deployed(&config)).expect("starts");
        run.set_goal(8.0, 0.0, 0.3).expect("a finite goal");
        match run.next_revolution() {
            Err(RunnerError::Refused(_)) => {}
            other => panic!(
                "start[{k}] = NaN: {:?}",
                other.map(|t| t.map(|t| t.command))
            ),
        }
    }
}
