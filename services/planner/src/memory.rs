//! What the route remembers beyond the local map (issue 22: a partition at a steep angle).
//!
//! The map is local (`grid.cells` × `grid.cell_m`, 10 m a side by default) and the route
//! ([`crate::route`]) assumes the world beyond its border open. A robot that drove along a
//! glass partition to its far end, where the goal lies behind the glass, turns back towards the
//! opening; a few metres on the pane at the goal's end leaves the map, the straight line to the
//! goal looks open again and the robot turns round — back and forth until its time runs out
//! (three of the Turtlebot 2's six timeouts on the tuning partitions of seed 300, traced at
//! stop 65). The way off the map stays a guess through what was never seen (the route's
//! `beyond`): the memory only turns it away from what the robot has seen closed.
//!
//! [`Memory`] keeps the solid and glass cells of every map the planner was given (and the
//! suspected glass), in the odometry frame on a coarse lattice, for `planner.route_memory_s`
//! and within `planner.route_memory_m` of the robot; a cell the current map covers is what the
//! current map says. [`Memory::beyond`] searches the lengths to the goal over that lattice (a
//! cell with anything solid or glass closed, one with suspected glass costing
//! `planner.route_suspect_weight` more a metre, the rest open — what was never seen is still
//! assumed open) and hands them to the route, which starts its border cells from them instead
//! of from their straight-line distance.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};
use std::hash::{BuildHasherDefault, Hasher};

use mimnav_shared::grid::GridSpec;
use mimnav_shared::pose::{Pose2, Pose2Ext};
use mimnav_shared::topics::cell_class;

// the route's 16 moves (straight, diagonal and knight moves: lengths within 3 % of the straight
// line's)
use crate::route::MOVES;

/// The remembered lattice's cell, m: coarser than the route's (a wall is a line of cells; the
/// 3721 cells within 15 m take about half a millisecond to search, spread over maps).
pub const CELL_M: f64 = 0.5;
/// The lengths are searched again when the robot has moved this far since the last search, m
/// (or the goal moved, or [`FIELD_EVERY_NS`] passed).
const FIELD_MOVE_M: f64 = 2.0;
/// ... or this long after the last search, ns.
const FIELD_EVERY_NS: u64 = 2_000_000_000;
/// [`Memory::take_in`] reads a map at most this often, ns: what it records matters once it has
/// left the map, and reading a whole map costs a fifth of a plan.
pub const UPDATE_EVERY_NS: u64 = 300_000_000;
/// The lattice cells a search settles per map ([`Memory::beyond`]'s `budget` in the pilot): a
/// field of 15 m is 3721 cells, searched over about ten maps (a second at 10 Hz).
pub const SEARCH_CELLS_PER_MAP: usize = 400;

/// The two cells a move passes beside (a straight move: its target twice), which must not be
/// closed: no move slips between two closed cells touching at a corner.
fn beside((dr, dc): (i32, i32)) -> [(i32, i32); 2] {
    match (dr.abs(), dc.abs()) {
        (1, 1) => [(dr, 0), (0, dc)],
        (2, 1) => [(dr / 2, 0), (dr / 2, dc)],
        (1, 2) => [(0, dc / 2), (dr, dc / 2)],
        _ => [(dr, dc), (dr, dc)],
    }
}

/// A hasher for lattice indices (multiply and rotate, as rustc's own `FxHasher`): the keys are
/// small integers from the robot's own maps, which need no protection against chosen collisions.
#[derive(Debug, Clone, Copy, Default)]
struct LatticeHasher(u64);

impl LatticeHasher {
    fn add(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

impl Hasher for LatticeHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.add(u64::from(b));
        }
    }

    fn write_i32(&mut self, i: i32) {
        self.add(u64::from(i as u32));
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// The remembered lattice cells.
type Lattice = HashMap<(i32, i32), Kept, BuildHasherDefault<LatticeHasher>>;

/// What a remembered cell held.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Kept {
    /// Something solid or glass (else suspected glass only).
    closed: bool,
    /// When a map last showed it, ns.
    seen_ns: u64,
}

