//! Glass panes: every spike sighting over time, fitted as segments with their evidence, extended
//! along the fitted line while nothing contradicts it, and kept by the angles they were seen from.
//!
//! A pane returns light to the sensor only near normal incidence (DESIGN §6; the intensity spike
//! of `cartographer-glass.txt`). So one spike says two things: a point of the pane (the spike's
//! returns) and the pane's orientation — the beam at the centre of the spike *is* the pane's
//! normal, because the spike is symmetric about normal incidence. As the robot moves, the foot of
//! its perpendicular on the pane slides along it, and with it the spot the spike comes from: the
//! sightings of one pane fall on one line. [`Panes`] gathers them in the odometry frame
//! (equation 6 of `mim-lidar-intensity-navigation.txt`: I_FN^t = T · (I_{z=0} ⊖ I_{z=−ε}), the
//! spike cells the −ε layer does not see, moved by the odometry T) and keeps their union
//! (equation 7: I_FN^{t+1} = I_FN^{t+1} ∪ I_FN^t; every detected cell is drawn as glass while
//! it is remembered, whatever is seen later).
//!
//! Each pane's line is fitted to its evidence (the spike returns; while they span less than
//! [`FIT_SPAN_M`], the mean of the normals the spikes were seen along). The pane is drawn along
//! that line over its evidence and, beyond it and across gaps in it, up to `glass_extend_m`
//! from the nearest evidence — until something contradicts it:
//! - a beam that crossed the line within `glass_normal_deg` of the line's normal and returned
//!   from beyond it, in a revolution whose ring shows no spike near that normal at all: glass
//!   there would have returned the spike (the *open* evidence, kept like the glass evidence: an
//!   opening seen once stays open, and glass evidence in the same spot wins over it) — also
//!   from the revolutions before the pane was seen (`HISTORY` of them), tested once when it is
//!   first drawn: a pane is seen first where the foot of the sensor's perpendicular reaches
//!   glass, and on the way along a partition the foot may have crossed its opening before that;
//! - a solid or passable cell of this revolution on the line (a frame, a wall, a curtain in the
//!   way: the pane ends there), or an unknown cell that something nearer hides (the inside of the
//!   pillar a pane meets: its far side is not this pane's to close).
//!
//! Past the part of an opening seen squarely the line is drawn on again (up to `glass_extend_m`
//! from it): an opening is as wide as it was seen — unless the line meets something solid first
//! (then it is a passage beside a frame). Its far edge — a pane's end — returns no spike
//! to a robot beside the opening (the nearest point of a pane's end is not where a beam meets it
//! squarely), and a robot that turned into an opening seen only in part struck that edge in the
//! tuning runs.
//!
//! Beams that cross the line at other angles say nothing: glass lets them through. This is how
//! Visagge (Foster et al., cited in `cartographer-glass.txt`) keeps glass by the angles it was
//! seen from, and how Cartographer_glass keeps detected glass against later misses: a miss
//! counts only from an angle where glass would have given a return.

use std::collections::{HashMap, VecDeque};

use mimnav_shared::grid::GridSpec;
use mimnav_shared::pose::{Pose2, Pose2Ext};
use mimnav_shared::topics::cell_class;

use crate::glass::Frame;

/// A sighting joins a pane whose normal is within this of its own, rad (5°).
const JOIN_ANGLE_RAD: f64 = 5.0 * std::f64::consts::PI / 180.0;
/// ... and whose line passes within this of the sighting's centre, m.
const JOIN_OFFSET_M: f64 = 0.2;
/// Evidence spanning less than this along the pane is fitted by its normals, not its points, m.
pub const FIT_SPAN_M: f64 = 1.0;
/// A beam must end at least this far beyond the line to count as passing through it, m.
const BEYOND_M: f64 = 0.25;
/// A pane is extended only once it has been seen in at least this many revolutions: one stray
/// spike does not draw a line across the map.
const MIN_REVOLUTIONS: u32 = 2;
/// Lines nearer the sensor than this are not tested for openings (the beams cross them at
/// angles the robot's own motion blurs), m.
const MIN_TEST_M: f64 = 0.3;

/// How far [`Panes::draw`] draws a pane's line on where it was not seen
/// (`mapper.glass_extend_m`, `glass_mullion_m`, `glass_passage_m`), m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reach {
    /// Up to this far from the pane's evidence (0: only the evidence).
    pub extend_m: f64,
    /// Past a solid stretch this short with the line going on beyond it (a post).
    pub mullion_m: f64,
    /// A stretch from what was seen open to a solid or passable cell up to this long is the rest
    /// of a passage beside a frame: not drawn.
    pub passage_m: f64,
}

/// One spike seen in one revolution, in the robot frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    /// Centre of the spike's returns, m.
    pub x: f64,
    /// Centre of the spike's returns, m.
    pub y: f64,
    /// Unit normal of the pane (the beam direction at the spike's centre), x.
    pub nx: f64,
    /// Unit normal, y.
    pub ny: f64,
}

