//! Consistency of the GNSS-aided filter on simulated runs: the normalised estimation error
//! squared (NEES) of position, velocity and attitude after each update, the normalised
//! innovation squared (NIS) of the position fixes, and the sensor errors' final normalised
//! errors [Bar-Shalom et al., §5.4].
//!
//! The sensor-error blocks (biases, scale factors) are compared with what the filter's bias
//! states hold of the simulated errors ([`effective_sensor_errors`]): the misalignment and
//! g-sensitivity at rest are, to the filter, part of the bias. Diagnostics: each block's NEES over time
//! ([`ConsistencyRow::blocks_over_time`]) and the simulator's error sources switched off one
//! at a time ([`Case::without`]).

use crate::aided::{self, AidedSample, AidedSink};
use crate::aided_cmd::{bias_state_part, filter_model_of, model_config, off_diagonal_rms};
use crate::gnss_sim::{self, GnssSimOptions};
use crate::recording_io::Recording;
use crate::report::interpolate;
use crate::sensor_model::{ErrorInjector, ErrorSource, Grade, ImuErrorModel};
use crate::simulate::{InRunBiases, SimOptions, plan, sense};
use crate::trajectory::scenarios::Scenario;
use crate::truth::Truth;
use anyhow::{Result, anyhow};
use nav_core::attitude::rotation_vector_of;
use nav_core::ins_filter::sequencer::{Realignments, Sequencer, Start};
use nav_core::ins_filter::{
    ATT, AidResult, AidedIns, BA, BG, GnssCorrelatedError, InitialSigma, POS, SA, SG, SensorErrors,
    VEL,
};
use nav_core::nalgebra::{SMatrix, SVector};
use nav_core::{NavState, Position, Scalar, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// One simulated aided run.
#[derive(Clone, Debug, PartialEq)]
pub struct Case {
    /// Scenario name (`land-vehicle`, `flight`, ...).
    pub scenario: String,
    /// Sensor grade.
    pub grade: Grade,
    /// Length [s].
    pub seconds: f64,
    /// IMU rate [Hz].
    pub imu_rate_hz: f64,
    /// The GNSS receiver.
    pub gnss: GnssSimOptions,
    /// Seed of the sensor errors, the GNSS noise and the start's errors.
    pub seed: u64,
    /// Zero-velocity and zero-rate updates at stops. Their 1-sigma (0.02 m/s, 0.01 deg/s)
    /// stands for a stopped vehicle's residual motion, which the simulated stops lack (they
    /// are exactly still): with them the filter is conservative at every stop by design.
    pub zero_motion: bool,
    /// Sensor errors the simulator leaves out (diagnostics; empty: the grade as it is); the
    /// filter's model ([`filter_model_of`] the simulated errors: the grade's turn-on spread as
    /// the start's sensor 1-sigma, its in-run processes alone as process noise) leaves them
    /// out as well, so that a diagnosis compares a filter with the sensor it models.
    pub without: Vec<ErrorSource>,
}

impl Case {
    /// The error model the filter is told of: the grade's, less [`Case::without`].
    pub fn error_model(&self) -> ImuErrorModel {
        self.without
            .iter()
            .fold(self.grade.model(), |m, s| m.without(*s))
    }

    /// The simulated sensor: [`Self::error_model`] with its triads' misalignments drawn from
    /// the seed, each off-diagonal element normal with the 1-sigma the filter's consider
    /// states assume (the RMS of the grade's, [`off_diagonal_rms`]). The grade's own matrix
    /// is one draw: with it every run shared the same larger elements, and the Monte Carlo
    /// tested that one sensor's misalignment, not the filter's model of a grade's.
    pub fn sensor_model(&self) -> ImuErrorModel {
        let mut m = self.error_model();
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed ^ 0x3A15_A11C_0FF5);
        for t in [&mut m.gyro, &mut m.accel] {
            let sigma = off_diagonal_rms(&t.misalignment);
            for (i, j) in [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)] {
                let n: f64 = StandardNormal.sample(&mut rng);
                t.misalignment[(i, j)] = sigma * n;
            }
        }
        m
    }
}

