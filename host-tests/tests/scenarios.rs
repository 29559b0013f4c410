//! The exact generator against the mechanization and against independent derivations.
//!
//! With error-free sensors in f64 the mechanization's error is its own (coning/sculling
//! truncation and rounding), so the bounds — 0.5 m and 1e-4 deg after the whole flight
//! and after 1 h of ship rocking — hold only if the generator's increments are exact.

use host_tests::trajectory::scenarios::{FlightPlan, Scenario, geodesic_direct, geodesic_inverse};
use host_tests::trajectory::{Generator, Sampling, Trajectory, generate};
use host_tests::truth::{MeridianFlight, Truth, distance_m};
use nav_core::attitude::quat_from_f64;
use nav_core::earth::LocalEarth;
use nav_core::{MechanizationConfig, NavState, Position, Strapdown};

const RATE_HZ: f64 = 400.0;

fn start_state(t: &Truth) -> NavState<f64> {
    NavState {
        q_b_n: quat_from_f64(&t.q_b_ned),
        v_eb_n: t.v_eb_ned,
        position: Position::from_radians(t.lat, t.lon, t.h),
    }
}

/// Largest position [m] and attitude [deg] errors of an f64 mechanization fed the exact
/// increments of `traj` for `seconds` (checked every second), and the final ones.
fn round_trip(traj: &dyn Trajectory, seconds: f64) -> (f64, f64) {
    let g = Generator::new(traj);
    let mut nav = Strapdown::new(start_state(&g.truth()), MechanizationConfig::default());
    let (mut worst_pos, mut worst_att): (f64, f64) = (0.0, 0.0);
    generate(traj, Sampling::new(RATE_HZ, seconds), |k, _, inc, truth| {
        nav.step(inc).unwrap();
        if (k + 1) % 400 == 0 {
            let s = nav.state().to_ned_frame();
            let p = &s.position;
            let pos = distance_m(
                p.lat_f64(),
                p.lon_f64(),
                p.h_f64(),
                truth.lat,
                truth.lon,
                truth.h,
            );
            let att = (truth.q_b_ned.inverse() * s.q_b_n).angle().to_degrees();
            worst_pos = worst_pos.max(pos);
            worst_att = worst_att.max(att);
        }
    });
    (worst_pos, worst_att)
}

#[test]
fn flight_round_trip_within_half_a_metre() {
    let Scenario::Flight(plan) = Scenario::by_name("flight").unwrap() else {
        unreachable!()
    };
    let flight = plan.build().unwrap();
    let seconds = flight.duration_s();
    let (pos, att) = round_trip(&flight, seconds);
    println!(
        "flight UWGG-ULLI {:.0} km, {seconds:.0} s: worst position error {pos:.3e} m, attitude {att:.3e} deg",
        flight.distance_m / 1e3
    );
    assert!(pos < 0.5, "{pos} m");
    assert!(att < 1e-4, "{att} deg");
}

#[test]
fn ship_rocking_one_hour_round_trip() {
    let s = Scenario::by_name("ship-rocking").unwrap();
    let traj = s.build().unwrap();
    let (pos, att) = round_trip(traj.as_ref(), 3600.0);
    println!(
        "ship rocking sea state 6, 1 h: worst position error {pos:.3e} m, attitude {att:.3e} deg"
    );
    assert!(pos < 0.5, "{pos} m");
    assert!(att < 1e-4, "{att} deg");
}

#[test]
fn every_scenario_round_trips_for_a_while() {
    for name in Scenario::NAMES {
        let traj = Scenario::by_name(name).unwrap().build().unwrap();
        let seconds = traj.duration_s().min(300.0);
        let (pos, att) = round_trip(traj.as_ref(), seconds);
        println!("{name}: {seconds} s, worst position error {pos:.3e} m, attitude {att:.3e} deg");
        assert!(pos < 0.05 && att < 1e-5, "{name}: {pos} m, {att} deg");
    }
}

