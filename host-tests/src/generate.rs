//! Synthetic recordings with exactly known inputs.
//!
//! A body at rest on the Earth senses the Earth rate and the reaction to gravity, resolved in its
//! own axes (Groves §5.6.1):
//! `omega_ib_b = c_n_b * omega_ie_n(lat)`, `f_ib_b = c_n_b * (0, 0, -normal_gravity(lat, h))`,
//! with `c_n_b = q_b_n^-1` from the body's roll, pitch and yaw. Both are computed in `f64` with
//! nav-core's Earth model; the recorded increments are `value * dt`, rounded once to `f32`.

use crate::recording_io::Recording;
use anyhow::{Result, ensure};
use hal_adapters::recording::{Kind, Record};
use nav_core::navigator::config::{MAX_HEIGHT_M, MIN_HEIGHT_M};
use nav_core::number::Number;
use nav_core::{Vector3, attitude, earth};

/// A stationary scenario: where the body stands, how it is oriented, how it is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stationary {
    /// Latitude [deg].
    pub lat_deg: f64,
    /// Longitude [deg] (the sensed inputs do not depend on it).
    pub lon_deg: f64,
    /// Ellipsoidal height [m].
    pub h_m: f64,
    /// Roll of the body (FRD) relative to NED [deg].
    pub roll_deg: f64,
    /// Pitch [deg].
    pub pitch_deg: f64,
    /// Yaw (true heading) [deg].
    pub yaw_deg: f64,
    /// Sampling rate [Hz].
    pub rate_hz: f64,
    /// Length of the recording [s].
    pub seconds: f64,
}

impl Default for Stationary {
    /// The CLI's defaults: 60 s at 400 Hz, 45 N 7.5 E 150 m, roll 1.5, pitch -2, yaw 30 deg.
    fn default() -> Self {
        Self {
            lat_deg: 45.0,
            lon_deg: 7.5,
            h_m: 150.0,
            roll_deg: 1.5,
            pitch_deg: -2.0,
            yaw_deg: 30.0,
            rate_hz: 400.0,
            seconds: 60.0,
        }
    }
}

/// Why a recording's sampling rate `rate_hz` [Hz] is not one to write or convert (`nav
/// generate`, `nav sim`, `nav convert`; nav-core's rule, `machine::check_rate`): not finite, above the navigator's highest
/// ([`nav_core::alignment::machine::MAX_RATE_HZ`]; a 50 kHz recording was written that every
/// replay refused), or so low that every increment is longer than the navigator accepts
/// (`nav_core::InputLimits::max_dt`, 0.1 s: 10 Hz), a recording whose every sample a replay
/// would refuse.
pub fn check_rate(rate_hz: f64) -> Result<()> {
    use nav_core::alignment::machine::{MAX_RATE_HZ, MIN_RATE_HZ, bad_rate_reason};
    ensure!(
        nav_core::alignment::machine::check_rate(rate_hz).is_ok(),
        "the rate must be within [{MIN_RATE_HZ}, {MAX_RATE_HZ}] Hz, the rates a replay navigates, \
         not {} ({})",
        Number(rate_hz),
        bad_rate_reason(rate_hz)
    );
    Ok(())
}

/// Sensor temperature written into synthetic records [deg C].
pub const TEMPERATURE_C: f32 = 25.0;

impl Stationary {
    /// `(omega_ib_b [rad/s], f_ib_b [m/s^2])` sensed by the body at rest, in `f64`.
    pub fn body_inputs(&self) -> (Vector3<f64>, Vector3<f64>) {
        let lat = self.lat_deg.to_radians();
        let q_b_n = attitude::from_euler(
            self.roll_deg.to_radians(),
            self.pitch_deg.to_radians(),
            self.yaw_deg.to_radians(),
        );
        let c_n_b = q_b_n.inverse();
        let omega_ib_b = c_n_b * earth::omega_ie_n(lat);
        let f_ib_b = c_n_b * Vector3::new(0.0, 0.0, -earth::normal_gravity(lat, self.h_m));
        (omega_ib_b, f_ib_b)
    }

    /// Number of samples: `round(seconds * rate_hz)`.
    pub fn sample_count(&self) -> u64 {
        (self.seconds * self.rate_hz).round() as u64
    }

    /// Time of the end of sample `k`'s interval [ns]: `round((k + 1) * 1e9 / rate)`.
    pub fn t_ns(&self, k: u64) -> u64 {
        ((k + 1) as f64 * 1e9 / self.rate_hz).round() as u64
    }

