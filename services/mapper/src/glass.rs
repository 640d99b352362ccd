//! Glass: detection in one revolution, and the memory that keeps it.
//!
//! Detection follows Algorithm 1 of `cartographer-glass.txt` along each near-horizontal laser's
//! ring of returns (whose text is damaged; restated in DESIGN §6): a run of returns whose
//! intensity reaches `threshold`, entered by a rise of at least `gradient` and left by a fall of
//! at least `gradient` within `width` of azimuth, with equal ranges at both edges (the spike sits
//! on one surface, not on the edge of an object). *Interpretation:* the width is measured in
//! degrees rather than beams because the VLP-16's azimuth step changes with its rotation rate;
//! a missing return counts as intensity 0 and range 0.
//!
//! The memory implements equations 6 and 7 of `mim-lidar-intensity-navigation.txt`: detected
//! glass is stored in the odometry frame (I_FN^t = T · …) and joined with every later
//! detection (I_FN^{t+1} ∪ I_FN^t). Beams that later pass through the pane never erase it (the
//! lesson of `cartographer-glass.txt`); an entry expires only by age or distance. Gaps between
//! detections along a pane, up to a configured length, are filled when the memory is drawn.

use std::collections::HashMap;

use crate::config::MapperConfig;
use mimnav_shared::grid::GridSpec;
pub use mimnav_shared::pose::Pose2;
use mimnav_shared::pose::Pose2Ext;

/// One return along a laser's ring.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RingReturn {
    /// Azimuth, degrees.
    pub azimuth_deg: f32,
    /// Intensity (0 where there was no return).
    pub intensity: f32,
    /// Horizontal range, m (0 where there was no return).
    pub range_m: f32,
}

/// Marks in `out` (same length as `ring`) the returns that form intensity spikes, by the glass
/// keys of `[mapper]`: returns at least `glass_intensity` bright, rising into and falling out of
/// the spike by at least `glass_gradient`, at most `glass_width_deg` wide, with the ranges at its
/// two edges within `glass_range_tolerance_m`.
pub fn detect_spikes(ring: &[RingReturn], p: &MapperConfig, out: &mut Vec<bool>) {
    let threshold = p.glass_intensity as f32;
    let gradient = p.glass_gradient as f32;
    let (width_deg, range_tolerance_m) =
        (p.glass_width_deg as f32, p.glass_range_tolerance_m as f32);
    out.clear();
    out.resize(ring.len(), false);
    let n = ring.len();
    let mut k = 1;
    while k + 1 < n {
        let rise = ring[k].intensity - ring[k - 1].intensity;
        if ring[k].intensity < threshold || rise < gradient {
            k += 1;
            continue;
        }
        // walk the run of high returns
        let mut end = k;
        while end + 1 < n && ring[end + 1].intensity >= threshold {
            end += 1;
        }
        if end + 1 >= n {
            break;
        }
        let fall = ring[end].intensity - ring[end + 1].intensity;
        let mut width = (ring[end].azimuth_deg - ring[k].azimuth_deg).abs();
        if width > 180.0 {
            width = 360.0 - width;
        }
        let edges_agree = (ring[k - 1].range_m - ring[end + 1].range_m).abs() <= range_tolerance_m;
        if fall >= gradient && width <= width_deg && edges_agree {
            for o in &mut out[k..=end] {
                *o = true;
            }
        }
        k = end + 1;
    }
}

/// Detected glass, kept in the odometry frame.
#[derive(Debug, Clone, Default)]
pub struct GlassMemory {
    /// Cell-sized keys in the odometry frame → (x, y, last seen ns).
    entries: HashMap<(i64, i64), (f64, f64, u64)>,
    cell_m: f64,
}

/// A [`Pose2`] ready to move many points between the robot and odometry frames: its sine and
/// cosine in plain numbers, for the inner loops (everything else uses [`Pose2Ext`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    x: f64,
    y: f64,
    sin: f64,
    cos: f64,
}

