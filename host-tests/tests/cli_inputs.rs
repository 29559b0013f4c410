//! Inputs of `nav` that were taken wrongly or silently: grades without noise, streams, data
//! sets mixed from two folders, repeated time tags, headers in capitals, holes in a truth file,
//! long output names, fixes just before the data, temperatures no sensor has, GNSS outliers
//! past the run, text not in UTF-8, a GPS week rollover. Each is refused with a message that names
//! the file and what was expected, warned about, or counted where the README says.

mod common;

use common::{nav, output_text};

/// `nav args`, which must succeed; its stdout and stderr.
fn ok(args: &[&str]) -> String {
    let o = nav(args);
    let text = output_text(&o);
    assert!(o.status.success(), "nav {args:?}: {text}");
    assert!(!text.contains("panicked"), "nav {args:?}: {text}");
    text
}

/// The constant-gain level filter with noise-free sensors: its time constant was 0, its gain
/// infinite, and the table printed NaN and 90 deg errors with status 0.
#[test]
fn the_ship_bench_with_ideal_sensors_prints_numbers() {
    let text = ok(&["align-bench", "seed002", "--grade", "ideal", "--runs", "1"]);
    assert!(!text.contains("NaN"), "{text}");
    // Every const row is within a millidegree (exact data).
    for row in text.lines().filter(|l| l.contains(" const ")) {
        let worst = row
            .split(['|', ' '])
            .filter_map(|f| f.parse::<f64>().ok())
            .skip(2)
            .fold(0.0_f64, |m, x| m.max(x.abs()));
        assert!(worst < 1e-3, "{row}");
    }
}

/// `nav args` with `input` written to its standard input through a pipe.
fn nav_with_stdin(args: &[&str], input: Vec<u8>) -> std::process::Output {
    use std::io::Write as _;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
        .args(args)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run nav");
    let mut stdin = child.stdin.take().unwrap();
    // A refusal closes the pipe before all is written: not this test's failure.
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let o = child.wait_with_output().expect("nav's output");
    writer.join().unwrap();
    o
}

/// A pipe as the IMU recording or the GNSS file: the format detection read its start, the
/// reader then found the rest and blamed valid data ("expected the header row", "not a NAVIMU
/// recording", "no data"). Refused now as what it is, nothing written.
#[test]
fn a_pipe_as_an_input_is_refused_as_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (bin, csv, out) = (path("imu.bin"), path("imu.csv"), path("out.bin"));
    common::generated_recording(std::path::Path::new(&bin), "1");
    ok(&["convert", "--in", &bin, "--out", &csv]);
    for input in [&bin, &csv] {
        let o = nav_with_stdin(
            &["convert", "--in", "/dev/stdin", "--out", &out],
            std::fs::read(input).unwrap(),
        );
        let text = output_text(&o);
        assert_eq!(o.status.code(), Some(1), "{text}");
        assert!(
            text.contains("/dev/stdin: not a regular file")
                && text.contains("pipes are not supported"),
            "{text}"
        );
        assert!(!std::path::Path::new(&out).exists());
    }
    let gnss = "t_s,lat_deg,lon_deg,h_m,sigma_n_m,sigma_e_m,sigma_d_m\n0.5,45,7.5,150,1,1,2\n";
    let o = nav_with_stdin(
        &["convert", "--gnss", "--in", "/dev/stdin", "--out", &out],
        gnss.as_bytes().to_vec(),
    );
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("GNSS file /dev/stdin: not a regular file"),
        "{text}"
    );
    assert!(!std::path::Path::new(&out).exists());
}

