//! GNSS aiding's files and simulator: the GNSS fix readers and writer (project CSV, KF-GINS
//! text), KF-GINS's YAML configuration, the KF-GINS `.nav` writer and the simulated receiver.
//!
//! The rates of the `.nav` writer and of the KF-GINS IMU reader on 720 000 rows:
//! `cargo test -p host-tests --release --test gnss_io -- --ignored --nocapture`.

use host_tests::gnss::{self, GnssFix, GnssFormat, GnssVelocity};
use host_tests::gnss_sim::{self, GnssSimOptions, Injected, Outage, Outlier};
use host_tests::kf_gins::{ImuReader, NavReader};
use host_tests::kf_gins_config;
use host_tests::nav_writer::{NavRow, NavWriter};
use host_tests::trajectory::Generator;
use host_tests::trajectory::scenarios::Scenario;
use host_tests::truth::Truth;
use nav_core::attitude::{euler, from_euler};
use nav_core::earth::geodetic_to_ecef;
use nav_core::nalgebra::Matrix3;
use nav_core::{Position, Vector3};
use std::io::BufReader;
use std::path::Path;
use std::time::Instant;

/// The names in `dir`, sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn err(r: anyhow::Result<Vec<GnssFix>>) -> String {
    format!("{:#}", r.unwrap_err())
}

// ---------------------------------------------------------------------------------------------
// GNSS files.

#[test]
fn read_gnss_detects_both_formats() {
    let dir = tempfile::tempdir().unwrap();
    let kf = dir.path().join("GNSS-RTK.txt");
    std::fs::write(
        &kf,
        "# KF-GINS GNSS, 7 columns\n\
         456250.000    30.4447858054   114.4718661162     21.095    0.010    0.009    0.019 \n\
         456251.000    30.4447857891   114.4718661133     21.091    0.010    0.009    0.019 \n",
    )
    .unwrap();
    assert_eq!(gnss::detect(&kf).unwrap(), GnssFormat::KfGins);
    let fixes = gnss::read_gnss(&kf).unwrap();
    assert_eq!(fixes.len(), 2);
    assert_eq!(fixes[1].t_s, 456_251.0);
    assert_eq!(fixes[1].sigma_ned_m, [0.010, 0.009, 0.019]);

    let csv = dir.path().join("gnss.csv");
    std::fs::write(
        &csv,
        "t_s,lat_deg,lon_deg,h_m,sigma_n_m,sigma_e_m,sigma_d_m,v_n_m_s,v_e_m_s,v_d_m_s,sigma_vn_m_s,sigma_ve_m_s,sigma_vd_m_s\n\
         1,45,7.5,250,0.5,0.5,1,,,,,,\n\
         2,45.00001,7.5,250,0.5,0.5,1,1.1,0,0,0.05,0.05,0.1\n",
    )
    .unwrap();
    assert_eq!(gnss::detect(&csv).unwrap(), GnssFormat::Csv);
    let fixes = gnss::read_gnss(&csv).unwrap();
    assert_eq!(fixes[0].velocity, None);
    assert_eq!(
        fixes[1].velocity,
        Some(GnssVelocity {
            v_ned_m_s: [1.1, 0.0, 0.0],
            sigma_ned_m_s: [0.05, 0.05, 0.1]
        })
    );
    assert_eq!(fixes[1].lat_rad, 45.00001_f64.to_radians());
    // `#` comment lines before the header and between rows are skipped: the same fixes.
    let commented = dir.path().join("commented.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let (head, rows) = text.split_once('\n').unwrap();
    let (first, second) = rows.split_once('\n').unwrap();
    std::fs::write(
        &commented,
        format!("# receiver X, antenna on the roof\n{head}\n{first}\n# restarted\n{second}"),
    )
    .unwrap();
    assert_eq!(gnss::detect(&commented).unwrap(), GnssFormat::Csv);
    assert_eq!(gnss::read_gnss(&commented).unwrap(), fixes);
}

#[test]
fn bad_gnss_files_name_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let header = "t_s,lat_deg,lon_deg,h_m,sigma_n_m,sigma_e_m,sigma_d_m";
    let cases = [
        ("empty.txt", "", "empty.txt: no data"),
        (
            "header.csv",
            &format!("{header}\n") as &str,
            "header.csv: no data",
        ),
        (
            "cut.csv",
            &format!("{header}\n1,45,7.5,250,0.5,0.5,1.25\n2,45,7.5,250,0.5,0.5,1."),
            "cut.csv: truncated: last line 3",
        ),
        (
            "count.txt",
            "1 45 7.5 250 0.5 0.5 1 2\n",
            "count.txt: line 1: expected 7 numbers",
        ),
        (
            "nan_time.txt",
            "1 45 7.5 250 0.5 0.5 1\nnan 45 7.5 250 0.5 0.5 1\n",
            "nan_time.txt: line 2: column seconds of week: expected a finite number",
        ),
        (
            "word.csv",
            &format!("{header}\n2,45,7.5,high,0.5,0.5,1\n"),
            "word.csv: line 2: column h_m: expected a number, found 'high'",
        ),
        // Comment lines count in the line numbers.
        (
            "comment.csv",
            &format!("# a receiver\n{header}\n# a comment\n2,45,7.5,high,0.5,0.5,1\n"),
            "comment.csv: line 4: column h_m: expected a number, found 'high'",
        ),
    ];
    for (name, text, expected) in cases {
        let m = err(gnss::read_gnss(&write(name, text)));
        assert!(m.contains(expected), "{expected}: {m}");
    }
    // Bad values are kept for the filter: NaN position, zero and negative sigmas.
    let fixes = gnss::read_gnss(&write(
        "values.txt",
        "1 nan nan nan 0 -1 inf\n2 45 7.5 250 0.5 0.5 1\n",
    ))
    .unwrap();
    assert!(fixes[0].h_m.is_nan() && fixes[0].sigma_ned_m[2].is_infinite());
    // So are a repeated epoch and one back in time: the navigator skips and counts them.
    let times = |name, text: &str| -> Vec<f64> {
        let fixes = gnss::read_gnss(&write(name, text)).unwrap();
        fixes.iter().map(|f| f.t_s).collect()
    };
    assert_eq!(
        times(
            "back.csv",
            &format!("{header}\n2,45,7.5,250,0.5,0.5,1\n1.5,45,7.5,250,0.5,0.5,1\n")
        ),
        [2.0, 1.5]
    );
    assert_eq!(
        times(
            "again.txt",
            "1 45 7.5 250 0.5 0.5 1\n1 45 7.5 250 0.5 0.5 1\n"
        ),
        [1.0, 1.0]
    );
}

