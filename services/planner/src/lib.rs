//! The mimnav planner as a library (no IPC): obstacle inflation on the intensity map and the
//! dynamic window approach that turns it into a velocity command.
//!
//! - [`inflate`]: the adaptive kernel (equations 8–9), inflation (eq. 10) and the planning map
//!   (eq. 11), with uniform inflation as the paper's ablation;
//! - [`route`]: a navigation function on the local map, so goal progress is measured around
//!   obstacles rather than through them (beyond the paper);
//! - [`clearance`]: the distance to the nearest solid or glass cell (a chamfer transform), which
//!   the route search and the dynamic window's footprint test both use;
//! - [`dwa`]: the dynamic window and the trajectory scores (eq. 12);
//! - [`look`]: where to drive so that suspected glass the route leads into gets seen;
//! - [`jamb`]: a curtain's free end, which the planner keeps off as a pane's end;
//! - [`Planner`]: inflation, clearance, route and dynamic window in order, with their buffers;
//! - [`pilot`]: the service's step around the planner (input freshness, the goal into the robot
//!   frame, foliage fusion, the fail-safe), which the service, `mimnav eval` and the lock-step
//!   runner drive alike.
#![deny(missing_docs)]

pub mod clearance;
pub mod config;
pub mod dwa;
pub mod guard;
pub mod inflate;
pub mod jamb;
pub mod look;
pub mod maneuver;
pub mod memory;
pub mod narrow;
pub mod params;
pub mod pilot;
pub mod route;

use mimnav_shared::config::Body;
use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::cell_class;

use clearance::Clearance;
use dwa::DwaOutcome;
use inflate::KernelCache;
pub use params::PlannerParams;
use route::Route;

/// Marks the cells of obstacles the foliage classifier confirmed solid (DESIGN §8: "obstacles
/// the foliage classifier confirms are solid for the planner"), so a trunk or a rock hidden in
/// grass that the map calls passable is avoided. `obstacles` are (bearing rad, horizontal range
/// m) in the sensor frame, which is the map's frame. Returns how many cells changed.
pub fn confirm_obstacles(
    classes: &mut [u8],
    grid: GridSpec,
    obstacles: impl IntoIterator<Item = (f32, f32)>,
) -> usize {
    let mut changed = 0;
    for (angle, range) in obstacles {
        if !(range > 0.0 && range.is_finite() && angle.is_finite()) {
            continue;
        }
        let (s, c) = angle.sin_cos();
        if let Some((r, col)) = grid.cell_of(range * c, range * s)
            && let Some(cell) = classes.get_mut(grid.index(r, col))
            && *cell != mimnav_shared::topics::cell_class::SOLID
        {
            *cell = mimnav_shared::topics::cell_class::SOLID;
            changed += 1;
        }
    }
    changed
}

/// Sets `cells` to `class` in the planner's copy of the map `own`, first copying `classes` into it
/// unless it holds them already (`copied`); true when the copy is in use after.
fn mark(own: &mut Vec<u8>, copied: bool, classes: &[u8], cells: &[usize], class: u8) -> bool {
    if cells.is_empty() {
        return copied;
    }
    if !copied {
        own.clear();
        own.extend_from_slice(classes);
    }
    for &i in cells {
        own[i] = class;
    }
    true
}

/// The planner with its kernel cache and buffers: one call per map.
#[derive(Debug)]
pub struct Planner {
    params: PlannerParams,
    /// `params` squeezing through ([`PlannerParams::tight`]).
    tight: PlannerParams,
    kernels: KernelCache,
    cost: Vec<u8>,
    inflate: inflate::Scratch,
    clear: Clearance,
    route: Route,
    /// The map with the cells under a rectangular body made free and curtains' free ends drawn
    /// as suspected glass (see [`Planner::plan_as`]).
    own: Vec<u8>,
    /// The curtains' free ends of the last map ([`jamb::curtain_ends`]).
    ends: Vec<usize>,
    /// Suspected glass too near a solid or glass cell for the body to pass ([`narrow`]).
    narrow: Vec<usize>,
    /// The maneuver search's buffers ([`Planner::maneuver`]).
    maneuver: maneuver::Scratch,
}

impl Planner {
    /// A planner with `params`.
    pub fn new(params: PlannerParams) -> Self {
        let p = &params.planner;
        Planner {
            kernels: KernelCache::new(p.kernel_cells, p.padding_cells, p.kernel_angles),
            tight: params.tight(),
            params,
            cost: Vec::new(),
            inflate: inflate::Scratch::default(),
            clear: Clearance::default(),
            route: Route::default(),
            own: Vec::new(),
            ends: Vec::new(),
            narrow: Vec::new(),
            maneuver: maneuver::Scratch::default(),
        }
    }

    /// The settings.
    pub fn params(&self) -> &PlannerParams {
        &self.params
    }

    /// Plans one step on a map of cell `classes` from the velocity (v0, ω0) towards `goal`
    /// (robot frame, m).
    pub fn plan(
        &mut self,
        classes: &[u8],
        grid: GridSpec,
        v0: f64,
        omega0: f64,
        goal: (f64, f64),
    ) -> DwaOutcome {
        self.plan_as(Mode::Forward, classes, grid, (v0, omega0), goal)
    }

