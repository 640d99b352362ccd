//! The mapper service's step: everything between receiving a revolution (and the odometry) and
//! publishing the map, without IPC and without reading a clock (every call is given `now`,
//! monotonic ns). The service, `mimnav eval`, `mimnav score-map` and the lock-step runner drive
//! this type alike.
//!
//! Odometry decides how a revolution is mapped:
//! - none received yet: mapped without de-skew, the memories stay put, the header's status says
//!   [`map_status::ODOM_MISSING`];
//! - older than `mapper.odom_max_age_s` when the revolution arrives: the same, with
//!   [`map_status::ODOM_STALE`];
//! - a message with a non-finite number is refused where it arrives ([`MapStep::odom`]) and never
//!   replaces the last good one, so it ages into stale odometry instead of moving the memories.

use mimnav_shared::hop::Hop;
use mimnav_shared::pose::{LidarMount, MountTransform, NonFiniteOdometry, check_odometry, pose2};
use mimnav_shared::topics::{MapHeader, Odometry, Point, PointsHeader, SliceHeader, map_status};

use crate::{Deskew, Mapper, MapperParams, Odom, OdomInput, UpdateStats};

/// One revolution mapped: the header to publish (its `processing_us` is the caller's to fill)
/// and what the mapper found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mapped {
    /// The header of `map/layers` and `map/plan`.
    pub header: MapHeader,
    /// What the update found.
    pub stats: UpdateStats,
}

impl Mapped {
    /// One line for a person (and systemd's `STATUS=`).
    pub fn describe(&self) -> &'static str {
        match self.header.status {
            map_status::ODOM_MISSING => "mapping; no odometry (the glass memory stays put)",
            map_status::ODOM_STALE => "mapping; stale odometry (the glass memory stays put)",
            _ => "mapping",
        }
    }
}

/// The mapper service's state between messages: the latest odometry, the map sequence and the
/// mapper.
#[derive(Debug)]
pub struct MapStep {
    mapper: Mapper,
    mount: Option<MountTransform>,
    mounted: Vec<Point>,
    odom_max_age_ns: u64,
    odom: Option<Odometry>,
    seq: u64,
    points_hop: Hop,
    /// The revolution being binned from `lidar/slices`.
    building: Option<Building>,
    /// How the next revolution binned from slices is de-skewed: with the (v, ω) the last map
    /// was made with, to the last map's last firing time.
    next_deskew: Deskew,
    /// The last revolution mapped from its slices: its `lidar/points` sample is not mapped again.
    sliced_seq: Option<u64>,
    /// The last revolution whose slices broke off (counted once each).
    broken_seq: Option<u64>,
    broken: u64,
    from_slices: u64,
}

/// A `lidar/points` revolution this few before the last one mapped from slices is that one or
/// an older one, mapped already or superseded; further back, the driver restarted its count.
const SLICED_BEHIND: u64 = 8;

/// A revolution being binned from its slices: what the next slice must be.
#[derive(Debug, Clone, Copy)]
struct Building {
    seq: u64,
    index: u32,
    points: u32,
    last_offset_ns: u32,
}

impl MapStep {
    /// A step mapping with `params`; odometry older than `odom_max_age_ns` is stale.
    pub fn new(params: MapperParams, odom_max_age_ns: u64) -> Self {
        MapStep {
            mapper: Mapper::new(params),
            mount: None,
            mounted: Vec::new(),
            odom_max_age_ns,
            odom: None,
            seq: 0,
            points_hop: Hop::new(),
            building: None,
            next_deskew: Deskew::default(),
            sliced_seq: None,
            broken_seq: None,
            broken: 0,
            from_slices: 0,
        }
    }

    /// The lidar sits at `mount` on the robot: every revolution is first brought into the frame
    /// of a sensor centred on the robot's axis ([`mount_points`]).
    pub fn with_mount(mut self, mount: &LidarMount) -> Self {
        self.mount = MountTransform::of(mount);
        self
    }

    /// The mapper: the last map's classes, cost and layers.
    pub fn mapper(&self) -> &Mapper {
        &self.mapper
    }

    /// Maps published so far.
    pub fn maps(&self) -> u64 {
        self.seq
    }

    /// The revolutions taken from `lidar/points` and those that never reached the mapper (gaps
    /// in their sequence: overwritten in the subscriber's buffer while it was busy).
    pub fn points_hop(&self) -> &Hop {
        &self.points_hop
    }

    /// Takes the latest odometry; refuses (and keeps the previous one) when a number is not
    /// finite.
    pub fn odom(&mut self, o: &Odometry) -> Result<(), NonFiniteOdometry> {
        check_odometry(o)?;
        self.odom = Some(*o);
        Ok(())
    }

    /// Revolutions whose slices broke off (a slice missing or out of order): each is mapped
    /// from `lidar/points` instead, once it is whole.
    pub fn broken_slices(&self) -> u64 {
        self.broken
    }