/// The sensor-error blocks of the NEES: gyro bias, accelerometer bias, gyro scale factor,
/// accelerometer scale factor (3 degrees of freedom each), after position, velocity, attitude.
pub const NEES_BLOCKS: [&str; 7] = ["pos", "vel", "att", "b_g", "b_a", "s_g", "s_a"];

/// Per-epoch statistics of one run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Epoch {
    /// Time of the update [s].
    pub t_s: f64,
    /// NEES of position, velocity and attitude (9 degrees of freedom).
    pub nees: f64,
    /// NEES of each block alone: position, velocity, attitude (3 degrees of freedom each).
    pub nees_blocks: [f64; 3],
    /// NEES of the sensor-error blocks ([`NEES_BLOCKS`] 3 to 6) against the simulator's
    /// constant errors (fixed and turn-on bias, scale factors).
    pub nees_sensor: [f64; 4],
    /// The position fix's NIS (3 degrees of freedom), when it was not invalid.
    pub nis: Option<f64>,
    /// Horizontal position error [m] and its 1-sigma (RSS of north and east) [m].
    pub horizontal_m: (f64, f64),
}

/// One run's result.
#[derive(Clone, Debug, PartialEq)]
pub struct CaseResult {
    /// After each GNSS update.
    pub epochs: Vec<Epoch>,
    /// Final gyro and accelerometer bias errors over their 1-sigma, per axis.
    pub bias_z: [f64; 6],
    /// Final errors over their 1-sigma of gyro bias, accelerometer bias, gyro and
    /// accelerometer scale factors, per axis, against [`effective_sensor_errors`].
    pub sensor_z: [f64; 12],
    /// Position fixes accepted and rejected.
    pub accepted: u32,
    /// Position fixes rejected.
    pub rejected: u32,
    /// The run's re-alignments in motion (`nav_core::ins_filter::sequencer`).
    pub realignments: Realignments,
}

/// The filter's reported covariance of position, velocity and attitude, in [`state_error`]'s
/// order: its own, with the reported position block and the velocity doubt (a refused
/// cluster's doubt included).
pub fn navigation_covariance(ins: &AidedIns<f64>) -> SMatrix<f64, 9, 9> {
    let p = ins.covariance();
    let blocks = [POS, VEL, ATT];
    let mut p9 = SMatrix::<f64, 9, 9>::zeros();
    for (a, ia) in blocks.iter().enumerate() {
        for (b, ib) in blocks.iter().enumerate() {
            p9.fixed_view_mut::<3, 3>(3 * a, 3 * b)
                .copy_from(&p.fixed_view::<3, 3>(*ia, *ib));
        }
    }
    p9.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&ins.position_covariance());
    let mut vel = p9.fixed_view_mut::<3, 3>(3, 3);
    vel += ins.filter().velocity_doubt();
    p9
}

/// The normalised estimation error squared `e^T P^-1 e` (infinite when `P` is not positive
/// definite).
pub fn nees(p9: &SMatrix<f64, 9, 9>, e: &SVector<f64, 9>) -> f64 {
    p9.cholesky()
        .map(|c| e.dot(&c.solve(e)))
        .unwrap_or(f64::INFINITY)
}

/// Error of the filter's state against the truth: position NED [m], velocity [m/s], attitude
/// `phi` [rad] (computed minus true, the filter's convention).
pub fn state_error(ins_state: &NavState<f64>, truth: &Truth) -> SVector<f64, 9> {
    let tp = Position::from_radians(truth.lat, truth.lon, truth.h);
    let dr = tp.ned_to(&ins_state.position);
    let dv = ins_state.v_eb_n - truth.v_eb_ned;
    // C~ = (I - [phi x]) C: q~ q^-1 is the rotation by -phi.
    let q_err = ins_state.q_b_n * truth.q_b_ned.inverse();
    let phi = -rotation_vector_of(&q_err);
    SVector::<f64, 9>::from_iterator(
        dr.into_iter()
            .chain(dv.iter().copied())
            .chain(phi.iter().copied()),
    )
}

