//! Issue 23: worlds that loaded although the simulator could not use them. Each test is named
//! after the defect it keeps fixed.

use mimnav_sim::blades::{MAX_FIELD_BLADES, MAX_FIELD_CELLS, field_size};
use mimnav_sim::world::{MAX_WORLD_FILE_BYTES, WORLD_EXTENT_M, WorldFile};
use proptest::prelude::*;

const HEAD: &str =
    "name = \"w\"\nstart = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\ntime_limit_s = 10.0\n";

/// Issue 23 item 2: grass 500 × 500 m at density 500 (each value within its own range) asked
/// `BladeField::new` for 110 GB and aborted `mimnav sim`. The world is refused at load, naming
/// the file, the key, the value and the limit, before anything is allocated.
#[test]
fn issue23_2_a_valid_world_aborts_the_simulator_huge_grass_is_refused_at_load() {
    let text =
        format!("{HEAD}[[grass]]\ncenter = [0.0, 0.0]\nsize = [500.0, 500.0]\ndensity = 500.0\n");
    let e = WorldFile::parse(&text, "huge_grass.toml").expect_err("refused");
    let shown = e.to_string();
    assert!(shown.starts_with("huge_grass.toml: "), "{shown}");
    let invalid = e.invalid.expect("a typed refusal");
    let grass: Vec<String> = invalid
        .0
        .iter()
        .filter(|p| p.key() == "grass")
        .map(ToString::to_string)
        .collect();
    assert_eq!(grass.len(), 2, "cells and blades both refused: {invalid}");
    let m = grass.join("; ");
    assert!(m.contains("grass[0]"), "{m}");
    assert!(m.contains("limit of 4000000"), "{m}");
    // the blades asked for are named too (about 3.6e9 with a 500 × 500 m box at density 500)
    assert!(m.contains("blades"), "{m}");
    // a box that alone has too many cells is named for its cells even at density 0
    let text =
        format!("{HEAD}[[grass]]\ncenter = [0.0, 0.0]\nsize = [500.0, 500.0]\ndensity = 0.0\n");
    let e = WorldFile::parse(&text, "w").expect_err("too many cells");
    assert!(e.to_string().contains("cells"), "{e}");
    // the bundled sizes load: 30 × 16 m at density 6 is far within
    let text =
        format!("{HEAD}[[grass]]\ncenter = [12.0, 0.0]\nsize = [30.0, 16.0]\ndensity = 6.0\n");
    WorldFile::parse(&text, "w").expect("a bundled-size patch loads");
    // the limit counts all patches together: two halves of a refused patch are refused
    let half = "[[grass]]\ncenter = [0.0, 0.0]\nsize = [60.0, 60.0]\ndensity = 15.0\n";
    assert!(WorldFile::parse(&format!("{HEAD}{half}"), "w").is_ok());
    assert!(WorldFile::parse(&format!("{HEAD}{half}{half}{half}"), "w").is_err());
}

/// Issue 23 item 2: whatever its size, yaw and density within their ranges, a grass patch
/// either loads with a blade field within the limits or is refused naming `grass`.
#[test]
fn issue23_2_every_grass_patch_that_loads_fits_the_blade_field_limits() {
    proptest!(ProptestConfig::with_cases(256), |(
        sx in 0.01f64..500.0,
        sy in 0.01f64..500.0,
        yaw in -360.0f64..360.0,
        density in 0.0f64..500.0,
    )| {
        let text = format!(
            "{HEAD}[[grass]]\ncenter = [1.0, 2.0]\nsize = [{sx:?}, {sy:?}]\nyaw_deg = {yaw:?}\n\
             density = {density:?}\n"
        );
        match WorldFile::parse(&text, "w") {
            Ok(w) => {
                let scene = w.compile();
                let mimnav_sim::world::Shape::Prism { poly, .. } = &scene.objects[0].shape else {
                    panic!("grass is a prism");
                };
                let lo = [0, 1].map(|k| poly.iter().map(|p| p[k]).fold(f64::INFINITY, f64::min));
                let hi = [0, 1].map(|k| poly.iter().map(|p| p[k]).fold(f64::NEG_INFINITY, f64::max));
                let (cells, blades) = field_size(lo, hi, density);
                prop_assert!(cells <= MAX_FIELD_CELLS && blades <= MAX_FIELD_BLADES);
            }
            Err(e) => {
                let invalid = e.invalid.expect("typed");
                prop_assert!(invalid.get("grass").is_some(), "{}", invalid);
            }
        }
    });
}