    /// [`Planner::plan`] backing out ([`dwa::back_out`]): the step of a robot the dynamic window
    /// held still.
    pub fn back_out(
        &mut self,
        classes: &[u8],
        grid: GridSpec,
        v0: f64,
        omega0: f64,
        goal: (f64, f64),
    ) -> DwaOutcome {
        self.plan_as(Mode::Back, classes, grid, (v0, omega0), goal)
    }

    /// One step planned as `mode` says ([`Planner::plan`] and [`Planner::back_out`] are two
    /// of them).
    pub fn plan_as(
        &mut self,
        mode: Mode,
        classes: &[u8],
        grid: GridSpec,
        (v0, omega0): (f64, f64),
        goal: (f64, f64),
    ) -> DwaOutcome {
        let p = match mode {
            Mode::Tight => &self.tight,
            Mode::Forward | Mode::Back => &self.params,
        };
        if classes.len() != grid.len() || grid.is_empty() {
            return DwaOutcome::Blocked;
        }
        // Nothing solid can be where the robot's body is (it would have touched it): a cell
        // under a rectangular body marked solid or glass — a pane drawn along its line through
        // the robot, a corner's stray return — is a mapping error, and left in place it blocks
        // every motion at once (Spot stood still for the rest of its run). The round body keeps
        // the map as it is: its centre test stops it inside an obstacle, as before.
        let mut own = match p.robot.body() {
            body @ Body::Rectangle { .. } => free_under_body(classes, grid, &body, &mut self.own),
            _ => false,
        };
        // the cells beside the body that no rollout may bring it nearer, read from the map before
        // anything under a rectangular body is freed. A round body too (stop 72): its centre's
        // clearance is a cell centre's, and on an impassable hedge the Turtlebot 2, squeezing
        // along it, grazed a bush whose edge cells kept their clearance as it came nearer
        let within = dwa::guard_m(grid) + GUARD_BAND_M;
        self.clear.set_guard(classes, grid, &p.robot.body(), within);
        // the reach of the dynamic window and of the clearance it reads
        let reach = p.reach_m();
        let near = reach as f32 + 2.0 * grid.cell_m;
        // a curtain's free end is kept off as a pane's end is ([`jamb`]): the pane that may go on
        // from it is seen only square on, and a body crossing the curtain at a slant sweeps it
        // (a long body too since the mapper passes a curtain's lone solid cells, stop 60: before,
        // those held Spot back from curtains, and marking the ends turned it to cross at a worse
        // slant)
        if p.planner.curtain_ends {
            let read = if own { &self.own[..] } else { classes };
            // ahead of the body's back: the rollouts drive forward
            let behind = (p.robot.body().enclosing_radius_m() + p.planner.margin_m) as f32;
            jamb::curtain_ends(read, grid, (behind.min(near), near), &mut self.ends);
            own |= mark(
                &mut self.own,
                own,
                classes,
                &self.ends,
                cell_class::SUSPECTED_GLASS,
            );
        }
        // suspected glass no body could pass even if it were open: glass for the route, whose
        // coarse test would otherwise find a way through a sliver beside a pane's end ([`narrow`];
        // the dynamic window treats suspected glass as glass anyway). A long body only: measured
        // on the tune worlds it took Spot out of the corners where a pane meets a wall and gave
        // the Turtlebot 2 nothing (docs/evaluation.md, stop 68)
        if p.planner.route_cell_m > 0.0
            && p.planner.route_suspect_weight > 0.0
            && matches!(p.robot.body(), Body::Rectangle { .. })
        {
            let read = if own { &self.own[..] } else { classes };
            narrow::too_narrow(read, grid, p.pass_need_m(), &mut self.narrow);
            own |= mark(&mut self.own, own, classes, &self.narrow, cell_class::GLASS);
        }
        let classes = if own { &self.own[..] } else { classes };
        inflate::plan_cost(
            classes,
            grid,
            self.kernels.get(p.planner.inflation, goal.1.atan2(goal.0)),
            p.passable_cost,
            &mut self.cost,
            &mut self.inflate,
        );
        // squeezing through, the margin is smaller from solids only: glass keeps the full one
        // (a pane goes on unseen; a wall or a bush does not)
        let glass_nearer = match mode {
            Mode::Tight => (self.params.planner.margin_m - p.planner.margin_m).max(0.0) as f32,
            Mode::Forward | Mode::Back => 0.0,
        };
        self.clear
            .compute_glass_nearer(classes, grid, near, 5.0, glass_nearer);
        let route = if p.planner.route_cell_m > 0.0 {
            self.route.build(
                &p.route_params(reach as f32),
                grid,
                classes,
                &self.cost,
                (goal.0 as f32, goal.1 as f32),
            );
            Some(&self.route)
        } else {
            None
        };
        if mode == Mode::Back {
            let (cost, clear) = (&self.cost, &self.clear);
            return dwa::back_out(p, grid, cost, clear, (v0, omega0), goal, route);
        }
        let (cap, turning_cap) = glass_speed_caps(p, classes, grid);
        dwa::plan_capped_turning(
            p,
            grid,
            &self.cost,
            &self.clear,
            (v0, omega0),
            (cap, turning_cap),
            goal,
            route,
        )
    }

