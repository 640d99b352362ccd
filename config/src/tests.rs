//! The config file as a whole: parsing, overrides, profiles, rules between sections, and the
//! shipped file holding every default.

use std::path::{Path, PathBuf};

use mimnav_shared::config::{
    Allowed, ConfigError, DEFAULT_IOX2_PREFIX, DEFAULT_IOX2_ROOT, ParamError, RobotProfile,
};
use mimnav_velodyne::config::VelodyneConfig;

use super::*;

fn parse(text: &str) -> Result<Config, ConfigError> {
    Config::from_toml(text, Path::new("test.toml"), &[])
}

#[test]
fn empty_file_gives_the_documented_defaults() {
    let c = parse("").expect("defaults");
    assert_eq!(c.velodyne, VelodyneConfig::default());
    assert_eq!(c.robot, RobotProfile::default());
    assert_eq!(c.iceoryx2.global.prefix.to_string(), DEFAULT_IOX2_PREFIX);
    assert_eq!(c.iceoryx2.global.root_path().to_string(), DEFAULT_IOX2_ROOT);
}

#[test]
fn map_age_limit_must_cover_a_revolution() {
    let e = parse("[velodyne]\nrpm = 300\n").expect_err("0.15 s < 1.2 × 0.2 s");
    let s = e.to_string();
    assert!(s.contains("planner.map_max_age_s = 0.15"), "{s}");
    assert!(s.contains("velodyne.rpm = 300"), "{s}");
    parse("[velodyne]\nrpm = 300\n[planner]\nmap_max_age_s = 0.25\n").expect("long enough");
}

#[test]
fn unknown_key_names_file_line_and_key() {
    let e = parse("[velodyne]\nrmp = 600\n").expect_err("unknown key");
    let s = e.to_string();
    assert!(s.starts_with("test.toml: "), "{s}");
    assert!(s.contains("rmp"), "{s}");
    assert!(s.contains("line 2"), "{s}");
}

