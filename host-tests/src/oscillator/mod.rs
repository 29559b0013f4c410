//! The isotropic-oscillator sensor simulator ([Oscillator INS]): the
//! displacement of a spring-suspended proof mass, observed in body axes, for a body that rotates
//! and accelerates along a [`Trajectory`](crate::trajectory::Trajectory).
//!
//! # Frames
//!
//! `i` is the inertial frame: ECEF frozen at `t = 0` (a vector fixed in ECEF turns in it with the
//! Earth, `C_e_i(t) = R_z(OMEGA_IE t)`), so `C_b_i(t) = R_z(OMEGA_IE t) C_n_e(lat, lon) C_b_n(t)`
//! ([`sim::q_b_i`]). `b` is the body (FRD) frame of the trajectory, `n` its NED frame.
//!
//! # Equations
//!
//! The mass sits at `rho_i = C_b_i r_b` [m] from its suspension point (the case). Mass and case
//! feel the same gravitation (the gradient over 20 um, ~6e-11 m/s^2, is neglected), so relative
//! to the case, in inertial axes,
//!
//! ```text
//! rho_i'' = -w0^2 rho_i - f_ib_i + F_i/m,        w0 = 2 pi f0,
//! ```
//!
//! with `f_ib` the case's specific force (what an accelerometer senses, `a - g`) and `F` the
//! damping and drive forces. The state is integrated in body axes: `r_b` and
//! `v_b = C_i_b rho_i'` (the inertial rate of the displacement, resolved in body axes; transport
//! theorem `v_b = dr_b/dt + omega_ib_b x r_b`):
//!
//! ```text
//! dr_b/dt = v_b - omega_ib_b x r_b                                   (= rdot_rel)
//! dv_b/dt = -omega_ib_b x v_b - w0^2 r_b - f_ib_b + (F_damp + F_drive)/m
//! F_damp/m  = -2 zeta w0 rdot_rel                                    (relative to the case)
//! F_drive/m = g(t) rdot_rel,   g = max(0, 2 zeta w0 (1 + k_a (1 - E_lp/E_ref)))   (drive on)
//! dE_lp/dt  = (E - E_lp) / tau,   E = |v_b|^2/2 + w0^2 |r_b - c_b|^2/2,   c_b = -f_ib_b/w0^2
//! ```
//!
//! Expanding `v_b` gives the classic relative-motion form
//! `r'' = -w0^2 r - 2 zeta w0 r' - f - omega_dot x r - omega x (omega x r) - 2 omega x r'` (+ the
//! drive); the `(r_b, v_b)` form is used because it needs no angular acceleration, only the
//! `omega_ib_b` and `f_ib_b` that the trajectory generator already evaluates at each RK4 stage
//! ([`Rider`](crate::trajectory::Rider)).
//!
//! **Drive** (amplitude keeping, like the energy loop of a hemispherical resonator gyro): `E` is
//! the oscillation energy per unit mass about the quasi-static centre `c_b = -f_ib_b/w0^2`
//! ([`sim::OscillatorModel::energy`]); `E_lp`, its first-order low pass (time constant `tau` =
//! [`OscillatorParams::drive_time_constant_s`]), is held at `E_ref = w0^2 (P^2 + Q^2)/2`
//! ([`OscillatorParams::energy_ref`]), the nominal ellipse's energy; loop gain `k_a` =
//! [`sim::AMPLITUDE_GAIN`]. `E_lp` is part of the integrated state and starts at `E_ref`. The
//! drive electronics know the centre from the readout's non-periodic part (its mean over a
//! period, or `-f_ib_b/w0^2` from the specific force); the simulator takes `c_b` from the
//! specific force of each RK4 stage. With the drive off, `g = 0` and the oscillation decays as
//! `exp(-zeta w0 t)`; with `zeta = 0` there is neither damping nor drive force. A force along
//! the velocity keeps the ellipse's shape and orientation: with `F = gamma rho'`, the angular
//! momentum `L = rho x rho'` obeys `dL/dt = gamma L`, and the Fradkin tensor
//! `T = rho' rho'^T + w0^2 rho rho^T` (whose eigenvectors are the ellipse axes and eigenvalues
//! `w0^2 P^2`, `w0^2 Q^2`) obeys `dT/dt = 2 gamma rho' rho'^T`, on average over a period
//! `gamma T`: energy, angular momentum and `T` are scaled alike, as long as `gamma` does not
//! ripple at `2 w0` (below).
//!
//! **The energy measure.** With `u = rho_i - c_i` (`c_i = -f_ib_i/w0^2`) the free oscillation
//! obeys `u'' + w0^2 u = -c_i'' + F/m`, so `E* = |u'|^2/2 + w0^2 |u|^2/2` is constant up to the
//! work of `F` and of the centre's acceleration, `dE*/dt = u'.(F/m - c_i'')`. Both terms are
//! rotation invariant; in body axes `u_b = r_b - c_b` and `C_i_b u' = v_b - v_c`, with
//! `v_c = C_i_b c_i' = -(f_ib_b' + omega_ib_b x f_ib_b)/w0^2` the centre's inertial rate. `v_c`
//! needs the derivative of the specific force, which a [`Rider`](crate::trajectory::Rider) stage
//! does not get, and is left out: `E = E* + u'.v_c + |v_c|^2/2`. With `|v_c| = |f_ib_i'|/w0^2`
//! against the oscillation speed `w0 Q..w0 P` (on `ship-rocking` `|f_ib_i'|` reaches
//! 0.88 m/s^3: `|v_c|` = 2.2e-6 m/s against `w0 Q` = 6.3e-3 m/s, 3.5e-4), the cross term is a
//! ripple at `w0` (plus and minus the body's motion frequencies) of at most
//! `2 P |f_ib_i'|/(w0^3 (P^2 + Q^2))` = 2.8e-4 of `E_ref`, 4.5e-7 after the low pass
//! (`/(w0 tau)`), and the square a set-point bias of `(|f_ib_i'|/w0^3)^2/(P^2 + Q^2)` =
//! 2.5e-8; the centre's acceleration (`|f_ib_i''|/w0^2` = 2.2e-6 m/s^2 at the ship's 0.86
//! m/s^4) adds a `w0` ripple of `P |f_ib_i''|/(w0^2 E_ref)` = 4.4e-7 (7e-10 after the low
//! pass). None of them has a `2 w0` component, which is what would turn the ellipse (below).
//! Taking `v_c` from a finite difference of `f_ib_b` would need the previous stage's specific
//! force in the state, which RK4's stages (evaluated out of order, combined linearly) cannot
//! carry cleanly, for a gain that the residual below shows to be second order.
//!
//! **Initial state** (`t = 0`): the nominal ellipse, semi-major axis `P` along `e1`, semi-minor
//! `Q` along `e2` (`e_k = ellipse_b unit_k`, body axes at `t = 0`), travelled from `e1` towards
//! `e2` (angular momentum along `e3 = e1 x e2`), about the quasi-static centre: the forced
//! response of `rho'' + w0^2 rho = -f_ib_i` to the slowly varying specific force,
//! `rho_p = -f_ib_i/w0^2 + f_ib_i''/w0^4 - ...` ([`sim::quasi_static_centre`]):
//!
//! ```text
//! r_b(0) = C_i_b rho_p(0) + P e1        (rho_p(0) ~ -f_ib_i/w0^2: c0 = -f_ib_b(0)/w0^2)
//! v_b(0) = w0 Q e2 + C_i_b rho_p'(0)    (rho_p'(0) = -f_ib_i'/w0^2)
//! ```
//!
//! so that the free oscillation, `rho_i - rho_p`, is exactly the nominal ellipse. The two
//! correction terms (refinements of `c0 = -f_ib_b/w0^2`, `v_b(0) = w0 Q e2`) matter at the
//! 1e-4 level: at the start of `ship-rocking` (`|f_ib_i'|` = 0.39 m/s^3, `|f_ib_i''|` = 0.58
//! m/s^4 at the 30 m lever arm) they are `|f'|/w0^3` = 1.6e-9 m and `|f''|/w0^4` = 3.7e-12 m,
//! which would tilt a 10 um semi-minor axis by up to 1.6e-4 and 3.7e-7 rad (at rest, the
//! Earth's rotation gives `|f'|` = 5e-4 m/s^3: 2e-7 rad). The derivatives are finite
//! differences over 3 ms at the start. [`OscillatorParams::start_scale`] scales `P` and `Q` of
//! the start (not `E_ref`) to test the loop.
//!
//! # Effects on the ellipse (what a gyro-free estimator sees)
//!
//! - **Case-relative damping drags the ellipse**: its `2 zeta w0 omega x rho` term (`omega` the
//!   case's inertial rate) gives, averaged over a period, `dT/dt = -zeta w0^2 P Q (e3 omega^T +
//!   omega e3^T - 2 (omega . e3) I)`: `P^2` and `Q^2` both change by `2 zeta P Q omega_3` per
//!   second, the plane does not turn in itself, and it tilts at `zeta omega_1 Q/P` about `e2`
//!   and `-zeta omega_2 P/Q` about `e1` (a resonant out-of-plane push, 90 deg behind the
//!   motion). With the drive on and balanced, the drive (also along `rdot_rel`) cancels it: the
//!   net force is `(g - 2 zeta w0) rdot_rel`, zero on average.
//! - **Why the drive measures the energy: a `2 w0` gain ripple turns the ellipse in its plane.**
//!   With a net gain `gamma~ = G sin(2 w0 t)` (`t` from the passage through `e1`),
//!   `dT/dt = 2 gamma~ rho' rho'^T` has the mean off-diagonal
//!   `<2 G sin(2 w0 t) (-w0^2 P Q sin(2 w0 t)/2)> = -G w0^2 P Q/2`, and `T` turned by `theta_3`
//!   about `e3` has `T_12 = theta_3 w0^2 (P^2 - Q^2)`: `dtheta_3/dt = -G P Q/(2 (P^2 - Q^2))`.
//!   The obvious amplitude measure, a low pass of `|rdot_rel|^2`, has that ripple:
//!   `|rdot_rel|^2` swings by `-w0^2 (P^2 - Q^2)/2 cos(2 w0 t)`, the low pass lags it by 90 deg
//!   (`2 w0 tau >> 1`) into `-w0 (P^2 - Q^2) sin(2 w0 t)/(4 tau)`, so `G = zeta k_a eps/tau`,
//!   `eps = (P^2 - Q^2)/(P^2 + Q^2)`, and
//!
//!   ```text
//!   dtheta_3/dt = -zeta k_a P Q / (2 tau (P^2 + Q^2))     (against the sense of travel)
//!   ```
//!
//!   -2e-4 rad/s (41 deg/h) for `zeta` 1e-3, `tau` 1 s, `P = 2 Q`: a turn a gyro-free estimator
//!   would read as a rotation of the body. A real amplitude loop (HRG) demodulates at the
//!   resonance and has no such ripple; the energy `E` has none either, being an invariant of
//!   the free motion. What is left of the in-plane drift:
//!   - `E`'s `w0` ripples (above): a `w0` gain ripple times `rho' rho'^T` (`0` and `2 w0`)
//!     averages to zero, so the first-order turn is zero on average. Times the slow part of
//!     `rdot_rel` (`~|f_ib_i'|/w0^2`) it is a resonant force, which turns `T` at most at
//!     `4 zeta k_a |f_ib_i'|^2/(w0^6 tau (P^2 + Q^2))` = 1e-10 rad/s on the ship: second
//!     order.
//!   - `E`'s `2 w0` ripple: `dE/dt = gamma u'.rdot_rel` with `gamma = g - 2 zeta w0` the net
//!     gain and `u'.rdot_rel = |u'|^2 - omega.L + (slow) . u'` (`omega.L` constant over a
//!     period), so `E` swings by `-gamma w0 (P^2 - Q^2) sin(2 w0 t)/4`; the low pass lags that by
//!     a further 90 deg into a `cos(2 w0 t)` gain, which trades `P` against `Q` but does not turn
//!     the axes, except for its in-phase leak `1/(2 w0 tau)^2`:
//!     `|dtheta_3/dt| = zeta k_a |gamma| P Q/(8 w0^2 tau^2 (P^2 + Q^2))`, second order again
//!     (`gamma` vanishes once the drive balances the damping; in the 10 % recovery
//!     `|gamma| < 2 zeta w0 k_a 0.21` = 0.26/s: 3e-11 rad/s).
//!
//!   So the in-plane drift is zero on average to first order in the drive's ripple, and what
//!   is left is of order `zeta k_a/tau (|f_ib_i'|^2/(w0^6 (P^2 + Q^2)) + |gamma|/(8 w0^2 tau))`,
//!   ~1e-10 rad/s (1e-9 rad in 10 s of ship rocking), at RK4's floor (the test measures
//!   1.5e-10 rad against the undamped run).
//! - **Numerics**: RK4 with `h = 1/(sample_rate substeps)` lags the phase by `(w0 h)^5/120` per
//!   step (an isotropic phase error: orientation and shape unaffected) and damps the amplitude
//!   by `(w0 h)^6/144`: at 5 kHz x 4, 5e-5 rad and 1.3e-6 after 10 s.

