//! Hand-made point sets for each equation and each class.

use super::*;
use mimnav_shared::pose::pose2;

fn pt(x: f32, y: f32, z: f32, intensity: u8, laser_id: u8, rt: u8) -> Point {
    let d = (x * x + y * y + z * z).sqrt();
    let az = ((-y).atan2(x).to_degrees().rem_euclid(360.0) * 100.0).round() as u16 % 36000;
    Point {
        x,
        y,
        z,
        time_offset_ns: 0,
        distance_raw: (d / 0.002).round() as u16,
        azimuth_cdeg: az,
        intensity,
        laser_id,
        ring: 0,
        return_type: rt,
    }
}

fn mapper() -> Mapper {
    Mapper::new(MapperParams::default())
}

/// A mapper with the defaults but for what `f` changes in `[mapper]`.
fn mapper_with(f: impl FnOnce(&mut MapperConfig)) -> Mapper {
    let mut p = MapperParams::default();
    f(&mut p.mapper);
    Mapper::new(p)
}

fn class_at(m: &Mapper, x: f32, y: f32) -> u8 {
    let g = m.params().grid;
    let (r, c) = g.cell_of(x, y).expect("inside");
    m.classes()[g.index(r, c)]
}

const BOTH: u8 = return_type::BOTH;

#[test]
fn equation_1_sums_normalised_intensity_over_the_cell_area() {
    let mut m = mapper();
    // three points in the "above" layer of one cell (z = 0.1 m above the sensor)
    let pts: Vec<Point> = (0..3)
        .map(|k| pt(2.01 + 0.01 * k as f32, 1.01, 0.1, 50, 3, BOTH))
        .collect();
    m.update(&pts, OdomInput::Missing, 0);
    let above = m
        .params()
        .layers()
        .iter()
        .position(|l| l.name == "above")
        .expect("layer");
    let mut v = Vec::new();
    m.layer_values(above, &mut v);
    let g = m.params().grid;
    let (r, c) = g.cell_of(2.02, 1.01).expect("inside");
    let expected = 3.0 * 0.5 / (0.05 * 0.05);
    assert!(
        (v[g.index(r, c)] - expected).abs() < 1e-2,
        "{} vs {expected}",
        v[g.index(r, c)]
    );
    assert_eq!(v.iter().filter(|&&x| x > 0.0).count(), 1);
    // map/layers carries the layers one after the other: this one at its place
    let all: Vec<f32> = m.layers().collect();
    assert_eq!(all.len(), m.layer_count() * g.len());
    assert_eq!(&all[above * g.len()..(above + 1) * g.len()], &v[..]);
    assert_eq!(all.iter().filter(|&&x| x > 0.0).count(), 1);
    // the service writes them into the sample a layer at a time: the same values
    let mut written = vec![-1.0; all.len()];
    m.write_layers(&mut written);
    assert_eq!(written, all);
}

#[test]
fn equations_3_to_5_split_solid_and_passable_by_mean_intensity() {
    let mut m = mapper();
    // bright cell: solid; dim cell: passable — the dim one has many more points (it is nearer),
    // which would win with the paper's sums; the mean keeps it passable
    let mut pts = vec![
        pt(3.0, 0.0, 0.05, 60, 3, BOTH),
        pt(3.01, 0.01, -0.1, 55, 12, BOTH),
    ];
    for k in 0..3 {
        pts.push(pt(
            1.0 + 0.01 * k as f32,
            0.5,
            -0.2,
            8,
            10,
            return_type::STRONGEST,
        ));
        pts.push(pt(2.5, 0.5, -0.3, 30, 10, return_type::LAST)); // the beam went on behind it
    }
    // put each last return before its strongest, as the driver emits a differing pair
    let mut ordered = vec![pts[0], pts[1]];
    for k in 0..3 {
        ordered.push(pts[3 + 2 * k]);
        ordered.push(pts[2 + 2 * k]);
    }
    m.update(&ordered, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 3.0, 0.0), cell_class::SOLID);
    assert_eq!(class_at(&m, 1.0, 0.5), cell_class::PASSABLE);
    let g = m.params().grid;
    let (r, c) = g.cell_of(3.0, 0.0).expect("inside");
    assert_eq!(m.cost()[g.index(r, c)], 255);
    let (r, c) = g.cell_of(1.0, 0.5).expect("inside");
    assert_eq!(
        m.cost()[g.index(r, c)],
        m.params().mapper.passable_cell_cost()
    );
}

#[test]
fn a_dim_cell_no_beam_passes_through_is_solid() {
    let mut m = mapper();
    // a wall seen at a grazing angle: dim, but many returns and none with anything behind
    let pts: Vec<Point> = (0..6)
        .map(|k| pt(2.0 + 0.005 * k as f32, 2.0, 0.05 * k as f32, 10, 3, BOTH))
        .collect();
    m.update(&pts, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 2.0, 2.0), cell_class::SOLID);
    // with fewer single-echo returns than min_returns_solid it stays passable by equation 3
    let mut m = mapper_with(|m| m.min_returns_solid = 3);
    m.update(&pts[..2], OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 2.0, 2.0), cell_class::PASSABLE);
    // and so do dim returns that were not alone on their beam (grass, where beams die in it)
    let blades: Vec<Point> = pts
        .iter()
        .map(|p| Point {
            return_type: return_type::LAST,
            ..*p
        })
        .collect();
    let mut m = mapper();
    m.update(&blades, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 2.0, 2.0), cell_class::PASSABLE);
}