/// A return of a near-horizontal ring as the opening test needs it (robot frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayReturn {
    /// Azimuth, degrees clockwise from x, [0, 360) (the sensor's convention).
    pub azimuth_deg: f32,
    /// Position, m.
    pub x: f32,
    /// Position, m.
    pub y: f32,
    /// Part of an intensity spike.
    pub spike: bool,
    /// Where the sensor fired the beam from, m (robot frame, de-skewed as the return: a moving
    /// sensor fires from behind where the revolution ends).
    pub origin: (f32, f32),
}

/// One near-horizontal ring, in firing order, with the index of its first return in each whole
/// degree of azimuth, so a pane's normal finds its few returns without a pass over the ring.
#[derive(Debug, Clone, Default)]
pub struct Ring {
    returns: Vec<RayReturn>,
    first: Vec<u32>,
}

impl Ring {
    /// Empties the ring.
    pub fn clear(&mut self) {
        self.returns.clear();
        self.first.clear();
        self.first.resize(360, u32::MAX);
    }

    /// Appends a return (in firing order: azimuth growing, wrapping once at 360°).
    pub fn push(&mut self, r: RayReturn) {
        if self.first.len() != 360 {
            self.first.resize(360, u32::MAX);
        }
        let d = (r.azimuth_deg as usize).min(359);
        if self.first[d] == u32::MAX {
            self.first[d] = self.returns.len() as u32;
        }
        self.returns.push(r);
    }

    /// Calls `f` with every return whose azimuth lies within `half_deg` of `centre_deg`
    /// (whole degrees: a few more than that).
    fn around(&self, centre_deg: f64, half_deg: f64, mut f: impl FnMut(&RayReturn)) {
        if self.returns.is_empty() {
            return;
        }
        let lo = (centre_deg - half_deg).floor() as i64;
        let hi = (centre_deg + half_deg).floor() as i64;
        for d in lo..=hi {
            let d = d.rem_euclid(360) as usize;
            let start = self.first[d];
            if start == u32::MAX {
                continue;
            }
            for r in &self.returns[start as usize..] {
                if (r.azimuth_deg as usize).min(359) != d {
                    break;
                }
                f(r);
            }
        }
    }
}

/// Evidence kept in the odometry frame, one entry per cell-sized key.
type Evidence = HashMap<(i64, i64), (f64, f64, u64)>;

/// One pane: its glass and open evidence and its fitted line (odometry frame).
#[derive(Debug, Clone)]
struct Pane {
    glass: Evidence,
    open: Evidence,
    /// Sum of the sightings' doubled normal angles (cos, sin): the axial mean normal.
    normal_sum: (f64, f64),
    /// A point of the line and its unit direction.
    line: ((f64, f64), (f64, f64)),
    revolutions: u32,
    last_revolution_ns: u64,
    /// The past revolutions' beams have been tested against the line (once, when the pane is
    /// first drawn).
    replayed: bool,
}

impl Pane {
    /// Refits the line to the glass evidence (total least squares once it is long enough, the
    /// mean normal before).
    fn refit(&mut self) {
        let n = self.glass.len() as f64;
        if n == 0.0 {
            return;
        }
        let (mut sx, mut sy) = (0.0, 0.0);
        for &(x, y, _) in self.glass.values() {
            sx += x;
            sy += y;
        }
        let (mx, my) = (sx / n, sy / n);
        let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
        for &(x, y, _) in self.glass.values() {
            let (dx, dy) = (x - mx, y - my);
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        }
        let along = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let (ux, uy) = (along.cos(), along.sin());
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &(x, y, _) in self.glass.values() {
            let s = (x - mx) * ux + (y - my) * uy;
            lo = lo.min(s);
            hi = hi.max(s);
        }
        let dir = if hi - lo >= FIT_SPAN_M {
            (ux, uy)
        } else {
            // the normal's axial mean, turned a quarter
            let a = 0.5 * self.normal_sum.1.atan2(self.normal_sum.0);
            (-a.sin(), a.cos())
        };
        self.line = ((mx, my), dir);
    }

    /// Whether a sighting (odometry frame: centre and normal angle) lies on this pane's line.
    fn accepts(&self, (x, y): (f64, f64), normal_angle: f64) -> bool {
        let ((px, py), (ux, uy)) = self.line;
        let offset = (-(x - px) * uy + (y - py) * ux).abs();
        // axial difference between the sighting's normal and the line's normal (-uy, ux)
        let d = (normal_angle - ux.atan2(-uy)).rem_euclid(std::f64::consts::PI);
        let d = d.min(std::f64::consts::PI - d);
        offset <= JOIN_OFFSET_M && d <= JOIN_ANGLE_RAD
    }
}

/// What [`Panes::draw`] added to the map.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Drawn {
    /// Cells of glass evidence drawn.
    pub evidence: u32,
    /// Cells drawn by extending panes along their lines.
    pub extended: u32,
}

/// Every pane seen, in the odometry frame.
#[derive(Debug, Clone, Default)]
pub struct Panes {
    panes: Vec<Pane>,
    cell_m: f64,
    /// Scratch per bin along a line: 0 unknown, 1 glass, 2 open.
    bins: Vec<u8>,
    bin_cells: Vec<Option<usize>>,
    reach: Vec<bool>,
    /// Scratch per bin: a post the extension passes.
    post: Vec<bool>,
    /// The near-horizontal rings of past revolutions, newest last: a pane is seen first where
    /// the foot of the sensor's perpendicular reaches glass, and an opening the foot passed
    /// before that (on the way along a partition) would otherwise be drawn over as suspected
    /// glass.
    history: VecDeque<Past>,
}