/// `nav kf-gins` run from a folder that has a file of `imupath`'s relative name read that one
/// and `gnsspath` from the configuration's folder, silently: two data sets mixed. The files
/// read are named now, and the mixing warned about.
#[test]
fn kf_gins_names_its_files_and_warns_of_two_folders() {
    let dir = tempfile::tempdir().unwrap();
    let data = host_tests::filter_bench::generate(
        &dir.path().join("set"),
        &host_tests::filter_bench::FilterBenchOptions {
            seconds: 20.0,
            ..Default::default()
        },
    )
    .unwrap();
    let yaml = std::fs::read_to_string(&data.config).unwrap();
    // Relative names, as a user writes them.
    let name_of = |key: &str| {
        let line = yaml.lines().find(|l| l.starts_with(key)).unwrap();
        let path = line.split('"').nth(1).unwrap();
        let name = std::path::Path::new(path).file_name().unwrap();
        (line.to_owned(), name.to_str().unwrap().to_owned())
    };
    let (imu_line, imu_name) = name_of("imupath:");
    let (gnss_line, gnss_name) = name_of("gnsspath:");
    let relative = yaml
        .replace(&imu_line, &format!("imupath: \"{imu_name}\""))
        .replace(&gnss_line, &format!("gnsspath: \"{gnss_name}\""));
    std::fs::write(&data.config, relative).unwrap();
    // Another folder with the first half of the IMU file under its name.
    let here = dir.path().join("here");
    std::fs::create_dir(&here).unwrap();
    let imu_text = std::fs::read_to_string(data.config.with_file_name(&imu_name)).unwrap();
    let lines: Vec<&str> = imu_text.lines().collect();
    std::fs::write(
        here.join(&imu_name),
        lines[..lines.len() / 2].join("\n") + "\n",
    )
    .unwrap();
    let run = |cwd: &std::path::Path| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
            .current_dir(cwd)
            .arg("kf-gins")
            .arg(&data.config)
            .arg("--out")
            .arg(&data.out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", output_text(&o));
        (
            String::from_utf8_lossy(&o.stderr).into_owned(),
            output_text(&o),
        )
    };
    let (stderr, text) = run(&here);
    let beside = data.config.with_file_name(&gnss_name);
    assert!(
        stderr.contains(&format!(
            "KF-GINS files: imupath {imu_name}, gnsspath {}",
            beside.display()
        )),
        "{stderr}"
    );
    assert!(
        text.contains("were found in different folders") && text.contains("has another"),
        "{text}"
    );
    // From the configuration's folder: one folder, no warning.
    let (stderr, text) = run(data.config.parent().unwrap());
    assert!(
        stderr.contains(&format!(
            "KF-GINS files: imupath {imu_name}, gnsspath {gnss_name}"
        )),
        "{stderr}"
    );
    assert!(!text.contains("warning"), "{text}");
}

/// `nav kf-gins` with `initpos` in radians: every fix refused, the solution free-inertial from
/// a start 45 deg off, exit 0 and a `.nav` file (no status column) with a warning on stdout.
/// Refused now with the counts and what to check, nothing written; the right start runs.
#[test]
fn kf_gins_that_refused_every_fix_fails() {
    let dir = tempfile::tempdir().unwrap();
    let data = host_tests::filter_bench::generate(
        &dir.path().join("set"),
        &host_tests::filter_bench::FilterBenchOptions {
            seconds: 20.0,
            ..Default::default()
        },
    )
    .unwrap();
    let yaml = std::fs::read_to_string(&data.config).unwrap();
    let line = yaml.lines().find(|l| l.starts_with("initpos:")).unwrap();
    let values: Vec<f64> = line
        .trim_start_matches("initpos: [")
        .trim_end_matches(']')
        .split(',')
        .map(|v| v.trim().parse().unwrap())
        .collect();
    let radians = format!(
        "initpos: [{}, {}, {}]",
        values[0].to_radians(),
        values[1].to_radians(),
        values[2]
    );
    let config = data.config.with_file_name("radians.yaml");
    std::fs::write(&config, yaml.replace(line, &radians)).unwrap();
    let kf_gins = |config: &std::path::Path| {
        nav(&[
            "kf-gins",
            config.to_str().unwrap(),
            "--out",
            data.out.to_str().unwrap(),
        ])
    };
    let o = kf_gins(&config);
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("the filter refused every GNSS fix it was given (position: ")
            && text.contains("and used none: the solution would be free-inertial"),
        "{text}"
    );
    assert!(!data.out.exists(), "{text}");
    let o = kf_gins(&data.config);
    assert!(o.status.success(), "{}", output_text(&o));
}