/// Lengths to the goal over the remembered lattice, for the route's border
/// ([`crate::route::Route::set_beyond`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Beyond {
    /// The goal these lengths lead to, robot frame (the route uses them for this goal only).
    pub goal: (f32, f32),
    /// The robot in the odometry frame: x, y, yaw.
    pose: (f64, f64, f64),
    /// Lattice index of the field's first cell.
    origin: (i32, i32),
    /// Cells per side.
    cells: usize,
    /// Length to the goal from each cell's centre (infinite: no way known), m.
    lengths: Vec<f32>,
    /// What each cell holds: 0 nothing remembered, 1 suspected glass, 2 closed.
    kinds: Vec<u8>,
    /// The goal, odometry frame.
    goal_odom: (f64, f64),
    /// A search has filled these lengths.
    ready: bool,
}

impl Beyond {
    /// The length to the goal from robot-frame point (x, y): the nearest lattice cell's length
    /// and the way to its centre; `None` outside the field or where it knows no way.
    pub fn length(&self, x: f32, y: f32) -> Option<f32> {
        let (px, py, yaw) = self.pose;
        let (s, c) = yaw.sin_cos();
        let (x, y) = (f64::from(x), f64::from(y));
        let (ox, oy) = (px + c * x - s * y, py + s * x + c * y);
        let (i, j) = key(ox, oy);
        let (r, k) = (i - self.origin.0, j - self.origin.1);
        let n = self.cells as i32;
        if !(0..n).contains(&r) || !(0..n).contains(&k) {
            return None;
        }
        let d = self.lengths[r as usize * self.cells + k as usize];
        if !d.is_finite() {
            return None;
        }
        // nothing remembered between here and the goal: the straight line, as without a memory
        let (gx, gy) = self.goal_odom;
        let straight = (gx - ox).hypot(gy - oy);
        let steps = (straight / (0.5 * CELL_M)).ceil() as usize;
        let clear = (1..=steps).all(|s| {
            let t = s as f64 / steps as f64;
            let (i, j) = key(ox + t * (gx - ox), oy + t * (gy - oy));
            let (r, k) = (i - self.origin.0, j - self.origin.1);
            // past the field's edge nothing is known
            !(0..n).contains(&r)
                || !(0..n).contains(&k)
                || self.kinds[r as usize * self.cells + k as usize] == 0
        });
        if clear {
            return Some(straight as f32);
        }
        let (cx, cy) = centre(i, j);
        Some(d + (ox - cx).hypot(oy - cy) as f32)
    }
}

/// The solids, glass and suspected glass of past maps, on a coarse lattice in the odometry
/// frame.
#[derive(Debug, Clone, Default)]
pub struct Memory {
    cells: Lattice,
    /// When the last search began.
    last: Option<Searched>,
    /// The lengths of the last search done.
    field: Beyond,
    /// The search under way.
    search: Option<Search>,
    /// A finished search's buffers, for the next.
    spare: Option<Search>,
    /// When [`Memory::take_in`] last read a map.
    read_ns: Option<u64>,
}

/// What the last search was for.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Searched {
    /// Where the robot was (odometry frame).
    at: (f64, f64),
    /// The goal (odometry frame).
    goal: (f64, f64),
    /// When, ns.
    ns: u64,
    /// The suspected glass's weight.
    weight: f32,
}

/// The lattice cell holding odometry-frame point (x, y).
fn key(x: f64, y: f64) -> (i32, i32) {
    (
        (x / CELL_M).floor().clamp(-1e9, 1e9) as i32,
        (y / CELL_M).floor().clamp(-1e9, 1e9) as i32,
    )
}

/// The centre of lattice cell (i, j), odometry frame.
fn centre(i: i32, j: i32) -> (f64, f64) {
    ((f64::from(i) + 0.5) * CELL_M, (f64::from(j) + 0.5) * CELL_M)
}

impl Memory {
    /// Cells remembered.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether nothing is remembered.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// [`Memory::update`] with a map, unless one was read less than [`UPDATE_EVERY_NS`] before.
    pub fn take_in(
        &mut self,
        pose: &Pose2,
        classes: &[u8],
        grid: GridSpec,
        now: u64,
        keep_ns: u64,
        keep_m: f64,
    ) {
        if (self.read_ns).is_none_or(|t| now.saturating_sub(t) >= UPDATE_EVERY_NS) {
            self.update(pose, classes, grid, now, keep_ns, keep_m);
            self.read_ns = Some(now);
        }
    }

