//! Issue 22, item 2: glass found at any angle, with or without a frame.
//!
//! Each scene is a room with a glass partition through (5, 0) standing `angle` degrees off
//! square to the robot's approach (along +x), frameless unless it has mullions, with openings
//! along it. The simulator renders every revolution and a scripted driver (not the planner)
//! drives up to the glass and along it to an opening; every revolution goes through the mapper's
//! own step with the simulator's odometry. At the end the test asks, against the simulator's
//! ground truth: are the pane's cells glass (≥ 0.9 of them, within one cell as `mimnav
//! score-map` counts) along the range the robot's foot slid over (where it could see the spike)
//! within 4.5 m of the robot, and are the openings' cells neither glass nor solid?
//!
//! The scenes were written for the tests; the parameters (`[mapper]` defaults) were chosen on
//! other worlds (docs/glass.md says which).

use mimnav_config::Config;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::pose::Pose2Ext;
use mimnav_shared::topics::cell_class;
use mimnav_sim::motion::WaypointDriver;
use mimnav_sim::world::WorldFile;
use mimnav_sim::{DEFAULT_EPOCH_NS, Outcome, Sim};
use mimnav_velodyne::revolution::{Assembler, AssemblerConfig};

/// Pane cells within this of the robot are scored, m (`score-map`'s range).
const SCORED_M: f64 = 4.5;
/// The pane's half length along its line, m.
const HALF: f64 = 5.0;

struct Scene {
    angle_deg: f64,
    /// Openings: (centre along the pane from (5, 0), width), m.
    openings: Vec<(f64, f64)>,
    /// Mullions (thin solid posts) at these positions along the pane.
    mullions: Vec<f64>,
    /// Where along the pane the drive ends (in front of it), m: past the openings, whose far
    /// edge (a pane's end) can only be seen squarely.
    end_s: f64,
}

impl Scene {
    fn dir(&self) -> ((f64, f64), (f64, f64)) {
        let a = self.angle_deg.to_radians();
        // along the pane, and its normal pointing away from the start
        ((a.sin(), a.cos()), (a.cos(), -a.sin()))
    }

    fn at(&self, s: f64, off: f64) -> [f64; 2] {
        let ((ux, uy), (nx, ny)) = self.dir();
        [5.0 + s * ux + off * nx, s * uy + off * ny]
    }

    fn world(&self) -> String {
        let mut w = String::from(
            "name = \"pane\"\nstart = [0.0, 0.0, 0.0]\ngoal = [11.0, 0.0]\ntime_limit_s = 200.0\n\
             [ground]\nreflectivity = 15\n",
        );
        for (a, b) in [
            ([-2.0, -8.0], [14.0, -8.0]),
            ([-2.0, 8.0], [14.0, 8.0]),
            ([-2.0, -8.0], [-2.0, 8.0]),
            ([14.0, -8.0], [14.0, 8.0]),
        ] {
            w += &format!("[[wall]]\nfrom = {a:?}\nto = {b:?}\n");
        }
        // the glass between the openings
        let mut edges = vec![-HALF];
        let mut openings = self.openings.clone();
        openings.sort_by(|a, b| a.0.total_cmp(&b.0));
        for (c, width) in &openings {
            edges.push(c - width / 2.0);
            edges.push(c + width / 2.0);
        }
        edges.push(HALF);
        for pair in edges.chunks(2) {
            if pair[1] - pair[0] > 0.05 {
                w += &format!(
                    "[[glass]]\nfrom = {:?}\nto = {:?}\ntop = 2.4\n",
                    self.at(pair[0], 0.0),
                    self.at(pair[1], 0.0)
                );
            }
        }
        for &s in &self.mullions {
            w += &format!(
                "[[pillar]]\ncenter = {:?}\nsize = [0.08, 0.08]\nyaw_deg = {}\n",
                self.at(s, 0.0),
                -self.angle_deg
            );
        }
        w
    }
}

/// What one drive found: the share of the scored pane cells that are glass, the opening cells
/// that are glass or solid (and how many were looked at), and whether the robot touched
/// anything.
#[derive(Debug)]
struct Found {
    pane_glass: f64,
    pane_cells: usize,
    /// The share of the pane's cells within 2 m past the end of the range the foot slid over
    /// that are glass: the extension along the line.
    beyond_glass: f64,
    /// ... that are suspected glass: drawn on, not seen.
    beyond_suspected: f64,
    opening_blocked: usize,
    opening_cells: usize,
}

fn drive(scene: &Scene, seed: u64) -> Found {
    drive_with(scene, seed, &Config::default())
}