#[test]
fn a_cells_highest_return_makes_it_tall_whichever_comes_first() {
    // (`Evidence::top_z` starts below every return and takes the maximum, with no branch on
    // whether a return is the cell's first)
    let p = MapperParams::default();
    let tall_z = (p.mapper.tall_m - p.robot.sensor_height_m) as f32;
    // dim returns, each the last of its firing, none with anything behind it: grass blades
    let blade = |z: f32| pt(2.0, 2.0, z, 10, 3, return_type::LAST);
    let blades = [blade(-0.2), blade(-0.1), blade(0.0)];
    let mut m = mapper();
    m.update(&blades, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 2.0, 2.0), cell_class::PASSABLE);
    // one return above `tall_m`, first or last: tall, hence solid
    for first in [true, false] {
        let mut pts = blades.to_vec();
        let top = blade(tall_z + 0.1);
        if first {
            pts.insert(0, top);
        } else {
            pts.push(top);
        }
        let mut m = mapper();
        m.update(&pts, OdomInput::Missing, 0);
        assert_eq!(
            class_at(&m, 2.0, 2.0),
            cell_class::SOLID,
            "top first: {first}"
        );
    }
    // every return below the sensor and below a `tall_m` lower than the sensor (tall_z < 0):
    // not tall (a top starting at 0, the sensor's height, would make it so)
    let mut m = mapper_with(|m| m.tall_m = 0.3);
    m.update(
        &[blade(-0.35), blade(-0.3), blade(-0.25)],
        OdomInput::Missing,
        0,
    );
    assert_eq!(class_at(&m, 2.0, 2.0), cell_class::PASSABLE);
}

/// A firing seen through grass: a faint blade echo (strongest) at `blade` m, then the last echo
/// at (x, y, z), in the driver's order (last first), sharing the firing's azimuth.
fn through_blade(x: f32, y: f32, z: f32, blade: f32, laser: u8) -> [Point; 2] {
    let far = pt(x, y, z, 6, laser, return_type::LAST);
    let s = blade / (x * x + y * y + z * z).sqrt();
    let near = Point {
        azimuth_cdeg: far.azimuth_cdeg,
        ..pt(x * s, y * s, z * s, 4, laser, return_type::STRONGEST)
    };
    [far, near]
}

#[test]
fn a_faint_surface_that_stops_every_beam_is_solid() {
    // a trunk behind a metre of grass: every beam crosses blades first, so the trunk's echoes are
    // last returns, as faint as the blades (below Γ), low (no "tall" cue) and never single
    let trunk: Vec<Point> = (0..20)
        .flat_map(|k| through_blade(2.0, 0.5, -0.3 + 0.02 * k as f32, 1.0, (k % 16) as u8))
        .collect();
    let mut m = mapper();
    assert_eq!(
        m.params().mapper.stop_min_returns,
        16,
        "the documented default"
    );
    m.update(&trunk, OdomInput::Missing, 0);
    assert_eq!(
        class_at(&m, 2.0, 0.5),
        cell_class::SOLID,
        "20 returns, none through"
    );
    // the same cell with fewer returns than stop_min_returns stays passable (equation 3)
    let mut m = mapper();
    m.update(&trunk[..2 * 15], OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 2.0, 0.5), cell_class::PASSABLE, "15 returns");
    // grass: as many faint returns, but one beam went on through the cell
    let [wall_behind, blade] = through_blade(4.0, 1.0, 0.0, 2.0f32.hypot(0.5), 5);
    let mut grass = trunk.clone();
    grass.extend([wall_behind, blade]);
    let blade_cell = (blade.x, blade.y);
    let mut m = mapper();
    m.update(&grass, OdomInput::Missing, 0);
    let g = m.params().grid;
    assert_eq!(
        g.cell_of(blade_cell.0, blade_cell.1),
        g.cell_of(2.0, 0.5),
        "the blade lies in the trunk's cell"
    );
    assert_eq!(
        class_at(&m, 2.0, 0.5),
        cell_class::PASSABLE,
        "a beam passed through"
    );
}

#[test]
fn a_weak_echo_just_behind_a_bright_one_is_inside_the_same_object() {
    let mut m = mapper();
    // a bush: bright front at 2.0 m, a weak trace 0.3 m inside; grass: weak, then a wall far
    // behind
    let pts = [
        pt(2.3, 1.0, 0.1, 3, 3, return_type::LAST),
        pt(2.0, 0.87, 0.087, 42, 3, return_type::STRONGEST),
        pt(4.5, -1.0, 0.1, 40, 3, return_type::LAST),
        pt(1.8, -0.4, 0.04, 6, 3, return_type::STRONGEST),
    ];
    // the pairs must share their firing's azimuth and laser
    let pts: Vec<Point> = pts
        .chunks(2)
        .flat_map(|c| {
            let az = c[1].azimuth_cdeg;
            c.iter()
                .map(move |p| Point {
                    azimuth_cdeg: az,
                    ..*p
                })
                .collect::<Vec<_>>()
        })
        .collect();
    m.update(&pts, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 2.3, 1.0), cell_class::SOLID, "inside the bush");
    assert_eq!(
        class_at(&m, 1.8, -0.4),
        cell_class::PASSABLE,
        "a blade the beam passed"
    );
}