    /// Takes in one map (`classes` on `grid`, the robot at `pose` in the odometry frame) at
    /// `now`: its solid, glass and suspected-glass cells are remembered, a remembered cell the
    /// map covers and no longer shows is forgotten, and so is one older than `keep_ns` or
    /// farther than `keep_m` from the robot.
    pub fn update(
        &mut self,
        pose: &Pose2,
        classes: &[u8],
        grid: GridSpec,
        now: u64,
        keep_ns: u64,
        keep_m: f64,
    ) {
        if classes.len() != grid.len() {
            return;
        }
        let n = grid.cells;
        let (sin, cos) = pose.yaw().sin_cos();
        let (px, py) = (pose.x(), pose.y());
        // a map row's cells fall on a lattice cell ten at a time: each lattice cell is looked up
        // once for its run
        let mut run: Option<((i32, i32), bool)> = None;
        let cells = &mut self.cells;
        let mut flush = |run: Option<((i32, i32), bool)>| {
            if let Some((k, closed)) = run {
                let e = cells.entry(k).or_insert(Kept {
                    closed,
                    seen_ns: now,
                });
                // within one map a lattice cell takes the worst of its map cells
                e.closed = (e.seen_ns == now && e.closed) || closed;
                e.seen_ns = now;
            }
        };
        for (r, row) in classes.chunks_exact(n).enumerate() {
            let (x, _) = grid.center_of(r, 0);
            let x = f64::from(x);
            for (c, &class) in row.iter().enumerate() {
                let closed = match class {
                    cell_class::SOLID | cell_class::GLASS => true,
                    cell_class::SUSPECTED_GLASS => false,
                    _ => continue,
                };
                let (_, y) = grid.center_of(r, c);
                let y = f64::from(y);
                let k = key(px + cos * x - sin * y, py + sin * x + cos * y);
                match &mut run {
                    Some((at, worst)) if *at == k => *worst |= closed,
                    _ => flush(run.replace((k, closed))),
                }
            }
        }
        flush(run);
        // a lattice cell wholly inside the map is what this map says
        let inner = f64::from(grid.half_extent_m()) - CELL_M * std::f64::consts::SQRT_2;
        let (rx, ry) = (pose.x(), pose.y());
        self.cells.retain(|&(i, j), k| {
            let (cx, cy) = centre(i, j);
            let (lx, ly) = pose.to_local(cx, cy);
            let covered = lx.abs() < inner && ly.abs() < inner;
            k.seen_ns == now
                || (!covered
                    && now.saturating_sub(k.seen_ns) <= keep_ns
                    && (cx - rx).hypot(cy - ry) <= keep_m)
        });
    }

    /// The lengths to `goal` (odometry frame; `goal_local` the same in the robot frame) over
    /// the remembered lattice within `radius_m` of the robot at `pose`; `None` while none are
    /// known for this goal (the route's border then starts from the straight line).
    /// `suspect_weight`: what a metre through suspected glass costs more (0: closed, as the
    /// route does).
    ///
    /// The lengths are searched again once the robot moved [`FIELD_MOVE_M`], or
    /// [`FIELD_EVERY_NS`] passed, or the goal moved, since the last search began; a search
    /// settles at most `budget` lattice cells a call and goes on at the next (a few thousand
    /// cells in all: a whole search at once would be a plan's time every second), and the
    /// lengths it replaces serve until it is done.
    #[allow(clippy::too_many_arguments)]
    pub fn beyond(
        &mut self,
        pose: &Pose2,
        goal: (f64, f64),
        goal_local: (f32, f32),
        now: u64,
        radius_m: f64,
        suspect_weight: f32,
        budget: usize,
    ) -> Option<&Beyond> {
        let here = (pose.x(), pose.y());
        let same_goal = |g: (f64, f64)| (g.0 - goal.0).hypot(g.1 - goal.1) < 1e-6;
        let due = self.last.is_none_or(|l| {
            (l.at.0 - here.0).hypot(l.at.1 - here.1) >= FIELD_MOVE_M
                || !same_goal(l.goal)
                || now.saturating_sub(l.ns) >= FIELD_EVERY_NS
                || l.weight != suspect_weight
        });
        // a search under way for this goal finishes first
        let busy = self
            .search
            .as_ref()
            .is_some_and(|s| same_goal(s.goal) && s.weight == suspect_weight);
        if due && !busy {
            self.start(here, goal, radius_m, suspect_weight);
            self.last = Some(Searched {
                at: here,
                goal,
                ns: now,
                weight: suspect_weight,
            });
        }
        if let Some(search) = &mut self.search
            && search.run(budget)
        {
            let f = &mut self.field;
            f.origin = search.origin;
            f.cells = search.cells;
            std::mem::swap(&mut f.lengths, &mut search.lengths);
            std::mem::swap(&mut f.kinds, &mut search.open);
            f.goal_odom = search.goal;
            f.ready = true;
            self.spare = self.search.take();
        }
        let f = &mut self.field;
        if !(f.ready && same_goal(f.goal_odom)) {
            return None;
        }
        f.goal = goal_local;
        f.pose = (pose.x(), pose.y(), pose.yaw());
        Some(&self.field)
    }