/// Richardson-style check of the increments' accuracy: 4 RK4 steps per sample against 16; RK4's
/// error falls 256-fold, so the difference bounds the default's error.
#[test]
fn increments_converge_below_the_required_accuracy() {
    for name in Scenario::NAMES {
        let traj = Scenario::by_name(name).unwrap().build().unwrap();
        let mut a = Generator::new(traj.as_ref());
        let mut b = Generator::with_substeps(traj.as_ref(), 16);
        let s = Sampling::new(RATE_HZ, 200.0);
        let (mut dth, mut dv): (f64, f64) = (0.0, 0.0);
        for k in 0..s.n {
            let t = s.t_ns(k) as f64 * 1e-9;
            let (ia, _) = a.advance_to(t);
            let (ib, _) = b.advance_to(t);
            dth = dth.max((ia.delta_theta_ib_b - ib.delta_theta_ib_b).amax());
            dv = dv.max((ia.delta_v_ib_b - ib.delta_v_ib_b).amax());
        }
        println!("{name}: largest change with 4x finer steps {dth:.1e} rad, {dv:.1e} m/s");
        assert!(dth < 1e-11 && dv < 1e-9, "{name}: {dth} rad, {dv} m/s");
    }
}

/// A northward flight at constant speed: the generic generator against the hand-derived
/// closed-form rates of [`MeridianFlight`].
#[test]
fn agrees_with_the_closed_form_meridian_flight() {
    use host_tests::trajectory::{Motion, Point};
    use nav_core::Vector3;
    struct North(f64);
    impl Trajectory for North {
        fn start(&self) -> Point {
            Point {
                lat: 45f64.to_radians(),
                lon: 0.5,
                h: 10_000.0,
                aux: 0.0,
            }
        }
        fn duration_s(&self) -> f64 {
            60.0
        }
        fn motion(&self, _: f64, _: &Point) -> Motion {
            Motion {
                v_eb_n: Vector3::new(self.0, 0.0, 0.0),
                ..Motion::default()
            }
        }
    }
    let m = MeridianFlight {
        lat0: 45f64.to_radians(),
        lon0: 0.5,
        h: 10_000.0,
        speed: 250.0,
    };
    let mut expected = Vec::new();
    m.run(1.0 / RATE_HZ, 4000, |inc, t| expected.push((*inc, *t)));
    let mut k = 0;
    generate(
        &North(250.0),
        Sampling::new(RATE_HZ, 10.0),
        |_, _, inc, t| {
            let (e, et) = &expected[k];
            assert!(
                (inc.delta_theta_ib_b - e.delta_theta_ib_b).amax() < 1e-15,
                "{k}"
            );
            assert!((inc.delta_v_ib_b - e.delta_v_ib_b).amax() < 1e-12, "{k}");
            assert!((t.lat - et.lat).abs() < 1e-14);
            k += 1;
        },
    );
    assert_eq!(k, 4000);
}

#[test]
fn the_flight_follows_the_geodesic_to_its_destination() {
    let plan = FlightPlan::default();
    let flight = plan.build().unwrap();
    let mut g = Generator::new(&flight);
    let mut max_h: f64 = 0.0;
    let mut max_speed: f64 = 0.0;
    let end = flight.duration_s();
    let mut t = 0.0;
    while t < end {
        t = (t + 1.0).min(end);
        let (_, truth) = g.advance_to(t);
        max_h = max_h.max(truth.h);
        max_speed = max_speed.max(truth.v_eb_ned.xy().norm());
    }
    let last = g.truth();
    let miss = distance_m(
        last.lat,
        last.lon,
        0.0,
        plan.to_lat_deg.to_radians(),
        plan.to_lon_deg.to_radians(),
        0.0,
    );
    println!(
        "geodesic {:.1} km; flight {end:.0} s, lands {miss:.0} m from the destination, ceiling {max_h:.1} m",
        flight.distance_m / 1e3
    );
    assert!(miss < 500.0, "{miss} m");
    assert!((max_h - plan.cruise_h_m).abs() < 1e-6);
    assert!((max_speed - plan.cruise_mps).abs() < 1e-9);
    assert!(last.v_eb_ned.norm() < 1e-12);
}