#[test]
fn gnss_csv_round_trips_through_a_file() {
    let dir = tempfile::tempdir().unwrap();
    let truth = land_vehicle(60.0);
    let options = GnssSimOptions {
        rate_hz: 5.0,
        sigma_ned_m: [0.3, 0.4, 0.9],
        sigma_v_ned_m_s: Some([0.05, 0.05, 0.1]),
        lever_arm_b_m: [1.2, -0.4, -1.5],
        outliers: vec![Outlier::NaN { t_s: 30.0 }],
        ..GnssSimOptions::default()
    };
    let sim = gnss_sim::simulate(&truth, &options).unwrap();
    let path = dir.path().join("gnss.csv");
    gnss::write_gnss_csv(&path, &sim.fixes).unwrap();
    assert_eq!(names(dir.path()), ["gnss.csv"]);
    let back = gnss::read_gnss(&path).unwrap();
    assert_eq!(back.len(), sim.fixes.len());
    for (a, b) in sim.fixes.iter().zip(&back) {
        assert_eq!(a.t_s.to_bits(), b.t_s.to_bits());
        assert_eq!(a.h_m.to_bits(), b.h_m.to_bits());
        assert_eq!(a.sigma_ned_m, b.sigma_ned_m);
        if a.lat_rad.is_nan() {
            assert!(b.lat_rad.is_nan() && b.lon_rad.is_nan() && b.h_m.is_nan());
            continue;
        }
        assert_eq!(a.velocity, b.velocity);
        // One deg <-> rad rounding each way.
        assert!((a.lat_rad - b.lat_rad).abs() <= 2.0 * f64::EPSILON * a.lat_rad.abs());
        assert!((a.lon_rad - b.lon_rad).abs() <= 2.0 * f64::EPSILON * a.lon_rad.abs());
    }
}

// ---------------------------------------------------------------------------------------------
// KF-GINS configuration.