/// The sensor errors the filter's bias and scale-factor states estimate, in its order (gyro
/// bias [rad/s], accelerometer bias [m/s^2], gyro and accelerometer scale factors [-]).
///
/// The simulator's sensors read `(I + S + M) x + b (+ G f, gyros)` ([Groves, §4.4.6]). The
/// filter carries `M` and `G` as consider states of the specific force's departure from rest
/// ([`nav_core::ins_filter::consider`]): its bias states hold `b` plus `G f_rest` and
/// `M_a f_rest` at rest in the nominal attitude, `f_rest = (0, 0, -g)` (the gyro misalignment
/// times Earth rate, below 1e-7 rad/s, is left out there as here). `biases`: the simulator's
/// biases of the gyros and the accelerometers as the bias states hold them
/// (`Consistency::biases_at`).
pub fn effective_sensor_errors(
    model: &ImuErrorModel,
    biases: [Vector3<f64>; 2],
) -> [Vector3<f64>; 4] {
    let f_rest = Vector3::new(0.0, 0.0, -9.806_65);
    [
        biases[0] + model.g_sensitivity_rad_s_per_m_s2 * f_rest,
        biases[1] + model.accel.misalignment * f_rest,
        model.gyro.scale,
        model.accel.scale,
    ]
}

/// The NEES after every update.
struct Consistency<'a> {
    truth: &'a [Truth],
    /// The simulator's error model.
    model: ImuErrorModel,
    /// Its fixed plus turn-on biases, gyros and accelerometers.
    biases: [Vector3<f64>; 2],
    /// Its in-run biases at each truth row.
    in_run: &'a [InRunBiases],
    epochs: Vec<Epoch>,
    /// The last update's time [s] and state.
    last: Option<(f64, AidedIns<f64>)>,
}

impl Consistency<'_> {
    /// The simulated gyro and accelerometer biases at `t_s` [s] as the filter's bias states
    /// hold them: fixed, turn-on, and the in-run parts they follow ([`bias_state_part`]) at
    /// the last truth row not after `t_s`.
    fn biases_at(&self, t_s: f64) -> [Vector3<f64>; 2] {
        let k = self
            .truth
            .partition_point(|row| row.t_s <= t_s)
            .saturating_sub(1);
        let drift = self.in_run.get(k).copied().unwrap_or_default();
        [
            self.biases[0] + bias_state_part(&self.model.gyro, drift.gyro_gm, drift.gyro_rw),
            self.biases[1] + bias_state_part(&self.model.accel, drift.accel_gm, drift.accel_rw),
        ]
    }
}

impl AidedSink<f64> for Consistency<'_> {
    fn sample(&mut self, _t_us: u64, _ins: &AidedIns<f64>) -> Result<()> {
        Ok(())
    }

    fn updated(&mut self, t_us: u64, ins: &AidedIns<f64>) {
        let t_s = t_us as f64 * 1e-6;
        if let Some(truth) = interpolate(self.truth, t_s) {
            let e = state_error(ins.state(), &truth);
            let p = ins.covariance();
            let p9 = navigation_covariance(ins);
            let nees = nees(&p9, &e);
            let block = |b: usize| {
                let eb = e.fixed_rows::<3>(3 * b).into_owned();
                p9.fixed_view::<3, 3>(3 * b, 3 * b)
                    .into_owned()
                    .cholesky()
                    .map(|c| eb.dot(&c.solve(&eb)))
                    .unwrap_or(f64::INFINITY)
            };
            let est = ins.sensor_errors();
            let estimates = [
                est.gyro_bias_rad_s,
                est.accel_bias_mps2,
                est.gyro_scale,
                est.accel_scale,
            ];
            let sensor_truth = effective_sensor_errors(&self.model, self.biases_at(t_s));
            let mut nees_sensor = [0.0; 4];
            for (k, (n, offset)) in nees_sensor.iter_mut().zip([BG, BA, SG, SA]).enumerate() {
                let e = estimates[k] - sensor_truth[k];
                *n = p
                    .fixed_view::<3, 3>(offset, offset)
                    .into_owned()
                    .cholesky()
                    .map(|c| e.dot(&c.solve(&e)))
                    .unwrap_or(f64::INFINITY);
            }
            self.epochs.push(Epoch {
                t_s,
                nees,
                nees_blocks: [block(0), block(1), block(2)],
                nees_sensor,
                nis: None,
                horizontal_m: (
                    (e[0] * e[0] + e[1] * e[1]).sqrt(),
                    (p[(0, 0)] + p[(1, 1)]).sqrt(),
                ),
            });
        }
        self.last = Some((t_s, ins.clone()));
    }
}