#[test]
fn ground_points_do_not_make_obstacles_and_free_space_is_where_beams_reached() {
    let mut m = mapper();
    // the sensor is 0.5 m up: ground at z = -0.5
    // one ring of the -15° laser at the VLP-16's 0.2° azimuth step
    let pts: Vec<Point> = (0..1800)
        .map(|k| {
            let a = (k as f32 * 0.2).to_radians();
            pt(3.0 * a.cos(), 3.0 * a.sin(), -0.5, 12, 0, BOTH)
        })
        .collect();
    m.update(&pts, OdomInput::Missing, 0);
    assert_eq!(
        class_at(&m, 3.0, 0.0),
        cell_class::FREE,
        "ground is not an obstacle"
    );
    assert_eq!(
        class_at(&m, 1.5, 0.0),
        cell_class::FREE,
        "beams passed over it"
    );
    assert_eq!(
        class_at(&m, 4.5, 0.0),
        cell_class::UNKNOWN,
        "no beam reached it"
    );
}

/// A return of laser 14 (−1°) at azimuth `az` (degrees, clockwise) and horizontal `range`.
fn on_minus_1_deg(az: f32, range: f32, intensity: u8) -> Point {
    let (s, c) = az.to_radians().sin_cos();
    pt(
        range * c,
        -range * s,
        -range * 1f32.to_radians().tan(),
        intensity,
        14,
        BOTH,
    )
}

/// A ring of the −1° laser (id 14) at 4 m with a glass spike straight ahead, and optionally
/// returns of the −3° laser (id 12) at the same place.
fn glass_scene(with_minus_eps: bool) -> Vec<Point> {
    let mut pts = Vec::new();
    for k in -40i32..=40 {
        let az = k as f32 * 0.2;
        let (s, c) = az.to_radians().sin_cos();
        let spike = k.abs() <= 3;
        let (range, intensity) = if spike { (4.0, 200) } else { (8.0 / c, 30) };
        pts.push(on_minus_1_deg(az, range, intensity));
        if with_minus_eps && spike {
            pts.push(pt(
                range * c,
                -range * s,
                -range * 3f32.to_radians().tan(),
                40,
                12,
                BOTH,
            ));
        }
    }
    pts
}

#[test]
fn equation_6_glass_is_a_spike_the_minus_eps_layer_does_not_see() {
    let mut m = mapper();
    let s = m.update(&glass_scene(false), OdomInput::Fresh(Odom::default()), 0);
    assert!(s.glass_detected > 0);
    assert_eq!(class_at(&m, 4.0, 0.0), cell_class::GLASS);
    let g = m.params().grid;
    for (i, &class) in m.classes().iter().enumerate() {
        if class == cell_class::GLASS {
            let (x, y) = g.center_of(i / g.cells, i % g.cells);
            assert!(
                (x - 4.0).abs() < 0.1 && y.abs() < 0.1,
                "glass only at the spike: {x} {y}"
            );
        }
    }
    let mut m = mapper();
    let s = m.update(&glass_scene(true), OdomInput::Fresh(Odom::default()), 0);
    assert_eq!(
        s.glass_detected, 0,
        "an opaque bright object is seen by the −3° laser too"
    );
}

/// A pane along the robot's way, 0.5 m to its right, seen squarely by laser 14 at 90°; the
/// revolution ends `behind_ns` after those beams fired.
fn pane_beside(behind_ns: u32) -> Vec<Point> {
    let mut pts = Vec::new();
    for k in -40i32..=40 {
        let az = 90.0 + k as f32 * 0.2;
        let (range, intensity) = if k.abs() <= 3 {
            (0.5 / az.to_radians().sin(), 200)
        } else {
            (8.0, 30)
        };
        pts.push(on_minus_1_deg(az, range, intensity));
    }
    // the revolution's last firing, high on a wall ahead
    let mut last = pt(5.0, 0.0, 1.0, 30, 15, BOTH);
    last.time_offset_ns = behind_ns;
    pts.push(last);
    pts
}

#[test]
fn a_spikes_normal_is_the_beam_from_where_the_moving_sensor_fired_it() {
    let moving = |v: f64| {
        OdomInput::Fresh(Odom {
            v,
            ..Odom::default()
        })
    };
    let mut m = mapper();
    // standing: the spike is at 90°, its normal straight to the right
    m.update(&pane_beside(50_000_000), moving(0.0), 0);
    let s = m.sightings();
    assert_eq!(s.len(), 1, "{s:?}");
    assert!(s[0].x.abs() < 0.01 && (s[0].y + 0.5).abs() < 0.01, "{s:?}");
    assert!((s[0].ny + 1.0).abs() < 1e-4, "{s:?}");
    // at 0.6 m/s the revolution ends 3 cm further on: the spike moves back by as much, the
    // pane does not turn
    let mut m = mapper();
    m.update(&pane_beside(50_000_000), moving(0.6), 0);
    let s = m.sightings();
    assert_eq!(s.len(), 1, "{s:?}");
    assert!((s[0].x + 0.03).abs() < 0.005, "de-skewed: {s:?}");
    let tilt = s[0].nx.atan2(-s[0].ny).to_degrees();
    assert!(
        tilt.abs() < 0.3,
        "the normal tilted {tilt:.2}° (from the revolution's end: {:.2}°)",
        0.03f64.atan2(0.5).to_degrees()
    );
}