    /// Begins a search from the goal (its cell, if on the field; else every border cell with
    /// its straight-line distance) over the field around `here`.
    fn start(&mut self, here: (f64, f64), goal: (f64, f64), radius_m: f64, suspect_weight: f32) {
        let half = (radius_m / CELL_M).ceil().clamp(1.0, 400.0) as i32;
        let (ci, cj) = key(here.0, here.1);
        let origin = (ci - half, cj - half);
        let cells = (2 * half + 1) as usize;
        let m = cells * cells;
        let mut s = self.spare.take().unwrap_or_default();
        s.origin = origin;
        s.cells = cells;
        s.goal = goal;
        s.weight = suspect_weight;
        // 0 open, 1 suspected, 2 closed
        s.open.clear();
        s.open.resize(m, 0);
        for (&(i, j), k) in &self.cells {
            let (r, c) = (i - origin.0, j - origin.1);
            if (0..cells as i32).contains(&r) && (0..cells as i32).contains(&c) {
                let closed = k.closed || suspect_weight <= 0.0;
                s.open[r as usize * cells + c as usize] = if closed { 2 } else { 1 };
            }
        }
        s.lengths.clear();
        s.lengths.resize(m, f32::INFINITY);
        s.heap.clear();
        let (gi, gj) = key(goal.0, goal.1);
        let (gr, gc) = (gi - origin.0, gj - origin.1);
        let n = cells as i32;
        if (0..n).contains(&gr) && (0..n).contains(&gc) {
            s.seed(gr, gc);
        } else {
            for k in 0..n {
                for (r, c) in [(0, k), (n - 1, k), (k, 0), (k, n - 1)] {
                    if s.open[r as usize * cells + c as usize] != 2 {
                        s.seed(r, c);
                    }
                }
            }
        }
        self.search = Some(s);
    }
}

/// A search of the lengths to the goal under way (Dijkstra's, over [`MOVES`]).
#[derive(Debug, Clone, Default)]
struct Search {
    /// Lattice index of the field's first cell.
    origin: (i32, i32),
    /// Cells per side.
    cells: usize,
    /// The goal, odometry frame.
    goal: (f64, f64),
    /// The suspected glass's weight.
    weight: f32,
    /// What each cell holds: 0 nothing remembered, 1 suspected glass, 2 closed.
    open: Vec<u8>,
    /// The lengths so far.
    lengths: Vec<f32>,
    heap: BinaryHeap<Entry>,
}

impl Search {
    /// Starts the search at cell (r, c) with its centre's straight-line distance to the goal.
    fn seed(&mut self, r: i32, c: i32) {
        let k = r as usize * self.cells + c as usize;
        let (x, y) = centre(r + self.origin.0, c + self.origin.1);
        let d = (self.goal.0 - x).hypot(self.goal.1 - y) as f32;
        if d < self.lengths[k] {
            self.lengths[k] = d;
            self.heap.push(Entry(d, k));
        }
    }

