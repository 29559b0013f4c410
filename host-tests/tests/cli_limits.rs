//! Absurd numeric options of `nav` (1e300, inf, a duration no memory holds) are refused with a
//! message naming the value readably and its range, with status 1: no panic (101), no
//! allocation abort, no silently computed nonsense.

mod common;

use common::{generated_recording, nav, output_text, replay_args};

/// Runs `nav args`, expecting a refusal (status 1) whose text contains every one of `expected`
/// and no number of more than 30 digits; returns the text.
fn refused(args: &[&str], expected: &[&str]) -> String {
    let o = nav(args);
    let text = output_text(&o);
    assert_eq!(o.status.code(), Some(1), "nav {args:?}: {text}");
    assert!(!text.contains("panicked"), "nav {args:?}: {text}");
    for e in expected {
        assert!(text.contains(e), "nav {args:?}: expected {e:?} in {text}");
    }
    assert!(
        longest_digits(&text) <= 30,
        "nav {args:?}: unreadable number in {text}"
    );
    text
}

/// The most digits in a row in `text`.
fn longest_digits(text: &str) -> usize {
    text.split(|c: char| !c.is_ascii_digit())
        .map(str::len)
        .max()
        .unwrap_or(0)
}

/// The oscillator's length and frequency: a capacity-overflow panic (1e300) or an allocation
/// abort (1e6 s: 44 GB of readouts) before; now the readout count is refused with its limit.
#[test]
fn oscillator_lengths_beyond_memory_are_refused() {
    refused(
        &["oscillator", "static", "--seconds", "1e300"],
        &["1e300 s", "at most 1.000e7"],
    );
    refused(
        &["oscillator", "static", "--seconds", "1e6"],
        &["1e6 s", "at most 1.000e7"],
    );
    refused(
        &["oscillator", "static", "--seconds", "2", "--f0-hz", "1e300"],
        &["5e301 readouts/s", "at most 1.000e7"],
    );
    refused(
        &["osc-bench", "--seconds", "inf"],
        &["seconds must be a finite number >= 0, not inf"],
    );
    refused(&["osc-bench", "--seconds", "1e300"], &["at most 1.000e7"]);
}

/// `osc-bench --noise-ratio`: 1e300, inf, NaN and 0 printed a table of zeros; a negative
/// value was a clap usage error without the range.
#[test]
fn oscillator_bench_ratio_out_of_range_is_refused() {
    for ratio in ["1e300", "inf", "NaN", "0", "-5"] {
        refused(
            &["osc-bench", "--seconds", "0.1", "--noise-ratio", ratio],
            &["w0/|omega| must be within [1, 1e6]"],
        );
    }
}

/// `osc-bench` too short for an epoch (0.01 s, 0.3 s): the first table said "no epochs" but the
/// noise table's rows and the damped run's line printed `0.00e0` errors, a perfect score from no
/// data. Every row and the line now say there was no epoch.
#[test]
fn oscillator_bench_without_epochs_prints_no_errors() {
    for seconds in ["0.01", "0.3"] {
        let o = nav(&["osc-bench", "--seconds", seconds]);
        let text = output_text(&o);
        assert_eq!(o.status.code(), Some(0), "{text}");
        assert!(!text.contains("0.00e0"), "--seconds {seconds}: {text}");
        let noise_rows: Vec<&str> = text
            .lines()
            .skip_while(|l| !l.starts_with("| noise [m]"))
            .skip(2)
            .take_while(|l| l.starts_with('|'))
            .collect();
        assert_eq!(noise_rows.len(), 5, "{text}");
        for row in noise_rows {
            assert!(row.contains("| no epochs | no epochs | - | - |"), "{row}");
        }
        let damped = text
            .lines()
            .find(|l| l.starts_with("With damping ratio"))
            .unwrap_or_else(|| panic!("no damped line in {text}"));
        assert!(damped.contains("): no epochs ("), "{damped}");
    }
}

/// A negative number given to a numeric option was taken for a flag by clap ("unexpected
/// argument '-1' found"): it now reaches the option's own range check.
#[test]
fn negative_numbers_reach_the_range_checks() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.bin");
    let out = out.to_str().unwrap();
    refused(
        &[
            "convert",
            "--gnss",
            "--in",
            "fixes.csv",
            "--out",
            out,
            "--gnss-latency",
            "-1",
        ],
        &["--gnss-latency must be within 0 to 1 s (the receiver's output latency), not -1"],
    );
    refused(
        &["bench", "outages", "--outage-seconds", "-5"],
        &["--outage-seconds must be from 1 to 170 s", "not -5"],
    );
    // Counts and seeds are unsigned: clap names the value and the option.
    let o = nav(&["align-bench", "family", "--runs", "-1"]);
    let text = output_text(&o);
    assert!(
        text.contains("invalid value '-1' for '--runs <RUNS>'"),
        "{text}"
    );
}

/// `generate` and `sim` lengths: 1e300 s said "18446744073709551615 samples do not fit the
/// binary format" (a saturated count), 1e7 s aborted allocating 160 GB.
#[test]
fn recording_lengths_beyond_memory_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.bin");
    let out = out.to_str().unwrap();
    for seconds in ["1e300", "1e7"] {
        let text = refused(
            &["generate", "--out", out, "--seconds", seconds],
            &["samples: a simulated recording holds at most 5.000e7"],
        );
        assert!(text.contains(&format!("{seconds} s at 400 Hz")), "{text}");
        let sim = dir.path().join("sim");
        refused(
            &[
                "sim",
                "static",
                "--out",
                sim.to_str().unwrap(),
                "--seconds",
                seconds,
            ],
            &["a simulated recording holds at most 5.000e7"],
        );
        assert!(
            !sim.exists(),
            "nav sim --seconds {seconds} wrote {}",
            sim.display()
        );
    }
    assert!(!dir.path().join("g.bin").exists());
    refused(
        &["sim", "static", "--out", out, "--rate", "1e300"],
        &["the rate must be within [10, 40000] Hz, the rates a replay navigates, not 1e300"],
    );
    // Written before at up to 100 kHz, then refused by every replay.
    refused(
        &["sim", "static", "--out", out, "--rate", "50000"],
        &["within [10, 40000] Hz", "not 50000"],
    );
    refused(
        &[
            "sim",
            "static",
            "--out",
            out,
            "--rate",
            "5",
            "--truth-rate",
            "5",
        ],
        &["below 10 Hz every increment is longer than the 0.1 s the navigator accepts"],
    );
    refused(
        &["sim", "static", "--out", out, "--truth-rate", "1e300"],
        &["the truth rate 1e300 Hz must divide the IMU rate 400 Hz"],
    );
}