    /// A rectangular body's way out by straight moves and turns on the spot ([`maneuver`]) on
    /// the map of the last plan, with its clearance and route: to the first pose the route
    /// counts [`MANEUVER_GAIN_M`] nearer the goal. `prev` is the move being made, if any.
    /// `None` for a round body, without a route, or with no such way within
    /// [`MANEUVER_RADIUS_M`].
    pub fn maneuver(
        &mut self,
        grid: GridSpec,
        prev: Option<maneuver::Move>,
    ) -> Option<maneuver::Plan> {
        let p = &self.params;
        let body = p.robot.body();
        if !matches!(body, Body::Rectangle { .. }) || p.planner.route_cell_m <= 0.0 {
            return None;
        }
        let settings = maneuver_settings(p);
        if !settings.checked(body.enclosing_radius_m()) {
            return None;
        }
        let route = &self.route;
        maneuver::search(
            &p.outline(),
            grid,
            &self.clear,
            |x, y| route.value(x, y),
            &settings,
            prev,
            &mut self.maneuver,
        )
    }

    /// True when the body fits at every one of `poses` (robot frame: x, y m, heading rad) on the
    /// map of the last plan, as a maneuver's poses must: each point of its outline at least
    /// the maneuver's need from obstacles, or no nearer than the body is where it stands.
    pub fn maneuver_holds(
        &self,
        grid: GridSpec,
        poses: impl IntoIterator<Item = [f64; 3]>,
    ) -> bool {
        let outline = self.params.outline();
        let least = |pose| maneuver::least_clearance(&outline, grid, &self.clear, pose);
        let need = maneuver_settings(&self.params)
            .need_m
            .min(least([0.0; 3]) - 1e-6);
        need > 0.0 && poses.into_iter().all(|pose| least(pose) >= need)
    }

    /// The planning cost of the last map (eq. 11), 0–255 per cell.
    pub fn cost(&self) -> &[u8] {
        &self.cost
    }

    /// The route of the last map.
    pub fn route(&self) -> &Route {
        &self.route
    }

    /// Sets the discs of suspected glass given up (x, y, radius; robot frame, m) for the plans
    /// that follow ([`Route::set_given_up`]).
    pub fn set_given_up(&mut self, discs: impl IntoIterator<Item = (f32, f32, f32)>) {
        self.route.set_given_up(discs);
    }

    /// Sets the lengths to the goal beyond the map the route's border starts from
    /// ([`Route::set_beyond`]).
    pub fn set_beyond(&mut self, beyond: Option<&crate::memory::Beyond>) {
        self.route.set_beyond(beyond);
    }
}

/// A maneuver ([`Planner::maneuver`]) ends where the route is this much shorter, m: past a
/// door's jambs for a body that had to turn into it.
pub const MANEUVER_GAIN_M: f64 = 1.0;

/// How far from the robot a maneuver may lead, m (its poses' centres): inside the clearance the
/// dynamic window computes, with the body's reach.
pub const MANEUVER_RADIUS_M: f64 = 2.0;

/// The maneuver search's settings for `p`: the lattice of 10 cm moves, a turn costing what
/// driving costs in the same time (at `recovery_mps` and half the top turn rate), a cusp
/// 0.3 m, the end where the body can turn on the spot (its enclosing circle
/// `inside_margin_share` of the margin from obstacles), and every point of the outline kept `inside_margin_share` of the margin from
/// obstacles (what the dynamic window allows a body already inside its margin) and half the
/// outline's spacing.
pub fn maneuver_settings(p: &PlannerParams) -> maneuver::Settings {
    let pl = &p.planner;
    maneuver::Settings {
        step_m: 0.1,
        radius_m: MANEUVER_RADIUS_M,
        turn_m_per_rad: pl.recovery_mps / maneuver_turn_rps(p),
        cusp_m: 0.3,
        gain_m: MANEUVER_GAIN_M,
        need_m: pl.inside_margin_share * pl.margin_m + 0.5 * params::OUTLINE_SPACING_M,
        turn_room_m: p.robot.body().enclosing_radius_m() + pl.inside_margin_share * pl.margin_m,
        max_expanded: 30_000,
    }
}

/// The turn rate of a maneuver's turns on the spot: half the robot's top, rad/s.
pub fn maneuver_turn_rps(p: &PlannerParams) -> f64 {
    (0.5 * p.robot.max_angular_rps).max(1e-3)
}

/// Beyond [`dwa::guard_m`], how far from the body a cell is still guarded, m: farther ones the
/// clearance keeps off.
const GUARD_BAND_M: f64 = 0.06;

/// Which plan [`Planner::plan_as`] makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Forward, the footprint kept `planner.margin_m` from solid and glass cells.
    Forward,
    /// Forward squeezing through: the footprint kept `planner.tight_margin_m` from solid cells
    /// instead of `planner.margin_m` (the route's and the dynamic window's); glass and
    /// suspected glass keep the full margin, since a pane may go on unseen where a wall or a
    /// bush does not.
    Tight,
    /// Backing out ([`dwa::back_out`]).
    Back,
}

