//! The writers (`nav sim`, `nav emulate`, `nav generate`) never emit what their readers
//! refuse: implausible parameters are refused with the reason, every row is checked before
//! anything is written, and a refusal leaves nothing at `--out` (an existing file there
//! untouched). Misleading alignment messages name the actual cause. Through the real command
//! line.

use std::path::{Path, PathBuf};
use std::process::Output;
mod common;
use common::{nav, output_text as text};

/// Asserts a refusal: exit status 1 (the `nav` binary's for every error) and `msg` in the
/// output.
fn assert_refused(o: &Output, msg: &str) {
    assert_eq!(o.status.code(), Some(1), "{}", text(o));
    assert!(text(o).contains(msg), "expected {msg:?} in: {}", text(o));
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The names in `dir`.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn sim_refuses_a_speed_beyond_any_vehicle_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let o = nav(&[
        "sim",
        "ship-rocking",
        "--set",
        "speed_mps=1e9",
        "--out",
        s(&out),
    ]);
    assert_refused(&o, "speed_mps 1e9 is beyond 1000 m/s");
    assert!(!out.exists());
    let o = nav(&[
        "sim",
        "flight",
        "--set",
        "cruise_mps=2000",
        "--out",
        s(&out),
    ]);
    assert_refused(&o, "cruise_mps 2000 is beyond 1000 m/s");
    assert!(!out.exists());
}

#[test]
fn sim_refuses_a_lever_arm_a_height_or_a_longitude_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    for (set, msg) in [
        ("lever_x_m=1e30", "lever arm 1e30 m"),
        ("h_m=-1e7", "h_m -1e7 is not within [-12000, 100000] m"),
        ("lon_deg=400", "lon_deg 400 is not within [-180, 180] deg"),
    ] {
        let o = nav(&["sim", "ship-rocking", "--set", set, "--out", s(&out)]);
        assert_refused(&o, msg);
        assert!(!out.exists(), "{set}");
    }
}

#[test]
fn sim_refuses_a_length_with_no_sample() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let o = nav(&["sim", "static", "--seconds", "1e-9", "--out", s(&out)]);
    assert_refused(&o, "1e-9 s at 400 Hz gives no sample");
    assert!(!out.exists());
    // One sample was written, a recording every reader refused.
    let o = nav(&["sim", "static", "--seconds", "0.0025", "--out", s(&out)]);
    assert_refused(
        &o,
        "0.0025 s at 400 Hz gives 1 sample: a recording needs at least 2 samples",
    );
    assert!(!out.exists());
    let o = nav(&["sim", "static", "--seconds", "0", "--out", s(&out)]);
    assert_refused(&o, "the length must be positive");
    assert!(!out.exists());
}

/// A motion period shorter than 10 samples is refused with its name and range: a roll period
/// of 1 ns wrote 1.4e6 rad in one 2.5 ms increment, one of 1 ms a ship at rest moving at
/// 2.8 km/s, each with exit 0 and "saturated 0".
#[test]
fn sim_refuses_a_motion_period_shorter_than_ten_samples() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    for (scenario, set, rate, msg) in [
        (
            "auv-bench",
            "roll_period_s=1e-9",
            "400",
            "roll_period_s 1e-9 is not within [0.025, ",
        ),
        (
            "ship-rocking",
            "roll_period_s=0.001",
            "400",
            "roll_period_s 0.001 is not within [0.025, ",
        ),
        (
            "ship-rocking",
            "pitch_period_s=0.05",
            "100",
            "pitch_period_s 0.05 is not within [0.1, ",
        ),
    ] {
        let o = nav(&[
            "sim",
            scenario,
            "--seconds",
            "2",
            "--rate",
            rate,
            "--truth-rate",
            "10",
            "--set",
            set,
            "--out",
            s(&out),
        ]);
        assert_refused(&o, msg);
        assert_refused(&o, "at least 10 samples");
        assert!(!out.exists(), "{set}");
    }
}