/// A start in motion that never started said "2 m positions without a velocity, differenced
/// over a second: 11 m/s" whatever the fixes; the oscillator's refusals named parameters no
/// option sets (`drive_time_constant_s`, `readout_noise_m`) or no cause ("0 epochs"). Each
/// describes the user's fixes and options now.
#[test]
fn messages_describe_the_users_fixes_and_options() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let sim = path("sim");
    ok(&[
        "sim",
        "static",
        "--seconds",
        "20",
        "--gnss-rate",
        "10",
        "--gnss-sigma",
        "0.1,0.1,0.1",
        "--grade",
        "mems-tactical",
        "--out",
        &sim,
    ]);
    let (imu, gnss, out) = (
        format!("{sim}/imu.bin"),
        format!("{sim}/gnss.csv"),
        path("x.csv"),
    );
    let o = nav(&[
        "replay",
        "--imu",
        &imu,
        "--gnss",
        &gnss,
        "--imu-noise",
        "mems-tactical",
        "--start-in-motion",
        "--out",
        &out,
    ]);
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains(
            "4 times the noise of its velocity (0.1000 m positions without a velocity, \
             differenced over 0.1000 s: 5.657 m/s)"
        ),
        "{text}"
    );
    let refused = |args: &[&str], expected: &str| {
        let o = nav(args);
        let text = output_text(&o);
        assert_eq!(o.status.code(), Some(1), "{text}");
        assert!(text.contains(expected), "{args:?}: {text}");
    };
    let osc = ["oscillator", "static", "--seconds", "2"];
    refused(
        &[&osc[..], &["--f0-hz", "0.5"]].concat(),
        "--f0-hz must be at least 30 Hz, not 0.5",
    );
    // 1 to 20 Hz passed the check and never gave an epoch, the failure blaming the readout
    // noise (1e-9 m against 2e-5 m): refused with the measured limit.
    refused(
        &[&osc[..], &["--f0-hz", "20"]].concat(),
        "--f0-hz must be at least 30 Hz, not 20: below it the estimator does not lock on the \
         simulated oscillator, even without readout noise",
    );
    refused(
        &[&osc[..], &["--noise-m", "-1"]].concat(),
        "--noise-m must be a finite number >= 0, not -1",
    );
    refused(
        &[&osc[..], &["--noise-m", "1e300"]].concat(),
        "nothing to navigate on (readout noise 1e300 m against an oscillation of 2e-5 m",
    );
    // A run too short for the loop to lock blamed the readout noise too (audit M6).
    refused(
        &["oscillator", "static", "--seconds", "0.1"],
        "nothing to navigate on (its phase-locked loop did not lock in the run's 9 periods of \
         the 100 Hz oscillation",
    );
}

