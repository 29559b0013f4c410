//! The oscillator's ODE, its start on the nominal ellipse, and the sampled run (equations in the
//! [module doc](super)).

use super::OscillatorParams;
use crate::trajectory::{Generator, Rider, Sampling, Trajectory, sensed_at, truth_at};
use crate::truth::Truth;
use anyhow::Result;
use nav_core::attitude::{about_y, about_z};
use nav_core::earth::OMEGA_IE;
use nav_core::{ImuIncrement, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Gain `k_a` of the amplitude loop [-].
pub const AMPLITUDE_GAIN: f64 = 1.0;

/// Time step of the finite differences of the specific force at the start [s].
pub const CENTRE_STEP_S: f64 = 1e-3;

/// The oscillator ODE's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscillatorModel {
    /// Natural angular frequency `w0` [rad/s].
    pub w0: f64,
    /// Damping ratio `zeta` [-].
    pub zeta: f64,
    /// Amplitude-keeping drive on.
    pub drive: bool,
    /// Loop gain `k_a` [-].
    pub amplitude_gain: f64,
    /// Time constant `tau` of the amplitude low pass [s].
    pub drive_time_constant_s: f64,
    /// `E_ref`, the set point of the low-passed oscillation energy [m^2/s^2].
    pub energy_ref: f64,
}

/// The integrated state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OscState {
    /// Displacement `r_b` of the mass from its suspension point, body axes [m].
    pub r_b_m: Vector3<f64>,
    /// `v_b`: inertial rate of the displacement, body axes [m/s] (`dr_b/dt + omega_ib_b x r_b`).
    pub v_b_mps: Vector3<f64>,
    /// `E_lp`: the drive's low-passed oscillation energy per unit mass [m^2/s^2]
    /// ([`OscillatorModel::energy`]).
    pub energy_m2ps2: f64,
}

impl OscState {
    /// `rdot_rel = dr_b/dt = v_b - omega_ib_b x r_b` [m/s], body axes.
    pub fn rdot_rel(&self, omega_ib_b: &Vector3<f64>) -> Vector3<f64> {
        self.v_b_mps - omega_ib_b.cross(&self.r_b_m)
    }

    /// `self + k s` (`k` a derivative, `s` [s]).
    pub fn axpy(&self, k: &Self, s: f64) -> Self {
        Self {
            r_b_m: self.r_b_m + k.r_b_m * s,
            v_b_mps: self.v_b_mps + k.v_b_mps * s,
            energy_m2ps2: self.energy_m2ps2 + k.energy_m2ps2 * s,
        }
    }
}

impl OscillatorModel {
    /// The constants of `p` (not validated here).
    pub fn new(p: &OscillatorParams) -> Self {
        Self {
            w0: p.w0(),
            zeta: p.damping_ratio,
            drive: p.drive,
            amplitude_gain: AMPLITUDE_GAIN,
            drive_time_constant_s: p.drive_time_constant_s,
            energy_ref: p.energy_ref(),
        }
    }

    /// The drive's gain `g = max(0, 2 zeta w0 (1 + k_a (1 - E_lp/E_ref)))` [1/s] for the
    /// low-passed energy `energy_lp` [m^2/s^2]; 0 with the drive off.
    pub fn drive_gain(&self, energy_lp: f64) -> f64 {
        if !self.drive {
            return 0.0;
        }
        let c = 2.0 * self.zeta * self.w0;
        (c * (1.0 + self.amplitude_gain * (1.0 - energy_lp / self.energy_ref))).max(0.0)
    }

    /// The drive's measure of the oscillation energy per unit mass [m^2/s^2] about the
    /// quasi-static centre `c_b = -f_ib_b/w0^2` of the specific force `f_ib_b` [m/s^2]:
    /// `E = |v_b|^2/2 + w0^2 |r_b - c_b|^2/2`, the free oscillation's invariant with the
    /// centre's rate `v_c` (~`|f_ib'|/w0^2`) left out (module doc).
    pub fn energy(&self, s: &OscState, f_ib_b: &Vector3<f64>) -> f64 {
        let w2 = self.w0 * self.w0;
        let u = s.r_b_m + f_ib_b / w2;
        0.5 * (s.v_b_mps.norm_squared() + w2 * u.norm_squared())
    }