/// A simulated case ready to run: the simulation, its fixes and the filter's sequencer
/// (started from the truth with errors drawn from the start's own 1-sigma).
pub struct Prepared {
    /// The simulation.
    pub sim: crate::simulate::Simulated,
    /// The GNSS receiver's output.
    pub gnss: crate::gnss_sim::GnssSim,
    /// The sequencer.
    pub seq: Sequencer<f64>,
}

impl Prepared {
    /// The recording's samples for [`aided::run`].
    pub fn samples(&self) -> impl FnMut() -> Result<Option<AidedSample<f64>>, String> + '_ {
        recording_samples(&self.sim.recording)
    }
}

/// A simulated recording's samples for [`aided::run`], in precision `T`.
pub fn recording_samples<T: Scalar>(
    recording: &Recording,
) -> impl FnMut() -> Result<Option<AidedSample<T>>, String> + '_ {
    let records = &recording.records;
    let mut prev_t_ns = recording.t0_ns;
    let mut k = 0;
    move || {
        let Some(r) = records.get(k) else {
            return Ok(None);
        };
        k += 1;
        let dt_s = (r.t_ns - prev_t_ns) as f64 * 1e-9;
        prev_t_ns = r.t_ns;
        Ok(Some(AidedSample {
            t_us: r.t_ns / 1000,
            increment: nav_core::ImuIncrement::new(
                r.gyro.map(T::of_f32),
                r.accel.map(T::of_f32),
                T::c(dt_s),
            ),
            unusable: false,
            behind: false,
            gap: false,
            clipped: Default::default(),
        }))
    }
}

