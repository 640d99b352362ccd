//! The mimnav map builder as a library: from one revolution of points (and the odometry) to the
//! multi-layer intensity map, the class of every cell and the planning cost. No IPC.
//!
//! The equations are those of `mim-lidar-intensity-navigation.txt` (§IV), restated in DESIGN §6:
//! - eq. 1: layer j of cell (r, c) is I_j = Σ intensity / g² over the points whose height (or
//!   elevation) lies in the layer's interval H_j; intensities are normalised by the full scale R;
//! - eq. 2: the layers stacked are the multi-layer map;
//! - eq. 3–5: a cell whose three main layers (below, above, zero) all stay at or below Γ is a
//!   false-positive obstacle (passable); otherwise a true positive (solid). As DESIGN §6 says, Γ is
//!   compared with the per-cell **mean** intensity, which does not grow with point density;
//! - eq. 6–7: glass (false negatives) from the z = 0 and z = −ε layers, kept in a memory that
//!   moves with the odometry ([`glass`]).
//!
//! Beyond the paper: in dual-return mode a return that another return of the same firing lies
//! behind (by more than a cell) shows a beam that went *through* the cell, and a firing with one
//! echo only (both blocks equal) shows a beam stopped by one surface. A cell with several
//! single-echo returns and none a beam passed through is solid whatever its intensity — an opaque
//! wall seen at a grazing angle returns little light but never lets a beam through. A cell
//! holding any return brighter than `solid_max` (a layer's maximum, kept beside its sum) is solid:
//! grass blades and curtain strands never return that much, while a solid object seen partly
//! through grass still returns brightly where a beam reaches it whole. Likewise a weak
//! echo less than 0.5 m behind a bright echo (above Γ) of the same firing comes from inside the
//! same object, and its cell is solid. And a cell that gathers many returns in one revolution
//! (`stop_min_returns`) with not one beam passing through it is solid however faint they are: a
//! trunk seen through a metre of grass returns no more light than the blades (the beam has lost
//! most of its energy on the way), but grass lets some beam on from nearly every cell it returns
//! from. (Single-return sensors give none of these cues: then
//! equation 3 alone decides.)
//!
//! One cue works in every return mode: the foliage paper's (`foliage-discrimination-rotating-
//! ladar.txt`, FIND-LOW-FREQ) observation that along one laser's scan the range of a solid
//! surface changes slowly from firing to firing while foliage returns at scattered ranges. A
//! downward beam's last return with enough of its neighbouring firings at the same range
//! (`surface_tolerance_m`, `surface_window`, `surface_neighbours`; or only
//! `surface_shaded_neighbours` when no more than `surface_beyond_max` of the window went farther:
//! the rest ended in the blades in front of it) lies on a surface when no beam passed through its
//! cell below it, and a cell that is not bright, tall or opaque is solid with
//! `surface_min_returns` such returns: a rock below the grass tops, whose echoes are as faint as
//! the blades' and whose cells the blades above it let beams through (a curtain lets them through
//! below too). Upward beams are left out: where one leaves a canopy, its last blades lie near one
//! range all along the ring. Cells the cue finds in two revolutions in a row are kept in the
//! odometry frame like glass (`surface_memory_s`, `surface_memory_m`), the longer the more
//! revolutions found them (`surface_memory_longest_s`): a rock lower than the lowest beam reaches
//! beside the robot is out of sight while the robot passes it. The beams meet a rock's near face
//! only: the cells behind a low surface cell along the beam are solid too (`surface_depth_m`,
//! `surface_depth_top_m`).
//!
//! The cues leave a few single solid cells in a curtain or in grass each revolution (a handful of
//! returns that looked bright, opaque or tall); a solid cell alone among passable ones, passable
//! on two opposite sides and not solid at its place the revolution before, is passable
//! (`lone_solid_passable`).
#![deny(missing_docs)]

pub mod baseline;
pub mod config;
pub mod glass;
pub mod pane;
pub mod render;
pub mod score;
pub mod step;

use mimnav_shared::config::{MapConfig, RobotProfile, seconds_ns};

use crate::config::{LayerConfig, LayerUnit, MapperConfig};
use mimnav_shared::grid::GridSpec;
use mimnav_shared::topics::{Point, cell_class, return_type};

use crate::glass::{Frame, RingReturn, detect_spikes};
use crate::pane::{Panes, RayReturn, Ring, Sighting};
use mimnav_shared::pose::{Pose2, Pose2Ext};

/// Everything the mapper is set by: the grid of `[map]`, the robot of `[robot]` (the sensor's
/// height, and the layers sized for it when `mapper.layer` is empty) and `[mapper]` itself. The
/// sections are held as the config has them; what the mapper needs in other units (ns, f32, the
/// 0–255 cost) is converted where it is used.
#[derive(Debug, Clone, PartialEq)]
pub struct MapperParams {
    /// The grid (`[map]`).
    pub grid: GridSpec,
    /// The robot (`[robot]`).
    pub robot: RobotProfile,
    /// `[mapper]`.
    pub mapper: MapperConfig,
}

impl MapperParams {
    /// The layers in force (at least `below`, `above`, `zero`, `minus_eps`): `mapper.layer`, or
    /// the paper's four sized for the robot.
    pub fn layers(&self) -> Vec<LayerConfig> {
        self.mapper.layers_for(&self.robot)
    }

    /// How long kept glass is remembered (`mapper.glass_memory_s`), ns.
    pub fn glass_memory_ns(&self) -> u64 {
        seconds_ns(self.mapper.glass_memory_s)
    }

    /// How long kept surface cells are remembered (`mapper.surface_memory_s`), ns; 0: not kept.
    pub fn surface_memory_ns(&self) -> u64 {
        seconds_ns(self.mapper.surface_memory_s)
    }

    /// The longest a kept surface cell found again and again is remembered
    /// (`mapper.surface_memory_longest_s`, at least `surface_memory_s`), ns.
    pub fn surface_memory_longest_ns(&self) -> u64 {
        seconds_ns(self.mapper.surface_memory_longest_s).max(self.surface_memory_ns())
    }

    /// How long kept tall cells are remembered (`mapper.tall_memory_s`), ns; 0: not kept.
    pub fn tall_memory_ns(&self) -> u64 {
        seconds_ns(self.mapper.tall_memory_s)
    }
}

impl Default for MapperParams {
    /// The documented defaults (`mimnav_config::Config::mapper_params` builds a file's).
    fn default() -> Self {
        MapperParams {
            grid: MapConfig::default().grid(),
            robot: RobotProfile::default(),
            mapper: MapperConfig::default(),
        }
    }
}

/// A count of returns as the per-cell evidence counts them (saturating at `u16::MAX`).
fn returns(n: u32) -> u16 {
    n.min(u32::from(u16::MAX)) as u16
}

/// Odometry: where the robot is and how it moves.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Odom {
    /// Pose in the odometry frame at the end of the revolution.
    pub pose: Pose2,
    /// Forward speed, m/s.
    pub v: f64,
    /// Turn rate, rad/s.
    pub omega: f64,
}

/// The odometry a revolution is mapped with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OdomInput {
    /// Recent odometry: points are de-skewed with its velocity and the glass memory moves with it.
    Fresh(Odom),
    /// Odometry too old to trust: the glass memory stays where it was.
    Stale,
    /// None yet.
    Missing,
}

/// How a revolution's points are de-skewed: each moves from its firing time into the robot's
/// frame at `t_ref_ns` as the robot moves at (v, ω) meanwhile. A point fired after `t_ref_ns`
/// moves back.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Deskew {
    /// Forward speed, m/s.
    pub v: f32,
    /// Turn rate, rad/s.
    pub omega: f32,
    /// The reference time, ns from the revolution's stamp (as [`Point::time_offset_ns`]).
    pub t_ref_ns: u32,
}

impl Deskew {
    /// With fresh odometry's (v, ω) to `t_ref_ns`; none (every point where it was measured)
    /// with stale or missing odometry.
    pub fn of(odom: OdomInput, t_ref_ns: u32) -> Self {
        match odom {
            OdomInput::Fresh(o) => Deskew {
                v: o.v as f32,
                omega: o.omega as f32,
                t_ref_ns,
            },
            _ => Deskew {
                t_ref_ns,
                ..Deskew::default()
            },
        }
    }
}

/// A near-horizontal ring's return: its intensity and range, its de-skewed position (x, y) and
/// the de-skewed position the sensor fired it from.
type RingEntry = (RingReturn, f32, f32, (f32, f32));

/// What one update found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct UpdateStats {
    /// Points binned into at least one layer.
    pub binned: u32,
    /// Ground points.
    pub ground: u32,
    /// Points outside the grid.
    pub outside: u32,
    /// Glass cells detected in this revolution.
    pub glass_detected: u32,
    /// Entries in the glass memory.
    pub glass_memory: u32,
    /// Cells added by extending panes to the solids that hold them.
    pub glass_extended: u32,
    /// Cells the surface cue made solid in this revolution.
    pub surface_found: u32,
    /// Entries in the surface memory.
    pub surface_memory: u32,
    /// Entries in the tall-cell memory.
    pub tall_memory: u32,
    /// Lone solid cells among passable ones called passable (`mapper.lone_solid_passable`).
    pub lone_passed: u32,
    /// Cells classified by their evidence after the last slice (the rest were settled as the
    /// slices arrived): every cell written when the revolution came whole.
    pub classified_at_end: u32,
}