    /// One `lidar/slices` sample that arrived at `now`: bins its points at once (issue 27), and
    /// on the revolution's last slice maps it, bit for bit the map
    /// [`revolution`](Self::revolution) makes of the whole revolution. The de-skew cannot wait
    /// for the revolution's end, so both move every point to the last map's last firing time
    /// (a revolution's span after its first firing) with the last map's (v, ω): the robot's
    /// motion predicted one revolution on. A revolution whose slices break off (one missing,
    /// out of order, or fewer points than its header says) is counted in
    /// [`broken_slices`](Self::broken_slices) and left to [`revolution`](Self::revolution).
    pub fn slice(&mut self, h: &SliceHeader, points: &[Point], now: u64) -> Option<Mapped> {
        let seq = h.revolution.seq;
        if h.index == 0 {
            if let Some(b) = self.building.take() {
                self.break_off(b.seq);
            }
            self.mapper.begin(self.next_deskew);
            self.building = Some(Building {
                seq,
                index: 0,
                points: 0,
                last_offset_ns: 0,
            });
        }
        let expected = self
            .building
            .as_ref()
            .is_some_and(|b| b.seq == seq && b.index == h.index && b.points == h.first_point);
        if !expected {
            if let Some(b) = self.building.take() {
                self.break_off(b.seq);
            }
            self.break_off(seq);
            return None;
        }
        let last = self.bin(points);
        let b = self.building.as_mut()?;
        b.index += 1;
        b.points = b.points.saturating_add(points.len() as u32);
        if let Some(t) = last {
            b.last_offset_ns = t;
        }
        if h.last == 0 {
            return None;
        }
        let b = self.building.take()?;
        if b.points != h.revolution.point_count {
            self.break_off(seq);
            return None;
        }
        self.sliced_seq = Some(seq);
        self.from_slices += 1;
        Some(self.finish(&h.revolution, b.last_offset_ns, now))
    }

    /// Maps made from their slices (the rest came whole from `lidar/points`).
    pub fn maps_from_slices(&self) -> u64 {
        self.from_slices
    }

    fn break_off(&mut self, seq: u64) {
        if self.broken_seq != Some(seq) {
            self.broken_seq = Some(seq);
            self.broken += 1;
        }
    }

    /// Maps the revolution `points` (with its header) that arrived at `now`, de-skewed as
    /// [`slice`](Self::slice) says; `None` when its slices have mapped it already, or a later
    /// one's have.
    pub fn revolution(&mut self, h: &PointsHeader, points: &[Point], now: u64) -> Option<Mapped> {
        if self
            .sliced_seq
            .is_some_and(|s| h.seq <= s && s - h.seq < SLICED_BEHIND)
        {
            return None;
        }
        // de-skewed as its slices would have been: the same map whichever way it came
        self.building = None;
        self.mapper.begin(self.next_deskew);
        let t_end = self.bin(points).unwrap_or(0);
        Some(self.finish(h, t_end, now))
    }

    /// Bins `points` (moved by the mount first); returns the last one's firing time.
    fn bin(&mut self, points: &[Point]) -> Option<u32> {
        let points = match &self.mount {
            Some(t) => {
                mount_points(t, points, &mut self.mounted);
                &self.mounted[..]
            }
            None => points,
        };
        self.mapper.bin_slice(points);
        points.last().map(|p| p.time_offset_ns)
    }

    /// The odometry a revolution ending at `now` is mapped with, and the map's status.
    fn input(&self, now: u64) -> (OdomInput, u8) {
        match self.odom {
            None => (OdomInput::Missing, map_status::ODOM_MISSING),
            Some(o) if now.saturating_sub(o.rx_mono_ns) > self.odom_max_age_ns => {
                (OdomInput::Stale, map_status::ODOM_STALE)
            }
            Some(o) => (
                OdomInput::Fresh(Odom {
                    pose: pose2(o.x, o.y, o.yaw),
                    v: f64::from(o.v),
                    omega: f64::from(o.omega),
                }),
                0,
            ),
        }
    }

    /// Ends the revolution binned into the mapper (its last firing at `t_end_ns`): its map and
    /// header; the next revolution's slices are de-skewed with this one's odometry.
    fn finish(&mut self, h: &PointsHeader, t_end_ns: u32, now: u64) -> Mapped {
        self.points_hop.see(h.seq);
        let (input, status) = self.input(now);
        self.next_deskew = Deskew::of(input, t_end_ns);
        let stats = self.mapper.finish(input, h.stamp_ns);
        let o = self.odom.unwrap_or_default();
        let grid = self.mapper.params().grid;
        let header = MapHeader {
            seq: self.seq,
            source_seq: h.seq,
            stamp_ns: h.stamp_ns,
            rx_mono_ns: h.rx_mono_ns,
            odom_seq: o.seq,
            odom_stamp_ns: o.stamp_ns,
            x: o.x,
            y: o.y,
            yaw: o.yaw,
            cells: grid.cells as u32,
            cell_m: grid.cell_m,
            layers: self.mapper.layer_count() as u32,
            processing_us: 0,
            status,
            reserved: [0; 7],
        };
        self.seq += 1;
        Mapped { header, stats }
    }
}