/// Simulates `case` and builds its filter.
pub fn prepare(case: &Case) -> Result<Prepared> {
    let mut scenario = Scenario::by_name(&case.scenario)?;
    if case.scenario == "land-vehicle" {
        // The route fills the run (its own default is 600 s).
        scenario.set("seconds", case.seconds)?;
    }
    let mut opts = SimOptions::new(scenario, case.grade);
    opts.seconds = Some(case.seconds);
    opts.rate_hz = case.imu_rate_hz;
    opts.seed = case.seed;
    let traj = opts.scenario.build()?;
    let (sampling, every) = plan(opts.rate_hz, opts.truth_rate_hz, case.seconds)?;
    let injector = ErrorInjector::new(case.sensor_model(), case.seed)
        .map_err(|e| anyhow!("grade {}: {e}", case.grade))?;
    let sim = sense(traj.as_ref(), sampling, every, injector, |_, _| {})?;
    let gnss = gnss_sim::simulate(&sim.truth, &case.gnss)?;
    let model = filter_model_of(&case.error_model());
    let mut config = model_config(&model);
    if !case.zero_motion {
        config.zero_motion = None;
    }
    config.antenna_lever_arm_b_m = Vector3::from(case.gnss.lever_arm_b_m);
    // The receiver's correlated error, as its user would declare it.
    config.gnss_correlated_error = case.gnss.correlated.map(|c| GnssCorrelatedError {
        sigma_ned_m: Vector3::from(c.sigma_ned_m),
        correlation_time_s: c.time_s,
    });
    // A start with errors drawn from its own 1-sigma.
    let t0 = sim.truth[0];
    let sigma = InitialSigma::new(
        Vector3::repeat(2.0),
        Vector3::repeat(0.1),
        Vector3::new(0.05f64, 0.05, 0.5).map(f64::to_radians),
        &model.start_sigma,
    );
    let mut rng = ChaCha8Rng::seed_from_u64(case.seed ^ 0x005E_ED0F_57A7);
    let mut draw = |s: &Vector3<f64>| {
        s.map(|x| {
            let n: f64 = StandardNormal.sample(&mut rng);
            n * x
        })
    };
    let dr = draw(&sigma.position_ned_m);
    let dv = draw(&sigma.velocity_ned_m_s);
    let dphi = draw(&sigma.attitude_rad);
    let start_state = NavState {
        q_b_n: nav_core::attitude::rotation_vector_quat(&(-dphi)) * t0.q_b_ned,
        v_eb_n: t0.v_eb_ned + dv,
        position: Position::from_radians(t0.lat, t0.lon, t0.h).offset_ned(dr.into()),
    };
    let seq = Sequencer::new(
        config,
        Start::Given {
            state: start_state,
            sensors: SensorErrors::default(),
            sigma,
        },
    )
    .map_err(|e| anyhow!("{e}"))?;
    Ok(Prepared { sim, gnss, seq })
}

/// Runs one case in `f64`.
pub fn run_case(case: &Case) -> Result<CaseResult> {
    let Prepared { sim, gnss, seq } = prepare(case)?;
    let fixes = gnss.fixes.clone();
    let prepared_sim = Prepared {
        sim,
        gnss,
        seq: seq.clone(),
    };
    let sim = &prepared_sim.sim;
    let m = case.sensor_model();
    let injector =
        ErrorInjector::new(m, case.seed).map_err(|e| anyhow!("grade {}: {e}", case.grade))?;
    let sink_biases = [
        m.gyro.bias + injector.gyro_state().turn_on_bias,
        m.accel.bias + injector.accel_state().turn_on_bias,
    ];
    let mut sink = Consistency {
        truth: &sim.truth,
        model: m,
        biases: sink_biases,
        in_run: &sim.in_run_biases,
        epochs: Vec::new(),
        last: None,
    };
    let report = aided::run(prepared_sim.samples(), &fixes, seq, &mut sink)?;
    let no_update = || anyhow!("no GNSS update in the run");
    let final_biases = sink.biases_at(sink.last.as_ref().ok_or_else(no_update)?.0);
    let Consistency {
        mut epochs, last, ..
    } = sink;
    // NIS in the same order as the epochs (one position update per epoch).
    let mut nis = report.updates.iter().map(|u| match u.position {
        AidResult::Accepted { nis } | AidResult::Rejected { nis } => Some(nis),
        AidResult::Invalid => None,
    });
    for e in &mut epochs {
        e.nis = nis.next().flatten();
    }
    let (_, ins) = last.ok_or_else(no_update)?;
    // The final estimates against what the filter can see of the sensor errors
    // ([`effective_sensor_errors`]), each over its own 1-sigma.
    let truth = effective_sensor_errors(&m, final_biases);
    let est = ins.sensor_errors();
    let estimates = [
        est.gyro_bias_rad_s,
        est.accel_bias_mps2,
        est.gyro_scale,
        est.accel_scale,
    ];
    let p = ins.covariance();
    let mut sensor_z = [0.0; 12];
    for (b, offset) in [BG, BA, SG, SA].into_iter().enumerate() {
        for k in 0..3 {
            sensor_z[3 * b + k] =
                (estimates[b][k] - truth[b][k]) / p[(offset + k, offset + k)].sqrt();
        }
    }
    let mut bias_z = [0.0; 6];
    bias_z.copy_from_slice(&sensor_z[..6]);
    Ok(CaseResult {
        epochs,
        bias_z,
        sensor_z,
        accepted: report.counters.position.accepted,
        rejected: report.counters.position.rejected,
        realignments: report.realignments,
    })
}