/// `sim` with a truth of one row: `--truth-rate 1e-300` (a truth interval of 1e300 s) and a
/// 0.004 s run (2 samples, a truth row every 8) wrote the start alone as the truth, and
/// `scenario.txt` printed the rate in 300 digits. The truth needs 2 rows.
#[test]
fn sim_truth_of_one_row_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s");
    let out = out.to_str().unwrap();
    refused(
        &[
            "sim",
            "static",
            "--seconds",
            "2",
            "--rate",
            "400",
            "--truth-rate",
            "1e-300",
            "--out",
            out,
        ],
        &[
            "2 s at 400 Hz gives 800 samples, fewer than the 4.000e302 between truth rows at \
             1e-300 Hz: the truth needs at least 2 rows",
            "the run must be at least 1.000e300 s",
        ],
    );
    refused(
        &["sim", "static", "--seconds", "0.004", "--out", out],
        &[
            "0.004 s at 400 Hz gives 2 samples, fewer than the 8 between truth rows at 50 Hz",
            "the run must be at least 0.02000 s or the truth rate higher",
        ],
    );
    assert!(!dir.path().join("s").exists());
}

/// `generate --roll/--pitch/--yaw 1e300` wrote a recording of a meaningless orientation (and
/// printed the angle in 301 digits).
#[test]
fn generate_angles_out_of_range_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("g.bin");
    let out = out.to_str().unwrap();
    for (option, range) in [
        ("--roll", "roll must be within [-180, 180] deg"),
        ("--pitch", "pitch must be within [-90, 90] deg"),
        ("--yaw", "yaw must be within [-360, 360] deg"),
    ] {
        refused(
            &["generate", "--out", out, "--seconds", "1", option, "1e300"],
            &[range, "not 1e300"],
        );
    }
    refused(
        &["generate", "--out", out, "--seconds", "1", "--pitch", "95"],
        &["pitch must be within [-90, 90] deg, not 95"],
    );
    assert!(!dir.path().join("g.bin").exists());
}

/// `replay --imu-noise ideal` on a perfectly still, noise-free recording failed with "base not
/// still: ... scatter infx and infx their noise": the alignment divided by the zero noise.
/// Refused now with the reason; a real grade aligns the same recording.
#[test]
fn replay_with_a_noise_free_model_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("imu.bin");
    let out = dir.path().join("o.csv");
    generated_recording(&imu, "12");
    let (imu, out_text) = (imu.to_str().unwrap(), out.to_str().unwrap());
    let text = refused(
        &replay_args(imu, out_text, &["--imu-noise", "ideal"]),
        &[
            "--imu-noise ideal: the alignment judges whether the base is still, and weighs its \
           measurements, by the IMU's noise, and a noise-free model has none; give the grade",
        ],
    );
    assert!(!text.contains("inf"), "{text}");
    assert!(!out.exists());
    let o = nav(&replay_args(imu, out_text, &["--imu-noise", "fog"]));
    assert!(o.status.success(), "{}", output_text(&o));
}

/// `replay`'s site and window: 1e300 printed 301 digits; `--align-seconds -1` (or 0, -0) was
/// reported as "alignment window 0.0025 s", the one sample it rounded to.
#[test]
fn replay_site_and_window_read_as_typed() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("imu.bin");
    let out = dir.path().join("o.csv");
    generated_recording(&imu, "12");
    let replay = |site: [&str; 4], expected: &str| {
        let args = [
            "replay",
            "--imu",
            imu.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--lat",
            site[0],
            "--lon",
            site[1],
            "--h",
            site[2],
            "--align-seconds",
            site[3],
        ];
        refused(&args, &[expected]);
        assert!(!out.exists());
    };
    replay(
        ["1e300", "7.5", "150", "10"],
        "latitude 1e300 deg is not within [-90, 90]",
    );
    replay(
        ["45", "-1e300", "150", "10"],
        "longitude -1e300 deg is not within [-180, 180]",
    );
    replay(["45", "7.5", "1e300", "10"], "height 1e300 m is not within");
    replay(
        ["45", "7.5", "150", "1e300"],
        "alignment window 1e300 s is longer than 86400 s",
    );
    for window in ["-1", "0", "-0"] {
        replay(
            ["45", "7.5", "150", window],
            &format!("alignment window {window} s is shorter than the static method's minimum"),
        );
    }
}

/// `replay`'s alignment options beyond any IMU or base: accepted in f64 (`--bias-prior 1e300`,
/// `--base-translation 1e300` navigated), refused in f32 as "the IMU noise / the lever arm /
/// the base motion must be finite and not negative" (1e100 is infinite in f32), which named
/// neither the option nor its range. Now the same refusal in both precisions.
#[test]
fn replay_alignment_options_beyond_range_are_refused_in_both_precisions() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("imu.bin");
    let out = dir.path().join("o.csv");
    generated_recording(&imu, "12");
    for precision in ["f32", "f64"] {
        for (option, value, expected) in [
            (
                "--bias-prior",
                "1e300",
                "bias prior scale 1e300 must be finite",
            ),
            (
                "--bias-prior",
                "1e10",
                "bias prior scale 1e10 must be finite",
            ),
            (
                "--base-translation",
                "1e100",
                "the base translation 1-sigma must be 0 to 100 m",
            ),
            (
                "--base-translation",
                "1e10",
                "the base translation 1-sigma must be 0 to 100 m",
            ),
            (
                "--lever-arm-sigma",
                "1e100",
                "lever arm 1-sigma 1.000e100 m is beyond 100 m",
            ),
            (
                "--lever-arm",
                "1e300,0,0",
                "lever arm 1.000e300 m is beyond 100 m",
            ),
        ] {
            let args = replay_args(
                imu.to_str().unwrap(),
                out.to_str().unwrap(),
                &["--precision", precision, option, value],
            );
            refused(&args, &[expected]);
            assert!(!out.exists());
        }
    }
}

/// A still recording aligned by the static method under a noise model whose gyro bias hides
/// the Earth rate (a consumer part's, declared for a better one): the run said ALIGNED, then
/// NAV, with a yaw 1-sigma of 9697 deg, and the aided run failed on the filter's own limit. Now
/// refused before any sample, as the fine and sway methods refuse, in both precisions (the
/// tactical preset's turn-on bias, 180 deg/h, too); the FOG's still aligns.
#[test]
fn a_static_alignment_whose_gyros_cannot_find_north_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("imu.bin");
    let out = dir.path().join("o.csv");
    generated_recording(&imu, "12");
    let (imu, out_s) = (imu.to_str().unwrap(), out.to_str().unwrap());
    for precision in ["f32", "f64"] {
        for grade in ["mems-consumer", "mems-tactical"] {
            let args = replay_args(
                imu,
                out_s,
                &["--precision", precision, "--imu-noise", grade],
            );
            refused(
                &args,
                &["gyros too coarse to find north", "give the heading"],
            );
            assert!(!out.exists());
        }
        let args = replay_args(
            imu,
            out_s,
            &["--precision", precision, "--imu-noise", "fog"],
        );
        let o = nav(&args);
        assert!(o.status.success(), "{}", output_text(&o));
        std::fs::remove_file(&out).unwrap();
    }
}