/// A repeated time tag and the second of a swapped pair were counted as "bad interval", the
/// README's "time out of order" staying 0 (the rest of a step back was counted there).
#[test]
fn repeated_and_swapped_time_tags_are_counted_out_of_order() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (bin, csv) = (path("imu.bin"), path("imu.csv"));
    common::generated_recording(std::path::Path::new(&bin), "12");
    ok(&["convert", "--in", &bin, "--out", &csv]);
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let write = |name: &str, lines: &[&str]| {
        std::fs::write(path(name), lines.join("\n") + "\n").unwrap();
        path(name)
    };
    let mut repeated = lines.clone();
    repeated.insert(4501, lines[4500]);
    let mut swapped = lines.clone();
    swapped.swap(4500, 4501);
    let out = path("out.csv");
    let summary = |imu: &str| {
        let text = ok(&common::replay_args(imu, &out, &[]));
        text.lines()
            .find(|l| l.starts_with("samples "))
            .unwrap()
            .to_owned()
    };
    let line = summary(&write("repeated.csv", &repeated));
    assert!(
        line.contains("flagged 1 (non-finite 0, bad interval 0, time out of order 1)"),
        "{line}"
    );
    // The first of the pair comes 2 periods after its predecessor with one period's increment
    // and the one after the pair too (bad intervals, docs/recording-format.md); the second is
    // behind the first.
    let line = summary(&write("swapped.csv", &swapped));
    assert!(
        line.contains("flagged 3 (non-finite 0, bad interval 2, time out of order 1)"),
        "{line}"
    );
}

/// A fix at the recording's first tick (2.5 ms before the first sample's end) was "on another
/// clock"; it lies in the data's time now. Fixes near the data but outside it are named by
/// the nearest; only fixes far from it are said to be on another clock.
#[test]
fn fixes_just_outside_the_data_are_not_on_another_clock() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let sim = path("sim");
    ok(&[
        "sim",
        "land-vehicle",
        "--out",
        &sim,
        "--seconds",
        "20",
        "--gnss-rate",
        "1",
        "--grade",
        "fog",
    ]);
    let gnss = std::fs::read_to_string(format!("{sim}/gnss.csv")).unwrap();
    let mut lines = gnss.lines();
    let header = lines.next().unwrap();
    let first = lines.next().unwrap();
    assert!(first.starts_with("0,"), "{first}");
    let (imu, out) = (format!("{sim}/imu.bin"), path("out.csv"));
    let replay = |t_s: &str| {
        let fix = path(&format!("fix_{t_s}.csv"));
        let row = first.replacen('0', t_s, 1);
        std::fs::write(&fix, format!("{header}\n{row}\n")).unwrap();
        let head = [
            "replay",
            "--imu",
            &imu,
            "--gnss",
            &fix,
            "--imu-noise",
            "fog",
        ];
        nav(&[&head[..], &common::GIVEN, &["--out", &out]].concat())
    };
    let o = replay("0");
    let text = output_text(&o);
    assert!(o.status.success(), "{text}");
    assert!(
        text.contains("WARNING: no GNSS position fix was used") && !text.contains("another clock"),
        "{text}"
    );
    let o = replay("21");
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("the nearest fix, at 21 s, is 1 s after it")
            && !text.contains("another clock"),
        "{text}"
    );
    let o = replay("345600");
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(text.contains("on another clock"), "{text}");
}

