//! The GNSS-aided filter on exactly known motions: convergence from a wrong start within its own
//! 1-sigma, the covariance positive definite, the aids counted.

use host_tests::truth::{MeridianFlight, Stationary};
use nav_core::attitude::{from_euler, rotation_vector_of, rotation_vector_quat};
use nav_core::ins_filter::model::FilterNoise;
use nav_core::ins_filter::{
    ATT, AidResult, AidedIns, BG, FilterConfig, GnssPosition, InitialSigma, POS, SensorErrors, VEL,
};
use nav_core::{ImuIncrement, NavState, Position, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

fn noise() -> FilterNoise<f64> {
    FilterNoise {
        arw_rad_per_sqrt_s: 0.002f64.to_radians() / 60.0,
        vrw_mps_per_sqrt_s: 0.005 / 60.0,
        gyro_bias_rad_s: 0.01f64.to_radians() / 3600.0,
        accel_bias_mps2: 1e-3,
        gyro_scale: 1e-5,
        accel_scale: 1e-5,
        correlation_time_s: 3600.0,
        gyro_cross_coupling_rad: 0.0,
        accel_cross_coupling_rad: 0.0,
        gyro_g_sensitivity: 0.0,
        gyro_bias_instability_rad_s: 0.0,
        gyro_bias_instability_time_s: 0.0,
    }
}

fn sigma0() -> InitialSigma<f64> {
    let n = noise();
    InitialSigma {
        position_ned_m: Vector3::repeat(2.0),
        velocity_ned_m_s: Vector3::repeat(0.1),
        attitude_rad: Vector3::new(0.05, 0.05, 1.0).map(f64::to_radians),
        gyro_bias_rad_s: Vector3::repeat(n.gyro_bias_rad_s),
        accel_bias_mps2: Vector3::repeat(n.accel_bias_mps2),
        gyro_scale: Vector3::repeat(n.gyro_scale),
        accel_scale: Vector3::repeat(n.accel_scale),
    }
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    StandardNormal.sample(rng)
}

/// Position, velocity and attitude errors over their 1-sigma.
fn z_scores(ins: &AidedIns<f64>, truth: &NavState<f64>) -> [f64; 9] {
    let s = ins.state();
    let dr = truth.position.ned_to(&s.position);
    let dv = s.v_eb_n - truth.v_eb_n;
    let phi = -rotation_vector_of(&(s.q_b_n * truth.q_b_n.inverse()));
    let (sp, sv, sa) = (ins.sigma(POS), ins.sigma(VEL), ins.sigma(ATT));
    [
        dr[0] / sp.x,
        dr[1] / sp.y,
        dr[2] / sp.z,
        dv.x / sv.x,
        dv.y / sv.y,
        dv.z / sv.z,
        phi.x / sa.x,
        phi.y / sa.y,
        phi.z / sa.z,
    ]
}

/// A position fix of `truth` drawn with 0.5 m white noise per axis, declared so, given to `ins`.
fn aid_half_metre_fix(ins: &mut AidedIns<f64>, truth: &NavState<f64>, rng: &mut ChaCha8Rng) {
    let d = [0, 1, 2].map(|_| 0.5 * normal(rng));
    let fix = truth.position.offset_ned(d);
    ins.aid_position(
        &GnssPosition {
            lat_rad: fix.lat_f64(),
            lon_rad: fix.lon_f64(),
            h_m: fix.h_f64(),
            sigma_ned_m: Vector3::repeat(0.5),
        },
        0.0,
    );
}

/// A base standing still, levelled and headed a little off the axes, and its state.
fn still_base() -> (Stationary, NavState<f64>) {
    let body = Stationary {
        lat: 0.8,
        lon: 0.2,
        h: 300.0,
        q_b_ned: from_euler(0.02, -0.01, 1.2),
    };
    let truth = NavState::at_rest(Position::from_radians(0.8, 0.2, 300.0), body.q_b_ned);
    (body, truth)
}

#[test]
fn a_still_base_with_position_fixes_converges_within_its_sigma() {
    let (body, truth) = still_base();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for run in 0..6 {
        let s0 = sigma0();
        let dphi = s0.attitude_rad.map(|s| s * normal(&mut rng));
        let dr = s0.position_ned_m.map(|s| s * normal(&mut rng));
        let start = NavState {
            q_b_n: rotation_vector_quat(&(-dphi)) * truth.q_b_n,
            v_eb_n: s0.velocity_ned_m_s.map(|s| s * normal(&mut rng)),
            position: truth.position.offset_ned(dr.into()),
        };
        let mut config = FilterConfig::new(noise());
        // ZUPT/ZARU tested below; here GNSS alone.
        config.zero_motion = None;
        let mut ins = AidedIns::new(start, SensorErrors::default(), &s0, config).unwrap();
        let dt = 0.0025;
        let inc = body.increment(dt);
        let sigma_gnss = 0.5;
        for k in 1..=400 * 300 {
            ins.step(&inc).unwrap();
            if k % 400 == 0 {
                let d = [0, 1, 2].map(|_| sigma_gnss * normal(&mut rng));
                let fix = truth.position.offset_ned(d);
                let r = ins.aid_position(
                    &GnssPosition {
                        lat_rad: fix.lat_f64(),
                        lon_rad: fix.lon_f64(),
                        h_m: fix.h_f64(),
                        sigma_ned_m: Vector3::repeat(sigma_gnss),
                    },
                    0.0,
                );
                assert!(
                    matches!(r, AidResult::Accepted { .. }),
                    "run {run} k {k}: {r:?}"
                );
            }
        }
        assert!(ins.covariance_is_positive_definite());
        let z = z_scores(&ins, &truth);
        assert!(z.iter().all(|v| v.abs() < 4.0), "run {run}: {z:?}");
        // Position known to the fixes' averaging; heading by gyrocompassing through the fixes:
        // a heading error psi tilts at psi Omega cos(lat) and moves the position by
        // g psi Omega cos(lat) t^3 / 6, 1.3 m at 0.2 deg in 300 s, against 0.5 m fixes: the
        // heading's 1-sigma is well below the start's 1 deg.
        assert!(ins.sigma(POS).x < 0.2, "{}", ins.sigma(POS));
        assert!(ins.sigma(ATT).z < 0.4f64.to_radians(), "{}", ins.sigma(ATT));
        assert_eq!(ins.counters().position.accepted, 300);
    }
}

/// A still base navigated on 10 Hz fixes of 2 m ([`GATE_SIGMA_M`]).
struct StillBase {
    ins: AidedIns<f64>,
    truth: NavState<f64>,
    inc: ImuIncrement<f64>,
}

impl StillBase {
    /// Converged on fixes each axis within 2 sigma (none beyond the gate; the windowed test
    /// may refuse one by chance, which starts no cluster), with no refused cluster.
    fn converged() -> Self {
        let (body, truth) = still_base();
        let mut config = FilterConfig::new(noise());
        config.zero_motion = None;
        let ins = AidedIns::new(truth, SensorErrors::default(), &sigma0(), config).unwrap();
        let mut base = Self {
            ins,
            truth,
            inc: body.increment(0.0025),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..600 {
            let d = [0, 1, 2].map(|_| GATE_SIGMA_M * normal(&mut rng).clamp(-2.0, 2.0));
            base.fix(d);
        }
        assert_eq!(base.ins.counters().position.cluster_rejected, 0);
        assert!(base.sigma_m().max() < 0.3, "{}", base.sigma_m());
        base
    }

    /// 0.1 s of increments, then a fix `d` [m] NED from the truth.
    fn fix(&mut self, d: [f64; 3]) -> AidResult<f64> {
        for _ in 0..40 {
            self.ins.step(&self.inc).unwrap();
        }
        let p = self.truth.position.offset_ned(d);
        self.ins.aid_position(
            &GnssPosition {
                lat_rad: p.lat_f64(),
                lon_rad: p.lon_f64(),
                h_m: p.h_f64(),
                sigma_ned_m: Vector3::repeat(GATE_SIGMA_M),
            },
            0.0,
        )
    }

    /// The reported position 1-sigma, NED [m].
    fn sigma_m(&self) -> Vector3<f64> {
        self.ins.position_covariance().diagonal().map(f64::sqrt)
    }

    /// The error after an ordinary fix (2.6 sigma west, 1.8 sigma up) taken after refused
    /// ones: within 1 m (taken whole, such a fix moves the solution by 5 m) and within 3 of
    /// the reported sigma, which is back below 1 m.
    fn an_ordinary_fix_moves_nothing(&mut self) {
        let r = self.fix([0.0, -2.6 * GATE_SIGMA_M, -1.8 * GATE_SIGMA_M]);
        assert!(matches!(r, AidResult::Accepted { .. }), "{r:?}");
        let e = Vector3::from(self.truth.position.ned_to(&self.ins.state().position));
        let sigma = self.sigma_m();
        assert!(e.norm() < 1.0, "{e:?}");
        assert!((0..3).all(|i| e[i].abs() < 3.0 * sigma[i]), "{e:?} {sigma}");
        assert!(sigma.max() < 1.0, "{sigma}");
    }
}

/// The fixes' 1-sigma of [`StillBase`] [m].
const GATE_SIGMA_M: f64 = 2.0;

/// One fault-free fix refused by the gate (4.5 sigma east: the gate's false alarm, one in a
/// thousand) and then an ordinary one: the refused fix is reported as a doubt of only its
/// part beyond the gate, and the next is taken as any fix, without widening the covariance
/// by its own offset. Before, both were taken whole: the reported sigma jumped from 0.1 m to
/// 4.5 m and the ordinary fix moved the solution by metres.
#[test]
fn a_lone_false_alarm_of_the_gate_moves_nothing() {
    let mut base = StillBase::converged();
    let r = base.fix([0.0, 4.5 * GATE_SIGMA_M, 0.0]);
    assert!(matches!(r, AidResult::Rejected { .. }), "{r:?}");
    assert!(base.sigma_m().max() < 1.0, "{}", base.sigma_m());
    base.an_ordinary_fix_moves_nothing();
}

/// A fix refused far beyond the gate (6 sigma east) holds a third of its offset as the
/// reported doubt; the next fix (2.6 sigma west, 1.8 sigma up) agrees with the filter, not
/// with it, and is taken as any fix. Before, the covariance was widened by the next fix's
/// offset in the refused fix's part, and the solution followed that fix by 2 m.
#[test]
fn a_fix_that_disagrees_with_the_refused_one_is_taken_as_any() {
    let mut base = StillBase::converged();
    let r = base.fix([0.0, 6.0 * GATE_SIGMA_M, 0.0]);
    assert!(matches!(r, AidResult::Rejected { .. }), "{r:?}");
    let doubt = base.sigma_m();
    assert!(doubt.y > 1.5 && doubt.y < 2.5, "{doubt}");
    base.an_ordinary_fix_moves_nothing();
}

/// The same false alarm, and the next fault-free fix (2.2 sigma east) closer to it than to
/// the prediction: refused as its cluster's second member. Their common offset is evidence
/// only a little beyond the gate, and the cluster holds that part: the reported sigma stays
/// below 1.5 m and the ordinary fix after them moves nothing. Before, the pair was taken
/// whole: 4 m of reported sigma, and the ordinary fix moved the solution by metres.
#[test]
fn a_chance_pair_of_refusals_moves_nothing() {
    let mut base = StillBase::converged();
    for east in [4.5, 2.2] {
        let r = base.fix([0.0, east * GATE_SIGMA_M, 0.0]);
        assert!(matches!(r, AidResult::Rejected { .. }), "{east}: {r:?}");
    }
    assert_eq!(base.ins.counters().position.cluster_rejected, 1);
    assert!(base.sigma_m().max() < 1.5, "{}", base.sigma_m());
    base.an_ordinary_fix_moves_nothing();
}

/// The solution is 6 m off (3 sigma of the fixes' innovations, 30 of its own 0.2 m 1-sigma:
/// a filter that went optimistic, as an RTK car's vertical leaving a stop) and the fixes say
/// so: the first one, 2 sigma further by chance, is refused by the gate, and the next ones,
/// which the gate passes, agree better with it than with the prediction. They are refused as
/// its cluster for at most a window of members, then taken, and the solution comes to them
/// within 3 of its reported sigma. Before, the cluster held them until its offset was typical
/// of the filter's covariance: at a still base, whose covariance hardly grows, for minutes.
#[test]
fn fixes_the_gate_passes_are_refused_as_a_cluster_for_at_most_a_window() {
    let mut base = StillBase::converged();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let off = 3.0 * GATE_SIGMA_M;
    let r = base.fix([0.0, off + 2.0 * GATE_SIGMA_M, 0.0]);
    assert!(matches!(r, AidResult::Rejected { .. }), "{r:?}");
    let mut refused = 1;
    for k in 0..100 {
        let d = [0, 1, 2].map(|_| 0.5 * GATE_SIGMA_M * normal(&mut rng));
        let r = base.fix([d[0], off + d[1], d[2]]);
        match r {
            AidResult::Rejected { nis } => {
                assert!(nis < 16.3, "fix {k} refused by the gate: {nis}");
                refused += 1;
            }
            _ => break,
        }
    }
    assert!(refused <= 10, "{refused} fixes refused in a row");
    for _ in 0..50 {
        let d = [0, 1, 2].map(|_| 0.5 * GATE_SIGMA_M * normal(&mut rng));
        base.fix([d[0], off + d[1], d[2]]);
    }
    let e = Vector3::from(
        base.truth
            .position
            .offset_ned([0.0, off, 0.0])
            .ned_to(&base.ins.state().position),
    );
    let sigma = base.sigma_m();
    assert!((0..3).all(|i| e[i].abs() < 3.0 * sigma[i]), "{e:?} {sigma}");
    assert!(e.norm() < 1.0, "{e:?}");
}

#[test]
fn a_flight_with_a_lever_arm_and_late_fixes_stays_consistent() {
    let flight = MeridianFlight {
        lat0: 0.5,
        lon0: 0.1,
        h: 3000.0,
        speed: 200.0,
    };
    let dt = 0.0025;
    let n = 400 * 200;
    let mut incs = Vec::with_capacity(n);
    let mut truths = Vec::with_capacity(n);
    flight.run(dt, n, |inc, t| {
        incs.push(*inc);
        truths.push(*t);
    });
    // The start: level, heading north along the meridian.
    let t0 = host_tests::truth::Truth {
        t_s: 0.0,
        lat: 0.5,
        lon: 0.1,
        h: 3000.0,
        v_eb_ned: Vector3::new(200.0, 0.0, 0.0),
        q_b_ned: nav_core::UnitQuaternion::identity(),
    };
    let s0 = sigma0();
    let lever = Vector3::new(1.5, -0.3, -1.2);
    let mut config = FilterConfig::new(noise());
    config.antenna_lever_arm_b_m = lever;
    let start = NavState {
        q_b_n: rotation_vector_quat(&Vector3::new(2e-4, -3e-4, 8e-3)).inverse() * t0.q_b_ned,
        v_eb_n: t0.v_eb_ned + Vector3::new(0.05, -0.1, 0.02),
        position: Position::from_radians(t0.lat, t0.lon, t0.h).offset_ned([1.0, -2.0, 0.5]),
    };
    let mut ins = AidedIns::new(start, SensorErrors::default(), &s0, config).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let sigma_gnss = 0.3;
    let mut nis_sum = 0.0;
    let mut fixes = 0;
    let mut rejected = 0;
    for (k, (inc, t)) in incs.iter().zip(&truths).enumerate() {
        ins.step(&ImuIncrement { ..*inc }).unwrap();
        // A fix 1.3 ms before every 400th sample's end (between samples).
        if (k + 1) % 400 == 0 {
            let lag = 0.0013;
            // Constant velocity and attitude: the truth `lag` earlier is `v lag` behind.
            let l_n = t.q_b_ned * lever - t.v_eb_ned * lag;
            let noise = [0, 1, 2].map(|_| sigma_gnss * normal(&mut rng));
            let ant = Position::from_radians(t.lat, t.lon, t.h).offset_ned([
                l_n.x + noise[0],
                l_n.y + noise[1],
                l_n.z + noise[2],
            ]);
            match ins.aid_position(
                &GnssPosition {
                    lat_rad: ant.lat_f64(),
                    lon_rad: ant.lon_f64(),
                    h_m: ant.h_f64(),
                    sigma_ned_m: Vector3::repeat(sigma_gnss),
                },
                lag,
            ) {
                AidResult::Accepted { nis } => {
                    nis_sum += nis;
                    fixes += 1;
                }
                AidResult::Rejected { nis } => {
                    // The 99.9 % gate refuses one consistent fix in a thousand.
                    rejected += 1;
                    assert!(rejected <= 2, "fix at {}: NIS {nis}", t.t_s);
                }
                AidResult::Invalid => panic!("fix at {}: invalid", t.t_s),
            }
        }
    }
    let t = truths.last().unwrap();
    let truth = NavState {
        q_b_n: t.q_b_ned,
        v_eb_n: t.v_eb_ned,
        position: Position::from_radians(t.lat, t.lon, t.h),
    };
    let z = z_scores(&ins, &truth);
    assert!(z.iter().all(|v| v.abs() < 4.0), "{z:?}");
    // Mean NIS of 200 fixes: chi-square(3) mean 3, 99.9 % band of the mean about 2.3..3.8.
    let mean = nis_sum / f64::from(fixes);
    assert!((2.2..4.0).contains(&mean), "mean NIS {mean}");
    assert!(ins.covariance_is_positive_definite());
}

#[test]
fn a_stop_is_detected_and_zero_velocity_updates_bound_the_velocity() {
    let body = Stationary {
        lat: 0.6,
        lon: 0.0,
        h: 0.0,
        q_b_ned: from_euler(0.0, 0.0, 0.3),
    };
    let truth = NavState::at_rest(Position::from_radians(0.6, 0.0, 0.0), body.q_b_ned);
    let s0 = sigma0();
    let mut ins = AidedIns::new(
        NavState {
            v_eb_n: Vector3::new(0.05, -0.05, 0.0),
            ..truth
        },
        SensorErrors::default(),
        &s0,
        FilterConfig::new(noise()),
    )
    .unwrap();
    let inc = body.increment(0.0025);
    for _ in 0..400 * 60 {
        ins.step(&inc).unwrap();
    }
    let c = ins.counters();
    assert!(ins.is_still());
    // 0.5 s windows, the first update after two: 119 in 60 s.
    assert!(c.zero_velocity.accepted >= 110, "{c:?}");
    assert!(c.zero_rate.accepted >= 110, "{c:?}");
    assert!(ins.state().v_eb_n.norm() < 0.01, "{}", ins.state().v_eb_n);
    assert!(ins.sigma(VEL).x < 0.02);
}

/// A consumer gyro at rest, its bias up to 3 times its 0.5 deg/s prior 1-sigma, and the
/// solution started off level by up to 3 times its 1 deg 1-sigma (1 deg reads 0.17 m/s^2 in
/// the levelled specific force): beyond the stop detector's own thresholds (0.5 deg/s,
/// 0.1 m/s^2), which widen by the filter's 1-sigmas of what they measure. Without that the
/// detector never declared the stop whose zero-rate update alone finds the bias (a consumer
/// flight's first minute on the ground turned its heading by 60 deg against a 16 deg 1-sigma).
/// A family: the first member the case above (1 deg/s vertical, 1 deg of roll), then drawn
/// sites, headings, biases and tilt errors. Each stop is taken, the bias found within 3 of its
/// 1-sigma and the heading kept within its own.
#[test]
fn a_consumer_gyro_bias_beyond_the_rate_threshold_is_found_at_a_stop() {
    let consumer = FilterNoise {
        arw_rad_per_sqrt_s: 0.168f64.to_radians() / 60.0,
        vrw_mps_per_sqrt_s: 70e-6 * 9.81,
        gyro_bias_rad_s: 0.5f64.to_radians(),
        accel_bias_mps2: 0.02 * 9.81,
        gyro_scale: 5e-3,
        accel_scale: 5e-3,
        ..noise()
    };
    let sigma = InitialSigma {
        attitude_rad: Vector3::new(1.0, 1.0, 2.0).map(f64::to_radians),
        gyro_bias_rad_s: Vector3::repeat(consumer.gyro_bias_rad_s),
        accel_bias_mps2: Vector3::repeat(consumer.accel_bias_mps2),
        gyro_scale: Vector3::repeat(consumer.gyro_scale),
        accel_scale: Vector3::repeat(consumer.accel_scale),
        ..sigma0()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    for member in 0..8 {
        // (latitude [rad], heading [rad], bias [deg/s], roll and pitch errors [deg]).
        let (lat, yaw, b_g_deg, tilt_deg) = if member == 0 {
            (0.98, -1.0, Vector3::new(0.2, -0.3, 1.0), [1.0, 0.0])
        } else {
            let mut draw = |s: f64| (s * normal(&mut rng)).clamp(-3.0 * s, 3.0 * s);
            (
                draw(0.5),
                draw(1.0),
                Vector3::new(draw(0.5), draw(0.5), draw(0.5)),
                [draw(1.0), draw(1.0)],
            )
        };
        let body = Stationary {
            lat,
            lon: 0.7,
            h: 80.0,
            q_b_ned: from_euler(0.0, 0.0, yaw),
        };
        let truth = NavState::at_rest(Position::from_radians(lat, 0.7, 80.0), body.q_b_ned);
        let start = NavState {
            q_b_n: from_euler(tilt_deg[0].to_radians(), tilt_deg[1].to_radians(), yaw),
            ..truth
        };
        let mut ins = AidedIns::new(
            start,
            SensorErrors::default(),
            &sigma,
            FilterConfig::new(consumer),
        )
        .unwrap();
        let b_g = b_g_deg.map(f64::to_radians);
        let dt = 0.0025;
        let exact = body.increment(dt);
        let inc = ImuIncrement {
            delta_theta_ib_b: exact.delta_theta_ib_b + b_g * dt,
            ..exact
        };
        for _ in 0..400 * 30 {
            ins.step(&inc).unwrap();
        }
        let c = ins.counters();
        let what = format!("member {member}: bias {b_g_deg} deg/s, tilt {tilt_deg:?} deg");
        assert!(ins.is_still(), "{what}");
        // 0.5 s windows: 59 in 30 s, the first update after two.
        assert!(c.zero_rate.accepted >= 50, "{what}: {c:?}");
        let (b_hat, s_bg) = (ins.sensor_errors().gyro_bias_rad_s, ins.sigma(BG));
        for k in 0..3 {
            let e = b_hat[k] - b_g[k];
            assert!(
                e.abs() < 3.0 * s_bg[k],
                "{what}: axis {k}: error {e:e} rad/s, 1-sigma {:e}",
                s_bg[k]
            );
            assert!(
                s_bg[k] < 0.02f64.to_radians(),
                "{what}: axis {k}: 1-sigma {:e}",
                s_bg[k]
            );
        }
        // The heading drifted only until the first stop (1 s), within its 1-sigma.
        let z = z_scores(&ins, &truth);
        assert!(z.iter().all(|v| v.abs() < 3.0), "{what}: {z:?}");
    }
}

/// A still base whose gyro bias (3 deg/h drawn per axis, 1-sigma 5 deg/h) is below the
/// horizontal Earth rate (10.5 deg/h at 46 deg), its heading drawn from a 10 deg 1-sigma, its
/// stops taken for 5 min with 0.5 m position fixes: the zero-rate update sees the bias plus the
/// Earth rate's share the heading error turns, `C_n_b [omega_ie_n x] phi`. Without that term
/// the update took the share for bias, and the heading's 1-sigma fell to 6.1 deg, below what
/// the data can tell (9.4 deg), with the error unchanged. Each member ends with its heading and
/// bias within 3 of their 1-sigma, and the heading's 1-sigma not below that floor.
#[test]
fn a_stop_tells_the_heading_error_from_the_gyro_bias() {
    let tactical = FilterNoise {
        arw_rad_per_sqrt_s: 0.05f64.to_radians() / 60.0,
        gyro_bias_rad_s: 5f64.to_radians() / 3600.0,
        ..noise()
    };
    let sigma = InitialSigma {
        attitude_rad: Vector3::new(0.05, 0.05, 10.0).map(f64::to_radians),
        gyro_bias_rad_s: Vector3::repeat(tactical.gyro_bias_rad_s),
        ..sigma0()
    };
    let (body, truth) = still_base();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for member in 0..6 {
        let mut draw = |s: f64| (s * normal(&mut rng)).clamp(-2.5 * s, 2.5 * s);
        let yaw_err = draw(10f64.to_radians());
        let b_g = Vector3::new(draw(3.0), draw(3.0), draw(3.0)).map(|b| b.to_radians() / 3600.0);
        let start = NavState {
            q_b_n: rotation_vector_quat(&Vector3::new(0.0, 0.0, -yaw_err)) * truth.q_b_n,
            ..truth
        };
        let mut ins = AidedIns::new(
            start,
            SensorErrors::default(),
            &sigma,
            FilterConfig::new(tactical),
        )
        .unwrap();
        let dt = 0.0025;
        let exact = body.increment(dt);
        let inc = ImuIncrement {
            delta_theta_ib_b: exact.delta_theta_ib_b + b_g * dt,
            ..exact
        };
        for k in 1..=400 * 300 {
            ins.step(&inc).unwrap();
            if k % 400 == 0 {
                aid_half_metre_fix(&mut ins, &truth, &mut rng);
            }
        }
        let what = format!(
            "member {member}: heading {} deg off at the start, bias {} deg/h",
            yaw_err.to_degrees(),
            b_g * 3600.0 / 1f64.to_radians()
        );
        assert!(ins.counters().zero_rate.accepted > 500, "{what}");
        let z = z_scores(&ins, &truth);
        assert!(z[8].abs() < 3.0, "{what}: yaw z {}", z[8]);
        // At rest the heading shows only through the Earth rate it turns, against the bias:
        // no filter may know it better than its prior and `Omega cos(lat) / sigma_b` per rad
        // together allow (9.4 deg here).
        let earth = nav_core::earth::OMEGA_IE * truth.position.lat_f64().cos();
        let floor = (sigma.attitude_rad.z.powi(-2) + (earth / tactical.gyro_bias_rad_s).powi(2))
            .sqrt()
            .recip();
        assert!(
            ins.sigma(ATT).z > 0.9 * floor,
            "{what}: heading 1-sigma {} deg below the floor {} deg",
            ins.sigma(ATT).z.to_degrees(),
            floor.to_degrees()
        );
        let (b_hat, s_bg) = (ins.sensor_errors().gyro_bias_rad_s, ins.sigma(BG));
        for k in 0..3 {
            let e = b_hat[k] - b_g[k];
            assert!(
                e.abs() < 3.0 * s_bg[k],
                "{what}: bias axis {k} z {}",
                e / s_bg[k]
            );
        }
    }
}

/// A still consumer part whose gyro bias (30 deg/h, drawn per axis) hides the horizontal Earth
/// rate (10.5 deg/h at 46 deg): its heading, drawn from a 30 deg 1-sigma, cannot be told from
/// 5 min of 0.5 m fixes, with or without the stops' updates. Two things told it all the same:
/// the attitude coupling linearised about the computed specific force, whose horizontal part
/// at rest is the filter's own error (tilt, accelerometer bias) and noise, and the reset's
/// half turn of the tilt. The heading's 1-sigma fell from 30 to 7-16 deg with the error
/// unchanged. Each member ends with its heading within 3 of its 1-sigma and that 1-sigma above
/// 0.9 of what the prior and `Omega cos(lat) / sigma_b` together allow (29.5 deg).
#[test]
fn a_still_part_that_cannot_find_north_keeps_its_heading_doubt() {
    let consumer = FilterNoise {
        arw_rad_per_sqrt_s: 0.3f64.to_radians() / 60.0,
        vrw_mps_per_sqrt_s: 0.2 / 60.0,
        gyro_bias_rad_s: 30f64.to_radians() / 3600.0,
        accel_bias_mps2: 0.03,
        gyro_scale: 1e-3,
        accel_scale: 1e-3,
        ..noise()
    };
    let sigma = InitialSigma {
        position_ned_m: Vector3::repeat(0.05),
        velocity_ned_m_s: Vector3::repeat(0.05),
        attitude_rad: Vector3::new(0.5, 0.5, 30.0).map(f64::to_radians),
        gyro_bias_rad_s: Vector3::repeat(consumer.gyro_bias_rad_s),
        accel_bias_mps2: Vector3::repeat(consumer.accel_bias_mps2),
        gyro_scale: Vector3::repeat(consumer.gyro_scale),
        accel_scale: Vector3::repeat(consumer.accel_scale),
    };
    let (body, truth) = still_base();
    let earth = nav_core::earth::OMEGA_IE * truth.position.lat_f64().cos();
    let floor = (sigma.attitude_rad.z.powi(-2) + (earth / consumer.gyro_bias_rad_s).powi(2))
        .sqrt()
        .recip();
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for member in 0..6 {
        let mut draw = |s: f64| (s * normal(&mut rng)).clamp(-2.5 * s, 2.5 * s);
        let phi = Vector3::new(draw(0.5), draw(0.5), draw(30.0)).map(f64::to_radians);
        let b_g = Vector3::new(draw(30.0), draw(30.0), draw(30.0)).map(|b| b.to_radians() / 3600.0);
        let b_a = Vector3::new(draw(0.03), draw(0.03), draw(0.03));
        let start = NavState {
            q_b_n: rotation_vector_quat(&-phi) * truth.q_b_n,
            ..truth
        };
        let mut config = FilterConfig::new(consumer);
        if member % 2 == 1 {
            config.zero_motion = None;
        }
        let mut ins = AidedIns::new(start, SensorErrors::default(), &sigma, config).unwrap();
        let dt = 0.0025;
        let exact = body.increment(dt);
        let (arw, vrw) = (consumer.arw_rad_per_sqrt_s, consumer.vrw_mps_per_sqrt_s);
        for k in 1..=400 * 300 {
            let mut white = |s: f64| Vector3::from_fn(|_, _| s * dt.sqrt() * normal(&mut rng));
            let inc = ImuIncrement {
                delta_theta_ib_b: exact.delta_theta_ib_b + b_g * dt + white(arw),
                delta_v_ib_b: exact.delta_v_ib_b + b_a * dt + white(vrw),
                dt,
            };
            ins.step(&inc).unwrap();
            if k % 400 == 0 {
                aid_half_metre_fix(&mut ins, &truth, &mut rng);
            }
        }
        let what = format!(
            "member {member} (stops {}): heading {:.1} deg off at the start",
            member % 2 == 0,
            phi.z.to_degrees()
        );
        let z = z_scores(&ins, &truth);
        let s_yaw = ins.sigma(ATT).z;
        assert!(z[8].abs() < 3.0, "{what}: yaw z {}", z[8]);
        assert!(
            s_yaw > 0.9 * floor,
            "{what}: heading 1-sigma {:.1} deg, the floor {:.1} deg",
            s_yaw.to_degrees(),
            floor.to_degrees()
        );
    }
}

/// A car easing to a stop: 2 m/s north, braking `a(t) = A sin^2(pi t / D)` over `D` = 10 s
/// (the deceleration fades with the speed: 0.09 m/s^2 at 0.05 m/s, 0.36 m/s^2 at 0.4 m/s),
/// level, no vibration, then 5 s still. The specific force's magnitude differs from gravity by
/// `a^2 / 2g` (under 0.01 m/s^2) and its scatter is the braking's slow change, so only the
/// levelled mean specific force tells the braking from a stop
/// ([`nav_core::ins_filter::stationarity`]): no zero velocity may be taken before the car is
/// within 0.06 m/s of standing (the filter's velocity 1-sigma of 0.1 m/s let one in at 0.44 m/s
/// through its gate, and its correction pulled the tilt and position with it), and the stop
/// must be taken once it stands.
#[test]
fn easing_to_a_stop_takes_no_zero_velocity_before_the_car_stands() {
    let (lat, lon, h) = (0.8, 0.1, 100.0);
    let earth = nav_core::earth::LocalEarth::new(lat, h);
    let omega_ie_n = earth.omega_ie_n();
    let (speed0_m_s, brake_s, still_s, dt) = (2.0, 10.0, 5.0, 0.0025);
    // sin^2 over D averages 1/2: A D / 2 = speed0.
    let a_max_m_s2 = 2.0 * speed0_m_s / brake_s;
    let w = std::f64::consts::PI / brake_s;
    // Speed and deceleration at t [s] (closed form of the integral of A sin^2(w t)).
    let kinematics = |t: f64| -> (f64, f64) {
        if t >= brake_s {
            return (0.0, 0.0);
        }
        let v = speed0_m_s - a_max_m_s2 * (t / 2.0 - (2.0 * w * t).sin() / (4.0 * w));
        (v, a_max_m_s2 * (w * t).sin().powi(2))
    };
    // Specific force in NED = body (level, heading north): -a north, Coriolis 2 omega_ie x v,
    // gravity; Simpson over the interval.
    let f_ib_b = |t: f64| {
        let (v, a) = kinematics(t);
        let v_eb_n = Vector3::new(v, 0.0, 0.0);
        Vector3::new(-a, 0.0, 0.0) + 2.0 * omega_ie_n.cross(&v_eb_n)
            - Vector3::new(0.0, 0.0, earth.g)
    };
    let omega_ib_b = |t: f64| {
        let (v, _) = kinematics(t);
        omega_ie_n + Vector3::new(0.0, -v / (earth.r_meridian + h), 0.0)
    };
    let truth = NavState {
        q_b_n: nav_core::UnitQuaternion::identity(),
        v_eb_n: Vector3::new(speed0_m_s, 0.0, 0.0),
        position: Position::from_radians(lat, lon, h),
    };
    let mut ins = AidedIns::new(
        truth,
        SensorErrors::default(),
        &sigma0(),
        FilterConfig::new(noise()),
    )
    .unwrap();
    let n = ((brake_s + still_s) / dt).round() as usize;
    let mut taken = 0;
    for k in 0..n {
        let t0 = k as f64 * dt;
        let t1 = t0 + dt;
        let simpson =
            |f: &dyn Fn(f64) -> Vector3<f64>| (f(t0) + 4.0 * f(t0 + dt / 2.0) + f(t1)) * (dt / 6.0);
        let inc = ImuIncrement {
            delta_theta_ib_b: simpson(&omega_ib_b),
            delta_v_ib_b: simpson(&f_ib_b),
            dt,
        };
        ins.step(&inc).unwrap();
        let accepted = ins.counters().zero_velocity.accepted;
        if accepted > taken {
            taken = accepted;
            let (v, _) = kinematics(t1);
            assert!(
                v <= 0.06,
                "zero velocity taken at t = {t1:.3} s with the car at {v:.3} m/s \
                 (solution {:.3} m/s)",
                ins.state().v_eb_n.norm()
            );
        }
    }
    // Still for 5 s: the first update after two 0.5 s windows.
    assert!(taken >= 6, "{:?}", ins.counters());
    assert!(ins.is_still());
    assert!(ins.state().v_eb_n.norm() < 0.02, "{}", ins.state().v_eb_n);
}

/// A car cruising straight and level at a constant 10 m/s looks still to the IMU (its specific
/// force differs from gravity's by the Coriolis term, 1e-3 m/s^2), so the stop detector takes
/// it for a stop; a filter that knows its velocity refuses that zero velocity at its gate. A
/// filter that does not, after a gap in the IMU data (here started at rest with a 5 m/s
/// velocity 1-sigma), would take it (10 m/s is 2 sigma) and believe it stands with a 0.02 m/s
/// 1-sigma: no stop is taken while the horizontal velocity's 1-sigma exceeds the speed a stop
/// may have ([`nav_core::ins_filter::ZeroMotionConfig::max_speed_m_s`]).
#[test]
fn a_cruise_is_no_stop_while_the_velocity_is_unknown() {
    let (lat, lon, h, speed_m_s, dt) = (0.8, 0.1, 100.0, 10.0, 0.0025);
    let earth = nav_core::earth::LocalEarth::new(lat, h);
    let v_eb_n = Vector3::new(speed_m_s, 0.0, 0.0);
    // Level, heading north: f = 2 omega_ie x v - g, omega = omega_ie + the transport rate.
    let inc = ImuIncrement {
        delta_theta_ib_b: (earth.omega_ie_n()
            + Vector3::new(0.0, -speed_m_s / (earth.r_meridian + h), 0.0))
            * dt,
        delta_v_ib_b: (2.0 * earth.omega_ie_n().cross(&v_eb_n) - Vector3::new(0.0, 0.0, earth.g))
            * dt,
        dt,
    };
    let start = NavState {
        q_b_n: nav_core::UnitQuaternion::identity(),
        v_eb_n: Vector3::zeros(),
        position: Position::from_radians(lat, lon, h),
    };
    let sigma = InitialSigma {
        velocity_ned_m_s: Vector3::repeat(5.0),
        ..sigma0()
    };
    let mut ins = AidedIns::new(
        start,
        SensorErrors::default(),
        &sigma,
        FilterConfig::new(noise()),
    )
    .unwrap();
    for _ in 0..400 * 20 {
        ins.step(&inc).unwrap();
    }
    let c = ins.counters();
    assert!(ins.is_still(), "the detector sees the cruise as a stop");
    assert_eq!(c.zero_velocity.accepted, 0, "{c:?}");
    assert!(ins.sigma(VEL).x > 1.0, "{}", ins.sigma(VEL));
}
