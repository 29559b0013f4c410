//! GNSS outages and outliers on simulated land-vehicle runs: the position drift at the end of
//! each outage beside the filter's own predicted 1-sigma, and what the gate does with jumps,
//! spikes, multipath ramps and NaN fixes.

use crate::aided::{self, AidedSink};
use crate::aided_bench::{Case, Prepared, prepare, state_error};
use crate::gnss_sim::{CorrelatedError, GnssSimOptions, Outage, Outlier};
use crate::report::interpolate;
use crate::sensor_model::Grade;
use crate::truth::Truth;
use anyhow::Result;
use nav_core::ins_filter::{AidResult, AidedIns, FilterStatus};

/// The drift at the end of one outage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutageDrift {
    /// End of the outage [s].
    pub t_s: f64,
    /// Horizontal position error [m].
    pub drift_m: f64,
    /// The filter's horizontal 1-sigma (RSS of north and east) [m].
    pub sigma_m: f64,
}

struct EndOfOutage<'a> {
    truth: &'a [Truth],
    outages: &'a [Outage],
    next: usize,
    last_t_s: f64,
    drifts: Vec<OutageDrift>,
}

impl AidedSink<f64> for EndOfOutage<'_> {
    fn sample(&mut self, t_us: u64, ins: &AidedIns<f64>) -> Result<()> {
        let t_s = t_us as f64 * 1e-6;
        while self
            .outages
            .get(self.next)
            .is_some_and(|o| t_s >= o.start_s + o.length_s)
        {
            self.next += 1;
        }
        if let Some(o) = self.outages.get(self.next) {
            let dt = t_s - self.last_t_s;
            // The last sample before the outage ends (the next one is at or after its end).
            if t_s > o.start_s
                && t_s + dt >= o.start_s + o.length_s
                && let Some(truth) = interpolate(self.truth, t_s)
            {
                let e = state_error(ins.state(), &truth);
                let p = ins.position_covariance();
                self.drifts.push(OutageDrift {
                    t_s,
                    drift_m: (e[0] * e[0] + e[1] * e[1]).sqrt(),
                    sigma_m: (p[(0, 0)] + p[(1, 1)]).sqrt(),
                });
                self.next += 1;
            }
        }
        self.last_t_s = t_s;
        Ok(())
    }
}

/// Length of the outages of the KF-GINS / OB_GINS outage test [s] (every
/// [`OUTAGE_PERIOD_S`]).
pub const OUTAGE_S: f64 = 60.0;

/// Period of the outages of [`outage_case`] [s].
pub const OUTAGE_PERIOD_S: f64 = 180.0;

/// Outages of `outage_s` (e.g. [`OUTAGE_S`]) every [`OUTAGE_PERIOD_S`] over `seconds` of a
/// land-vehicle run of `grade` (1 Hz fixes of 0.5 m / 0.5 m / 1 m, starting after 300 s of
/// aiding).
pub fn outage_case(grade: Grade, seconds: f64, outage_s: f64, seed: u64) -> Case {
    Case {
        scenario: "land-vehicle".into(),
        grade,
        seconds,
        imu_rate_hz: 200.0,
        zero_motion: true,
        without: Vec::new(),
        gnss: GnssSimOptions {
            rate_hz: 1.0,
            sigma_ned_m: [0.5, 0.5, 1.0],
            sigma_v_ned_m_s: None,
            lever_arm_b_m: [0.8, -0.3, -1.1],
            outages: Outage::every(OUTAGE_PERIOD_S, outage_s, 300.0, seconds),
            seed,
            ..GnssSimOptions::default()
        },
        seed,
    }
}

/// The drift at the end of every outage of `case`.
pub fn outage_drifts(case: &Case) -> Result<Vec<OutageDrift>> {
    let prepared = prepare(case)?;
    let mut sink = EndOfOutage {
        truth: &prepared.sim.truth,
        outages: &case.gnss.outages,
        next: 0,
        last_t_s: 0.0,
        drifts: Vec::new(),
    };
    let Prepared { gnss, seq, .. } = &prepared;
    aided::run(prepared.samples(), &gnss.fixes, seq.clone(), &mut sink)?;
    Ok(sink.drifts)
}

