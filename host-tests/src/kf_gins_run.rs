//! `nav kf-gins CONFIG.yaml`: a KF-GINS configuration run as it is — its IMU and GNSS text
//! files, its start (`initpos`, `initvel`, `initatt`, `init*std`), its noise (`imunoise`) and
//! antenna lever arm — through this project's filter, writing KF-GINS's 11-column `.nav`
//! trajectory, one row per IMU epoch after the start (an epoch at `starttime` is the start's,
//! as in KF-GINS: not integrated, no row), in `f64`.

use crate::aided::{self, AidedReport, AidedSample, AidedSink};
use crate::aided_cmd::{AidedStart, GivenStart, sequencer};
use crate::gnss::{self, GnssFix};
use crate::kf_gins::ImuReader;
use crate::kf_gins_config::{self, KfGinsConfig};
use crate::nav_writer::{NavRow, NavWriter};
use anyhow::{Context, Result, bail};
use nav_core::attitude::euler;
use nav_core::ins_filter::model::FilterNoise;
use nav_core::ins_filter::{ATT, AidedIns, FilterConfig, SensorErrors};
use nav_core::number::Number;
use nav_core::{ImuIncrement, Vector3};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// The name KF-GINS gives its trajectory in `outputpath`.
pub const KF_GINS_NAV_NAME: &str = "KF_GINS_Navresult.nav";

/// What a KF-GINS run did.
#[derive(Clone, Debug, PartialEq)]
pub struct KfGinsRun {
    /// The aided run's report.
    pub report: AidedReport,
    /// Rows written.
    pub rows: u64,
    /// The trajectory written.
    pub out: PathBuf,
    /// The configuration's warnings (keys not used).
    pub warnings: Vec<String>,
    /// IMU rows skipped before `starttime` or after `endtime`.
    pub outside_window: u64,
    /// Time spent storing the trajectory once written, syncing it to the disk and renaming
    /// it into place [s]: a wait on the disk, not processing (KF-GINS does not sync its
    /// output).
    pub store_s: f64,
    /// The filter's own 1-sigma over the trajectory's rows.
    pub sigma_rms: SigmaRms,
}

/// RMS over a run's rows of the filter's own 1-sigma: the error a consistent filter expects,
/// the bound its accuracy is judged beside.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SigmaRms {
    /// Horizontal position, `sqrt(mean(P_nn + P_ee))` [m].
    pub horizontal_m: f64,
    /// Heading [deg].
    pub yaw_deg: f64,
}

/// The filter's settings of a KF-GINS configuration. KF-GINS gives the noise per axis; the
/// filter's noise model is the same on all three axes: the largest axis is taken.
pub fn filter_config(c: &KfGinsConfig) -> FilterConfig<f64> {
    let n = &c.imu_noise;
    let max = |v: &[f64; 3]| v.iter().fold(0.0_f64, |a, b| a.max(*b));
    let mut config = FilterConfig::new(FilterNoise {
        arw_rad_per_sqrt_s: max(&n.arw_rad_sqrt_s),
        vrw_mps_per_sqrt_s: max(&n.vrw_m_s_sqrt_s),
        gyro_bias_rad_s: max(&n.gyro_bias_std_rad_s),
        accel_bias_mps2: max(&n.accel_bias_std_m_s2),
        gyro_scale: max(&n.gyro_scale_std),
        accel_scale: max(&n.accel_scale_std),
        correlation_time_s: n.corr_time_s,
        // KF-GINS models no cross-axis coupling.
        gyro_cross_coupling_rad: 0.0,
        accel_cross_coupling_rad: 0.0,
        gyro_g_sensitivity: 0.0,
        gyro_bias_instability_rad_s: 0.0,
        gyro_bias_instability_time_s: 0.0,
    });
    config.antenna_lever_arm_b_m = Vector3::from(c.lever_arm_b_m);
    // KF-GINS has no stop detector; the filter's ZUPT stays on (its gate refuses a wrong one).
    config
}

