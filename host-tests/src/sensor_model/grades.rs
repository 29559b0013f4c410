//! Named sensor grades: `ideal`, `fog`, `rlg`, `mems-tactical`, `mems-consumer`.
//!
//! The sources of every number are in the table of the [module docs](super). Spreads (turn-on
//! biases) are 1-sigma per axis, drawn per seed; "bias instability" is the peak of the
//! Gauss–Markov term's Allan deviation ([`super::GaussMarkov`]).

use super::allan::GM_PEAK_TAU_PER_CORRELATION_TIME;
use super::model::ImuErrorModel;
use super::triad::{GaussMarkov, TriadErrors, WhiteNoise};
use super::units::{
    deg_h, deg_h_sqrt_h, deg_s, deg_s_per_g, deg_s_sqrt_hz, deg_sqrt_h, g, m_s_sqrt_h, micro_g,
    micro_g_sqrt_hz, milli_g,
};
use core::fmt;
use core::str::FromStr;
use nav_core::Vector3;
use nav_core::nalgebra::Matrix3;

/// Output rate the rate-output presets' increment LSB refers to [Hz] (the project's rate).
pub const PRESET_RATE_HZ: f64 = 400.0;

/// The Gauss–Markov bias of bias instability `b` [U] for a triad with white-noise density
/// `white_density` [U/sqrt(Hz)], its correlation time chosen (data sheets do not give one) so
/// that the hump of its Allan deviation, at `1.8926 T`, sits where the white noise's Allan
/// deviation `N / sqrt(tau)` has fallen to `b`, i.e. where a measured curve flattens out:
/// `T = (N / b)^2 / 1.8926`.
pub fn gauss_markov_at_floor(b: f64, white_density: f64) -> GaussMarkov {
    let tau_floor_s = (white_density / b).powi(2);
    GaussMarkov::from_bias_instability(b, tau_floor_s / GM_PEAK_TAU_PER_CORRELATION_TIME)
}

/// A named error model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Grade {
    /// No errors at all.
    Ideal,
    /// Fibre-optic gyro IMU of the bench test of [Vavilova et al., §4].
    Fog,
    /// Ring-laser-gyro IMU of the flight simulation of [Stand model].
    Rlg,
    /// Tactical MEMS, ADIS16505-2 class (the navigation board's IMU).
    MemsTactical,
    /// Consumer MEMS, ICM-42688-P class.
    MemsConsumer,
}

impl Grade {
    /// Every grade, in order of the names.
    pub const ALL: [Grade; 5] = [
        Grade::Ideal,
        Grade::Fog,
        Grade::Rlg,
        Grade::MemsTactical,
        Grade::MemsConsumer,
    ];

    /// The name on the command line and in files.
    pub fn name(self) -> &'static str {
        match self {
            Grade::Ideal => "ideal",
            Grade::Fog => "fog",
            Grade::Rlg => "rlg",
            Grade::MemsTactical => "mems-tactical",
            Grade::MemsConsumer => "mems-consumer",
        }
    }

    /// The figures an alignment filter assumes for this grade: white noise densities, and per
    /// axis the largest of the fixed bias, the turn-on 1-sigma and the Gauss–Markov 1-sigma;
    /// and the aided filter's other figures: the largest scale factor of each triad (at least
    /// 1 ppm), the RMS of its misalignment's six elements, the largest g-sensitivity.
    pub fn noise_spec(self) -> hal_adapters::drivers::NoiseSpec {
        let m = self.model();
        let bias = |t: &super::TriadErrors| {
            t.bias
                .amax()
                .max(t.turn_on_bias_sigma.amax())
                .max(t.bias_instability.sigma)
        };
        let coupling = |t: &super::TriadErrors| crate::aided_cmd::off_diagonal_rms(&t.misalignment);
        hal_adapters::drivers::NoiseSpec {
            gyro_arw_rad_per_sqrt_s: m.gyro.white_noise.density(),
            accel_vrw_mps_per_sqrt_s: m.accel.white_noise.density(),
            gyro_bias_rad_s: bias(&m.gyro),
            accel_bias_mps2: bias(&m.accel),
            figures: nav_core::navigator::SensorFigures {
                gyro_scale: m.gyro.scale_sigma() as f32,
                accel_scale: m.accel.scale_sigma() as f32,
                gyro_cross_coupling_rad: coupling(&m.gyro) as f32,
                accel_cross_coupling_rad: coupling(&m.accel) as f32,
                gyro_g_sensitivity: m.g_sensitivity_rad_s_per_m_s2.amax() as f32,
            },
        }
    }

    /// The error model of this grade.
    pub fn model(self) -> ImuErrorModel {
        match self {
            Grade::Ideal => ImuErrorModel::IDEAL,
            Grade::Fog => fog(),
            Grade::Rlg => rlg(),
            Grade::MemsTactical => mems_tactical(),
            Grade::MemsConsumer => mems_consumer(),
        }
    }
}

