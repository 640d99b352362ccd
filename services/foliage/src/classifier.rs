//! The [`Classifier`]: the paper's `CLASSIFY(A, R)`, the routines run in order on buffers it owns,
//! with the temporal state and the carried scans.

use mimnav_shared::config::Invalid;

use crate::FoliageParams;
use crate::archive::update_and_archive;
use crate::bins::{Scan, prepare_scan};
use crate::bits::keep_if;
use crate::candidates::{WindowWork, candidates_in};
use crate::carry::{Carry, Motion};
use crate::class;
use crate::history::History;
use crate::low_freq::{LowFreq, differences, fill_notches_in, max_filter};
use crate::prune::{seen_near_windows, thin_and_crop};
use crate::relax::{RelaxWork, relax_obst};

/// Result of one [`Classifier::classify`] call; borrows the classifier's buffers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Verdict<'a> {
    /// `alarm`: at least one confirmed obstacle return in `[d_min, d_max]`.
    pub alarm: bool,
    /// `R_s`: nearest confirmed obstacle range per sector (sector `s` covers angles
    /// `[-π + s·sector, -π + (s+1)·sector)`), `f32::INFINITY` where none.
    pub nearest_per_sector: &'a [f32],
    /// Class of every return ([`class`]), in input order; length `min(angles.len(), ranges.len())`.
    pub classes: &'a [u8],
    /// Returns classed [`class::OBSTACLE`].
    pub obstacle_count: usize,
    /// Returns that were candidates (`R_c`, after `RELAX-OBST`): `OBSTACLE` + `PRUNED`.
    pub candidate_count: usize,
}

/// The foliage classifier: parameters, temporal state and every working buffer.
#[derive(Debug, Clone)]
pub struct Classifier {
    // (the buffers the tests look into are visible in the crate)
    params: FoliageParams,
    n_windows: usize,
    pub(crate) history: History,
    low: LowFreq,
    t_k: Vec<f32>,
    c_k: Vec<f32>,
    pub(crate) work: WindowWork,
    pub(crate) ranges: Vec<f32>,
    pub(crate) windows: Vec<u32>,
    sectors: Vec<u32>,
    pub(crate) rc: Vec<f32>,
    pub(crate) rf: Vec<f32>,
    pub(crate) thin_copy: Vec<f32>,
    seen: Vec<bool>,
    pub(crate) relax_work: RelaxWork,
    pub(crate) classes: Vec<u8>,
    nearest: Vec<f32>,
    /// Interpretation 17: the earlier scans carried, this scan's own (filled) maxima, the raw
    /// ones, and the carried maxima per window.
    carry: Carry,
    v_own: Vec<f32>,
    v_raw: Vec<f32>,
    carry_max: Vec<f32>,
}

impl Classifier {
    /// A classifier with zeroed temporal state; fails if [`FoliageParams::validate`] does.
    pub fn new(params: FoliageParams) -> Result<Self, Invalid> {
        params.validate()?;
        let n_w = params.n_windows();
        let n_s = params.n_sectors();
        Ok(Self {
            params,
            n_windows: n_w,
            history: History::free_space(n_w, params.k1),
            low: LowFreq {
                v: Vec::with_capacity(n_w),
                dv: Vec::with_capacity(n_w),
                nad2v: Vec::with_capacity(n_w),
            },
            t_k: Vec::with_capacity(n_w),
            c_k: Vec::with_capacity(n_w),
            work: WindowWork::with_windows(n_w),
            ranges: Vec::new(),
            windows: Vec::new(),
            sectors: Vec::new(),
            rc: Vec::new(),
            rf: Vec::new(),
            thin_copy: Vec::new(),
            seen: Vec::with_capacity(n_w),
            relax_work: RelaxWork::default(),
            classes: Vec::new(),
            nearest: vec![f32::INFINITY; n_s],
            carry: Carry::with_windows(params.window_rad, n_w),
            v_own: Vec::with_capacity(n_w),
            v_raw: Vec::with_capacity(n_w),
            carry_max: Vec::with_capacity(n_w),
        })
    }