/// What [`Mapper::settle_cell`] compares a cell's evidence with, converted from the parameters
/// once (they do not change after [`Mapper::new`]) instead of at every cell.
#[derive(Debug, Clone, Copy)]
struct SettleLimits {
    /// Γ, `mapper.gamma`.
    gamma: f32,
    /// R, `mapper.full_scale`.
    full_scale: f32,
    /// `mapper.solid_max` in intensity units.
    solid_max_abs: f32,
    /// `mapper.tall_m`, sensor frame.
    tall_z: f32,
    min_returns_solid: u16,
    stop_min_returns: u16,
    /// `mapper.surface_min_returns` > 0.
    surface_cue: bool,
}

impl SettleLimits {
    fn of(params: &MapperParams) -> Self {
        let mp = &params.mapper;
        SettleLimits {
            gamma: mp.gamma as f32,
            full_scale: mp.full_scale as f32,
            solid_max_abs: mp.solid_max as f32 * mp.full_scale as f32,
            tall_z: (mp.tall_m - params.robot.sensor_height_m) as f32,
            min_returns_solid: returns(mp.min_returns_solid),
            stop_min_returns: returns(mp.stop_min_returns),
            surface_cue: mp.surface_min_returns > 0,
        }
    }
}

#[derive(Debug, Clone, Copy)]
struct LayerBounds {
    elevation: bool,
    low: f32,
    high: f32,
}

/// The map builder's state: per-revolution buffers and the glass memory.
#[derive(Debug)]
pub struct Mapper {
    params: MapperParams,
    bounds: Vec<LayerBounds>,
    /// `bounds` four at a time, for the binning's layer tests.
    quads: Vec<LayerQuad>,
    /// 1 / (R g²): turns a layer's intensity sum into eq. 1's I_j.
    layer_scale: f32,
    roles: [usize; 4],
    /// The parameters [`Mapper::settle_cell`] reads, converted once.
    limits: SettleLimits,
    /// Per cell and layer (cell-major: `i * m + j`): eq. 1's sum, the count and the maximum.
    layer: Vec<LayerCell>,
    /// Per cell: the dual-return evidence.
    evidence: Vec<Evidence>,
    /// Cells written in this revolution (cleared at the next), in the order first written.
    touched: Vec<u32>,
    /// Per cell: [`UNTOUCHED`], [`TOUCHED`] or [`SETTLED`] in this revolution.
    state: Vec<u8>,
    /// Per cell with returns: its class by its own evidence ([`Mapper::settle_cell`]), with
    /// [`TALL_BIT`]; [`NO_HIT_CLASS`] without returns. Valid where `state` is [`SETTLED`].
    hit_class: Vec<u8>,
    /// `touched[..settled]` have been settled (classified as the slices arrived).
    settled: usize,
    /// `touched.len()` at the end of the previous slice.
    slice_end: usize,
    /// Settled cells written again since: classified anew at the revolution's end.
    redo: Vec<u32>,
    /// Glass detected in this revolution (cell indices, sorted, unique).
    glass_cells: Vec<usize>,
    reach: Box<[f32; REACH_BINS]>,
    cell_range: Vec<f32>,
    cell_bin: Vec<u16>,
    classes: Vec<u8>,
    cost: Vec<u8>,
    /// Glass panes: every spike sighting, kept in the odometry frame (equations 6–7).
    panes: Panes,
    /// This revolution's spike sightings (robot frame).
    sightings: Vec<Sighting>,
    /// Their spike returns the −ε layer does not see: (x, y, sighting).
    sighting_points: Vec<(f32, f32, u32)>,
    /// The near-horizontal rings as the panes' opening test reads them.
    pane_rings: Vec<Ring>,
    /// Scratch: spike runs along one ring.
    runs: Vec<(usize, usize)>,
    /// Cells the surface cue made solid, kept in the odometry frame like glass.
    surface_kept: Kept,
    /// The cells behind the surface cells (`surface_depth_m`), kept `surface_memory_s` and no
    /// longer.
    body_kept: Kept,
    /// Cells the surface cue made solid in this revolution.
    surface_cells: Vec<usize>,
    /// Scratch: the lone solid cells of this revolution turned passable.
    lone: Vec<usize>,
    /// The last revolution's solid cells, for `mapper.lone_solid_passable`.
    lone_last: LastSolids,
    /// Tall cells (solid by the height cue), kept in the odometry frame.
    tall_kept: Kept,
    /// Tall cells of this revolution.
    tall_cells: Vec<usize>,
    /// Cells the surface cue looks at: not bright, tall or opaque (cleared with the cells written,
    /// at the next revolution's start).
    surface_candidate: Vec<bool>,
    /// Per candidate cell: the height of its highest surface return (sensor frame, m;
    /// `-inf`: none), set by [`Mapper::mark_surfaces`].
    surface_top: Vec<f32>,
    last_pose: Option<Pose2>,
    /// Per zero-layer laser, in firing order: each strongest return, its de-skewed position and
    /// where the sensor was when it fired (de-skewed the same way: the beam ran from there).
    rings: Vec<Vec<RingEntry>>,
    /// Per laser, in firing order: each firing's last return (for the surface cue).
    last_rings: Vec<LastRing>,
    /// Per ring: the returns whose window has been counted.
    last_counted: Vec<usize>,
    /// The last returns with enough of their neighbouring firings at their range
    /// (`surface_neighbours` within `surface_window`), as (cell, height): listed as soon as
    /// their window along the ring is whole.
    flat: Vec<(u32, f32)>,
    spikes: Vec<bool>,
    /// Scratch: the slice being binned, each point de-skewed and its cell looked up.
    placed: Vec<Placed>,
    /// How the revolution being binned is de-skewed.
    deskew: Deskew,
    /// What the revolution being binned has found so far.
    stats: UpdateStats,
}

/// One laser's last returns, in firing order. The ranges are kept apart from the rest so that
/// the surface cue's window over them is a plain run of `f32` the compiler turns into vector
/// compares (read from the returns, the window was 7 % of a grass revolution's instructions).
#[derive(Debug, Clone, Default)]
struct LastRing {
    /// Each return's range, m; negated for ground: never on the same surface as anything, and
    /// its size still says how far the beam went.
    ranges: Vec<f32>,
    /// The rest of each return, at the same index.
    returns: Vec<LastReturn>,
}

impl LastRing {
    fn clear(&mut self) {
        self.ranges.clear();
        self.returns.clear();
    }
}

/// A firing's last return along its laser's ring (its range in [`LastRing::ranges`]).
#[derive(Debug, Clone, Copy)]
struct LastReturn {
    /// Height, sensor frame, m.
    z: f32,
    /// The cell it votes for, or [`NO_CELL`] (outside the grid, ground).
    cell: u32,
}

const NO_CELL: u32 = u32::MAX;

/// A cell no point, beam or echo has written in this revolution.
const UNTOUCHED: u8 = 0;
/// Written, and not classified since.
const TOUCHED: u8 = 1;
/// Classified by its evidence as the slices arrived ([`Mapper::hit_class`]), not written since.
const SETTLED: u8 = 2;
/// [`Mapper::hit_class`] of a cell without returns: free or unknown by the reach.
const NO_HIT_CLASS: u8 = u8::MAX;
/// [`Mapper::hit_class`]'s flag of a tall cell (a return above `tall_m`, no beam through).
const TALL_BIT: u8 = 0x80;

/// A weak echo at most this far behind a bright echo of the same firing is the inside of the
/// same object (a dense bush returns its front brightly and a trace from within), m.
const INSIDE_M: f32 = 0.5;

/// Azimuth bins of the reach table (for observed-free space): 0.5°.
const REACH_BINS: usize = 720;

fn role(layers: &[LayerConfig], name: &str) -> usize {
    layers.iter().position(|l| l.name == name).unwrap_or(0)
}

impl Mapper {
    /// A mapper with empty buffers.
    pub fn new(params: MapperParams) -> Self {
        let n2 = params.grid.len();
        let layers = params.layers();
        let m = layers.len();
        let bounds: Vec<LayerBounds> = layers
            .iter()
            .map(|l| match l.unit {
                LayerUnit::M => LayerBounds {
                    elevation: false,
                    low: l.low as f32,
                    high: l.high as f32,
                },
                LayerUnit::Deg => LayerBounds {
                    elevation: true,
                    low: (l.low as f32).to_radians().sin(),
                    high: (l.high as f32).to_radians().sin(),
                },
            })
            .collect();
        let roles = [
            role(&layers, "below"),
            role(&layers, "above"),
            role(&layers, "zero"),
            role(&layers, "minus_eps"),
        ];
        let mut cell_range = Vec::with_capacity(n2);
        let mut cell_bin = Vec::with_capacity(n2);
        for r in 0..params.grid.cells {
            for c in 0..params.grid.cells {
                let (x, y) = params.grid.center_of(r, c);
                cell_range.push(x.hypot(y));
                let az = (-y).atan2(x).to_degrees().rem_euclid(360.0);
                cell_bin.push(((az * 2.0) as usize % REACH_BINS) as u16);
            }
        }
        let g = params.grid.cell_m;
        Mapper {
            quads: LayerQuad::of(&bounds),
            bounds,
            layer_scale: 1.0 / (params.mapper.full_scale as f32 * g * g),
            roles,
            limits: SettleLimits::of(&params),
            layer: vec![LayerCell::default(); m * n2],
            evidence: vec![Evidence::default(); n2],
            touched: Vec::with_capacity(n2),
            state: vec![UNTOUCHED; n2],
            hit_class: vec![NO_HIT_CLASS; n2],
            settled: 0,
            slice_end: 0,
            redo: Vec::new(),
            glass_cells: Vec::new(),
            reach: Box::new([0.0; REACH_BINS]),
            cell_range,
            cell_bin,
            classes: vec![cell_class::UNKNOWN; n2],
            cost: vec![0; n2],
            panes: Panes::new(f64::from(params.grid.cell_m)),
            sightings: Vec::new(),
            sighting_points: Vec::new(),
            pane_rings: Vec::new(),
            runs: Vec::new(),
            surface_kept: Kept::new(n2),
            body_kept: Kept::new(n2),
            surface_cells: Vec::new(),
            lone: Vec::new(),
            lone_last: LastSolids::default(),
            tall_kept: Kept::new(n2),
            tall_cells: Vec::new(),
            surface_candidate: vec![false; n2],
            surface_top: vec![f32::NEG_INFINITY; n2],
            last_pose: None,
            rings: vec![Vec::new(); 16],
            last_rings: vec![LastRing::default(); 16],
            last_counted: vec![0; 16],
            flat: Vec::new(),
            spikes: Vec::new(),
            placed: Vec::new(),
            deskew: Deskew::default(),
            stats: UpdateStats::default(),
            params,
        }
    }