/// An IMU standing on end (`generate --pitch 90 --roll 1.5 --yaw 30`, exact data) aligned in
/// f32 said roll 0, pitch 89.972566, yaw 0 deg, and its last row roll 180, pitch 90, yaw 180:
/// its yaw minus roll, 28.5 deg, lost (24 times the heading's 1-sigma), where f64 gave it. The
/// angles of an f32 attitude are now taken within f32's singular band: the same rotation in
/// both precisions.
#[test]
fn an_imu_on_end_keeps_its_heading_in_f32() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("imu.bin");
    let out = dir.path().join("o.csv");
    let o = nav(&[
        "generate",
        "--out",
        imu.to_str().unwrap(),
        "--seconds",
        "12",
        "--pitch",
        "90",
        "--roll",
        "1.5",
        "--yaw",
        "30",
    ]);
    assert!(o.status.success(), "{}", output_text(&o));
    let (imu, out) = (imu.to_str().unwrap(), out.to_str().unwrap());
    for precision in ["f32", "f64"] {
        let o = nav(&replay_args(
            imu,
            out,
            &["--precision", precision, "--imu-noise", "fog"],
        ));
        let text = output_text(&o);
        assert!(o.status.success(), "{text}");
        for line in ["alignment (static)", "final at t ="] {
            let l = text.lines().find(|l| l.starts_with(line)).unwrap();
            let angle = |name: &str| -> f64 {
                let at = l.find(&format!("{name} ")).unwrap() + name.len() + 1;
                l[at..].split(' ').next().unwrap().parse().unwrap()
            };
            let (roll, pitch, yaw) = (angle("roll"), angle("pitch"), angle("yaw"));
            assert!(pitch > 89.999, "{precision}: {l}");
            assert!((yaw - roll - 28.5).abs() < 0.01, "{precision}: {l}");
        }
    }
}

/// `nav config` (the board's f32 run): `base-translation = 1e300` was refused as "the lever
/// arm must be finite and not negative", naming the lever-arm line too.
#[test]
fn config_text_base_translation_beyond_range_names_its_key() {
    let dir = tempfile::tempdir().unwrap();
    let text = dir.path().join("run.txt");
    std::fs::write(
        &text,
        "base-translation = 1e300\nlat-deg = 45\nlon-deg = 7\nh-m = 150\n",
    )
    .unwrap();
    let out = dir.path().join("run.bin");
    let msg = refused(
        &[
            "config",
            text.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        &["the base translation 1-sigma must be 0 to 100 m"],
    );
    assert!(!msg.contains("lever arm"), "{msg}");
    assert!(!out.exists());
}

/// A `nav config` run in a folder of its own: the text file `run.txt` it reads and the frame
/// `run.bin` it writes.
struct ConfigRun {
    _dir: tempfile::TempDir,
    text: std::path::PathBuf,
    out: std::path::PathBuf,
}

impl ConfigRun {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let (text, out) = (dir.path().join("run.txt"), dir.path().join("run.bin"));
        Self {
            _dir: dir,
            text,
            out,
        }
    }

    /// `config TEXT --out OUT`.
    fn args(&self) -> [&str; 4] {
        [
            "config",
            self.text.to_str().unwrap(),
            "--out",
            self.out.to_str().unwrap(),
        ]
    }
}

/// `nav config` named the wrong keys of a refusal: a negative `lever-arm-sigma` or
/// `align-seconds`, or a negative `base-translation`, was "keys lat-deg (line 1), ..." (every
/// alignment key the file gave); and `imu-rate-hz = 1e300` was reported as "inf Hz" (the frame's
/// f32). Each refusal now names its own line and key, a figure beyond f32 its value as typed.
#[test]
fn config_text_refusals_name_their_own_key() {
    let run = ConfigRun::new();
    let (text, out, args) = (&run.text, &run.out, run.args());
    let site = "lat-deg = 45\nlon-deg = 7\nh-m = 150\n";
    for (line, expected) in [
        (
            "lever-arm-sigma = -1",
            "run.txt:4: refused (reason code 8): the lever arm's 1-sigma must be finite and not negative\n",
        ),
        (
            "align-seconds = -5",
            "run.txt:4: refused (reason code 8): alignment window -5 s is shorter than the static method's minimum of 10 s\n",
        ),
        (
            "align-method = inertial\nbase-translation = -1",
            "run.txt:5: refused (reason code 8): the base motion's 1-sigma must be finite and not negative\n",
        ),
        (
            "imu-rate-hz = 1e300",
            "run.txt:4: imu-rate-hz: takes a finite number within f32's range (3.4e38), got 1e300",
        ),
    ] {
        std::fs::write(text, format!("{site}{line}\n")).unwrap();
        let msg = refused(&args, &[expected]);
        assert!(!msg.contains("lat-deg (line 1)"), "{msg}");
        assert!(!out.exists());
    }
}

/// `nav config` refused the documented bound 0.1 of the IMU's other figures (0.1 in f32
/// widened to f64 is 0.10000000149, beyond 0.1), with aiding off and on; the next value beyond
/// is still refused. With aiding off, a figure's refusal said "GNSS aiding:".
#[test]
fn config_text_figures_accept_their_documented_bound() {
    let run = ConfigRun::new();
    let (text, out, args) = (&run.text, &run.out, run.args());
    let site = "lat-deg = 45\nlon-deg = 7\nh-m = 150\n";
    for key in [
        "gyro-scale-sigma",
        "accel-scale-sigma",
        "gyro-cross-coupling-rad",
        "accel-cross-coupling-rad",
        "gyro-g-sensitivity",
    ] {
        for aiding in ["off", "on"] {
            std::fs::write(text, format!("{site}aiding = {aiding}\n{key} = 0.1\n")).unwrap();
            let o = nav(&args);
            assert!(
                o.status.success(),
                "{key} = 0.1, aiding {aiding}: {}",
                output_text(&o)
            );
            std::fs::remove_file(out).unwrap();
            std::fs::write(
                text,
                format!("{site}aiding = {aiding}\n{key} = 0.1000001\n"),
            )
            .unwrap();
            let msg = refused(&args, &["run.txt:5: refused (reason code 9): "]);
            assert!(
                msg.contains("must be 0 to 0.1") || msg.contains("at most 0.1"),
                "{msg}"
            );
            assert!(!out.exists());
        }
    }
    std::fs::write(text, format!("{site}aiding = off\ngyro-scale-sigma = 0\n")).unwrap();
    let msg = refused(
        &args,
        &["run.txt:5: refused (reason code 9): IMU error figures: a scale-factor 1-sigma"],
    );
    assert!(!msg.contains("GNSS aiding"), "{msg}");
    std::fs::write(
        text,
        format!("{site}aiding = off\ngyro-g-sensitivity = 1\n"),
    )
    .unwrap();
    refused(
        &args,
        &[
            "run.txt:5: refused (reason code 9): IMU error figures: a cross-coupling or g-sensitivity 1-sigma must be 0 to 0.1",
        ],
    );
}