impl Frame {
    /// The frame of `pose`.
    pub fn of(pose: &Pose2) -> Frame {
        // a unit complex holds the heading's cosine and sine as they were worked out
        Frame {
            x: pose.translation.x,
            y: pose.translation.y,
            sin: pose.rotation.im,
            cos: pose.rotation.re,
        }
    }

    /// Robot frame → odometry frame.
    #[inline]
    pub fn to_odom(&self, x: f64, y: f64) -> (f64, f64) {
        (
            self.x + self.cos * x - self.sin * y,
            self.y + self.sin * x + self.cos * y,
        )
    }

    /// Odometry frame → robot frame.
    #[inline]
    pub fn to_robot(&self, x: f64, y: f64) -> (f64, f64) {
        let (dx, dy) = (x - self.x, y - self.y);
        (
            self.cos * dx + self.sin * dy,
            -self.sin * dx + self.cos * dy,
        )
    }
}

impl GlassMemory {
    /// An empty memory that merges detections closer than `cell_m`.
    pub fn new(cell_m: f64) -> Self {
        GlassMemory {
            entries: HashMap::new(),
            cell_m: cell_m.max(1e-3),
        }
    }

    /// Entries held.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when nothing is held.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Adds a detection at robot-frame (x, y) seen from `pose` at `now_ns` (equation 6).
    pub fn add(&mut self, pose: &Pose2, x: f64, y: f64, now_ns: u64) {
        let (ox, oy) = Frame::of(pose).to_odom(x, y);
        let key = (
            (ox / self.cell_m).floor() as i64,
            (oy / self.cell_m).floor() as i64,
        );
        self.entries.insert(key, (ox, oy, now_ns));
    }

    /// Forgets entries older than `max_age_ns` or farther than `max_distance_m` from `pose`.
    pub fn expire(&mut self, pose: &Pose2, now_ns: u64, max_age_ns: u64, max_distance_m: f64) {
        self.entries.retain(|_, (x, y, t)| {
            now_ns.saturating_sub(*t) <= max_age_ns
                && (*x - pose.x()).hypot(*y - pose.y()) <= max_distance_m
        });
    }

    /// Draws the memory into `grid` around `pose` (equation 7): pushes the indices of the glass
    /// cells to `cells`, each once, filling gaps up to `gap_fill_m` between entries along a line.
    /// `marked` (one flag per cell, all false) tracks what was pushed and is left all false.
    pub fn draw(
        &self,
        pose: &Pose2,
        grid: GridSpec,
        gap_fill_m: f64,
        cells: &mut Vec<usize>,
        marked: &mut [bool],
    ) {
        let first = cells.len();
        let push = |i: usize, cells: &mut Vec<usize>, marked: &mut [bool]| {
            if !marked[i] {
                marked[i] = true;
                cells.push(i);
            }
        };
        let fill = gap_fill_m > 0.0;
        let mut pts: Vec<(f64, f64)> = Vec::new();
        let frame = Frame::of(pose);
        for (x, y, _) in self.entries.values() {
            let (rx, ry) = frame.to_robot(*x, *y);
            if let Some((r, c)) = grid.cell_of(rx as f32, ry as f32) {
                push(grid.index(r, c), cells, marked);
                if fill {
                    pts.push((rx, ry));
                }
            }
        }
        // join entries closer than the gap: a pane detected in pieces becomes one
        let fill = fill && pts.len() >= 2;
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let step = f64::from(grid.cell_m) * 0.5;
        for i in 0..if fill { pts.len() } else { 0 } {
            for j in i + 1..pts.len() {
                if pts[j].0 - pts[i].0 > gap_fill_m {
                    break;
                }
                let d = (pts[j].0 - pts[i].0).hypot(pts[j].1 - pts[i].1);
                if d > gap_fill_m || d < 2.0 * step {
                    continue;
                }
                // a drawn midpoint means no gap between the two (the entries run on between
                // them, or an earlier line already crossed it): nothing to fill, and skipping
                // keeps a long pane from drawing every pair of its entries
                let (mx, my) = (0.5 * (pts[i].0 + pts[j].0), 0.5 * (pts[i].1 + pts[j].1));
                if grid
                    .cell_of(mx as f32, my as f32)
                    .is_some_and(|(r, c)| marked[grid.index(r, c)])
                {
                    continue;
                }
                let n = (d / step).ceil() as usize;
                for k in 1..n {
                    let t = k as f64 / n as f64;
                    let x = pts[i].0 + t * (pts[j].0 - pts[i].0);
                    let y = pts[i].1 + t * (pts[j].1 - pts[i].1);
                    if let Some((r, c)) = grid.cell_of(x as f32, y as f32) {
                        push(grid.index(r, c), cells, marked);
                    }
                }
            }
        }
        for &i in &cells[first..] {
            marked[i] = false;
        }
    }
}