pub mod bench;
pub mod file;
pub mod navigate;
pub mod replay;
pub mod sim;

pub use sim::{
    OscRider, OscSample, OscState, OscTruth, OscillatorModel, OscillatorRun, q_b_i,
    quasi_static_centre, simulate_oscillator,
};

use anyhow::{Result, bail};
use nav_core::number::{Number, Rounded};
use nav_core::{UnitQuaternion, attitude};
use std::f64::consts::TAU;
use std::fmt::Write as _;

/// The oscillator sensor's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OscillatorParams {
    /// Natural frequency `f0` [Hz].
    pub f0_hz: f64,
    /// Damping ratio `zeta` [-] (relative to the case); 0: none (and no drive force).
    pub damping_ratio: f64,
    /// Semi-major axis `P` of the nominal ellipse [m].
    pub major_m: f64,
    /// Semi-minor axis `Q` of the nominal ellipse [m] (`0 <= Q <= P`).
    pub minor_m: f64,
    /// Orientation of the nominal ellipse in body axes at `t = 0`: its columns are `e1` (major
    /// axis), `e2` (minor axis), `e3 = e1 x e2` (normal; the sense of travel is from `e1` to
    /// `e2`).
    pub ellipse_b: UnitQuaternion<f64>,
    /// Amplitude-keeping drive on.
    pub drive: bool,
    /// Time constant `tau` of the low pass of the drive's energy measure [s].
    pub drive_time_constant_s: f64,
    /// Readout sample rate [Hz].
    pub sample_rate_hz: f64,
    /// Readout noise, 1 sigma per axis per sample [m].
    pub readout_noise_m: f64,
    /// Seed of the readout noise.
    pub seed: u64,
    /// RK4 steps per sample interval.
    pub substeps: usize,
    /// Scale of the start ellipse relative to `P`, `Q` [-] (the drive's reference stays at
    /// `P`, `Q`): 1.1 starts 10 % large.
    pub start_scale: f64,
}

