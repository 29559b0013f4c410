//! Gaps in the IMU data on simulated aided land-vehicle runs: the records of a span removed
//! (a logger's dropout, a bus lost for a while), the run replayed through the same sequencer,
//! and what the bridge of `nav_core::gap` leaves: the error against the filter's widened
//! covariance at the first sample after the gap, the largest horizontal error per reported
//! 1-sigma over the 30 s after it, and the fixes the filter refused then. A gap beyond the
//! bridge ([`nav_core::gap::MAX_BRIDGED_S`]) is lost: the sequencer re-aligns in motion on the
//! fixes after it ([`nav_core::ins_filter::sequencer`]), and the same figures are those of the
//! restarted filter, from its first sample, with the time it took to navigate again.

use crate::aided::{self, AidedSink};
use crate::aided_bench::{Case, navigation_covariance, nees, prepare, state_error};
use crate::gnss_bench::{OUTLIER_VELOCITY_SIGMA_M_S, outlier_case};
use crate::recording_io::ReplaySource;
use crate::report::interpolate;
use crate::sensor_model::Grade;
use crate::truth::Truth;
use anyhow::{Result, bail};
use nav_core::ins_filter::{AidResult, AidedIns, FilterStatus};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Uniform};

/// Span after a gap that is watched [s].
pub const WATCH_S: f64 = 30.0;

/// What one gap left.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GapOutcome {
    /// Start of the gap (the first record removed) [s].
    pub at_s: f64,
    /// Length of the records removed [s].
    pub lost_s: f64,
    /// NEES of position, velocity and attitude (9 degrees of freedom) at the first filter
    /// sample after the gap, against the widened covariance (after a lost gap, the restarted
    /// filter's first sample; NaN, as the figures below, when no filter navigated within
    /// [`WATCH_S`] after the gap).
    pub nees_after: f64,
    /// Horizontal position error there [m].
    pub error_after_m: f64,
    /// Largest ratio of the horizontal error to the reported horizontal 1-sigma over
    /// [`WATCH_S`] after the gap [-].
    pub max_error_per_sigma: f64,
    /// Largest horizontal error over the same span [m].
    pub max_error_m: f64,
    /// Position fixes refused over the same span.
    pub refused: usize,
    /// Position fixes over the same span.
    pub fixes: usize,
    /// The filter's status at the end of the run.
    pub status: FilterStatus,
    /// After a lost gap, the time from its end until the filter navigated again [s] (`None`:
    /// no re-alignment completed).
    pub realigned_after_s: Option<f64>,
    /// Largest ratio of the horizontal error to the reported horizontal 1-sigma over the lost
    /// filter's rows (DEGRADED) within [`WATCH_S`] after the gap [-] (NaN: none, the gap
    /// bridged).
    pub lost_max_error_per_sigma: f64,
}

/// The gap run: a land vehicle of `grade`, 300 s at 200 Hz, 1 Hz fixes of 0.5 m (1 m down)
/// through a 0.8 / -0.3 / -1.1 m lever arm, the filter's noise model the simulated sensor's.
pub fn gap_case(grade: Grade, seed: u64) -> Case {
    // The outlier run's vehicle and receiver, shorter, without outliers or outages.
    let mut case = outlier_case(grade, seed);
    case.seconds = 300.0;
    case.gnss.outages.clear();
    case.gnss.outliers.clear();
    case
}

/// [`gap_case`] with a velocity in every fix ([`OUTLIER_VELOCITY_SIGMA_M_S`]), as most
/// receivers give: the re-alignment after a lost gap finds the level over a quasi-static
/// interval between two fixes ([`nav_core::ins_filter::motion`]), which velocities
/// differenced from 0.5 m positions (an acceleration noise near 1 m/s^2 against the 0.3 m/s^2
/// bound) seldom show.
pub fn gap_case_with_velocity(grade: Grade, seed: u64) -> Case {
    let mut case = gap_case(grade, seed);
    case.gnss.sigma_v_ned_m_s = Some(OUTLIER_VELOCITY_SIGMA_M_S);
    case
}

/// The start of the gap of `case`'s seed: uniform over 60-240 s (moving, the filter settled).
pub fn gap_start_s(seed: u64) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6A95_0F1E_D47A);
    // The bounds are finite and ordered: `new` cannot fail.
    Uniform::new(60.0, 240.0).map_or(150.0, |u| u.sample(&mut rng))
}

struct AfterGap<'a> {
    truth: &'a [Truth],
    gap_end_s: f64,
    first: Option<(f64, f64)>,
    max_ratio: f64,
    max_error_m: f64,
    lost_max_ratio: f64,
    status: FilterStatus,
}

