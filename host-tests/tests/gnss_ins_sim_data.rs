//! gnss-ins-sim's output folders: the real consumer-MEMS logs of `shared/data` (skipped, with
//! a message, when the folder is absent), and a folder written from this project's simulator
//! the way gnss-ins-sim writes one (rates at the epochs, reference trajectory with the body-frame
//! velocity), which must replay as the recording it came from and report against its truth.

mod common;

use common::{nav, output_text};
use host_tests::recording_io::{self, Format};
use host_tests::{truth, truth_csv};
use nav_core::attitude::euler;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn shared_folder(name: &str) -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/gnss-ins-sim-stationary")
        .join(name);
    if path.is_dir() {
        Some(path)
    } else {
        eprintln!("skipped: {} is absent", path.display());
        None
    }
}

/// The real logs: 1,000 epochs at 100 Hz give 999 increments; the parts stand level (the
/// specific force about g along -z, FRD) and turn about z only (up to 130 deg/s, a turntable):
/// the mean x and y rates are below 1 deg/s.
#[test]
fn real_stationary_logs_read_as_recordings() {
    for name in ["bosch", "nxp"] {
        let Some(dir) = shared_folder(name) else {
            return;
        };
        assert_eq!(recording_io::detect(&dir).unwrap(), Format::GnssInsSim);
        let rec = recording_io::read(&dir).unwrap();
        assert_eq!(rec.records.len(), 999, "{name}");
        assert!(
            (rec.rate_hz - 100.0).abs() < 1e-6,
            "{name}: {}",
            rec.rate_hz
        );
        let n = rec.records.len() as f64;
        let mean = |f: &dyn Fn(&hal_adapters::recording::Record) -> [f32; 3]| {
            let mut s = [0.0; 3];
            for r in &rec.records {
                for (a, x) in s.iter_mut().zip(f(r)) {
                    *a += f64::from(x) / (n * 0.01);
                }
            }
            s
        };
        let f = mean(&|r| r.accel);
        let g = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        assert!((g - 9.81).abs() < 0.2 && f[2] < -9.5, "{name}: {f:?}");
        let w = mean(&|r| r.gyro);
        assert!(
            w[..2].iter().all(|x| x.abs() < 1f64.to_radians()),
            "{name}: {w:?}"
        );
        // One of its files names the folder too.
        let via_file = recording_io::read(&dir.join("accel-0.csv")).unwrap();
        let key = |r: &hal_adapters::recording::Record| (r.t_ns, r.gyro, r.accel);
        assert!(
            via_file
                .records
                .iter()
                .map(key)
                .eq(rec.records.iter().map(key)),
            "{name}: read through accel-0.csv differs"
        );
    }
}

/// Writes `rows` of `header` to `dir/name`.
fn write_csv(dir: &Path, name: &str, header: &str, rows: impl Iterator<Item = [f64; 3]>) {
    let mut text = format!("{header}\n");
    for [a, b, c] in rows {
        writeln!(text, "{a:e},{b:e},{c:e}").unwrap();
    }
    std::fs::write(dir.join(name), text).unwrap();
}