#[test]
fn equation_7_glass_memory_follows_the_odometry_and_survives_beams_through_it() {
    let mut m = mapper();
    m.update(&glass_scene(false), OdomInput::Fresh(Odom::default()), 0);
    // the robot moved 1 m forward; the pane is now seen only obliquely: beams pass through
    let moved = pose2(1.0, 0.0, 0.0);
    let through: Vec<Point> = (0..50)
        .map(|k| pt(7.0, -1.0 + 0.04 * k as f32, -0.12, 30, 14, BOTH))
        .collect();
    let s = m.update(
        &through,
        OdomInput::Fresh(Odom {
            pose: moved,
            ..Odom::default()
        }),
        100_000_000,
    );
    assert_eq!(s.glass_detected, 0);
    assert_eq!(
        class_at(&m, 3.0, 0.0),
        cell_class::GLASS,
        "kept, 1 m nearer in the robot frame"
    );
    assert_ne!(class_at(&m, 4.0, 0.0), cell_class::GLASS);
    // stale odometry: the memory is not moved
    let s = m.update(&through, OdomInput::Stale, 200_000_000);
    assert!(s.glass_memory > 0);
    assert_eq!(class_at(&m, 3.0, 0.0), cell_class::GLASS);
}

#[test]
fn glass_memory_expires_by_age() {
    let mut m = mapper_with(|m| m.glass_memory_s = 1.0);
    m.update(&glass_scene(false), OdomInput::Fresh(Odom::default()), 0);
    m.update(&[], OdomInput::Fresh(Odom::default()), 2_000_000_000);
    assert_ne!(class_at(&m, 4.0, 0.0), cell_class::GLASS);
}

/// One downward laser's ring across a rock hidden in grass: each firing crosses a blade 0.8 m
/// out, then ends faintly on the rock's face 1.5 m ahead (x = 1.5, 0.15 m above the ground),
/// its range scaled by `scatter(k)` (1: the face itself). Another laser's beams pass through
/// blades above the rock (0.05 m below the sensor, 0.45 m above the ground) in the same cells
/// and go on 1.5 m. Like the firings of a revolution, all in one slice.
fn rock_in_grass(scatter: impl Fn(usize) -> f32) -> Vec<Point> {
    let mut pts = Vec::new();
    for k in 0..30 {
        let y = 0.1 - 0.2 * k as f32 / 29.0;
        let s = scatter(k);
        pts.extend(through_blade(1.5 * s, y * s, -0.35 * s, 0.8, 1));
        let over = (1.5f32 * 1.5 + y * y + 0.05 * 0.05).sqrt();
        pts.extend(through_blade(3.0, 2.0 * y, -0.1, over, 5));
    }
    pts
}

fn fresh(x: f64, y: f64) -> OdomInput {
    OdomInput::Fresh(Odom {
        pose: pose2(x, y, 0.0),
        v: 0.0,
        omega: 0.0,
    })
}

#[test]
fn a_rock_below_the_grass_tops_is_solid_by_its_surface_along_the_ring() {
    let rock = rock_in_grass(|_| 1.0);
    let mut m = mapper();
    m.update(&rock, OdomInput::Missing, 0);
    for y in [0.08, 0.0, -0.08] {
        assert_eq!(
            class_at(&m, 1.5, y),
            cell_class::SOLID,
            "the face at y = {y}"
        );
        let g = m.params().grid;
        let (r, c) = g.cell_of(1.5, y).expect("inside");
        let (_, _, passed, means) = m.cell_evidence(g.index(r, c));
        assert!(passed > 0, "beams passed through the blades above the rock");
        assert!(
            means.iter().all(|&v| v <= 0.3),
            "as faint as grass: {means:?}"
        );
    }
    // it is the surface cue that says so
    let mut off = mapper_with(|m| m.surface_min_returns = 0);
    off.update(&rock, OdomInput::Missing, 0);
    assert_eq!(class_at(&off, 1.5, 0.0), cell_class::PASSABLE);
    // blades at scattered ranges along the ring are not a surface
    let grass = rock_in_grass(|k| 1.0 + 0.4 * ((k as f32 * 0.618).fract() - 0.5));
    let mut m = mapper();
    m.update(&grass, OdomInput::Missing, 0);
    for p in grass.iter().filter(|p| p.laser_id == 1) {
        assert_ne!(
            class_at(&m, p.x, p.y),
            cell_class::SOLID,
            "a blade at ({}, {}) in scattered grass",
            p.x,
            p.y
        );
    }
    // (the ring behind, 3 m out, where the passing beams end, is a surface: solid)
    assert_eq!(class_at(&m, 3.0, 0.0), cell_class::SOLID);
}

/// The ring of [`rock_in_grass`] in the shade of the grass in front: only every `every`-th
/// firing reaches the rock's face; the others end on a blade short of it, at scattered ranges
/// (0.5–1.1 m), or, with `past`, go on past the face to the ground 3 m out (a curtain's
/// strands, which let every other beam through).
fn shaded_rock(every: usize, past: bool) -> Vec<Point> {
    let mut pts = Vec::new();
    for k in 0..30 {
        let y = 0.1 - 0.2 * k as f32 / 29.0;
        if k % every == 0 {
            pts.extend(through_blade(1.5, y, -0.35, 0.8, 1));
        } else if past {
            pts.push(pt(3.0, 2.0 * y, -0.7, 6, 1, return_type::LAST));
        } else {
            let s = (0.5 + 0.6 * (k as f32 * 0.618).fract()) / 1.5;
            pts.push(pt(1.5 * s, y * s, -0.35 * s, 4, 1, return_type::LAST));
        }
        let over = (1.5f32 * 1.5 + y * y + 0.05 * 0.05).sqrt();
        pts.extend(through_blade(3.0, 2.0 * y, -0.1, over, 5));
    }
    pts
}