impl Default for OscillatorParams {
    fn default() -> Self {
        Self {
            f0_hz: 100.0,
            damping_ratio: 0.0,
            major_m: 20e-6,
            minor_m: 10e-6,
            ellipse_b: attitude::from_euler(0.3, -0.5, 0.9),
            drive: true,
            drive_time_constant_s: 1.0,
            sample_rate_hz: 5000.0,
            readout_noise_m: 1e-9,
            seed: 1,
            substeps: crate::trajectory::SUBSTEPS,
            start_scale: 1.0,
        }
    }
}

/// Fewest RK4 steps per oscillator period that [`OscillatorParams::validate`] accepts (phase
/// lag `(2 pi/32)^5/120` = 2.4e-6 rad per step).
pub const MIN_STEPS_PER_PERIOD: f64 = 32.0;

/// Most readouts one simulation makes: 2000 s at the default 5 kHz, about a minute of one
/// core (the bench keeps every readout in memory, some 80 bytes each).
pub const MAX_READOUTS: f64 = 1e7;

impl OscillatorParams {
    /// `w0 = 2 pi f0` [rad/s].
    pub fn w0(&self) -> f64 {
        TAU * self.f0_hz
    }

    /// `E_ref = w0^2 (P^2 + Q^2)/2` [m^2/s^2]: the nominal ellipse's oscillation energy per
    /// unit mass (and its mean squared speed), the drive's set point.
    pub fn energy_ref(&self) -> f64 {
        let w0 = self.w0();
        w0 * w0 * (self.major_m.powi(2) + self.minor_m.powi(2)) / 2.0
    }

