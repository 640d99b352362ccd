//! Unit and integration tests, one module per routine of the paper (as the library is cut) and
//! for the classifier as a whole. No dev-dependencies: a tiny deterministic PRNG and a planar scene
//! simulator (trunks, walls, a grass field) live in the crate's hidden `scene` module, shared with
//! the `scan` bench; the helpers shared by the test modules are here.

use std::f32::consts::{PI, TAU};

use super::*;
use crate::low_freq::differences;
use mimnav_shared::pose::pose2;

mod archive;
mod bins;
mod candidates;
mod carry;
mod classifier;
mod held_and_filled;
mod low_freq;
mod paper_loops;
mod prune;
mod relax;
mod scenes;

use crate::scene::*;

fn classifier() -> Classifier {
    match Classifier::new(FoliageParams::default()) {
        Ok(c) => c,
        Err(e) => panic!("default params rejected: {e}"),
    }
}

/// A classifier with the given parameters.
fn classifier_with(params: FoliageParams) -> Classifier {
    Classifier::new(params).unwrap_or_else(|e| panic!("params rejected: {e}"))
}

/// A classifier with 4-beam windows (α = 0.8°, the default before the simulated evaluation): the
/// setting for a scan whose obstacle returns are the farthest ones of a partly hidden obstacle (a
/// last-return scan in grass), where more beams per window make it likelier that one reaches.
fn classifier_wide_windows() -> Classifier {
    match Classifier::new(FoliageParams {
        window_rad: 0.8f32.to_radians(),
        ..Default::default()
    }) {
        Ok(c) => c,
        Err(e) => panic!("params rejected: {e}"),
    }
}

/// Window of an angle under the default parameters.
fn window_of(angle: f32) -> usize {
    let p = FoliageParams::default();
    angle_bin(angle, p.window_rad, p.n_windows()).map_or(usize::MAX, |w| w as usize)
}

fn prepared(angles: &[f32], ranges: &[f32], p: &FoliageParams) -> (Vec<f32>, Vec<u32>, Vec<u32>) {
    let (mut r, mut w, mut s) = (vec![], vec![], vec![]);
    prepare_scan(angles, ranges, p, &mut r, &mut w, &mut s);
    (r, w, s)
}

/// Runs FIND-LOW-FREQ and GET-OBST-CANDIDATES on one scan with a fresh history.
fn candidates_of(angles: &[f32], ranges: &[f32]) -> Vec<f32> {
    let p = FoliageParams::default();
    let (r, w, s) = prepared(angles, ranges, &p);
    let scan = Scan {
        ranges: &r,
        windows: &w,
        sectors: &s,
    };
    let mut low = LowFreq::default();
    find_low_freq(scan, p.n_windows(), &mut low);
    let hist = History::free_space(p.n_windows(), p.k1);
    let (mut tk, mut rc, mut work) = (vec![], vec![], WindowWork::default());
    get_obst_candidates(&p, scan, &low, &hist, &mut tk, &mut rc, &mut work);
    rc
}

/// Number of distinct windows holding a candidate.
fn candidate_windows(angles: &[f32], rc: &[f32]) -> usize {
    let mut w: Vec<usize> = (0..rc.len())
        .filter(|&i| rc[i] > 0.0)
        .map(|i| window_of(angles[i]))
        .collect();
    w.sort_unstable();
    w.dedup();
    w.len()
}

/// A flat wall 2 m in front (x = 2, y in [-1, 1]), nothing elsewhere, VLP-16 noise.
fn wall_scan(rng: &mut Rng) -> (Vec<f32>, Vec<f32>) {
    Scene {
        segments: vec![((2.0, -1.0), (2.0, 1.0))],
        ..Scene::open()
    }
    .scan(rng)
}