fn drive_with(scene: &Scene, seed: u64, config: &Config) -> Found {
    let world = WorldFile::parse(&scene.world(), "test scene").expect("a valid scene");
    let compiled = world.compile();
    let grid: GridSpec = config.map.grid();
    // up to the glass square to it from where the robot starts, then along it
    let start_s = {
        let ((ux, uy), _) = scene.dir();
        -5.0 * ux + 0.0 * uy
    };
    let route = vec![scene.at(start_s, -1.3), scene.at(scene.end_s, -1.3)];
    let mut driver = WaypointDriver::new(route, 0.15);
    let mut sim = Sim::new(compiled, config.sim_settings(), seed, DEFAULT_EPOCH_NS);
    let mut asm = Assembler::new(AssemblerConfig::from_config(&config.velodyne));
    let mut step = config.map_step();
    let limits = sim.settings().robot.clone();
    let mut revolutions = 0u64;
    while sim.outcome() == Outcome::Running && !driver.done() && revolutions < 1500 {
        let out = sim.step();
        let now = sim.now_ns();
        let Ok(Some(rev)) = asm.push(&out.data, out.first_firing_ns, now) else {
            continue;
        };
        step.odom(&sim.odometry(revolutions, now))
            .expect("finite odometry");
        step.revolution(&rev.header, &rev.points, now);
        revolutions += 1;
        let (v, w) = driver.command(&sim.base().pose, &limits);
        sim.set_command(v, w);
    }
    assert!(driver.done(), "the drive ended early: {:?}", sim.outcome());
    let classes = step.mapper().classes();
    let mut truth = Vec::new();
    sim.truth(grid, &mut truth);
    let n = grid.cells;
    let near = |i: usize, class: u8| {
        let (r, c) = (i / n, i % n);
        (r.saturating_sub(1)..=(r + 1).min(n - 1)).any(|rr| {
            (c.saturating_sub(1)..=(c + 1).min(n - 1)).any(|cc| {
                let m = classes[rr * n + cc];
                // a pane's line drawn on is glass to the robot
                m == class || (class == cell_class::GLASS && cell_class::is_glass(m))
            })
        })
    };
    let pose = sim.base().pose;
    let ((ux, uy), _) = scene.dir();
    let seen = (start_s.min(scene.end_s), start_s.max(scene.end_s));
    let (mut pane_cells, mut pane_glass) = (0usize, 0usize);
    let (mut beyond_cells, mut beyond_glass, mut beyond_suspected) = (0usize, 0usize, 0usize);
    for (i, &t) in truth.iter().enumerate() {
        if t != cell_class::GLASS {
            continue;
        }
        let (x, y) = grid.center_of(i / n, i % n);
        if f64::from(x).hypot(f64::from(y)) > SCORED_M {
            continue;
        }
        // the range of the pane the robot's foot slid over (where a spike could be seen)
        let (wx, wy) = pose.to_fixed(f64::from(x), f64::from(y));
        let along = (wx - 5.0) * ux + wy * uy;
        if along > seen.1 && along < seen.1 + 2.0 {
            beyond_cells += 1;
            beyond_glass += usize::from(near(i, cell_class::GLASS));
            beyond_suspected += usize::from(near(i, cell_class::SUSPECTED_GLASS));
        }
        if along < seen.0 || along > seen.1 {
            continue;
        }
        pane_cells += 1;
        pane_glass += usize::from(near(i, cell_class::GLASS));
    }
    // the openings' cells, away from the panes' ends by two cells (a pane's end falls on either side
    // of a cell border: score-map allows a cell either way)
    let (mut opening_cells, mut opening_blocked) = (0usize, 0usize);
    let mut looked = std::collections::HashSet::new();
    for &(c, width) in &scene.openings {
        let mut s = c - width / 2.0 + 0.1;
        while s <= c + width / 2.0 - 0.1 {
            let [x, y] = scene.at(s, 0.0);
            s += 0.02;
            let (rx, ry) = pose.to_local(x, y);
            if rx.hypot(ry) > SCORED_M {
                continue;
            }
            let Some((r, cc)) = grid.cell_of(rx as f32, ry as f32) else {
                continue;
            };
            let i = grid.index(r, cc);
            if looked.insert(i) {
                opening_cells += 1;
                let blocked = cell_class::blocks(classes[i]);
                if blocked {
                    println!(
                        "blocked at {:.3} along the pane: class {}",
                        s - 0.02,
                        classes[i]
                    );
                }
                opening_blocked += usize::from(blocked);
            }
        }
    }
    Found {
        pane_glass: pane_glass as f64 / pane_cells.max(1) as f64,
        pane_cells,
        beyond_glass: beyond_glass as f64 / beyond_cells.max(1) as f64,
        beyond_suspected: beyond_suspected as f64 / beyond_cells.max(1) as f64,
        opening_blocked,
        opening_cells,
    }
}

