//! The navigation filter in `f32` (the MCU's precision) against the same filter in `f64`, over
//! one hour of GNSS-aided land-vehicle data: the `f32` filter's errors stay within twice the
//! `f64` filter's, and its covariance stays symmetric positive definite, checked by a Cholesky
//! factorisation in `f32` after every update.

use host_tests::aided::{self, AidedSink};
use host_tests::aided_bench::{recording_samples, state_error};
use host_tests::aided_cmd::{AidedStart, GivenStart, grade_noise, sequencer};
use host_tests::gnss_sim::{self, GnssSimOptions, Outage};
use host_tests::report::interpolate;
use host_tests::sensor_model::Grade;
use host_tests::simulate::{SimOptions, Simulated, simulate};
use host_tests::trajectory::scenarios::Scenario;
use host_tests::truth::Truth;
use nav_core::ins_filter::{AidedIns, FilterConfig, SensorErrors};
use nav_core::nalgebra::{Quaternion, UnitQuaternion};
use nav_core::{NavState, Scalar, Vector3};

/// Errors after every update: horizontal, vertical [m], velocity [m/s], tilt, yaw [rad].
#[derive(Default)]
struct Errors {
    truth: Vec<Truth>,
    rows: Vec<[f64; 5]>,
    /// Their times [s].
    times: Vec<f64>,
    /// Updates after which the covariance was not symmetric positive definite.
    not_pd: Vec<f64>,
}

impl<T: Scalar> AidedSink<T> for Errors {
    fn sample(&mut self, _t_us: u64, _ins: &AidedIns<T>) -> anyhow::Result<()> {
        Ok(())
    }

    fn updated(&mut self, t_us: u64, ins: &AidedIns<T>) {
        let t_s = t_us as f64 * 1e-6;
        let p = ins.covariance();
        let symmetric = (0..p.nrows()).all(|i| (0..i).all(|j| p[(i, j)] == p[(j, i)]));
        if !symmetric || (*p).cholesky().is_none() {
            self.not_pd.push(t_s);
        }
        let Some(truth) = interpolate(&self.truth, t_s) else {
            return;
        };
        let s = ins.state();
        let wide = NavState {
            q_b_n: UnitQuaternion::from_quaternion(Quaternion::from(s.q_b_n.coords.map(T::to_f64))),
            v_eb_n: s.v_eb_n.map(T::to_f64),
            position: s.position,
        };
        let e = state_error(&wide, &truth);
        self.times.push(t_s);
        self.rows.push([
            e[0].hypot(e[1]),
            e[2].abs(),
            e.fixed_rows::<3>(3).norm(),
            e[6].hypot(e[7]),
            e[8].abs(),
        ]);
    }
}

impl Errors {
    fn rms(&self) -> [f64; 5] {
        let n = self.rows.len().max(1) as f64;
        core::array::from_fn(|k| (self.rows.iter().map(|r| r[k] * r[k]).sum::<f64>() / n).sqrt())
    }

    fn max(&self) -> [f64; 5] {
        core::array::from_fn(|k| self.rows.iter().map(|r| r[k]).fold(0.0, f64::max))
    }

    /// Time of the largest error of quantity `k` [s].
    fn t_max(&self, k: usize) -> f64 {
        let i = (0..self.rows.len())
            .max_by(|&a, &b| self.rows[a][k].total_cmp(&self.rows[b][k]))
            .unwrap_or(0);
        self.times.get(i).copied().unwrap_or(f64::NAN)
    }
}

/// One hour of `grade` on the land-vehicle route with 1 Hz fixes of `sigma_ned_m`, 60 s outages
/// at 20 and 40 minutes.
fn data(grade: Grade, sigma_ned_m: [f64; 3], seed: u64) -> (Simulated, gnss_sim::GnssSim) {
    let seconds = 3600.0;
    let mut scenario = Scenario::by_name("land-vehicle").unwrap();
    scenario.set("seconds", seconds).unwrap();
    let mut opts = SimOptions::new(scenario, grade);
    opts.seconds = Some(seconds);
    opts.rate_hz = 200.0;
    opts.truth_rate_hz = 10.0;
    opts.seed = seed;
    let sim = simulate(&opts, |_, _| {}).unwrap();
    let gnss = gnss_sim::simulate(
        &sim.truth,
        &GnssSimOptions {
            sigma_ned_m,
            lever_arm_b_m: [0.8, -0.3, -1.1],
            outages: vec![
                Outage {
                    start_s: 1200.0,
                    length_s: 60.0,
                },
                Outage {
                    start_s: 2400.0,
                    length_s: 60.0,
                },
            ],
            seed,
            ..GnssSimOptions::default()
        },
    )
    .unwrap();
    (sim, gnss)
}