    /// `d(state)/dt` with the body's `omega_ib_b` [rad/s] and `f_ib_b` [m/s^2] (module doc).
    pub fn deriv(
        &self,
        s: &OscState,
        omega_ib_b: &Vector3<f64>,
        f_ib_b: &Vector3<f64>,
    ) -> OscState {
        let rdot = s.rdot_rel(omega_ib_b);
        // Net force along the relative velocity per unit mass and speed: drive - damping.
        let gamma = self.drive_gain(s.energy_m2ps2) - 2.0 * self.zeta * self.w0;
        OscState {
            r_b_m: rdot,
            v_b_mps: -omega_ib_b.cross(&s.v_b_mps) - s.r_b_m * (self.w0 * self.w0) - f_ib_b
                + rdot * gamma,
            energy_m2ps2: (self.energy(s, f_ib_b) - s.energy_m2ps2) / self.drive_time_constant_s,
        }
    }

    /// The state on the nominal ellipse of `p` (scaled by `p.start_scale`) about the centre
    /// `centre_b` [m] moving at `centre_rate_b` [m/s] (its inertial rate; both body axes):
    /// `r_b = centre_b + P e1`, `v_b = w0 Q e2 + centre_rate_b`, `E_lp = E_ref`.
    pub fn start(
        &self,
        p: &OscillatorParams,
        centre_b: &Vector3<f64>,
        centre_rate_b: &Vector3<f64>,
    ) -> OscState {
        let e1 = p.ellipse_b * Vector3::x();
        let e2 = p.ellipse_b * Vector3::y();
        let s = p.start_scale;
        OscState {
            r_b_m: centre_b + e1 * (s * p.major_m),
            v_b_mps: e2 * (s * self.w0 * p.minor_m) + centre_rate_b,
            energy_m2ps2: self.energy_ref,
        }
    }
}

/// The quasi-static centre of `traj`'s oscillator at `t = 0`, body axes: `(centre [m], its
/// inertial rate [m/s])`, the forced response `rho_p = -f_ib_i/w0^2 + f_ib_i''/w0^4` and
/// `rho_p' = -f_ib_i'/w0^2` of `rho'' + w0^2 rho = -f_ib_i` (next terms `f''''/w0^6`,
/// `f'''/w0^4`). The derivatives of `f_ib_i = C_b_i f_ib_b` are 4-point forward differences
/// over [`CENTRE_STEP_S`] steps at the start point (errors `h^3 f''''/4` and
/// `11 h^2 f''''/12`).
pub fn quasi_static_centre(traj: &dyn Trajectory, w0: f64) -> (Vector3<f64>, Vector3<f64>) {
    let p0 = traj.start();
    let h = CENTRE_STEP_S;
    let f_i = |k: u32| {
        let t = f64::from(k) * h;
        q_b_i(&truth_at(traj, t, &p0)) * sensed_at(traj, t, &p0).1
    };
    let [f0, f1, f2, f3] = [f_i(0), f_i(1), f_i(2), f_i(3)];
    let d1 = (f0 * -11.0 + f1 * 18.0 - f2 * 9.0 + f3 * 2.0) / (6.0 * h);
    let d2 = (f0 * 2.0 - f1 * 5.0 + f2 * 4.0 - f3) / (h * h);
    let w2 = w0 * w0;
    let q_i_b = q_b_i(&truth_at(traj, 0.0, &p0)).inverse();
    (q_i_b * (-f0 / w2 + d2 / (w2 * w2)), q_i_b * (-d1 / w2))
}

/// The oscillator as a [`Rider`] of the trajectory generator: its constants and its state (the
/// derivative carries the constants along unused).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscRider {
    /// Constants.
    pub model: OscillatorModel,
    /// State.
    pub state: OscState,
}

impl Rider for OscRider {
    fn deriv(&self, _t: f64, omega_ib_b: &Vector3<f64>, f_ib_b: &Vector3<f64>) -> Self {
        Self {
            model: self.model,
            state: self.model.deriv(&self.state, omega_ib_b, f_ib_b),
        }
    }

    fn axpy(&self, k: &Self, s: f64) -> Self {
        Self {
            model: self.model,
            state: self.state.axpy(&k.state, s),
        }
    }
}

