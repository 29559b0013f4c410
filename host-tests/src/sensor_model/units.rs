//! Conversions between datasheet units and the SI units used inside the sensor model.
//!
//! Inside [`super`] everything is SI: rates [rad/s], specific force [m/s^2], white-noise densities
//! [rad/s/sqrt(Hz)] = [rad/sqrt(s)] and [m/s^2/sqrt(Hz)] = [m/s/sqrt(s)], rate random walk
//! [rad/s/sqrt(s)] and [m/s^2/sqrt(s)]. Datasheet units appear only in these helpers.

use core::f64::consts::PI;

/// Standard gravity [m/s^2] (CGPM 1901), for values given in g.
pub const STANDARD_GRAVITY_M_S2: f64 = 9.806_65;

const DEG: f64 = PI / 180.0;
/// sqrt(1 h) = 60 sqrt(s).
const SQRT_HOUR_S: f64 = 60.0;
const HOUR_S: f64 = 3600.0;

/// [deg/s] -> [rad/s].
pub fn deg_s(x_deg_s: f64) -> f64 {
    x_deg_s * DEG
}

/// [deg/h] -> [rad/s].
pub fn deg_h(x_deg_h: f64) -> f64 {
    x_deg_h * DEG / HOUR_S
}

/// Angle random walk [deg/sqrt(h)] -> white-noise density [rad/s/sqrt(Hz)].
pub fn deg_sqrt_h(x_deg_sqrt_h: f64) -> f64 {
    x_deg_sqrt_h * DEG / SQRT_HOUR_S
}

/// Rate noise density [deg/s/sqrt(Hz)] -> [rad/s/sqrt(Hz)].
pub fn deg_s_sqrt_hz(x_deg_s_sqrt_hz: f64) -> f64 {
    x_deg_s_sqrt_hz * DEG
}

/// Rate random walk [deg/h/sqrt(h)] -> [rad/s/sqrt(s)].
pub fn deg_h_sqrt_h(x_deg_h_sqrt_h: f64) -> f64 {
    x_deg_h_sqrt_h * DEG / (HOUR_S * SQRT_HOUR_S)
}

/// [g] -> [m/s^2].
pub fn g(x_g: f64) -> f64 {
    x_g * STANDARD_GRAVITY_M_S2
}

/// [mg] -> [m/s^2].
pub fn milli_g(x_mg: f64) -> f64 {
    x_mg * 1e-3 * STANDARD_GRAVITY_M_S2
}

/// [ug] -> [m/s^2].
pub fn micro_g(x_ug: f64) -> f64 {
    x_ug * 1e-6 * STANDARD_GRAVITY_M_S2
}

/// Accelerometer noise density [ug/sqrt(Hz)] -> [m/s^2/sqrt(Hz)].
pub fn micro_g_sqrt_hz(x_ug_sqrt_hz: f64) -> f64 {
    micro_g(x_ug_sqrt_hz)
}

/// Velocity random walk [m/s/sqrt(h)] -> white-noise density [m/s^2/sqrt(Hz)].
pub fn m_s_sqrt_h(x_m_s_sqrt_h: f64) -> f64 {
    x_m_s_sqrt_h / SQRT_HOUR_S
}

/// Gyro g-sensitivity [deg/s/g] -> [rad/s per m/s^2].
pub fn deg_s_per_g(x_deg_s_g: f64) -> f64 {
    deg_s(x_deg_s_g) / STANDARD_GRAVITY_M_S2
}

/// [rad/s] -> [deg/h].
pub fn to_deg_h(x_rad_s: f64) -> f64 {
    x_rad_s / DEG * HOUR_S
}

/// White-noise density [rad/s/sqrt(Hz)] -> angle random walk [deg/sqrt(h)].
pub fn to_deg_sqrt_h(x_rad_s_sqrt_hz: f64) -> f64 {
    x_rad_s_sqrt_hz / DEG * SQRT_HOUR_S
}

/// Rate random walk [rad/s/sqrt(s)] -> [deg/h/sqrt(h)].
pub fn to_deg_h_sqrt_h(x_rad_s_sqrt_s: f64) -> f64 {
    x_rad_s_sqrt_s / DEG * HOUR_S * SQRT_HOUR_S
}

/// White-noise density [m/s^2/sqrt(Hz)] -> velocity random walk [m/s/sqrt(h)].
pub fn to_m_s_sqrt_h(x_m_s2_sqrt_hz: f64) -> f64 {
    x_m_s2_sqrt_hz * SQRT_HOUR_S
}

/// [m/s^2] -> [ug].
pub fn to_micro_g(x_m_s2: f64) -> f64 {
    x_m_s2 / STANDARD_GRAVITY_M_S2 * 1e6
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        for x in [0.0, 0.13, 2.3, 1e3] {
            assert!((to_deg_h(deg_h(x)) - x).abs() <= 1e-12 * x.max(1.0));
            assert!((to_deg_sqrt_h(deg_sqrt_h(x)) - x).abs() <= 1e-12 * x.max(1.0));
            assert!((to_deg_h_sqrt_h(deg_h_sqrt_h(x)) - x).abs() <= 1e-12 * x.max(1.0));
            assert!((to_m_s_sqrt_h(m_s_sqrt_h(x)) - x).abs() <= 1e-12 * x.max(1.0));
            assert!((to_micro_g(micro_g(x)) - x).abs() <= 1e-12 * x.max(1.0));
        }
        // 1 deg/sqrt(h) is 1/60 deg/sqrt(s).
        assert!((deg_sqrt_h(1.0) - deg_s(1.0) / 60.0).abs() < 1e-18);
    }
}
