//! `nav bench filter`: a 1-hour, 200 Hz GNSS-aided land-vehicle data set in KF-GINS's text
//! formats (IMU file, GNSS file with RTK-grade 1-sigma, truth `.nav`, YAML configuration), run
//! through `nav kf-gins` ([`crate::kf_gins_run`]): IMU samples per second (text parsing and
//! `.nav` writing included) and the accuracy against the truth.

use crate::aided_cmd::grade_filter_model;
use crate::gnss::GnssFix;
use crate::gnss_sim::{self, GnssSimOptions};
use crate::kf_gins::read_truth;
use crate::kf_gins_run;
use crate::nav_writer::NavWriter;
use crate::sensor_model::ErrorInjector;
use crate::sensor_model::Grade;
use crate::trajectory::scenarios::Scenario;
use crate::truth::horizontal_distance_m;
use anyhow::{Context, Result, anyhow, ensure};
use nav_core::nalgebra::{Matrix3, Vector3};
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The data set's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterBenchOptions {
    /// Length [s].
    pub seconds: f64,
    /// IMU rate [Hz].
    pub imu_rate_hz: f64,
    /// Sensor grade.
    pub grade: Grade,
    /// GNSS 1-sigma north, east, down [m].
    pub gnss_sigma_ned_m: [f64; 3],
    /// Antenna lever arm, body FRD [m].
    pub lever_arm_b_m: [f64; 3],
    /// GNSS seconds of week of the first IMU epoch [s].
    pub start_sow_s: f64,
    /// Seed.
    pub seed: u64,
}

impl Default for FilterBenchOptions {
    /// 1 h at 200 Hz, tactical MEMS (ADIS16465 class, as KF-GINS's own data set; calibrated:
    /// no misalignment or g-sensitivity, see [`generate`]), RTK fixes
    /// of 1.0 cm / 0.9 cm / 1.9 cm at 1 Hz (the 1-sigma of KF-GINS's own data set's
    /// `GNSS-RTK.txt` in open sky), antenna 0.5 m ahead and 1.2 m above.
    fn default() -> Self {
        Self {
            seconds: 3600.0,
            imu_rate_hz: 200.0,
            grade: Grade::MemsTactical,
            gnss_sigma_ned_m: [0.010, 0.009, 0.019],
            lever_arm_b_m: [0.5, -0.2, -1.2],
            start_sow_s: 356_400.0,
            seed: 1,
        }
    }
}

/// The data set's files.
#[derive(Clone, Debug, PartialEq)]
pub struct DataSet {
    /// The YAML configuration.
    pub config: PathBuf,
    /// The truth trajectory (`.nav`).
    pub truth: PathBuf,
    /// The trajectory `nav kf-gins` writes.
    pub out: PathBuf,
    /// IMU rows.
    pub imu_rows: u64,
}

fn write_lines(path: &Path, body: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    crate::atomic::write(path, |w| body(w)).with_context(|| format!("writing {}", path.display()))
}