    /// Checks the parameters: finite, positive where they must be, `P >= Q >= 0`, a damping
    /// ratio in `[0, 1)`, a drive time constant of at least a period, a sample rate of at least
    /// `8 f0` and at least [`MIN_STEPS_PER_PERIOD`] RK4 steps per period.
    pub fn validate(&self) -> Result<()> {
        let positive = |key: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!("{key} must be a positive finite number, not {v}");
            }
            Ok(())
        };
        positive("f0_hz", self.f0_hz)?;
        if !(self.damping_ratio.is_finite() && (0.0..1.0).contains(&self.damping_ratio)) {
            bail!(
                "damping_ratio must be within [0, 1), not {}",
                self.damping_ratio
            );
        }
        positive("major_m", self.major_m)?;
        if !(self.minor_m.is_finite() && (0.0..=self.major_m).contains(&self.minor_m)) {
            bail!(
                "minor_m must be within [0, major_m = {}], not {}",
                self.major_m,
                self.minor_m
            );
        }
        let q = self.ellipse_b.quaternion();
        if !(q.coords.iter().all(|c| c.is_finite()) && (q.norm() - 1.0).abs() < 1e-9) {
            bail!("ellipse_b must be a unit quaternion, not {q:?}");
        }
        positive("drive_time_constant_s", self.drive_time_constant_s)?;
        if self.drive_time_constant_s * self.f0_hz < 1.0 {
            bail!(
                "drive_time_constant_s must be at least one period (1/f0 = {} s) to average the amplitude, not {}",
                1.0 / self.f0_hz,
                self.drive_time_constant_s
            );
        }
        positive("sample_rate_hz", self.sample_rate_hz)?;
        if self.sample_rate_hz < 8.0 * self.f0_hz {
            bail!(
                "sample_rate_hz must be at least 8 f0 = {} Hz, not {}",
                8.0 * self.f0_hz,
                self.sample_rate_hz
            );
        }
        if !(self.readout_noise_m.is_finite() && self.readout_noise_m >= 0.0) {
            bail!(
                "readout_noise_m must be a finite number >= 0, not {}",
                self.readout_noise_m
            );
        }
        let steps = self.sample_rate_hz * self.substeps as f64 / self.f0_hz;
        if self.substeps == 0 || steps < MIN_STEPS_PER_PERIOD {
            bail!(
                "substeps = {} gives {steps} RK4 steps per oscillator period; at least {MIN_STEPS_PER_PERIOD} are needed",
                self.substeps
            );
        }
        positive("start_scale", self.start_scale)?;
        Ok(())
    }

    /// The readouts in `seconds` [s] at [`Self::sample_rate_hz`]; refused: a length that is not
    /// a finite number >= 0, or more than [`MAX_READOUTS`] readouts.
    pub fn readouts_in(&self, seconds: f64) -> Result<u64> {
        if !(seconds.is_finite() && seconds >= 0.0) {
            bail!(
                "seconds must be a finite number >= 0, not {}",
                Number(seconds)
            );
        }
        let n = (seconds * self.sample_rate_hz).round();
        if n > MAX_READOUTS {
            bail!(
                "{} s at {} readouts/s (50 f0) is {} readouts: at most {} are simulated ({} s at \
                 this rate)",
                Number(seconds),
                Number(self.sample_rate_hz),
                Rounded(n),
                Rounded(MAX_READOUTS),
                Rounded(MAX_READOUTS / self.sample_rate_hz)
            );
        }
        Ok(n as u64)
    }

    /// The parameters as `key = value` lines (SI units as the keys say; the ellipse
    /// orientation as roll, pitch, yaw of `ellipse_b` [deg]).
    pub fn describe(&self) -> String {
        let (r, p, y) = attitude::euler(&self.ellipse_b);
        let mut s = String::new();
        let mut line = |k: &str, v: String| {
            // Writing to a String cannot fail.
            let _ = writeln!(s, "{k} = {v}");
        };
        line("f0_hz", self.f0_hz.to_string());
        line("damping_ratio", self.damping_ratio.to_string());
        line("major_m", self.major_m.to_string());
        line("minor_m", self.minor_m.to_string());
        line(
            "ellipse_b_euler_deg",
            format!("{}, {}, {}", r.to_degrees(), p.to_degrees(), y.to_degrees()),
        );
        line("drive", self.drive.to_string());
        line(
            "drive_time_constant_s",
            self.drive_time_constant_s.to_string(),
        );
        line("sample_rate_hz", self.sample_rate_hz.to_string());
        line("readout_noise_m", self.readout_noise_m.to_string());
        line("seed", self.seed.to_string());
        line("substeps", self.substeps.to_string());
        line("start_scale", self.start_scale.to_string());
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_described() {
        let p = OscillatorParams::default();
        p.validate().unwrap();
        let d = p.describe();
        assert!(d.contains("f0_hz = 100\n"), "{d}");
        assert!(d.contains("ellipse_b_euler_deg = "), "{d}");
        assert_eq!(d.lines().count(), 12);
        // w0^2 (P^2 + Q^2)/2 with w0 = 200 pi.
        let w0 = 200.0 * std::f64::consts::PI;
        assert!((p.energy_ref() - w0 * w0 * 5e-10 / 2.0).abs() < 1e-18);
    }

    #[test]
    fn bad_parameters_are_refused() {
        let ok = OscillatorParams::default();
        let cases: [(&str, OscillatorParams); 9] = [
            ("f0_hz", OscillatorParams { f0_hz: 0.0, ..ok }),
            (
                "damping_ratio",
                OscillatorParams {
                    damping_ratio: 1.0,
                    ..ok
                },
            ),
            (
                "major_m",
                OscillatorParams {
                    major_m: f64::NAN,
                    ..ok
                },
            ),
            (
                "minor_m",
                OscillatorParams {
                    minor_m: 30e-6,
                    ..ok
                },
            ),
            (
                "sample_rate_hz",
                OscillatorParams {
                    sample_rate_hz: 700.0,
                    ..ok
                },
            ),
            (
                "readout_noise_m",
                OscillatorParams {
                    readout_noise_m: -1.0,
                    ..ok
                },
            ),
            ("substeps", OscillatorParams { substeps: 0, ..ok }),
            (
                "drive_time_constant_s",
                OscillatorParams {
                    drive_time_constant_s: 0.001,
                    ..ok
                },
            ),
            (
                "start_scale",
                OscillatorParams {
                    start_scale: 0.0,
                    ..ok
                },
            ),
        ];
        for (key, p) in cases {
            let msg = p.validate().unwrap_err().to_string();
            assert!(msg.starts_with(key), "{key}: {msg}");
        }
    }
}