/// Independently of the parameter checks: 1000 m/s is accepted, but north for 6000 s it
/// crosses the pole, and the first truth row beyond it refuses the run; the earlier run's
/// files in the directory stay as they were.
#[test]
fn sim_refuses_the_first_row_past_the_pole_and_keeps_the_old_files() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let o = nav(&[
        "sim",
        "static",
        "--seconds",
        "1",
        "--format",
        "bin",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let old = contents(&out);
    let o = nav(&[
        "sim",
        "ship-rocking",
        "--set",
        "speed_mps=1000",
        "--set",
        "heading_deg=0",
        "--seconds",
        "6000",
        "--rate",
        "10",
        "--truth-rate",
        "10",
        "--out",
        s(&out),
    ]);
    assert_refused(&o, "nothing written: truth row ");
    assert!(
        text(&o).contains("deg is not within [-90, 90]") || text(&o).contains("not a finite"),
        "{}",
        text(&o)
    );
    assert!(contents(&out) == old, "{:?}", names(&out));
}

/// The names and bytes of the files in `dir`.
fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    names(dir)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(dir.join(&n)).unwrap()))
        .collect()
}

/// A file of a name `nav sim` writes that an earlier `nav sim` did not write is the user's:
/// the run is refused, naming it, and nothing in the folder changes. A user's `gnss.csv` and
/// `imu.csv` were removed "(an earlier run's, not this one's)" by `--format bin`.
#[test]
fn sim_refuses_a_folder_holding_files_it_did_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("mine");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("gnss.csv"), "my own GNSS log\n").unwrap();
    std::fs::write(out.join("imu.csv"), "my own IMU log\n").unwrap();
    let sim = |out: &Path| {
        nav(&[
            "sim",
            "static",
            "--seconds",
            "2",
            "--format",
            "bin",
            "--out",
            s(out),
        ])
    };
    let before = contents(&out);
    let o = sim(&out);
    assert_refused(
        &o,
        "was not written by nav sim (no scenario.txt of an earlier",
    );
    assert_refused(&o, "choose an empty folder, or move the file away");
    assert!(text(&o).contains(&format!("{}/", s(&out))), "{}", text(&o));
    assert!(contents(&out) == before, "{:?}", names(&out));

    // Beside an earlier run's scenario.txt, a file it did not write (its header not nav
    // sim's) is still the user's.
    let run = dir.path().join("run");
    let o = nav(&[
        "sim",
        "static",
        "--seconds",
        "2",
        "--gnss-rate",
        "1",
        "--out",
        s(&run),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    std::fs::write(run.join("gnss.csv"), "my own GNSS log\n").unwrap();
    let before = contents(&run);
    let o = sim(&run);
    assert_refused(
        &o,
        &format!(
            "{} was not written by nav sim (it does not begin as nav sim's gnss.csv does)",
            s(&run.join("gnss.csv"))
        ),
    );
    assert!(contents(&run) == before, "{:?}", names(&run));

    // A scenario.txt of the user's own proves nothing.
    let notes = dir.path().join("notes");
    std::fs::create_dir(&notes).unwrap();
    std::fs::write(notes.join("scenario.txt"), "my scenario\n").unwrap();
    let o = sim(&notes);
    assert_refused(&o, "(its first line is not \"# nav sim ...\")");
    assert_eq!(names(&notes), ["scenario.txt"]);
}

/// A run into the directory of an earlier one leaves no file of the earlier run: `nav sim
/// static --format bin` into a `land-vehicle --gnss-rate 1` directory kept the car's
/// `imu.csv` and fixes beside the static truth, a set that looked whole. A user file of
/// another name stays.
#[test]
fn sim_removes_an_earlier_runs_files_it_does_not_write() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let car = nav(&[
        "sim",
        "land-vehicle",
        "--seconds",
        "10",
        "--gnss-rate",
        "1",
        "--out",
        s(&out),
    ]);
    assert!(car.status.success(), "{}", text(&car));
    std::fs::write(out.join("notes.txt"), "mine\n").unwrap();
    let car_truth = std::fs::read_to_string(out.join("truth.csv")).unwrap();
    let o = nav(&[
        "sim",
        "static",
        "--seconds",
        "5",
        "--format",
        "bin",
        "--out",
        s(&out),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        names(&out),
        ["imu.bin", "notes.txt", "scenario.txt", "truth.csv"]
    );
    assert_ne!(
        std::fs::read_to_string(out.join("truth.csv")).unwrap(),
        car_truth
    );
    for name in ["imu.csv", "gnss.csv", "gnss.bin"] {
        assert!(
            text(&o).contains(&format!("removed    {}", s(&out.join(name)))),
            "{name}: {}",
            text(&o)
        );
    }
    // A refused run changes nothing.
    let before = names(&out);
    let o = nav(&["sim", "static", "--seconds", "0", "--out", s(&out)]);
    assert_refused(&o, "the length must be positive");
    assert_eq!(names(&out), before);
}

/// A run whose set cannot be written whole writes none of it: with a directory in the place
/// of `truth.csv`, `nav sim` wrote the new recording and fixes beside the earlier run's
/// description before it failed (found by a probe), a mixed set. Now every destination is
/// checked first and the set is renamed into place only once all of it is written: the
/// earlier run's files are as they were, and no staging directory is left.
#[test]
fn sim_writes_its_set_whole_or_not_at_all() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let run = |seed: &str| {
        nav(&[
            "sim",
            "land-vehicle",
            "--grade",
            "fog",
            "--seconds",
            "10",
            "--seed",
            seed,
            "--gnss-rate",
            "1",
            "--out",
            s(&out),
        ])
    };
    let o = run("1");
    assert!(o.status.success(), "{}", text(&o));
    std::fs::remove_file(out.join("truth.csv")).unwrap();
    std::fs::create_dir(out.join("truth.csv")).unwrap();
    let before: Vec<(String, Vec<u8>)> = names(&out)
        .into_iter()
        .filter(|n| n != "truth.csv")
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap()))
        .collect();
    assert_eq!(before.len(), 5, "{before:?}");
    let o = run("2");
    assert_refused(&o, "truth.csv is not a regular file (a directory)");
    let after: Vec<(String, Vec<u8>)> = names(&out)
        .into_iter()
        .filter(|n| n != "truth.csv")
        .map(|n| (n.clone(), std::fs::read(out.join(&n)).unwrap()))
        .collect();
    assert!(after == before, "{:?}", names(&out));
    // Once the path is free the run writes its whole set.
    std::fs::remove_dir(out.join("truth.csv")).unwrap();
    let o = run("2");
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        names(&out),
        [
            "gnss.bin",
            "gnss.csv",
            "imu.bin",
            "imu.csv",
            "scenario.txt",
            "truth.csv"
        ]
    );
    let scenario = std::fs::read_to_string(out.join("scenario.txt")).unwrap();
    assert!(scenario.contains("seed = 2"), "{scenario}");
}