    /// The parameters.
    pub fn params(&self) -> &MapperParams {
        &self.params
    }

    /// Class of every cell ([`cell_class`]), row-major.
    pub fn classes(&self) -> &[u8] {
        &self.classes
    }

    /// The last revolution's glass spike sightings (robot frame: each spike's centre and the
    /// pane's normal).
    pub fn sightings(&self) -> &[Sighting] {
        &self.sightings
    }

    /// Planning cost of every cell, 0–255.
    pub fn cost(&self) -> &[u8] {
        &self.cost
    }

    /// Number of layers.
    pub fn layer_count(&self) -> usize {
        self.bounds.len()
    }

    /// Layer j as the paper's I_j (eq. 1): Σ (intensity / R) / g² per cell.
    pub fn layer_values(&self, j: usize, out: &mut Vec<f32>) {
        out.clear();
        out.extend((0..self.params.grid.len()).map(|i| self.layer_value(j, i)));
    }

    /// Every layer's I_j, one layer after the other (each row-major), as `map/layers` carries
    /// them.
    pub fn layers(&self) -> impl Iterator<Item = f32> + '_ {
        let n2 = self.params.grid.len();
        (0..self.bounds.len()).flat_map(move |j| (0..n2).map(move |i| self.layer_value(j, i)))
    }

    /// [`Mapper::layers`] written into `out` (its first layers × cells elements; the rest is
    /// left as it is), one layer at a time: a plain loop per layer where the iterator is stepped
    /// one element at a time (the mapper publishes 160 000 values a revolution).
    pub fn write_layers(&self, out: &mut [f32]) {
        let (n2, nb) = (self.params.grid.len(), self.bounds.len());
        if nb == 0 || n2 == 0 {
            return;
        }
        for (j, dst) in out.chunks_exact_mut(n2).take(nb).enumerate() {
            for (o, cell) in dst.iter_mut().zip(self.layer.chunks_exact(nb)) {
                *o = cell[j].sum * self.layer_scale;
            }
        }
    }

    /// Layer j of cell i as the paper's I_j (eq. 1): Σ (intensity / R) / g².
    #[inline]
    fn layer_value(&self, j: usize, i: usize) -> f32 {
        self.layer[i * self.bounds.len() + j].sum * self.layer_scale
    }

    /// Mean normalised intensity of layer j in cell i (0 without points).
    #[inline]
    fn mean(&self, j: usize, i: usize) -> f32 {
        let cell = &self.layer[i * self.bounds.len() + j];
        // an empty layer's sum is 0: 0 over 1 is its mean without a branch
        cell.sum / (f32::from(cell.count.max(1)) * self.params.mapper.full_scale as f32)
    }

    /// Diagnostics of cell i: (returns, single-echo returns, returns a beam passed through,
    /// mean normalised intensity of below, above, zero).
    pub fn cell_evidence(&self, i: usize) -> (u16, u16, u16, [f32; 3]) {
        let (b, a, z) = (self.roles[0], self.roles[1], self.roles[2]);
        (
            self.evidence[i].hits,
            self.evidence[i].single,
            self.evidence[i].passed,
            [self.mean(b, i), self.mean(a, i), self.mean(z, i)],
        )
    }

    /// Points in layer j of cell i.
    pub fn layer_count_at(&self, j: usize, i: usize) -> u16 {
        self.layer[i * self.bounds.len() + j].count
    }

    /// Maps one revolution. `now_ns` is the revolution's stamp (ages the glass memory). The
    /// points are de-skewed to the revolution's last point with the odometry's (v, ω): the same
    /// as [`begin`](Self::begin), [`bin_slice`](Self::bin_slice) over the points in any number of
    /// pieces and [`finish`](Self::finish).
    pub fn update(&mut self, points: &[Point], odom: OdomInput, now_ns: u64) -> UpdateStats {
        let t_end = points.last().map_or(0, |p| p.time_offset_ns);
        self.begin(Deskew::of(odom, t_end));
        self.bin_slice(points);
        self.finish(odom, now_ns)
    }

    /// Starts a revolution: forgets the last one's cells, rings and reach; its points will be
    /// de-skewed by `deskew`.
    pub fn begin(&mut self, deskew: Deskew) {
        self.reset();
        self.deskew = deskew;
        self.stats = UpdateStats::default();
    }

    /// Bins the next points of the revolution, in firing order (equations 1–2): a slice must
    /// hold whole packets, so that both returns of a firing are in it.
    pub fn bin_slice(&mut self, points: &[Point]) {
        let mut stats = self.stats;
        self.bin(points, &mut stats);
        self.stats = stats;
        // the surface cue's windows already whole: counted now, not after the last packet
        if self.params.mapper.surface_min_returns > 0 {
            self.count_windows(false);
        }
        // the cells the sweep has left behind — first written before the previous slice
        // ended — classified now, not after the last packet; the few it comes back to (cells
        // near the sensor span several slices' azimuths) are classified anew at the end (`redo`)
        let upto = std::mem::replace(&mut self.slice_end, self.touched.len());
        self.settle(upto);
    }

    /// Ends the revolution begun by [`begin`](Self::begin): glass, classes, memories and cost
    /// from what was binned. `now_ns` is the revolution's stamp (ages the memories).
    pub fn finish(&mut self, odom: OdomInput, now_ns: u64) -> UpdateStats {
        // glass seen in this revolution (Algorithm 1 and equation 6's layer difference)
        self.detect_glass();
        // the panes (equations 6 and 7)
        self.remember_glass(odom, now_ns);
        // classes (equations 3–5) and cost
        let surface_min_returns = returns(self.params.mapper.surface_min_returns);
        let surface_cue = surface_min_returns > 0;
        self.classify();
        self.pass_lone_solids(odom);
        let mut stats = self.stats;
        stats.glass_detected = self.glass_cells.len() as u32;
        stats.glass_memory = self.panes.evidence_len() as u32;
        let grid = self.params.grid;
        if surface_cue {
            // returns on a surface along the ring: a rock hidden in grass
            self.mark_surfaces(surface_min_returns);
            for &i in &self.surface_cells {
                self.classes[i] = cell_class::SOLID;
                self.cost[i] = 255;
            }
        }
        self.remember_surfaces(odom, now_ns);
        if surface_cue {
            // the body behind this revolution's faces
            self.deepen_surfaces(odom, now_ns);
        }
        stats.surface_found = self.surface_cells.len() as u32;
        stats.surface_memory = (self.surface_kept.len() + self.body_kept.len()) as u32;
        self.remember_tall(odom, now_ns);
        stats.tall_memory = self.tall_kept.len() as u32;
        for &i in &self.glass_cells {
            self.classes[i] = cell_class::GLASS;
            self.cost[i] = 255;
        }
        // the panes: their evidence (equation 7's union), and each extended along its fitted
        // line while nothing contradicts it; drawn afresh each revolution from the evidence, so
        // an extension never feeds the next one
        if let Some(pose) = self.last_pose {
            // unknown behind a nearer return in its direction: hidden (inside a pillar), not open
            // space beyond a pane with nothing behind it
            let (reach, cell_bin, cell_range) = (&self.reach, &self.cell_bin, &self.cell_range);
            let occluded = |i: usize| {
                let r = reach[usize::from(cell_bin[i])];
                r > 0.0 && r < cell_range[i]
            };
            let drawn = self.panes.draw(
                &pose,
                grid,
                pane::Reach {
                    extend_m: self.params.mapper.glass_extend_m,
                    mullion_m: self.params.mapper.glass_mullion_m,
                    passage_m: self.params.mapper.glass_passage_m,
                },
                &mut self.classes,
                &mut self.cost,
                occluded,
            );
            stats.glass_extended = drawn.extended;
        }
        stats
    }
}