/// The given start of a KF-GINS configuration.
pub fn start(c: &KfGinsConfig) -> GivenStart {
    let v = |a: [f64; 3]| Vector3::from(a);
    GivenStart {
        pos_deg_m: [
            c.init_lat_rad.to_degrees(),
            c.init_lon_rad.to_degrees(),
            c.init_h_m,
        ],
        vel_m_s: c.init_v_eb_n_m_s,
        att_deg: c.init_euler_rad.map(f64::to_degrees),
        pos_std_m: c.init_pos_std_ned_m,
        vel_std_m_s: c.init_vel_std_ned_m_s,
        att_std_deg: c.init_att_std_rad.map(f64::to_degrees),
        sensors: SensorErrors {
            gyro_bias_rad_s: v(c.init_gyro_bias_rad_s),
            accel_bias_mps2: v(c.init_accel_bias_m_s2),
            gyro_scale: v(c.init_gyro_scale),
            accel_scale: v(c.init_accel_scale),
        },
        sensor_sigma: Some([
            c.init_gyro_bias_std_rad_s,
            c.init_accel_bias_std_m_s2,
            c.init_gyro_scale_std,
            c.init_accel_scale_std,
        ]),
    }
}

/// Every filter sample as a `.nav` row, and the sums of [`SigmaRms`].
struct NavRows {
    writer: NavWriter,
    /// Sums of the horizontal position variance [m^2] and the heading's [rad^2], and rows.
    variance_sums: (f64, f64, u64),
}

impl NavRows {
    fn sigma_rms(&self) -> SigmaRms {
        let (h2, y2, n) = self.variance_sums;
        let n = n.max(1) as f64;
        SigmaRms {
            horizontal_m: (h2 / n).sqrt(),
            yaw_deg: (y2 / n).sqrt().to_degrees(),
        }
    }
}

impl AidedSink<f64> for NavRows {
    fn sample(&mut self, t_us: u64, ins: &AidedIns<f64>) -> Result<()> {
        let s = ins.state();
        let p = ins.covariance();
        let p_pos = ins.position_covariance();
        let sums = &mut self.variance_sums;
        sums.0 += p_pos[(0, 0)] + p_pos[(1, 1)];
        sums.1 += p[(ATT + 2, ATT + 2)];
        sums.2 += 1;
        let (roll, pitch, yaw) = euler(&s.q_b_n);
        self.writer.write_row(&NavRow {
            t_s: t_us as f64 * 1e-6,
            lat_rad: s.position.lat_f64(),
            lon_rad: s.position.lon_f64(),
            h_m: s.position.h_f64(),
            v_eb_n_m_s: [s.v_eb_n.x, s.v_eb_n.y, s.v_eb_n.z],
            euler_rad: [roll, pitch, yaw],
        })?;
        Ok(())
    }
}

