//! Glass: the intensity spike in one revolution, and the frame the memory moves with.
//!
//! Detection follows Algorithm 1 of `cartographer-glass.txt` along each near-horizontal laser's
//! ring of returns (whose text is damaged; restated in DESIGN §6): a run of returns whose
//! intensity reaches `threshold`, entered by a rise of at least `gradient` and left by a fall of
//! at least `gradient` within `width` of azimuth, its own returns on one surface (ranges within a
//! tolerance). Nothing is asked of the returns beside the spike: they come from whatever lies
//! behind the glass. *Interpretation:* the width is measured in degrees rather than beams because
//! the VLP-16's azimuth step changes with its rotation rate; a missing return counts as intensity
//! 0 and range 0.
//!
//! What the spikes become over time — panes fitted to every sighting, kept in the odometry frame
//! (equations 6 and 7 of `mim-lidar-intensity-navigation.txt`) — is [`crate::pane`].

use crate::config::MapperConfig;
pub use mimnav_shared::pose::Pose2;

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
/// the spike by at least `glass_gradient`, at most `glass_width_deg` wide, with the spike's own
/// ranges within `glass_range_tolerance_m` of each other (one surface). Pushes each spike's first
/// and last index to `runs`.
///
/// What lies at the spike's edges says nothing: away from normal incidence the beams pass the
/// glass and return from whatever is behind it, at any range (DESIGN §6: never require the
/// background to be parallel to the pane).
pub fn detect_spikes(
    ring: &[RingReturn],
    p: &MapperConfig,
    out: &mut Vec<bool>,
    runs: &mut Vec<(usize, usize)>,
) {
    let threshold = p.glass_intensity as f32;
    let gradient = p.glass_gradient as f32;
    let (width_deg, range_tolerance_m) =
        (p.glass_width_deg as f32, p.glass_range_tolerance_m as f32);
    out.clear();
    out.resize(ring.len(), false);
    runs.clear();
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
        let (mut near, mut far) = (ring[k].range_m, ring[k].range_m);
        while end + 1 < n && ring[end + 1].intensity >= threshold {
            end += 1;
            near = near.min(ring[end].range_m);
            far = far.max(ring[end].range_m);
        }
        if end + 1 >= n {
            break;
        }
        let fall = ring[end].intensity - ring[end + 1].intensity;
        let mut width = (ring[end].azimuth_deg - ring[k].azimuth_deg).abs();
        if width > 180.0 {
            width = 360.0 - width;
        }
        if fall >= gradient && width <= width_deg && far - near <= range_tolerance_m {
            for o in &mut out[k..=end] {
                *o = true;
            }
            runs.push((k, end));
        }
        k = end + 1;
    }
}

/// A [`Pose2`] ready to move many points between the robot and odometry frames: its sine and
/// cosine in plain numbers, for the inner loops (everything else uses
/// [`Pose2Ext`](mimnav_shared::pose::Pose2Ext)).
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

#[cfg(test)]
mod tests {
    use super::*;

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
    fn a_spike_on_one_surface_is_glass_whatever_lies_behind_it() {
        let mut out = Vec::new();
        let mut runs = Vec::new();
        // the background parallel to the pane
        let r = ring(
            &[20.0, 22.0, 180.0, 230.0, 170.0, 25.0, 21.0],
            &[8.0, 8.0, 4.0, 4.0, 4.0, 8.1, 8.0],
        );
        detect_spikes(&r, &p(), &mut out, &mut runs);
        assert_eq!(out, [false, false, true, true, true, false, false]);
        assert_eq!(runs, [(2, 4)]);
        // a pane at an angle to the room: the background behind it at different ranges on its
        // two sides, or nothing at all on one side
        for ranges in [
            [3.0, 3.0, 4.0, 4.0, 4.0, 9.0, 9.5],
            [20.0, 20.0, 4.0, 4.0, 4.0, 0.0, 0.0],
        ] {
            let mut intensities = [20.0, 22.0, 180.0, 230.0, 170.0, 25.0, 21.0];
            if ranges[6] == 0.0 {
                intensities[5] = 0.0;
                intensities[6] = 0.0;
            }
            detect_spikes(&ring(&intensities, &ranges), &p(), &mut out, &mut runs);
            assert_eq!(
                out,
                [false, false, true, true, true, false, false],
                "{ranges:?}"
            );
        }
    }

    #[test]
    fn a_wide_plateau_a_slow_rise_or_returns_on_two_surfaces_are_not() {
        let mut out = Vec::new();
        let mut runs = Vec::new();
        // wider than 2°: a retro-reflective sign, not a specular spike
        let wide: Vec<f32> = (0..20)
            .map(|i| if (2..18).contains(&i) { 200.0 } else { 20.0 })
            .collect();
        detect_spikes(&ring(&wide, &[5.0; 20]), &p(), &mut out, &mut runs);
        assert!(out.iter().all(|&g| !g));
        // no rise: below the gradient
        detect_spikes(
            &ring(&[90.0, 105.0, 110.0, 95.0], &[5.0; 4]),
            &p(),
            &mut out,
            &mut runs,
        );
        assert!(out.iter().all(|&g| !g));
        // the bright returns lie on two surfaces a metre apart: not one pane
        detect_spikes(
            &ring(&[20.0, 200.0, 210.0, 20.0], &[3.0, 4.0, 5.0, 9.0]),
            &p(),
            &mut out,
            &mut runs,
        );
        assert!(out.iter().all(|&g| !g));
        assert!(runs.is_empty());
    }
}