/// Scenario lengths and angles of `nav sim --set`: the land vehicle's `seconds=1e300` (or inf) planned
/// its route lap by lap until an allocation aborted; the flight's `climb_s` or `still_s` of
/// 1e300 summed its ground distance second by second without end.
#[test]
fn scenario_lengths_beyond_range_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let out = out.to_str().unwrap();
    for (scenario, set, expected) in [
        (
            "land-vehicle",
            "seconds=1e300",
            "seconds must be at most 1e6 (11 days), not 1e300",
        ),
        (
            "land-vehicle",
            "seconds=inf",
            "seconds must be a finite number, not inf",
        ),
        ("static", "seconds=1e300", "seconds must be at most 1e6"),
        (
            "flight",
            "climb_s=1e300",
            "climb_s must be at most 1e6 s, not 1e300",
        ),
        (
            "flight",
            "still_s=1e300",
            "still_s must be within [0, 1e6] s, not 1e300",
        ),
        (
            "flight",
            "still_s=-1",
            "still_s must be within [0, 1e6] s, not -1",
        ),
        // Angles beyond a turn: accepted before, as an orientation no one meant.
        (
            "static",
            "roll_deg=1e300",
            "roll_deg 1e300 is not within [-180, 180] deg",
        ),
        (
            "static",
            "yaw_deg=400",
            "yaw_deg 400 is not within [-360, 360] deg",
        ),
        (
            "ship-rocking",
            "heading_deg=1e300",
            "heading_deg 1e300 is not within [-360, 360] deg",
        ),
        (
            "ship-rocking",
            "roll_phase_deg=-1e300",
            "roll_phase_deg -1e300 is not within [-360, 360] deg",
        ),
        // The land vehicle's was not checked: its truth started at yaw -3.7 deg.
        (
            "land-vehicle",
            "heading_deg=1e300",
            "heading_deg 1e300 is not within [-360, 360] deg",
        ),
    ] {
        // A length given by --set alone (with --seconds too, two lengths are refused).
        let seconds: &[&str] = if set.starts_with("seconds=") {
            &[]
        } else {
            &["--seconds", "5"]
        };
        refused(
            &[
                &["sim", scenario, "--out", out][..],
                seconds,
                &["--set", set],
            ]
            .concat(),
            &[expected],
        );
    }
    // `nav bench consistency` plans its land-vehicle runs the same way, checked before its
    // table's header is printed.
    refused(
        &[
            "bench",
            "consistency",
            "--runs",
            "2",
            "--cells",
            "1",
            "--seconds",
            "1e300",
        ],
        &["seconds must be at most 1e6"],
    );
}

/// `nav sim --seconds S --set seconds=T`: two lengths that disagree are refused (--seconds
/// was taken without a word); the same length twice is one.
#[test]
fn scenario_lengths_given_twice_must_agree() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let out = out.to_str().unwrap();
    let sim = ["sim", "static", "--out", out, "--seconds", "5", "--set"];
    refused(
        &[&sim[..], &["seconds=20"]].concat(),
        &["--seconds 5 and --set seconds=20: two lengths; give one"],
    );
    assert!(!dir.path().join("sim").exists());
    let o = nav(&[&sim[..], &["seconds=5"]].concat());
    assert_eq!(o.status.code(), Some(0), "{}", output_text(&o));
}

/// `nav bench consistency --cells 0,9` printed an empty table with status 0.
#[test]
fn bench_cells_outside_the_table_are_refused() {
    refused(
        &["bench", "consistency", "--runs", "2", "--cells", "1,9"],
        &["--cells 9: the table has cells 1 to 6"],
    );
}

/// An absurd `--runs` allocated every seed before failing; `--threads 0` ran on one thread.
#[test]
fn bench_runs_threads_and_families_are_bounded() {
    for (what, args, expected) in [
        (
            "consistency",
            ["--runs", "1"],
            "--runs must be from 2 to 100000, not 1",
        ),
        (
            "consistency",
            ["--runs", "999999999999"],
            "--runs must be from 2 to 100000, not 999999999999",
        ),
        (
            "consistency",
            ["--threads", "0"],
            "--threads must be from 1 to 256, not 0",
        ),
        (
            "outages",
            ["--runs", "0"],
            "--runs must be from 1 to 100000, not 0",
        ),
        (
            "outages",
            ["--threads", "1000"],
            "--threads must be from 1 to 256, not 1000",
        ),
    ] {
        let mut argv = vec!["bench", what];
        argv.extend(args);
        refused(&argv, &[expected]);
    }
}

/// A recording below 10 Hz (every increment longer than the 0.1 s the navigator takes) ended
/// its alignment with "0 of 50 samples used (100 rejected)", its rate unnamed; a PSINS interval
/// of 1e9 ms was refused as "alignment window 1e6 s is longer than 86400 s" for a 10 s window.
/// Refused now with the rate, before the alignment, and nothing written.
#[test]
fn a_recording_below_10_hz_is_refused_with_its_rate() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("slow.csv");
    let mut text =
        String::from("t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_x_mps,dv_y_mps,dv_z_mps\n");
    for k in 1..=100 {
        text.push_str(&format!("{},0,0,0,0,0,-1.961\n", f64::from(k) * 0.2));
    }
    std::fs::write(&imu, text).unwrap();
    let out = dir.path().join("sol.csv");
    let (imu, out_s) = (imu.to_str().unwrap(), out.to_str().unwrap());
    refused(
        &replay_args(imu, out_s, &[]),
        &[
            "sampling rate 5 Hz is not within [10, 40000] Hz (below 10 Hz every increment is longer than the 0.1 s the navigator accepts)",
        ],
    );
    assert!(!out.exists());
}

/// `nav align-bench family --seconds 1e300` printed the window in 301 digits.
#[test]
fn align_bench_window_reads_as_typed() {
    refused(
        &["align-bench", "family", "--runs", "1", "--seconds", "1e300"],
        &["alignment windows must be within (0, 300] s, not 1e300"],
    );
}