/// The run in precision `T`, from the truth's first row off by a few sigma-sized errors.
fn run<T: Scalar>(
    sim: &Simulated,
    gnss: &gnss_sim::GnssSim,
    config: &FilterConfig<f64>,
) -> (Errors, u32) {
    let t0 = sim.truth[0];
    let (roll, pitch, yaw) = t0.q_b_ned.euler_angles();
    let start = GivenStart {
        pos_deg_m: [t0.lat.to_degrees(), t0.lon.to_degrees(), t0.h + 1.0],
        vel_m_s: (t0.v_eb_ned + Vector3::repeat(0.05)).into(),
        att_deg: [roll, pitch, yaw].map(f64::to_degrees).map(|a| a + 0.03),
        pos_std_m: [2.0; 3],
        vel_std_m_s: [0.1; 3],
        att_std_deg: [0.05, 0.05, 0.5],
        sensors: SensorErrors::default(),
        sensor_sigma: None,
    };
    let seq = sequencer::<T>(config, &AidedStart::Given(Box::new(start))).unwrap();
    let mut errors = Errors {
        truth: sim.truth.clone(),
        ..Errors::default()
    };
    let samples = recording_samples::<T>(&sim.recording);
    let report = aided::run(samples, &gnss.fixes, seq, &mut errors).unwrap();
    assert!(report.counters.position.accepted > 3000, "{report:?}");
    (errors, report.covariance_faults)
}

fn f32_within_twice_f64(grade: Grade, sigma_ned_m: [f64; 3], seed: u64) {
    let (sim, gnss) = data(grade, sigma_ned_m, seed);
    let mut config = FilterConfig::new(grade_noise(grade));
    config.antenna_lever_arm_b_m = Vector3::new(0.8, -0.3, -1.1);
    let (wide, wide_faults) = run::<f64>(&sim, &gnss, &config);
    let (narrow, narrow_faults) = run::<f32>(&sim, &gnss, &config);
    let names = ["horizontal", "vertical", "velocity", "tilt", "yaw"];
    let (rms64, rms32, max64, max32) = (wide.rms(), narrow.rms(), wide.max(), narrow.max());
    for k in 0..5 {
        eprintln!(
            "{grade} {sigma_ned_m:?}: {} RMS f64 {:.3e} f32 {:.3e}; max f64 {:.3e} (at {:.1} s) \
             f32 {:.3e} (at {:.1} s)",
            names[k],
            rms64[k],
            rms32[k],
            max64[k],
            wide.t_max(k),
            max32[k],
            narrow.t_max(k)
        );
    }
    assert_eq!(wide.rows.len(), narrow.rows.len());
    assert_eq!((wide_faults, narrow_faults), (0, 0));
    assert!(
        narrow.not_pd.is_empty(),
        "f32 not PD at {:?}",
        narrow.not_pd
    );
    assert!(wide.not_pd.is_empty(), "f64 not PD at {:?}", wide.not_pd);
    for k in 0..5 {
        assert!(
            rms32[k] <= 2.0 * rms64[k],
            "{grade}: {} RMS f32 {} > 2 x f64 {}",
            names[k],
            rms32[k],
            rms64[k]
        );
        assert!(
            max32[k] <= 2.0 * max64[k],
            "{grade}: {} max f32 {} > 2 x f64 {}",
            names[k],
            max32[k],
            max64[k]
        );
    }
}

/// Tactical MEMS with 0.5 m fixes (the covariance grows through the outages and shrinks again).
#[test]
fn f32_filter_within_twice_f64_over_an_hour_mems() {
    f32_within_twice_f64(Grade::MemsTactical, [0.5, 0.5, 1.0], 21);
}

/// FOG with RTK fixes of 2 cm (the hardest conditioning: sigmas from centimetres to
/// microradians of gyro bias in one matrix).
#[test]
fn f32_filter_within_twice_f64_over_an_hour_fog_rtk() {
    f32_within_twice_f64(Grade::Fog, [0.02, 0.02, 0.04], 22);
}