/// A simulated land vehicle written as gnss-ins-sim writes a run: each epoch's rates are the
/// next interval's increment over its length (gnss-ins-sim steps its trajectory forward from
/// them); the reference velocity in the body frame.
#[test]
fn a_simulated_run_replays_and_reports_as_its_recording() {
    let tmp = tempfile::tempdir().unwrap();
    let sim = tmp.path().join("sim");
    let o = nav(&[
        "sim",
        "land-vehicle",
        "--grade",
        "fog",
        "--seconds",
        "120",
        "--rate",
        "50",
        "--out",
        sim.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", output_text(&o));
    let rec = recording_io::read(&sim.join("imu.bin")).unwrap();
    let truth = truth_csv::read(&sim.join("truth.csv")).unwrap();
    assert_eq!(truth.len(), rec.records.len() + 1);
    let dir = tmp.path().join("gis");
    std::fs::create_dir(&dir).unwrap();
    let times: Vec<f64> = std::iter::once(rec.t0_ns)
        .chain(rec.records.iter().map(|r| r.t_ns))
        .map(|t| t as f64 * 1e-9)
        .collect();
    let mut text = String::from("time (sec)\n");
    for t in &times {
        writeln!(text, "{t:e}").unwrap();
    }
    std::fs::write(dir.join("time.csv"), text).unwrap();
    let rate = |k: usize, f: fn(&hal_adapters::recording::Record) -> [f32; 3], scale: f64| {
        let k = k.min(rec.records.len() - 1);
        let dt = times[k + 1] - times[k];
        f(&rec.records[k]).map(|x| f64::from(x) / dt * scale)
    };
    let n = times.len();
    write_csv(
        &dir,
        "gyro-0.csv",
        "gyro_x (deg/s),gyro_y (deg/s),gyro_z (deg/s)",
        (0..n).map(|k| rate(k, |r| r.gyro, 1f64.to_degrees())),
    );
    write_csv(
        &dir,
        "accel-0.csv",
        "accel_x (m/s^2),accel_y (m/s^2),accel_z (m/s^2)",
        (0..n).map(|k| rate(k, |r| r.accel, 1.0)),
    );
    write_csv(
        &dir,
        "ref_pos.csv",
        "ref_pos_lat (deg),ref_pos_lon (deg),ref_pos_alt (m)",
        truth
            .iter()
            .map(|t| [t.lat.to_degrees(), t.lon.to_degrees(), t.h]),
    );
    write_csv(
        &dir,
        "ref_vel.csv",
        "ref_vel_x (m/s),ref_vel_y (m/s),ref_vel_z (m/s)",
        truth
            .iter()
            .map(|t| (t.q_b_ned.inverse() * t.v_eb_ned).into()),
    );
    write_csv(
        &dir,
        "ref_att_euler.csv",
        "ref_Yaw (deg),ref_Pitch (deg),ref_Roll (deg)",
        truth.iter().map(|t| {
            let (r, p, y) = euler(&t.q_b_ned);
            [y, p, r].map(f64::to_degrees)
        }),
    );
    // The same increments, to the rounding of the text.
    let back = recording_io::read(&dir).unwrap();
    assert_eq!(back.records.len(), rec.records.len());
    for (a, b) in back.records.iter().zip(&rec.records) {
        assert_eq!(a.t_ns, b.t_ns);
        for (x, y) in a
            .gyro
            .iter()
            .chain(&a.accel)
            .zip(b.gyro.iter().chain(&b.accel))
        {
            assert!((x - y).abs() <= 1e-6 * y.abs() + 1e-12, "{a:?} {b:?}");
        }
    }
    // The folder's reference trajectory is the simulator's truth.
    let report = nav(&[
        "report",
        "--solution",
        sim.join("truth.csv").to_str().unwrap(),
        "--truth",
        dir.to_str().unwrap(),
    ]);
    assert!(report.status.success(), "{}", output_text(&report));
    let read_back = host_tests::report::read_trajectory(&dir, false).unwrap();
    for (a, b) in read_back.iter().zip(&truth) {
        assert!((a.t_s - b.t_s).abs() < 1e-9);
        assert!(truth::distance_m(a.lat, a.lon, a.h, b.lat, b.lon, b.h) < 1e-6);
        assert!((a.v_eb_ned - b.v_eb_ned).norm() < 1e-9, "{a:?} {b:?}");
        assert!(a.q_b_ned.angle_to(&b.q_b_ned) < 1e-9);
    }
    // Replayed from the folder as from the binary recording: the same navigation.
    let start = &truth[0];
    let (lat, lon, h) = (
        start.lat.to_degrees().to_string(),
        start.lon.to_degrees().to_string(),
        start.h.to_string(),
    );
    let logs: Vec<String> = [dir.clone(), sim.join("imu.bin")]
        .iter()
        .enumerate()
        .map(|(i, input)| {
            let out = tmp.path().join(format!("sol{i}.csv"));
            let o = nav(&[
                "replay",
                "--imu",
                input.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
                "--lat",
                &lat,
                "--lon",
                &lon,
                "--h",
                &h,
                "--align-seconds",
                "10",
                "--imu-noise",
                "fog",
            ]);
            assert!(o.status.success(), "{}", output_text(&o));
            out.to_str().unwrap().to_owned()
        })
        .collect();
    let a = host_tests::report::read_trajectory(Path::new(&logs[0]), false).unwrap();
    let b = host_tests::report::read_trajectory(Path::new(&logs[1]), false).unwrap();
    assert_eq!(a.len(), b.len());
    let last = (a.last().unwrap(), b.last().unwrap());
    let d = truth::distance_m(
        last.0.lat, last.0.lon, last.0.h, last.1.lat, last.1.lon, last.1.h,
    );
    assert!(d < 0.01, "{d} m apart");

    // gnss-ins-sim's GPS file (1 Hz, the truth's position and NED velocity, no lever arm):
    // refused without a stated 1-sigma, navigated with one.
    let mut gps = String::from(
        "gps_lat (deg),gps_lon (deg),gps_alt (m),gps_vN (m/s),gps_vE (m/s),gps_vD (m/s)\n",
    );
    let mut gps_time = String::from("gps_time (sec)\n");
    for t in truth.iter().step_by(50) {
        let v = t.v_eb_ned;
        writeln!(
            gps,
            "{:e},{:e},{:e},{:e},{:e},{:e}",
            t.lat.to_degrees(),
            t.lon.to_degrees(),
            t.h,
            v.x,
            v.y,
            v.z
        )
        .unwrap();
        writeln!(gps_time, "{:e}", t.t_s).unwrap();
    }
    std::fs::write(dir.join("gps-0.csv"), gps).unwrap();
    std::fs::write(dir.join("gps_time.csv"), gps_time).unwrap();
    let (roll, pitch, yaw) = euler(&start.q_b_ned);
    let init_pos = format!("{lat},{lon},{h}");
    let v0 = start.v_eb_ned;
    let init_vel = format!("{},{},{}", v0.x, v0.y, v0.z);
    let init_att = format!(
        "{},{},{}",
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    );
    let aided_out = tmp.path().join("aided.csv");
    let aided = |extra: &[&str]| {
        let mut args = vec![
            "replay",
            "--imu",
            dir.to_str().unwrap(),
            "--gnss",
            dir.to_str().unwrap(),
            "--out",
            aided_out.to_str().unwrap(),
            "--init-pos",
            &init_pos,
            "--init-vel",
            &init_vel,
            "--init-att",
            &init_att,
            "--imu-noise",
            "fog",
        ];
        args.extend_from_slice(extra);
        nav(&args)
    };
    let refused = aided(&[]);
    assert!(!refused.status.success());
    let text = output_text(&refused);
    assert!(text.contains("holds no 1-sigma"), "{text}");
    assert!(!aided_out.exists());
    let o = aided(&[
        "--gnss-sigma",
        "0.5,0.5,1",
        "--gnss-velocity-sigma",
        "0.05,0.05,0.05",
    ]);
    let text = output_text(&o);
    assert!(o.status.success(), "{text}");
    // 121 fixes, the first at the first epoch, before the first increment ends.
    assert!(
        text.contains("GNSS position: 120 accepted, 0 rejected"),
        "{text}"
    );
    assert!(text.contains("GNSS velocity: 120 accepted"), "{text}");
    let sol = host_tests::report::read_trajectory(&aided_out, false).unwrap();
    let end = sol.last().unwrap();
    let t_end = truth
        .iter()
        .min_by(|a, b| (a.t_s - end.t_s).abs().total_cmp(&(b.t_s - end.t_s).abs()))
        .unwrap();
    let d = truth::distance_m(end.lat, end.lon, end.h, t_end.lat, t_end.lon, t_end.h);
    assert!(d < 1.5, "aided end error {d} m");
}