/// The rings of one past revolution and where they were seen from.
#[derive(Debug, Clone)]
struct Past {
    pose: Pose2,
    now_ns: u64,
    rings: Vec<Ring>,
}

/// Past revolutions kept for a pane seen later: at most this many, ...
const HISTORY: usize = 32;
/// ... one each time the sensor has moved this far (a robot standing still adds nothing), m:
/// 3.2 m of driving. A beam within `glass_normal_deg` (2.8°) of the normal covers 10 cm of a
/// line 1 m away, and one stretch of open evidence is enough to stop a pane's extension.
const HISTORY_STEP_M: f64 = 0.1;
/// Returns each kept ring has room for from the start: a VLP-16 laser's firings in one
/// revolution at 600 rpm (about 1810), rounded up. A longer ring (a slower sensor) grows its
/// buffer once.
const HISTORY_RING_RETURNS: usize = 2048;

/// An unseen stretch of a pane's line between two stretches seen open, no longer than this, is
/// not drawn, m: open evidence comes from a narrow cone round the normal (2·d·tan
/// `glass_normal_deg`: 4 cm on a line 0.4 m away) and from past rings `HISTORY_STEP_M` apart,
/// so an opening passed close by is seen open in strips with holes between; drawn, a hole of
/// one cell closed a 1.32 m opening to the Turtlebot 2's body and margin (tune world
/// `glass-partition s1700 i2`). No pane stands this narrow between two openings; a post
/// between panes is solid (`glass_mullion_m`).
const OPEN_GAP_M: f64 = 0.2;

const UNSEEN: u8 = 0;
const GLASS: u8 = 1;
const OPEN: u8 = 2;

fn key(x: f64, y: f64, cell_m: f64) -> (i64, i64) {
    ((x / cell_m).floor() as i64, (y / cell_m).floor() as i64)
}

impl Panes {
    /// No panes; evidence closer than `cell_m` merges.
    pub fn new(cell_m: f64) -> Self {
        Panes {
            cell_m: cell_m.max(1e-3),
            ..Panes::default()
        }
    }

    /// Panes held.
    pub fn len(&self) -> usize {
        self.panes.len()
    }

    /// True when no pane is held.
    pub fn is_empty(&self) -> bool {
        self.panes.is_empty()
    }

    /// Glass evidence entries held (all panes).
    pub fn evidence_len(&self) -> usize {
        self.panes.iter().map(|p| p.glass.len()).sum()
    }

    /// Keeps this revolution's `rings` for panes seen later, when the sensor has moved
    /// [`HISTORY_STEP_M`] since the last kept.
    fn keep(&mut self, pose: &Pose2, now_ns: u64, rings: &[Ring]) {
        if let Some(last) = self.history.back()
            && (last.pose.x() - pose.x()).hypot(last.pose.y() - pose.y()) < HISTORY_STEP_M
        {
            return;
        }
        // a revolution without near-horizontal returns adds nothing when replayed
        if rings.iter().all(|r| r.returns.is_empty()) {
            return;
        }
        if self.history.is_empty() {
            self.reserve_history(pose, now_ns, rings);
        }
        // the oldest's buffers reused once the history is full
        let mut rings_kept = match self.history.len() >= HISTORY {
            true => self
                .history
                .pop_front()
                .map(|p| p.rings)
                .unwrap_or_default(),
            false => Vec::new(),
        };
        // the rings with returns (most are empty), and of them only the beams that can pass a
        // line the opening test looks at (squared lengths: this runs after the last packet)
        let least = (MIN_TEST_M + BEYOND_M).powi(2) as f32;
        let full = rings.iter().filter(|r| !r.returns.is_empty());
        rings_kept.resize_with(full.clone().count(), Ring::default);
        for (kept, ring) in rings_kept.iter_mut().zip(full) {
            kept.clear();
            for r in &ring.returns {
                let (dx, dy) = (r.x - r.origin.0, r.y - r.origin.1);
                if dx * dx + dy * dy >= least {
                    kept.push(*r);
                }
            }
        }
        self.history.push_back(Past {
            pose: *pose,
            now_ns,
            rings: rings_kept,
        });
    }

    /// Fills the history with empty revolutions (they add no evidence when replayed) whose
    /// rings are allocated and written once, as many as `rings` has with returns, each for the
    /// longest of them and at least [`HISTORY_RING_RETURNS`]: the history's memory is taken
    /// at the first revolution with near-horizontal returns, not over the first metres driven
    /// (and a soak sees the service's heap flat).
    fn reserve_history(&mut self, pose: &Pose2, now_ns: u64, rings: &[Ring]) {
        let full = rings.iter().filter(|r| !r.returns.is_empty());
        let count = full.clone().count();
        let cap = full
            .map(|r| r.returns.len())
            .fold(HISTORY_RING_RETURNS, usize::max);
        let blank = RayReturn {
            azimuth_deg: 0.0,
            x: 0.0,
            y: 0.0,
            spike: false,
            origin: (0.0, 0.0),
        };
        for _ in 0..HISTORY {
            let rings = (0..count)
                .map(|_| {
                    let mut ring = Ring {
                        returns: vec![blank; cap],
                        first: Vec::new(),
                    };
                    ring.clear();
                    ring
                })
                .collect();
            self.history.push_back(Past {
                pose: *pose,
                now_ns,
                rings,
            });
        }
    }