/// A configuration as KF-GINS's `dataset/kf-gins.yaml` is written (its comments in two
/// languages, paths relative to where KF-GINS runs), with the optional sigmas given.
const CONFIG: &str = r#"# KF-GINS configuration file
# IMU和GNSS数据文件路径
# imudata and gnssdata filepath
imupath: "imu.txt"
gnsspath: "gnss.txt"
outputpath: "out"
imudatalen: 8
imudatarate: 100
starttime: 1000
endtime: 2000.5
initpos: [ 45.0, 7.5, 250.0 ]
initvel: [ 1.0, -2.0, 0.5 ]
initatt: [ 1.0, -2.0, 270.0 ]
initgyrbias: [ 3600, 0, -36 ]    # [deg/h]
initaccbias: [ 1000, 0, 0 ]    # [mGal]
initgyrscale: [ 100, 0, 0 ]   # [ppm]
initaccscale: [ 0, 0, 50 ]   # [ppm]
initposstd: [ 0.5, 0.5, 1.0 ]
initvelstd: [ 0.1, 0.1, 0.1 ]
initattstd: [ 0.5, 0.5, 2.0 ]
initbgstd: [ 10, 10, 10 ]          # [deg/h]
initbastd: [ 500, 500, 500 ]       # [mGal]
initsgstd: [ 1000, 1000, 1000 ]    # [ppm]
initsastd: [ 2000, 2000, 2000 ]    # [ppm]
imunoise:
  arw: [0.24, 0.24, 0.24]          # [deg/sqrt(hr)]
  vrw: [0.24, 0.24, 0.24]          # [m/s/sqrt(hr)]
  gbstd: [50.0, 50.0, 50.0]        # [deg/hr]
  abstd: [250.0, 250.0, 250.0]     # [mGal]
  gsstd: [1000.0, 1000.0, 1000.0]  # [ppm]
  asstd: [1000.0, 1000.0, 1000.0]  # [ppm]
  corrtime: 1.0                    # [hr]
  odonoise: 0.1
antlever: [ 0.136, -0.301, -0.184 ]
"#;

#[test]
fn kf_gins_config_from_a_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("imu.txt"), "").unwrap();
    std::fs::write(dir.path().join("gnss.txt"), "").unwrap();
    std::fs::create_dir(dir.path().join("out")).unwrap();
    let path = dir.path().join("kf-gins.yaml");
    std::fs::write(&path, CONFIG).unwrap();
    let (c, warnings) = kf_gins_config::load(&path).unwrap();
    // Found beside the configuration (the tests do not run in `dir`).
    assert_eq!(c.imu_path, dir.path().join("imu.txt"));
    assert_eq!(c.gnss_path, dir.path().join("gnss.txt"));
    assert_eq!(c.output_dir, dir.path().join("out"));
    assert_eq!((c.imu_columns, c.imu_rate_hz), (8, 100.0));
    assert_eq!((c.start_time_s, c.end_time_s), (1000.0, Some(2000.5)));
    let deg = std::f64::consts::PI / 180.0;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs();
    assert!(close(c.init_lat_rad, 45.0 * deg) && c.init_h_m == 250.0);
    assert_eq!(c.init_v_eb_n_m_s, [1.0, -2.0, 0.5]);
    assert!(close(c.init_euler_rad[2], 270.0 * deg));
    // 3600 deg/h = 1 deg/s; 1000 mGal = 0.01 m/s^2; 100 ppm = 1e-4.
    assert!(close(c.init_gyro_bias_rad_s[0], deg));
    assert!(close(c.init_gyro_bias_rad_s[2], -0.01 * deg));
    assert!(close(c.init_accel_bias_m_s2[0], 0.01));
    assert!(close(c.init_gyro_scale[0], 1e-4) && close(c.init_accel_scale[2], 5e-5));
    assert!(close(c.init_att_std_rad[2], 2.0 * deg));
    assert!(close(c.init_gyro_bias_std_rad_s[0], 10.0 * deg / 3600.0));
    assert!(close(c.init_accel_bias_std_m_s2[1], 500e-5));
    assert!(close(c.init_gyro_scale_std[2], 1e-3) && close(c.init_accel_scale_std[0], 2e-3));
    let n = &c.imu_noise;
    // 0.24 deg/sqrt(h) = 0.24 deg / 60 per sqrt(s).
    assert!(close(n.arw_rad_sqrt_s[0], 0.24 * deg / 60.0));
    assert!(close(n.vrw_m_s_sqrt_s[2], 0.004));
    assert!(close(n.gyro_bias_std_rad_s[1], 50.0 * deg / 3600.0));
    assert!(close(n.accel_bias_std_m_s2[0], 250e-5));
    assert!(close(n.gyro_scale_std[0], 1e-3) && close(n.accel_scale_std[0], 1e-3));
    assert_eq!(n.corr_time_s, 3600.0);
    assert_eq!(c.lever_arm_b_m, [0.136, -0.301, -0.184]);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(
        warnings[0].contains("'imunoise.odonoise' ignored"),
        "{warnings:?}"
    );
    // A bad value names the file and the key.
    std::fs::write(
        &path,
        CONFIG.replace("initposstd: [ 0.5,", "initposstd: [ -0.5,"),
    )
    .unwrap();
    let m = format!("{:#}", kf_gins_config::load(&path).unwrap_err());
    assert!(m.contains("kf-gins.yaml: key 'initposstd': value 1"), "{m}");
}