/// The top speeds near glass (`planner.glass_slow_mps` with glass at the body's edge, rising
/// linearly to the robot's top speed `planner.glass_slow_within_m` away from it), from the
/// nearest glass cell — or post standing alone on open floor, which frames unseen panes — ahead of the robot's
/// centre (x > 0 in the map's robot frame; glass behind it is not driven into). Infinite with no
/// glass that near, or with the limit off.
///
/// Issue 22, item 3: a pane returns light only where a beam meets it squarely, so the parts of
/// a pane the robot has not faced appear in the map late — a door's far edge, the rest of a
/// pane past a post. Slower near the glass already seen, the robot stops within what it sees
/// later, and the point where its beams meet the pane squarely slides along the pane more
/// slowly, so more of it is seen per metre driven.
///
/// With `planner.glass_slow_beside` (on by default; a round body only) a glass or
/// suspected-glass cell outside the body's lane (its half width and `planner.margin_m` either
/// side of the heading) whose pane runs along the heading ([`along_heading`]) does not limit the
/// speed: driving beside a pane does not bring the body to it — driving straight on: a turning
/// motion keeps the cap.
///
/// Two caps: for a motion that keeps its heading, and for one that turns — a pane beside the
/// lane is exempt only for the first, since a turning body's lane bends towards it. Equal
/// without `glass_slow_beside` and for a long body.
pub fn glass_speed_caps(p: &PlannerParams, classes: &[u8], grid: GridSpec) -> (f64, f64) {
    let (slow, within) = (p.planner.glass_slow_mps, p.planner.glass_slow_within_m);
    let top = p.robot.max_linear_mps;
    let none = (f64::INFINITY, f64::INFINITY);
    if within <= 0.0 || slow >= top || classes.len() != grid.len() {
        return none;
    }
    let body = p.robot.body();
    // a round body's first point to reach a pane's line is the foot of the sensor's
    // perpendicular, where the pane spikes: only a long body's corner crosses the line unseen
    let ends = p.planner.glass_slow_ends && matches!(body, Body::Rectangle { .. });
    // a long body keeps the cap beside a pane: come past the pane at speed, it reaches the door
    // at the pane's end too fast to square up to it, and must turn in or go round again
    let beside_exempt = p.planner.glass_slow_beside && !matches!(body, Body::Rectangle { .. });
    let reach = (body.enclosing_radius_m() + within) as f32 + grid.cell_m;
    let (Some((r0, c0)), Some((r1, c1))) = (grid.cell_of(0.0, -reach), grid.cell_of(reach, reach))
    else {
        return none;
    };
    // the lane the body sweeps driving straight on, with its margin
    let lane = (body.half_width_m() + p.planner.margin_m) as f32;
    let mut nearest = f64::INFINITY;
    let mut nearest_turning = f64::INFINITY;
    for r in r0.min(r1)..=r0.max(r1) {
        for c in c0.min(c1)..=c0.max(c1) {
            let class = classes[grid.index(r, c)];
            if !cell_class::blocks(class) {
                continue;
            }
            let (x, y) = grid.center_of(r, c);
            if x <= 0.0 {
                continue;
            }
            let d = body.signed_distance(f64::from(x), f64::from(y));
            // (`nearest` is never below `nearest_turning`: a cell no nearer than it changes
            // neither)
            if d >= nearest {
                continue;
            }
            if cell_class::is_glass(class) {
                nearest_turning = nearest_turning.min(d);
                let beside = beside_exempt && y.abs() > lane && along_heading(classes, grid, r, c);
                if !beside {
                    nearest = nearest.min(d);
                }
            } else if is_post(classes, grid, r, c) || ends && is_end(classes, grid, r, c) {
                nearest_turning = nearest_turning.min(d);
                nearest = nearest.min(d);
            }
        }
    }
    let cap = |d: f64| {
        if d >= within {
            f64::INFINITY
        } else {
            slow + (top - slow) * (d / within).clamp(0.0, 1.0)
        }
    };
    (cap(nearest), cap(nearest_turning))
}

/// Rows [`along_heading`] looks ahead and behind a glass cell for the rest of its pane, m.
const ALONG_M: f32 = 0.2;

/// True when the glass cell (r, c) belongs to a pane that runs along the robot's heading: a glass
/// or suspected glass cell [`ALONG_M`] ahead of it or behind it lies within a cell of its column
/// (the pane within about 15° of the heading). Driving straight on, the body passes such a pane
/// beside it (the part not yet seen goes on along the same line), so it does not limit the
/// speed where it lies outside the body's lane; a pane across the way does.
fn along_heading(classes: &[u8], grid: GridSpec, r: usize, c: usize) -> bool {
    let k = (ALONG_M / grid.cell_m).round().max(1.0) as usize;
    let n = grid.cells;
    [r.checked_sub(k), Some(r + k).filter(|&rr| rr < n)]
        .into_iter()
        .flatten()
        .any(|rr| {
            (c.saturating_sub(1)..=(c + 1).min(n - 1))
                .any(|cc| cell_class::is_glass(classes[grid.index(rr, cc)]))
        })
}

/// Half the width of the largest solid the speed limit near glass takes for a post between
/// panes, m: a mullion or a frame's joint is 5–15 cm, a structural pillar 30 cm or more.
const POST_HALF_M: f32 = 0.15;

/// True when the solid cell (r, c) is part of a post standing alone — nothing solid or passable
/// in the ring from [`POST_HALF_M`] to twice that around it (a trunk standing in grass is not
/// one). A post with nothing seen between it and its
/// neighbours is how a framed glass partition looks from most places (the panes return light
/// only where a beam meets them squarely): "an opening between solids" of issue 22, item 3.
fn is_post(classes: &[u8], grid: GridSpec, r: usize, c: usize) -> bool {
    let inner = (POST_HALF_M / grid.cell_m).ceil() as isize;
    let outer = 2 * inner;
    let n = grid.cells as isize;
    for dr in -outer..=outer {
        for dc in -outer..=outer {
            if dr.abs().max(dc.abs()) <= inner {
                continue;
            }
            let (rr, cc) = (r as isize + dr, c as isize + dc);
            if rr < 0 || cc < 0 || rr >= n || cc >= n {
                return false;
            }
            let class = classes[grid.index(rr as usize, cc as usize)];
            // a trunk in grass is no pane's post: partitions stand on open floor
            if class == cell_class::SOLID || class == cell_class::PASSABLE {
                return false;
            }
        }
    }
    true
}