#[test]
fn a_rock_few_beams_reach_through_the_grass_is_solid_unless_beams_go_past_it() {
    let p = MapperParams::default();
    assert_eq!(
        (
            p.mapper.surface_shaded_neighbours,
            p.mapper.surface_beyond_max
        ),
        (3, 2),
        "the documented defaults"
    );
    // one firing in four reaches the face: 4 or 5 of a return's 16 neighbours, fewer than
    // surface_neighbours (8), and none went farther
    let shaded = shaded_rock(4, false);
    let mut m = mapper();
    m.update(&shaded, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "in the shade");
    let mut off = mapper_with(|m| m.surface_shaded_neighbours = 0);
    off.update(&shaded, OdomInput::Missing, 0);
    assert_ne!(class_at(&off, 1.5, 0.0), cell_class::SOLID, "the cue off");
    // the blades the other firings ended on are no surface
    for q in shaded.iter().filter(|q| q.laser_id == 1 && q.x < 1.2) {
        assert_ne!(class_at(&m, q.x, q.y), cell_class::SOLID, "a blade");
    }
    // the same face with the other firings gone past it, to the ground behind: strands
    let strands = shaded_rock(4, true);
    let mut m = mapper();
    m.update(&strands, OdomInput::Missing, 0);
    assert_ne!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "beams went past");
    // ... unless as many may go past as do
    let mut lax = mapper_with(|m| m.surface_beyond_max = 16);
    lax.update(&strands, OdomInput::Missing, 0);
    assert_eq!(class_at(&lax, 1.5, 0.0), cell_class::SOLID, "beyond_max 16");
}

/// A rock under grass shows the beams its near face; the cells behind the face, along the
/// beams, up to `mapper.surface_depth_m`, are its body.
#[test]
fn the_cells_behind_a_surface_along_the_beams_are_solid_to_its_depth() {
    let rock = rock_in_grass(|_| 1.0);
    assert_eq!(
        mapper().params().mapper.surface_depth_m,
        0.3,
        "the documented default"
    );
    let mut m = mapper_with(|m| m.surface_depth_m = 0.3);
    m.update(&rock, OdomInput::Missing, 0);
    for x in [1.6, 1.7, 1.75] {
        assert_eq!(
            class_at(&m, x, 0.0),
            cell_class::SOLID,
            "behind the face, x = {x}"
        );
    }
    for x in [1.9, 2.2] {
        assert_ne!(
            class_at(&m, x, 0.0),
            cell_class::SOLID,
            "deeper than 0.3 m, x = {x}"
        );
    }
    // in front of the face, and beside it, nothing is added
    assert_ne!(class_at(&m, 1.35, 0.0), cell_class::SOLID, "in front");
    assert_ne!(class_at(&m, 1.7, 0.4), cell_class::SOLID, "beside");
    // the face alone with 0
    let mut m = mapper_with(|m| m.surface_depth_m = 0.0);
    m.update(&rock, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "the face");
    assert_ne!(class_at(&m, 1.7, 0.0), cell_class::SOLID, "only the face");
    // a face whose returns reach higher than surface_depth_top_m above the ground (this one
    // is 0.15 m up) is a bush's or a trunk's foot, not a rock under the grass: not deepened
    let mut m = mapper_with(|m| m.surface_depth_top_m = 0.1);
    m.update(&rock, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "the face, high");
    assert_ne!(class_at(&m, 1.7, 0.0), cell_class::SOLID, "not deepened");
    // out of sight, the face is kept longer the more it was found, the cells behind it only
    // surface_memory_s (3 s): they lie along the beams of where the sensor stood, and kept
    // as long they marked the grass behind bushes' and trunks' edges solid
    let s = 1_000_000_000u64;
    let mut m = mapper();
    for k in 0..10 {
        m.update(&rock, fresh(0.0, 0.0), k * s / 10);
    }
    assert_eq!(class_at(&m, 1.7, 0.0), cell_class::SOLID, "behind, seen");
    m.update(&[], fresh(0.0, 0.0), 3 * s);
    assert_eq!(class_at(&m, 1.7, 0.0), cell_class::SOLID, "behind, kept");
    m.update(&[], fresh(0.0, 0.0), 5 * s);
    assert_eq!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "the face, kept");
    assert_ne!(
        class_at(&m, 1.7, 0.0),
        cell_class::SOLID,
        "behind it, forgotten"
    );
}

#[test]
fn a_surface_that_beams_pass_below_or_an_upward_ring_is_not_solid() {
    // a curtain: the beams over the face become beams under it (0.1 m above the ground)
    let curtain: Vec<Point> = rock_in_grass(|_| 1.0)
        .into_iter()
        .map(|p| {
            if p.laser_id == 5 {
                Point { z: -0.8, ..p }
            } else {
                p
            }
        })
        .collect();
    let mut m = mapper();
    m.update(&curtain, OdomInput::Missing, 0);
    assert_eq!(
        class_at(&m, 1.5, 0.0),
        cell_class::PASSABLE,
        "beams pass below"
    );
    // the same face seen by a laser pointing up: where such a beam leaves a canopy its last
    // blades lie at one range all along the ring
    let up: Vec<Point> = rock_in_grass(|_| 1.0)
        .into_iter()
        .filter(|p| p.laser_id == 1)
        .map(|p| Point { z: 0.2, ..p })
        .collect();
    let mut m = mapper();
    m.update(&up, OdomInput::Missing, 0);
    assert_eq!(
        class_at(&m, 1.5, 0.0),
        cell_class::PASSABLE,
        "an upward ring"
    );
}