/// `q_b_i`, body to inertial (ECEF frozen at `t = 0`), of a truth:
/// `C_b_i = R_z(OMEGA_IE t) C_n_e(lat, lon) C_b_n`, `C_n_e = R_z(lon) R_y(-(pi/2 + lat))`
/// (Groves eq. 2.150). A vector fixed in ECEF turns by `+OMEGA_IE t` about the polar axis in
/// the inertial frame.
pub fn q_b_i(truth: &Truth) -> UnitQuaternion<f64> {
    let q_n_e = about_z(truth.lon) * about_y(-(core::f64::consts::FRAC_PI_2 + truth.lat));
    about_z(OMEGA_IE * truth.t_s) * q_n_e * truth.q_b_ned
}

/// One readout sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscSample {
    /// Time [s].
    pub t_s: f64,
    /// Measured displacement, body axes [m] (with readout noise).
    pub r_b_m: Vector3<f64>,
}

/// The truth at a sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscTruth {
    /// Time [s].
    pub t_s: f64,
    /// Body-to-inertial attitude (inertial = ECEF frozen at `t = 0`).
    pub q_b_i: UnitQuaternion<f64>,
    /// Mean body rate over the sample interval, `delta_theta_ib_b / dt`, body axes [rad/s].
    pub omega_ib_b: Vector3<f64>,
    /// Mean specific force over the interval, `delta_v_ib_b / dt`, body axes [m/s^2].
    pub f_ib_b: Vector3<f64>,
    /// Exact (noise-free) displacement, body axes [m].
    pub r_b_m: Vector3<f64>,
    /// Inertial rate of the displacement, body axes [m/s].
    pub v_b_mps: Vector3<f64>,
    /// The drive's low-passed oscillation energy per unit mass `E_lp` [m^2/s^2].
    pub energy_m2ps2: f64,
    /// The trajectory's truth (position, NED velocity, `q_b_ned`).
    pub nav: Truth,
    /// The exact IMU increment over the interval.
    pub inc: ImuIncrement<f64>,
}

/// What a run returns besides the samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscillatorRun {
    /// The initial ellipse's axes in the inertial frame, `q_b_i(0) ellipse_b` (columns `e1`,
    /// `e2`, `e3`): the frame an ideal estimator recovers.
    pub ellipse_i: UnitQuaternion<f64>,
    /// Number of samples.
    pub samples: u64,
}