/// An option of another `nav align-bench` table was ignored without a word (`seed003 --seconds
/// 5` ran its default 50 runs; `lasergyro --runs 5` the whole recording; `family --member 3
/// --runs 200` one member), `--threads 0` or 1000 ran on 1 or 64 threads, and `--runs` had no
/// bound. Refused now, before anything runs, as `nav bench` refuses its own.
#[test]
fn align_bench_options_of_another_table_are_refused() {
    for (args, expected) in [
        (
            &["seed003", "--seconds", "5"][..],
            "--seconds is an option of `nav align-bench family`, not of `nav align-bench seed003`",
        ),
        (
            &["lasergyro", "--runs", "5"],
            "--runs is an option of `nav align-bench seed002` and `nav align-bench seed003` and \
             `nav align-bench family`, not of `nav align-bench lasergyro`",
        ),
        (
            &["seed002", "--threads", "8"],
            "--threads is an option of `nav align-bench seed003` and `nav align-bench family`",
        ),
        (
            &["family", "--grade", "rlg"],
            "--grade is an option of `nav align-bench seed002`",
        ),
        (
            &["seed002", "--data", "x.imu"],
            "--data is an option of `nav align-bench lasergyro`",
        ),
        (
            &["seed003", "--member", "3"],
            "--member is an option of `nav align-bench family`",
        ),
        (
            &["family", "--member", "3", "--runs", "200"],
            "--runs is not an option of `nav align-bench family --member K`",
        ),
        (
            &["family", "--threads", "0"],
            "--threads must be from 1 to 256, not 0",
        ),
        (
            &["seed003", "--threads", "1000"],
            "--threads must be from 1 to 256, not 1000",
        ),
        // The range of `nav bench --threads` (it was 1 to 64 here, 1 to 256 there).
        (
            &["seed003", "--threads", "257"],
            "--threads must be from 1 to 256, not 257",
        ),
        // `--runs` had no bound: 99999999999999 ran silently until killed. `nav bench`'s.
        (
            &["seed003", "--runs", "99999999999999"],
            "--runs must be from 1 to 100000, not 99999999999999",
        ),
        (
            &["family", "--runs", "0"],
            "--runs must be from 1 to 100000, not 0",
        ),
    ] {
        let mut argv = vec!["align-bench"];
        argv.extend(args);
        refused(&argv, &[expected]);
    }
}

/// A KF-GINS configuration whose files need not exist: refusals of `nav kf-gins` that come
/// before it opens them.
const KF_GINS_CONFIG: &str = "imupath: imu.txt
gnsspath: gnss.txt
outputpath: .
imudatalen: 7
imudatarate: 200
starttime: 0
endtime: -1
initpos: [45.0, 7.5, 250.0]
initvel: [0.0, 0.0, 0.0]
initatt: [0.0, 0.0, 0.0]
initgyrbias: [0, 0, 0]
initaccbias: [0, 0, 0]
initgyrscale: [0, 0, 0]
initaccscale: [0, 0, 0]
initposstd: [0.1, 0.1, 0.2]
initvelstd: [0.05, 0.05, 0.05]
initattstd: [0.5, 0.5, 1.0]
imunoise:
  arw: [0.24, 0.24, 0.24]
  vrw: [0.24, 0.24, 0.24]
  gbstd: [50.0, 50.0, 50.0]
  abstd: [250.0, 250.0, 250.0]
  gsstd: [1000.0, 1000.0, 1000.0]
  asstd: [1000.0, 1000.0, 1000.0]
  corrtime: 1.0
antlever: [0.0, 0.0, 0.0]
";

/// A KF-GINS configuration's refusal names its file once, with the key (it was
/// `KF-GINS configuration k.yaml: k.yaml: key ...`); one that comes from elsewhere in the
/// run is still told as the configuration's, its own file named once as well (it was
/// `GNSS file gnss.txt (gnsspath): gnss.txt: No such file ...`).
#[test]
fn a_kf_gins_refusal_names_its_configuration_once() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("k.yaml");
    let config = config.to_str().unwrap();
    std::fs::write(
        config,
        KF_GINS_CONFIG.replace("corrtime: 1.0", "corrtime: 0"),
    )
    .unwrap();
    let text = refused(
        &["kf-gins", config],
        &["KF-GINS configuration", "k.yaml: key 'imunoise.corrtime'"],
    );
    assert_eq!(text.matches("k.yaml").count(), 1, "{text}");
    std::fs::write(config, KF_GINS_CONFIG).unwrap();
    let text = refused(&["kf-gins", config], &["KF-GINS configuration", "gnsspath"]);
    assert_eq!(text.matches("k.yaml").count(), 1, "{text}");
    // And the GNSS file, which names itself, once (in the refusal: the run's first line
    // names the files it reads).
    let refusal = text.lines().find(|l| l.starts_with("error:")).unwrap();
    assert_eq!(refusal.matches("gnss.txt").count(), 1, "{text}");
}

/// Inputs given as the output were overwritten: `kf-gins ok.yaml --out ok.yaml` the
/// configuration, `emulate --errors E --out E` (or `--errors-out E`) the error file,
/// `replay --calibration C --out C` the calibration. Refused now, the file untouched.
#[test]
fn configuration_inputs_are_not_overwritten_by_the_output() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (config, errors, truth, calibration) = (
        path("ok.yaml"),
        path("err.txt"),
        path("tr.csv"),
        path("cal.txt"),
    );
    std::fs::write(&config, KF_GINS_CONFIG).unwrap();
    std::fs::write(&errors, "gyro-bias-deg-h = 0.01 0.01 0.01\n").unwrap();
    std::fs::write(&truth, "t_s\n").unwrap();
    std::fs::write(&calibration, "calibration\n").unwrap();
    let unchanged = || {
        assert_eq!(std::fs::read_to_string(&config).unwrap(), KF_GINS_CONFIG);
        assert_eq!(
            std::fs::read_to_string(&errors).unwrap(),
            "gyro-bias-deg-h = 0.01 0.01 0.01\n"
        );
        assert_eq!(
            std::fs::read_to_string(&calibration).unwrap(),
            "calibration\n"
        );
    };
    refused(&["kf-gins", &config, "--out", &config], &["is the input"]);
    unchanged();
    for out in ["--out", "--errors-out"] {
        let other = path("displayed.csv");
        let mut args = vec!["emulate", "--truth", &truth, "--errors", &errors];
        args.extend([out, &errors]);
        if out == "--errors-out" {
            args.extend(["--out", &other]);
        }
        refused(&args, &["is the input", "err.txt"]);
        unchanged();
    }
    let imu = path("imu.bin");
    let args = replay_args(&imu, &calibration, &["--calibration", &calibration]);
    refused(&args, &["is the input", "cal.txt"]);
    unchanged();
    // `nav config`: the prefix was given twice ("output X: output X is the input X").
    let text_config = path("run.txt");
    std::fs::write(&text_config, "lat-deg = 45\n").unwrap();
    let msg = refused(
        &["config", &text_config, "--out", &text_config],
        &[&format!(
            "error: output {text_config} is the input {text_config}: refusing to overwrite it"
        )],
    );
    assert_eq!(msg.matches("output ").count(), 1, "{msg}");
    assert_eq!(
        std::fs::read_to_string(&text_config).unwrap(),
        "lat-deg = 45\n"
    );
}

