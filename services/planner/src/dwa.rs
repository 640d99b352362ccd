//! The dynamic window approach on the planning map (equation 12 of
//! `mim-lidar-intensity-navigation.txt`).
//!
//! Velocity pairs (v, ω) are sampled in the window the acceleration limits allow within one
//! control period of the current velocity; each is rolled forward over the horizon from the robot
//! (at the map's centre, heading along x). A trajectory whose footprint (the robot's radius)
//! touches a solid or glass cell is infeasible (beyond the paper: narrow passages stay open
//! without ever grazing a wall); the others are scored by goal progress, speed and the obstacle
//! cost summed along them on the planning map (eq. 12), and the cheapest wins.

use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

/// Settings of the planner's search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DwaParams {
    /// Largest forward speed, m/s.
    pub max_v: f64,
    /// Largest turn rate, rad/s.
    pub max_omega: f64,
    /// Largest linear acceleration, m/s².
    pub max_accel: f64,
    /// Largest angular acceleration, rad/s².
    pub max_alpha: f64,
    /// Footprint radius, m.
    pub radius_m: f64,
    /// Time the window's accelerations apply over (the control period), s.
    pub window_s: f64,
    /// Rollout step, s.
    pub dt_s: f64,
    /// Rollout horizon, s.
    pub horizon_s: f64,
    /// Speed samples.
    pub v_samples: usize,
    /// Turn-rate samples.
    pub omega_samples: usize,
    /// Weight of the remaining distance to the goal, per metre.
    pub goal_weight: f64,
    /// Weight of driving slower than the top speed, per m/s.
    pub speed_weight: f64,
    /// Weight of the summed obstacle cost (each cell 0–1).
    pub obstacle_weight: f64,
}

impl Default for DwaParams {
    /// The authors' starting point (DESIGN §7) on a Turtlebot 2's limits.
    fn default() -> Self {
        DwaParams {
            max_v: 0.5,
            max_omega: 1.5,
            max_accel: 0.6,
            max_alpha: 3.0,
            radius_m: 0.2,
            window_s: 0.5,
            dt_s: 0.1,
            horizon_s: 3.5,
            v_samples: 11,
            omega_samples: 21,
            goal_weight: 5.0,
            speed_weight: 0.1,
            obstacle_weight: 1.0,
        }
    }
}

/// What the search decided.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DwaOutcome {
    /// Drive at (v, ω).
    Drive {
        /// Speed, m/s.
        v: f64,
        /// Turn rate, rad/s.
        omega: f64,
        /// The winning score (lower is better).
        score: f64,
    },
    /// No sampled trajectory is feasible: stop.
    Blocked,
}

/// Distance from every cell to the nearest solid or glass cell, m (two-pass chamfer transform,
/// capped at `cap_m`).
pub fn clearance(classes: &[u8], grid: GridSpec, cap_m: f32, out: &mut Vec<f32>) {
    let n = grid.cells;
    let g = grid.cell_m;
    out.clear();
    out.extend(classes.iter().map(|&c| {
        if c == cell_class::SOLID || c == cell_class::GLASS {
            0.0
        } else {
            cap_m
        }
    }));
    let diag = g * std::f32::consts::SQRT_2;
    for r in 0..n {
        for c in 0..n {
            let i = r * n + c;
            let mut d = out[i];
            if r > 0 {
                d = d.min(out[i - n] + g);
                if c > 0 {
                    d = d.min(out[i - n - 1] + diag);
                }
                if c + 1 < n {
                    d = d.min(out[i - n + 1] + diag);
                }
            }
            if c > 0 {
                d = d.min(out[i - 1] + g);
            }
            out[i] = d;
        }
    }
    for r in (0..n).rev() {
        for c in (0..n).rev() {
            let i = r * n + c;
            let mut d = out[i];
            if r + 1 < n {
                d = d.min(out[i + n] + g);
                if c + 1 < n {
                    d = d.min(out[i + n + 1] + diag);
                }
                if c > 0 {
                    d = d.min(out[i + n - 1] + diag);
                }
            }
            if c + 1 < n {
                d = d.min(out[i + 1] + g);
            }
            out[i] = d;
        }
    }
}