/// 95 % two-sided bounds of the average of `runs` chi-square variables with `dof` degrees of
/// freedom (Wilson–Hilferty approximation of the chi-square quantiles).
pub fn average_chi2_bounds(dof: f64, runs: usize) -> (f64, f64) {
    let k = dof * runs as f64;
    let q = |z: f64| {
        let a = 2.0 / (9.0 * k);
        k * (1.0 - a + z * a.sqrt()).powi(3)
    };
    (q(-1.959_964) / runs as f64, q(1.959_964) / runs as f64)
}

/// The consistency table of `runs` seeded runs of each (scenario, grade, GNSS rate) cell: the
/// fraction of epochs whose average NEES (9 dof) and NIS (3 dof) over the runs lies inside the
/// 95 % bounds, the sensor biases' final normalised errors, and the gate's refusals.
#[derive(Clone, Debug, PartialEq)]
pub struct ConsistencyRow {
    /// Scenario.
    pub scenario: String,
    /// Grade.
    pub grade: Grade,
    /// GNSS rate [Hz].
    pub gnss_rate_hz: f64,
    /// Runs.
    pub runs: usize,
    /// Epochs compared (common to all runs).
    pub epochs: usize,
    /// Fraction of epochs with the average NEES inside its 95 % bounds.
    pub nees_inside: f64,
    /// Mean of the average NEES over the epochs (9 when consistent).
    pub nees_mean: f64,
    /// The same of each block: position, velocity, attitude (3 when consistent).
    pub nees_blocks_mean: [f64; 3],
    /// Per tenth of the run: its end [s] and the mean NEES of each of [`NEES_BLOCKS`] over
    /// the runs and that tenth's epochs (3 when consistent).
    pub blocks_over_time: Vec<(f64, [f64; 7])>,
    /// Fraction of epochs with the average NIS inside its 95 % bounds.
    pub nis_inside: f64,
    /// Mean NIS (3 when consistent).
    pub nis_mean: f64,
    /// RMS of the final bias errors over their 1-sigma (gyro, accelerometer).
    pub bias_z_rms: (f64, f64),
    /// Largest |bias error / 1-sigma|.
    pub bias_z_max: f64,
    /// Fraction of the final estimates (runs x 3 axes) within 3 sigma of
    /// [`effective_sensor_errors`]: gyro bias, accelerometer bias, gyro and accelerometer
    /// scale factors.
    pub sensor_within_3_sigma: [f64; 4],
    /// Fixes refused by the gate, of all.
    pub rejected: (u32, u32),
}