    /// The bytes the history's rings hold allocated.
    #[cfg(test)]
    fn history_bytes(&self) -> usize {
        let ring = |r: &Ring| {
            r.returns.capacity() * std::mem::size_of::<RayReturn>()
                + r.first.capacity() * std::mem::size_of::<u32>()
        };
        self.history
            .iter()
            .map(|p| p.rings.iter().map(ring).sum::<usize>())
            .sum()
    }

    /// Adds one revolution seen from `pose` at `now_ns` (equations 6 and 7): the sightings with
    /// their spike returns (`points[k]` for the sighting `owner[k]`, robot frame), then, for every
    /// pane, the open evidence of the `rings` (the returns within `normal_rad` of a pane's normal
    /// that passed its line without a spike), for panes within `max_m`.
    #[allow(clippy::too_many_arguments)]
    pub fn observe(
        &mut self,
        pose: &Pose2,
        now_ns: u64,
        sightings: &[Sighting],
        points: &[(f32, f32, u32)],
        rings: &[Ring],
        normal_rad: f64,
        max_m: f64,
    ) {
        let frame = Frame::of(pose);
        let yaw = pose.yaw();
        let cell_m = self.cell_m;
        let mut owner = vec![usize::MAX; sightings.len()];
        for (k, s) in sightings.iter().enumerate() {
            let c = frame.to_odom(s.x, s.y);
            let angle = s.ny.atan2(s.nx) + yaw;
            let found = self.panes.iter().position(|p| p.accepts(c, angle));
            let j = match found {
                Some(j) => j,
                None => {
                    let (ux, uy) = (-angle.sin(), angle.cos());
                    self.panes.push(Pane {
                        glass: HashMap::new(),
                        open: HashMap::new(),
                        normal_sum: (0.0, 0.0),
                        line: (c, (ux, uy)),
                        revolutions: 0,
                        last_revolution_ns: u64::MAX,
                        replayed: false,
                    });
                    self.panes.len() - 1
                }
            };
            owner[k] = j;
            let p = &mut self.panes[j];
            p.normal_sum.0 += (2.0 * angle).cos();
            p.normal_sum.1 += (2.0 * angle).sin();
            if p.last_revolution_ns != now_ns {
                p.last_revolution_ns = now_ns;
                p.revolutions += 1;
            }
        }
        for &(x, y, s) in points {
            let Some(&j) = owner.get(s as usize) else {
                continue;
            };
            let (ox, oy) = frame.to_odom(f64::from(x), f64::from(y));
            self.panes[j]
                .glass
                .insert(key(ox, oy, cell_m), (ox, oy, now_ns));
        }
        for &j in &owner {
            if j != usize::MAX {
                self.panes[j].refit();
            }
        }
        // open evidence: beams near a pane's normal that passed its line without a spike
        for p in &mut self.panes {
            open_evidence(p, pose, now_ns, rings, normal_rad, max_m, cell_m);
        }
        // a pane drawn for the first time (seen in `MIN_REVOLUTIONS`): the beams of past
        // revolutions that crossed its line squarely before anything of it was seen
        for p in &mut self.panes {
            if p.revolutions >= MIN_REVOLUTIONS && !p.replayed {
                p.replayed = true;
                for past in &self.history {
                    open_evidence(
                        p,
                        &past.pose,
                        past.now_ns,
                        &past.rings,
                        normal_rad,
                        max_m,
                        cell_m,
                    );
                }
            }
        }
        self.keep(pose, now_ns, rings);
    }

    /// Forgets evidence older than `max_age_ns` or farther than `max_m` from `pose`, and panes
    /// left without glass evidence.
    pub fn expire(&mut self, pose: &Pose2, now_ns: u64, max_age_ns: u64, max_m: f64) {
        let (x0, y0) = (pose.x(), pose.y());
        let keep = |e: &mut (f64, f64, u64)| {
            now_ns.saturating_sub(e.2) <= max_age_ns && (e.0 - x0).hypot(e.1 - y0) <= max_m
        };
        for p in &mut self.panes {
            let before = p.glass.len();
            p.glass.retain(|_, e| keep(e));
            p.open.retain(|_, e| keep(e));
            if p.glass.len() != before {
                p.refit();
            }
        }
        self.panes.retain(|p| !p.glass.is_empty());
    }

