//! `nav kf-gins CONFIG.yaml`: a KF-GINS configuration run as it is — its IMU and GNSS text
//! files, its start (`initpos`, `initvel`, `initatt`, `init*std`), its noise (`imunoise`) and
//! antenna lever arm — through this project's filter, writing KF-GINS's 11-column `.nav`
//! trajectory, one row per IMU epoch after the start (an epoch at `starttime` is the start's,
//! as in KF-GINS: not integrated, no row), in `f64`. Where it differs from KF-GINS: a
//! 13-column GNSS file's velocities are used too (KF-GINS's loader reads and drops them; a
//! velocity in other axes shows as refused velocity fixes and a warning), and the filter's
//! zero-velocity updates at stops stay on unless `--no-stops` ([`run_with`]).
//!
//! On request ([`Outputs`]) also KF-GINS's two other files, one row per `.nav` row, in its
//! units (`kf_gins.cpp` `writeNavResult`, `writeSTD`):
//! - the IMU errors (`KF_GINS_IMU_ERR.txt`, 13 columns): time [s], gyro biases [deg/h],
//!   accelerometer biases [mGal], gyro and accelerometer scale factors [ppm], as compensated
//!   (KF-GINS's signs: the bias is subtracted, the scale factor divides);
//! - the 1-sigma (`KF_GINS_STD.txt`, 22 columns): time [s], position north, east, down [m]
//!   (the reported covariance: the filter's own plus the doubt of its integrity tests),
//!   velocity north, east, down [m/s], attitude [deg], then the same four sensor errors in the
//!   same units. The attitude columns are the 1-sigma of the `.nav`'s roll, pitch and yaw
//!   (KF-GINS writes its misalignment angles' about north, east, down; for a level vehicle
//!   heading north they are the same, and the yaw is the down one in any heading).

use crate::aided::{self, AidedReport, AidedSample, AidedSink};
use crate::aided_cmd::{AidedStart, GivenStart, sequencer};
use crate::gnss::{self, GnssFix};
use crate::kf_gins::ImuReader;
use crate::kf_gins_config::{self, KfGinsConfig};
use crate::nav_writer::{NavRow, NavWriter};
use crate::text_error::seconds_to_ns;
use crate::text_recording::{RATE_PREFIX_RECORDS, rate_from_times};
use anyhow::{Context, Result, bail};
use nav_core::attitude::euler;
use nav_core::ins_filter::model::FilterNoise;
use nav_core::ins_filter::{ATT, AidedIns, BA, BG, FilterConfig, POS, SA, SG, SensorErrors, VEL};
use nav_core::number::Number;
use nav_core::{ImuIncrement, Vector3};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// The name KF-GINS gives its trajectory in `outputpath`.
pub const KF_GINS_NAV_NAME: &str = "KF_GINS_Navresult.nav";

/// The name KF-GINS gives its IMU error file in `outputpath`.
pub const KF_GINS_IMU_ERR_NAME: &str = "KF_GINS_IMU_ERR.txt";

/// The name KF-GINS gives its 1-sigma file in `outputpath`.
pub const KF_GINS_STD_NAME: &str = "KF_GINS_STD.txt";

/// Relative difference between `imudatarate` and the file's median epoch interval beyond which
/// it is warned of: 0.1 %, ten times an IMU clock's crystal error (100 ppm), so that a rate the
/// file does not have is said (`imudatarate: 401` for a 400 Hz file ran silently) and a clock's
/// own error is not.
pub const RATE_TOLERANCE: f64 = 1e-3;

/// The files a run writes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outputs {
    /// The trajectory; `None`: KF-GINS's `outputpath/KF_GINS_Navresult.nav`.
    pub nav: Option<PathBuf>,
    /// The IMU errors, if wanted.
    pub imu_err: Option<PathBuf>,
    /// The 1-sigma, if wanted.
    pub std: Option<PathBuf>,
}