impl Mapper {
    /// Forgets the last revolution's cells, rings and reach.
    fn reset(&mut self) {
        let m = self.bounds.len();
        for &i in &self.touched {
            let i = i as usize;
            self.evidence[i] = Evidence::default();
            self.layer[i * m..(i + 1) * m].fill(LayerCell::default());
            self.state[i] = UNTOUCHED;
            self.hit_class[i] = NO_HIT_CLASS;
            self.surface_candidate[i] = false;
            self.surface_top[i] = f32::NEG_INFINITY;
        }
        self.touched.clear();
        self.redo.clear();
        self.tall_cells.clear();
        self.slice_end = 0;
        self.settled = 0;
        self.reach.fill(0.0);
        for r in &mut self.rings {
            r.clear();
        }
        for r in &mut self.last_rings {
            r.clear();
        }
        self.last_counted.fill(0);
        self.flat.clear();
    }

    /// Bins every point into its cell's layers (equations 1–2), de-skewed by the odometry's
    /// (v, ω); collects the near-horizontal rings for the glass spike and the dual-return and
    /// surface cues.
    fn bin(&mut self, points: &[Point], stats: &mut UpdateStats) {
        let m = self.bounds.len();
        let mp = &self.params.mapper;
        let surface_cue = mp.surface_min_returns > 0;
        let grid = self.params.grid;
        let ground_z = -(self.params.robot.sensor_height_m - mp.ground_clearance_m) as f32;
        let zero_b = self.bounds[self.roles[2]];
        // De-skew: a revolution takes 0.05–0.2 s, in which a turning robot rotates by up to
        // several degrees. Each point moves into the robot frame at the reference time, from
        // its own firing time, with (v, ω) (small-angle rotation, exact enough below 0.3 rad).
        let Deskew { v, omega, t_ref_ns } = self.deskew;
        let full_scale = mp.full_scale as f32;
        let gamma_abs = mp.gamma as f32 * full_scale;
        // the single-echo and stopped cues only count returns at least this bright: a beam that
        // clips one grass blade and then meets nothing (the sky) has one faint echo too
        let opaque_min = (mp.opaque_min as f32 * full_scale)
            .round()
            .clamp(0.0, 255.0) as u8;
        let deskew = v != 0.0 || omega != 0.0;
        // the sensor on the robot: where every beam starts, before the de-skew
        let (mount_x, mount_y) = (
            self.params.robot.mount.x_m as f32,
            self.params.robot.mount.y_m as f32,
        );
        // first pass: each point de-skewed and its cell looked up once — the pair cues read the
        // next point's, and the cells are asked into the cache here, a slice ahead of the
        // second pass (in grass most cells a revolution touches are no longer cached since the
        // last one, and waiting for their layers and evidence was a third of the binning)
        let locator = grid.locator();
        let mut placed = std::mem::take(&mut self.placed);
        placed.clear();
        // (the closure takes copies of what it reads: captured by reference, each constant was
        // a load through a pointer a point)
        let (layer, evidence) = (&self.layer[..], &self.evidence[..]);
        placed.extend(points.iter().map(move |p| {
            let mut az_cdeg = i32::from(p.azimuth_cdeg);
            let (mut th, mut shift) = (0.0f32, 0.0f32);
            if deskew {
                let dt = (i64::from(t_ref_ns) - i64::from(p.time_offset_ns)) as f32 * 1e-9;
                th = omega * dt;
                shift = v * dt;
                // (saturating: an absurd rate must not overflow)
                az_cdeg = az_cdeg.saturating_add((th.to_degrees() * 100.0) as i32);
            }
            // (an azimuth past a turn from a damaged point too)
            let az_cdeg = wrap_cdeg(az_cdeg);
            let (sin_t, cos_t) = small_angle(th);
            let x = p.x - shift;
            let (x, y) = (cos_t * x + sin_t * p.y, -sin_t * x + cos_t * p.y);
            let cell = locator.index_of(x, y).map_or(NO_CELL, |i| i as u32);
            if cell != NO_CELL {
                let i = cell as usize;
                // both ends: a cell's layers (and its evidence) may straddle two cache lines
                prefetch(layer, i * m, m);
                prefetch(evidence, i, 1);
            }
            Placed {
                x,
                y,
                th,
                shift,
                cell,
                az_cdeg,
            }
        }));
        for (k, (p, pl)) in points.iter().zip(&placed).enumerate() {
            // the point's own fields but its de-skewed (x, y), read from the first pass's record
            // (a copy of the point with them written over it cost 3 % of a grass revolution's
            // instructions)
            let (px, py) = (pl.x, pl.y);
            let az_cdeg = pl.az_cdeg;
            let horizontal = (px * px + py * py).sqrt();
            // (the azimuth is below 36 000: the bin is below REACH_BINS)
            let bin = usize::from(az_cdeg / 50).min(REACH_BINS - 1);
            self.reach[bin] = running_max(self.reach[bin], horizontal);
            let d = p.distance_m().max(1e-3);
            let sin_el = p.z / d;
            let strongest = p.return_type & return_type::STRONGEST != 0;
            if strongest
                && in_layer(&zero_b, p.z, sin_el)
                && let Some(ring) = self.rings.get_mut(usize::from(p.laser_id))
            {
                // a moving sensor fired this beam from behind where the revolution ends (the
                // rotation computed here only: few points are on the zero layer's rings)
                let (sin_t, cos_t) = small_angle(pl.th);
                let x = mount_x - pl.shift;
                let origin = (cos_t * x + sin_t * mount_y, -sin_t * x + cos_t * mount_y);
                ring.push((
                    RingReturn {
                        azimuth_deg: f32::from(az_cdeg) * 0.01,
                        intensity: f32::from(p.intensity),
                        range_m: horizontal,
                    },
                    px,
                    py,
                    origin,
                ));
            }
            // a dual pair that differs (last, then strongest, same firing): the nearer return
            // let the beam through
            if p.return_type == return_type::LAST
                && let Some(q) = points.get(k + 1)
                && let Some(ql) = placed.get(k + 1)
                && q.return_type == return_type::STRONGEST
                && q.laser_id == p.laser_id
                && q.azimuth_cdeg == p.azimuth_cdeg
            {
                // the nearer and the farther return's cells (NO_CELL: off the grid)
                let q_nearer = q.distance_raw < p.distance_raw;
                let (near_cell, near_i, far_cell) = if q_nearer {
                    (ql.cell, q.intensity, pl.cell)
                } else {
                    (pl.cell, p.intensity, ql.cell)
                };
                let gap = (q.distance_m() - p.distance_m()).abs();
                if gap > 1.5 * grid.cell_m {
                    if near_cell != NO_CELL {
                        let ni = near_cell as usize;
                        touch(&mut self.state, &mut self.touched, &mut self.redo, ni);
                        let near_z = if q_nearer { q.z } else { p.z };
                        let e = &mut self.evidence[ni];
                        if e.passed == 0 || near_z < e.pass_low_z {
                            e.pass_low_z = near_z;
                        }
                        e.passed = e.passed.saturating_add(1);
                    }
                    // the beam ended on its strongest echo (p is the last return, q the
                    // second strongest): it stopped on something more reflective than
                    // what it passed — a surface, not the last blade of a spent beam
                    if q_nearer
                        && u16::from(p.intensity) > 3 * u16::from(q.intensity)
                        && p.intensity >= opaque_min
                        && far_cell != NO_CELL
                    {
                        let fi = far_cell as usize;
                        touch(&mut self.state, &mut self.touched, &mut self.redo, fi);
                        self.evidence[fi].stopped = self.evidence[fi].stopped.saturating_add(1);
                    }
                }
                // a weak echo just behind a bright one is the inside of the same object
                if gap <= INSIDE_M && f32::from(near_i) > gamma_abs && far_cell != NO_CELL {
                    let fi = far_cell as usize;
                    touch(&mut self.state, &mut self.touched, &mut self.redo, fi);
                    self.evidence[fi].inside = self.evidence[fi].inside.saturating_add(1);
                }
            }
            let cell = if p.z < ground_z || pl.cell == NO_CELL {
                None
            } else {
                Some(pl.cell as usize)
            };
            // one return per firing for the surface cue, on downward rings only (a laser's
            // elevation is fixed: its ring is all downward or all upward): the last (or only)
            // one; in dual mode the second strongest follows the last return of its firing
            if surface_cue
                && p.z < 0.0
                && !(p.return_type == return_type::STRONGEST
                    && k > 0
                    && points[k - 1].return_type == return_type::LAST
                    && points[k - 1].laser_id == p.laser_id
                    && points[k - 1].azimuth_cdeg == p.azimuth_cdeg)
                && let Some(ring) = self.last_rings.get_mut(usize::from(p.laser_id))
            {
                ring.ranges.push(if p.z < ground_z { -d } else { d });
                ring.returns.push(LastReturn {
                    z: p.z,
                    cell: cell.map_or(NO_CELL, |i| i as u32),
                });
            }
            if p.z < ground_z {
                stats.ground += 1;
                continue;
            }
            let Some(i) = cell else {
                stats.outside += 1;
                continue;
            };
            let mut any = false;
            for (q, quad) in self.quads.iter().enumerate() {
                // the layers holding the point, four tests at a time without a branch each (in
                // grass which layers a return falls in changes from point to point), then
                // only those layers written
                let mut within = quad.within(p.z, sin_el);
                any |= within != 0;
                while within != 0 {
                    let j = 4 * q + within.trailing_zeros() as usize;
                    within &= within - 1;
                    let cell = &mut self.layer[i * m + j];
                    cell.count = cell.count.saturating_add(1);
                    cell.sum += f32::from(p.intensity);
                    cell.max = cell.max.max(p.intensity);
                }
            }
            if any {
                stats.binned += 1;
                touch(&mut self.state, &mut self.touched, &mut self.redo, i);
                let e = &mut self.evidence[i];
                e.hits = e.hits.saturating_add(1);
                // (selects, not branches: in grass which way they go is a coin toss; a return
                // in a layer has a number for its height)
                e.top_z = running_max(e.top_z, p.z);
                e.single = e.single.saturating_add(u16::from(
                    (p.return_type == return_type::BOTH) & (p.intensity >= opaque_min),
                ));
            }
        }
        self.placed = placed;
    }