#[test]
fn a_surface_found_twice_is_kept_while_out_of_sight_and_moves_with_the_odometry() {
    let rock = rock_in_grass(|_| 1.0);
    let s = 1_000_000_000u64;
    // found once: not kept
    let mut m = mapper();
    m.update(&rock, fresh(0.0, 0.0), 0);
    m.update(&[], fresh(0.0, 0.0), s / 10);
    assert_ne!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "seen once");
    // found in two revolutions: kept while the robot drives 1 m towards it, out of sight
    let mut m = mapper();
    m.update(&rock, fresh(0.0, 0.0), 0);
    m.update(&rock, fresh(0.0, 0.0), s / 10);
    m.update(&[], fresh(1.0, 0.0), 2 * s);
    assert_eq!(
        class_at(&m, 0.5, 0.0),
        cell_class::SOLID,
        "kept, 1 m nearer"
    );
    assert_ne!(
        class_at(&m, 1.5, 0.0),
        cell_class::SOLID,
        "not where it was"
    );
    // forgotten after surface_memory_s (3 s)
    assert_eq!(
        m.params().surface_memory_ns(),
        3 * s,
        "the documented default"
    );
    m.update(&[], fresh(1.0, 0.0), 4 * s);
    assert_ne!(class_at(&m, 0.5, 0.0), cell_class::SOLID, "expired");
    // and not kept at all with surface_memory_s = 0
    let mut m = mapper_with(|m| m.surface_memory_s = 0.0);
    m.update(&rock, fresh(0.0, 0.0), 0);
    m.update(&rock, fresh(0.0, 0.0), s / 10);
    m.update(&[], fresh(0.0, 0.0), s / 5);
    assert_ne!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "memory off");
}

/// A rock's face is found revolution after revolution, a curtain's strands now and then: a
/// cell found in more revolutions is kept longer (half `surface_memory_s` a further find, up to
/// `surface_memory_longest_s`), as when the robot stands beside a rock it can no longer see.
#[test]
fn a_surface_found_again_and_again_is_kept_longer() {
    let rock = rock_in_grass(|_| 1.0);
    let s = 1_000_000_000u64;
    assert_eq!(
        mapper().params().surface_memory_longest_ns(),
        30 * s,
        "the documented default"
    );
    let found = |revolutions: u64| {
        let mut m = mapper_with(|m| m.surface_memory_longest_s = 30.0);
        for k in 0..revolutions {
            m.update(&rock, fresh(0.0, 0.0), k * s / 10);
        }
        (m, revolutions * s / 10)
    };
    // ten finds: 10 × 1.5 s = 15 s after the last
    let (mut m, t) = found(10);
    m.update(&[], fresh(0.0, 0.0), t + 14 * s);
    assert_eq!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "kept 14 s");
    m.update(&[], fresh(0.0, 0.0), t + 16 * s);
    assert_ne!(
        class_at(&m, 1.5, 0.0),
        cell_class::SOLID,
        "forgotten after 15 s"
    );
    // forty finds: no longer than surface_memory_longest_s (30 s)
    let (mut m, t) = found(40);
    assert_eq!(m.params().surface_memory_longest_ns(), 30 * s, "as set");
    m.update(&[], fresh(0.0, 0.0), t + 29 * s);
    assert_eq!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "kept 29 s");
    m.update(&[], fresh(0.0, 0.0), t + 31 * s);
    assert_ne!(
        class_at(&m, 1.5, 0.0),
        cell_class::SOLID,
        "forgotten after 30 s"
    );
    // no longer than surface_memory_s when the longest is set below it
    let mut m = mapper_with(|m| m.surface_memory_longest_s = 0.0);
    for k in 0..10 {
        m.update(&rock, fresh(0.0, 0.0), k * s / 10);
    }
    m.update(&[], fresh(0.0, 0.0), s + 4 * s);
    assert_ne!(class_at(&m, 1.5, 0.0), cell_class::SOLID, "3 s only");
}

/// A bush's top above the grass seen from afar: faint last returns 1.1 m above the ground
/// (0.6 m above the sensor), each behind a blade, around (x, y).
fn bush_top(x: f32, y: f32) -> Vec<Point> {
    (0..4)
        .flat_map(|k| through_blade(x, y + 0.005 * k as f32, 0.6, 1.0, 14))
        .collect()
}

/// The same place seen close by through grass: one faint last return low down, behind a blade.
fn bush_through_grass(x: f32, y: f32) -> Vec<Point> {
    through_blade(x, y, -0.2, 0.5, 3).to_vec()
}