// ---------------------------------------------------------------------------------------------
// The .nav writer.

fn nav_row(k: usize) -> NavRow {
    let t = k as f64 * 0.005;
    NavRow {
        t_s: 456_300.0 + t,
        lat_rad: (30.444_787_370_1 + 1e-7 * t).to_radians(),
        lon_rad: (114.471_863_204_7 - 3e-7 * t).to_radians(),
        h_m: 20.899 + 0.01 * t,
        v_eb_n_m_s: [0.01 * t, -12.5 + 1e-3 * t, 0.0001],
        euler_rad: [
            (0.854 + 1e-3 * t).to_radians(),
            (-2.034 + 1e-3 * t).to_radians(),
            (-174.3 + 0.1 * t).to_radians(),
        ],
    }
}

#[test]
fn nav_files_read_back_to_their_precision() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("KF_GINS_Navresult.nav");
    let rows: Vec<NavRow> = (0..2000).map(nav_row).collect();
    let mut w = NavWriter::create(&path).unwrap();
    for r in &rows {
        w.write_row(r).unwrap();
    }
    // Nothing at the path until finish.
    assert!(!path.exists());
    assert_eq!(w.finish().unwrap(), 2000);
    let text = std::fs::read_to_string(&path).unwrap();
    let first = text.lines().next().unwrap();
    assert!(
        first
            .starts_with("0.000000000     456300.000000000 30.444787370    114.471863205   20.899"),
        "{first}"
    );
    // Yaw in [0, 360) as KF-GINS writes it; every line ends with a blank.
    assert!(first.ends_with("185.700000000   "), "{first}");
    let back: Vec<Truth> =
        NavReader::new(BufReader::new(std::fs::File::open(&path).unwrap()), &path)
            .collect::<Result<_, _>>()
            .unwrap();
    assert_eq!(back.len(), rows.len());
    // Nine decimals: half a unit of 1e-9 (plus the parsing's rounding).
    let half = 0.5e-9 * (1.0 + 1e-6);
    for (r, b) in rows.iter().zip(&back) {
        assert!((r.t_s - b.t_s).abs() <= half);
        assert!((r.lat_rad.to_degrees() - b.lat.to_degrees()).abs() <= half);
        assert!((r.lon_rad.to_degrees() - b.lon.to_degrees()).abs() <= half);
        assert!((r.h_m - b.h).abs() <= half);
        for j in 0..3 {
            assert!((r.v_eb_n_m_s[j] - b.v_eb_ned[j]).abs() <= half);
        }
        let (roll, pitch, yaw) = euler(&b.q_b_ned);
        let d_yaw = (r.euler_rad[2] - yaw).rem_euclid(std::f64::consts::TAU);
        let d_yaw = d_yaw.min(std::f64::consts::TAU - d_yaw);
        // Through the quaternion: a few 1e-15 rad more.
        for d in [r.euler_rad[0] - roll, r.euler_rad[1] - pitch, d_yaw] {
            assert!(d.abs().to_degrees() <= half + 1e-12, "{d}");
        }
    }
}

