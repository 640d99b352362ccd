//! Ground truth: the class of every map cell around the robot, in the robot frame, from the
//! scene's objects. A cell takes the class of the most important object whose footprint comes
//! within half a cell of its centre (a curtain: plus the sway of its strands): solid before glass
//! before passable; every other cell is free.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

use mimnav_shared::pose::{Pose2, Pose2Ext};

use mimnav_velodyne::packet::VLP16_ELEVATION_DEG;

use crate::geometry::footprint_distance;
use crate::world::{Material, Object, Scene, Shape};

fn rank(class: u8) -> u8 {
    match class {
        cell_class::SOLID => 3,
        cell_class::GLASS => 2,
        cell_class::PASSABLE => 1,
        _ => 0,
    }
}

/// Fills `out` (resized to the grid) with the true class of every cell of `grid` around `pose`.
pub fn truth_grid(scene: &Scene, pose: &Pose2, grid: GridSpec, out: &mut Vec<u8>) {
    out.clear();
    out.resize(grid.len(), cell_class::FREE);
    let half = f64::from(grid.cell_m) * 0.5;
    let extent = f64::from(grid.half_extent_m());
    for obj in &scene.objects {
        let (centre, radius) = obj.bound;
        // the object's bounding circle in the robot frame
        let (rx, ry) = pose.to_local(centre[0], centre[1]);
        let reach = radius + half + obj.truth_margin_m;
        if rx + reach < -extent
            || rx - reach > extent
            || ry + reach < -extent
            || ry - reach > extent
        {
            continue;
        }
        let cell = |v: f64| {
            ((v + extent) / f64::from(grid.cell_m))
                .floor()
                .clamp(0.0, grid.cells as f64 - 1.0) as usize
        };
        let (r0, r1) = (cell(rx - reach), cell(rx + reach));
        let (c0, c1) = (cell(ry - reach), cell(ry + reach));
        let new_rank = rank(obj.class);
        for r in r0..=r1 {
            for col in c0..=c1 {
                let i = grid.index(r, col);
                if rank(out[i]) >= new_rank {
                    continue;
                }
                let (x, y) = grid.center_of(r, col);
                let (wx, wy) = pose.to_fixed(f64::from(x), f64::from(y));
                // a hair over half a cell, so a sheet lying exactly on a cell border marks the
                // cells on both sides rather than neither
                if footprint_distance(&obj.shape, [wx, wy]) <= half + obj.truth_margin_m + 1e-6 {
                    out[i] = obj.class;
                }
            }
        }
    }
}

/// Whether a VLP-16 whose optical centre stands at `sensor` (x, y, height; world frame, level)
/// faces the glass pane `obj`: whether a beam of one of its lasers can meet the pane within
/// `specular_deg` of the pane's normal, the simulator's own condition for a glass return
/// (`sim.glass_specular_deg`, [`crate::physics`]). The beam checked is the one nearest the normal
/// that meets the pane (off the normal only where the foot of the sensor's perpendicular lies
/// beyond an end), at each laser's elevation. What lies between and the sensor's range are not
/// considered: an upper bound on where the pane can show itself. False for anything but a
/// glass sheet.
///
/// Issue 22: a pane no revolution has faced is not in any map built from the sensor's returns,
/// so the evaluation tells a contact with one apart (`touched_kind`).
pub fn faces_pane(obj: &Object, sensor: [f64; 3], specular_deg: f64) -> bool {
    let (Shape::Sheet { a, b, z0, z1 }, Material::Glass) = (&obj.shape, &obj.material) else {
        return false;
    };
    let len = (b[0] - a[0]).hypot(b[1] - a[1]);
    // NaN fails too
    if !(len > 0.0 && specular_deg > 0.0) {
        return false;
    }
    let (ux, uy) = ((b[0] - a[0]) / len, (b[1] - a[1]) / len);
    let (sx, sy) = (sensor[0] - a[0], sensor[1] - a[1]);
    // along the pane to the foot of the sensor's perpendicular, and across to the pane's line
    let along = sx * ux + sy * uy;
    let across = (sx * uy - sy * ux).abs();
    if across.is_nan() || across <= 1e-6 {
        return false;
    }
    // the level beam nearest the normal that meets the pane, off the normal by `azimuth`
    let beyond = (-along).max(along - len).max(0.0);
    let azimuth = (beyond / across).atan();
    let cos_max = specular_deg.to_radians().cos();
    VLP16_ELEVATION_DEG.iter().any(|&e| {
        let e = f64::from(e).to_radians();
        // the pane's normal is level: cos(incidence) = cos(elevation)·cos(azimuth)
        if e.cos() * azimuth.cos() <= cos_max {
            return false;
        }
        let z = sensor[2] + across / azimuth.cos() * e.tan();
        (*z0..=*z1).contains(&z)
    })
}

/// The glass panes of `scene` that stand on the same line as pane `i` and join it end to end,
/// directly or through others (a shop front or partition built of several panes), `i` included;
/// empty when `i` is not a glass sheet. Within 2 cm and 1° counts as joined and on the line.
pub fn pane_line(scene: &Scene, i: usize) -> Vec<usize> {
    // a pane's two ends
    type Segment = ([f64; 2], [f64; 2]);
    let sheet = |k: usize| match (scene.objects.get(k).map(|o| (&o.shape, &o.material)))? {
        (Shape::Sheet { a, b, .. }, Material::Glass) => Some((*a, *b)),
        _ => None,
    };
    let joined = |p: Segment, q: Segment| {
        let near = |u: [f64; 2], v: [f64; 2]| (u[0] - v[0]).hypot(u[1] - v[1]) < 0.02;
        let touch = near(p.0, q.0) || near(p.0, q.1) || near(p.1, q.0) || near(p.1, q.1);
        let dir = |s: Segment| (s.1[1] - s.0[1]).atan2(s.1[0] - s.0[0]);
        // the angle between the lines, folded onto [0, 90°]
        let turn = (dir(p) - dir(q)).rem_euclid(std::f64::consts::PI);
        touch && turn.min(std::f64::consts::PI - turn) < 1f64.to_radians()
    };
    // the panes found so far with their ends; each is searched from in turn
    let mut line: Vec<(usize, Segment)> = sheet(i).map(|p| (i, p)).into_iter().collect();
    let mut k = 0;
    while let Some(&(_, p)) = line.get(k) {
        for j in 0..scene.objects.len() {
            if !line.iter().any(|&(m, _)| m == j)
                && let Some(q) = sheet(j)
                && joined(p, q)
            {
                line.push((j, q));
            }
        }
        k += 1;
    }
    line.into_iter().map(|(j, _)| j).collect()
}