    /// Glass in this revolution: spikes along the near-horizontal rings (Algorithm 1 of
    /// `cartographer-glass.txt`) in cells the −ε layer does not see (equation 6's layer
    /// difference), into `self.glass_cells`; each spike with such a cell is a sighting of a pane
    /// (its centre, and its normal: the beam at the spike's centre). The rings go to the panes'
    /// opening test too.
    fn detect_glass(&mut self) {
        let (m, minus, grid) = (self.bounds.len(), self.roles[3], self.params.grid);
        let glass_intensity = self.params.mapper.glass_intensity as f32;
        let mut glass_cells = std::mem::take(&mut self.glass_cells);
        glass_cells.clear();
        self.sightings.clear();
        self.sighting_points.clear();
        if self.pane_rings.len() != self.rings.len() {
            self.pane_rings.resize(self.rings.len(), Ring::default());
        }
        // rings stay in firing order: the azimuth grows (wrapping at 360°) along them
        let mut padded: Vec<RingReturn> = Vec::new();
        let mut index: Vec<Option<usize>> = Vec::new();
        for (ring, rays) in self.rings.iter().zip(&mut self.pane_rings) {
            rays.clear();
            if ring.len() < 3 {
                continue;
            }
            padded.clear();
            index.clear();
            for (n, (rr, ..)) in ring.iter().enumerate() {
                if n > 0 && (rr.azimuth_deg - ring[n - 1].0.azimuth_deg).rem_euclid(360.0) > 0.5 {
                    // a firing without a return: intensity 0, range 0
                    padded.push(RingReturn {
                        azimuth_deg: rr.azimuth_deg - 0.25,
                        intensity: 0.0,
                        range_m: 0.0,
                    });
                    index.push(None);
                }
                padded.push(*rr);
                index.push(Some(n));
            }
            // the revolution is cut wherever its time runs out, and a spike lying across the
            // cut would be lost at both ends of the ring: start the ring at its faintest return
            // instead (a full ring is a circle)
            if let Some(start) = padded
                .iter()
                .enumerate()
                .min_by(|a, b| a.1.intensity.total_cmp(&b.1.intensity))
                .map(|(j, _)| j)
            {
                padded.rotate_left(start);
                index.rotate_left(start);
            }
            detect_spikes(
                &padded,
                &self.params.mapper,
                &mut self.spikes,
                &mut self.runs,
            );
            for (pn, n) in index.iter().enumerate() {
                if let Some(n) = *n {
                    let (rr, x, y, origin) = ring[n];
                    rays.push(RayReturn {
                        azimuth_deg: rr.azimuth_deg.rem_euclid(360.0),
                        x,
                        y,
                        spike: self.spikes[pn],
                        origin,
                    });
                }
            }
            for &(first, last) in &self.runs {
                let owner = self.sightings.len() as u32;
                let (mut sx, mut sy, mut count, mut seen) = (0.0f64, 0.0f64, 0usize, 0usize);
                let (mut fx, mut fy) = (0.0f64, 0.0f64);
                for n in index[first..=last].iter().flatten() {
                    let (_, x, y, (ox, oy)) = ring[*n];
                    sx += f64::from(x);
                    sy += f64::from(y);
                    fx += f64::from(ox);
                    fy += f64::from(oy);
                    count += 1;
                    if let Some((r, c)) = grid.cell_of(x, y) {
                        let i = grid.index(r, c);
                        // equation 6's I_{z=0} ⊖ I_{z=−ε}: the −ε layer sees an opaque surface
                        // in the cell; a spike there too (a laser at the edge of the pane's
                        // specular cone) is the same glass, not something the difference removes
                        let below = &self.layer[i * m + minus];
                        if below.count == 0 || below.sum >= glass_intensity * f32::from(below.count)
                        {
                            glass_cells.push(i);
                            self.sighting_points.push((x, y, owner));
                            seen += 1;
                        }
                    }
                }
                if seen == 0 || count == 0 {
                    continue;
                }
                let (cx, cy) = (sx / count as f64, sy / count as f64);
                // the normal is the beam at the spike's centre, from where the sensor fired it:
                // taken from the revolution's end instead, a robot driving past a pane at
                // 0.6 m/s tilted it by up to 10° (the sensor moves 6 cm in a revolution), and
                // the line drawn ahead along that normal ran into Spot's front corner
                let (bx, by) = (cx - fx / count as f64, cy - fy / count as f64);
                let d = bx.hypot(by);
                if d > 1e-3 {
                    self.sightings.push(Sighting {
                        x: cx,
                        y: cy,
                        nx: bx / d,
                        ny: by / d,
                    });
                } else {
                    // no direction: drop its points
                    self.sighting_points.retain(|q| q.2 != owner);
                }
            }
        }
        glass_cells.sort_unstable();
        glass_cells.dedup();
        self.glass_cells = glass_cells;
    }

    /// Equations 6 and 7: this revolution's sightings and opening evidence into the panes in
    /// the odometry frame, old evidence forgotten.
    fn remember_glass(&mut self, odom: OdomInput, now_ns: u64) {
        match odom {
            OdomInput::Fresh(Odom { pose, .. }) => {
                let mp = &self.params.mapper;
                self.panes.observe(
                    &pose,
                    now_ns,
                    &self.sightings,
                    &self.sighting_points,
                    &self.pane_rings,
                    mp.glass_normal_deg.to_radians(),
                    mp.glass_memory_m,
                );
                self.panes.expire(
                    &pose,
                    now_ns,
                    self.params.glass_memory_ns(),
                    self.params.mapper.glass_memory_m,
                );
                self.last_pose = Some(pose);
            }
            OdomInput::Stale | OdomInput::Missing => {}
        }
    }

    /// Equations 3–5: every cell free or unknown by the beams' reach, then each cell with
    /// returns solid or passable by its layers' mean intensity and the cues.
    fn classify(&mut self) {
        let grid = self.params.grid;
        // the cells the slices have not settled, and those written again since
        self.stats.classified_at_end = (self.touched.len() - self.settled + self.redo.len()) as u32;
        self.settle(self.touched.len());
        for t in 0..self.redo.len() {
            let i = self.redo[t] as usize;
            if self.state[i] == TOUCHED {
                self.settle_cell(i);
            }
        }
        // classes (equations 3–5) and cost in one pass the compiler can vectorise: a cell
        // with returns as settled, any other free or unknown by the beams' reach (glass and
        // the memories go on top after)
        let reach_margin = grid.cell_m;
        let passable_cost = self.params.mapper.passable_cell_cost();
        let reach = &self.reach;
        for ((((class, cost), &range), &bin), &hit) in self
            .classes
            .iter_mut()
            .zip(self.cost.iter_mut())
            .zip(&self.cell_range)
            .zip(&self.cell_bin)
            .zip(&self.hit_class)
        {
            let seen = hit & !TALL_BIT;
            (*class, *cost) = if hit != NO_HIT_CLASS {
                let c = if seen == cell_class::PASSABLE {
                    passable_cost
                } else {
                    255
                };
                (seen, c)
            } else if range < reach[usize::from(bin)] + reach_margin {
                (cell_class::FREE, 0)
            } else {
                (cell_class::UNKNOWN, 0)
            };
        }
        // settled tall, and written since so that it no longer is
        let hit_class = &self.hit_class;
        self.tall_cells
            .retain(|&i| hit_class[i] != NO_HIT_CLASS && hit_class[i] & TALL_BIT != 0);
        self.surface_cells.clear();
    }