/// Runs the oscillator along `traj` for `seconds` [s], calling `visit(k, sample, truth)` for
/// every sample `k` at `t = (k + 1)/sample_rate` (rounded to ns as
/// [`crate::trajectory::generate`]).
///
/// The readout noise is `readout_noise_m` times standard normals from
/// `ChaCha8Rng::seed_from_u64(seed)`, three per sample (x, y, z), drawn even when the noise is
/// 0: the same seed gives the same samples.
pub fn simulate_oscillator(
    traj: &dyn Trajectory,
    params: &OscillatorParams,
    seconds: f64,
    mut visit: impl FnMut(u64, &OscSample, &OscTruth),
) -> Result<OscillatorRun> {
    params.validate()?;
    params.readouts_in(seconds)?;
    let model = OscillatorModel::new(params);
    let mut generator = Generator::with_substeps(traj, params.substeps);
    let ellipse_i = q_b_i(&generator.truth()) * params.ellipse_b;

    let (centre_b, centre_rate_b) = quasi_static_centre(traj, model.w0);
    let mut rider = OscRider {
        model,
        state: model.start(params, &centre_b, &centre_rate_b),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let sampling = Sampling::new(params.sample_rate_hz, seconds);
    for k in 0..sampling.n {
        let t_s = sampling.t_ns(k) as f64 * 1e-9;
        let (inc, nav) = generator.advance_with(t_s, &mut rider);
        let n: [f64; 3] = [
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
            StandardNormal.sample(&mut rng),
        ];
        let s = rider.state;
        let sample = OscSample {
            t_s,
            r_b_m: s.r_b_m + Vector3::from(n) * params.readout_noise_m,
        };
        let truth = OscTruth {
            t_s,
            q_b_i: q_b_i(&nav),
            omega_ib_b: inc.delta_theta_ib_b / inc.dt,
            f_ib_b: inc.delta_v_ib_b / inc.dt,
            r_b_m: s.r_b_m,
            v_b_mps: s.v_b_mps,
            energy_m2ps2: s.energy_m2ps2,
            nav,
            inc,
        };
        visit(k, &sample, &truth);
    }
    Ok(OscillatorRun {
        ellipse_i,
        samples: sampling.n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn start_is_on_the_nominal_ellipse() {
        let p = OscillatorParams::default();
        let m = OscillatorModel::new(&p);
        let c = Vector3::new(0.1, -0.2, -9.8) / -(m.w0 * m.w0);
        let s = m.start(&p, &c, &Vector3::zeros());
        let e1 = p.ellipse_b * Vector3::x();
        let e2 = p.ellipse_b * Vector3::y();
        assert!((s.r_b_m - c - e1 * p.major_m).norm() < 1e-18);
        assert!((s.v_b_mps - e2 * m.w0 * p.minor_m).norm() < 1e-15);
        // The low pass starts at the set point; the ellipse's energy about the centre
        // (c_b = -f_ib_b/w0^2) is w0^2 (P^2 + Q^2)/2 (rounding of the 1e-5 m terms: 1e-16).
        assert_eq!(s.energy_m2ps2, p.energy_ref());
        let e = m.energy(&s, &(c * -(m.w0 * m.w0)));
        assert!((e / p.energy_ref() - 1.0).abs() < 1e-12, "{e}");
    }

    #[test]
    fn energy_does_not_ripple_around_the_ellipse() {
        // Around the nominal ellipse (about a centre at rest) the squared speed swings between
        // w0^2 Q^2 and w0^2 P^2; the energy about the centre stays at w0^2 (P^2 + Q^2)/2.
        let p = OscillatorParams::default();
        let m = OscillatorModel::new(&p);
        let f = Vector3::new(0.3, -0.1, -9.8);
        let c = f / -(m.w0 * m.w0);
        let (e1, e2) = (p.ellipse_b * Vector3::x(), p.ellipse_b * Vector3::y());
        let (mut lo, mut hi) = (f64::MAX, f64::MIN);
        for k in 0..16 {
            let psi = f64::from(k) * std::f64::consts::TAU / 16.0;
            let s = OscState {
                r_b_m: c + e1 * (p.major_m * psi.cos()) + e2 * (p.minor_m * psi.sin()),
                v_b_mps: (e2 * (p.minor_m * psi.cos()) - e1 * (p.major_m * psi.sin())) * m.w0,
                energy_m2ps2: 0.0,
            };
            let speed2 = s.v_b_mps.norm_squared();
            (lo, hi) = (lo.min(speed2), hi.max(speed2));
            let e = m.energy(&s, &f);
            assert!((e / m.energy_ref - 1.0).abs() < 1e-12, "{k}: {e}");
        }
        assert!((hi - lo) / m.energy_ref > 1.19, "{lo} {hi}");
    }

    #[test]
    fn drive_gain_balances_damping_at_the_reference() {
        let p = OscillatorParams {
            damping_ratio: 1e-3,
            ..OscillatorParams::default()
        };
        let m = OscillatorModel::new(&p);
        let c = 2.0 * p.damping_ratio * m.w0;
        assert!((m.drive_gain(m.energy_ref) - c).abs() < 1e-15);
        assert!(m.drive_gain(m.energy_ref * 1.5) < c);
        assert_eq!(m.drive_gain(m.energy_ref * 3.0), 0.0);
        let off = OscillatorModel { drive: false, ..m };
        assert_eq!(off.drive_gain(0.0), 0.0);
    }

    #[test]
    fn q_b_i_is_the_ned_frame_turned_with_the_earth() {
        // At lat 0, lon 0, t = 0: north is ECEF z, east is y, down is -x.
        let t = Truth {
            t_s: 0.0,
            lat: 0.0,
            lon: 0.0,
            h: 0.0,
            v_eb_ned: Vector3::zeros(),
            q_b_ned: UnitQuaternion::identity(),
        };
        let q = q_b_i(&t);
        assert!((q * Vector3::x() - Vector3::z()).norm() < 1e-15);
        assert!((q * Vector3::y() - Vector3::y()).norm() < 1e-15);
        assert!((q * Vector3::z() + Vector3::x()).norm() < 1e-15);
        // A quarter of a sidereal day later, down points along -y of the frozen frame.
        let later = Truth {
            t_s: std::f64::consts::FRAC_PI_2 / OMEGA_IE,
            ..t
        };
        assert!((q_b_i(&later) * Vector3::z() + Vector3::y()).norm() < 1e-12);
    }
}