/// How far from a cell [`is_end`] looks for the rest of its wall, m: the near ring beyond a
/// wall's thickness, the far one where a wall (not a post or a pair of posts) still runs on.
const END_RINGS_M: [f32; 2] = [0.3, 0.6];

/// True when the solid cell (r, c) is at a free end of a wall standing on open floor — the
/// mouth of a corridor, the jamb of a door in a wall: on each square ring [`END_RINGS_M`]
/// around it the solid cells all lie to one side ([`route::one_side`]: a wall's middle and a
/// corner are none), the same side on both rings,
/// with at least one on each (a post or a pair of posts is none; [`is_post`] takes a lone
/// post), nothing on the near ring is passable (a bush at a hedge's gap, a trunk in grass) and
/// the rings lie within the map. Glass is not counted: a pane's end beside a door has no wall
/// to go on from, and slowing there kept Spot from framed doors it passed through before. A
/// pane may go on from a wall's end unseen: a long body turning round the end swings its nose
/// across the pane's line before its sensor, at its centre, has faced any of it.
fn is_end(classes: &[u8], grid: GridSpec, r: usize, c: usize) -> bool {
    let n = grid.cells as isize;
    let (r, c) = (r as isize, c as isize);
    let mut towards: Option<(f32, f32)> = None;
    for (ring, radius) in END_RINGS_M.into_iter().enumerate() {
        let k = (radius / grid.cell_m).ceil() as isize;
        if r < k || c < k || r + k >= n || c + k >= n {
            return false;
        }
        let mut passable = false;
        let solid = |dr: isize, dc: isize| {
            let class = classes[grid.index((r + dr) as usize, (c + dc) as usize)];
            passable |= ring == 0 && class == cell_class::PASSABLE;
            class == cell_class::SOLID
        };
        let Some(dir) = route::one_side(k, solid) else {
            return false;
        };
        if passable {
            return false;
        }
        if let Some((ux, uy)) = towards
            && ux * dir.0 + uy * dir.1 < 0.9
        {
            return false;
        }
        towards = Some(dir);
    }
    true
}

/// `classes` with every solid or glass cell under `body` (at the map's centre, heading along x)
/// made free, into `out`: every cell whose centre lies within the body or within ¾ of a cell of
/// its outline, so that the cells the outline's own points fall in are free too. False, and
/// `out` untouched, when no such cell is there (the map is copied only when it changes).
fn free_under_body(classes: &[u8], grid: GridSpec, body: &Body, out: &mut Vec<u8>) -> bool {
    let edge = 0.75 * f64::from(grid.cell_m);
    let reach = body.enclosing_radius_m() as f32 + grid.cell_m;
    let (Some((r0, c0)), Some((r1, c1))) =
        (grid.cell_of(-reach, -reach), grid.cell_of(reach, reach))
    else {
        return false;
    };
    let mut copied = false;
    for r in r0.min(r1)..=r0.max(r1) {
        for c in c0.min(c1)..=c0.max(c1) {
            let i = grid.index(r, c);
            let blocking = cell_class::blocks(classes[i]);
            let (x, y) = grid.center_of(r, c);
            if blocking && body.signed_distance(f64::from(x), f64::from(y)) < edge {
                if !copied {
                    out.clear();
                    out.extend_from_slice(classes);
                    copied = true;
                }
                out[i] = cell_class::FREE;
            }
        }
    }
    copied
}

#[cfg(test)]
mod tests {
    use super::*;
    use mimnav_shared::topics::cell_class;

    /// The cap of a motion that keeps its heading.
    fn glass_speed_cap(p: &PlannerParams, classes: &[u8], grid: GridSpec) -> f64 {
        glass_speed_caps(p, classes, grid).0
    }

    /// True when the plan drives on without turning.
    fn straight(o: DwaOutcome) -> bool {
        match o {
            DwaOutcome::Drive { omega, .. } => omega.abs() < 0.05,
            DwaOutcome::Blocked => false,
        }
    }

    #[test]
    fn confirmed_obstacles_turn_grass_solid_and_bad_returns_are_ignored() {
        let grid = GridSpec {
            cells: 40,
            cell_m: 0.1,
        };
        let mut classes = vec![cell_class::PASSABLE; grid.len()];
        let n = confirm_obstacles(
            &mut classes,
            grid,
            [
                (0.0, 1.0),
                (std::f32::consts::FRAC_PI_2, 1.5),
                (0.0, f32::NAN),
                (0.0, 0.0),
                (1.0, 50.0),
            ],
        );
        assert_eq!(n, 2);
        let at = |x: f32, y: f32| {
            let (r, c) = grid.cell_of(x, y).expect("inside");
            classes[grid.index(r, c)]
        };
        assert_eq!(at(1.0, 0.0), cell_class::SOLID);
        let (sy, cy) = std::f32::consts::FRAC_PI_2.sin_cos();
        assert_eq!(at(1.5 * cy, 1.5 * sy), cell_class::SOLID);
        assert_eq!(at(-1.0, 0.0), cell_class::PASSABLE);
    }