/// `nav kf-gins` compared `imudatarate` with the average rate of the epochs, a gap's time
/// included: a 7 s hole in 400 Hz data read as 353 Hz and blamed `imudatarate`. The median
/// interval is the file's rate; a declared rate off it by more than 0.1 % is said (a 401 Hz
/// `imudatarate` for a 400 Hz file ran silently).
#[test]
fn kf_gins_judges_imudatarate_by_the_median_interval() {
    let dir = tempfile::tempdir().unwrap();
    let data = host_tests::filter_bench::generate(
        dir.path(),
        &host_tests::filter_bench::FilterBenchOptions {
            seconds: 20.0,
            ..Default::default()
        },
    )
    .unwrap();
    let yaml = std::fs::read_to_string(&data.config).unwrap();
    let imu_line = yaml.lines().find(|l| l.starts_with("imupath:")).unwrap();
    let imu = imu_line.split('"').nth(1).unwrap();
    let text = std::fs::read_to_string(imu).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // 7 s of the 200 Hz epochs dropped.
    let holed = [&lines[..1000], &lines[2400..]].concat().join("\n") + "\n";
    let holed_path = dir.path().join("holed.txt");
    std::fs::write(&holed_path, holed).unwrap();
    let run = |name: &str, yaml: String| {
        let config = dir.path().join(name);
        std::fs::write(&config, yaml).unwrap();
        let out = dir.path().join("out.nav");
        ok(&[
            "kf-gins",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    let with_hole = yaml.replace(imu_line, &format!("imupath: \"{}\"", holed_path.display()));
    let text = run("holed.yaml", with_hole);
    assert!(
        text.contains("WARNING: 7.") && !text.contains("imudatarate"),
        "{text}"
    );
    let text = run(
        "off.yaml",
        yaml.replace("imudatarate: 200\n", "imudatarate: 200.3\n"),
    );
    assert!(
        text.contains("warning: imudatarate 200.3 Hz, but the epochs of ")
            && text.contains("come every 0.005 s (200 Hz"),
        "{text}"
    );
}

/// A NUL byte inside a value was printed raw: invisible, the message "got 45.5" refused what
/// looked valid. Control characters are shown escaped.
#[test]
fn a_nul_byte_in_a_value_is_shown() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let config = path("nul.txt");
    std::fs::write(&config, "lat-deg = 45.5\0\n").unwrap();
    let o = nav(&["config", &config, "--out", &path("c.bin")]);
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("lat-deg: takes a finite number, got 45.5\\u{0}"),
        "{text}"
    );
    let (bin, csv) = (path("imu.bin"), path("imu.csv"));
    common::generated_recording(std::path::Path::new(&bin), "1");
    ok(&["convert", "--in", &bin, "--out", &csv]);
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    lines[5] = lines[5].replacen(',', ",\0", 2).replacen(",\0", ",", 1);
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    let o = nav(&common::replay_args(&csv, &path("out.csv"), &[]));
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("line 6: column") && text.contains("found '\\u{0}"),
        "{text}"
    );
}

/// A binary recording as `imupath` was read as text: "line 1: expected 7 numbers ..., found
/// 1". Named as what it is.
#[test]
fn a_binary_recording_as_imupath_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let data = host_tests::filter_bench::generate(
        &dir.path().join("set"),
        &host_tests::filter_bench::FilterBenchOptions {
            seconds: 5.0,
            ..Default::default()
        },
    )
    .unwrap();
    let bin = dir.path().join("imu.bin");
    common::generated_recording(&bin, "1");
    let yaml = std::fs::read_to_string(&data.config).unwrap();
    let imu_line = yaml.lines().find(|l| l.starts_with("imupath:")).unwrap();
    let config = dir.path().join("bin.yaml");
    std::fs::write(
        &config,
        yaml.replace(imu_line, &format!("imupath: \"{}\"", bin.display())),
    )
    .unwrap();
    let o = nav(&["kf-gins", config.to_str().unwrap()]);
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("(imupath): a binary IMU recording (it starts with the NAVIMU magic"),
        "{text}"
    );
}

/// `emulate --out E --errors-out E` with E from an earlier run said "output E is the input E":
/// it is the other output. Worded as kf-gins words it.
#[test]
fn two_emulator_outputs_in_one_file_are_named_as_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let sim = path("sim");
    ok(&["sim", "static", "--seconds", "2", "--out", &sim]);
    let (truth, out) = (format!("{sim}/truth.csv"), path("e.csv"));
    std::fs::write(&out, "an earlier run\n").unwrap();
    let o = nav(&[
        "emulate",
        "--truth",
        &truth,
        "--out",
        &out,
        "--errors-out",
        &out,
    ]);
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("--out and --errors-out name the same file") && !text.contains("input"),
        "{text}"
    );
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "an earlier run\n");
}