/// What happened around one injected outlier.
#[derive(Clone, Debug, PartialEq)]
pub struct OutlierOutcome {
    /// The outlier's name.
    pub name: &'static str,
    /// Its start [s].
    pub t_s: f64,
    /// Fixes it touched.
    pub fixes: usize,
    /// Of those, refused by the gate (or as invalid).
    pub refused: usize,
    /// Largest horizontal position error from its start to 30 s after its end [m].
    pub max_error_m: f64,
    /// The filter's horizontal 1-sigma at that moment [m].
    pub sigma_at_max_m: f64,
    /// Largest ratio of the horizontal error to the horizontal 1-sigma over the same span [-]
    /// (where the filter was most overconfident; below 3 for an honest sigma).
    pub max_error_per_sigma: f64,
    /// The same from its end to 30 s after it [-]: the filter that followed a fault it could
    /// not see refuses the true fixes when they come back, and its reported sigma must then
    /// cover what it cannot tell (the doubt of `nav_core::ins_filter::integrity`).
    pub max_error_per_sigma_after: f64,
    /// The filter reported DEGRADED during it.
    pub degraded: bool,
    /// A fix was accepted again after it ended (within 60 s).
    pub reacquired: bool,
}

struct Watch<'a> {
    truth: &'a [Truth],
    windows: Vec<(f64, f64)>,
    max: Vec<(f64, f64)>,
    max_ratio: Vec<f64>,
    max_ratio_after: Vec<f64>,
    degraded: Vec<bool>,
}

impl AidedSink<f64> for Watch<'_> {
    fn sample(&mut self, t_us: u64, ins: &AidedIns<f64>) -> Result<()> {
        let t_s = t_us as f64 * 1e-6;
        for (k, (a, b)) in self.windows.iter().enumerate() {
            if t_s >= *a && t_s <= b + 30.0 {
                if ins.status() == FilterStatus::AidingRejected {
                    self.degraded[k] = true;
                }
                // Every 0.1 s is enough for the maximum.
                if (t_us / 1000).is_multiple_of(100)
                    && let Some(truth) = interpolate(self.truth, t_s)
                {
                    let e = state_error(ins.state(), &truth);
                    let h = (e[0] * e[0] + e[1] * e[1]).sqrt();
                    let p = ins.position_covariance();
                    let sigma = (p[(0, 0)] + p[(1, 1)]).sqrt();
                    if h > self.max[k].0 {
                        self.max[k] = (h, sigma);
                    }
                    self.max_ratio[k] = self.max_ratio[k].max(h / sigma);
                    if t_s > *b {
                        self.max_ratio_after[k] = self.max_ratio_after[k].max(h / sigma);
                    }
                }
            }
        }
        Ok(())
    }
}

/// The outlier run: a land vehicle of `grade` with 1 Hz fixes of 0.5 m; a 50 m jump for 20 s
/// at 200 s, a 120 s outage from 300 s ended by a 20 m spike, a multipath bias growing to 5 m
/// over 30 s from 500 s, a NaN fix at 600 s, and a consistent 30 m offset for 150 s from 700 s
/// (beyond the 100 rejections that make the filter DEGRADED).
pub fn outlier_case(grade: Grade, seed: u64) -> Case {
    Case {
        scenario: "land-vehicle".into(),
        grade,
        seconds: 1000.0,
        imu_rate_hz: 200.0,
        zero_motion: true,
        without: Vec::new(),
        gnss: GnssSimOptions {
            rate_hz: 1.0,
            sigma_ned_m: [0.5, 0.5, 1.0],
            sigma_v_ned_m_s: None,
            lever_arm_b_m: [0.8, -0.3, -1.1],
            outages: vec![Outage {
                start_s: 300.0,
                length_s: 120.0,
            }],
            outliers: vec![
                Outlier::Jump {
                    t_s: 200.0,
                    length_s: 20.0,
                    offset_ned_m: [50.0, 0.0, 0.0],
                },
                Outlier::Spike {
                    t_s: 420.0,
                    offset_ned_m: [0.0, 20.0, 0.0],
                },
                Outlier::Ramp {
                    start_s: 500.0,
                    length_s: 30.0,
                    final_offset_ned_m: [0.0, 5.0, 0.0],
                },
                Outlier::NaN { t_s: 600.0 },
                Outlier::Jump {
                    t_s: 700.0,
                    length_s: 150.0,
                    offset_ned_m: [0.0, 30.0, 0.0],
                },
            ],
            correlated: None,
            seed,
        },
        seed,
    }
}