#[test]
fn geodesics_on_the_equator_and_a_meridian() {
    let e = LocalEarth::new(0.0, 0.0);
    // Along the equator the geodesic is the equator: length a * dlon, azimuth 90 deg.
    let (az, s) = geodesic_inverse(0.0, 0.0, 0.0, 0.1).unwrap();
    assert!((az - std::f64::consts::FRAC_PI_2).abs() < 1e-9, "{az}");
    assert!((s - e.r_transverse * 0.1).abs() < 1e-3, "{s}");
    // Along a meridian: the meridian arc, the integral of M dlat (Simpson).
    let (lat1, lat2) = (0.3_f64, 0.9_f64);
    let (az, s) = geodesic_inverse(lat1, 1.0, lat2, 1.0).unwrap();
    let n = 1000;
    let h = (lat2 - lat1) / n as f64;
    let m = |x: f64| LocalEarth::new(x, 0.0).r_meridian;
    let arc: f64 = (0..n)
        .map(|k| {
            let a = lat1 + k as f64 * h;
            h / 6.0 * (m(a) + 4.0 * m(a + h / 2.0) + m(a + h))
        })
        .sum();
    assert!(az.abs() < 1e-9 && (s - arc).abs() < 1e-3, "{az} {s} {arc}");
    // Direct and inverse agree.
    let (la, lo) = geodesic_direct(0.9, 0.5, 2.0, 700e3);
    let (az2, s2) = geodesic_inverse(0.9, 0.5, la, lo).unwrap();
    assert!((az2 - 2.0).abs() < 1e-9 && (s2 - 700e3).abs() < 1e-3);
}

/// A route over a pole (80 N, 0 E to 80 N, 180 E) is refused naming the pole (was: "the
/// geodesic did not converge (antipodal or coincident points?)", neither of which it is); one
/// passing 50 m from it is flown.
#[test]
fn a_route_over_a_pole_is_refused_naming_it() {
    let r = |lon2_deg: f64| {
        geodesic_inverse(
            80_f64.to_radians(),
            0.0,
            80_f64.to_radians(),
            lon2_deg.to_radians(),
        )
    };
    for lon2 in [180.0, 179.999] {
        let e = r(lon2).unwrap_err().to_string();
        assert!(
            e.contains("North Pole") && e.contains("at least 1 km"),
            "{e}"
        );
    }
    assert!(r(179.995).is_ok());
}

#[test]
fn scenario_parameters_are_checked() {
    let mut s = Scenario::by_name("ship-rocking").unwrap();
    s.set("sea_state", 3.0).unwrap();
    s.set("lat_deg", 60.0).unwrap();
    let d = s.describe();
    let get = |k: &str| d.iter().find(|p| p.0 == k).unwrap().1;
    assert_eq!(get("roll_amp_deg"), 0.5);
    assert_eq!(get("lat_deg"), 60.0);
    assert!(s.set("sea_state", 7.0).is_err());
    assert!(
        s.set("nonsense", 1.0)
            .unwrap_err()
            .to_string()
            .contains("lever_x_m")
    );
    assert!(s.set("lat_deg", f64::NAN).is_err());
    s.set("lat_deg", 95.0).unwrap();
    assert!(s.build().err().is_some());
    assert!(Scenario::by_name("submarine").is_err());
    let mut f = Scenario::by_name("flight").unwrap();
    f.set("to_lat_deg", 56.3).unwrap();
    f.set("to_lon_deg", 43.9).unwrap();
    assert!(f.build().err().unwrap().to_string().contains("too close"));
}

/// Runs `nav` on `args`: (success, stdout and stderr).
fn nav(args: &[&str]) -> (bool, String) {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_nav"))
        .args(args)
        .output()
        .expect("run nav");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    (o.status.success(), text)
}