    #[test]
    fn a_rock_confirmed_in_the_grass_ahead_is_driven_around() {
        // all grass; the classifier confirms a rock 1 m ahead across the straight way
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let mut classes = vec![cell_class::PASSABLE; grid.len()];
        let mut planner = Planner::new(PlannerParams::default());
        assert!(straight(planner.plan(&classes, grid, 0.3, 0.0, (4.0, 0.0))));
        let rock: Vec<(f32, f32)> = (-6..=6)
            .map(|k| {
                (
                    (k as f32 * 0.04).atan2(1.0),
                    (1.0f32).hypot(k as f32 * 0.04),
                )
            })
            .collect();
        confirm_obstacles(&mut classes, grid, rock);
        assert!(!straight(planner.plan(
            &classes,
            grid,
            0.3,
            0.0,
            (4.0, 0.0)
        )));
    }

    #[test]
    fn a_long_bodys_route_takes_no_sliver_of_suspected_glass_between_a_panes_end_and_a_wall() {
        // a shop front 1 m ahead, glass from the map's edge on the right to 0.05 m right of the
        // robot, its line drawn on as suspected glass for 0.42 m to a side wall across the map
        // 0.4 m to the left (a coarse cell of the route's holds nothing else), the goal behind
        // the glass: even open, the sliver is too narrow for the body, so for a long body the
        // map holds no way to the goal and the route leads off the map; a round body's route
        // still crosses it (the rule is a long body's, chosen on the tune worlds)
        let (grid, classes) = crate::clearance::tests::map(|x, y| {
            if (y - 0.4).abs() < 0.03 {
                return cell_class::SOLID;
            }
            match (x - 1.0).abs() < 0.03 {
                true if y < -0.05 => cell_class::GLASS,
                true if y < 0.37 => cell_class::SUSPECTED_GLASS,
                _ => cell_class::FREE,
            }
        });
        for (body, long) in [
            (PlannerParams::default(), false),
            (crate::dwa::tests::spot(), true),
        ] {
            let need = body.pass_need_m();
            let mut planner = Planner::new(body);
            let _ = planner.plan(&classes, grid, 0.0, 0.0, (2.0, 0.0));
            let route = planner.route();
            assert_eq!(
                route.beyond(),
                long,
                "need {need} m, long body {long}: {} m",
                route.value(0.0, 0.0)
            );
        }
    }

    #[test]
    fn a_curtains_free_end_beside_the_way_is_kept_off_as_a_panes_end() {
        // a curtain across the way ends in free floor 0.05 m left of the straight line to the
        // goal: a pane may go on from its end unseen, so the body keeps its margin from the end
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let mut classes = vec![cell_class::FREE; grid.len()];
        for k in 0..40 {
            let y = 0.075 + k as f32 * 0.05;
            if let Some((r, c)) = grid.cell_of(0.8, y) {
                classes[grid.index(r, c)] = cell_class::PASSABLE;
            }
        }
        assert!(PlannerParams::default().planner.curtain_ends);
        // a round body, and a long one (Spot's 1.1 × 0.5 m)
        for body in [PlannerParams::default(), crate::dwa::tests::spot()] {
            for on in [false, true] {
                let mut p = body.clone();
                p.planner.curtain_ends = on;
                let mut planner = Planner::new(p);
                let plan = planner.plan(&classes, grid, 0.3, 0.0, (4.0, 0.0));
                assert_eq!(straight(plan), !on, "curtain_ends {on}: {plan:?}");
            }
        }
    }

    #[test]
    fn near_glass_ahead_the_planner_slows_and_glass_behind_does_not_slow_it() {
        // a pane along y = 0.6 m beside the way ahead (not across it)
        let beside = |from: f32| {
            crate::clearance::tests::map(move |x, y| {
                if (y - 0.6).abs() < 0.03 && x > from && x < from + 3.0 {
                    cell_class::GLASS
                } else {
                    cell_class::FREE
                }
            })
        };
        let speed = |p: PlannerParams, (grid, classes): (GridSpec, Vec<u8>)| match Planner::new(p)
            .plan(&classes, grid, 0.5, 0.0, (4.0, 0.0))
        {
            DwaOutcome::Drive { v, .. } => v,
            o => panic!("{o:?}"),
        };
        // the rule itself, on a pane along the way (`glass_slow_beside`, on by default, exempts
        // it: below)
        let mut p = PlannerParams::default();
        p.planner.glass_slow_beside = false;
        // 0.4 m from the body's edge: 0.2 + (0.5 − 0.2) · 0.4 / 1.0 m/s
        let cap = glass_speed_cap(&p, &beside(0.0).1, beside(0.0).0);
        assert!((cap - 0.32).abs() < 0.03, "{cap}");
        let slowed = speed(p.clone(), beside(0.0));
        assert!(slowed <= cap + 1e-9, "{slowed} > {cap}");
        let mut off = p.clone();
        off.planner.glass_slow_within_m = 0.0;
        assert!(speed(off, beside(0.0)) > 0.45, "no limit when it is off");
        // the same pane behind the robot
        assert_eq!(
            glass_speed_cap(&p, &beside(-3.5).1, beside(-3.5).0),
            f64::INFINITY
        );
        assert!(speed(p, beside(-3.5)) > 0.45);
    }