/// 1-sigma of the velocity fixes of [`outlier_case_with_velocity`], north, east, down
/// [m/s] (a receiver's Doppler velocity).
pub const OUTLIER_VELOCITY_SIGMA_M_S: [f64; 3] = [0.05, 0.05, 0.1];

/// [`outlier_case`] with velocity in every fix ([`OUTLIER_VELOCITY_SIGMA_M_S`]); the
/// outliers move the positions alone, as multipath moves a code position but not the
/// Doppler velocity. A slow position ramp that a MEMS filter cannot tell from its own drift
/// on positions alone disagrees with the velocity fixes.
pub fn outlier_case_with_velocity(grade: Grade, seed: u64) -> Case {
    let mut case = outlier_case(grade, seed);
    case.gnss.sigma_v_ned_m_s = Some(OUTLIER_VELOCITY_SIGMA_M_S);
    case
}

/// The time-correlated error of [`outlier_case_code_receiver`]'s receiver: 1-sigma north,
/// east, down [m] and correlation time [s] (a code receiver's multipath and atmosphere).
pub const CODE_RECEIVER_CORRELATED: ([f64; 3], f64) = ([2.0, 2.0, 4.0], 60.0);

/// [`outlier_case`] with a code receiver's positions: besides the white 0.5 m, a
/// Gauss–Markov error of [`CODE_RECEIVER_CORRELATED`], simulated and declared to the filter
/// (a consider state of the fixes, [`nav_core::ins_filter::consider`]). Declared white, the
/// multipath ramp is a fault the tactical MEMS filter cannot tell from its own drift; declared,
/// the filter's sigma holds what it cannot tell.
pub fn outlier_case_code_receiver(grade: Grade, seed: u64) -> Case {
    let mut case = outlier_case(grade, seed);
    let (sigma_ned_m, time_s) = CODE_RECEIVER_CORRELATED;
    case.gnss.correlated = Some(CorrelatedError {
        sigma_ned_m,
        time_s,
    });
    case
}

/// Runs the outlier case and reports each outlier.
pub fn outliers(case: &Case) -> Result<Vec<OutlierOutcome>> {
    let prepared = prepare(case)?;
    let windows: Vec<(f64, f64)> = case
        .gnss
        .outliers
        .iter()
        .map(|o| match *o {
            Outlier::Jump { t_s, length_s, .. } => (t_s, t_s + length_s),
            Outlier::Spike { t_s, .. } | Outlier::NaN { t_s } => (t_s, t_s),
            Outlier::Ramp {
                start_s, length_s, ..
            } => (start_s, start_s + length_s),
        })
        .collect();
    let n = windows.len();
    let mut sink = Watch {
        truth: &prepared.sim.truth,
        windows: windows.clone(),
        max: vec![(0.0, 0.0); n],
        max_ratio: vec![0.0; n],
        max_ratio_after: vec![0.0; n],
        degraded: vec![false; n],
    };
    let report = aided::run(
        prepared.samples(),
        &prepared.gnss.fixes,
        prepared.seq.clone(),
        &mut sink,
    )?;
    let mut out = Vec::new();
    for (k, o) in case.gnss.outliers.iter().enumerate() {
        let (a, b) = windows[k];
        let touched: Vec<f64> = prepared
            .gnss
            .injections
            .iter()
            .filter(|i| i.outlier == k)
            .map(|i| i.t_s)
            .collect();
        let refused = report
            .updates
            .iter()
            .filter(|u| touched.iter().any(|t| (t - u.t_s).abs() < 1e-3))
            .filter(|u| !matches!(u.position, AidResult::Accepted { .. }))
            .count();
        let reacquired = report.updates.iter().any(|u| {
            u.t_s > b && u.t_s <= b + 60.0 && matches!(u.position, AidResult::Accepted { .. })
        });
        out.push(OutlierOutcome {
            name: o.name(),
            t_s: a,
            fixes: touched.len(),
            refused,
            max_error_m: sink.max[k].0,
            sigma_at_max_m: sink.max[k].1,
            max_error_per_sigma: sink.max_ratio[k],
            max_error_per_sigma_after: sink.max_ratio_after[k],
            degraded: sink.degraded[k],
            reacquired,
        });
    }
    Ok(out)
}