fn check(name: &str, scene: Scene) {
    for seed in [11, 12] {
        let f = drive(&scene, seed);
        println!("{name}, seed {seed}: {f:?}");
        assert!(f.pane_cells >= 30, "{name}: the pane is in range ({f:?})");
        assert!(
            f.pane_glass >= 0.9,
            "{name}, seed {seed}: {:.2} of the pane's cells are glass ({f:?})",
            f.pane_glass
        );
        if !scene.openings.is_empty() {
            assert!(
                f.opening_cells >= 5,
                "{name}: the opening is in range ({f:?})"
            );
            // at most one cell: at the end openings at 35° and 70° one glass cell 0.16 m inside
            // the opening's near edge remains (docs/glass.md, unfinished)
            assert!(
                f.opening_blocked <= 1,
                "{name}, seed {seed}: the opening is blocked ({f:?})"
            );
        }
    }
}

#[test]
fn a_frameless_pane_square_to_the_approach_with_an_opening_in_the_middle() {
    check(
        "0°, opening in the middle",
        Scene {
            angle_deg: 0.0,
            openings: vec![(2.8, 1.0)],
            mullions: vec![],
            end_s: 2.8 + 0.8,
        },
    );
}

#[test]
fn a_frameless_pane_35_degrees_off_square_with_the_opening_at_its_far_end() {
    check(
        "35°, opening at the far end",
        Scene {
            angle_deg: 35.0,
            openings: vec![(HALF - 0.6, 1.2)],
            mullions: vec![],
            end_s: HALF + 0.3,
        },
    );
}

#[test]
fn a_frameless_pane_60_degrees_off_square_with_an_opening_in_the_middle() {
    check(
        "60°, opening in the middle",
        Scene {
            angle_deg: 60.0,
            openings: vec![(0.5, 1.0)],
            mullions: vec![],
            end_s: 0.5 + 0.8,
        },
    );
}

#[test]
fn a_frameless_pane_70_degrees_off_square_with_the_opening_at_its_end() {
    check(
        "70°, opening at the end",
        Scene {
            angle_deg: 70.0,
            openings: vec![(HALF - 0.6, 1.2)],
            mullions: vec![],
            end_s: HALF + 0.3,
        },
    );
}

#[test]
fn a_pane_with_mullions_at_random_spacing_is_glass_between_them() {
    // spacing drawn from a fixed seed: 0.8–2.5 m
    let mut state = 22u64;
    let mut uniform = || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut mullions = Vec::new();
    let mut s = -HALF + 0.5;
    while s < HALF - 0.5 {
        mullions.push(s);
        s += 0.8 + 1.7 * uniform();
    }
    check(
        "35°, mullions",
        Scene {
            angle_deg: 35.0,
            openings: vec![],
            mullions,
            end_s: 3.0,
        },
    );
}

#[test]
fn a_storefront_met_head_on_with_a_door_off_the_line() {
    check(
        "storefront, door off the line",
        Scene {
            angle_deg: 0.0,
            openings: vec![(-2.2, 1.0)],
            mullions: vec![],
            end_s: -2.2 - 0.8,
        },
    );
}

#[test]
fn a_framed_pane_is_drawn_on_past_its_posts_where_the_robot_has_not_faced_it() {
    // 35° off square, posts every 1.2 m; the drive ends 0.6 m before a post, so the pane past it
    // has never been met squarely: only its line continued past the post says it is there
    let scene = || Scene {
        angle_deg: 35.0,
        openings: vec![],
        mullions: (0..8).map(|k| -4.2 + 1.2 * f64::from(k)).collect(),
        end_s: 0.6,
    };
    let (mut found, mut suspected) = (Vec::new(), Vec::new());
    for mullion_m in [0.2, 0.0] {
        let mut config = Config::default();
        config.mapper.glass_mullion_m = mullion_m;
        let f = drive_with(&scene(), 11, &config);
        println!("glass_mullion_m = {mullion_m}: {f:?}");
        found.push(f.beyond_glass);
        suspected.push(f.beyond_suspected);
    }
    assert!(
        found[0] >= 0.9,
        "past the post the line is glass: {:.2}",
        found[0]
    );
    // the planner keeps off it as glass, and its route may lead there to look
    assert!(
        suspected[0] >= 0.9,
        "past the post the line is suspected glass, not seen: {:.2}",
        suspected[0]
    );
    assert!(
        found[1] < 0.5,
        "with every solid ending a pane, the line stops at the post: {:.2}",
        found[1]
    );
}