    #[test]
    fn a_pane_along_the_way_beside_the_lane_does_not_slow_and_one_across_it_does() {
        let p = PlannerParams::default();
        assert!(p.planner.glass_slow_beside, "on by default");
        // the cap with the cells where `f` holds of class `class`, the rest free
        let cap_for = |p: &PlannerParams, class: u8, f: &dyn Fn(f32, f32) -> bool| {
            let (grid, classes) = crate::clearance::tests::map(|x, y| match f(x, y) {
                true => class,
                false => cell_class::FREE,
            });
            glass_speed_cap(p, &classes, grid)
        };
        let cap = |f: &dyn Fn(f32, f32) -> bool| cap_for(&p, cell_class::GLASS, f);
        // beside the way, 0.6 m to the left, along the heading
        let beside = |x: f32, y: f32| (y - 0.6).abs() < 0.03 && x > 0.0 && x < 3.0;
        assert_eq!(cap(&beside), f64::INFINITY);
        // the same pane, suspected: the same
        assert_eq!(
            cap_for(&p, cell_class::SUSPECTED_GLASS, &beside),
            f64::INFINITY
        );
        // a single glass cell of it, a pane's end seen alone: no pane along the way, it slows
        // (the one cell centred at (0.625, 0.625): the test grid's centres lie 0.05 m apart)
        let lone = |x: f32, y: f32| (x - 0.625).abs() < 0.01 && (y - 0.625).abs() < 0.01;
        assert!(cap(&lone) < 0.45, "{}", cap(&lone));
        // across the way 0.8 m ahead, with a door in the lane: it slows
        let across = |x: f32, y: f32| (x - 0.8).abs() < 0.03 && y.abs() > 0.45 && y.abs() < 2.0;
        assert!(cap(&across) < 0.45, "{}", cap(&across));
        // at 45° ahead on the left: it slows
        let oblique = |x: f32, y: f32| (y - x).abs() < 0.04 && x > 0.4 && x < 2.0;
        assert!(cap(&oblique) < 0.45, "{}", cap(&oblique));
        // along the way but inside the lane (0.3 m: the half width and the margin): it slows
        let inside = |x: f32, y: f32| (y - 0.25).abs() < 0.03 && x > 0.5 && x < 3.0;
        assert!(cap(&inside) < 0.45, "{}", cap(&inside));
        // ... but not a turning motion, whose lane bends towards it
        let (grid, classes) = crate::clearance::tests::map(|x, y| match beside(x, y) {
            true => cell_class::GLASS,
            false => cell_class::FREE,
        });
        let (straight, turning) = glass_speed_caps(&p, &classes, grid);
        assert_eq!(straight, f64::INFINITY);
        assert!(turning < 0.4, "{turning}");
        // a pane across the way beyond the one beside: the straight motion slows for it, though
        // the nearer pane beside does not slow it
        let (grid, both) =
            crate::clearance::tests::map(|x, y| match beside(x, y) || across(x, y) {
                true => cell_class::GLASS,
                false => cell_class::FREE,
            });
        let (straight, _) = glass_speed_caps(&p, &both, grid);
        assert!(straight < 0.45, "{straight}");
        // off, the pane beside slows as before, both motions
        let mut off = p.clone();
        off.planner.glass_slow_beside = false;
        assert!(cap_for(&off, cell_class::GLASS, &beside) < 0.4);
        let (straight, turning) = glass_speed_caps(&off, &classes, grid);
        assert_eq!(straight, turning);
        // a long body: the pane beside slows it, key on or off
        let mut spot = crate::dwa::tests::spot();
        spot.planner.glass_slow_beside = true;
        let (straight, turning) = glass_speed_caps(&spot, &classes, grid);
        assert!(straight < 0.5, "{straight}");
        assert_eq!(straight, turning);
    }