#[test]
fn an_unfinished_nav_writer_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.nav");
    std::fs::write(&path, "an older result\n").unwrap();
    {
        let mut w = NavWriter::create(&path).unwrap();
        w.write_truth(&Truth {
            t_s: 1.0,
            lat: 0.5,
            lon: 0.1,
            h: 10.0,
            v_eb_ned: Vector3::zeros(),
            q_b_ned: from_euler(0.0, 0.0, 0.0),
        })
        .unwrap();
        assert_eq!(w.rows(), 1);
        // Dropped: a run that failed half way.
    }
    assert_eq!(names(dir.path()), ["run.nav"]);
    assert_eq!(std::fs::read_to_string(&path).unwrap(), "an older result\n");
}

// ---------------------------------------------------------------------------------------------
// The simulated receiver.

/// `nav sim land-vehicle`'s truth for `seconds` at 50 Hz: starts, stops and turns.
fn land_vehicle(seconds: f64) -> Vec<Truth> {
    let traj = Scenario::by_name("land-vehicle").unwrap().build().unwrap();
    let mut g = Generator::new(traj.as_ref());
    let mut truth = vec![g.truth()];
    for k in 1..=(seconds * 50.0) as usize {
        truth.push(g.advance_to(k as f64 * 0.02).1);
    }
    truth
}

/// A body at rest, turning about the vertical at `rate` [rad/s] with constant roll and pitch, 50 Hz.
fn turntable(seconds: f64, rate: f64) -> Vec<Truth> {
    (0..=(seconds * 50.0) as usize)
        .map(|k| {
            let t_s = k as f64 * 0.02;
            Truth {
                t_s,
                lat: 45f64.to_radians(),
                lon: 7.5f64.to_radians(),
                h: 250.0,
                v_eb_ned: Vector3::zeros(),
                q_b_ned: from_euler(0.2, -0.1, 0.3 + rate * t_s),
            }
        })
        .collect()
}

/// `C_n_e` at `lat`, `lon` [rad] (Groves eq. 2.150), written out here for the independent check.
#[rustfmt::skip]
fn c_n_e(lat: f64, lon: f64) -> Matrix3<f64> {
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    Matrix3::new(
        -sl * co, -so, -cl * co,
        -sl * so,  co, -cl * so,
         cl,      0.0, -sl,
    )
}

/// ECEF position [m] of the antenna `l_b` [m] from `truth`, computed independently of the
/// simulator (no local radii, no fixed point).
fn antenna_ecef(truth: &Truth, l_b: &Vector3<f64>) -> Vector3<f64> {
    geodetic_to_ecef(truth.lat, truth.lon, truth.h)
        + c_n_e(truth.lat, truth.lon) * (truth.q_b_ned * l_b)
}

/// Mean and sample standard deviation.
fn mean_std(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, var.sqrt())
}

#[test]
fn noise_has_the_stated_mean_and_sigma() {
    let truth = turntable(2000.0, 0.0);
    let options = GnssSimOptions {
        rate_hz: 10.0,
        sigma_ned_m: [1.0, 2.0, 3.0],
        sigma_v_ned_m_s: Some([0.1, 0.2, 0.3]),
        seed: 42,
        ..GnssSimOptions::default()
    };
    let sim = gnss_sim::simulate(&truth, &options).unwrap();
    let n = sim.fixes.len();
    assert_eq!(n, 20_001);
    let mut e_pos = [vec![], vec![], vec![]];
    let mut e_vel = [vec![], vec![], vec![]];
    for (f, &k) in sim.fixes.iter().zip(&sim.truth_rows) {
        assert_eq!(f.t_s, truth[k].t_s);
        // The reported sigmas are the simulation's.
        assert_eq!(f.sigma_ned_m, options.sigma_ned_m);
        let v = f.velocity.unwrap();
        assert_eq!(Some(v.sigma_ned_m_s), options.sigma_v_ned_m_s);
        let t = &truth[k];
        let d = Position::from_radians(t.lat, t.lon, t.h)
            .ned_to(&Position::from_radians(f.lat_rad, f.lon_rad, f.h_m));
        for j in 0..3 {
            e_pos[j].push(d[j]);
            e_vel[j].push(v.v_ned_m_s[j] - t.v_eb_ned[j]);
        }
    }
    // Mean within 4 sigma / sqrt(n); sample sigma within 4 sigma / sqrt(2 n) (chi-square).
    let sqrt_n = (n as f64).sqrt();
    let sigma_v = options.sigma_v_ned_m_s.unwrap();
    let sigmas = options.sigma_ned_m.iter().chain(&sigma_v);
    for (e, &sigma) in e_pos.iter().chain(&e_vel).zip(sigmas) {
        let (mean, std) = mean_std(e);
        assert!(
            mean.abs() < 4.0 * sigma / sqrt_n,
            "mean {mean} for sigma {sigma}"
        );
        assert!(
            (std - sigma).abs() < 4.0 * sigma / (2.0_f64.sqrt() * sqrt_n),
            "std {std} for sigma {sigma}"
        );
    }
    // Axes independent: correlation within 4 / sqrt(n).
    let corr = |a: &[f64], b: &[f64]| {
        let ((ma, sa), (mb, sb)) = (mean_std(a), mean_std(b));
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - ma) * (y - mb))
            .sum::<f64>()
            / ((n - 1) as f64 * sa * sb)
    };
    for (a, b) in [(0, 1), (1, 2), (0, 2)] {
        assert!(corr(&e_pos[a], &e_pos[b]).abs() < 4.0 / sqrt_n);
        assert!(corr(&e_pos[a], &e_vel[a]).abs() < 4.0 / sqrt_n);
    }
}