    /// Settles up to `budget` cells; whether the search is done.
    fn run(&mut self, budget: usize) -> bool {
        let (cells, n) = (self.cells, self.cells as i32);
        let step = CELL_M as f32;
        let mut settled = 0usize;
        while let Some(Entry(d, k)) = self.heap.pop() {
            if d > self.lengths[k] {
                continue;
            }
            let (r, c) = ((k / cells) as i32, (k % cells) as i32);
            for (dr, dc) in MOVES {
                let (rr, cc) = (r + dr, c + dc);
                if !(0..n).contains(&rr) || !(0..n).contains(&cc) {
                    continue;
                }
                let to = rr as usize * cells + cc as usize;
                let kind = self.open[to];
                if kind == 2
                    || beside((dr, dc)).iter().any(|&(br, bc)| {
                        self.open[(r + br) as usize * cells + (c + bc) as usize] == 2
                    })
                {
                    continue;
                }
                let len = step * ((dr * dr + dc * dc) as f32).sqrt();
                let extra = if kind == 1 { self.weight } else { 0.0 };
                let nd = d + len * (1.0 + extra);
                if nd < self.lengths[to] {
                    self.lengths[to] = nd;
                    self.heap.push(Entry(nd, to));
                }
            }
            settled += 1;
            if settled >= budget {
                return self.heap.is_empty();
            }
        }
        true
    }
}

/// A heap entry ordered by length, shortest first.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry(f32, usize);

