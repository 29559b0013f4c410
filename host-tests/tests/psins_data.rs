//! The real PSINS laser-gyro recording (`shared/data/psins-lasergyro`, see its README): parsing,
//! unit and axis conversion, and a replay that completes. There is no ground truth for the
//! navigation (the vehicle stood with its engine running), so only parsing facts and sanity
//! bounds are asserted. Skipped, with a message, when the data folder is absent.

mod common;

use host_tests::pipeline::sensor_noise;
use host_tests::psins;
use host_tests::recording_io::{self, Format};
use host_tests::replay::ReplayOptions;
use host_tests::sensor_model::Grade;
use nav_core::alignment::AlignMethod;
use std::path::PathBuf;

fn data_file() -> Option<PathBuf> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/psins-lasergyro/lasergyro.imu");
    if path.is_file() {
        Some(path)
    } else {
        eprintln!(
            "skipped: {} is absent (shared data folder not checked out)",
            path.display()
        );
        None
    }
}

#[test]
fn lasergyro_parses_and_converts_to_frd() {
    let Some(path) = data_file() else { return };
    assert_eq!(recording_io::detect(&path).unwrap(), Format::Psins);
    let rec = psins::read(&path).unwrap();
    let h = rec.header;
    assert_eq!(rec.samples.len(), 184_718);
    assert_eq!(
        (h.lat_deg, h.lon_deg, h.h_m),
        (34.246048, 108.909664, 380.0)
    );
    assert_eq!(
        (h.interval_ms, h.g_mps2, h.yaw0_deg),
        (10.0, 9.780327, -90.6)
    );
    assert_eq!(h.gyro_scale_arcsec, [0.1; 3]);
    assert_eq!(h.accel_scale_ug_s, [125.0; 3]);

    // First second: mean specific force in FRD. The vehicle stands (roughly level), so the
    // accelerometers read about 1 g up: z_frd about -9.78 m/s^2 (the counts are scaled with the
    // header's g = 9.780327), the horizontal axes a small fraction of g (tilt below ~3 deg).
    // Summing the velocity increments over 1 s gives the mean specific force [m/s^2].
    let first_second = &rec.samples[..100];
    let f: [f64; 3] =
        core::array::from_fn(|a| first_second.iter().map(|s| s.delta_v_ib_b[a]).sum());
    assert!((f[2] + 9.78).abs() < 0.05, "{f:?}");
    assert!(f[0].abs() < 0.5 && f[1].abs() < 0.5, "{f:?}");
    // The Earth rate is 15 deg/h; the mean rate over the first minute must be of that order,
    // far below the vibration rates of a single sample.
    let minute = &rec.samples[..6000];
    let w: Vec<f64> = (0..3)
        .map(|a| minute.iter().map(|s| s.delta_theta_ib_b[a]).sum::<f64>() / 60.0)
        .collect();
    let w_dph = w.iter().map(|x| x * x).sum::<f64>().sqrt().to_degrees() * 3600.0;
    assert!(w_dph < 45.0, "{w_dph} deg/h");

    // In memory as the binary format: 100 Hz, t0 = 0, record k at (k + 1) * 10 ms.
    let r = recording_io::read(&path).unwrap();
    assert_eq!((r.rate_hz, r.t0_ns, r.records.len()), (100.0, 0, 184_718));
    assert_eq!(r.records[0].t_ns, 10_000_000);
    assert_eq!(r.records[184_717].t_ns, 1_847_180_000_000);
    assert!(r.records[0].temperature_c.is_nan());
}

#[test]
fn lasergyro_replays() {
    let Some(path) = data_file() else { return };
    let mut options = ReplayOptions::new(34.246048, 108.909664, 380.0, 60.0);
    options.run.log_every = 100;
    // The engine ran and people moved: the static method must see that the base is not still.
    let why = common::replay_error(&path, &options);
    assert!(why.contains("base not still"), "{why}");
    // The inertial-frame method is made for a disturbed base (laser-gyro noise assumed).
    options.run.align_method = AlignMethod::Inertial;
    options.run.noise = sensor_noise(&Grade::Rlg.noise_spec());
    // With the default wave prior (0.5 m) a 60 s window on a base that is not still is
    // refused: its translation would leak beyond 15 deg of heading through 15 s ramps.
    let why = common::replay_error(&path, &options);
    assert!(why.contains("heading 1-sigma passes 15 deg"), "{why}");
    // A standing vehicle rocks by centimetres when people move.
    options.run.base.translation_sigma_m = 0.02;
    let (fr, log) = common::replay::<f64>(&path, &options);
    let r = fr.report;
    assert_eq!(
        (r.samples, r.flagged, r.rejected, r.n_align),
        (184_718, 0, 0, 6000)
    );
    assert_eq!(r.source.unwrap(), Default::default());
    // Levelling on a standing vehicle: a few degrees at most; |f| is gravity within the 2 %
    // the alignment accepts (it would have failed otherwise).
    assert!(
        r.alignment.roll_deg.abs() < 5.0 && r.alignment.pitch_deg.abs() < 5.0,
        "{:?}",
        r.alignment
    );
    let rows = common::parse_log(&log);
    assert_eq!(rows.len() as u32, common::expected_rows(&r, 100));
    assert_eq!(rows.last().unwrap().t_s, 1847.18);
    assert!(
        rows.iter()
            .all(|row| row.v_ned.iter().chain(&row.rpy_deg).all(|v| v.is_finite()))
    );
}