impl AidedSink<f64> for AfterGap<'_> {
    fn sample(&mut self, t_us: u64, ins: &AidedIns<f64>) -> Result<()> {
        let t_s = t_us as f64 * 1e-6;
        self.status = ins.status();
        if t_s < self.gap_end_s || t_s > self.gap_end_s + WATCH_S {
            return Ok(());
        }
        let lost = self.status == FilterStatus::ImuLost;
        let first = self.first.is_none() && !lost;
        // Every 0.1 s is enough for the maximum.
        if (first || (t_us / 1000).is_multiple_of(100))
            && let Some(truth) = interpolate(self.truth, t_s)
        {
            let e = state_error(ins.state(), &truth);
            let h = (e[0] * e[0] + e[1] * e[1]).sqrt();
            let p = ins.position_covariance();
            let sigma = (p[(0, 0)] + p[(1, 1)]).sqrt();
            // The lost filter's rows (DEGRADED, until a re-alignment restarts the filter)
            // are watched apart: their 1-sigma must still tell their error.
            if lost {
                self.lost_max_ratio = self.lost_max_ratio.max(h / sigma);
                return Ok(());
            }
            if first {
                self.first = Some((nees(&navigation_covariance(ins), &e), h));
            }
            self.max_ratio = self.max_ratio.max(h / sigma);
            self.max_error_m = self.max_error_m.max(h);
        }
        Ok(())
    }
}

/// Runs `case` with the IMU records of `[at_s, at_s + lost_s)` removed.
pub fn gap_run(case: &Case, at_s: f64, lost_s: f64) -> Result<GapOutcome> {
    let prepared = prepare(case)?;
    let mut rec = prepared.sim.recording.clone();
    let (a_ns, b_ns) = (
        rec.t0_ns + (at_s * 1e9) as u64,
        rec.t0_ns + ((at_s + lost_s) * 1e9) as u64,
    );
    let before = rec.records.len();
    rec.records.retain(|r| r.t_ns < a_ns || r.t_ns >= b_ns);
    if rec.records.len() == before {
        bail!("no IMU record within the gap at {at_s} s");
    }
    // The first sample after the gap ends at the first record kept.
    let gap_end_s = rec
        .records
        .iter()
        .find(|r| r.t_ns >= b_ns)
        .map(|r| (r.t_ns - rec.t0_ns) as f64 * 1e-9)
        .ok_or_else(|| anyhow::anyhow!("the gap at {at_s} s reaches the end of the data"))?;
    let mut sink = AfterGap {
        truth: &prepared.sim.truth,
        gap_end_s,
        first: None,
        max_ratio: 0.0,
        max_error_m: 0.0,
        lost_max_ratio: f64::NAN,
        status: FilterStatus::Nominal,
    };
    // Through the recording reader, as `nav replay` reads a file: its rules for gaps apply.
    let mut source = ReplaySource::from_recording(&rec)?;
    let report = aided::run_source(
        &mut source,
        &prepared.gnss.fixes,
        prepared.seq.clone(),
        &mut sink,
    )?;
    let watched: Vec<_> = report
        .updates
        .iter()
        .filter(|u| u.t_s >= gap_end_s && u.t_s <= gap_end_s + WATCH_S)
        .collect();
    let refused = watched
        .iter()
        .filter(|u| !matches!(u.position, AidResult::Accepted { .. }))
        .count();
    let (nees_after, error_after_m) = sink.first.unwrap_or((f64::NAN, f64::NAN));
    let navigated = sink.first.is_some();
    Ok(GapOutcome {
        at_s,
        lost_s,
        nees_after,
        error_after_m,
        max_error_per_sigma: if navigated { sink.max_ratio } else { f64::NAN },
        max_error_m: if navigated {
            sink.max_error_m
        } else {
            f64::NAN
        },
        refused,
        fixes: watched.len(),
        status: sink.status,
        realigned_after_s: (report.realignments.completed > 0).then_some({
            (report.realignments.navigating_us as f64 - report.realignments.gap_end_us as f64)
                * 1e-6
        }),
        lost_max_error_per_sigma: sink.lost_max_ratio,
    })
}

/// A table cell "median / max" with `decimals` decimals, or "-" when no run gave the figure
/// (`NaN`, as [`GapOutcome`]'s figures of a gap that lost nothing): "NaN / NaN" was printed.
pub fn median_max_cell((median, max): (f64, f64), decimals: usize) -> String {
    if median.is_nan() || max.is_nan() {
        "-".to_owned()
    } else {
        format!("{median:.decimals$} / {max:.decimals$}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_no_run_gave_is_a_dash() {
        assert_eq!(median_max_cell((f64::NAN, f64::NAN), 2), "-");
        assert_eq!(median_max_cell((0.071, 0.73), 2), "0.07 / 0.73");
        assert_eq!(median_max_cell((6.94, 6.94), 1), "6.9 / 6.9");
    }
}