#[test]
fn lever_arm_matches_the_rigid_body_kinematics() {
    let l = [1.5, -0.7, -1.2];
    let l_b = Vector3::from(l);
    let noiseless = |truth: &[Truth]| {
        let options = GnssSimOptions {
            rate_hz: 10.0,
            // Practically noiseless (a zero 1-sigma is refused: the filter could not use it).
            sigma_ned_m: [1e-12; 3],
            sigma_v_ned_m_s: Some([1e-12; 3]),
            lever_arm_b_m: l,
            ..GnssSimOptions::default()
        };
        gnss_sim::simulate(truth, &options).unwrap()
    };

    // A turntable: the antenna circles, v = rate z x (C_b_n l).
    let rate = 0.5;
    let truth = turntable(30.0, rate);
    let sim = noiseless(&truth);
    for (f, &k) in sim.fixes.iter().zip(&sim.truth_rows) {
        let t = &truth[k];
        let l_n = t.q_b_ned * l_b;
        let d = Position::from_radians(t.lat, t.lon, t.h)
            .ned_to(&Position::from_radians(f.lat_rad, f.lon_rad, f.h_m));
        for j in 0..3 {
            assert!((d[j] - l_n[j]).abs() < 1e-6, "{d:?} {l_n}");
        }
        let v_expected = Vector3::new(0.0, 0.0, rate).cross(&l_n);
        let v = Vector3::from(f.velocity.unwrap().v_ned_m_s);
        assert!((v - v_expected).norm() < 1e-9, "{v} {v_expected}");
    }

    // A car: position and velocity against ECEF positions of the antenna and their central
    // difference (0.02 s apart), resolved in NED.
    let truth = land_vehicle(120.0);
    let sim = noiseless(&truth);
    let mut largest_lever_term = 0.0_f64;
    for (f, &k) in sim.fixes.iter().zip(&sim.truth_rows) {
        let t = &truth[k];
        let r_fix = geodetic_to_ecef(f.lat_rad, f.lon_rad, f.h_m);
        assert!((r_fix - antenna_ecef(t, &l_b)).norm() < 1e-6);
        if k == 0 || k + 1 == truth.len() {
            continue;
        }
        let (a, b) = (&truth[k - 1], &truth[k + 1]);
        let v_e = (antenna_ecef(b, &l_b) - antenna_ecef(a, &l_b)) / (b.t_s - a.t_s);
        let v_expected = c_n_e(t.lat, t.lon).transpose() * v_e;
        let v = Vector3::from(f.velocity.unwrap().v_ned_m_s);
        assert!(
            (v - v_expected).norm() < 2e-3,
            "t {} s: {v} {v_expected}",
            t.t_s
        );
        largest_lever_term = largest_lever_term.max((v - t.v_eb_ned).norm());
    }
    // The check is not trivial: the car turns, the lever-arm term is large.
    assert!(largest_lever_term > 0.1, "{largest_lever_term}");
}

