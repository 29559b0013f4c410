//! Aiding measurements of the navigation filter, their outcomes and counters.

use crate::Scalar;
use nalgebra::Vector3;

/// A GNSS position fix of the antenna, time-tagged by the caller (see
/// [`crate::ins_filter::AidedIns::aid_position`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssPosition<T: Scalar> {
    /// Geodetic latitude [rad].
    pub lat_rad: f64,
    /// Longitude [rad].
    pub lon_rad: f64,
    /// Ellipsoidal height [m].
    pub h_m: f64,
    /// 1-sigma north, east, down [m].
    pub sigma_ned_m: Vector3<T>,
}

impl<T: Scalar> GnssPosition<T> {
    /// True when the place is finite (latitude within +-90 deg) and every 1-sigma positive and
    /// at most [`MAX_FIX_SIGMA`].
    pub fn is_valid(&self) -> bool {
        self.lat_rad.is_finite()
            && self.lat_rad.abs() <= core::f64::consts::FRAC_PI_2
            && self.lon_rad.is_finite()
            && self.h_m.is_finite()
            && self.h_m.abs() < 1e7
            && sigmas_valid(&self.sigma_ned_m)
    }
}

/// A GNSS velocity of the antenna.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssVelocity<T: Scalar> {
    /// Velocity north, east, down [m/s].
    pub v_ned_m_s: Vector3<T>,
    /// 1-sigma north, east, down [m/s].
    pub sigma_ned_m_s: Vector3<T>,
}

impl<T: Scalar> GnssVelocity<T> {
    /// True when every value is finite and every 1-sigma positive and at most
    /// [`MAX_FIX_SIGMA`].
    pub fn is_valid(&self) -> bool {
        self.v_ned_m_s.iter().all(|v| v.finite()) && sigmas_valid(&self.sigma_ned_m_s)
    }
}

/// The largest 1-sigma of a usable fix [m, m/s]: a receiver that states more (the Earth's
/// radius is 6.4e6 m) is saying it has no fix, so the fix is counted invalid, and a file of
/// nothing else is refused as one without a usable fix.
pub const MAX_FIX_SIGMA: f64 = 1e7;

pub(crate) fn sigmas_valid<T: Scalar>(s: &Vector3<T>) -> bool {
    s.iter()
        .all(|v| v.finite() && *v > T::zero() && *v <= T::c(MAX_FIX_SIGMA))
}

/// What became of one aiding measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AidResult<T: Scalar> {
    /// Used; `nis` is its normalised innovation squared (chi-square with 3 degrees of
    /// freedom when the filter is consistent).
    Accepted {
        /// Normalised innovation squared [-].
        nis: T,
    },
    /// Refused by the chi-square innovation gate.
    Rejected {
        /// Normalised innovation squared [-].
        nis: T,
    },
    /// Refused: not finite, a non-positive 1-sigma, or a degenerate innovation covariance.
    Invalid,
}

/// Counts of one aid's measurements.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AidCounters {
    /// Used.
    pub accepted: u32,
    /// Refused by the gate.
    pub rejected: u32,
    /// Refused as invalid.
    pub invalid: u32,
    /// Gate refusals since the last accepted one.
    pub consecutive_rejected: u32,
    /// Of the refused, refused by the windowed innovation test although each passed the
    /// per-fix gate ([`super::integrity`]; GNSS position only).
    pub window_rejected: u32,
    /// Of the refused, refused as members of a consistent cluster refused before, although
    /// each passed the per-fix gate ([`super::integrity`]; GNSS position only).
    pub cluster_rejected: u32,
}

impl AidCounters {
    pub(crate) fn count<T: Scalar>(&mut self, r: &AidResult<T>) {
        match r {
            AidResult::Accepted { .. } => {
                self.accepted = self.accepted.saturating_add(1);
                self.consecutive_rejected = 0;
            }
            AidResult::Rejected { .. } => {
                self.rejected = self.rejected.saturating_add(1);
                self.consecutive_rejected = self.consecutive_rejected.saturating_add(1);
            }
            AidResult::Invalid => self.invalid = self.invalid.saturating_add(1),
        }
    }
}

impl core::fmt::Display for AidCounters {
    /// `A accepted, R rejected (W by the window test, C as a refused cluster), I invalid`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{} accepted, {} rejected", self.accepted, self.rejected)?;
        if self.window_rejected > 0 || self.cluster_rejected > 0 {
            write!(
                f,
                " ({} by the window test, {} as a refused cluster)",
                self.window_rejected, self.cluster_rejected
            )?;
        }
        write!(f, ", {} invalid", self.invalid)
    }
}

/// The counters of every aid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FilterCounters {
    /// GNSS position.
    pub position: AidCounters,
    /// GNSS velocity.
    pub velocity: AidCounters,
    /// Zero-velocity updates.
    pub zero_velocity: AidCounters,
    /// Zero-angular-rate updates.
    pub zero_rate: AidCounters,
    /// Covariance propagations.
    pub propagations: u32,
}

/// 99.9 % point of the chi-square distribution with 3 degrees of freedom: the default gate.
pub const CHI2_3DOF_999: f64 = 16.266;
