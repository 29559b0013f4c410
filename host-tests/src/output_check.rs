//! Rows checked before they are written, so a writer never emits what its readers refuse
//! (`nav sim`, `nav sim family`, `nav emulate`, `nav generate`).
//!
//! A trajectory row ([`check_truth`]) must have every value finite, the latitude within
//! [-90, 90] deg, the longitude within [-180, 180] deg (the writers wrap it) and a time that
//! does not go backwards — what [`crate::truth_csv`] reads back. An IMU record
//! ([`check_records`]) must have finite f32 increments (an f64 value beyond the f32 range
//! would be written as infinity) and a timestamp after the previous one (the first after the
//! recording's start). The first bad row refuses the run, named by its index and cause.

use crate::truth::Truth;
use core::fmt;
use hal_adapters::recording::Record;
use nav_core::number::Number;

/// What is wrong with a row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowFault {
    /// A value that is NaN or infinite.
    NotFinite {
        /// The column (file name of the value).
        column: &'static str,
        /// Its value.
        value: f64,
    },
    /// A latitude beyond the poles.
    Latitude {
        /// Latitude [deg].
        lat_deg: f64,
    },
    /// A longitude outside [-180, 180] deg.
    Longitude {
        /// Longitude [deg].
        lon_deg: f64,
    },
    /// A trajectory time before the previous row's.
    TimeBackwards {
        /// This row's time [s].
        t_s: f64,
        /// The previous row's [s].
        previous_t_s: f64,
    },
    /// A record timestamp not after the previous one (or the recording's start).
    TimeNotIncreasing {
        /// This record's timestamp [ns].
        t_ns: u64,
        /// The previous one [ns].
        previous_t_ns: u64,
    },
}

impl fmt::Display for RowFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::NotFinite { column, value } => {
                write!(f, "{column} is {value}, not a finite number")
            }
            Self::Latitude { lat_deg } => write!(
                f,
                "latitude {} deg is not within [-90, 90]",
                Number(lat_deg)
            ),
            Self::Longitude { lon_deg } => write!(
                f,
                "longitude {} deg is not within [-180, 180]",
                Number(lon_deg)
            ),
            Self::TimeBackwards { t_s, previous_t_s } => write!(
                f,
                "time {} s is before the previous row's {} s",
                Number(t_s),
                Number(previous_t_s)
            ),
            Self::TimeNotIncreasing {
                t_ns,
                previous_t_ns,
            } => write!(
                f,
                "timestamp {t_ns} ns does not follow the previous {previous_t_ns} ns"
            ),
        }
    }
}

/// The first bad row of an output: which one, when, and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowError {
    /// What the rows are (`truth row`, `IMU record`, ...).
    pub what: &'static str,
    /// The row's index (0-based).
    pub index: usize,
    /// Its time [s].
    pub t_s: f64,
    /// What is wrong.
    pub fault: RowFault,
}

impl fmt::Display for RowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {} (t = {} s): {}",
            self.what,
            self.index,
            Number(self.t_s),
            self.fault
        )
    }
}

impl std::error::Error for RowError {}