impl Eq for Entry {}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other.0.total_cmp(&self.0).then(other.1.cmp(&self.1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mimnav_shared::pose::pose2;

    /// A map `side` cells of 5 cm a side.
    fn grid(side: usize) -> GridSpec {
        GridSpec {
            cells: side,
            cell_m: 0.05,
        }
    }

    /// A map on `g` with `class` where `at` says (robot frame), free elsewhere.
    fn map(g: GridSpec, class: u8, at: impl Fn(f32, f32) -> bool) -> Vec<u8> {
        (0..g.len())
            .map(|i| {
                let (x, y) = g.center_of(i / g.cells, i % g.cells);
                if at(x, y) { class } else { cell_class::FREE }
            })
            .collect()
    }

    #[test]
    fn a_wall_left_behind_is_remembered_and_led_round() {
        let g = grid(400);
        let mut mem = Memory::default();
        // a wall along x = 2 from y = -1 on, seen as the robot drives along it
        let wall = |at: f64| {
            let p = pose2(0.0, at, 0.0);
            let m = map(g, cell_class::SOLID, |x, y| {
                (1.95..2.05).contains(&x) && f64::from(y) + at > -1.0
            });
            (p, m)
        };
        for (k, at) in [0.0, 10.0, 20.0].into_iter().enumerate() {
            let (p, m) = wall(at);
            mem.update(&p, &m, g, k as u64, u64::MAX, 30.0);
        }
        // 25 m on, its start is off the map
        let (far, m) = wall(25.0);
        mem.update(&far, &m, g, 3, u64::MAX, 30.0);
        assert!(!mem.is_empty(), "kept off the map");
        // the goal beyond the wall: the way from the map's border nearest it (robot frame
        // (0, -10), odometry (0, 15)) leads round the wall's end at y = -1
        let goal = (4.0, 0.0);
        let local = far.to_local(goal.0, goal.1);
        let local = (local.0 as f32, local.1 as f32);
        let b = (mem.beyond(&far, goal, local, 3, 30.0, 10.0, usize::MAX))
            .expect("searched")
            .clone();
        let len = b.length(0.0, -10.0).expect("a way");
        let straight = 4.0f32.hypot(15.0);
        // (round the lattice's cells at the wall's end: up to a few metres more)
        let round = 2.0f32.hypot(16.0) + 2.0f32.hypot(1.0);
        assert!(
            (round..round + 3.0).contains(&len),
            "{len} against {round} round"
        );
        assert!(len > straight + 1.5, "{len} against {straight} straight");
        // nothing remembered: the straight line
        let mut none = Memory::default();
        let len = none
            .beyond(&far, goal, local, 3, 30.0, 10.0, usize::MAX)
            .and_then(|b| b.length(0.0, -10.0));
        let len = len.expect("a way");
        assert!((len - straight).abs() < 0.5, "{len} against {straight}");
        // off the field: nothing known
        assert_eq!(b.length(0.0, -40.0), None);
    }

    #[test]
    fn what_the_map_covers_now_is_what_it_shows() {
        let g = grid(100);
        let origin = pose2(0.0, 0.0, 0.0);
        let mut mem = Memory::default();
        let wall = map(g, cell_class::GLASS, |x, _| (1.95..2.05).contains(&x));
        let nothing = map(g, cell_class::GLASS, |_, _| false);
        mem.update(&origin, &wall, g, 1, u64::MAX, 30.0);
        let had = mem.len();
        assert!(had >= 5, "{had}");
        // the same place, the wall gone (a door opened): forgotten where the map covers it
        mem.update(&origin, &nothing, g, 2, u64::MAX, 30.0);
        assert!(mem.len() < had, "{} of {had} kept", mem.len());
        // cells off the map now are kept; too old or too far, forgotten
        mem.update(&origin, &wall, g, 3, u64::MAX, 30.0);
        mem.update(&pose2(0.0, 20.0, 0.0), &nothing, g, 4, u64::MAX, 30.0);
        assert_eq!(mem.len(), had);
        mem.update(&pose2(0.0, 20.0, 0.0), &nothing, g, 10, 5, 30.0);
        assert!(mem.is_empty(), "older than keep_ns");
        mem.update(&origin, &wall, g, 11, u64::MAX, 30.0);
        mem.update(&pose2(0.0, 40.0, 0.0), &nothing, g, 12, u64::MAX, 30.0);
        assert!(mem.is_empty(), "farther than keep_m");
    }

    #[test]
    fn suspected_glass_costs_and_closes_without_a_weight() {
        // a line of suspected glass right across the field (a 20 m map, a field of 8 m)
        let g = grid(400);
        let line = map(g, cell_class::SUSPECTED_GLASS, |x, _| {
            (1.95..2.05).contains(&x)
        });
        let p = pose2(0.0, 0.0, 0.0);
        let mut mem = Memory::default();
        mem.update(&p, &line, g, 1, u64::MAX, 30.0);
        let goal = (6.0, 0.0);
        let closed = mem
            .beyond(&p, goal, (6.0, 0.0), 1, 8.0, 0.0, usize::MAX)
            .and_then(|b| b.length(1.0, 0.0));
        assert_eq!(closed, None, "no way round a closed line");
        let crossed = mem
            .beyond(&p, goal, (6.0, 0.0), 2, 8.0, 10.0, usize::MAX)
            .and_then(|b| b.length(1.0, 0.0));
        let crossed = crossed.expect("crossed at a cost");
        // 5 m and half a metre through it at 10 more a metre
        assert!((9.0..12.0).contains(&crossed), "{crossed}");
        // solids over 3 m of it close that stretch: the way crosses beside it, longer
        let both = map(g, cell_class::SOLID, |x, y| {
            (1.95..2.05).contains(&x) && y.abs() < 1.5
        });
        let both: Vec<u8> = (both.iter().zip(&line))
            .map(|(&a, &b)| if a == cell_class::SOLID { a } else { b })
            .collect();
        // (searched again seconds later)
        mem.update(&p, &both, g, 5_000_000_000, u64::MAX, 30.0);
        let round = mem
            .beyond(&p, goal, (6.0, 0.0), 5_000_000_000, 8.0, 10.0, usize::MAX)
            .and_then(|b| b.length(1.0, 0.0));
        assert!(
            round.expect("round") > crossed,
            "{round:?} against {crossed}"
        );
    }

    #[test]
    fn a_search_spread_over_maps_gives_the_lengths_of_one_at_once() {
        let g = grid(400);
        let wall = map(g, cell_class::GLASS, |x, y| {
            (1.95..2.05).contains(&x) && y > -3.0
        });
        let p = pose2(0.0, 0.0, 0.0);
        let goal = (6.0, 0.0);
        let mut once = Memory::default();
        once.update(&p, &wall, g, 1, u64::MAX, 30.0);
        let whole = (once.beyond(&p, goal, (6.0, 0.0), 1, 15.0, 10.0, usize::MAX))
            .expect("searched at once")
            .clone();
        let mut spread = Memory::default();
        spread.update(&p, &wall, g, 1, u64::MAX, 30.0);
        let mut calls = 1;
        while spread
            .beyond(
                &p,
                goal,
                (6.0, 0.0),
                1 + calls,
                15.0,
                10.0,
                SEARCH_CELLS_PER_MAP,
            )
            .is_none()
        {
            calls += 1;
            assert!(calls < 50, "never done");
        }
        assert!((4..20).contains(&calls), "{calls} maps");
        let spread = spread.beyond(&p, goal, (6.0, 0.0), 2, 15.0, 10.0, 0);
        assert_eq!(spread, Some(&whole));
    }
}