/// Writes the data set into `dir`.
pub fn generate(dir: &Path, o: &FilterBenchOptions) -> Result<DataSet> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut scenario = Scenario::by_name("land-vehicle")?;
    scenario.set("seconds", o.seconds)?;
    let traj = scenario.build()?;
    let (sampling, every) = crate::simulate::plan(o.imu_rate_hz, 50.0, o.seconds)?;
    // A calibrated IMU: KF-GINS's model (and its configuration file) has biases and scale
    // factors only; the triads' misalignments (whose rotation part is a mounting error no
    // filter can see) and the gyros' g-sensitivity are calibrated out.
    let mut model = o.grade.model();
    model.gyro.misalignment = Matrix3::zeros();
    model.accel.misalignment = Matrix3::zeros();
    model.g_sensitivity_rad_s_per_m_s2 = Matrix3::zeros();
    let injector = ErrorInjector::new(model, o.seed).map_err(|e| anyhow!("{e}"))?;
    let sim = crate::simulate::sense(traj.as_ref(), sampling, every, injector, |_, _| {})?;
    let gnss = gnss_sim::simulate(
        &sim.truth,
        &GnssSimOptions {
            rate_hz: 1.0,
            sigma_ned_m: o.gnss_sigma_ned_m,
            sigma_v_ned_m_s: None,
            lever_arm_b_m: o.lever_arm_b_m,
            seed: o.seed,
            ..GnssSimOptions::default()
        },
    )?;
    let t0 = o.start_sow_s;
    let imu = dir.join("imu.txt");
    let records = &sim.recording.records;
    write_lines(&imu, |w| {
        // An epoch at `starttime`, the start's (KF-GINS takes the start at the first epoch at
        // or after it, and integrates from there): the first interval's increments, not
        // integrated.
        let start = records.first().map(|r| (0, r));
        let epochs = start.into_iter().chain(records.iter().map(|r| (r.t_ns, r)));
        for (t_ns, r) in epochs {
            let t = t0 + t_ns as f64 * 1e-9;
            let [gx, gy, gz] = r.gyro.map(f64::from);
            let [ax, ay, az] = r.accel.map(f64::from);
            writeln!(w, "{t:.6} {gx:e} {gy:e} {gz:e} {ax:e} {ay:e} {az:e}")?;
        }
        Ok(())
    })?;
    let gnss_path = dir.join("gnss.txt");
    let fixes: Vec<GnssFix> = gnss.fixes;
    write_lines(&gnss_path, |w| {
        for f in &fixes {
            writeln!(
                w,
                "{:.6} {:.10} {:.10} {:.4} {} {} {}",
                t0 + f.t_s,
                f.lat_rad.to_degrees(),
                f.lon_rad.to_degrees(),
                f.h_m,
                f.sigma_ned_m[0],
                f.sigma_ned_m[1],
                f.sigma_ned_m[2]
            )?;
        }
        Ok(())
    })?;
    let truth = dir.join("truth.nav");
    let mut tw = NavWriter::create(&truth)?;
    for t in &sim.truth {
        let mut t = *t;
        t.t_s += t0;
        tw.write_truth(&t)?;
    }
    tw.finish()?;
    // The configuration: the start at the truth (KF-GINS users give the reference's), the
    // grade's noise in KF-GINS's units, as the filter models the simulated sensor
    // ([`grade_filter_model`]): KF-GINS's `imunoise` is the in-run part (white noise, the
    // gyros' few-second bias instability folded into it, the bias drift as `gbstd`/`abstd`
    // over `corrtime`; the scale factors are constants, no drift) and `init*std` the start's
    // (turn-on biases, scale factors).
    let s = sim.truth[0];
    let (roll, pitch, yaw) = nav_core::attitude::euler(&s.q_b_ned);
    let model = grade_filter_model(o.grade);
    let n = &model.noise;
    let s0 = &model.start_sigma;
    let (init_bg, init_ba, init_sg, init_sa) = (
        s0.gyro_bias_rad_s,
        s0.accel_bias_mps2,
        s0.gyro_scale,
        s0.accel_scale,
    );
    let deg = f64::to_degrees;
    let three = |v: f64| format!("[{v:e}, {v:e}, {v:e}]");
    let each = |v: Vector3<f64>| format!("[{:e}, {:e}, {:e}]", v.x, v.y, v.z);
    let out = dir.join("result.nav");
    let mut yaml = String::new();
    writeln!(
        yaml,
        "# Generated by nav bench filter: KF-GINS's keys and units."
    )?;
    writeln!(yaml, "imupath: \"{}\"", imu.display())?;
    writeln!(yaml, "gnsspath: \"{}\"", gnss_path.display())?;
    writeln!(yaml, "outputpath: \"{}\"", dir.display())?;
    writeln!(yaml, "imudatalen: 7\nimudatarate: {}", o.imu_rate_hz)?;
    writeln!(yaml, "starttime: {t0}\nendtime: -1")?;
    writeln!(
        yaml,
        "initpos: [{:.10}, {:.10}, {:.4}]",
        deg(s.lat),
        deg(s.lon),
        s.h
    )?;
    writeln!(
        yaml,
        "initvel: [{}, {}, {}]",
        s.v_eb_ned.x, s.v_eb_ned.y, s.v_eb_ned.z
    )?;
    writeln!(
        yaml,
        "initatt: [{}, {}, {}]",
        deg(roll),
        deg(pitch),
        deg(yaw)
    )?;
    writeln!(yaml, "initgyrbias: [0, 0, 0]\ninitaccbias: [0, 0, 0]")?;
    writeln!(yaml, "initgyrscale: [0, 0, 0]\ninitaccscale: [0, 0, 0]")?;
    writeln!(
        yaml,
        "initposstd: [0.05, 0.05, 0.1]\ninitvelstd: [0.05, 0.05, 0.05]"
    )?;
    writeln!(yaml, "initattstd: [0.1, 0.1, 0.5]")?;
    writeln!(
        yaml,
        "initbgstd: {}\ninitbastd: {}",
        each(init_bg.map(|v| deg(v) * 3600.0)),
        each(init_ba * 1e5)
    )?;
    writeln!(
        yaml,
        "initsgstd: {}\ninitsastd: {}",
        each(init_sg * 1e6),
        each(init_sa * 1e6)
    )?;
    writeln!(yaml, "imunoise:")?;
    // KF-GINS has no state for the few-second bias instability (our filter's consider state):
    // it integrates like white noise of density 2 sigma^2 T ([Groves, eq. 14.80]).
    let arw = (n.arw_rad_per_sqrt_s.powi(2)
        + 2.0 * n.gyro_bias_instability_rad_s.powi(2) * n.gyro_bias_instability_time_s)
        .sqrt();
    writeln!(yaml, "  arw: {}", three(deg(arw) * 60.0))?;
    writeln!(yaml, "  vrw: {}", three(n.vrw_mps_per_sqrt_s * 60.0))?;
    writeln!(yaml, "  gbstd: {}", three(deg(n.gyro_bias_rad_s) * 3600.0))?;
    writeln!(yaml, "  abstd: {}", three(n.accel_bias_mps2 * 1e5))?;
    writeln!(yaml, "  gsstd: {}", three(n.gyro_scale * 1e6))?;
    writeln!(yaml, "  asstd: {}", three(n.accel_scale * 1e6))?;
    writeln!(yaml, "  corrtime: {}", n.correlation_time_s / 3600.0)?;
    writeln!(
        yaml,
        "antlever: [{}, {}, {}]",
        o.lever_arm_b_m[0], o.lever_arm_b_m[1], o.lever_arm_b_m[2]
    )?;
    let config = dir.join("kf-gins.yaml");
    write_lines(&config, |w| Ok(w.write_all(yaml.as_bytes())?))?;
    Ok(DataSet {
        config,
        truth,
        out,
        imu_rows: records.len() as u64,
    })
}