    /// Draws the panes into `classes`/`cost` seen from `pose`: the evidence as glass (over
    /// anything but solid), and each pane seen in two revolutions or more extended along its line
    /// as suspected glass ([`cell_class::SUSPECTED_GLASS`]) up to `extend_m` from its evidence,
    /// stopping at open evidence, at a solid or passable cell (past a solid no longer than
    /// `mullion_m` with the line going on beyond it: a post), at an unknown cell something nearer
    /// hides (`occluded`: the inside of a pillar the pane meets) and at the grid's edge; a
    /// stretch from open evidence to a solid or passable cell no longer than `passage_m`, and one
    /// between two stretches of open evidence no longer than [`OPEN_GAP_M`], are not drawn.
    /// Returns what was drawn.
    pub fn draw(
        &mut self,
        pose: &Pose2,
        grid: GridSpec,
        Reach {
            extend_m,
            mullion_m,
            passage_m,
        }: Reach,
        classes: &mut [u8],
        cost: &mut [u8],
        occluded: impl Fn(usize) -> bool,
    ) -> Drawn {
        let frame = Frame::of(pose);
        let mut drawn = Drawn::default();
        let bin_m = f64::from(grid.cell_m) * 0.5;
        let cell = |x: f64, y: f64| -> Option<usize> {
            let (rx, ry) = frame.to_robot(x, y);
            grid.cell_of(rx as f32, ry as f32)
                .map(|(r, c)| grid.index(r, c))
        };
        for p in &self.panes {
            // the evidence itself (equation 7's union)
            for &(x, y, _) in p.glass.values() {
                if let Some(i) = cell(x, y)
                    && classes[i] != cell_class::SOLID
                {
                    if !cell_class::is_glass(classes[i]) {
                        drawn.evidence += 1;
                    }
                    classes[i] = cell_class::GLASS;
                    cost[i] = 255;
                }
            }
            if extend_m <= 0.0 || p.revolutions < MIN_REVOLUTIONS {
                continue;
            }
            let ((px, py), (ux, uy)) = p.line;
            let along = |x: f64, y: f64| (x - px) * ux + (y - py) * uy;
            let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
            for &(x, y, _) in p.glass.values().chain(p.open.values()) {
                let s = along(x, y);
                lo = lo.min(s);
                hi = hi.max(s);
            }
            let (lo, hi) = (lo - extend_m, hi + extend_m);
            let n = ((hi - lo) / bin_m).ceil() as usize + 1;
            self.bins.clear();
            self.bins.resize(n, UNSEEN);
            let bin = |s: f64| ((s - lo) / bin_m).round() as isize;
            // an entry stands for its cell: the bins on either side of it too (a bin is half a
            // cell); glass over open where they meet
            for (evidence, state) in [(&p.open, OPEN), (&p.glass, GLASS)] {
                for &(x, y, _) in evidence.values() {
                    let b = bin(along(x, y));
                    for b in b - 1..=b + 1 {
                        if (0..n as isize).contains(&b) {
                            self.bins[b as usize] = state;
                        }
                    }
                }
            }
            self.bin_cells.clear();
            self.reach.clear();
            self.reach.resize(n, false);
            for b in 0..n {
                let s = lo + b as f64 * bin_m;
                self.bin_cells.push(cell(px + s * ux, py + s * uy));
            }
            let blocked = |c: Option<usize>| {
                c.is_none_or(|i| {
                    classes[i] == cell_class::SOLID
                        || classes[i] == cell_class::PASSABLE
                        || (classes[i] == cell_class::UNKNOWN && occluded(i))
                })
            };
            let limit = (extend_m / bin_m).round() as usize;
            let passage_bins = (passage_m / bin_m).round() as usize;
            let gap_bins = (OPEN_GAP_M / bin_m).round() as usize;
            // a solid stretch of the line no longer than `mullion_m`, with the line going on
            // beyond it, is a post between panes (a mullion, a frame's joint), not the pane's
            // end: the run goes on past it (a framed partition seen at a slant showed its
            // posts and none of the panes between them, and Spot walked into one)
            self.post.clear();
            self.post.resize(n, false);
            let post_bins = (mullion_m / bin_m).round() as usize;
            let mut b = 0;
            while b < n {
                if self.bins[b] != UNSEEN || !blocked(self.bin_cells[b]) {
                    b += 1;
                    continue;
                }
                let from = b;
                while b < n && self.bins[b] == UNSEEN && blocked(self.bin_cells[b]) {
                    b += 1;
                }
                let inside = from > 0 && b < n && self.bin_cells[from - 1].is_some();
                if inside && b - from <= post_bins && self.bin_cells[b].is_some() {
                    self.post[from..b].fill(true);
                }
            }
            // forward, then backward: an unseen bin is reached within `limit` bins of evidence,
            // glass or open, with nothing solid or passable between; a run from open evidence
            // that ends at something solid or passable within `passage_m` is dropped — the rest
            // of an opening between a frame and what was seen open (a passage beside a pillar),
            // not a pane that may go on past a door. A longer one is kept: a partition's far pane
            // running from the door to the room's wall
            for forward in [true, false] {
                let mut run: Option<(usize, bool)> = None;
                let mut run_bins: Vec<usize> = Vec::new();
                for k in 0..n {
                    let b = if forward { k } else { n - 1 - k };
                    match self.bins[b] {
                        GLASS => {
                            run = Some((0, false));
                            run_bins.clear();
                        }
                        OPEN => {
                            // a short hole between two stretches seen open: one opening
                            // sampled in strips, not a pane (`OPEN_GAP_M`)
                            if run.is_some_and(|(r, from_open)| from_open && r <= gap_bins) {
                                for &q in &run_bins {
                                    self.reach[q] = false;
                                }
                            }
                            run = Some((0, true));
                            run_bins.clear();
                        }
                        _ if self.post[b] => {
                            run = run.map(|(r, o)| (r + 1, o)).filter(|&(r, _)| r <= limit);
                        }
                        _ if blocked(self.bin_cells[b]) => {
                            if run.is_some_and(|(r, from_open)| from_open && r <= passage_bins) {
                                for &q in &run_bins {
                                    self.reach[q] = false;
                                }
                            }
                            run = None;
                            run_bins.clear();
                        }
                        _ => {
                            run = run.map(|(r, o)| (r + 1, o)).filter(|&(r, _)| r <= limit);
                            if run.is_some() {
                                if !self.reach[b] {
                                    run_bins.push(b);
                                }
                                self.reach[b] = true;
                            } else {
                                run_bins.clear();
                            }
                        }
                    }
                }
            }
            // drawn as suspected glass: a pane's line where the pane was not seen may be glass
            // or an opening never faced, and the planner treats the two apart
            for b in 0..n {
                if self.reach[b]
                    && let Some(i) = self.bin_cells[b]
                    && !cell_class::is_glass(classes[i])
                {
                    classes[i] = cell_class::SUSPECTED_GLASS;
                    cost[i] = 255;
                    drawn.extended += 1;
                }
            }
        }
        drawn
    }
}