/// The first of `values` (`(column, value)`) that is not finite.
pub fn first_not_finite(values: &[(&'static str, f64)]) -> Option<RowFault> {
    values
        .iter()
        .find(|(_, v)| !v.is_finite())
        .map(|&(column, value)| RowFault::NotFinite { column, value })
}

/// Checks trajectory rows (`what` names them in the error) as the trajectory CSV's reader
/// does, and the longitude as the writers wrap it.
pub fn check_truth(what: &'static str, rows: &[Truth]) -> Result<(), RowError> {
    let mut previous_t_s = f64::NEG_INFINITY;
    for (index, t) in rows.iter().enumerate() {
        let q = t.q_b_ned.quaternion();
        let fault = first_not_finite(&[
            ("t_s", t.t_s),
            ("lat", t.lat),
            ("lon", t.lon),
            ("h_m", t.h),
            ("v_n_mps", t.v_eb_ned.x),
            ("v_e_mps", t.v_eb_ned.y),
            ("v_d_mps", t.v_eb_ned.z),
            ("attitude quaternion w", q.w),
            ("attitude quaternion x", q.i),
            ("attitude quaternion y", q.j),
            ("attitude quaternion z", q.k),
        ])
        .or_else(|| {
            let (lat_deg, lon_deg) = (t.lat.to_degrees(), t.lon.to_degrees());
            if !(-90.0..=90.0).contains(&lat_deg) {
                Some(RowFault::Latitude { lat_deg })
            } else if !(-180.0..=180.0).contains(&lon_deg) {
                Some(RowFault::Longitude { lon_deg })
            } else if t.t_s < previous_t_s {
                Some(RowFault::TimeBackwards {
                    t_s: t.t_s,
                    previous_t_s,
                })
            } else {
                None
            }
        });
        if let Some(fault) = fault {
            return Err(RowError {
                what,
                index,
                t_s: t.t_s,
                fault,
            });
        }
        previous_t_s = t.t_s;
    }
    Ok(())
}

/// Checks IMU records of a recording starting at `t0_ns`: finite values, timestamps after
/// the start and increasing.
pub fn check_records(t0_ns: u64, records: &[Record]) -> Result<(), RowError> {
    let mut previous_t_ns = t0_ns;
    for (index, r) in records.iter().enumerate() {
        let [gx, gy, gz] = r.gyro.map(f64::from);
        let [ax, ay, az] = r.accel.map(f64::from);
        let fault = first_not_finite(&[
            ("dtheta_x_rad", gx),
            ("dtheta_y_rad", gy),
            ("dtheta_z_rad", gz),
            ("dv_x_mps", ax),
            ("dv_y_mps", ay),
            ("dv_z_mps", az),
        ])
        .or(
            (r.t_ns <= previous_t_ns).then_some(RowFault::TimeNotIncreasing {
                t_ns: r.t_ns,
                previous_t_ns,
            }),
        );
        if let Some(fault) = fault {
            return Err(RowError {
                what: "IMU record",
                index,
                t_s: r.t_ns as f64 * 1e-9,
                fault,
            });
        }
        previous_t_ns = r.t_ns;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use nav_core::{UnitQuaternion, Vector3};

    fn row(t_s: f64, lat_deg: f64, lon_deg: f64) -> Truth {
        Truth {
            t_s,
            lat: lat_deg.to_radians(),
            lon: lon_deg.to_radians(),
            h: 100.0,
            v_eb_ned: Vector3::zeros(),
            q_b_ned: UnitQuaternion::identity(),
        }
    }

    #[test]
    fn the_first_bad_row_is_named_with_its_cause() {
        let good = [row(0.0, 45.0, 7.5), row(0.5, -90.0, 180.0)];
        assert_eq!(check_truth("truth row", &good), Ok(()));
        let e = check_truth(
            "truth row",
            &[good[0], row(1.0, 200.0, 0.0), row(f64::NAN, 0.0, 0.0)],
        )
        .unwrap_err();
        assert_eq!(
            (e.index, e.fault),
            (1, RowFault::Latitude { lat_deg: 200.0 })
        );
        assert_eq!(
            e.to_string(),
            "truth row 1 (t = 1 s): latitude 200 deg is not within [-90, 90]"
        );
        let mut nan = good[1];
        nan.v_eb_ned.y = f64::NAN;
        let e = check_truth("displayed row", &[good[0], nan]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "displayed row 1 (t = 0.5 s): v_e_mps is NaN, not a finite number"
        );
        let e = check_truth("truth row", &[row(0.0, 0.0, 181.0)]).unwrap_err();
        assert!(matches!(e.fault, RowFault::Longitude { .. }), "{e}");
        let e = check_truth("truth row", &[row(2.0, 0.0, 0.0), row(1.0, 0.0, 0.0)]).unwrap_err();
        assert!(matches!(e.fault, RowFault::TimeBackwards { .. }), "{e}");
    }

    #[test]
    fn records_need_finite_values_and_increasing_timestamps() {
        let r = |t_ns, dv: f32| Record {
            t_ns,
            gyro: [0.0; 3],
            accel: [0.0, 0.0, dv],
            temperature_c: 25.0,
        };
        assert_eq!(check_records(0, &[r(1, -0.02), r(2, -0.02)]), Ok(()));
        let e = check_records(0, &[r(1, -0.02), r(2, f32::INFINITY)]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "IMU record 1 (t = 2e-9 s): dv_z_mps is inf, not a finite number"
        );
        let e = check_records(5, &[r(5, 0.0)]).unwrap_err();
        assert_eq!(
            e.fault,
            RowFault::TimeNotIncreasing {
                t_ns: 5,
                previous_t_ns: 5
            }
        );
    }
}