#[test]
fn a_tall_cell_found_twice_is_kept_where_grass_hides_it_and_moves_with_the_odometry() {
    let s = 1_000_000_000u64;
    let (x, y) = (2.02f32, 1.02f32);
    let mut m = mapper();
    m.update(&bush_top(x, y), fresh(0.0, 0.0), 0);
    assert_eq!(
        class_at(&m, x, y),
        cell_class::SOLID,
        "tall, nothing through"
    );
    // seen through grass with nothing kept: passable by equation 3
    m.update(&bush_through_grass(x - 1.0, y), fresh(1.0, 0.0), s / 10);
    assert_eq!(
        class_at(&m, x - 1.0, y),
        cell_class::PASSABLE,
        "found once: not kept"
    );
    // found in two revolutions in a row, then seen only through grass 1 m nearer: kept
    let mut m = mapper();
    m.update(&bush_top(x, y), fresh(0.0, 0.0), 0);
    m.update(&bush_top(x, y), fresh(0.0, 0.0), s / 10);
    m.update(&bush_through_grass(x - 1.0, y), fresh(1.0, 0.0), s);
    assert_eq!(
        class_at(&m, x - 1.0, y),
        cell_class::SOLID,
        "kept, 1 m nearer"
    );
    assert_ne!(class_at(&m, x, y), cell_class::SOLID, "not where it was");
    // stale odometry: the memory stays where it was drawn last
    m.update(&[], OdomInput::Stale, 2 * s);
    assert_eq!(
        class_at(&m, x - 1.0, y),
        cell_class::SOLID,
        "stale odometry"
    );
    // forgotten after tall_memory_s (10 s)
    assert_eq!(
        m.params().tall_memory_ns(),
        10 * s,
        "the documented default"
    );
    m.update(&[], fresh(1.0, 0.0), 12 * s);
    assert_ne!(class_at(&m, x - 1.0, y), cell_class::SOLID, "expired");
    // and never kept with tall_memory_s = 0
    let mut m = mapper_with(|m| m.tall_memory_s = 0.0);
    m.update(&bush_top(x, y), fresh(0.0, 0.0), 0);
    m.update(&bush_top(x, y), fresh(0.0, 0.0), s / 10);
    m.update(&bush_through_grass(x - 1.0, y), fresh(1.0, 0.0), s);
    assert_eq!(class_at(&m, x - 1.0, y), cell_class::PASSABLE, "memory off");
}

#[test]
fn a_kept_tall_cell_gives_way_to_a_beam_through_it_and_to_what_is_seen_now() {
    let s = 1_000_000_000u64;
    let (x, y) = (2.02f32, 1.02f32);
    let kept = || {
        let mut m = mapper();
        m.update(&bush_top(x, y), fresh(0.0, 0.0), 0);
        m.update(&bush_top(x, y), fresh(0.0, 0.0), s / 10);
        m
    };
    // a curtain's strand stopped the beams for two revolutions; now one goes through the cell
    // to the wall 1 m behind it
    let mut m = kept();
    let d = x.hypot(y);
    let through = through_blade(x * (d + 1.0) / d, y * (d + 1.0) / d, 0.0, d, 7);
    m.update(&through, fresh(0.0, 0.0), s / 5);
    assert_eq!(
        class_at(&m, x, y),
        cell_class::PASSABLE,
        "a beam passed through"
    );
    // and forgotten: not drawn in the next revolution either
    m.update(&[], fresh(0.0, 0.0), s / 4);
    assert_ne!(class_at(&m, x, y), cell_class::SOLID, "forgotten");
    // the object is seen now one cell over: the kept cell is not drawn beside it
    let mut m = kept();
    m.update(&bush_top(x + 0.05, y), fresh(0.0, 0.0), s / 5);
    assert_eq!(class_at(&m, x + 0.05, y), cell_class::SOLID, "seen now");
    assert_ne!(class_at(&m, x, y), cell_class::SOLID, "not drawn beside it");
    // with nothing seen there now, it is drawn
    let mut m = kept();
    m.update(&[], fresh(0.0, 0.0), s / 5);
    assert_eq!(class_at(&m, x, y), cell_class::SOLID, "nothing seen now");
}

#[test]
fn a_prefetch_out_of_bounds_empty_or_of_a_type_of_no_size_is_a_no_op() {
    let cells = [LayerCell::default(); 3];
    for i in [0, 2, 3, usize::MAX] {
        for n in [0, 1, 3, usize::MAX] {
            prefetch(&cells, i, n);
        }
    }
    prefetch(&[(); 4], 3, 1);
    prefetch::<u8>(&[], 0, 1);
}

/// The values the layer tests must agree on: the bounds, either side of them, the signed zeros,
/// the infinities and a NaN.
const EDGES: [f32; 11] = [
    -1.5,
    -0.3,
    -0.0,
    0.0,
    0.026,
    0.5,
    1.0e-7,
    -1.0e-7,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
];

#[test]
fn four_layer_tests_at_once_agree_with_each_layers_own_test() {
    // the paper's four (two in metres, two in elevation), and five to fill a second four
    let mut params = MapperParams::default();
    let mut bounds = Mapper::new(params.clone()).bounds;
    let quads = LayerQuad::of(&bounds);
    assert_eq!(quads.len(), 1);
    params.mapper.layers = params.layers();
    params.mapper.layers.push(LayerConfig {
        name: "fifth".into(),
        unit: LayerUnit::M,
        low: -0.3,
        high: 0.5,
    });
    bounds = Mapper::new(params).bounds;
    let quads = LayerQuad::of(&bounds);
    assert_eq!(quads.len(), 2);
    let mut values: Vec<f32> = EDGES.to_vec();
    values.extend(bounds.iter().flat_map(|b| [b.low, b.high]));
    values.extend((0..200).map(|k| -2.0 + 0.02 * k as f32));
    for &z in &values {
        for &sin_el in &values {
            for (j, b) in bounds.iter().enumerate() {
                let bit = (quads[j / 4].within(z, sin_el) >> (j % 4)) & 1 == 1;
                assert_eq!(
                    bit,
                    in_layer(b, z, sin_el),
                    "layer {j}, z {z}, sin_el {sin_el}"
                );
            }
            // the padding holds nothing
            assert_eq!(quads[1].within(z, sin_el) >> 1, 0, "z {z}, sin_el {sin_el}");
        }
    }
}