/// Issue 23 item 3: NaN and infinities in a world's start, goal, walls, yaw and trunk positions
/// loaded silently (a NaN start had the planner turn at −1.5 rad/s for the whole episode). Each
/// is refused, naming its key.
#[test]
fn issue23_3_non_finite_values_accepted_in_worlds_are_refused() {
    let cases = [
        ("start = [nan, 0.0, 0.0]", "", "start[0]"),
        ("start = [0.0, 0.0, inf]", "", "start[2]"),
        ("goal = [3.0, -inf]", "", "goal[1]"),
        (
            "",
            "[[wall]]\nfrom = [nan, 0.0]\nto = [1.0, 2.0]\n",
            "wall[0].from[0]",
        ),
        (
            "",
            "[[wall]]\nfrom = [1.0, 0.0]\nto = [1.0, inf]\n",
            "wall[0].to[1]",
        ),
        (
            "",
            "[[pillar]]\ncenter = [1.0, 1.0]\nyaw_deg = nan\n",
            "pillar[0].yaw_deg",
        ),
        (
            "",
            "[[grass]]\ncenter = [1.0, 1.0]\nsize = [2.0, 2.0]\nyaw_deg = inf\n",
            "grass[0].yaw_deg",
        ),
        ("", "[[trunk]]\ncenter = [nan, 4.0]\n", "trunk[0].center[0]"),
        ("", "[[rock]]\ncenter = [1.0, -inf]\n", "rock[0].center[1]"),
        (
            "",
            "[[bush]]\ncenter = [inf, 4.0]\nradius = 1.0\n",
            "bush[0].center[0]",
        ),
        (
            "",
            "[[glass]]\nfrom = [1.0, 0.0]\nto = [nan, 2.0]\n",
            "glass[0].to[0]",
        ),
        (
            "",
            "[[curtain]]\nfrom = [1.0, 0.0]\nto = [1.0, 2.0]\nheight = nan\n",
            "curtain[0].height",
        ),
        ("survey = [[1.0, nan]]", "", "survey[0][1]"),
        ("time_limit_s = inf", "", "time_limit_s"),
    ];
    for (top, table, key) in cases {
        let mut head = HEAD.to_string();
        if let Some((k, _)) = top.split_once(" = ") {
            head = head
                .lines()
                .filter(|l| !l.starts_with(&format!("{k} =")))
                .map(|l| format!("{l}\n"))
                .collect();
            head.push_str(top);
            head.push('\n');
        }
        let e = WorldFile::parse(&format!("{head}{table}"), "nan.toml")
            .expect_err(&format!("{key}: refused"));
        let invalid = e
            .invalid
            .as_ref()
            .unwrap_or_else(|| panic!("{key}: typed: {e}"));
        assert!(invalid.get(key).is_some(), "{key} not named: {e}");
        assert!(e.to_string().starts_with("nan.toml: "), "{e}");
    }
    // far away but finite is refused too: the world's extent is bounded
    let far = format!(
        "{HEAD}[[trunk]]\ncenter = [{:.1}, 0.0]\n",
        WORLD_EXTENT_M * 2.0
    );
    let e = WorldFile::parse(&far, "far.toml").expect_err("outside the extent");
    assert!(e.to_string().contains("trunk[0].center[0]"), "{e}");
}