    /// Classifies one scan (`CLASSIFY(A, R)`) and advances the temporal state.
    ///
    /// `angles[r]` (radians) and `ranges[r]` (metres, 0 = no return) describe return `r` in firing
    /// order. If the slices differ in length only the first `min` returns are used. Never panics:
    /// non-finite, zero or negative ranges and non-finite angles are "no return"; an empty scan is a
    /// scan without returns (see interpretation 13).
    ///
    /// Without the sensor's motion no earlier scan is carried (interpretation 17): this is
    /// [`Classifier::classify_moved`] with `None`.
    pub fn classify(&mut self, angles: &[f32], ranges: &[f32]) -> Verdict<'_> {
        self.classify_moved(angles, ranges, None)
    }

    /// [`Classifier::classify`] knowing how the sensor moved since the previous scan
    /// (interpretation 17, [`FoliageParams::carry_scans`]): the window maxima of up to
    /// `carry_scans` earlier scans, moved into this scan's frame, join the max filter's
    /// smoothness test once the sensor has moved `carry_min_travel_m` from where they were taken.
    /// `None`, or an implausible motion ([`Motion::is_plausible`]: a jump or a non-finite value),
    /// drops every earlier scan; this scan is kept for the next.
    pub fn classify_moved(
        &mut self,
        angles: &[f32],
        ranges: &[f32],
        motion: Option<Motion>,
    ) -> Verdict<'_> {
        let p = self.params;
        prepare_scan(
            angles,
            ranges,
            &p,
            &mut self.ranges,
            &mut self.windows,
            &mut self.sectors,
        );
        let scan = Scan {
            ranges: &self.ranges,
            windows: &self.windows,
            sectors: &self.sectors,
        };
        let ne = scan.len();

        // FIND-LOW-FREQ, with the notches filled (interpretation 16) between its max filter and
        // its differences
        max_filter(scan, self.n_windows, &mut self.low);
        // Interpretation 17: the carried maxima join `v` for the differences; the candidates are
        // still this scan's own maxima (`v_own`), where they agree with the merged one.
        let carried = match motion.filter(|m| p.carry_scans > 0 && m.is_plausible()) {
            Some(m) => self.carry.advance(
                m,
                p.carry_min_travel_m,
                1.0 / p.window_rad,
                &mut self.carry_max,
            ),
            None => {
                self.carry.clear();
                false
            }
        };
        if p.carry_scans > 0 {
            self.v_raw.clone_from(&self.low.v);
        }
        if carried {
            self.v_own.clone_from(&self.low.v);
            for (v, &c) in self.low.v.iter_mut().zip(&self.carry_max) {
                *v = v.max(c);
            }
            if p.fill_notches {
                fill_notches_in(&p, &mut self.v_own);
            }
        }
        if p.fill_notches {
            fill_notches_in(&p, &mut self.low.v);
        }
        if !carried {
            self.v_own.clone_from(&self.low.v);
        }
        differences(&mut self.low);
        candidates_in(
            &p,
            scan,
            &self.v_own,
            &self.low,
            &self.history,
            &mut self.t_k,
            &mut self.rc,
            &mut self.work,
        );
        self.history.archive_thresholds(&mut self.t_k);
        relax_obst(&p, scan, &self.history, &mut self.rc, &mut self.relax_work);
        // Interpretation (12): the paper's pruning order, REMOVE-NEW → REMOVE-THIN → CROP-RANGE;
        // REMOVE-NEW-OBST writes the copy that REMOVE-THIN-OBST reads.
        seen_near_windows(&self.history, &mut self.seen);
        let new = &mut self.thin_copy;
        new.clear();
        new.extend(
            self.rc[..ne]
                .iter()
                .zip(&self.windows[..ne])
                .map(|(&c, &w)| {
                    // Interpretation (6), with the windows' answers made beforehand (branch-free).
                    let seen = self.seen.get(w as usize).copied().unwrap_or(false);
                    keep_if(c, (c > 0.0) & seen)
                }),
        );
        thin_and_crop(&p, new, &mut self.rf);
        let alarm = update_and_archive(
            &p,
            scan,
            &self.rc,
            &self.rf,
            &mut self.history,
            &mut self.c_k,
            &mut self.nearest,
        );
        if p.carry_scans > 0 {
            self.carry.record(&self.v_raw, p.carry_scans);
        }

        self.classes.clear();
        let (mut obstacles, mut candidates) = (0, 0);
        let per_return = self.rf[..ne]
            .iter()
            .zip(&self.rc[..ne])
            .zip(&self.ranges[..ne]);
        self.classes.extend(per_return.map(|((&f, &cand), &range)| {
            // (Branch-free: the classes interleave at random.) R_f ⊆ R_c ⊆ {R > 0}.
            let (is_obstacle, is_candidate) = (f > 0.0, cand > 0.0);
            obstacles += usize::from(is_obstacle);
            candidates += usize::from(is_candidate);
            let mut c = if range > 0.0 {
                class::FOLIAGE
            } else {
                class::NO_RETURN
            };
            c = if is_candidate { class::PRUNED } else { c };
            if is_obstacle { class::OBSTACLE } else { c }
        }));
        Verdict {
            alarm,
            nearest_per_sector: &self.nearest,
            classes: &self.classes,
            obstacle_count: obstacles,
            candidate_count: candidates,
        }
    }

    /// Forgets the temporal state, as after [`Classifier::new`]: evidence 0, thresholds at the
    /// free-space value `2·K1` ([`History::free_space`]).
    pub fn reset(&mut self) {
        self.history.reset_free_space(self.params.k1);
        self.carry.clear();
        self.nearest.fill(f32::INFINITY);
    }

    /// The parameters in use.
    pub fn params(&self) -> &FoliageParams {
        &self.params
    }

    /// The temporal state (`T_{k-1}`, `T_{k-2}`, `C_{k-1}`, `C_{k-2}` per window) after the last scan.
    pub fn history(&self) -> &History {
        &self.history
    }

    /// `v`, `dv`, `nad2v` of the last scan.
    pub fn low_freq(&self) -> &LowFreq {
        &self.low
    }

    /// `R_c` of the last scan (candidate range per return, 0 = not a candidate).
    pub fn candidates(&self) -> &[f32] {
        &self.rc
    }

    /// `R_f` of the last scan (obstacle range per return after pruning, 0 = not an obstacle).
    pub fn obstacles(&self) -> &[f32] {
        &self.rf
    }

    /// Number of angular windows `N_w`.
    pub fn n_windows(&self) -> usize {
        self.n_windows
    }
}