impl fmt::Display for Grade {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A grade name that is not one of [`Grade::ALL`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownGrade(pub String);

impl fmt::Display for UnknownGrade {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "unknown sensor grade '{}'; expected one of: ", self.0)?;
        for (i, g) in Grade::ALL.iter().enumerate() {
            let sep = if i == 0 { "" } else { ", " };
            write!(f, "{sep}{}", g.name())?;
        }
        Ok(())
    }
}

impl core::error::Error for UnknownGrade {}

impl FromStr for Grade {
    type Err = UnknownGrade;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Grade::ALL
            .into_iter()
            .find(|g| g.name() == s)
            .ok_or_else(|| UnknownGrade(s.to_owned()))
    }
}

/// A misalignment matrix [rad] from off-diagonal entries [deg]: `[xy, xz, yx, yz, zx, zy]`.
fn misalignment_deg(off: [f64; 6]) -> Matrix3<f64> {
    let [xy, xz, yx, yz, zx, zy] = off.map(f64::to_radians);
    Matrix3::new(0.0, xy, xz, yx, 0.0, yz, zx, zy, 0.0)
}

/// [Vavilova et al., §4] (bench test): gyro bias 0.2 deg/h, noise 0.003 deg/s RMS at 400 Hz;
/// accelerometer bias 0.005 m/s^2, noise 0.02 m/s^2 RMS at 400 Hz. Nothing else is given.
fn fog() -> ImuErrorModel {
    let mut m = ImuErrorModel::IDEAL;
    m.gyro.turn_on_bias_sigma = Vector3::repeat(deg_h(0.2));
    m.gyro.white_noise = WhiteNoise::RmsAtRate {
        rms: deg_s(0.003),
        rate_hz: 400.0,
    };
    m.accel.turn_on_bias_sigma = Vector3::repeat(0.005);
    m.accel.white_noise = WhiteNoise::RmsAtRate {
        rms: 0.02,
        rate_hz: 400.0,
    };
    m
}

/// [Stand model] (flight simulation): gyro drift 0.01 deg/h, accelerometer error 0.1e-3 g; the
/// random walks are assumed (RLG and navigation-grade accelerometer typical).
fn rlg() -> ImuErrorModel {
    let mut m = ImuErrorModel::IDEAL;
    m.gyro.turn_on_bias_sigma = Vector3::repeat(deg_h(0.01));
    m.gyro.white_noise = WhiteNoise::Density(deg_sqrt_h(0.002));
    m.accel.turn_on_bias_sigma = Vector3::repeat(milli_g(0.1));
    m.accel.white_noise = WhiteNoise::Density(m_s_sqrt_h(0.005));
    m
}