/// Extends panes to the solid structure that holds them (the extrapolation of the paper's
/// Fig. 5: "the glass between the pillars is extrapolated").
///
/// The glass cells are grouped (cells closer than `link_m`); a group of at least three cells
/// that lies along a line is extended from both ends along that line through free cells, and the
/// extension is kept only where it meets a solid cell within `max_m` — so a pane between pillars
/// closes up, while a detection with nothing solid in line (or a passable curtain, or unknown
/// space, in the way) is left as it is. Returns the cells added.
pub fn extend_to_solids(
    glass: &[usize],
    classes: &[u8],
    grid: GridSpec,
    link_m: f32,
    max_m: f32,
    marked: &mut [bool],
) -> Vec<usize> {
    use mimnav_shared::topics::cell_class;
    let mut added = Vec::new();
    if max_m <= 0.0 || glass.len() < 3 {
        return added;
    }
    // group by flood fill over the grid (neighbours within link_m), unmarking as it goes, so
    // `marked` ends all false again
    for &i in glass {
        marked[i] = true;
    }
    let reach = (link_m / grid.cell_m).floor() as i64;
    let n = grid.cells as i64;
    let step = grid.cell_m * 0.5;
    let mut members: Vec<(f32, f32)> = Vec::new();
    let mut stack: Vec<usize> = Vec::new();
    for &start in glass {
        if !marked[start] {
            continue;
        }
        marked[start] = false;
        members.clear();
        stack.push(start);
        while let Some(a) = stack.pop() {
            members.push(grid.center_of(a / grid.cells, a % grid.cells));
            let (r, c) = ((a / grid.cells) as i64, (a % grid.cells) as i64);
            for dr in -reach..=reach {
                for dc in -reach..=reach {
                    let (rr, cc) = (r + dr, c + dc);
                    if rr < 0 || cc < 0 || rr >= n || cc >= n || dr * dr + dc * dc > reach * reach {
                        continue;
                    }
                    let b = (rr * n + cc) as usize;
                    if marked[b] {
                        marked[b] = false;
                        stack.push(b);
                    }
                }
            }
        }
        if members.len() < 3 {
            continue;
        }
        // principal direction of the group
        let count = members.len() as f32;
        let mx = members.iter().map(|p| p.0).sum::<f32>() / count;
        let my = members.iter().map(|p| p.1).sum::<f32>() / count;
        let (mut sxx, mut syy, mut sxy) = (0.0f32, 0.0f32, 0.0f32);
        for p in &members {
            let (dx, dy) = (p.0 - mx, p.1 - my);
            sxx += dx * dx;
            syy += dy * dy;
            sxy += dx * dy;
        }
        let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let (uy, ux) = angle.sin_cos();
        // elongated: the spread across the line is small against the spread along it
        let (mut lo, mut hi, mut across) = (f32::INFINITY, f32::NEG_INFINITY, 0.0f32);
        for p in &members {
            let along = (p.0 - mx) * ux + (p.1 - my) * uy;
            lo = lo.min(along);
            hi = hi.max(along);
            across = across.max((-(p.0 - mx) * uy + (p.1 - my) * ux).abs());
        }
        if hi - lo < 2.0 * grid.cell_m || across > (hi - lo) * 0.25 + grid.cell_m {
            continue;
        }
        for (from, dir) in [(hi, 1.0f32), (lo, -1.0f32)] {
            let path_start = added.len();
            let mut t = step;
            let mut closed = false;
            while t <= max_m {
                let s = from + dir * t;
                let Some((r, c)) = grid.cell_of(mx + s * ux, my + s * uy) else {
                    break;
                };
                let i = grid.index(r, c);
                match classes[i] {
                    cell_class::FREE => added.push(i),
                    cell_class::GLASS => {}
                    cell_class::SOLID => {
                        closed = true;
                        break;
                    }
                    _ => break,
                }
                t += step;
            }
            if !closed {
                added.truncate(path_start);
            }
        }
    }
    added.sort_unstable();
    added.dedup();
    added
}