/// Runs the configuration at `config_path`; the trajectory goes to `out`, or to KF-GINS's
/// `outputpath/KF_GINS_Navresult.nav`.
pub fn run(config_path: &Path, out: Option<&Path>) -> Result<KfGinsRun> {
    let (c, warnings) = kf_gins_config::load(config_path)?;
    let out = out.map_or_else(|| c.output_dir.join(KF_GINS_NAV_NAME), Path::to_path_buf);
    crate::atomic::refuse_same_file(&[config_path, &c.imu_path, &c.gnss_path], &out)?;
    // Before the run, not after it: the folder the trajectory goes to.
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty())
        && !dir.is_dir()
    {
        bail!(
            "the output folder {} does not exist (outputpath, or --out's folder)",
            dir.display()
        );
    }
    let fixes: Vec<GnssFix> = gnss::read_gnss(&c.gnss_path)
        .with_context(|| format!("GNSS file {} (gnsspath)", c.gnss_path.display()))?;
    let config = filter_config(&c);
    let seq = sequencer::<f64>(&config, &AidedStart::Given(Box::new(start(&c))))?;
    let file = File::open(&c.imu_path)
        .with_context(|| format!("IMU file {} (imupath)", c.imu_path.display()))?;
    let mut rows = ImuReader::new(BufReader::with_capacity(1 << 20, file), &c.imu_path)
        .with_columns(c.imu_columns);
    let nominal_dt = 1.0 / c.imu_rate_hz;
    let (t_start, t_end) = (c.start_time_s, c.end_time_s.unwrap_or(f64::INFINITY));
    let mut prev_t: Option<f64> = None;
    // The last epoch's velocity increment that covered one interval.
    let mut prev_dv: Option<[f32; 3]> = None;
    let mut outside_window = 0_u64;
    // Intervals off `imudatarate` by more than a quarter of its interval, of all intervals (a
    // rate off by a factor of 2 or 4/3 is caught; a receiver's jitter of a few percent is not).
    let (mut off_rate, mut intervals) = (0_u64, 0_u64);
    let samples = || -> Result<Option<AidedSample<f64>>> {
        loop {
            let Some(row) = rows.next() else {
                return Ok(None);
            };
            let row = row?;
            let dt = prev_t.map_or(nominal_dt, |p| row.t_s - p);
            if prev_t.is_some() {
                intervals += 1;
                off_rate += u64::from((dt - nominal_dt).abs() > 0.25 * nominal_dt);
            }
            prev_t = Some(row.t_s);
            let gap = dt > 1.5 * nominal_dt;
            let dv = row.delta_v_ib_b.map(|x| x as f32);
            // After a gap, an increment of the last interval alone (a logger that dropped
            // epochs) is not integrated over the gap: the navigation bridges it.
            // Within the reader's gap limit (10 intervals; a longer interval is refused by the
            // increment limits or is no interval of `imudatarate`'s, which is checked below).
            let short = gap
                && dt <= 10.0 * nominal_dt
                && prev_dv.is_some_and(|p| {
                    !hal_adapters::sample::increment_spans_interval(&dv, &p, dt / nominal_dt)
                });
            // The last increment of one period stays the reference (the reader's rule: a run
            // of gaps is judged epoch by epoch).
            if !gap || short {
                prev_dv = Some(dv);
            }
            // KF-GINS starts at the first epoch at or after `starttime`: its initpos, initvel
            // and initatt hold at that epoch, whose increment (over the interval before it)
            // is not integrated (`kf_gins.cpp` adds it as `imupre_` only) and which gets no
            // row. An epoch at `starttime` is that epoch here too (the start holds at
            // `starttime`, every later epoch is integrated from it); integrating it moved
            // the whole trajectory one IMU interval ahead (6 cm at 12 m/s and 200 Hz).
            if row.t_s < t_start {
                outside_window += 1;
                continue;
            }
            if row.t_s == t_start {
                continue;
            }
            if row.t_s > t_end {
                outside_window += 1;
                return Ok(None);
            }
            return Ok(Some(AidedSample {
                t_us: (row.t_s * 1e6).round() as u64,
                increment: ImuIncrement::new(row.delta_theta_ib_b, row.delta_v_ib_b, dt),
                unusable: short,
                gap,
            }));
        }
    };
    let mut sink = NavRows {
        writer: NavWriter::create(&out)?,
        variance_sums: (0.0, 0.0, 0),
    };
    let report = aided::run(samples, &fixes, seq, &mut sink)?;
    if report.samples == 0 {
        bail!(
            "no IMU epoch between starttime {} s and endtime {} s in {}",
            t_start,
            t_end,
            c.imu_path.display()
        );
    }
    if report.start_s.is_none() {
        // Epochs in the window, none navigated: not "no epoch".
        bail!(
            "{}: {}",
            c.imu_path.display(),
            aided::no_usable_sample(&report)
        );
    }
    // A wrong `imudatarate` marks every epoch a gap (or none): refused before the
    // trajectory is written.
    if intervals > 0 && off_rate * 10 > intervals {
        bail!(
            "imudatarate {} Hz does not match {}: {off_rate} of its {intervals} epoch intervals \
             differ from {} s by more than a quarter",
            Number(c.imu_rate_hz),
            c.imu_path.display(),
            Number(nominal_dt)
        );
    }
    let sigma_rms = sink.sigma_rms();
    let (rows, store_s) = sink.writer.finish_timed()?;
    Ok(KfGinsRun {
        report,
        rows,
        out,
        warnings,
        outside_window,
        store_s,
        sigma_rms,
    })
}