/// ADIS16505-2 class (see the module table for each number's source).
fn mems_tactical() -> ImuErrorModel {
    let (arw, vrw) = (deg_sqrt_h(0.13), m_s_sqrt_h(0.04));
    let gyro = TriadErrors {
        bias: Vector3::zeros(),
        turn_on_bias_sigma: Vector3::repeat(deg_s(0.05)),
        scale: Vector3::new(300e-6, -200e-6, 150e-6),
        misalignment: misalignment_deg([0.10, -0.05, -0.08, 0.12, 0.06, -0.10]),
        white_noise: WhiteNoise::Density(arw),
        bias_instability: gauss_markov_at_floor(deg_h(2.3), arw),
        rate_random_walk: deg_h_sqrt_h(1.0),
        // 32-bit delta-angle burst: +-720 deg over 2^31.
        lsb: (720.0 / 2f64.powi(31)).to_radians(),
        full_scale: deg_s(500.0),
    };
    let accel = TriadErrors {
        bias: Vector3::zeros(),
        turn_on_bias_sigma: Vector3::repeat(milli_g(1.0)),
        scale: Vector3::new(-250e-6, 100e-6, 200e-6),
        misalignment: misalignment_deg([-0.06, 0.09, 0.04, -0.07, 0.11, 0.05]),
        white_noise: WhiteNoise::Density(vrw),
        bias_instability: gauss_markov_at_floor(26.5e-6, vrw),
        rate_random_walk: 1e-6,
        // 32-bit delta-velocity burst: +-100 m/s over 2^31.
        lsb: 100.0 / 2f64.powi(31),
        full_scale: 78.4,
    };
    ImuErrorModel {
        gyro,
        accel,
        g_sensitivity_rad_s_per_m_s2: Matrix3::from_diagonal_element(deg_s_per_g(0.005)),
    }
}

/// ICM-42688-P class (see the module table for each number's source).
fn mems_consumer() -> ImuErrorModel {
    let (arw, vrw) = (deg_s_sqrt_hz(2.8e-3), micro_g_sqrt_hz(70.0));
    let gyro = TriadErrors {
        bias: Vector3::zeros(),
        turn_on_bias_sigma: Vector3::repeat(deg_s(0.5)),
        scale: Vector3::new(0.004, -0.003, 0.005),
        misalignment: misalignment_deg([0.5, -0.4, -0.3, 0.6, 0.4, -0.5]),
        white_noise: WhiteNoise::Density(arw),
        bias_instability: gauss_markov_at_floor(deg_h(3.0), arw),
        rate_random_walk: deg_h_sqrt_h(10.0),
        // 16-bit rate word at +-2000 deg/s (16.4 LSB/(deg/s)), held over one sample.
        lsb: deg_s(2000.0 / 32768.0) / PRESET_RATE_HZ,
        full_scale: deg_s(2000.0),
    };
    let accel = TriadErrors {
        bias: Vector3::zeros(),
        turn_on_bias_sigma: Vector3::repeat(milli_g(20.0)),
        scale: Vector3::new(-0.005, 0.004, 0.003),
        misalignment: misalignment_deg([0.4, 0.5, -0.6, -0.3, 0.5, 0.4]),
        white_noise: WhiteNoise::Density(vrw),
        bias_instability: gauss_markov_at_floor(micro_g(20.0), vrw),
        rate_random_walk: 1e-5,
        // 16-bit word at +-16 g (2048 LSB/g), held over one sample.
        lsb: g(16.0 / 32768.0) / PRESET_RATE_HZ,
        full_scale: g(16.0),
    };
    ImuErrorModel {
        gyro,
        accel,
        g_sensitivity_rad_s_per_m_s2: Matrix3::from_diagonal_element(deg_s_per_g(0.1)),
    }
}

#[cfg(test)]
mod tests {
    use super::super::units;
    use super::*;

    #[test]
    fn names_round_trip_and_errors_list_them() {
        for g in Grade::ALL {
            assert_eq!(g.name().parse::<Grade>(), Ok(g));
            assert_eq!(g.to_string(), g.name());
            assert!(g.model().validate().is_ok(), "{g}");
        }
        let e = "mems".parse::<Grade>().unwrap_err().to_string();
        assert!(e.contains("'mems'"), "{e}");
        for g in Grade::ALL {
            assert!(e.contains(g.name()), "{e}");
        }
        assert!("FOG".parse::<Grade>().is_err());
    }