#[test]
fn outages_leave_gaps() {
    let truth = turntable(1000.0, 0.0);
    let options = GnssSimOptions {
        outages: Outage::every(180.0, 60.0, 120.0, 1000.0),
        ..GnssSimOptions::default()
    };
    assert_eq!(options.outages.len(), 5);
    let sim = gnss_sim::simulate(&truth, &options).unwrap();
    assert_eq!(sim.dropped, 5 * 60);
    assert_eq!(sim.fixes.len(), 1001 - 5 * 60);
    let gaps: Vec<(f64, f64)> = sim
        .fixes
        .windows(2)
        .filter(|w| w[1].t_s - w[0].t_s > 1.5)
        .map(|w| (w[0].t_s, w[1].t_s))
        .collect();
    let expected: Vec<(f64, f64)> = (0..5)
        .map(|k| (119.0 + 180.0 * k as f64, 180.0 + 180.0 * k as f64))
        .collect();
    assert_eq!(gaps.len(), expected.len());
    for (g, e) in gaps.iter().zip(&expected) {
        assert!(
            (g.0 - e.0).abs() < 1e-9 && (g.1 - e.1).abs() < 1e-9,
            "{gaps:?}"
        );
    }
    assert!(
        sim.fixes
            .iter()
            .all(|f| !options.outages.iter().any(|o| o.contains(f.t_s)))
    );
}

#[test]
fn each_outlier_is_at_its_time_and_the_noise_elsewhere_is_unchanged() {
    let truth = turntable(300.0, 0.0);
    let base = GnssSimOptions {
        rate_hz: 1.0,
        sigma_ned_m: [0.5, 0.5, 1.0],
        sigma_v_ned_m_s: Some([0.1, 0.1, 0.2]),
        seed: 7,
        ..GnssSimOptions::default()
    };
    let options = GnssSimOptions {
        outliers: vec![
            Outlier::Jump {
                t_s: 50.0,
                length_s: 10.0,
                offset_ned_m: [20.0, 0.0, 0.0],
            },
            Outlier::Spike {
                t_s: 99.5,
                offset_ned_m: [0.0, -30.0, 5.0],
            },
            Outlier::Ramp {
                start_s: 150.0,
                length_s: 20.0,
                final_offset_ned_m: [0.0, 0.0, -40.0],
            },
            Outlier::NaN { t_s: 200.0 },
            // In an outage: reaches no fix.
            Outlier::Spike {
                t_s: 250.0,
                offset_ned_m: [100.0, 0.0, 0.0],
            },
        ],
        outages: vec![Outage {
            start_s: 245.0,
            length_s: 10.0,
        }],
        ..base.clone()
    };
    let clean = gnss_sim::simulate(&truth, &base).unwrap();
    let sim = gnss_sim::simulate(&truth, &options).unwrap();
    assert_eq!(sim.missed_outliers, [4]);
    let clean_at = |t_s: f64| clean.fixes.iter().find(|f| f.t_s == t_s).unwrap();
    let mut expected_by_time = Vec::new();
    for f in &sim.fixes {
        let c = clean_at(f.t_s);
        let t = f.t_s;
        let expected = if (50.0..60.0).contains(&t) {
            Some([20.0, 0.0, 0.0])
        } else if t == 100.0 {
            Some([0.0, -30.0, 5.0])
        } else if (150.0..170.0).contains(&t) {
            Some([0.0, 0.0, -40.0 * (t - 150.0) / 20.0])
        } else {
            None
        };
        if t == 200.0 {
            assert!(f.lat_rad.is_nan() && f.lon_rad.is_nan() && f.h_m.is_nan());
            assert!(f.velocity.unwrap().v_ned_m_s[0].is_nan());
            assert_eq!(f.sigma_ned_m, base.sigma_ned_m);
            expected_by_time.push((t, None));
            continue;
        }
        // Position offset from the clean run (same noise), velocity and sigmas unchanged.
        let d = Position::from_radians(c.lat_rad, c.lon_rad, c.h_m)
            .ned_to(&Position::from_radians(f.lat_rad, f.lon_rad, f.h_m));
        let e = expected.unwrap_or([0.0; 3]);
        for j in 0..3 {
            assert!((d[j] - e[j]).abs() < 1e-3, "t {t}: {d:?} {e:?}");
        }
        assert_eq!(f.velocity, c.velocity);
        assert_eq!(f.sigma_ned_m, c.sigma_ned_m);
        if expected.is_some() {
            expected_by_time.push((t, expected));
        }
    }
    // The description lists exactly those fixes.
    let listed: Vec<(f64, Option<[f64; 3]>)> = sim
        .injections
        .iter()
        .map(|i| match i.injected {
            Injected::Offset(d) => (i.t_s, Some(d)),
            Injected::NaN => (i.t_s, None),
        })
        .collect();
    assert_eq!(listed, expected_by_time);
    let text = sim.describe(&options);
    assert!(text.contains("t 100 s (fix"), "{text}");
    assert!(text.contains("spike #4: reached no fix"), "{text}");
}