/// `nav sim` with an unknown name lists every name it takes, from the same list it accepts:
/// each listed name is accepted (its parameters print) and the family is among them.
#[test]
fn nav_sim_lists_the_scenarios_it_accepts() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, text) = nav(&["sim", "nonsense", "--out", dir.path().to_str().unwrap()]);
    assert!(!ok, "{text}");
    let listed: Vec<&str> = text
        .split_once("nav sim takes ")
        .unwrap_or_else(|| panic!("no list of scenarios: {text}"))
        .1
        .trim()
        .split(", ")
        .collect();
    assert_eq!(
        listed,
        host_tests::simulate_family::sim_scenario_names(),
        "{text}"
    );
    assert!(listed.contains(&"family"), "{text}");
    for name in listed {
        let (ok, text) = nav(&["sim", name, "--list-params"]);
        assert!(ok && text.contains("parameters"), "{name}: {text}");
    }
}

/// Runs the `# replay: nav ...` line of the scenario.txt `text`, its solution into
/// `solution`: the line, whether it succeeded and its output.
fn run_replay_hint(text: &str, solution: &std::path::Path) -> (String, bool, String) {
    let line = text
        .lines()
        .find_map(|l| l.strip_prefix("# replay: nav "))
        .unwrap_or_else(|| panic!("no replay line in\n{text}"));
    let args: Vec<String> = line
        .split_whitespace()
        .map(|a| match a {
            "solution.csv" => solution.to_str().unwrap().to_owned(),
            _ => a.to_owned(),
        })
        .collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (ok, out) = nav(&args);
    (line.to_owned(), ok, out)
}

/// A MEMS part's gyro bias hides the Earth rate, so its replay hint cannot align at rest
/// (the hint did, and failed: "mean angular rate exceeds the Earth rate"; found by a probe):
/// with simulated fixes it starts in motion, and runs; without, it says why there is none.
#[test]
fn a_mems_replay_hint_starts_in_motion_or_says_why_not() {
    let dir = tempfile::tempdir().unwrap();
    for grade in ["mems-tactical", "mems-consumer"] {
        let sim = |gnss: &[&str], name: &str| {
            let out = dir.path().join(name);
            let args = ["sim", "land-vehicle", "--grade", grade, "--seconds", "60"];
            let out_s = out.to_str().unwrap();
            let (ok, text) = nav(&[&args[..], gnss, &["--format", "bin", "--out", out_s]].concat());
            assert!(ok, "{text}");
            std::fs::read_to_string(out.join("scenario.txt")).unwrap()
        };
        let text = sim(&[], &format!("{grade}-alone"));
        let none = format!("# replay: none: a {grade} part's gyro bias (");
        assert!(text.contains(&none), "{text}");
        assert!(!text.contains("# replay: nav "), "{text}");
        let text = sim(&["--gnss-rate", "1"], &format!("{grade}-gnss"));
        let solution = dir.path().join(format!("{grade}.csv"));
        let (line, ok, out) = run_replay_hint(&text, &solution);
        assert!(line.contains(" --start-in-motion "), "{line}");
        assert!(ok, "{line}\n{out}");
        assert!(out.contains("filter started at t = "), "{out}");
    }
}

/// `nav sim land-vehicle`'s replay hint runs as written: its alignment window ends before the
/// car first moves, and scenario.txt gives the recording's length, not the scenario's default;
/// a recording too short to align and navigate says so instead of a command that would fail.
#[test]
fn the_land_vehicle_replay_hint_runs() {
    let dir = tempfile::tempdir().unwrap();
    let sim = |seconds: &str, name: &str| {
        let out = dir.path().join(name);
        let out_s = out.to_str().unwrap();
        let args = ["sim", "land-vehicle", "--seconds", seconds];
        let (ok, text) = nav(&[&args[..], &["--format", "bin", "--out", out_s]].concat());
        assert!(ok, "{text}");
        std::fs::read_to_string(out.join("scenario.txt")).unwrap()
    };
    let text = sim("100", "long");
    assert!(
        text.contains("\nseconds = 100  # length [s] (--seconds; the scenario's own is 600)"),
        "{text}"
    );
    let solution = dir.path().join("solution.csv");
    let (line, ok, out) = run_replay_hint(&text, &solution);
    // The car moves from 20 s: a window ending before it.
    assert!(line.contains("--align-seconds 15 "), "{line}");
    assert!(ok, "{line}\n{out}");
    assert!(solution.exists());

    let text = sim("10", "short");
    assert!(
        text.contains("# replay: none: 10.0 s leave a 0 s alignment window"),
        "{text}"
    );
}