#[cfg(test)]
mod tests {
    use super::*;
    use mimnav_shared::pose::pose2;

    fn ring(intensities: &[f32], ranges: &[f32]) -> Vec<RingReturn> {
        intensities
            .iter()
            .zip(ranges)
            .enumerate()
            .map(|(i, (&intensity, &range_m))| RingReturn {
                azimuth_deg: i as f32 * 0.2,
                intensity,
                range_m,
            })
            .collect()
    }

    /// The default glass keys, with spikes at most 2° wide.
    fn p() -> MapperConfig {
        MapperConfig {
            glass_intensity: 100.0,
            glass_gradient: 30.0,
            glass_width_deg: 2.0,
            glass_range_tolerance_m: 0.3,
            ..MapperConfig::default()
        }
    }

    #[test]
    fn a_spike_on_one_surface_is_glass() {
        let r = ring(
            &[20.0, 22.0, 180.0, 230.0, 170.0, 25.0, 21.0],
            &[8.0, 8.0, 4.0, 4.0, 4.0, 8.1, 8.0],
        );
        let mut out = Vec::new();
        detect_spikes(&r, &p(), &mut out);
        assert_eq!(out, [false, false, true, true, true, false, false]);
    }

    #[test]
    fn a_wide_plateau_a_slow_rise_or_an_object_edge_is_not() {
        let mut out = Vec::new();
        // wider than 2°: a retro-reflective sign, not a specular spike
        let wide: Vec<f32> = (0..20)
            .map(|i| if (2..18).contains(&i) { 200.0 } else { 20.0 })
            .collect();
        detect_spikes(&ring(&wide, &[5.0; 20]), &p(), &mut out);
        assert!(out.iter().all(|&g| !g));
        // no rise: below the gradient
        detect_spikes(
            &ring(&[90.0, 105.0, 110.0, 95.0], &[5.0; 4]),
            &p(),
            &mut out,
        );
        assert!(out.iter().all(|&g| !g));
        // edges at different ranges: the spike sits on an object's edge
        detect_spikes(
            &ring(&[20.0, 200.0, 20.0], &[3.0, 4.0, 9.0]),
            &p(),
            &mut out,
        );
        assert!(out.iter().all(|&g| !g));
    }

    #[test]
    fn memory_moves_with_odometry_and_is_not_erased() {
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let mut m = GlassMemory::new(0.05);
        // seen 2 m ahead from the origin
        let p0 = pose2(0.0, 0.0, 0.0);
        m.add(&p0, 2.0, 0.0, 0);
        // the robot drove 1 m forward and turned left 90°: the glass is now 1 m to its right
        let p1 = pose2(1.0, 0.0, std::f64::consts::FRAC_PI_2);
        let mut cells = Vec::new();
        m.draw(&p1, grid, 0.0, &mut cells, &mut vec![false; grid.len()]);
        let (r, c) = grid.cell_of(0.0, -1.0).expect("inside");
        assert_eq!(
            cells,
            vec![grid.index(r, c)],
            "equation 6: moved by the robot's motion"
        );
        // expiry by age and distance only
        m.expire(&p1, 1_000_000_000, 5_000_000_000, 8.0);
        assert_eq!(m.len(), 1);
        m.expire(&p1, 6_000_000_000, 5_000_000_000, 8.0);
        assert!(m.is_empty());
    }