    /// A solid cell of this revolution with no solid neighbour and at least
    /// `mapper.lone_solid_passable` passable ones, two of them on opposite sides of it, is
    /// passable — unless the cells within one of its place held a solid in the last revolution
    /// too (fresh odometry both times): a curtain's or grass's strands stop one revolution's few
    /// beams in a cell now and then, a post or a rock's face seen as a single cell is found at
    /// its place again.
    fn pass_lone_solids(&mut self, odom: OdomInput) {
        let need = self.params.mapper.lone_solid_passable;
        if need == 0 {
            return;
        }
        let grid = self.params.grid;
        let n = grid.cells;
        let passable_cost = self.params.mapper.passable_cell_cost();
        let pose = match odom {
            OdomInput::Fresh(Odom { pose, .. }) => Some(Frame::of(&pose)),
            OdomInput::Stale | OdomInput::Missing => None,
        };
        let mut lone = std::mem::take(&mut self.lone);
        lone.clear();
        let last = &self.lone_last;
        for &t in &self.touched {
            let i = t as usize;
            if self.classes[i] != cell_class::SOLID {
                continue;
            }
            let (r, c) = (i / n, i % n);
            if r == 0 || c == 0 || r + 1 >= n || c + 1 >= n {
                continue;
            }
            let class = |dr: usize, dc: usize| self.classes[grid.index(r + dr - 1, c + dc - 1)];
            let mut passable = 0;
            let mut solid = false;
            for dr in 0..3 {
                for dc in 0..3 {
                    match class(dr, dc) {
                        _ if (dr, dc) == (1, 1) => {}
                        cell_class::SOLID | cell_class::GLASS => solid = true,
                        cell_class::PASSABLE => passable += 1,
                        _ => {}
                    }
                }
            }
            // inside the strands (passable on two opposite sides), not at their end: a
            // curtain's tip, solid now and then, is where a door's jamb may be
            let flanked = [(0, 0), (0, 1), (0, 2), (1, 2)].iter().any(|&(dr, dc)| {
                class(dr, dc) == cell_class::PASSABLE
                    && class(2 - dr, 2 - dc) == cell_class::PASSABLE
            });
            if solid || passable < need || !flanked {
                continue;
            }
            // found solid at its place in the last revolution: kept
            let again = match (pose, last.frame) {
                (Some(now), Some(then)) => {
                    let (x, y) = grid.center_of(r, c);
                    let (ox, oy) = now.to_odom(f64::from(x), f64::from(y));
                    let (lx, ly) = then.to_robot(ox, oy);
                    grid.cell_of(lx as f32, ly as f32)
                        .is_some_and(|(lr, lc)| near3(n, grid.index(lr, lc), |j| last.solid[j]))
                }
                _ => false,
            };
            if !again {
                lone.push(i);
            }
        }
        // this revolution's solids, before any is passed, for the next revolution's test
        let last = &mut self.lone_last;
        for &j in &last.cells {
            last.solid[j] = false;
        }
        last.cells.clear();
        last.solid.resize(grid.len(), false);
        last.frame = pose;
        if pose.is_some() {
            for &t in &self.touched {
                let i = t as usize;
                if self.classes[i] == cell_class::SOLID {
                    last.solid[i] = true;
                    last.cells.push(i);
                }
            }
        }
        for &i in &lone {
            self.classes[i] = cell_class::PASSABLE;
            self.cost[i] = passable_cost;
        }
        self.stats.lone_passed = lone.len() as u32;
        self.lone = lone;
    }

    /// Settles `touched[self.settled..upto]`.
    fn settle(&mut self, upto: usize) {
        for t in self.settled..upto {
            let i = self.touched[t] as usize;
            self.settle_cell(i);
        }
        self.settled = self.settled.max(upto);
    }

    /// Classifies cell `i` by its own evidence (equations 3–5) into `hit_class` and marks it
    /// settled: a cell with returns is passable or solid; it is tall, or one the surface cue
    /// looks at. The same whenever it runs, so a cell settled as the slices arrive and not
    /// written since is classified as it would be at the revolution's end.
    fn settle_cell(&mut self, i: usize) {
        self.state[i] = SETTLED;
        let e = self.evidence[i];
        if e.hits == 0 {
            self.hit_class[i] = NO_HIT_CLASS;
            return;
        }
        let was_tall = self.hit_class[i] != NO_HIT_CLASS && self.hit_class[i] & TALL_BIT != 0;
        let m = self.bounds.len();
        let (below, above, zero) = (self.roles[0], self.roles[1], self.roles[2]);
        let SettleLimits {
            gamma,
            full_scale,
            solid_max_abs,
            tall_z,
            min_returns_solid,
            stop_min_returns,
            surface_cue,
        } = self.limits;
        // the cell's layers looked up once (a cell with returns is settled once or twice a
        // revolution, thousands of them in grass); the means as `Mapper::mean` has them
        let cell = &self.layer[i * m..(i + 1) * m];
        let mean_of = |l: &LayerCell| l.sum / (f32::from(l.count.max(1)) * full_scale);
        let (b, a, z) = (&cell[below], &cell[above], &cell[zero]);
        let mean = mean_of(b).max(mean_of(a)).max(mean_of(z));
        let brightest = b.max.max(a.max).max(z.max);
        let bright = f32::from(brightest) > solid_max_abs;
        let ended = e.single.saturating_add(e.stopped);
        let opaque = e.passed == 0 && ended >= min_returns_solid && 2 * ended > e.hits;
        let opaque = opaque || 2 * e.inside >= e.hits;
        // taller than grass grows and no beam passed through it: a trunk or a bush
        let tall = e.top_z > tall_z && e.passed == 0;
        // many returns and not one beam through: a surface that stops every beam, however
        // faint (grass lets some beams on from nearly every cell it returns from)
        let stops = e.passed == 0 && e.hits >= stop_min_returns;
        // the surface cue looks at cells that stand out neither by brightness or height nor
        // as an opaque surface (walls: the memory stays small)
        self.surface_candidate[i] = surface_cue && !tall && !bright && !opaque;
        let class = if mean <= gamma && !opaque && !tall && !stops && !bright {
            cell_class::PASSABLE
        } else {
            cell_class::SOLID
        };
        self.hit_class[i] = if tall { class | TALL_BIT } else { class };
        // listed once: when first found tall (one no longer tall leaves at the end)
        if tall && !was_tall {
            self.tall_cells.push(i);
        }
    }
}

impl Mapper {
    /// Keeps this revolution's surface cells in the odometry frame and draws the kept ones as
    /// solid: a rock lower than the lowest beam reaches beside the robot is out of sight while
    /// the robot passes it. Like the glass memory, it does not move without fresh odometry.
    fn remember_surfaces(&mut self, odom: OdomInput, now_ns: u64) {
        let longest_ns = self.params.surface_memory_longest_ns();
        remember_solid(
            &mut self.surface_kept,
            &self.surface_cells,
            (odom, self.last_pose),
            now_ns,
            &self.params,
            longest_ns,
            (&mut self.classes, &mut self.cost),
        );
    }

    /// Keeps this revolution's tall cells (a return above `tall_m`, no beam through) in the
    /// odometry frame, and draws the kept ones as solid where this revolution sees nothing of
    /// them: a bush's top is above the grass from a distance, but close by the beams that reach
    /// it have crossed grass and come back too faint and too few to tell it from the grass. A
    /// kept cell a beam passes through is forgotten (a curtain's strands stop every beam of a
    /// cell now and then, never for long), and one next to a solid cell of this revolution is
    /// not drawn (what is seen now is where the object is).
    fn remember_tall(&mut self, odom: OdomInput, now_ns: u64) {
        let max_age_ns = self.params.tall_memory_ns();
        if max_age_ns == 0 {
            return;
        }
        let grid = self.params.grid;
        let (classes, evidence, state) = (&self.classes, &self.evidence, &self.state);
        // a beam through the cell now: open (a curtain); forgotten with fresh odometry, at least
        // not drawn without
        let through = |i: usize| state[i] != UNTOUCHED && evidence[i].passed > 0;
        if let OdomInput::Fresh(Odom { pose, .. }) = odom {
            self.tall_kept.remember(
                &self.tall_cells,
                grid,
                &pose,
                now_ns,
                (max_age_ns, max_age_ns),
                self.params.mapper.tall_memory_m,
                through,
            );
        } else if let Some(pose) = self.last_pose {
            self.tall_kept.draw(&pose, grid);
        }
        self.tall_kept.drawn.retain(|&i| {
            classes[i] != cell_class::SOLID
                && classes[i] != cell_class::GLASS
                && !through(i)
                && !near3(grid.cells, i, |j| classes[j] == cell_class::SOLID)
        });
        for &i in &self.tall_kept.drawn {
            self.classes[i] = cell_class::SOLID;
            self.cost[i] = 255;
        }
    }

    /// The surface cue: every downward last return with at least `surface_neighbours` of the
    /// `surface_window` firings on each side within `surface_tolerance_m` of its range counts
    /// as a surface return in its cell. Only the candidates (cells not bright, tall or opaque)
    /// are looked at.
    /// The candidates that reach `min_returns` go to `surface_cells`.
    fn mark_surfaces(&mut self, min_returns: u16) {
        self.count_windows(true);
        for &(cell, z) in &self.flat {
            let cell = cell as usize;
            if !self.surface_candidate[cell] {
                continue;
            }
            let top = &mut self.surface_top[cell];
            *top = top.max(z);
            let e = &mut self.evidence[cell];
            // below every beam that passed through the cell: a curtain lets beams through at
            // every height, grass over a rock only above the rock
            if e.passed > 0 && z >= e.pass_low_z {
                continue;
            }
            e.surface = e.surface.saturating_add(1);
            if e.surface == min_returns {
                self.surface_cells.push(cell);
            }
        }
    }