    #[test]
    fn a_post_standing_alone_slows_like_glass_and_a_wall_does_not() {
        let p = PlannerParams::default();
        // a 0.15 m post 0.6 m ahead and 0.5 m to the left: a framed pane's joint
        let (grid, post) = crate::clearance::tests::map(|x, y| {
            if (x - 0.6).abs() < 0.075 && (y - 0.5).abs() < 0.075 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert!(glass_speed_cap(&p, &post, grid) < 0.4);
        // a wall in the same place, running on ahead: no limit
        let (grid, wall) = crate::clearance::tests::map(|x, y| {
            if x > 0.5 && (y - 0.5).abs() < 0.075 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert_eq!(glass_speed_cap(&p, &wall, grid), f64::INFINITY);
        // the post standing in grass: a trunk
        let trunk: Vec<u8> = post
            .iter()
            .map(|&c| match c {
                cell_class::FREE => cell_class::PASSABLE,
                c => c,
            })
            .collect();
        assert_eq!(glass_speed_cap(&p, &trunk, grid), f64::INFINITY);
    }

    #[test]
    fn without_a_route_to_the_goal_the_planner_creeps_and_says_so() {
        // a wall all round the robot, 1.5 m away: it can move, but never reach the goal
        let (grid, classes) = crate::clearance::tests::map(|x, y| {
            if (x.hypot(y) - 1.5).abs() < 0.05 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let p = PlannerParams::default();
        // it drives on towards the wall as the paper's DWA does, slowly, and says it has no route
        match Planner::new(p.clone()).plan(&classes, grid, 0.3, 0.0, (3.0, 0.0)) {
            DwaOutcome::Drive { v, routed, .. } => {
                assert!(!routed);
                assert!(v <= p.planner.glass_slow_mps + 1e-9, "{v}");
            }
            o => panic!("{o:?}"),
        }
        // a goal inside the wall has a route
        assert!(matches!(
            Planner::new(p).plan(&classes, grid, 0.0, 0.0, (1.0, 0.0)),
            DwaOutcome::Drive { routed: true, .. }
        ));
    }

    #[test]
    fn a_stray_glass_cell_under_a_rectangular_body_does_not_freeze_it() {
        // a pane drawn along its line through Spot's front corner; the real glass beyond
        let (grid, classes) = crate::clearance::tests::map(|x, y| {
            let on_line = (y - (x - 0.45)).abs() < 0.04;
            if on_line && x > 0.4 {
                cell_class::GLASS
            } else {
                cell_class::FREE
            }
        });
        let mut p = PlannerParams::default();
        (p.robot.radius_m, p.robot.length_m, p.robot.width_m) = (0.6, 1.1, 0.5);
        let mut spot = Planner::new(p.clone());
        match spot.plan(&classes, grid, 0.0, 0.0, (-3.0, 0.0)) {
            DwaOutcome::Drive { .. } => {}
            o => panic!("backs away from the pane: {o:?}"),
        }
        // the glass outside the body stays: a rollout through it is refused
        let mut straight = p;
        straight.planner.omega_samples = 1;
        straight.robot.max_angular_rps = 0.0;
        let mut ahead = Planner::new(straight);
        assert!(
            !matches!(
                ahead.plan(&classes, grid, 0.5, 0.0, (3.0, 0.0)),
                DwaOutcome::Drive { v, .. } if v > 0.3
            ),
            "drives into the pane"
        );
    }

    /// Issue 22: Spot turning into a glass corridor's mouth touched a pane that went on, unseen,
    /// from the end of the wall beside the mouth. With `glass_slow_ends` a wall's free end ahead
    /// limits a long body's speed as glass does; the wall's middle and a corner do not, nor an
    /// end behind, nor any end a round body's.
    #[test]
    fn a_walls_free_end_ahead_slows_like_glass_when_asked() {
        let mut p = PlannerParams::default();
        p.planner.glass_slow_ends = true;
        (p.robot.length_m, p.robot.width_m) = (1.1, 0.5);
        // a wall along y = 0.5 m ending 0.6 m ahead of the robot, running on to the left edge
        let (grid, ending) = crate::clearance::tests::map(|x, y| {
            if x < 0.6 && x > -4.0 && (y - 0.5).abs() < 0.05 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        let cap = glass_speed_cap(&p, &ending, grid);
        assert!(cap < 0.4, "{cap}");
        let mut off = p.clone();
        off.planner.glass_slow_ends = false;
        assert_eq!(glass_speed_cap(&off, &ending, grid), f64::INFINITY);
        // a round body is not slowed by a wall's end: it faces a pane before it can touch it
        let mut round = p.clone();
        (round.robot.length_m, round.robot.width_m) = (0.0, 0.0);
        assert_eq!(glass_speed_cap(&round, &ending, grid), f64::INFINITY);
        // the same wall running on past the robot: no end near
        let (grid, through) = crate::clearance::tests::map(|x, y| {
            if x > -4.0 && x < 4.0 && (y - 0.5).abs() < 0.05 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert_eq!(glass_speed_cap(&p, &through, grid), f64::INFINITY);
        // a corner ahead: the wall turns away from the robot at x = 0.6 m
        let (grid, corner) = crate::clearance::tests::map(|x, y| {
            let along = x < 0.65 && x > -4.0 && (y - 0.5).abs() < 0.05;
            let up = (x - 0.6).abs() < 0.05 && y > 0.45 && y < 4.0;
            if along || up {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert_eq!(glass_speed_cap(&p, &corner, grid), f64::INFINITY);
        // a pair of posts ahead (a framed door's jamb), and a pane ending there: no wall's end
        let (grid, pair) = crate::clearance::tests::map(|x, y| {
            let post = |cx: f32| (x - cx).abs() < 0.06 && (y - 0.5).abs() < 0.06;
            if post(0.6) || post(0.75) {
                cell_class::SOLID
            } else if x < 0.55 && x > -4.0 && (y - 0.5).abs() < 0.03 {
                cell_class::GLASS
            } else {
                cell_class::FREE
            }
        });
        assert_eq!(
            glass_speed_cap(&p, &pair, grid),
            glass_speed_cap(&off, &pair, grid),
            "slowed by the pane only"
        );
        let pair: Vec<u8> = pair
            .iter()
            .map(|&c| match c {
                cell_class::GLASS => cell_class::FREE,
                c => c,
            })
            .collect();
        assert_eq!(
            glass_speed_cap(&p, &pair, grid),
            glass_speed_cap(&off, &pair, grid)
        );
        // the end behind the robot
        let (grid, behind) = crate::clearance::tests::map(|x, y| {
            if x < -0.6 && x > -4.0 && (y - 0.5).abs() < 0.05 {
                cell_class::SOLID
            } else {
                cell_class::FREE
            }
        });
        assert_eq!(glass_speed_cap(&p, &behind, grid), f64::INFINITY);
    }
}