    /// The recording: increments, `t0_ns = 0`, record `k` ending at [`Self::t_ns`]`(k)`.
    ///
    /// Each increment is the constant input times its own interval `(t_ns(k) - t_ns(k-1)) / 1e9`
    /// (with `t_ns(-1) = 0`), which is what the replay measures as `dt`; at rates dividing 1e9
    /// every interval is the nominal one.
    ///
    /// Refused: a rate [`check_rate`] refuses, a length giving no sample (or more
    /// than [`crate::simulate::MAX_SAMPLES`]), a site `nav replay` would refuse (latitude, longitude,
    /// height range), a roll, pitch or yaw beyond +-180, +-90 or +-360 deg; and, independently, any record that is not finite
    /// or not after the previous one ([`crate::output_check::check_records`]).
    pub fn recording(&self) -> Result<Recording> {
        check_rate(self.rate_hz)?;
        ensure!(
            self.seconds.is_finite() && self.seconds > 0.0,
            "the duration must be positive, not {} s",
            Number(self.seconds)
        );
        ensure!(
            (-90.0..=90.0).contains(&self.lat_deg),
            "the latitude must be within [-90, 90] deg, not {}",
            Number(self.lat_deg)
        );
        ensure!(
            (-180.0..=180.0).contains(&self.lon_deg),
            "the longitude must be within [-180, 180] deg, not {}",
            Number(self.lon_deg)
        );
        ensure!(
            (MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&self.h_m),
            "the height must be within [{MIN_HEIGHT_M}, {MAX_HEIGHT_M}] m (the Earth model's range), not {}",
            Number(self.h_m)
        );
        for (name, v, limit) in [
            ("roll", self.roll_deg, 180.0),
            ("pitch", self.pitch_deg, 90.0),
            ("yaw", self.yaw_deg, 360.0),
        ] {
            ensure!(
                (-limit..=limit).contains(&v),
                "the {name} must be within [-{limit}, {limit}] deg, not {}",
                Number(v)
            );
        }
        crate::simulate::check_sample_count(
            crate::trajectory::Sampling::new(self.rate_hz, self.seconds),
            self.seconds,
        )?;
        let n = self.sample_count();
        let (omega_ib_b, f_ib_b) = self.body_inputs();
        let mut t_prev = 0_u64;
        let records = (0..n)
            .map(|k| {
                let t_ns = self.t_ns(k);
                let dt = (t_ns - t_prev) as f64 / 1e9;
                t_prev = t_ns;
                let to_f32 = |v: Vector3<f64>| [v.x as f32, v.y as f32, v.z as f32];
                Record {
                    t_ns,
                    gyro: to_f32(omega_ib_b * dt),
                    accel: to_f32(f_ib_b * dt),
                    temperature_c: TEMPERATURE_C,
                }
            })
            .collect::<Vec<_>>();
        crate::output_check::check_records(0, &records)
            .map_err(|e| anyhow::anyhow!("not a valid recording, nothing written: {e}"))?;
        Ok(Recording {
            kind: Kind::Increments,
            rate_hz: self.rate_hz,
            t0_ns: 0,
            records,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_are_earth_rate_and_gravity_in_body_axes() {
        let s = Stationary::default();
        let (w, f) = s.body_inputs();
        assert!((w.norm() - earth::OMEGA_IE).abs() < 1e-18);
        let g = earth::normal_gravity(45f64.to_radians(), 150.0);
        assert!((f.norm() - g).abs() < 1e-12);
        // Levelling (Groves eq. 5.101) reads pitch = atan2(f_x, |f_yz|): f_x = g sin(pitch).
        assert!((f.x - g * (-2f64).to_radians().sin()).abs() < 1e-12, "{f}");
    }

    #[test]
    fn timestamps_and_count() {
        let s = Stationary {
            rate_hz: 300.0,
            seconds: 1.0,
            ..Stationary::default()
        };
        let r = s.recording().unwrap();
        assert_eq!(r.records.len(), 300);
        assert_eq!(r.records[0].t_ns, 3_333_333);
        assert_eq!(r.records[1].t_ns, 6_666_667);
        assert_eq!(r.records[299].t_ns, 1_000_000_000);
        assert_eq!(r.records[0].temperature_c, 25.0);
        assert!(Stationary { rate_hz: 0.0, ..s }.recording().is_err());
    }
}