/// `nav kf-gins` whose output folder is a file (outputpath, or `--out`'s folder) said the
/// folder "does not exist", beside the file a user can see; it says what the path is now.
#[test]
fn a_kf_gins_output_folder_that_is_a_file_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (config, file) = (path("ok.yaml"), path("file.txt"));
    std::fs::write(&config, KF_GINS_CONFIG).unwrap();
    std::fs::write(&file, "not a folder\n").unwrap();
    let inside = format!("{file}/result.nav");
    refused(
        &["kf-gins", &config, "--out", &inside],
        &[
            "the output folder",
            "file.txt of the trajectory (--out) is not a folder",
        ],
    );
    let missing = path("missing/result.nav");
    refused(
        &["kf-gins", &config, "--out", &missing],
        &["missing of the trajectory (--out) does not exist"],
    );
}

/// Figures of `nav sim`'s receiver and of `nav kf-gins` printed in hundreds of digits:
/// `--gnss-rate 1e300` ("a 1000... Hz receiver"), `--gnss-lever-arm 1e300,0,0`,
/// `imudatarate: 1e300`; a 1e300 m spike's line (355 characters) of a run that succeeded.
#[test]
fn receiver_and_kf_gins_figures_read_as_typed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let out = out.to_str().unwrap();
    let sim = ["sim", "static", "--seconds", "5", "--out", out];
    let with = |extra: &[&'static str]| [&sim[..], extra].concat();
    refused(
        &with(&["--gnss-rate", "1e300"]),
        &["a 1e300 Hz receiver on truth at 50 Hz"],
    );
    refused(
        &with(&["--gnss-rate", "1", "--gnss-lever-arm", "1e300,0,0"]),
        &["lever arm 1e300,0,0 m: must be finite and within 100 m"],
    );
    // Refused now (a fix at the pole with its usual sigma).
    refused(
        &with(&["--gnss-rate", "1", "--gnss-spike", "2,1e300,0,0"]),
        &["offsets within 100000 m on each axis"],
    );

    let data = host_tests::filter_bench::generate(
        dir.path(),
        &host_tests::filter_bench::FilterBenchOptions {
            seconds: 20.0,
            ..Default::default()
        },
    )
    .unwrap();
    let text = std::fs::read_to_string(&data.config).unwrap();
    assert!(text.contains("imudatarate: 200\n"), "{text}");
    let config = dir.path().join("rate.yaml");
    std::fs::write(
        &config,
        text.replace("imudatarate: 200\n", "imudatarate: 1e300\n"),
    )
    .unwrap();
    let nav_out = dir.path().join("rate.nav");
    refused(
        &[
            "kf-gins",
            config.to_str().unwrap(),
            "--out",
            nav_out.to_str().unwrap(),
        ],
        &[
            "imudatarate 1e300 Hz does not match",
            "differ from 1e-300 s",
        ],
    );
    assert!(!nav_out.exists());
}

/// `convert --in imu.bin --out c1.txt` wrote the binary format under a name the readers take
/// for KF-GINS text (`.imu`: PSINS; `.nav`: a KF-GINS trajectory); refused as `convert --gnss`
/// refuses it, nothing written.
#[test]
fn a_binary_recording_under_a_text_name_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("imu.bin");
    generated_recording(&imu, "1");
    for (name, format) in [
        ("c1.txt", "KF-GINS text file's name"),
        ("c1.IMU", "PSINS text file's name"),
        // A KF-GINS trajectory's name was taken (audit L13).
        ("c1.nav", "KF-GINS trajectory's name (.nav)"),
    ] {
        let out = dir.path().join(name);
        refused(
            &[
                "convert",
                "--in",
                imu.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ],
            &[format, "name it .bin"],
        );
        assert!(!out.exists());
    }
    for name in ["c1.bin", "c1.csv", "c1.dat"] {
        let out = dir.path().join(name);
        let o = nav(&[
            "convert",
            "--in",
            imu.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", output_text(&o));
    }
}

/// `--out` at a FIFO or a directory: the rename replaced it (`--out /dev/full` made a regular
/// file of the device, as root); refused now, naming the path, the FIFO left as it was.
#[cfg(unix)]
#[test]
fn an_output_that_is_not_a_regular_file_is_refused() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.csv");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap();
    assert!(made.success());
    let imu = dir.path().join("imu.bin");
    generated_recording(&imu, "1");
    let imu = imu.to_str().unwrap();
    for (out, what) in [(fifo.as_path(), "a FIFO"), (dir.path(), "a directory")] {
        let out = out.to_str().unwrap();
        refused(
            &replay_args(imu, out, &[]),
            &[out, &format!("is not a regular file ({what})")],
        );
        refused(
            &["convert", "--in", imu, "--out", out],
            &[&format!("is not a regular file ({what})")],
        );
    }
    let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
    assert!(kind.is_fifo());
}

/// `replay --start-speed`: the start in motion's heading threshold is bounded (0.5 to
/// 100 m/s: below, the track's direction is noise; above, no vehicle would ever start), and
/// it needs `--start-in-motion`.
#[test]
fn start_speed_out_of_range_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let imu = dir.path().join("imu.bin");
    generated_recording(&imu, "5");
    let gnss = dir.path().join("gnss.csv");
    std::fs::write(
        &gnss,
        "t_s,lat_deg,lon_deg,h_m,sigma_n_m,sigma_e_m,sigma_d_m\n1,45,7.5,250,1,1,2\n",
    )
    .unwrap();
    let out = dir.path().join("sol.csv");
    let base = [
        "replay",
        "--imu",
        imu.to_str().unwrap(),
        "--gnss",
        gnss.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--start-in-motion",
        "--start-speed",
    ];
    for speed in ["0", "-1", "0.1", "NaN", "inf", "1e300", "101"] {
        refused(
            &[&base[..], &[speed]].concat(),
            &["--start-speed must be within 0.5 to 100 m/s"],
        );
        assert!(!out.exists());
    }
    // A given start has no heading threshold.
    refused(
        &[&base[..7], &common::GIVEN[..], &["--start-speed", "2"]].concat(),
        &["--start-speed is the heading threshold of a --start-in-motion"],
    );
    assert!(!out.exists());
}