#[test]
fn out_of_range_names_key_and_range() {
    let e = parse("[velodyne]\nrpm = 50\n").expect_err("range");
    assert!(
        matches!(
            e.invalid.as_ref().and_then(|i| i.get("velodyne.rpm")),
            Some(ParamError::OutOfRange { value, .. }) if *value == 50.0
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "test.toml: velodyne.rpm = 50 is out of range: allowed 300 to 1200"
    );
    let e = parse("[velodyne]\ninput = \"pcap\"\n").expect_err("pcap without file");
    assert!(e.to_string().contains("velodyne.pcap"), "{e}");
}

#[test]
fn a_section_checked_alone_gives_typed_errors() {
    let v = VelodyneConfig {
        rpm: 50.0,
        ..VelodyneConfig::default()
    };
    let e = v.validate().expect_err("rpm");
    assert_eq!(
        e.get("velodyne.rpm"),
        Some(&ParamError::OutOfRange {
            key: "velodyne.rpm".into(),
            value: 50.0,
            allowed: Allowed::closed(300.0, 1200.0),
        })
    );
    assert_eq!(Config::default().validate(), Ok(()));
}

#[test]
fn surface_cue_needs_no_more_neighbours_than_its_window_holds() {
    let e = parse("[mapper]\nsurface_window = 3\nsurface_neighbours = 7\n").expect_err("7 of 6");
    assert_eq!(
        e.to_string(),
        "test.toml: mapper.surface_neighbours = 7 must be at most 2 × mapper.surface_window = 6"
    );
    assert!(parse("[mapper]\nsurface_window = 3\nsurface_neighbours = 6\n").is_ok());
    assert!(parse("[mapper]\nsurface_min_returns = 0\nsurface_memory_s = 0\n").is_ok());
}

#[test]
fn wrong_type_is_refused() {
    let e = parse("[velodyne]\ndata_port = \"x\"\n").expect_err("type");
    assert!(
        e.to_string().contains("data_port") || e.to_string().contains("line 2"),
        "{e}"
    );
    let e = parse("[velodyne]\ndata_port = 70000\n").expect_err("u16");
    assert!(e.to_string().contains("line 2"), "{e}");
}

#[test]
fn iceoryx2_table_is_passed_and_checked() {
    let c = parse("[iceoryx2.global]\nprefix = \"abc_\"\n[iceoryx2.defaults.publish-subscribe]\nmax-subscribers = 3\n")
        .expect("iceoryx2 table");
    assert_eq!(c.iceoryx2.global.prefix.to_string(), "abc_");
    assert_eq!(c.iceoryx2.defaults.publish_subscribe.max_subscribers, 3);
    let e = parse("[iceoryx2.global]\nprefx = \"abc_\"\n").expect_err("unknown iceoryx2 key");
    assert!(e.to_string().contains("iceoryx2.global.prefx"), "{e}");
}

#[test]
fn set_overrides_a_key() {
    let c = Config::from_toml(
        "[velodyne]\nrpm = 600\n",
        Path::new("t.toml"),
        &[
            "velodyne.rpm=900".into(),
            "velodyne.pcap=/data/x.pcap".into(),
        ],
    )
    .expect("override");
    assert_eq!(c.velodyne.rpm, 900.0);
    assert_eq!(c.velodyne.pcap, Some(PathBuf::from("/data/x.pcap")));
    let e = Config::from_toml("", Path::new("t.toml"), &["velodyne.rpm".into()]).expect_err("no =");
    assert!(e.to_string().contains("KEY=VALUE"), "{e}");
    let e = Config::from_toml("", Path::new("t.toml"), &["velodyne.nope=1".into()])
        .expect_err("unknown");
    assert!(e.to_string().contains("nope"), "{e}");
}

#[test]
fn robot_profile_is_loaded_and_overridden() {
    let dir = std::env::temp_dir().join(format!("mimnav-config-test-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("robots")).expect("dir");
    std::fs::write(
        dir.join("robots/bigbot.toml"),
        "name = \"bigbot\"\nradius_m = 0.6\nsensor_height_m = 0.7\n",
    )
    .expect("write");
    let path = dir.join("mimnav.toml");
    let c = Config::from_toml(
        "[robot]\nprofile = \"bigbot\"\nmax_linear_mps = 0.3\n",
        &path,
        &[],
    )
    .expect("profile");
    assert_eq!(c.robot.name, "bigbot");
    assert_eq!(c.robot.radius_m, 0.6);
    assert_eq!(c.robot.max_linear_mps, 0.3);
    let e = Config::from_toml("[robot]\nprofile = \"nobot\"\n", &path, &[])
        .expect_err("missing profile");
    assert!(e.to_string().contains("nobot.toml"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `config/mimnav.toml` documents every key at its default: keep it true.
#[test]
fn shipped_config_holds_the_defaults() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("mimnav.toml");
    let c = Config::load(&path, &[]).expect("shipped config loads");
    let d = Config::default();
    assert_eq!(c.velodyne, d.velodyne);
    assert_eq!(c.robot, d.robot);
    assert_eq!(c.log, d.log);
    assert_eq!(c.iceoryx2, d.iceoryx2);
    assert_eq!(c.map, d.map);
    assert_eq!(c.sim, d.sim);
    assert_eq!(c.mapper, d.mapper);
    assert_eq!(c.planner, d.planner);
    assert_eq!(c.foliage, d.foliage);
    assert_eq!(c.latency, d.latency);
    assert_eq!(c.zenoh, d.zenoh);
    assert_eq!(c.sick, d.sick);
    assert_eq!(c.kobuki, d.kobuki);
    for profile in ["spot", "turtlebot2"] {
        let c = Config::load(&path, &[format!("robot.profile=\"{profile}\"")]).expect("profile");
        assert_eq!(c.robot.name, profile);
    }
}

/// Issue 23 item 3: TOML reads `nan` and `inf`, and a key with no range of its own (a mapper
/// layer's bounds) let them through. Every non-finite number in the file, a `--set` or a robot
/// profile is refused, naming the key and where it was written.
#[test]
fn issue23_3_non_finite_values_accepted_in_config_are_refused() {
    for (text, key) in [
        ("[velodyne]\nrpm = nan\n", "velodyne.rpm"),
        ("[sim]\nrange_noise_m = inf\n", "sim.range_noise_m"),
        ("[planner]\ngoal_weight = -inf\n", "planner.goal_weight"),
        ("[foliage]\nk1 = nan\n", "foliage.k1"),
        ("[map]\ncell_m = nan\n", "map.cell_m"),
        ("[robot]\nmax_linear_mps = inf\n", "robot.max_linear_mps"),
        (
            "[[mapper.layer]]\nname = \"below\"\nunit = \"m\"\nlow = -inf\nhigh = 0.0\n",
            "mapper.layer[0].low",
        ),
    ] {
        let e = parse(text).expect_err(key);
        let invalid = e.invalid.as_ref().unwrap_or_else(|| panic!("typed: {e}"));
        assert!(invalid.get(key).is_some(), "{key} not named: {e}");
        assert!(e.to_string().starts_with("test.toml: "), "{e}");
    }
    let e = Config::from_toml(
        "",
        Path::new("test.toml"),
        &["sim.goal_tolerance_m=nan".into()],
    )
    .expect_err("--set nan");
    assert!(e.to_string().contains("sim.goal_tolerance_m = NaN"), "{e}");
    assert!(e.source_name.contains("--set"), "{e}");
    // a robot profile file: named where it was written
    let dir = std::env::temp_dir().join(format!("mimnav-config-nan-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("robots")).expect("dir");
    std::fs::write(
        dir.join("robots/nanbot.toml"),
        "name = \"nanbot\"\nradius_m = 0.3\nsensor_height_m = nan\n",
    )
    .expect("write");
    let e = Config::from_toml(
        "[robot]\nprofile = \"nanbot\"\n",
        &dir.join("mimnav.toml"),
        &[],
    )
    .expect_err("nan in the profile");
    std::fs::remove_dir_all(&dir).ok();
    assert!(e.source_name.ends_with("nanbot.toml"), "{e}");
    assert!(e.to_string().contains("robot.sensor_height_m = NaN"), "{e}");
    // the library's own validate() refuses a non-finite layer bound handed to it directly
    let mapper = mimnav_mapper::config::MapperConfig {
        layers: vec![mimnav_mapper::config::LayerConfig {
            name: "below".into(),
            unit: mimnav_mapper::config::LayerUnit::M,
            low: f64::NEG_INFINITY,
            high: 0.0,
        }],
        ..Default::default()
    };
    let e = mapper.validate().expect_err("-inf low");
    assert!(e.get("mapper.layer[0].low").is_some(), "{e}");
}

/// Issue 23 item 2: a config file is read whole, so its size is bounded before reading
/// (`--config /dev/zero` never ended).
#[test]
fn issue23_2_an_oversized_config_file_is_refused_before_reading_it_whole() {
    let e = Config::load(Path::new("/dev/zero"), &[]).expect_err("endless");
    assert_eq!(e.source_name, "/dev/zero");
    assert!(e.message.contains("longer than 1048576 bytes"), "{e}");
}

#[test]
fn a_sicks_window_is_at_least_its_step_and_the_velodynes_is_as_written() {
    // issue 26: a window narrower than the scan's step leaves empty windows between returns
    let vlp = parse("").expect("defaults");
    assert_eq!(vlp.foliage_params(), vlp.foliage);
    let lms = parse("[foliage]\nsource = \"sick\"\n").expect("valid");
    assert_eq!(
        lms.foliage_params().window_rad,
        lms.foliage.window_rad,
        "0.4° ≥ 0.25°"
    );
    let tim = parse("[foliage]\nsource = \"sick\"\n[sick]\nmodel = \"tim5xx\"\n").expect("valid");
    assert!((tim.foliage_params().window_rad - 1f32.to_radians()).abs() < 1e-6);
    let wide =
        parse("[foliage]\nsource = \"sick\"\nwindow_deg = 1.5\n[sick]\nmodel = \"tim5xx\"\n")
            .expect("valid");
    assert!((wide.foliage_params().window_rad - 1.5f32.to_radians()).abs() < 1e-6);
    tim.scan_step().expect("a step");
}