/// The open evidence of one revolution seen from `pose` for pane `p`: the returns of `rings`
/// within `normal_rad` of the pane's normal that passed its line without a spike, the pane
/// within `max_m`.
fn open_evidence(
    p: &mut Pane,
    pose: &Pose2,
    now_ns: u64,
    rings: &[Ring],
    normal_rad: f64,
    max_m: f64,
    cell_m: f64,
) {
    let frame = Frame::of(pose);
    let yaw = pose.yaw();
    let (sx, sy) = (pose.x(), pose.y());
    let ((px, py), (ux, uy)) = p.line;
    // the foot of the sensor's perpendicular on the line, and its distance
    let s_foot = (sx - px) * ux + (sy - py) * uy;
    let (fx, fy) = (px + s_foot * ux, py + s_foot * uy);
    let (nx, ny) = (fx - sx, fy - sy);
    let d = nx.hypot(ny);
    if !(MIN_TEST_M..=max_m).contains(&d) {
        return;
    }
    // the normal's bearing in the robot frame, and as the sensor's azimuth (clockwise)
    let normal_bearing = ny.atan2(nx) - yaw;
    let centre_deg = (-normal_bearing.to_degrees()).rem_euclid(360.0);
    let open = &mut p.open;
    let half_deg = normal_rad.to_degrees() + 1.0;
    // the unit normal towards the line: a beam fired from elsewhere than the sensor
    // where the revolution ends is as far from the line as its origin
    let (cn, sn) = (nx / d, ny / d);
    for ring in rings {
        // a spike near the normal: glass is there, and the beams beside it are at the
        // edge of its cone (or beyond the pane's end, which the next revolutions see
        // squarely as the robot moves on)
        let mut spiked = false;
        ring.around(centre_deg, half_deg, |r| spiked |= r.spike);
        if spiked {
            continue;
        }
        ring.around(centre_deg, half_deg, |r| {
            // the beam, from where it was fired (robot frame)
            let (bx, by) = (r.origin.0, r.origin.1);
            let (rx, ry) = (f64::from(r.x - bx), f64::from(r.y - by));
            let bearing = ry.atan2(rx);
            let off = wrap(bearing - normal_bearing);
            if off.abs() > normal_rad {
                return;
            }
            // the origin in the odometry frame, and its distance to the line
            let (ox, oy) = frame.to_odom(f64::from(bx), f64::from(by));
            let d_origin = d - ((ox - sx) * cn + (oy - sy) * sn);
            if d_origin < MIN_TEST_M {
                return;
            }
            let t = d_origin / off.cos();
            if rx.hypot(ry) < t + BEYOND_M {
                return;
            }
            // where the beam crossed the line (odometry frame)
            let b = bearing + yaw;
            let (cx, cy) = (ox + t * b.cos(), oy + t * b.sin());
            open.insert(key(cx, cy, cell_m), (cx, cy, now_ns));
        });
    }
}