    /// The firmware's no_std table of the grades' alignment figures (`--imu-noise`) says what
    /// the error models say.
    #[test]
    fn noise_specs_agree_with_the_no_std_table() {
        use hal_adapters::drivers::noise::grade;
        for g in Grade::ALL {
            let Some(table) = grade::by_name(g.name()) else {
                assert_eq!(g, Grade::Ideal, "{g} missing from the table");
                continue;
            };
            let host = g.noise_spec();
            for (what, a, b) in [
                (
                    "ARW",
                    host.gyro_arw_rad_per_sqrt_s,
                    table.gyro_arw_rad_per_sqrt_s,
                ),
                (
                    "VRW",
                    host.accel_vrw_mps_per_sqrt_s,
                    table.accel_vrw_mps_per_sqrt_s,
                ),
                ("gyro bias", host.gyro_bias_rad_s, table.gyro_bias_rad_s),
                ("accel bias", host.accel_bias_mps2, table.accel_bias_mps2),
            ] {
                assert!(
                    a > 0.0 && (a / b - 1.0).abs() < 1e-12,
                    "{g} {what}: {a} vs {b}"
                );
            }
            let (h, t) = (host.figures, table.figures);
            for (what, a, b) in [
                ("gyro scale", h.gyro_scale, t.gyro_scale),
                ("accel scale", h.accel_scale, t.accel_scale),
                (
                    "gyro coupling",
                    h.gyro_cross_coupling_rad,
                    t.gyro_cross_coupling_rad,
                ),
                (
                    "accel coupling",
                    h.accel_cross_coupling_rad,
                    t.accel_cross_coupling_rad,
                ),
                ("g-sensitivity", h.gyro_g_sensitivity, t.gyro_g_sensitivity),
            ] {
                // Single precision: the table's literal and the model's value round alike.
                assert_eq!(a, b, "{g} {what}");
            }
        }
        assert_eq!(grade::ALL.len(), Grade::ALL.len() - 1);
    }

    #[test]
    fn presets_carry_the_seed_and_datasheet_values() {
        let fog = Grade::Fog.model();
        // 0.003 deg/s RMS at 400 Hz = 1.5e-4 deg/s/sqrt(Hz) = 0.009 deg/sqrt(h).
        assert!((units::to_deg_sqrt_h(fog.gyro.white_noise.density()) - 0.009).abs() < 1e-12);
        // 0.02 m/s^2 RMS at 400 Hz = 1e-3 m/s^2/sqrt(Hz).
        assert!((fog.accel.white_noise.density() - 1e-3).abs() < 1e-15);
        assert!((units::to_deg_h(fog.gyro.turn_on_bias_sigma.x) - 0.2).abs() < 1e-12);

        let rlg = Grade::Rlg.model();
        assert!((units::to_deg_h(rlg.gyro.turn_on_bias_sigma.z) - 0.01).abs() < 1e-12);
        assert!((rlg.accel.turn_on_bias_sigma.y - 0.1e-3 * 9.806_65).abs() < 1e-15);

        let t = Grade::MemsTactical.model();
        let b = units::to_deg_h(t.gyro.bias_instability.bias_instability());
        assert!((b - 2.3).abs() < 1e-9, "{b}");
        assert!((units::to_deg_sqrt_h(t.gyro.white_noise.density()) - 0.13).abs() < 1e-12);
        assert!((t.gyro.full_scale.to_degrees() - 500.0).abs() < 1e-9);

        let c = Grade::MemsConsumer.model();
        // 2.8 mdps/sqrt(Hz) = 0.168 deg/sqrt(h).
        assert!((units::to_deg_sqrt_h(c.gyro.white_noise.density()) - 0.168).abs() < 1e-9);
        assert!((c.accel.full_scale / 9.806_65 - 16.0).abs() < 1e-12);

        // Correlation times from the floor rule: the hump where N / sqrt(tau) = B.
        for (tri, n, tc) in [
            (t.gyro, deg_sqrt_h(0.13), 6.08),
            (t.accel, m_s_sqrt_h(0.04), 334.4),
            (c.gyro, deg_s_sqrt_hz(2.8e-3), 5.96),
            (c.accel, micro_g_sqrt_hz(70.0), 6.47),
        ] {
            let gm = tri.bias_instability;
            assert!(
                (gm.correlation_time_s / tc - 1.0).abs() < 1e-3,
                "{}",
                gm.correlation_time_s
            );
            let tau = GM_PEAK_TAU_PER_CORRELATION_TIME * gm.correlation_time_s;
            assert!((n / tau.sqrt() / gm.bias_instability() - 1.0).abs() < 1e-9);
        }

        let ideal = Grade::Ideal.model();
        assert_eq!(ideal, ImuErrorModel::IDEAL);
    }
}