/// `points` of a sensor mounted by `t`, as a sensor centred on the robot's axis (at the same
/// height, level, facing forward) would give them: position, distance and azimuth move; the
/// firing (time, laser, ring), intensity and return type stay. The mapper's layers, rings and
/// reach then read as they do for a centred sensor.
pub fn mount_points(t: &MountTransform, points: &[Point], out: &mut Vec<Point>) {
    out.clear();
    out.extend(points.iter().map(|p| {
        let [x, y, z] = t.apply([p.x, p.y, p.z]);
        let d = (x * x + y * y + z * z).sqrt();
        // clockwise seen from above, as the sensor counts
        let az = (-y.atan2(x)).to_degrees() * 100.0;
        Point {
            x,
            y,
            z,
            // `as` saturates: beyond 131 m is beyond the sensor's range anyway
            distance_raw: ((d / 0.002).round() as u16).max(1),
            azimuth_cdeg: (az.round() as i32).rem_euclid(36000) as u16,
            ..*p
        }
    }));
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: u64 = 1_000_000_000;

    fn odom(at: u64) -> Odometry {
        Odometry {
            seq: 7,
            stamp_ns: 11,
            rx_mono_ns: at,
            x: 1.0,
            y: 2.0,
            yaw: 0.5,
            v: 0.2,
            omega: 0.1,
        }
    }

    fn points_header(seq: u64) -> PointsHeader {
        PointsHeader {
            seq,
            stamp_ns: 5 * S + seq,
            rx_mono_ns: 9 * S,
            ..PointsHeader::default()
        }
    }

    #[test]
    fn the_header_names_the_revolution_and_the_odometry_and_counts_maps() {
        let mut step = MapStep::new(MapperParams::default(), S / 2);
        step.odom(&odom(10 * S)).expect("good odometry");
        let m = step
            .revolution(&points_header(3), &[], 10 * S)
            .expect("mapped");
        let h = m.header;
        assert_eq!(
            (h.seq, h.source_seq, h.stamp_ns, h.rx_mono_ns),
            (0, 3, 5 * S + 3, 9 * S)
        );
        assert_eq!(
            (h.odom_seq, h.odom_stamp_ns, h.x, h.y, h.yaw),
            (7, 11, 1.0, 2.0, 0.5)
        );
        let grid = MapperParams::default().grid;
        assert_eq!(
            (h.cells as usize, h.cell_m, h.layers),
            (grid.cells, grid.cell_m, 4)
        );
        assert_eq!((h.status, m.describe()), (0, "mapping"));
        assert_eq!(
            step.revolution(&points_header(4), &[], 10 * S)
                .expect("mapped")
                .header
                .seq,
            1
        );
        assert_eq!(step.maps(), 2);
    }

    /// Issue 23, the soak: a revolution overwritten in the mapper's subscriber buffer is counted
    /// as dropped on the hop from the driver.
    #[test]
    fn revolutions_that_never_reached_the_mapper_are_counted_dropped() {
        let mut step = MapStep::new(MapperParams::default(), S / 2);
        for seq in [3, 4, 7, 8] {
            step.revolution(&points_header(seq), &[], 10 * S)
                .expect("mapped");
        }
        let hop = step.points_hop();
        assert_eq!((hop.received(), hop.dropped()), (4, 2));
        assert_eq!(step.maps(), 4);
    }

    #[test]
    fn missing_and_stale_odometry_are_named_in_the_header() {
        let mut step = MapStep::new(MapperParams::default(), S / 2);
        let m = step
            .revolution(&points_header(0), &[], 10 * S)
            .expect("mapped");
        assert_eq!(m.header.status, map_status::ODOM_MISSING);
        assert!(m.describe().contains("no odometry"));
        step.odom(&odom(10 * S)).expect("good odometry");
        assert_eq!(
            step.revolution(&points_header(1), &[], 10 * S + S / 2)
                .expect("mapped")
                .header
                .status,
            0
        );
        let m = step
            .revolution(&points_header(2), &[], 10 * S + S / 2 + 1)
            .expect("mapped");
        assert_eq!(m.header.status, map_status::ODOM_STALE);
        assert!(m.describe().contains("stale odometry"));
    }

    #[test]
    fn non_finite_odometry_is_refused_and_the_last_good_one_ages() {
        let mut step = MapStep::new(MapperParams::default(), S / 2);
        step.odom(&odom(10 * S)).expect("good odometry");
        for bad in [
            Odometry {
                x: f64::NAN,
                ..odom(11 * S)
            },
            Odometry {
                yaw: f64::INFINITY,
                ..odom(11 * S)
            },
            Odometry {
                v: f32::NAN,
                ..odom(11 * S)
            },
            Odometry {
                omega: f32::INFINITY,
                ..odom(11 * S)
            },
        ] {
            assert_eq!(step.odom(&bad), Err(NonFiniteOdometry(7)));
        }
        let m = step
            .revolution(&points_header(0), &[], 11 * S)
            .expect("mapped");
        assert_eq!(m.header.status, map_status::ODOM_STALE);
        assert_eq!((m.header.x, m.header.y), (1.0, 2.0), "the last good pose");
    }
}