/// An angle wrapped into (−π, π].
fn wrap(a: f64) -> f64 {
    let t = (a + std::f64::consts::PI).rem_euclid(2.0 * std::f64::consts::PI);
    t - std::f64::consts::PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use mimnav_shared::pose::pose2;

    /// A pane along y = −0.5 m beside a robot at the origin heading along x.
    fn pane_beside() -> Panes {
        let mut panes = Panes::new(0.05);
        let sighting = Sighting {
            x: 0.0,
            y: -0.5,
            nx: 0.0,
            ny: -1.0,
        };
        let at = pose2(0.0, 0.0, 0.0);
        panes.observe(&at, 1, &[sighting], &[(0.0, -0.5, 0)], &[], 0.035, 10.0);
        assert_eq!(panes.len(), 1);
        panes
    }

    /// The opening evidence one return without a spike leaves: its ring holds only it.
    fn open_after(x: f32, y: f32, origin: (f32, f32)) -> Vec<(f64, f64)> {
        let mut panes = pane_beside();
        let mut ring = Ring::default();
        ring.clear();
        let azimuth_deg = (-(y - origin.1).atan2(x - origin.0).to_degrees()).rem_euclid(360.0);
        ring.push(RayReturn {
            azimuth_deg,
            x,
            y,
            spike: false,
            origin,
        });
        let at = pose2(0.0, 0.0, 0.0);
        panes.observe(&at, 2, &[], &[], &[ring], 2f64.to_radians(), 10.0);
        panes.panes[0]
            .open
            .values()
            .map(|&(x, y, _)| (x, y))
            .collect()
    }

    #[test]
    fn a_beam_opens_a_pane_only_if_it_crossed_squarely_from_where_it_was_fired() {
        // the sensor fired 6 cm behind where the revolution ends (driving at 0.6 m/s)
        let behind = (-0.06, 0.0);
        // squarely across the line from there: open where it crossed
        let open = open_after(-0.06, -1.0, behind);
        assert_eq!(open.len(), 1, "{open:?}");
        assert!((open[0].0 + 0.06).abs() < 1e-6 && (open[0].1 + 0.5).abs() < 1e-6);
        // 4° off the normal from there (glass lets it through without a spike) — though from
        // where the revolution ends it looks 0.6° off: no evidence either way
        let (s, c) = 4f32.to_radians().sin_cos();
        let open = open_after(-0.06 + s, -c, behind);
        assert!(open.is_empty(), "{open:?}");
    }

    /// A ring with one return straight to the robot's right, 1 m beyond a line at y = −0.5.
    fn right_through() -> Ring {
        let mut ring = Ring::default();
        ring.clear();
        ring.push(RayReturn {
            azimuth_deg: 90.0,
            x: 0.0,
            y: -1.5,
            spike: false,
            origin: (0.0, 0.0),
        });
        ring
    }

    #[test]
    fn an_opening_passed_before_its_pane_was_seen_is_open_once_the_pane_is() {
        // the robot drives along x past an opening, its beams square to the partition's line
        // (y = −0.5) passing through; then the foot of its perpendicular reaches glass at x = 2
        let run = |history: bool| {
            let mut panes = Panes::new(0.05);
            let ring = right_through();
            let mut t = 0;
            if history {
                for k in 0..20 {
                    t += 1;
                    let at = pose2(0.05 * f64::from(k), 0.0, 0.0);
                    panes.observe(&at, t, &[], &[], std::slice::from_ref(&ring), 0.035, 10.0);
                }
            }
            assert!(panes.is_empty());
            let sighting = Sighting {
                x: 0.0,
                y: -0.5,
                nx: 0.0,
                ny: -1.0,
            };
            for x in [2.0, 2.05] {
                t += 1;
                let at = pose2(x, 0.0, 0.0);
                panes.observe(&at, t, &[sighting], &[(0.0, -0.5, 0)], &[], 0.035, 10.0);
            }
            assert_eq!(panes.len(), 1);
            let mut open: Vec<f64> = panes.panes[0].open.values().map(|e| e.0).collect();
            open.sort_by(f64::total_cmp);
            open
        };
        let open = run(true);
        // where the kept revolutions' beams crossed the line: from x = 0 to the last place
        // kept (0.85–0.9), one every `HISTORY_STEP_M` or a step more
        assert!(open.len() >= 7, "{open:?}");
        assert!(open[0].abs() < 1e-6, "{open:?}");
        assert!(open[open.len() - 1] >= 0.8, "{open:?}");
        assert!(open.windows(2).all(|w| w[1] - w[0] <= 0.16), "{open:?}");
        // without those revolutions nothing says the line is open there
        assert!(run(false).is_empty());
    }

    /// A pane along y = −0.5 m seen often enough to be extended, its glass and open evidence
    /// at the cells of x = 0.05·k m for the given k, held alone; and an 8 m grid of 5 cm cells.
    fn pane_along_y_minus_half(
        glass: impl IntoIterator<Item = i32>,
        open: impl IntoIterator<Item = i32>,
    ) -> (Panes, GridSpec) {
        let cell_m = 0.05;
        fn fill(evidence: &mut Evidence, ks: impl IntoIterator<Item = i32>) {
            for k in ks {
                let x = 0.05 * f64::from(k);
                evidence.insert(key(x, -0.5, 0.05), (x, -0.5, 1));
            }
        }
        let mut pane = Pane {
            glass: HashMap::new(),
            open: HashMap::new(),
            normal_sum: (0.0, 0.0),
            line: ((0.0, -0.5), (1.0, 0.0)),
            revolutions: MIN_REVOLUTIONS,
            last_revolution_ns: 1,
            replayed: true,
        };
        fill(&mut pane.glass, glass);
        fill(&mut pane.open, open);
        let mut panes = Panes::new(cell_m);
        panes.panes.push(pane);
        let grid = GridSpec {
            cells: 160,
            cell_m: cell_m as f32,
        };
        (panes, grid)
    }

    #[test]
    fn a_stretch_from_an_opening_to_a_wall_is_drawn_only_when_longer_than_a_passage() {
        // an office partition along y = −0.5: a pane seen from x = −1 to 0, a door seen open
        // (squarely) from 0.05 to 0.25 only, and a wall on the line from 1.6 m. Between the door's
        // seen part and the wall, 1.35 m that may be the rest of the door or a pane never faced
        let (mut panes, grid) = pane_along_y_minus_half(-20..=0, 1..=5);
        let at = |x: f64| grid.cell_of(x as f32, -0.5).map(|(r, c)| grid.index(r, c));
        let draw = |panes: &mut Panes, passage_m: f64| {
            let mut classes = vec![cell_class::FREE; grid.len()];
            for k in 0..=20 {
                if let Some(i) = at(1.6 + 0.05 * f64::from(k)) {
                    classes[i] = cell_class::SOLID;
                }
            }
            let mut cost = vec![0u8; grid.len()];
            let reach = Reach {
                extend_m: 3.0,
                mullion_m: 0.2,
                passage_m,
            };
            panes.draw(
                &pose2(0.0, 0.0, 0.0),
                grid,
                reach,
                &mut classes,
                &mut cost,
                |_| false,
            );
            classes
        };
        let between = |classes: &[u8]| {
            (8..=30)
                .filter_map(|k| at(0.05 * f64::from(k)))
                .filter(|&i| classes[i] == cell_class::SUSPECTED_GLASS)
                .count()
        };
        // a passage of up to 1.8 m: the rest of the door, drawn open
        let classes = draw(&mut panes, 1.8);
        assert_eq!(between(&classes), 0);
        // up to 1.0 m: longer, so it may hide a pane, drawn as suspected glass up to the wall
        let classes = draw(&mut panes, 1.0);
        assert!(between(&classes) >= 20, "{}", between(&classes));
        // the door's seen part stays open, and the pane glass, either way
        for x in [0.1, 0.2] {
            assert_eq!(
                classes[at(x).expect("on the grid")],
                cell_class::FREE,
                "{x}"
            );
        }
        assert_eq!(classes[at(-0.5).expect("on the grid")], cell_class::GLASS);
    }

    #[test]
    fn a_short_hole_between_stretches_seen_open_is_not_drawn() {
        // a pane along y = −0.5 seen from x = −1 to 0; beyond it an opening seen open in
        // strips, as a robot passing close by sees it: 0.05–0.3, 0.5–0.8 and 1.25–1.4 m. The
        // 0.15 m hole between the first two is sampling; the 0.4 m one may hide a pane
        let (mut panes, grid) =
            pane_along_y_minus_half(-20..=0, (1..=6).chain(10..=16).chain(25..=28));
        let mut classes = vec![cell_class::FREE; grid.len()];
        let mut cost = vec![0u8; grid.len()];
        let reach = Reach {
            extend_m: 3.0,
            mullion_m: 0.2,
            passage_m: 1.8,
        };
        let origin = pose2(0.0, 0.0, 0.0);
        panes.draw(&origin, grid, reach, &mut classes, &mut cost, |_| false);
        let at = |x: f64| {
            let (r, c) = grid.cell_of(x as f32, -0.5).expect("on the grid");
            classes[grid.index(r, c)]
        };
        for x in [0.35, 0.4, 0.45] {
            assert_eq!(at(x), cell_class::FREE, "the short hole at {x}");
        }
        for x in [0.9, 1.0, 1.1, 1.2] {
            assert_eq!(at(x), cell_class::SUSPECTED_GLASS, "the long hole at {x}");
        }
        // past the last stretch seen open the line goes on as before
        assert_eq!(at(1.7), cell_class::SUSPECTED_GLASS);
        assert_eq!(at(-0.5), cell_class::GLASS);
    }

    #[test]
    fn the_history_takes_its_memory_at_the_first_revolution_and_no_more() {
        let mut panes = Panes::new(0.05);
        // nothing near horizontal: nothing reserved
        panes.observe(
            &pose2(0.0, 0.0, 0.0),
            1,
            &[],
            &[],
            &[Ring::default()],
            0.035,
            10.0,
        );
        assert_eq!(panes.history_bytes(), 0);
        let short = right_through();
        let mut long = Ring::default();
        for k in 0..2000 {
            let a = k as f32 * 0.18;
            long.push(RayReturn {
                azimuth_deg: a,
                x: 3.0 * a.to_radians().cos(),
                y: -3.0 * a.to_radians().sin(),
                spike: false,
                origin: (0.0, 0.0),
            });
        }
        let mut t = 1;
        let mut step = |panes: &mut Panes, k: u32, rings: &[Ring]| {
            t += 1;
            let at = pose2(0.1 * f64::from(k), 0.0, 0.0);
            panes.observe(&at, t, &[], &[], rings, 0.035, 10.0);
        };
        step(&mut panes, 1, std::slice::from_ref(&short));
        let reserved = panes.history_bytes();
        assert_eq!(panes.history.len(), HISTORY);
        assert!(
            reserved >= HISTORY * HISTORY_RING_RETURNS * 24,
            "{reserved}"
        );
        // many places, rings up to a whole revolution long: the same memory
        for k in 2..200 {
            let ring = if k % 3 == 0 { &long } else { &short };
            step(&mut panes, k, std::slice::from_ref(ring));
            assert_eq!(panes.history.len(), HISTORY);
            assert_eq!(panes.history_bytes(), reserved, "after {k} places");
        }
    }
}
