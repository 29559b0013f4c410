//! Sensor error models of the IMU simulator: exact increments in, what a real sensor
//! would output out.
//!
//! - [`triad`]: one triad's errors ([`TriadErrors`], [`WhiteNoise`], [`GaussMarkov`]).
//! - [`model`]: the IMU's model ([`ImuErrorModel`]: two triads and the gyro g-sensitivity).
//! - [`injector`]: [`ErrorInjector`], the model with its seeded random states.
//! - [`quantizer`]: the integrating quantiser of the increment outputs.
//! - [`grades`]: named presets ([`Grade`]).
//! - [`allan`]: overlapping Allan variance and the noise-model fit.
//! - [`units`]: datasheet units to SI.
//!
//! # The model (Groves 2nd ed. §4.4, error models §4.4.6; [Berdinskikh et al., eqs. 3, 8])
//! Per triad, with `U` = [rad/s] (gyros) or [m/s^2] (accelerometers), over an interval `dt`:
//!
//! ```text
//! d_meas = (I + diag(s) + M) d_true + G dv_true (gyros only)
//!        + (b_fixed + b_turn_on + b_gm + b_rw) dt + N sqrt(dt) n
//! d_out  = quantise(clamp(d_meas, +-full_scale dt), lsb)          (remainder carried)
//! ```
//! `b_turn_on ~ N(0, sigma_on^2)` once per seed; `b_gm` first-order Gauss–Markov
//! (`phi = exp(-dt/T)`, driving `sigma sqrt(1 - phi^2)`), started in its stationary distribution;
//! `b_rw += K sqrt(dt) n`; white noise `N sqrt(dt) n` on the increment. Each process is
//! discretised exactly for the sample's own `dt`. See [`ErrorInjector`] for the draw order and
//! the handling of bad input.
//!
//! **Bias instability.** For this model it means the peak over averaging time of the Allan
//! deviation of the Gauss–Markov term, `B = 0.6174 sigma` at `tau = 1.89 T` ([`allan`]). A
//! datasheet's in-run bias stability (the floor of a measured Allan curve) is mapped to
//! `sigma = B / 0.6174` ([`GaussMarkov::from_bias_instability`]); the Allan fit reports `B` from
//! the fitted `sigma` the same way, so configured and recovered values are compared like with
//! like.
//!
//! # Presets and their sources
//! "Front page" is the ADIS16505 data sheet's feature list (Analog Devices, *ADIS16505 Precision,
//! Miniature MEMS IMU*, features for the -1 model), the only part of it that could be read here,
//! through a mirror whose text extraction dropped every digit 5 (it reads "12_ deg/sec, _00
//! deg/sec"): 0.25 deg and 26.5 um/s^2 assume that reading;
//! "driver table" is the table of facts in `hal_adapters::drivers` (Linux `adis16475.c`, no-OS).
//! Spreads are 1-sigma per axis. "Assumed" values are this module's choice.
//!
//! | grade | quantity | value | source |
//! | ----- | -------- | ----- | ------ |
//! | fog | gyro bias (turn-on 1-sigma) | 0.2 deg/h | [Vavilova et al., §4] |
//! | fog | gyro white noise | 0.003 deg/s RMS at 400 Hz (= 0.009 deg/sqrt(h)) | [Vavilova et al., §4] |
//! | fog | accel bias (turn-on 1-sigma) | 0.005 m/s^2 | [Vavilova et al., §4] |
//! | fog | accel white noise | 0.02 m/s^2 RMS at 400 Hz (= 0.06 m/s/sqrt(h)) | [Vavilova et al., §4] |
//! | fog | everything else | none | [Vavilova et al., §4] gives nothing else |
//! | rlg | gyro drift (turn-on 1-sigma) | 0.01 deg/h | [Stand model] |
//! | rlg | accel error (turn-on 1-sigma) | 0.1e-3 g | [Stand model] |
//! | rlg | gyro ARW | 0.002 deg/sqrt(h) | assumed (RLG-typical 0.001-0.003) |
//! | rlg | accel VRW | 0.005 m/s/sqrt(h) (8.5 ug/sqrt(Hz)) | assumed (navigation-grade accelerometer) |
//! | mems-tactical | gyro ARW | 0.13 deg/sqrt(h) | front page (-1, x and y axes) |
//! | mems-tactical | gyro bias instability | 2.3 deg/h | front page (-1) |
//! | mems-tactical | gyro Gauss–Markov correlation time | 6.1 s | assumed: floor rule (below) |
//! | mems-tactical | gyro rate random walk | 1 deg/h/sqrt(h) | assumed |
//! | mems-tactical | gyro turn-on bias | 0.05 deg/s | assumed |
//! | mems-tactical | gyro scale errors | +300, -200, +150 ppm | assumed |
//! | mems-tactical | misalignment (both triads) | off-diagonals up to 0.12 deg | assumed, within the front page's 0.25 deg axis-to-axis |
//! | mems-tactical | gyro full scale | 500 deg/s | front page (-2 model) |
//! | mems-tactical | delta-angle LSB | 720 deg / 2^31 | driver table (32-bit burst) |
//! | mems-tactical | g-sensitivity | 0.005 deg/s/g, diagonal | assumed (residual after the factory's linear-g compensation) |
//! | mems-tactical | accel bias instability | 26.5 um/s^2 (2.7 ug) | front page (x and y axes) |
//! | mems-tactical | accel VRW | 0.04 m/s/sqrt(h) | assumed (not on the front page) |
//! | mems-tactical | accel Gauss–Markov correlation time | 334 s | assumed: floor rule |
//! | mems-tactical | accel rate random walk | 1e-6 m/s^2/sqrt(s) | assumed |
//! | mems-tactical | accel turn-on bias | 1 mg | assumed |
//! | mems-tactical | accel scale errors | -250, +100, +200 ppm | assumed |
//! | mems-tactical | accel full scale | 78.4 m/s^2 (8 g) | front page |
//! | mems-tactical | delta-velocity LSB | 100 m/s / 2^31 | driver table (32-bit burst) |
//! | mems-consumer | gyro noise density | 2.8 mdps/sqrt(Hz) (0.168 deg/sqrt(h)) | ICM-42688-P data sheet (quoted, not read) |
//! | mems-consumer | accel noise density | 70 ug/sqrt(Hz) | ICM-42688-P data sheet (quoted, not read) |
//! | mems-consumer | full scale | 2000 deg/s, 16 g | ICM-42688-P data sheet (quoted, not read); driver table |
//! | mems-consumer | increment LSB | 16-bit word (2000/32768 deg/s, 16/32768 g) x 1/400 s | ICM-42688-P data sheet (16-bit; quoted, not read); held over one 400 Hz sample: assumed |
//! | mems-consumer | gyro turn-on bias | 0.5 deg/s | assumed (consumer-typical zero-rate offset) |
//! | mems-consumer | gyro bias instability | 3 deg/h, correlation time 6.0 s (floor rule) | assumed |
//! | mems-consumer | gyro rate random walk | 10 deg/h/sqrt(h) | assumed |
//! | mems-consumer | accel turn-on bias | 20 mg | assumed (consumer-typical zero-g offset) |
//! | mems-consumer | accel bias instability | 20 ug, correlation time 6.5 s (floor rule) | assumed |
//! | mems-consumer | accel rate random walk | 1e-5 m/s^2/sqrt(s) | assumed |
//! | mems-consumer | scale errors | up to 0.5 % | assumed |
//! | mems-consumer | misalignment | off-diagonals up to 0.6 deg | assumed |
//! | mems-consumer | g-sensitivity | 0.1 deg/s/g, diagonal | assumed |
//!
//! Floor rule ([`grades::gauss_markov_at_floor`]): data sheets give no correlation time, so it
//! is chosen to put the Gauss–Markov hump (at `1.89 T`) where the white noise's Allan deviation
//! `N / sqrt(tau)` has fallen to `B`, i.e. where a measured curve flattens out:
//! `T = (N / B)^2 / 1.8926`.
//!
//! The ADIS16505-2 (the board's part) shares the -1's data-sheet class; its own noise figures
//! could not be read here, so the -1 figures stand in.

pub mod allan;
pub mod grades;
pub mod injector;
pub mod model;
pub mod quantizer;
pub mod triad;
pub mod units;

pub use allan::{AllanFit, AllanPoint, FitError};
pub use grades::{Grade, UnknownGrade};
pub use injector::{ErrorInjector, InjectorCounters, TriadState};
pub use model::{ErrorSource, ImuErrorModel};
pub use quantizer::IntegratingQuantizer;
pub use triad::{GaussMarkov, InvalidModel, TriadErrors, WhiteNoise};