/// Issue 23 item 3: a non-finite value anywhere a world takes a number is refused, never loaded.
#[test]
fn issue23_3_no_world_with_a_non_finite_number_loads() {
    let slots = [
        "start = [{v}, 0.0, 0.0]\ngoal = [3.0, 0.0]",
        "start = [0.0, {v}, 0.0]\ngoal = [3.0, 0.0]",
        "start = [0.0, 0.0, {v}]\ngoal = [3.0, 0.0]",
        "start = [0.0, 0.0, 0.0]\ngoal = [{v}, 0.0]",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, {v}]",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[wall]]\nfrom = [1.0, {v}]\nto = [1.0, 2.0]",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[wall]]\nfrom = [1.0, 0.0]\nto = [1.0, 2.0]\nreflectivity = {v}",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[pillar]]\ncenter = [{v}, 1.0]",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[pillar]]\ncenter = [1.0, 1.0]\nsize = [{v}, 1.0]",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[grass]]\ncenter = [1.0, 1.0]\nsize = [2.0, 2.0]\ndensity = {v}",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[grass]]\ncenter = [1.0, {v}]\nsize = [2.0, 2.0]",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[bush]]\ncenter = [1.0, 1.0]\nradius = {v}",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[trunk]]\ncenter = [1.0, 1.0]\nheight = {v}",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[rock]]\ncenter = [1.0, 1.0]\nradius = {v}",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[glass]]\nfrom = [1.0, 0.0]\nto = [1.0, 2.0]\ntop = {v}",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[[curtain]]\nfrom = [1.0, 0.0]\nto = [1.0, 2.0]\ncoverage = {v}",
        "start = [0.0, 0.0, 0.0]\ngoal = [3.0, 0.0]\n[ground]\nreflectivity = {v}",
    ];
    proptest!(ProptestConfig::with_cases(200), |(
        slot in 0..slots.len(),
        v in prop_oneof![Just("nan"), Just("+nan"), Just("-nan"), Just("inf"), Just("+inf"), Just("-inf")],
    )| {
        let body = slots[slot].replace("{v}", v);
        let text = format!("name = \"w\"\ntime_limit_s = 10.0\n{body}\n");
        let r = WorldFile::parse(&text, "w");
        prop_assert!(r.is_err(), "loaded: {}", text);
    });
}

/// Issue 23 item 2: a world file is read whole, so its size is bounded before reading.
#[test]
fn issue23_2_an_oversized_world_file_is_refused_before_reading_it_whole() {
    let path = std::env::temp_dir().join(format!("mimnav-big-world-{}.toml", std::process::id()));
    let mut text = String::from(HEAD);
    while (text.len() as u64) <= MAX_WORLD_FILE_BYTES {
        text.push_str("# padding padding padding padding padding padding padding padding\n");
    }
    std::fs::write(&path, &text).expect("write");
    let e = WorldFile::load(&path).expect_err("too long");
    std::fs::remove_file(&path).ok();
    assert!(
        e.message
            .contains(&format!("longer than {MAX_WORLD_FILE_BYTES} bytes")),
        "{e}"
    );
    assert!(e.path.contains("mimnav-big-world"), "{e}");
}

/// Issue 23 item 2: `mimnav worlds check` fills a grid over the world's extent; a world 2 km
/// across (the most its positions allow) is filled at a coarser cell, within the bound, rather
/// than allocating gigabytes (99 000² cells at 2 cm).
#[test]
fn issue23_2_the_reachability_grid_of_a_world_at_its_extent_stays_bounded() {
    use mimnav_sim::reach::{CELL_M, MAX_POSES, reach};
    let text = "name = \"far\"\nstart = [-990.0, 0.0, 0.0]\ngoal = [-988.0, 0.0]\n\
                time_limit_s = 10.0\n[[trunk]]\ncenter = [990.0, 990.0]\n";
    let scene = WorldFile::parse(text, "far")
        .expect("within the extent")
        .compile();
    let r = reach(&scene, 0.2, 0.3, CELL_M);
    assert!(r.reachable, "{r:?}");
    assert!(r.coarsened && r.cell_m > CELL_M, "coarsened: {r:?}");
    // the extent: x from −990 to 990.15, y from 0 to 990.15, and the fill's margin
    let margin = 2.0 * (0.4 + 4.0 * r.cell_m + 0.1);
    let cells = ((1980.15 + margin) / r.cell_m + 2.0) * ((990.15 + margin) / r.cell_m + 2.0);
    assert!(cells <= MAX_POSES, "{cells} cells: {r:?}");
    assert!(
        cells > MAX_POSES / 2.0,
        "not coarser than needed: {cells} cells: {r:?}"
    );
}