/// A still truth of 600 s at 1 Hz, from `nav sim static`.
fn still_truth(dir: &Path) -> PathBuf {
    let sim = dir.join("still");
    let o = nav(&[
        "sim",
        "static",
        "--seconds",
        "600",
        "--rate",
        "50",
        "--truth-rate",
        "1",
        "--format",
        "bin",
        "--out",
        s(&sim),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    sim.join("truth.csv")
}

fn emulate(truth: &Path, out: &Path, errors_out: &Path, set: &str) -> Output {
    nav(&[
        "emulate",
        "--truth",
        s(truth),
        "--out",
        s(out),
        "--errors-out",
        s(errors_out),
        "--set",
        set,
    ])
}

/// In the words the errors were given in (the `--set` or file line, the key, its unit).
#[test]
fn emulate_refuses_errors_beyond_the_linear_model_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let truth = still_truth(dir.path());
    let out = dir.path().join("displayed.csv");
    let errors_out = dir.path().join("errors.csv");
    std::fs::write(&out, "previous run\n").unwrap();
    for (set, msg) in [
        (
            "gyro_drift_deg_h = 1e300 0 0",
            "--set #1 `gyro_drift_deg_h = 1e300 0 0`: gyro_drift_deg_h: the magnitude of \
             (1.000e300, 0, 0) is 1.000e300, beyond 68.75: over the truth's length",
        ),
        (
            "accel_bias_g = 1e6 0 0",
            "accel_bias_g: the magnitude of (1.000e6, 0, 0) is 1.000e6, beyond 0.2000: the tilt \
             bias/g",
        ),
        (
            "position_error_m = 1e12 0 0",
            "position_error_m: the magnitude of (1.000e12, 0, 0) is 1.000e12, beyond 100000",
        ),
        (
            "attitude_error_deg = 20 0 0",
            "attitude_error_deg: the magnitude of (20.00, 0, 0) is 20.00, beyond 11.46",
        ),
        (
            "velocity_error_m_s = 1e3 0 0",
            "velocity_error_m_s: the magnitude of (1000, 0, 0) is 1000, beyond 100.0",
        ),
        // Each component within the bound, the vector beyond it: its norm was given as the
        // value ("attitude_error_arcmin 1178 is beyond +-687.5"), read as a component.
        (
            "attitude_error_arcmin = 680 680 680",
            "attitude_error_arcmin: the magnitude of (680.0, 680.0, 680.0) is 1178, beyond \
             687.5: beyond the linear error model's small-angle range",
        ),
        (
            "velocity_error_m_s = 80 -80 0",
            "velocity_error_m_s: the magnitude of (80.00, -80.00, 0) is 113.1, beyond 100.0",
        ),
        // A scale factor's bound is per component: its largest, with its sign.
        (
            "gyro_scale_ppm = 0 -1e10 0",
            "gyro_scale_ppm -1.000e10 is beyond +-",
        ),
    ] {
        let o = emulate(&truth, &out, &errors_out, set);
        assert_refused(&o, msg);
        assert_eq!(std::fs::read_to_string(&out).unwrap(), "previous run\n");
        assert!(!errors_out.exists(), "{set}");
    }
    assert_eq!(names(dir.path()), ["displayed.csv", "still"]);
    // Within the range: written.
    let o = emulate(&truth, &out, &errors_out, "gyro_drift_deg_h = 10 0 0");
    assert!(o.status.success(), "{}", text(&o));
    assert!(errors_out.exists());
    assert!(
        std::fs::read_to_string(&out)
            .unwrap()
            .starts_with("t_s,lat_deg")
    );
}

/// A 0.1 g bias is within the parameter range, but its position error grows past 100 km
/// within the 600 s (b t^2 / 2): the first row beyond refuses the run.
#[test]
fn emulate_refuses_errors_that_grow_out_of_the_linear_range() {
    let dir = tempfile::tempdir().unwrap();
    let truth = still_truth(dir.path());
    let out = dir.path().join("displayed.csv");
    let errors_out = dir.path().join("errors.csv");
    let o = emulate(&truth, &out, &errors_out, "accel_bias_g = 0.1 0 0");
    assert_refused(&o, "the position error reached");
    // sqrt(2 * 100 km / 0.98 m/s^2) = 452 s (a little later: the Schuler loop bends it).
    let t = text(&o);
    let row: usize = t
        .split("row ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|r| r.parse().ok())
        .unwrap_or_else(|| panic!("{t}"));
    assert!((452..=470).contains(&row), "{t}");
    assert!(!out.exists() && !errors_out.exists());
}

#[test]
fn emulate_refuses_an_output_that_is_its_truth() {
    let dir = tempfile::tempdir().unwrap();
    let truth = still_truth(dir.path());
    let before = std::fs::read(&truth).unwrap();
    let o = nav(&["emulate", "--truth", s(&truth), "--out", s(&truth)]);
    assert_refused(&o, "is the input");
    assert_eq!(std::fs::read(&truth).unwrap(), before);
    let out = dir.path().join("displayed.csv");
    let o = nav(&[
        "emulate",
        "--truth",
        s(&truth),
        "--out",
        s(&out),
        "--errors-out",
        s(&out),
    ]);
    assert_refused(&o, "--out and --errors-out name the same file");
    assert!(!out.exists());
}

#[test]
fn generate_refuses_what_the_replay_would_refuse_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("imu.bin");
    for (arg, value, msg) in [
        ("--seconds", "0", "the duration must be positive, not 0 s"),
        ("--seconds", "1e-9", "1e-9 s at 400 Hz gives no sample"),
        (
            "--rate",
            "0",
            "the rate must be within [10, 40000] Hz, the rates a replay navigates, not 0",
        ),
        (
            "--rate",
            "1e12",
            "the rate must be within [10, 40000] Hz, the rates a replay navigates, not 1e12",
        ),
        // Every 2 s increment would be refused by the replay (0.1 s at most).
        (
            "--rate",
            "0.5",
            "the rate must be within [10, 40000] Hz, the rates a replay navigates, not 0.5",
        ),
        (
            "--lon",
            "400",
            "the longitude must be within [-180, 180] deg, not 400",
        ),
        (
            "--h",
            "-1e7",
            "the height must be within [-12000, 100000] m (the Earth model's range), not -1e7",
        ),
    ] {
        let o = nav(&["generate", "--out", s(&out), arg, value]);
        assert_refused(&o, msg);
        assert!(!out.exists(), "{arg} {value}");
    }
}

fn replay(imu: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "replay",
        "--imu",
        s(imu),
        "--out",
        s(out),
        "--lat",
        "45",
        "--lon",
        "7.5",
        "--h",
        "150",
    ];
    args.extend_from_slice(extra);
    nav(&args)
}