/// `nav convert` and `nav replay` of the recording `input` each exit 1 with a message holding
/// every one of `expected`, and leave no `out`.
fn refused_by_convert_and_replay(input: &str, out: &str, expected: &[&str]) {
    for args in [
        vec!["convert", "--in", input, "--out", out],
        common::replay_args(input, out, &[]),
    ] {
        let o = nav(&args);
        let text = output_text(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {text}");
        assert!(
            expected.iter().all(|e| text.contains(e)),
            "{args:?}: expected {expected:?} in: {text}"
        );
        assert!(!std::path::Path::new(out).exists(), "{args:?}: {out} left");
    }
}

/// `temp_c` was not range-checked: 1,000,000 deg C replayed silently and `nav convert` copied
/// it. Refused with its line and column; an empty field and NaN are both "unknown".
#[test]
fn an_imu_csv_temperature_no_sensor_has_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (bin, csv) = (path("imu.bin"), path("imu.csv"));
    common::generated_recording(std::path::Path::new(&bin), "1");
    ok(&["convert", "--in", &bin, "--out", &csv]);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("t_s,") && text.lines().next().unwrap().ends_with(",temp_c"));
    // Field 8 of data line `k` (line k + 2) set to `temp`.
    let with = |k: usize, temp: &str| {
        let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let mut fields: Vec<&str> = lines[k + 1].split(',').collect();
        fields[7] = temp;
        lines[k + 1] = fields.join(",");
        lines.join("\n") + "\n"
    };
    let (odd, out) = (path("odd.csv"), path("out.bin"));
    for temp in ["1e6", "inf", "-300"] {
        std::fs::write(&odd, with(3, temp)).unwrap();
        refused_by_convert_and_replay(
            &odd,
            &out,
            &["line 5: column temp_c: ", "deg C is outside [-100, 200]"],
        );
    }
    for temp in ["", "NaN"] {
        std::fs::write(&odd, with(3, temp)).unwrap();
        ok(&["convert", "--in", &odd, "--out", &out]);
    }
}

/// A binary record's temperature was not range-checked: 1e30 deg C replayed and converted
/// silently where the CSV row's 500 deg C is refused. Refused by the same rule, with the
/// record's byte offset; NaN is "unknown" in both.
#[test]
fn a_binary_temperature_no_sensor_has_is_refused_as_in_csv() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (bin, odd, out) = (path("imu.bin"), path("odd.bin"), path("out.csv"));
    common::generated_recording(std::path::Path::new(&bin), "11");
    let clean = host_tests::recording_io::read(std::path::Path::new(&bin)).unwrap();
    for temp in [1e30_f32, f32::NEG_INFINITY, 500.0, -101.0] {
        let mut rec = clean.clone();
        rec.records[4].temperature_c = temp;
        host_tests::recording_io::write(std::path::Path::new(&odd), &rec).unwrap();
        refused_by_convert_and_replay(
            &odd,
            &out,
            &[
                "byte offset 208 (record 4): temperature ",
                " deg C is outside [-100, 200], not a sensor's temperature",
            ],
        );
    }
    let o = nav(&common::replay_args(&odd, &out, &[]));
    assert!(output_text(&o).contains("temperature -101 deg C"));
    // Compact at any magnitude (it printed 31 digits).
    let mut rec = clean.clone();
    rec.records[4].temperature_c = 1e30;
    host_tests::recording_io::write(std::path::Path::new(&odd), &rec).unwrap();
    let o = nav(&common::replay_args(&odd, &out, &[]));
    assert!(output_text(&o).contains("temperature 1e30 deg C"));
    let mut rec = clean;
    for r in &mut rec.records {
        r.temperature_c = f32::NAN;
    }
    rec.records[5].temperature_c = 200.0;
    host_tests::recording_io::write(std::path::Path::new(&odd), &rec).unwrap();
    ok(&["convert", "--in", &odd, "--out", &out]);
    ok(&common::replay_args(&odd, &out, &[]));
}