/// Refusals that named neither the option, the key nor the cause (the messages of before in
/// the comments); each names them now.
#[test]
fn refusals_name_the_option_the_key_and_the_cause() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let imu = path("imu.bin");
    generated_recording(std::path::Path::new(&imu), "12");
    let out = path("out.csv");
    // "calibration line 1: unknown key".
    let cal = path("units.cal");
    std::fs::write(&cal, "gyro_bias_deg_h = 1 0 0\n").unwrap();
    refused(
        &replay_args(&imu, &out, &["--calibration", &cal]),
        &[
            "--calibration",
            "units.cal: calibration line 1: unknown key `gyro_bias_deg_h` (known: \
             gyro_bias_rad_s, gyro_scale,",
        ],
    );
    // "the lever arm must be finite and not negative", "the base motion must be ...".
    refused(
        &replay_args(&imu, &out, &["--lever-arm-sigma", "-1"]),
        &["--lever-arm-sigma -1: the lever arm's 1-sigma must be finite and not negative"],
    );
    refused(
        &replay_args(&imu, &out, &["--base-translation", "NaN"]),
        &["--base-translation NaN: the base motion's 1-sigma must be finite and not negative"],
    );
    // Accepted: an unknown lever arm of 1-sigma 0 is a known one of 0 m.
    refused(
        &replay_args(&imu, &out, &["--lever-arm-sigma", "0"]),
        &[
            "--lever-arm-sigma 0: an unknown lever arm's 1-sigma of 0 m",
            "--lever-arm 0,0,0",
        ],
    );
    // "creating FILE: File exists (os error 17)".
    refused(
        &["sim", "static", "--seconds", "1", "--out", &imu],
        &[
            "--out",
            "imu.bin is a file: nav sim writes a folder of files",
        ],
    );
    // "reading X: X: No such file or directory (os error 2): No such file or directory ...".
    let text = refused(
        &["align-bench", "lasergyro", "--data", "/nonexistent"],
        &["/nonexistent: No such file or directory"],
    );
    assert_eq!(text.matches("No such file").count(), 1, "{text}");
    // "/nonexistent: No such file or directory": one of a replay's inputs, not named.
    refused(
        &replay_args(&imu, &out, &["--calibration", "/nonexistent"]),
        &["--calibration /nonexistent: /nonexistent: No such file or directory"],
    );
    // "line 1: expected 7 numbers ..., found 1": an IMU recording given as GNSS fixes.
    refused(
        &["convert", "--gnss", "--in", &imu, "--out", &path("g.bin")],
        &["imu.bin: an IMU recording (it starts with the NAVIMU magic"],
    );
    // `nav emulate`: "gyro_scale 2.000 is beyond 0.1219" named the SI key, dropped the sign
    // and gave no file or line.
    let sim = path("sim");
    let o = common::nav(&["sim", "static", "--seconds", "2", "--out", &sim]);
    assert!(o.status.success(), "{}", output_text(&o));
    let truth = format!("{sim}/truth.csv");
    let errors = path("errors.txt");
    std::fs::write(&errors, "# scale\ngyro_scale_ppm = -1e10 0 0\n").unwrap();
    let emulated = path("emulated.csv");
    refused(
        &[
            "emulate", "--truth", &truth, "--out", &emulated, "--errors", &errors,
        ],
        &["errors.txt line 2: gyro_scale_ppm -1", "is beyond +-"],
    );
    // An empty `--set ''` was accepted.
    refused(
        &[
            "emulate", "--truth", &truth, "--out", &emulated, "--set", "",
        ],
        &["--set #1 ``: empty; give `key = v1 v2 v3`"],
    );
    // A 301-digit member number was printed in full (audit L7).
    refused(
        &[
            "sim",
            "family",
            "--set",
            "member=1e300",
            "--out",
            &path("fam"),
        ],
        &["member must be a whole number from 0 to 9e15, not 1e300"],
    );
    // A quantity given by two `--set`s silently took the second (audit L10); a `--set` over
    // the error file's quantity is its documented override.
    refused(
        &[
            "emulate",
            "--truth",
            &truth,
            "--out",
            &emulated,
            "--set",
            "gyro_drift_deg_h = 1 1 1",
            "--set",
            "gyro_drift_rad_s = 0 0 1e-6",
        ],
        &[
            "--set #2 `gyro_drift_rad_s = 0 0 1e-6`: `gyro_drift_rad_s` gives a quantity \
             --set #1 `gyro_drift_deg_h = 1 1 1` gave already",
        ],
    );
    std::fs::write(&errors, "gyro_drift_deg_h = 1 1 1\n").unwrap();
    let o = common::nav(&[
        "emulate",
        "--truth",
        &truth,
        "--out",
        &emulated,
        "--errors",
        &errors,
        "--set",
        "gyro_drift_deg_h = 2 2 2",
    ]);
    assert!(o.status.success(), "{}", output_text(&o));
}

/// `--base-translation` with the static alignment was taken silently (its log byte for byte
/// the one without it: the static method takes a still base only), and so was `nav config`'s
/// `base-translation` without a method that uses it. Refused with the reason (the rule is
/// nav-core's `AlignMethod::takes_base_translation`, the firmware's command line refuses it
/// too); taken with a method that uses it.
#[test]
fn base_translation_with_the_static_alignment_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (imu, out) = (path("imu.bin"), path("out.csv"));
    generated_recording(std::path::Path::new(&imu), "12");
    refused(
        &replay_args(&imu, &out, &["--base-translation", "3"]),
        &[
            "--base-translation: the base translation is the base motion of the inertial, fine and sway alignments",
        ],
    );
    refused(
        &replay_args(
            &imu,
            &out,
            &["--align-method", "static", "--base-translation", "0.5"],
        ),
        &["the static one takes a still base only"],
    );
    let o = nav(&replay_args(
        &imu,
        &out,
        &["--align-method", "inertial", "--base-translation", "0"],
    ));
    // Taken (this still base's 10 s are too short for the inertial method's heading).
    assert!(
        !output_text(&o).contains("--base-translation"),
        "{}",
        output_text(&o)
    );
    // `nav config` wrote a frame with it (the board took the frame and ignored the value).
    let text = dir.path().join("run.txt");
    let frame = path("run.bin");
    let site = "lat-deg = 45\nlon-deg = 7\nh-m = 150\n";
    std::fs::write(&text, format!("{site}base-translation = 0.5\n")).unwrap();
    let msg = refused(
        &["config", text.to_str().unwrap(), "--out", &frame],
        &[
            "run.txt:4: base-translation: ",
            "the static one takes a still base only",
        ],
    );
    assert!(!std::path::Path::new(&frame).exists(), "{msg}");
    std::fs::write(
        &text,
        format!("{site}align-method = inertial\nbase-translation = 0.5\n"),
    )
    .unwrap();
    let o = nav(&["config", text.to_str().unwrap(), "--out", &frame]);
    assert!(o.status.success(), "{}", output_text(&o));
}