/// Searches the dynamic window from the current velocity (v0, ω0) towards `goal` (robot frame,
/// m) on the planning `cost` (0–255 per cell) with the footprint `clearance` (m per cell).
pub fn plan(
    p: &DwaParams,
    grid: GridSpec,
    cost: &[u8],
    clear: &[f32],
    v0: f64,
    omega0: f64,
    goal: (f64, f64),
) -> DwaOutcome {
    let v_lo = (v0 - p.max_accel * p.window_s).max(0.0);
    let v_hi = (v0 + p.max_accel * p.window_s).min(p.max_v);
    let w_lo = (omega0 - p.max_alpha * p.window_s).max(-p.max_omega);
    let w_hi = (omega0 + p.max_alpha * p.window_s).min(p.max_omega);
    let steps = (p.horizon_s / p.dt_s).ceil().max(1.0) as usize;
    let goal_dist = goal.0.hypot(goal.1).max(1e-6);
    // already touching: every motion starts in collision
    if let Some((r, c)) = grid.cell_of(0.0, 0.0)
        && f64::from(clear[grid.index(r, c)]) < p.radius_m
    {
        return DwaOutcome::Blocked;
    }
    let mut best: Option<(f64, f64, f64)> = None;
    let sample = |lo: f64, hi: f64, k: usize, n: usize| {
        if n <= 1 {
            0.5 * (lo + hi)
        } else {
            lo + (hi - lo) * k as f64 / (n - 1) as f64
        }
    };
    for kv in 0..p.v_samples.max(1) {
        let v = sample(v_lo, v_hi, kv, p.v_samples);
        for kw in 0..p.omega_samples.max(1) {
            let w = sample(w_lo, w_hi, kw, p.omega_samples);
            let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
            let mut obstacle = 0.0;
            let mut feasible = true;
            let mut closest = goal_dist;
            for _ in 0..steps {
                th += w * p.dt_s;
                x += v * th.cos() * p.dt_s;
                y += v * th.sin() * p.dt_s;
                let Some((r, c)) = grid.cell_of(x as f32, y as f32) else {
                    break;
                };
                let i = grid.index(r, c);
                if f64::from(clear[i]) < p.radius_m {
                    feasible = false;
                    break;
                }
                obstacle += f64::from(cost[i]) / 255.0;
                closest = closest.min((goal.0 - x).hypot(goal.1 - y));
                if closest < 0.05 {
                    break;
                }
            }
            if !feasible {
                continue;
            }
            let score = p.goal_weight * closest
                + p.speed_weight * (p.max_v - v)
                + p.obstacle_weight * obstacle * p.dt_s;
            if best.is_none_or(|b| score < b.2) {
                best = Some((v, w, score));
            }
        }
    }
    match best {
        Some((v, omega, score)) => DwaOutcome::Drive { v, omega, score },
        None => DwaOutcome::Blocked,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(f: impl Fn(f32, f32) -> u8) -> (GridSpec, Vec<u8>) {
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let classes = (0..grid.len())
            .map(|i| {
                let (x, y) = grid.center_of(i / grid.cells, i % grid.cells);
                f(x, y)
            })
            .collect();
        (grid, classes)
    }

    fn run(classes: &[u8], grid: GridSpec, v0: f64, goal: (f64, f64)) -> DwaOutcome {
        let mut clear = Vec::new();
        clearance(classes, grid, 5.0, &mut clear);
        let cost: Vec<u8> = classes
            .iter()
            .map(|&c| if c == cell_class::SOLID { 255 } else { 0 })
            .collect();
        plan(&DwaParams::default(), grid, &cost, &clear, v0, 0.0, goal)
    }

    #[test]
    fn clearance_measures_the_distance_to_the_nearest_wall() {
        let (grid, classes) = map(|x, _| {
            if (x - 1.0).abs() < 0.03 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let mut clear = Vec::new();
        clearance(&classes, grid, 5.0, &mut clear);
        let at = |x: f32, y: f32| {
            let (r, c) = grid.cell_of(x, y).expect("inside");
            clear[grid.index(r, c)]
        };
        assert!((at(0.5, 0.0) - 0.5).abs() < 0.06, "{}", at(0.5, 0.0));
        assert_eq!(at(1.01, 0.0), 0.0);
    }

    #[test]
    fn an_open_map_drives_straight_at_a_goal_ahead() {
        let (grid, classes) = map(|_, _| cell_class::FREE);
        match run(&classes, grid, 0.3, (4.0, 0.0)) {
            DwaOutcome::Drive { v, omega, .. } => {
                assert!(v > 0.4, "{v}");
                assert!(omega.abs() < 0.2, "{omega}");
            }
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn a_goal_to_the_left_turns_left() {
        let (grid, classes) = map(|_, _| cell_class::FREE);
        match run(&classes, grid, 0.0, (0.5, 3.0)) {
            DwaOutcome::Drive { omega, .. } => assert!(omega > 0.5, "{omega}"),
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn a_wall_ahead_with_an_opening_on_the_left_is_driven_around() {
        // wall across at x = 1 m from y = -3 to y = 0.5; open beyond
        let (grid, classes) = map(|x, y| {
            if (x - 1.0).abs() < 0.05 && y < 0.5 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        match run(&classes, grid, 0.2, (3.0, 0.0)) {
            DwaOutcome::Drive { omega, .. } => assert!(omega > 0.2, "swerves left: {omega}"),
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn boxed_in_at_speed_is_blocked() {
        // a ring of wall 0.35 m around a robot doing 0.5 m/s: it cannot slow below 0.2 m/s
        // within the window, and every such trajectory touches the ring
        let (grid, classes) = map(|x, y| {
            if (x.hypot(y) - 0.35).abs() < 0.05 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert_eq!(run(&classes, grid, 0.5, (3.0, 0.0)), DwaOutcome::Blocked);
    }

    #[test]
    fn touching_already_is_blocked() {
        let (grid, classes) = map(|x, _| {
            if (x - 0.1).abs() < 0.03 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert_eq!(run(&classes, grid, 0.0, (-3.0, 0.0)), DwaOutcome::Blocked);
    }
}
