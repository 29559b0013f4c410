//! Blank values: the fine filters as `const`s with nothing started, all zero, the storage
//! of filters started later in place (through `&mut`: [`FineCore::init_in`],
//! [`super::bank::Bank::init_in`], [`crate::alignment::sway::SwayAlignment::init_in`]).
//!
//! Why: a value of a few tens of KB built by value (`Some(Bank::new(..))`) is built on the
//! stack and then copied into its place; the sway filters are some 30 KB in `f32`, and an MCU
//! task's stack a few tens of KB. A slot assigned from a `const` is written where it lives
//! (all zero: one `memset`), and [`FineCore::init_in`] then starts the filter there.

use super::base::{ShapingBlock, Translation};
use super::integrator::SiteStrapdown;
use super::{FineConfig, FineCore, FineStatus, NoExtension};
use crate::alignment::{LeverArm, SensorNoise};
use crate::scalar::zeros;
use crate::{InputLimits, Position, Scalar};

/// A `const` value with nothing started: the storage of one started later in place (through
/// `&mut`, e.g. [`FineCore::init_in`]), so that a slot assigned from it is written where it
/// lives instead of being built on the stack and copied (the sway filters are some 30 KB in
/// `f32`; an MCU task's stack is a few tens of KB).
pub trait Blank {
    /// The value (all zero where it can be: the compiler writes it with one `memset`).
    const BLANK: Self;
}

impl Blank for NoExtension {
    const BLANK: Self = NoExtension;
}

impl<T: Scalar> FineConfig<T> {
    /// Every value zero (a known lever arm at the centre; not a usable configuration): the
    /// storage of a filter started later in place ([`FineCore::BLANK`]).
    pub(crate) const ZERO: Self = Self {
        noise: SensorNoise {
            arw_rad_per_sqrt_s: T::ZERO,
            vrw_mps_per_sqrt_s: T::ZERO,
            gyro_bias_rad_s: T::ZERO,
            accel_bias_mps2: T::ZERO,
        },
        gyro_bias_walk: T::ZERO,
        accel_bias_walk: T::ZERO,
        lever_arm: LeverArm::Known(zeros()),
        translation: Translation {
            horizontal_sigma_m: T::ZERO,
            vertical_sigma_m: T::ZERO,
            omega0_rad_s: T::ZERO,
            damping: T::ZERO,
            corner_rad_s: T::ZERO,
        },
        position_noise_m: T::ZERO,
        tilt_sigma_rad: T::ZERO,
        update_period_s: T::ZERO,
        gate_sigma: T::ZERO,
        max_heading_sigma_rad: T::ZERO,
        limits: InputLimits {
            max_dt: T::ZERO,
            max_rate: T::ZERO,
            max_specific_force: T::ZERO,
        },
    };
}

impl FineStatus {
    /// No increment yet (as `Default`, in a `const`).
    pub(crate) const ZERO: Self = Self {
        increments: 0,
        rejected_increments: 0,
        updates: 0,
        accepted_measurements: 0,
        rejected_measurements: 0,
        resets: 0,
        mean_nis: 0.0,
    };
}

impl<T: Scalar, const N: usize> Blank for FineCore<T, N> {
    /// A filter that has not started, all zero (no interval has run: it refuses with
    /// [`FineRefusal::NotStarted`]): the storage [`FineCore::init_in`] starts in place.
    const BLANK: Self = Self {
        config: FineConfig::ZERO,
        nav: SiteStrapdown::BLANK,
        centre: Position::BLANK,
        w_h: T::ZERO,
        lever_b: zeros(),
        c0: zeros(),
        blocks: [ShapingBlock {
            a: zeros(),
            gain: T::ZERO,
        }; 3],
        x: zeros(),
        p: zeros(),
        broken: false,
        q_ins: zeros(),
        interval_s: 0.0,
        sum_c: zeros(),
        sum_dv_c: zeros(),
        elapsed_s: 0.0,
        nis_sum: 0.0,
        nis_n: 0,
        log_likelihood: 0.0,
        magnitude_z: None,
        status: FineStatus::ZERO,
    };
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::alignment::fine::FineRefusal;
    use crate::alignment::fine::bank::Bank;
    use crate::alignment::fine::model::FINE_STATES;
    use crate::alignment::sway::{SwayAlignment, SwayConfig};
    use crate::attitude::from_euler;
    use crate::{ImuIncrement, earth};
    use nalgebra::Vector3;
    use std::format;