/// An empty `--calibration` file (or one of comments) was taken as identity without a word,
/// where `nav config` refuses an empty file: a truncated or wrong file passed unnoticed.
/// Refused with the reason; a file with a key runs.
#[test]
fn an_empty_calibration_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (imu, out) = (path("imu.bin"), path("out.csv"));
    generated_recording(std::path::Path::new(&imu), "12");
    let cal = path("empty.cal");
    for text in ["", "\u{feff}\r\n", "# gyro_bias_rad_s = 1e-6 0 0\n\n  \n"] {
        std::fs::write(&cal, text).unwrap();
        refused(
            &replay_args(&imu, &out, &["--calibration", &cal]),
            &[
                "--calibration ",
                "empty.cal: no 'key = values' line (an empty or truncated file, or the wrong \
                 one): give the keys (gyro_bias_rad_s, gyro_scale,",
            ],
        );
        assert!(!std::path::Path::new(&out).exists());
    }
    std::fs::write(&cal, "\u{feff}gyro_bias_rad_s = 0 0 0 # none\n").unwrap();
    let o = nav(&replay_args(&imu, &out, &["--calibration", &cal]));
    assert!(o.status.success(), "{}", output_text(&o));
}

/// `nav kf-gins` of an empty configuration said "missing key 'imunoise'", one key of many;
/// a scalar where 3 numbers belong said "line 19 column 8: expected sequence start".
#[test]
fn kf_gins_configuration_shapes_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("kf.yaml");
    let config = config.to_str().unwrap();
    std::fs::write(config, "# KF-GINS configuration file\n\n").unwrap();
    refused(
        &["kf-gins", config],
        &["kf.yaml: no keys (an empty file, or comments only)"],
    );
    std::fs::write(config, "imunoise:\n  arw: 0.2\n").unwrap();
    refused(
        &["kf-gins", config],
        &[
            "kf.yaml: key 'imunoise.arw': expected 3 numbers [deg/sqrt(h)], found a single number (0.2)",
        ],
    );
}

/// `--init-std` refusals said "a zero claims an exactly known state" of -1 and NaN, and "must
/// be 0 to 6,400 km" of 1e300, where 0 is refused; a binary header's rate of 1e300 printed
/// 301 digits. Each names its value compactly and the cause now.
#[test]
fn init_std_and_header_rate_refusals_say_what_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (imu, out) = (path("imu.bin"), path("out.csv"));
    generated_recording(std::path::Path::new(&imu), "12");
    for (std, expected) in [
        (
            "-1,0.1,1",
            "the position 1-sigma -1 m in \"-1,0.1,1\" must be above 0 and at most 6.4e6 m",
        ),
        (
            "NaN,1,1",
            "the position 1-sigma NaN m in \"NaN,1,1\" must be above 0",
        ),
        (
            "1e300,0.1,1",
            "the position 1-sigma 1e300 m in \"1e300,0.1,1\" must be above 0 and at most 6.4e6 m",
        ),
        ("1,1,1,1,1e9,1,1,1,1", "the velocity 1-sigma 1e9 m/s in"),
        ("1,0.1,400", "the attitude 1-sigma 400 deg in"),
        (
            "1,0,1",
            "the velocity 1-sigma in \"1,0,1\" is 0: a zero claims an exactly known state",
        ),
        (
            "1,x,1",
            "the velocity 1-sigma \"x\" in \"1,x,1\" is not a number",
        ),
        ("1,1", "expected three or nine 1-sigmas"),
    ] {
        // clap's refusal of an option's value: status 2.
        let o = nav(&[
            "replay",
            "--imu",
            &imu,
            "--gnss",
            &imu,
            "--out",
            &out,
            "--init-pos",
            "45,7.5,150",
            "--init-vel",
            "0,0,0",
            "--init-att",
            "0,0,0",
            "--init-std",
            std,
        ]);
        let text = output_text(&o);
        assert_eq!(o.status.code(), Some(2), "{text}");
        assert!(text.contains(expected), "{std}: {text}");
        if std != "1,0,1" {
            assert!(!text.contains("a zero claims"), "{text}");
        }
    }
    // The header's rate 1e300 against 400 Hz timestamps.
    let mut bytes = std::fs::read(&imu).unwrap();
    let mut head: [u8; 48] = bytes[..48].try_into().unwrap();
    let mut header = hal_adapters::recording::Header::decode(&head).unwrap();
    header.rate_hz = 1e300;
    head = header.encode();
    bytes[..48].copy_from_slice(&head);
    let odd = path("rate.bin");
    std::fs::write(&odd, bytes).unwrap();
    refused(
        &replay_args(&odd, &out, &[]),
        &["the header's rate 1e300 Hz contradicts the timestamps"],
    );
}

/// Options that named the wrong thing or were taken silently: `sim --set speed=NaN` named a
/// parameter `speed` the scenario does not have (the value was checked before the key); a
/// `--set` key given twice kept the last (`nav config` refuses one); `bench filter --dir FILE`
/// said "File exists"; `align-bench lasergyro --data DIR` said "line 1: Is a directory";
/// `sim --gnss-nan 2 --gnss-nan 2` made one fix NaN, silently;
/// `bench consistency --first-seed u64::MAX` wrapped its seeds to 0.
#[test]
fn options_are_refused_by_what_they_name() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let (sim, file) = (path("sim"), path("file"));
    std::fs::write(&file, "").unwrap();
    let sim_with = |set: &[&'static str]| {
        let mut args = vec!["sim", "land-vehicle", "--out", &sim];
        for s in set {
            args.extend(["--set", s]);
        }
        refused(&args, &[])
    };
    let text = sim_with(&["speed=NaN"]);
    assert!(text.contains("unknown parameter \"speed\""), "{text}");
    let text = sim_with(&["seconds=5", "seconds=6"]);
    assert!(
        text.contains("--set seconds is given twice (5 and 6)"),
        "{text}"
    );
    refused(
        &[
            "sim",
            "static",
            "--seconds",
            "5",
            "--out",
            &sim,
            "--gnss-rate",
            "1",
            "--gnss-nan",
            "2",
            "--gnss-nan",
            "2",
        ],
        &["--gnss-nan 2 is given twice"],
    );
    refused(
        &["bench", "filter", "--dir", &file],
        &["--dir", "file is a file: nav bench filter writes a folder"],
    );
    refused(
        &[
            "align-bench",
            "lasergyro",
            "--data",
            dir.path().to_str().unwrap(),
        ],
        &["is a folder: give the laser-gyro recording"],
    );
    refused(
        &[
            "bench",
            "consistency",
            "--first-seed",
            "18446744073709551615",
            "--runs",
            "2",
            "--seconds",
            "1",
            "--cells",
            "1",
        ],
        &["--first-seed 18446744073709551615 + --runs 2 x --families 1 overflows the seeds"],
    );
}