fn generated(dir: &Path, name: &str, seconds: &str) -> PathBuf {
    let path = dir.join(name);
    let o = nav(&["generate", "--out", s(&path), "--seconds", seconds]);
    assert!(o.status.success(), "{}", text(&o));
    path
}

#[test]
fn a_lever_arm_beyond_a_hull_is_refused_as_a_bad_argument() {
    let dir = tempfile::tempdir().unwrap();
    let imu = generated(dir.path(), "imu.bin", "30");
    let out = dir.path().join("log.csv");
    let inertial = ["--align-seconds", "20", "--align-method", "inertial"];
    let o = replay(
        &imu,
        &out,
        &[&inertial[..], &["--lever-arm", "1e30,0,0"]].concat(),
    );
    assert_refused(
        &o,
        "--lever-arm 1e30,0,0: lever arm 1.000e30 m is beyond 100 m",
    );
    assert!(!text(&o).contains("gravity"), "{}", text(&o));
    assert!(!out.exists());
    let o = replay(
        &imu,
        &out,
        &[&inertial[..], &["--lever-arm-sigma", "1e30"]].concat(),
    );
    assert_refused(
        &o,
        "--lever-arm-sigma 1e30: lever arm 1-sigma 1.000e30 m is beyond 100 m",
    );
    assert!(!out.exists());
    // A ship's deck lever arm is accepted (a FOG's noise: the ADIS16505 default cannot
    // resolve the Earth rate in 20 s).
    let o = replay(
        &imu,
        &out,
        &[
            &inertial[..],
            &["--lever-arm", "30,10,15", "--imu-noise", "fog"],
        ]
        .concat(),
    );
    assert!(o.status.success(), "{}", text(&o));
}