    const DT: f64 = 0.0025;

    /// Increment `k` of a body at latitude `lat` [rad], heading 0.3 rad, rolling 2 deg at a
    /// 6 s period about level (first order in `dt`: enough to drive the filters).
    fn rolling(lat: f64, k: u32) -> ImuIncrement<f64> {
        let t = f64::from(k) * DT;
        let (amp, w) = (2f64.to_radians(), core::f64::consts::TAU / 6.0);
        let q_n_b = from_euler(amp * (w * t).sin(), 0.0, 0.3).inverse();
        let g = earth::normal_gravity(lat, 0.0);
        let mut delta_theta_ib_b = q_n_b * earth::omega_ie_n(lat) * DT;
        delta_theta_ib_b.x += amp * w * (w * t).cos() * DT;
        ImuIncrement {
            delta_theta_ib_b,
            delta_v_ib_b: q_n_b * Vector3::new(0.0, 0.0, -g) * DT,
            dt: DT,
        }
    }

    #[test]
    fn blank_filters_refuse_until_started() {
        let f = FineCore::<f32, FINE_STATES>::BLANK;
        assert_eq!(f.outcome(), Err(FineRefusal::NotStarted));
        let bank = Bank::<f32, FINE_STATES, NoExtension>::BLANK;
        assert_eq!(bank.outcome(), Err(FineRefusal::NotStarted));
        assert_eq!(
            SwayAlignment::<f32>::BLANK.outcome(),
            Err(FineRefusal::NotStarted)
        );
    }

    /// A filter that has run (the sway filters through their identification), started again
    /// in place, is the filter `new` builds: every field (their `Debug` text), and the same
    /// after more data.
    #[test]
    fn init_in_restarts_a_used_filter_as_new_builds_it() {
        let position = Position::from_degrees(45.0, 7.5, 100.0);
        let lat = position.lat_f64();
        let fine = FineConfig {
            lever_arm: LeverArm::Known(Vector3::new(1.0, -2.0, 0.5)),
            ..FineConfig::default()
        };
        let config = SwayConfig {
            fine,
            ..SwayConfig::default()
        };
        let (q0, w0) = (from_euler(0.01, -0.02, 0.0), Vector3::new(1e-3, 0.0, 0.0));
        let elsewhere = Position::from_degrees(10.0, 0.0, 0.0);

        let mut used = SwayAlignment::new(
            from_euler(-0.03, 0.02, 1.0),
            Vector3::zeros(),
            elsewhere,
            SwayConfig::default(),
        );
        // 30 s: the open loop, the identification window and its search.
        for k in 0..12_000 {
            let _ = used.add(&rolling(elsewhere.lat_f64(), k));
        }
        assert_ne!(used.status().attempts, 0, "{:?}", used.status());
        used.init_in(q0, w0, position, config);
        let mut fresh = SwayAlignment::new(q0, w0, position, config);
        assert_eq!(format!("{used:?}"), format!("{fresh:?}"));
        for k in 0..2000 {
            let _ = used.add(&rolling(lat, k));
            let _ = fresh.add(&rolling(lat, k));
        }
        assert_eq!(format!("{used:?}"), format!("{fresh:?}"));

        let mut used =
            Bank::<_, FINE_STATES, _>::new(q0, w0, elsewhere, FineConfig::default(), NoExtension);
        for k in 0..2000 {
            let _ = used.add(&rolling(elsewhere.lat_f64(), k));
        }
        used.init_in(q0, w0, position, fine, |_| {});
        let fresh = Bank::<_, FINE_STATES, _>::new(q0, w0, position, fine, NoExtension);
        assert_eq!(format!("{used:?}"), format!("{fresh:?}"));
    }
}