/// With a simulated receiver, scenario.txt records its settings and what was injected, and
/// its replay hint takes the fixes (with the antenna's lever arm): before, the receiver was
/// missing from the description and the hint ran free-inertial beside the fixes it wrote.
#[test]
fn the_replay_hint_takes_the_simulated_receivers_fixes() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim");
    let out_s = out.to_str().unwrap();
    let (ok, text) = nav(&[
        "sim",
        "land-vehicle",
        "--grade",
        "fog",
        "--seconds",
        "40",
        "--gnss-rate",
        "1",
        "--gnss-lever-arm",
        "0.5,0,-1",
        "--gnss-spike",
        "30,5,0,0",
        "--format",
        "bin",
        "--out",
        out_s,
    ]);
    assert!(ok, "{text}");
    let text = std::fs::read_to_string(out.join("scenario.txt")).unwrap();
    for want in [
        "\ngnss_rate_hz = 1\n",
        "\ngnss_sigma_ned_m = 0.5,0.5,1\n",
        "\ngnss_lever_arm_b_m = 0.5,0,-1\n",
        "spike #0: N 5.000",
    ] {
        assert!(text.contains(want), "{want:?} in\n{text}");
    }
    let solution = dir.path().join("solution.csv");
    let (line, ok, report) = run_replay_hint(&text, &solution);
    let gnss = out.join("gnss.csv");
    assert!(
        line.ends_with(&format!(
            " --gnss {} --gnss-lever-arm 0.5,0,-1 --out solution.csv",
            gnss.display()
        )),
        "{line}"
    );
    assert!(ok, "{line}\n{report}");
    assert!(report.contains("GNSS position: "), "{report}");
    assert!(std::fs::read_to_string(&solution).unwrap().starts_with(
        "t_s,lat_deg,lon_deg,h_m,v_n_mps,v_e_mps,v_d_mps,roll_deg,pitch_deg,yaw_deg,sigma_n_m"
    ));
}

/// `nav sim ... --list-params | head -1`: the reader closes the pipe before `nav` has written
/// everything; `nav` ends as command-line tools do, without a panic message.
#[test]
fn output_into_a_closed_pipe_is_not_a_panic() {
    use std::process::{Command, Stdio};
    // `nav` starts after the reader has gone (the shell waits first).
    let mut child = Command::new("sh")
        .args([
            "-c",
            "sleep 0.3; exec \"$0\" sim land-vehicle --list-params",
            env!("CARGO_BIN_EXE_nav"),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_ne!(out.status.code(), Some(101), "{err}");
}

/// A period of the rocking or of the centre's translation is refused by its name when it spans
/// fewer than 10 samples at the rate (it aliases, or is faster than an IMU senses), or is not
/// finite; 10 samples exactly pass.
#[test]
fn a_motion_period_shorter_than_ten_samples_is_refused() {
    use host_tests::trajectory::scenarios::Rocking;
    let mut r = Rocking::ship(6);
    r.check_periods(400.0).unwrap();
    // 8 samples at 400 Hz.
    r.translation.heave.period_s = 0.02;
    let msg = r.check_periods(400.0).unwrap_err().to_string();
    assert!(
        msg.starts_with("heave_period_s 0.02 is not within [0.025, "),
        "{msg}"
    );
    r.translation.heave.period_s = 0.025;
    r.check_periods(400.0).unwrap();
    // The same period at 100 Hz: 2.5 samples.
    let msg = r.check_periods(100.0).unwrap_err().to_string();
    assert!(
        msg.starts_with("heave_period_s 0.025 is not within [0.1, "),
        "{msg}"
    );
    r.roll.period_s = f64::INFINITY;
    let msg = r.check_periods(400.0).unwrap_err().to_string();
    assert!(msg.starts_with("roll_period_s inf"), "{msg}");
}