#[test]
fn a_running_maximum_is_f32_max_while_it_is_a_number() {
    let mut values: Vec<f32> = EDGES.to_vec();
    values.extend((0..100).map(|k| -5.0 + 0.1 * k as f32));
    for &max in values.iter().filter(|v| !v.is_nan()) {
        for &x in &values {
            let (got, want) = (running_max(max, x), max.max(x));
            // (the signed zeros compare equal; `f32::max` may give either)
            assert!(got == want, "max {max}, x {x}: {got} against {want}");
        }
    }
}

/// Dim last returns (a beam that went on) filling the cells of the square from (x0, y0), `n`
/// cells a side: passable by equation 3. With `bright`, a bright single echo in each of those
/// cells too: solid by its brightness.
fn strands(x0: f32, y0: f32, n: usize, bright: &[(f32, f32)]) -> Vec<Point> {
    let mut pts = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (x0 + 0.05 * i as f32 + 0.02, y0 + 0.05 * j as f32 + 0.02);
            pts.push(pt(x, y, -0.3, 10, 3, return_type::LAST));
        }
    }
    for &(x, y) in bright {
        pts.push(pt(x, y, -0.3, 60, 4, BOTH));
    }
    pts
}

#[test]
fn a_lone_solid_among_passable_cells_is_passable_unless_found_there_again() {
    let speck = (2.12, 0.12);
    let band = strands(2.0, 0.0, 5, &[speck]);
    // off: the bright cell is solid by its brightness
    let mut m = mapper_with(|m| m.lone_solid_passable = 0);
    m.update(&band, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, speck.0, speck.1), cell_class::SOLID);
    assert_eq!(class_at(&m, 2.02, 0.02), cell_class::PASSABLE);
    // on (the default): alone among passable cells, it is one of the strands
    assert_eq!(MapperConfig::default().lone_solid_passable, 3);
    let mut m = mapper();
    let stats = m.update(&band, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, speck.0, speck.1), cell_class::PASSABLE);
    assert_eq!(stats.lone_passed, 1);
    let g = m.params().grid;
    let (r, c) = g.cell_of(speck.0, speck.1).expect("inside");
    assert_eq!(
        m.cost()[g.index(r, c)],
        m.params().mapper.passable_cell_cost()
    );
    // two solid cells side by side are not lone; nor is one with too few passable neighbours
    let pair = strands(2.0, 0.0, 5, &[speck, (speck.0 + 0.05, speck.1)]);
    m.update(&pair, OdomInput::Missing, 0);
    assert_eq!(class_at(&m, speck.0, speck.1), cell_class::SOLID);
    assert_eq!(class_at(&m, speck.0 + 0.05, speck.1), cell_class::SOLID);
    // at the strands' end (passable on one side only): a curtain's tip, where a jamb may be
    let tip = (2.12, 0.27);
    m.update(&strands(2.0, 0.0, 5, &[tip]), OdomInput::Missing, 0);
    assert_eq!(class_at(&m, tip.0, tip.1), cell_class::SOLID, "the tip");
    let post = vec![pt(3.02, 1.02, -0.3, 60, 4, BOTH)];
    m.update(&post, OdomInput::Missing, 0);
    assert_eq!(
        class_at(&m, 3.02, 1.02),
        cell_class::SOLID,
        "a post on open floor"
    );
    // found at its place again with fresh odometry (the robot moved 0.5 m on): kept solid
    let mut m = mapper_with(|m| m.lone_solid_passable = 3);
    m.update(&band, fresh(0.0, 0.0), 0);
    assert_eq!(class_at(&m, speck.0, speck.1), cell_class::PASSABLE);
    let moved: Vec<Point> = strands(1.5, 0.0, 5, &[(speck.0 - 0.5, speck.1)]);
    let stats = m.update(&moved, fresh(0.5, 0.0), 100_000_000);
    assert_eq!(class_at(&m, speck.0 - 0.5, speck.1), cell_class::SOLID);
    assert_eq!(stats.lone_passed, 0);
    // elsewhere in the band the next revolution (two cells on): passable again
    let mut m = mapper_with(|m| m.lone_solid_passable = 3);
    m.update(&band, fresh(0.0, 0.0), 0);
    let other = strands(2.0, 0.0, 5, &[(speck.0, speck.1 + 0.1)]);
    m.update(&other, fresh(0.0, 0.0), 100_000_000);
    assert_eq!(class_at(&m, speck.0, speck.1 + 0.1), cell_class::PASSABLE);
    // without fresh odometry the last revolution's place cannot be told: passable
    m.update(&other, OdomInput::Missing, 200_000_000);
    assert_eq!(class_at(&m, speck.0, speck.1 + 0.1), cell_class::PASSABLE);
}

/// The binning's azimuth wrap is `rem_euclid(36000)` for every azimuth, the de-skew's few
/// degrees either side of a turn and a damaged point's far beyond it alike.
#[test]
fn an_azimuth_wraps_into_one_turn_as_rem_euclid_does() {
    let mut some = vec![
        0,
        1,
        -1,
        35_999,
        36_000,
        36_001,
        -36_000,
        -36_001,
        71_999,
        72_000,
        -72_001,
        i32::MAX,
        i32::MIN,
        i32::MIN + 1,
    ];
    some.extend((-40_000..110_000).step_by(7));
    for a in some {
        assert_eq!(i32::from(wrap_cdeg(a)), a.rem_euclid(36_000), "{a}");
    }
}