/// What a KF-GINS run did.
#[derive(Clone, Debug, PartialEq)]
pub struct KfGinsRun {
    /// The aided run's report.
    pub report: AidedReport,
    /// Rows written.
    pub rows: u64,
    /// The trajectory written.
    pub out: PathBuf,
    /// The IMU error file written, as asked.
    pub imu_err: Option<PathBuf>,
    /// The 1-sigma file written, as asked.
    pub std: Option<PathBuf>,
    /// The configuration's warnings (keys not used).
    pub warnings: Vec<String>,
    /// IMU rows skipped before `starttime`.
    pub before_start: u64,
    /// The time of the first IMU row after `endtime` [s], where the run stopped reading the
    /// file (the rows from it on are not read, so not counted); `None`: read to its end.
    pub stopped_after_end_s: Option<f64>,
    /// Time spent storing the files once written, syncing them to the disk and renaming
    /// them into place [s]: a wait on the disk, not processing (KF-GINS does not sync its
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

/// Refuses a start whose first IMU epoch at or after `starttime` `t_start_s` [s] is
/// `start_epoch_s` [s], more than an interval and a half `dt_s` [s] later (within half an
/// interval it is the start's epoch; within one and a half its increment spans the interval
/// from `starttime`); `before_start` epochs came before `starttime`. `initpos`, `initvel`
/// and `initatt` hold at `starttime`, and KF-GINS would take them at that later epoch
/// whatever the vehicle did in between (it refuses a `starttime` before the file's first
/// epoch, "Process time ERROR", not a gap in the file across it): a file that began 50 s
/// late was navigated from the state of 50 s before, without a word.
pub fn check_start_epoch(
    t_start_s: f64,
    start_epoch_s: f64,
    dt_s: f64,
    before_start: u64,
) -> Result<()> {
    let late = start_epoch_s - t_start_s;
    if late <= 1.5 * dt_s {
        return Ok(());
    }
    let gap = if before_start == 0 {
        "the IMU file begins"
    } else {
        "the IMU file has no epoch from it until"
    };
    bail!(
        "starttime {} s: {gap} {} s later, at {} s, and initpos, initvel and initatt hold at \
         starttime (the vehicle may have moved since); set starttime to an epoch of the file \
         whose state they are",
        Number(t_start_s),
        Number((late * 1e6).round() / 1e6),
        Number(start_epoch_s)
    )
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
    // KF-GINS has no stop detector; the filter's ZUPT stays on unless `run_with` turns it off:
    // its gate does not refuse a wrong one (a vehicle creeping straight at 0.5 m/s looks still
    // to the IMU, and its fixes were refused instead: 1 km off after 300 s).
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
        sensor_sigma: Some(SensorErrors {
            gyro_bias_rad_s: v(c.init_gyro_bias_std_rad_s),
            accel_bias_mps2: v(c.init_accel_bias_std_m_s2),
            gyro_scale: v(c.init_gyro_scale_std),
            accel_scale: v(c.init_accel_scale_std),
        }),
    }
}

/// Every filter sample as a `.nav` row (and the IMU error and 1-sigma rows, when asked for),
/// and the sums of [`SigmaRms`].
struct NavRows {
    writer: NavWriter,
    imu_err: Option<NavWriter>,
    std: Option<NavWriter>,
    /// Sums of the horizontal position variance [m^2] and the heading's [rad^2], and rows.
    variance_sums: (f64, f64, u64),
}

/// rad/s -> deg/h.
const DEG_H_PER_RAD_S: f64 = 180.0 / core::f64::consts::PI * 3600.0;
/// m/s^2 -> mGal.
const MGAL_PER_M_S2: f64 = 1e5;
/// [-] -> ppm.
const PPM: f64 = 1e6;

/// The 12 sensor-error fields of KF-GINS's files in its units: gyro biases [deg/h],
/// accelerometer biases [mGal], gyro and accelerometer scale factors [ppm].
pub(crate) fn sensor_fields(
    gb: &Vector3<f64>,
    ab: &Vector3<f64>,
    gs: &Vector3<f64>,
    sa: &Vector3<f64>,
) -> [f64; 12] {
    let mut out = [0.0; 12];
    for k in 0..3 {
        out[k] = gb[k] * DEG_H_PER_RAD_S;
        out[3 + k] = ab[k] * MGAL_PER_M_S2;
        out[6 + k] = gs[k] * PPM;
        out[9 + k] = sa[k] * PPM;
    }
    out
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
        let t_s = t_us as f64 * 1e-6;
        if let Some(w) = &mut self.imu_err {
            let e = ins.sensor_errors();
            let f = sensor_fields(
                &e.gyro_bias_rad_s,
                &e.accel_bias_mps2,
                &e.gyro_scale,
                &e.accel_scale,
            );
            let mut row = [0.0; 13];
            row[0] = t_s;
            row[1..].copy_from_slice(&f);
            w.write_fields(&row)?;
        }
        if let Some(w) = &mut self.std {
            let sigma = |at| ins.sigma(at);
            let f = sensor_fields(&sigma(BG), &sigma(BA), &sigma(SG), &sigma(SA));
            let (pos, vel) = (sigma(POS), sigma(VEL));
            let att = ins.attitude_sigma_rad();
            let mut row = [0.0; 22];
            row[0] = t_s;
            for k in 0..3 {
                row[1 + k] = pos[k];
                row[4 + k] = vel[k];
                row[7 + k] = att[k].to_degrees();
            }
            row[10..].copy_from_slice(&f);
            w.write_fields(&row)?;
        }
        Ok(())
    }
}