#[test]
fn the_seed_decides_everything() {
    let truth = land_vehicle(30.0);
    let options = GnssSimOptions {
        rate_hz: 5.0,
        sigma_v_ned_m_s: Some([0.1, 0.1, 0.1]),
        lever_arm_b_m: [1.0, 0.0, -1.0],
        seed: 11,
        ..GnssSimOptions::default()
    };
    let a = gnss_sim::simulate(&truth, &options).unwrap();
    let b = gnss_sim::simulate(&truth, &options).unwrap();
    assert_eq!(a, b);
    let c = gnss_sim::simulate(
        &truth,
        &GnssSimOptions {
            seed: 12,
            ..options
        },
    )
    .unwrap();
    assert_eq!(a.fixes.len(), c.fixes.len());
    assert!(
        a.fixes
            .iter()
            .zip(&c.fixes)
            .all(|(x, y)| x.lat_rad != y.lat_rad)
    );
}

// ---------------------------------------------------------------------------------------------
// Rates (not in CI).

/// Rows written and read per second on 720 000 rows (an hour at 200 Hz): the `.nav` writer, and
/// the KF-GINS IMU reader on a 7-column file as KF-GINS's datasets write them.
#[test]
#[ignore = "benchmark: 720 000 rows written and read, about a second in release"]
fn rates_of_the_nav_writer_and_the_imu_reader() {
    const ROWS: usize = 720_000;
    let dir = tempfile::tempdir().unwrap();
    let nav = dir.path().join("rate.nav");
    let rows: Vec<NavRow> = (0..ROWS).map(nav_row).collect();
    let started = Instant::now();
    let mut w = NavWriter::create(&nav).unwrap();
    for r in &rows {
        w.write_row(r).unwrap();
    }
    w.finish().unwrap();
    let s = started.elapsed().as_secs_f64();
    let bytes = std::fs::metadata(&nav).unwrap().len();
    println!(
        "nav writer: {ROWS} rows in {s:.3} s: {:.2} M rows/s ({:.0} MB/s)",
        ROWS as f64 / s / 1e6,
        bytes as f64 / s / 1e6
    );

    // An IMU file: seconds of week with 9 decimals, increments as `%.9e`-like text.
    let imu = dir.path().join("imu.txt");
    let mut text = String::with_capacity(ROWS * 110);
    for k in 0..ROWS {
        use std::fmt::Write as _;
        let t = 456_300.0 + k as f64 * 0.005;
        let x = k as f64 * 1e-3;
        let _ = writeln!(
            text,
            "{t:.9} {:.12} {:.12} {:.12} {:.12} {:.12} {:.12}",
            1.1e-5 * x.sin(),
            -2.7e-6 * x.cos(),
            3.3e-6,
            2.2e-4 * x.cos(),
            -3.0e-5,
            -0.049_042_72 + 1e-6 * x.sin()
        );
    }
    std::fs::write(&imu, &text).unwrap();
    for pass in 0..2 {
        let started = Instant::now();
        let file = std::fs::File::open(&imu).unwrap();
        let mut n = 0;
        for row in ImuReader::new(BufReader::new(file), &imu) {
            row.unwrap();
            n += 1;
        }
        let s = started.elapsed().as_secs_f64();
        assert_eq!(n, ROWS);
        println!(
            "KF-GINS IMU reader (pass {pass}): {n} rows in {s:.3} s: {:.2} M rows/s ({:.0} MB/s)",
            n as f64 / s / 1e6,
            text.len() as f64 / s / 1e6
        );
    }
}