/// `nav sim --gnss-jump 1,1e9,...` (a jump of 1e9 s in a 5 s run) and a jump given twice (its
/// offset added twice) were simulated silently. Refused, nothing written.
#[test]
fn sim_refuses_outliers_past_the_run_or_given_twice() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let out = out.to_str().unwrap();
    let sim = |extra: &[&str]| {
        let mut args = vec![
            "sim",
            "static",
            "--seconds",
            "5",
            "--out",
            out,
            "--gnss-rate",
            "1",
        ];
        args.extend_from_slice(extra);
        nav(&args)
    };
    for (extra, expected) in [
        (
            &["--gnss-jump", "1,1e9,1,1,1"][..],
            "GNSS jump at 1 s for 1e9 s ends at 1.000000001e9 s, past the run's end at 5 s: \
             give a length of at most 5 s",
        ),
        (
            &["--gnss-ramp", "2,30,1,1,1"],
            "GNSS ramp at 2 s for 30 s ends at 32 s, past the run's end at 5 s",
        ),
        (
            &["--gnss-jump", "1,2,1,1,1", "--gnss-jump", "1,2,1,1,1"],
            "GNSS jump at 1 s is given twice",
        ),
        (
            &["--gnss-nan", "2", "--gnss-nan", "2"],
            "--gnss-nan 2 is given twice",
        ),
    ] {
        let o = sim(extra);
        let text = output_text(&o);
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {text}");
        assert!(text.contains(expected), "{extra:?}: {text}");
        assert!(!std::path::Path::new(out).exists(), "{extra:?}");
    }
    // To the run's end: taken.
    let o = sim(&["--gnss-jump", "1,5,1,1,1"]);
    assert!(o.status.success(), "{}", output_text(&o));
}

/// A recording not in UTF-8 said "line 6: stream did not contain valid UTF-8" (KF-GINS text)
/// or "malformed CSV: invalid UTF-8: invalid utf-8: invalid UTF-8 in field 8 near byte index
/// 4" (CSV): the byte where the text stops being UTF-8 is named, in a user's words.
#[test]
fn a_recording_not_in_utf8_names_its_line_and_byte() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let mut text: Vec<u8> = (1..=400)
        .flat_map(|k| format!("{} 0 0 0 0 0 -0.0245\n", f64::from(k) * 0.0025).into_bytes())
        .collect();
    // Line 6, "0.015 0 0 0 0 0 -0.0245", with its last 5 as cp1252's e-acute.
    let line6: usize = text
        .split(|&b| b == b'\n')
        .take(5)
        .map(|l| l.len() + 1)
        .sum();
    let bad = line6 + text[line6..].iter().position(|&b| b == b'\n').unwrap() - 1;
    text[bad] = 0xe9;
    let kf = path("imu.txt");
    std::fs::write(&kf, &text).unwrap();
    let o = nav(&common::replay_args(&kf, &path("out.csv"), &[]));
    let said = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains(&format!(
            "imu.txt: line 6: not UTF-8 text (byte {bad}, 0xe9): save the file as UTF-8"
        )),
        "{said}"
    );
    let (bin, csv) = (path("imu.bin"), path("imu.csv"));
    common::generated_recording(std::path::Path::new(&bin), "1");
    ok(&["convert", "--in", &bin, "--out", &csv]);
    let mut text = std::fs::read(&csv).unwrap();
    let line3: usize = text
        .split(|&b| b == b'\n')
        .take(2)
        .map(|l| l.len() + 1)
        .sum();
    text.insert(line3 + 1, 0xe9);
    std::fs::write(&csv, &text).unwrap();
    let o = nav(&["convert", "--in", &csv, "--out", &path("out.bin")]);
    let said = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains(&format!(
            "imu.csv: line 3: not UTF-8 text (field 1 of the row at byte {line3}, its byte 1): \
             save the file as UTF-8"
        )),
        "{said}"
    );
}