/// Runs the configuration at `config_path`; the trajectory goes to `outputs.nav`, or to
/// KF-GINS's `outputpath/KF_GINS_Navresult.nav`, and the IMU error and 1-sigma files where
/// `outputs` asks.
pub fn run(config_path: &Path, outputs: &Outputs) -> Result<KfGinsRun> {
    run_with(config_path, outputs, true)
}

/// [`run`], with the filter's zero-velocity and zero-rate updates at stops (`stops`) or
/// without them, as KF-GINS (`nav kf-gins --no-stops`: a vehicle that may move steadily below
/// the 1 m/s a stop is believed at).
pub fn run_with(config_path: &Path, outputs: &Outputs, stops: bool) -> Result<KfGinsRun> {
    let (c, mut warnings) = kf_gins_config::load(config_path)?;
    let out = outputs
        .nav
        .clone()
        .unwrap_or_else(|| c.output_dir.join(KF_GINS_NAV_NAME));
    // The relative paths are looked for in two folders (kf_gins_config's module docs): the
    // files the run reads, as found.
    eprintln!(
        "KF-GINS files: imupath {}, gnsspath {}, trajectory {}",
        c.imu_path.display(),
        c.gnss_path.display(),
        out.display()
    );
    let named = [
        Some(("the trajectory (--out)", out.as_path())),
        outputs.imu_err.as_deref().map(|p| ("--imu-err", p)),
        outputs.std.as_deref().map(|p| ("--std", p)),
    ];
    let named: Vec<(&str, &Path)> = named.into_iter().flatten().collect();
    for (name, path) in &named {
        crate::atomic::refuse_same_file(&[config_path, &c.imu_path, &c.gnss_path], path)?;
        // Before the run, not after it: the folder each file goes to.
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty())
            && !dir.is_dir()
        {
            let what = if dir.exists() {
                "is not a folder"
            } else {
                "does not exist"
            };
            bail!(
                "the output folder {} of {name} {what} (outputpath, or the option's folder)",
                dir.display()
            );
        }
    }
    crate::atomic::refuse_shared_outputs(&named)?;
    crate::gnss_file::refuse_the_imu_recording(&c.gnss_path, &c.imu_path)
        .context("gnsspath and imupath")?;
    let fixes: Vec<GnssFix> = gnss::read_gnss(&c.gnss_path).map_err(|e| {
        let label = format!("GNSS file {} (gnsspath)", c.gnss_path.display());
        crate::text_error::told_as(e, &c.gnss_path, label)
    })?;
    let mut config = filter_config(&c);
    if !stops {
        config.zero_motion = None;
    }
    let seq = sequencer::<f64>(&config, &AidedStart::Given(Box::new(start(&c))))?;
    crate::text_error::refuse_a_stream(&c.imu_path)
        .map_err(|e| anyhow::anyhow!("IMU file (imupath) {e}"))?;
    let mut file = File::open(&c.imu_path)
        .with_context(|| format!("IMU file {} (imupath)", c.imu_path.display()))?;
    // A binary recording read as text failed with "line 1: expected 7 numbers ..., found 1".
    let mut magic = [0_u8; 6];
    if std::io::Read::read_exact(&mut file, &mut magic).is_ok()
        && magic == hal_adapters::recording::MAGIC[..6]
    {
        bail!(
            "IMU file {} (imupath): a binary IMU recording (it starts with the NAVIMU magic of \
             docs/recording-format.md), not KF-GINS's IMU text: give the text file (7 or 8 \
             numbers a line), or replay the recording with nav replay",
            c.imu_path.display()
        );
    }
    std::io::Seek::rewind(&mut file)
        .with_context(|| format!("IMU file {} (imupath)", c.imu_path.display()))?;
    let mut rows = ImuReader::new(BufReader::with_capacity(1 << 20, file), &c.imu_path)
        .with_columns(c.imu_columns);
    let nominal_dt = 1.0 / c.imu_rate_hz;
    let (t_start, t_end) = (c.start_time_s, c.end_time_s.unwrap_or(f64::INFINITY));
    let mut prev_t: Option<f64> = None;
    // The last epoch's velocity increment that covered one interval.
    let mut prev_dv: Option<[f32; 3]> = None;
    let mut before_start = 0_u64;
    let mut stopped_after_end_s = None;
    // The start's epoch (the first at or after `starttime`) was read.
    let mut started = false;
    // Intervals off `imudatarate` by more than a quarter of its interval, of all intervals (a
    // rate off by a factor of 2 or 4/3 is caught; a receiver's jitter of a few percent is not).
    let (mut off_rate, mut intervals) = (0_u64, 0_u64);
    // The first epochs' times [ns], for the rate the file has (their median interval, as a
    // replay's header takes it: a gap does not lower it).
    let mut prefix_t_ns: Vec<u64> = Vec::with_capacity(RATE_PREFIX_RECORDS);
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
            if prefix_t_ns.len() < RATE_PREFIX_RECORDS
                && let Some(t_ns) = seconds_to_ns(row.t_s)
            {
                prefix_t_ns.push(t_ns);
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
            // row. That epoch is the start here too (every later epoch is integrated from
            // it); integrating it moved the whole trajectory one IMU interval ahead (6 cm at
            // 12 m/s and 200 Hz).
            if row.t_s < t_start {
                before_start += 1;
                continue;
            }
            if row.t_s > t_end {
                stopped_after_end_s = Some(row.t_s);
                return Ok(None);
            }
            if !started {
                started = true;
                if row.t_s - t_start <= 0.5 * nominal_dt {
                    continue;
                }
                // One interval after `starttime`: its increment spans the interval from it,
                // integrated from the start (a simulator's file that begins at its first
                // increment); later, refused.
                check_start_epoch(t_start, row.t_s, nominal_dt, before_start)?;
            }
            return Ok(Some(AidedSample {
                t_us: (row.t_s * 1e6).round() as u64,
                increment: ImuIncrement::new(row.delta_theta_ib_b, row.delta_v_ib_b, dt),
                unusable: short,
                // The reader refuses a time that does not increase.
                behind: false,
                gap,
                clipped: Default::default(),
            }));
        }
    };
    let create = |p: &Option<PathBuf>| p.as_deref().map(NavWriter::create).transpose();
    let mut sink = NavRows {
        writer: NavWriter::create(&out)?,
        imu_err: create(&outputs.imu_err)?,
        std: create(&outputs.std)?,
        variance_sums: (0.0, 0.0, 0),
    };
    let report = aided::run(samples, &fixes, seq, &mut sink)?;
    if report.samples == 0 {
        // KF-GINS's `endtime: -1` ("to the end") is infinite here.
        let end = if t_end.is_finite() {
            format!("endtime {} s", Number(t_end))
        } else {
            "the end of the file (endtime -1)".to_owned()
        };
        bail!(
            "no IMU epoch between starttime {} s and {end} in {}",
            Number(t_start),
            c.imu_path.display()
        );
    }
    // A wrong `imudatarate` marks every epoch a gap (or none): refused before the
    // trajectory is written, and before its flags are blamed on the data.
    if intervals > 0 && off_rate * 10 > intervals {
        bail!(
            "imudatarate {} Hz does not match {}: {off_rate} of its {intervals} epoch intervals \
             differ from {} s by more than a quarter",
            Number(c.imu_rate_hz),
            c.imu_path.display(),
            Number(nominal_dt)
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
    crate::replay::check_refused_share(report.samples, report.rejected, "in the run's window")
        .with_context(|| c.imu_path.display().to_string())?;
    crate::aided_cmd::check_some_fix_used(&report.counters)?;
    // Within that, a rate the file does not have is said: the intervals are the time
    // column's, `imudatarate` only judges them (and the first epoch's). Against the median
    // interval (the average counted a gap's time: a 7 s hole in 400 Hz data read as 353 Hz,
    // blaming imudatarate), within RATE_TOLERANCE.
    if let Ok((file_hz, _)) = rate_from_times(&prefix_t_ns)
        && (file_hz - c.imu_rate_hz).abs() > RATE_TOLERANCE * c.imu_rate_hz
    {
        warnings.push(format!(
            "imudatarate {} Hz, but the epochs of {} come every {} s ({} Hz, the median \
             interval of the first {}): the intervals are taken from its time column",
            Number(c.imu_rate_hz),
            c.imu_path.display(),
            Number(1.0 / file_hz),
            Number((file_hz * 1e3).round() / 1e3),
            prefix_t_ns.len()
        ));
    }
    let sigma_rms = sink.sigma_rms();
    let (rows, mut store_s) = sink.writer.finish_timed()?;
    for w in [sink.imu_err, sink.std].into_iter().flatten() {
        store_s += w.finish_timed()?.1;
    }
    Ok(KfGinsRun {
        report,
        rows,
        out,
        imu_err: outputs.imu_err.clone(),
        std: outputs.std.clone(),
        warnings,
        before_start,
        stopped_after_end_s,
        store_s,
        sigma_rms,
    })
}