    #[test]
    fn a_pane_is_extended_to_the_pillars_but_not_into_the_open() {
        use mimnav_shared::topics::cell_class;
        let grid = GridSpec {
            cells: 100,
            cell_m: 0.05,
        };
        let mut classes = vec![cell_class::FREE; grid.len()];
        let idx = |x: f32, y: f32| {
            let (r, c) = grid.cell_of(x, y).expect("inside");
            grid.index(r, c)
        };
        // a pane along y at x = 1.5, seen between y = -0.1 and 0.1; pillars at y = ±1.0
        let glass: Vec<usize> = (-2..=2).map(|k| idx(1.5, k as f32 * 0.05)).collect();
        classes[idx(1.5, 1.0)] = cell_class::SOLID;
        classes[idx(1.5, -1.0)] = cell_class::SOLID;
        let added = extend_to_solids(
            &glass,
            &classes,
            grid,
            0.3,
            2.0,
            &mut vec![false; grid.len()],
        );
        assert!(
            added.contains(&idx(1.5, 0.6)) && added.contains(&idx(1.5, -0.6)),
            "closed up to the pillars"
        );
        assert!(!added.contains(&idx(1.5, 1.2)), "not past them");
        // without a pillar in line on one side, that side stays open
        classes[idx(1.5, -1.0)] = cell_class::FREE;
        let added = extend_to_solids(
            &glass,
            &classes,
            grid,
            0.3,
            2.0,
            &mut vec![false; grid.len()],
        );
        assert!(added.contains(&idx(1.5, 0.6)));
        assert!(
            !added.contains(&idx(1.5, -0.6)),
            "nothing solid in line: no extrapolation"
        );
        // a passable curtain in the way stops it
        classes[idx(1.5, 0.5)] = cell_class::PASSABLE;
        let added = extend_to_solids(
            &glass,
            &classes,
            grid,
            0.3,
            2.0,
            &mut vec![false; grid.len()],
        );
        assert!(added.is_empty(), "{added:?}");
    }

    #[test]
    fn gaps_along_a_pane_are_filled() {
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let mut m = GlassMemory::new(0.05);
        let p = Pose2::identity();
        m.add(&p, 3.0, -0.3, 0);
        m.add(&p, 3.0, 0.3, 0);
        m.add(&p, 3.0, 2.0, 0); // too far to join
        let mut cells = Vec::new();
        m.draw(&p, grid, 0.8, &mut cells, &mut vec![false; grid.len()]);
        let (r, c) = grid.cell_of(3.0, 0.0).expect("inside");
        assert!(cells.contains(&grid.index(r, c)), "the 0.6 m gap is filled");
        let (r, c) = grid.cell_of(3.0, 1.2).expect("inside");
        assert!(!cells.contains(&grid.index(r, c)), "the 1.7 m gap is not");
    }

    #[test]
    fn a_long_pane_with_a_gap_draws_exactly_its_line() {
        // a pane across the heading (every entry at the same x: the order the fill sorts by
        // does not separate them), detected in two pieces with a 0.35 m gap
        let grid = GridSpec {
            cells: 200,
            cell_m: 0.05,
        };
        let mut m = GlassMemory::new(0.05);
        let p = Pose2::identity();
        let ys: Vec<f64> = (0..=40)
            .map(|k| -1.0 + 0.05 * f64::from(k) + 0.025)
            .filter(|y| y.abs() > 0.2)
            .collect();
        for &y in &ys {
            m.add(&p, 3.025, y, 0);
        }
        let mut cells = Vec::new();
        m.draw(&p, grid, 0.8, &mut cells, &mut vec![false; grid.len()]);
        let line: Vec<usize> = (0..=40)
            .map(|k| {
                let (r, c) = grid
                    .cell_of(3.025, -1.0 + 0.05 * k as f32 + 0.025)
                    .expect("in");
                grid.index(r, c)
            })
            .collect();
        for i in &line {
            assert!(
                cells.contains(i),
                "cell {i} of the pane or its gap is drawn"
            );
        }
        assert_eq!(cells.len(), line.len(), "nothing off the pane: {cells:?}");
    }
}