/// A GNSS file of binary garbage was "stream did not contain valid UTF-8", no line or byte
/// (its first line was read as text to tell gnss-ins-sim's files from the others); now as the
/// IMU readers say it.
#[test]
fn a_gnss_file_that_is_not_text_is_told_by_line_and_byte() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (bin, gnss) = (path("imu.bin"), path("gnss.txt"));
    common::generated_recording(std::path::Path::new(&bin), "1");
    std::fs::write(&gnss, b"\xd2\x01\x7f garbage\n\x00\xff").unwrap();
    let o = nav(&common::replay_args(
        &bin,
        &path("out.csv"),
        &["--gnss", &gnss],
    ));
    let said = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains("gnss.txt: line 1: not UTF-8 text (byte 0, 0xd2): save the file as UTF-8"),
        "{said}"
    );
}

/// IMU time tags in seconds of week that roll over to 0 made an aided run fail as "GNSS on
/// another clock" with the IMU data covering "604780 .. 20 s", no word of the rollover; the
/// step back of a week is named in the refusal.
#[test]
fn an_aided_run_refused_after_a_week_rollover_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    let sim = sim.to_str().unwrap();
    ok(&[
        "sim",
        "land-vehicle",
        "--seconds",
        "40",
        "--gnss-rate",
        "1",
        "--format",
        "csv",
        "--out",
        sim,
    ]);
    let text = std::fs::read_to_string(format!("{sim}/imu.csv")).unwrap();
    // The first 20 s at the end of a GPS week, the rest from 0.
    let mut lines = text.lines();
    let mut wrapped = lines.next().unwrap().to_owned() + "\n";
    for line in lines {
        let (t, rest) = line.split_once(',').unwrap();
        let t_s: f64 = t.parse().unwrap();
        let t_s = if t_s <= 20.0 {
            t_s + 604_780.0
        } else {
            t_s - 20.0
        };
        wrapped += &format!("{t_s},{rest}\n");
    }
    let imu = dir.path().join("wrapped.csv");
    std::fs::write(&imu, wrapped).unwrap();
    let (imu, out) = (imu.to_str().unwrap(), format!("{sim}/out.csv"));
    let gnss = format!("{sim}/gnss.csv");
    let mut args = vec!["replay", "--imu", imu, "--gnss", &gnss, "--out", &out];
    args.extend(common::GIVEN);
    let o = nav(&args);
    let said = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains("another clock")
            && said.contains("the time tags stepped back by 604799.99")
            && said.contains("(to t = 0.003 s): a GPS week rollover"),
        "{said}"
    );
}

/// `imudatarate: 401` for a 400 Hz file ran without a word on stderr (its warning was on
/// stdout, among the results). A declared rate off the file's by more than 0.1 % is warned of
/// on stderr; one within it is not.
#[test]
fn kf_gins_warns_of_an_imudatarate_off_the_file_on_stderr() {
    let dir = tempfile::tempdir().unwrap();
    let data = host_tests::filter_bench::generate(
        dir.path(),
        &host_tests::filter_bench::FilterBenchOptions {
            seconds: 5.0,
            ..Default::default()
        },
    )
    .unwrap();
    let yaml = std::fs::read_to_string(&data.config).unwrap();
    assert!(yaml.contains("imudatarate: 200\n"), "{yaml}");
    let out = dir.path().join("out.nav");
    for (rate, warned) in [("201", true), ("200.1", false)] {
        let config = dir.path().join("rate.yaml");
        std::fs::write(
            &config,
            yaml.replace("imudatarate: 200\n", &format!("imudatarate: {rate}\n")),
        )
        .unwrap();
        let o = nav(&[
            "kf-gins",
            config.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let (stdout, stderr) = (
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr),
        );
        assert!(o.status.success(), "{stdout}{stderr}");
        assert!(!stdout.contains("imudatarate"), "{stdout}");
        assert_eq!(
            stderr.contains(&format!(
                "warning: imudatarate {rate} Hz, but the epochs of "
            )),
            warned,
            "{rate}: {stderr}"
        );
    }
}