    /// The cells behind each surface cell along the beam from the sensor, up to
    /// `surface_depth_m` (or a glass cell), join it: the beams met the face of the object, and
    /// nothing they returned shows where it ends (a rock under grass shows a few cells of its
    /// near face). A cell there without returns reads free (within the reach of other beams
    /// of its bearing, over the rock), which is no sign of the rock's end. Only behind a face
    /// whose surface returns all lie at most `surface_depth_top_m` above the ground (a rock
    /// under the grass is low; a higher face is a bush's or a trunk's foot, and its beams
    /// went on past their far side into the grass). The added cells follow the found ones in
    /// `surface_cells`, each once, and are kept `surface_memory_s` and no longer (a face found
    /// again and again is kept longer; its body, drawn along the beams of where the sensor
    /// stood, is not).
    fn deepen_surfaces(&mut self, odom: OdomInput, now_ns: u64) {
        let depth = self.params.mapper.surface_depth_m as f32;
        let found = self.surface_cells.len();
        if depth <= 0.0 {
            return;
        }
        let grid = self.params.grid;
        let sensor = (
            self.params.robot.mount.x_m as f32,
            self.params.robot.mount.y_m as f32,
        );
        let step = 0.5 * grid.cell_m;
        let steps = (depth / step).ceil() as usize;
        // a rock under the grass is low
        let top_z =
            (self.params.mapper.surface_depth_top_m - self.params.robot.sensor_height_m) as f32;
        for k in 0..found {
            let i = self.surface_cells[k];
            if self.surface_top[i] > top_z {
                continue;
            }
            let (x, y) = grid.center_of(i / grid.cells, i % grid.cells);
            let (dx, dy) = (x - sensor.0, y - sensor.1);
            let d = dx.hypot(dy);
            if d < 1e-3 {
                continue;
            }
            let (ux, uy) = (dx / d, dy / d);
            for s in 1..=steps {
                let t = (s as f32 * step).min(depth);
                let Some((r, c)) = grid.cell_of(x + ux * t, y + uy * t) else {
                    break;
                };
                let j = grid.index(r, c);
                if self.classes[j] == cell_class::GLASS {
                    break;
                }
                if j != i {
                    self.surface_cells.push(j);
                }
            }
        }
        // the added cells after the found ones, each once and none of the found
        let (faces, added) = self.surface_cells.split_at_mut(found);
        faces.sort_unstable();
        added.sort_unstable();
        let mut keep = found;
        for k in found..self.surface_cells.len() {
            let j = self.surface_cells[k];
            if self.surface_cells[..found].binary_search(&j).is_err()
                && (keep == found || self.surface_cells[keep - 1] != j)
            {
                self.surface_cells[keep] = j;
                keep += 1;
            }
        }
        self.surface_cells.truncate(keep);
        let memory_ns = self.params.surface_memory_ns();
        remember_solid(
            &mut self.body_kept,
            &self.surface_cells[found..],
            (odom, self.last_pose),
            now_ns,
            &self.params,
            memory_ns,
            (&mut self.classes, &mut self.cost),
        );
        draw_solid(
            &self.surface_cells[found..],
            (&mut self.classes, &mut self.cost),
        );
    }

    /// Counts the surface cue's window of every return along its ring whose window is whole:
    /// all the ring's returns once the revolution is (`whole`), else those with `surface_window`
    /// returns after them. A window holds the same returns then as at the revolution's end.
    fn count_windows(&mut self, whole: bool) {
        let w = self.params.mapper.surface_window as usize;
        let need = self.params.mapper.surface_neighbours as usize;
        let tol = self.params.mapper.surface_tolerance_m as f32;
        let shaded = self.params.mapper.surface_shaded_neighbours as usize;
        let beyond_max = self.params.mapper.surface_beyond_max as usize;
        for (ring, counted) in self.last_rings.iter().zip(&mut self.last_counted) {
            let ranges = &ring.ranges[..];
            let end = if whole {
                ranges.len()
            } else {
                ranges.len().saturating_sub(w)
            };
            for (k, lr) in ring.returns.iter().enumerate().take(end).skip(*counted) {
                if lr.cell == NO_CELL {
                    continue;
                }
                let range = ranges[k];
                // the return itself is within the tolerance of itself: need + 1 in the window.
                // The whole window is counted: stopping once they are there saved a few
                // comparisons and cost a mispredicted branch a return in grass; counted in a
                // u32 so that the compares' lanes add as they are (a usize count widened each)
                let near = &ranges[k.saturating_sub(w)..(k + w + 1).min(ranges.len())];
                let same: u32 = near
                    .iter()
                    .map(|&q| u32::from((q - range).abs() < tol))
                    .sum();
                if same as usize > need
                    || (shaded > 0 && same as usize > shaded && {
                        // in the shade of blades: the window's other firings ended short of
                        // it (nearer) and but a few went past it (its sides, a gap); a ground
                        // return's range is negative, farther by its size
                        let beyond: u32 =
                            near.iter().map(|&q| u32::from(q.abs() > range + tol)).sum();
                        beyond as usize <= beyond_max
                    })
                {
                    self.flat.push((lr.cell, lr.z));
                }
            }
            *counted = (*counted).max(end);
        }
    }
}

/// Keeps `cells` in `kept` (with fresh odometry; else draws it as it is from the last pose),
/// each `surface_memory_s` after it was last found and half that longer for each further
/// revolution it was found in, up to `longest_ns`; draws the kept cells solid (not over glass).
fn remember_solid(
    kept: &mut Kept,
    cells: &[usize],
    (odom, last_pose): (OdomInput, Option<Pose2>),
    now_ns: u64,
    params: &MapperParams,
    longest_ns: u64,
    (classes, cost): (&mut [u8], &mut [u8]),
) {
    let max_age_ns = params.surface_memory_ns();
    if max_age_ns == 0 {
        return;
    }
    let grid = params.grid;
    if let OdomInput::Fresh(Odom { pose, .. }) = odom {
        // kept once found again: a rock is on its surface revolution after revolution, a
        // curtain's swaying strands only now and then
        kept.remember(
            cells,
            grid,
            &pose,
            now_ns,
            (max_age_ns, longest_ns),
            params.mapper.surface_memory_m,
            |_| false,
        );
    } else if let Some(pose) = last_pose {
        kept.draw(&pose, grid);
    }
    draw_solid(&kept.drawn, (classes, cost));
}

/// Draws `cells` solid, but not over glass.
fn draw_solid(cells: &[usize], (classes, cost): (&mut [u8], &mut [u8])) {
    for &i in cells {
        if classes[i] != cell_class::GLASS {
            classes[i] = cell_class::SOLID;
            cost[i] = 255;
        }
    }
}

/// Cells kept in the odometry frame once found in two revolutions in a row (near each other),
/// forgotten by age and distance, like the glass memory. Entries are deduplicated through the
/// grid as they are drawn (one per cell), so the memory needs no hashing: it is worked on for
/// hundreds of cells every revolution.
#[derive(Debug)]
struct Kept {
    /// The kept cells.
    entries: Vec<KeptCell>,
    /// Odometry-frame centres of the cells found in the last revolution.
    last: Vec<(f64, f64)>,
    /// The kept cells in the grid, this revolution.
    drawn: Vec<usize>,
    /// Per cell: the entry drawn there ([`NO_CELL`]: none); reset after each use.
    slot: Vec<u32>,
    /// Per cell: a cell of the last revolution lies there; reset after each use.
    near_last: Vec<bool>,
    /// Cells flagged in `near_last`.
    flagged: Vec<usize>,
}

/// A kept cell: its odometry-frame centre, when it was last found and in how many revolutions.
#[derive(Debug, Clone, Copy)]
struct KeptCell {
    x: f64,
    y: f64,
    found_ns: u64,
    finds: u32,
}

impl Kept {
    fn new(cells: usize) -> Self {
        Kept {
            entries: Vec::new(),
            last: Vec::new(),
            drawn: Vec::new(),
            slot: vec![NO_CELL; cells],
            near_last: vec![false; cells],
            flagged: Vec::new(),
        }
    }

    /// Entries held.
    fn len(&self) -> usize {
        self.entries.len()
    }

    /// How long after it was last found a cell found in `finds` revolutions is kept: `max_age_ns`
    /// after its second find, half that longer each further find, up to `longest_ns`.
    fn age_limit_ns(finds: u32, (max_age_ns, longest_ns): (u64, u64)) -> u64 {
        let grown = u64::from(finds.max(2)).saturating_mul(max_age_ns / 2);
        grown.min(longest_ns).max(max_age_ns)
    }

    /// Draws the entries seen from `pose` into `drawn` (one entry per cell: duplicates merge,
    /// keeping the latest time) and, with `keep` = Some((now, ages, max distance)), forgets
    /// entries older than their [age limit](Self::age_limit_ns), farther than that, or in a cell
    /// `forget` names. Leaves `slot` set for
    /// the drawn cells.
    fn place(
        &mut self,
        pose: &Pose2,
        grid: GridSpec,
        keep: Option<(u64, (u64, u64), f64)>,
        forget: impl Fn(usize) -> bool,
    ) {
        self.drawn.clear();
        let frame = Frame::of(pose);
        let mut out = 0;
        for k in 0..self.entries.len() {
            let e = self.entries[k];
            if let Some((now, ages, dist)) = keep
                && (now.saturating_sub(e.found_ns) > Self::age_limit_ns(e.finds, ages)
                    || (e.x - pose.x()).hypot(e.y - pose.y()) > dist)
            {
                continue;
            }
            let (rx, ry) = frame.to_robot(e.x, e.y);
            if let Some((r, c)) = grid.cell_of(rx as f32, ry as f32) {
                let i = grid.index(r, c);
                if keep.is_some() && forget(i) {
                    continue;
                }
                let j = self.slot[i];
                if j != NO_CELL {
                    let held = &mut self.entries[j as usize];
                    held.found_ns = held.found_ns.max(e.found_ns);
                    held.finds = held.finds.max(e.finds);
                    continue;
                }
                self.slot[i] = out as u32;
                self.drawn.push(i);
            }
            self.entries[out] = e;
            out += 1;
        }
        self.entries.truncate(out);
    }