#[test]
fn a_height_far_from_the_earth_is_a_bad_argument_not_a_gravity_mismatch() {
    let dir = tempfile::tempdir().unwrap();
    let imu = generated(dir.path(), "imu.bin", "20");
    let out = dir.path().join("log.csv");
    let mut args = vec![
        "replay",
        "--imu",
        s(&imu),
        "--out",
        s(&out),
        "--lat",
        "45",
        "--lon",
        "7.5",
        "--h",
        "-1e7",
        "--align-seconds",
        "10",
    ];
    let o = nav(&args);
    assert_refused(
        &o,
        "invalid configuration: height -1e7 m is not within [-12000, 100000] m",
    );
    assert!(!text(&o).contains("gravity"), "{}", text(&o));
    assert!(!out.exists());
    args[10] = "150";
    assert!(nav(&args).status.success());
}

/// A CSV whose timestamps were multiplied by 10 (400 Hz increments 25 ms apart: 40 Hz
/// apparent): a tenth of gravity per second, which the alignment names as a scale error
/// with the numbers, for the static, inertial and two-stage methods alike.
#[test]
fn timestamps_ten_times_too_far_apart_are_named_as_a_scale_error() {
    let dir = tempfile::tempdir().unwrap();
    let csv = generated(dir.path(), "imu.csv", "30");
    let text_in = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text_in.lines();
    let mut scaled = format!("{}\n", lines.next().unwrap());
    for line in lines {
        let (t, rest) = line.split_once(',').unwrap();
        let t: f64 = t.parse().unwrap();
        scaled += &format!("{},{rest}\n", t * 10.0);
    }
    let x10 = dir.path().join("x10.csv");
    std::fs::write(&x10, scaled).unwrap();
    let out = dir.path().join("log.csv");
    for method in ["static", "inertial", "fine"] {
        let o = replay(
            &x10,
            &out,
            // FOG noise: with the board's default (ADIS16505) prior `fine` refuses the gyros
            // before any sample.
            &[
                "--align-seconds",
                "100",
                "--align-method",
                method,
                "--imu-noise",
                "fog",
            ],
        );
        assert_refused(
            &o,
            "mean specific force 0.9806 m/s^2 is not gravity 9.806 m/s^2 (0.1000 times it): sample rate, timestamps or units wrong?",
        );
        assert!(!out.exists(), "{method}");
    }
    // The same file with its own timestamps aligns.
    let o = replay(&csv, &out, &["--align-seconds", "20"]);
    assert!(o.status.success(), "{}", text(&o));
}