/// Runs `runs` seeds of one cell on `threads` threads.
pub fn consistency_cell(base: &Case, runs: usize, threads: usize) -> Result<ConsistencyRow> {
    let seeds: Vec<u64> = (0..runs as u64)
        .map(|k| base.seed.wrapping_add(k))
        .collect();
    let results = std::sync::Mutex::new(Vec::new());
    let chunks: Vec<Vec<u64>> = (0..threads.max(1))
        .map(|t| {
            seeds
                .iter()
                .copied()
                .skip(t)
                .step_by(threads.max(1))
                .collect()
        })
        .collect();
    std::thread::scope(|s| {
        for chunk in &chunks {
            let results = &results;
            s.spawn(move || {
                for seed in chunk {
                    let mut case = base.clone();
                    case.seed = *seed;
                    case.gnss.seed = *seed;
                    let r = run_case(&case);
                    results.lock().expect("no panics").push((*seed, r));
                }
            });
        }
    });
    let mut results = results.into_inner().expect("no panics");
    results.sort_by_key(|(s, _)| *s);
    let results: Vec<CaseResult> = results
        .into_iter()
        .map(|(s, r)| r.map_err(|e| anyhow!("seed {s}: {e}")))
        .collect::<Result<_>>()?;
    // Epochs matched by their time (to the microsecond): a run that re-aligned in motion
    // has none while it did, and its later epochs are those of the others' times.
    let key = |e: &Epoch| (e.t_s * 1e6).round() as i64;
    let by_time: Vec<std::collections::HashMap<i64, &Epoch>> = results
        .iter()
        .map(|r| r.epochs.iter().map(|e| (key(e), e)).collect())
        .collect();
    let table: Vec<Vec<&Epoch>> = results
        .first()
        .map(|r| r.epochs.as_slice())
        .unwrap_or_default()
        .iter()
        .filter_map(|e| by_time.iter().map(|m| m.get(&key(e)).copied()).collect())
        .collect();
    let epochs = table.len();
    let (lo9, hi9) = average_chi2_bounds(9.0, runs);
    let (lo3, hi3) = average_chi2_bounds(3.0, runs);
    let (mut nees_in, mut nis_in, mut nis_n) = (0, 0, 0);
    let (mut nees_sum, mut nis_sum) = (0.0, 0.0);
    let mut blocks = [0.0; 3];
    for row in &table {
        for (b, sum) in blocks.iter_mut().enumerate() {
            *sum +=
                row.iter().map(|e| e.nees_blocks[b]).sum::<f64>() / (runs * epochs.max(1)) as f64;
        }
        let nees = row.iter().map(|e| e.nees).sum::<f64>() / runs as f64;
        nees_sum += nees;
        if (lo9..=hi9).contains(&nees) {
            nees_in += 1;
        }
        let nis: Vec<f64> = row.iter().filter_map(|e| e.nis).collect();
        if nis.len() == runs {
            let m = nis.iter().sum::<f64>() / runs as f64;
            nis_sum += m;
            nis_n += 1;
            if (lo3..=hi3).contains(&m) {
                nis_in += 1;
            }
        }
    }
    let tenths = 10.min(epochs);
    let blocks_over_time = (0..tenths)
        .map(|w| {
            let (a, b) = (w * epochs / tenths, (w + 1) * epochs / tenths);
            let mut mean = [0.0; 7];
            for e in table[a..b].iter().flatten() {
                let all = e.nees_blocks.iter().chain(&e.nees_sensor);
                for (m, x) in mean.iter_mut().zip(all) {
                    *m += x / ((b - a) * runs) as f64;
                }
            }
            (table[b - 1][0].t_s, mean)
        })
        .collect();
    let z: Vec<[f64; 6]> = results.iter().map(|r| r.bias_z).collect();
    let rms = |range: std::ops::Range<usize>| {
        let v: Vec<f64> = z.iter().flat_map(|b| b[range.clone()].to_vec()).collect();
        (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt()
    };
    Ok(ConsistencyRow {
        scenario: base.scenario.clone(),
        grade: base.grade,
        gnss_rate_hz: base.gnss.rate_hz,
        runs,
        epochs,
        nees_inside: nees_in as f64 / epochs.max(1) as f64,
        nees_mean: nees_sum / epochs.max(1) as f64,
        nees_blocks_mean: blocks,
        blocks_over_time,
        nis_inside: nis_in as f64 / nis_n.max(1) as f64,
        nis_mean: nis_sum / nis_n.max(1) as f64,
        bias_z_rms: (rms(0..3), rms(3..6)),
        bias_z_max: z.iter().flatten().fold(0.0_f64, |a, b| a.max(b.abs())),
        sensor_within_3_sigma: core::array::from_fn(|b| {
            let inside = results
                .iter()
                .flat_map(|r| &r.sensor_z[3 * b..3 * b + 3])
                .filter(|z| z.abs() <= 3.0)
                .count();
            inside as f64 / (3 * runs) as f64
        }),
        rejected: (
            results.iter().map(|r| r.rejected).sum(),
            results.iter().map(|r| r.accepted + r.rejected).sum(),
        ),
    })
}