    /// Keeps the `cells` found now (robot grid, seen from `pose`) that lie near a cell found in
    /// the last revolution, forgets entries older than `ages` = (max age, longest) say
    /// ([`Kept::age_limit_ns`]), farther than `max_m` or in a
    /// cell `forget` names, and draws the memory.
    #[allow(clippy::too_many_arguments)]
    fn remember(
        &mut self,
        cells: &[usize],
        grid: GridSpec,
        pose: &Pose2,
        now_ns: u64,
        ages: (u64, u64),
        max_m: f64,
        forget: impl Fn(usize) -> bool,
    ) {
        self.place(pose, grid, Some((now_ns, ages, max_m)), forget);
        let frame = Frame::of(pose);
        for &(ox, oy) in &self.last {
            let (rx, ry) = frame.to_robot(ox, oy);
            if let Some((r, c)) = grid.cell_of(rx as f32, ry as f32) {
                let i = grid.index(r, c);
                if !self.near_last[i] {
                    self.near_last[i] = true;
                    self.flagged.push(i);
                }
            }
        }
        let n = grid.cells;
        self.last.clear();
        for &i in cells {
            let (r, c) = (i / n, i % n);
            let (x, y) = grid.center_of(r, c);
            let (ox, oy) = frame.to_odom(f64::from(x), f64::from(y));
            self.last.push((ox, oy));
            if !near3(n, i, |j| self.near_last[j]) {
                continue;
            }
            match self.slot[i] {
                NO_CELL => {
                    self.slot[i] = self.entries.len() as u32;
                    self.entries.push(KeptCell {
                        x: ox,
                        y: oy,
                        found_ns: now_ns,
                        finds: 2,
                    });
                    self.drawn.push(i);
                }
                j => {
                    let e = &mut self.entries[j as usize];
                    e.found_ns = now_ns;
                    e.finds = e.finds.saturating_add(1);
                }
            }
        }
        for &i in &self.flagged {
            self.near_last[i] = false;
        }
        self.flagged.clear();
        self.reset_slots();
    }

    /// Draws the memory seen from `pose`, as it is (no fresh odometry: nothing is added or
    /// forgotten).
    fn draw(&mut self, pose: &Pose2, grid: GridSpec) {
        self.place(pose, grid, None, |_| false);
        self.reset_slots();
    }

    fn reset_slots(&mut self) {
        for &i in &self.drawn {
            self.slot[i] = NO_CELL;
        }
    }
}

/// Whether `f` holds for cell i of an n × n grid or one of the cells around it.
#[inline]
fn near3(n: usize, i: usize, f: impl Fn(usize) -> bool) -> bool {
    let (r, c) = (i / n, i % n);
    (r.saturating_sub(1)..=(r + 1).min(n - 1))
        .any(|rr| (c.saturating_sub(1)..=(c + 1).min(n - 1)).any(|cc| f(rr * n + cc)))
}

/// The solid cells of the last revolution (before lone ones were passed) and the frame they were
/// found in (`None`: no fresh odometry then).
#[derive(Debug, Default)]
struct LastSolids {
    /// Per cell: solid in the last revolution.
    solid: Vec<bool>,
    /// The cells set in `solid`.
    cells: Vec<usize>,
    frame: Option<Frame>,
}

/// One layer of one cell.
#[derive(Debug, Clone, Copy, Default)]
struct LayerCell {
    sum: f32,
    count: u16,
    max: u8,
}

/// What the dual returns say about one cell.
#[derive(Debug, Clone, Copy)]
struct Evidence {
    /// Returns in the main layers.
    hits: u16,
    /// Of those, firings with one echo.
    single: u16,
    /// Returns another return of the same firing lies behind (by more than a cell).
    passed: u16,
    /// Weak returns just behind a bright one of the same firing.
    inside: u16,
    /// Last returns much stronger than the rest of their firing.
    stopped: u16,
    /// Downward last returns on a surface along their ring, lower than any beam passed
    /// through the cell.
    surface: u16,
    /// Height of the lowest return a beam passed through (with `passed` > 0), sensor frame, m.
    pass_low_z: f32,
    /// Height of the highest return, sensor frame, m.
    top_z: f32,
}

impl Default for Evidence {
    fn default() -> Self {
        Self {
            hits: 0,
            single: 0,
            passed: 0,
            inside: 0,
            stopped: 0,
            surface: 0,
            pass_low_z: 0.0,
            // below every return: the first one raises it
            top_z: f32::NEG_INFINITY,
        }
    }
}

/// Cell `i` is written: listed in `touched` the first time, in `redo` when it was settled.
#[inline]
fn touch(state: &mut [u8], touched: &mut Vec<u32>, redo: &mut Vec<u32>, i: usize) {
    match state[i] {
        UNTOUCHED => {
            state[i] = TOUCHED;
            touched.push(i as u32);
        }
        SETTLED => {
            state[i] = TOUCHED;
            redo.push(i as u32);
        }
        _ => {}
    }
}

/// One point of the slice being binned, as [`Mapper::bin`]'s first pass leaves it.
#[derive(Debug, Clone, Copy, Default)]
struct Placed {
    /// De-skewed position, robot frame at the revolution's reference time, m.
    x: f32,
    y: f32,
    /// The de-skew's rotation (rad, small angle) and shift along x (m) from the firing time.
    th: f32,
    shift: f32,
    /// The grid cell of (x, y) (the ground not tested), or [`NO_CELL`] off the grid.
    cell: u32,
    /// Azimuth, de-skewed, hundredths of a degree in [0, 36000).
    az_cdeg: u16,
}

/// The small-angle rotation the de-skew uses (exact enough below 0.3 rad): (sin, cos).
#[inline(always)]
fn small_angle(th: f32) -> (f32, f32) {
    (th, 1.0 - 0.5 * th * th)
}

/// An azimuth in hundredths of a degree brought into [0, 36000): `rem_euclid(36000)`, without
/// the division where it is already no more than one turn off (a de-skew's few degrees).
#[inline(always)]
fn wrap_cdeg(a: i32) -> u16 {
    let a = if a < 0 {
        a + 36000
    } else if a >= 36000 {
        a - 36000
    } else {
        a
    };
    if (0..36000).contains(&a) {
        a as u16
    } else {
        a.rem_euclid(36000) as u16
    }
}

/// Asks the processor to bring `s[i..i + n]` into the cache by its first and its last byte (the
/// lines between them too while the run is no longer than a cache line: a cell's layers or its
/// evidence); nothing where it cannot, or the run is empty or out of bounds. A hint only: what
/// the program computes does not change.
#[inline(always)]
fn prefetch<T>(s: &[T], i: usize, n: usize) {
    #[cfg(target_arch = "x86_64")]
    if let Some(run) = s.get(i..i.saturating_add(n))
        && !run.is_empty()
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        let first = run.as_ptr().cast::<i8>();
        // SAFETY: a prefetch never faults nor changes memory; both addresses are in `run`
        // (its first and last byte; the same one for a type of no size)
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>(first);
            _mm_prefetch::<_MM_HINT_T0>(first.add(size_of_val(run).saturating_sub(1)));
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (s, i, n);
}

/// Four layers' bounds side by side, so that the four tests of a point compile to a few vector
/// instructions (a layer's test and its branch were a sixth of the binning's second pass in
/// grass).
#[derive(Debug, Clone, Copy)]
struct LayerQuad {
    /// All ones where the layer is in elevation (tests `sin_el`), zeros where in metres (`z`).
    elevation: [u32; 4],
    low: [f32; 4],
    high: [f32; 4],
}

impl LayerQuad {
    /// `bounds` in fours; the last four padded with layers that hold nothing (low +∞, high −∞:
    /// no number, nor a NaN, is at once at least the one and below the other).
    fn of(bounds: &[LayerBounds]) -> Vec<LayerQuad> {
        bounds
            .chunks(4)
            .map(|four| {
                let mut q = LayerQuad {
                    elevation: [0; 4],
                    low: [f32::INFINITY; 4],
                    high: [f32::NEG_INFINITY; 4],
                };
                for (l, b) in four.iter().enumerate() {
                    q.elevation[l] = if b.elevation { u32::MAX } else { 0 };
                    q.low[l] = b.low;
                    q.high[l] = b.high;
                }
                q
            })
            .collect()
    }

    /// Bit l set where the point (height `z`, elevation's sine `sin_el`) lies in layer l of the
    /// four: [`in_layer`]'s test, the value picked by its bits (exactly `z` or `sin_el`).
    #[inline(always)]
    fn within(&self, z: f32, sin_el: f32) -> u32 {
        let (zb, sb) = (z.to_bits(), sin_el.to_bits());
        let mut bits = 0;
        for l in 0..4 {
            let e = self.elevation[l];
            let v = f32::from_bits((zb & !e) | (sb & e));
            bits |= u32::from((v >= self.low[l]) & (v < self.high[l])) << l;
        }
        bits
    }
}

/// `max.max(x)` for a running maximum `max` that is never NaN (it starts at a number and only
/// ever takes a greater one): `x` where greater, else `max` — a NaN `x` leaves `max`, as
/// `f32::max` does. One compare and select a point, where `f32::max` must test `max` for NaN too.
#[inline(always)]
fn running_max(max: f32, x: f32) -> f32 {
    if x > max { x } else { max }
}

#[inline]
fn in_layer(b: &LayerBounds, z: f32, sin_el: f32) -> bool {
    let v = if b.elevation { sin_el } else { z };
    v >= b.low && v < b.high
}

#[cfg(test)]
mod tests;