/// The benchmark's figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterBenchReport {
    /// IMU samples processed.
    pub samples: u64,
    /// Wall-clock time of `nav kf-gins` [s].
    pub seconds: f64,
    /// Of [`Self::seconds`], the wait for the disk to store the `.nav` file (sync and rename)
    /// [s].
    pub store_seconds: f64,
    /// The thread's own CPU time over the same run [s] (Linux; `None` elsewhere): the speed on
    /// one core when other jobs share the machine's cores and stretch the wall clock.
    pub cpu_seconds: Option<f64>,
    /// Horizontal position error RMS [m].
    pub horizontal_rms_m: f64,
    /// Vertical position error RMS [m].
    pub vertical_rms_m: f64,
    /// Yaw error RMS [deg].
    pub yaw_rms_deg: f64,
    /// Largest horizontal error [m].
    pub horizontal_max_m: f64,
    /// Truth epochs compared.
    pub compared: usize,
    /// The filter's own 1-sigma RMS over the run: the error it expects of itself on these
    /// data, which no forward filter of the same model beats.
    pub sigma_rms: kf_gins_run::SigmaRms,
}

/// Runs `nav kf-gins` on a generated data set and compares its trajectory with the truth.
pub fn run(data: &DataSet) -> Result<FilterBenchReport> {
    let started = std::time::Instant::now();
    let cpu_started = thread_cpu_s();
    let run = kf_gins_run::run(
        &data.config,
        &kf_gins_run::Outputs {
            nav: Some(data.out.clone()),
            ..Default::default()
        },
    )?;
    let cpu_seconds = thread_cpu_s()
        .zip(cpu_started)
        .map(|(end, start)| end - start);
    let seconds = started.elapsed().as_secs_f64();
    let solution = read_truth(&data.out)?;
    let truth = read_truth(&data.truth)?;
    let (mut k, mut n) = (0, 0usize);
    let (mut h2, mut v2, mut y2, mut hmax) = (0.0, 0.0, 0.0, 0.0_f64);
    for t in &truth {
        while k < solution.len() && solution[k].t_s < t.t_s - 1e-6 {
            k += 1;
        }
        let Some(s) = solution.get(k) else { break };
        if (s.t_s - t.t_s).abs() > 1e-6 {
            continue;
        }
        let h = horizontal_distance_m(t.lat, t.lon, t.h, s.lat, s.lon);
        let (_, _, yt) = nav_core::attitude::euler(&t.q_b_ned);
        let (_, _, ys) = nav_core::attitude::euler(&s.q_b_ned);
        let mut dy = (ys - yt).to_degrees();
        dy -= 360.0 * (dy / 360.0).round();
        h2 += h * h;
        v2 += (s.h - t.h).powi(2);
        y2 += dy * dy;
        hmax = hmax.max(h);
        n += 1;
    }
    ensure!(n > 0, "no truth epoch matches the trajectory's");
    Ok(FilterBenchReport {
        samples: run.report.samples,
        seconds,
        store_seconds: run.store_s,
        cpu_seconds,
        horizontal_rms_m: (h2 / n as f64).sqrt(),
        vertical_rms_m: (v2 / n as f64).sqrt(),
        yaw_rms_deg: (y2 / n as f64).sqrt(),
        horizontal_max_m: hmax,
        compared: n,
        sigma_rms: run.sigma_rms,
    })
}

/// The calling thread's time on a CPU so far [s], user and kernel (Linux's
/// `/proc/thread-self/schedstat`, first field, nanoseconds); `None` where there is no such file.
pub fn thread_cpu_s() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: u64 = text.split_whitespace().next()?.parse().ok()?;
    Some(ns as f64 * 1e-9)
}
