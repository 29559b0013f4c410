//! ADIS16505 / ADIS16465 model variants, their sensitivities and timings.
//!
//! Every constant says where it comes from. "Linux" is `drivers/iio/imu/adis16475.c` (chip info
//! tables), "no-OS" is Analog Devices' `drivers/imu/adis1650x.c` / `adis1646x.c` ("values from
//! datasheet"), "PX4" is `src/drivers/imu/analog_devices/adis16470`. Facts that could not be
//! checked against a datasheet are listed in the table of [`crate::drivers`].

/// Internal sample rate with the internal clock [Hz] (Linux and no-OS `int_clk = 2000`).
pub const INTERNAL_RATE_HZ: u32 = 2000;
/// `DEC_RATE` for 400 Hz output: `2000 / (DEC_RATE + 1) = 400` (Linux `adis16475_set_freq`).
pub const DEC_RATE_400_HZ: u16 = 4;
/// Output period with [`DEC_RATE_400_HZ`] [s].
pub const OUTPUT_PERIOD_S: f32 = (DEC_RATE_400_HZ as f32 + 1.0) / INTERNAL_RATE_HZ as f32;

/// Chip-select-high stall between 16-bit register words [us] (Linux and no-OS
/// `cs_change_delay = 16`, PX4 `SPI_STALL_PERIOD`).
pub const STALL_US: u32 = 16;
/// Maximum SCLK for register access [Hz] (project specification; not confirmed, see
/// [`crate::drivers`]).
pub const MAX_SCLK_HZ: u32 = 2_000_000;
/// Maximum SCLK for burst reads [Hz] (Linux `ADIS16475_BURST_MAX_SPEED`).
pub const MAX_BURST_SCLK_HZ: u32 = 1_000_000;

/// Software-reset recovery wait [ms]: the larger of Linux (260 ms for the ADIS1650x) and no-OS
/// (`sw_reset_ms = 255`).
pub const SOFTWARE_RESET_MS: u32 = 260;
/// Power-on start-up wait before the first access [ms] (no-OS `reset_ms = 310`).
pub const POWER_ON_MS: u32 = 310;
/// Self-test duration [ms]: the larger of Linux (30 ms, ADIS1650x) and no-OS (24 ms).
pub const SELF_TEST_MS: u32 = 30;
/// Wait after writing `MSC_CTRL` [us] (no-OS `msc_reg_update_us = 200`; Linux waits 250 us).
pub const MSC_CTRL_UPDATE_US: u32 = 200;
/// Wait after writing `DEC_RATE` [us] (no-OS `dec_rate_update_us = 30`).
pub const DEC_RATE_UPDATE_US: u32 = 30;

/// `TEMP_OUT` scale [deg C/LSB], 0 LSB = 0 deg C (Linux `temp_scale = 100` milli-degrees; PX4
/// `TEMP_OUT * 0.1`).
pub const TEMP_C_PER_LSB: f32 = 0.1;

/// Standard gravity [m/s^2], for sensitivities given in g.
pub const STANDARD_GRAVITY_MPS2: f64 = 9.806_65;

/// ADIS16505 accelerometer range [m/s^2] (datasheet front page: "78.4 m/sec^2 dynamic range").
pub const ADIS16505_ACCEL_RANGE_MPS2: f64 = 78.4;
/// Counts of the 16-bit `x_ACCL_OUT` word at [`ADIS16505_ACCEL_RANGE_MPS2`] (Linux and no-OS
/// `32000 << 16` for the 32-bit value). Linux and no-OS divide by 78 m/s^2 (an integer field);
/// 78.4 is taken here (see [`crate::drivers`]).
pub const ADIS16505_ACCEL_FULL_SCALE_LSB: f64 = 32000.0;
/// ADIS16465 accelerometer sensitivity, 16-bit [LSB/g] (Linux and no-OS `4000 << 16`, i.e.
/// 0.25 mg/LSB); its range is +-8 g.
pub const ADIS16465_ACCEL_LSB_PER_G: f64 = 4000.0;
/// Delta-velocity range of the ADIS16505 and ADIS16465 [m/s] (Linux and no-OS
/// `deltvel_max_val = 100`); the 32-bit LSB is range / 2^31.
pub const DELTA_VELOCITY_RANGE_MPS: f64 = 100.0;

/// The range variant of a model: -1, -2 or -3.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Range {
    /// -1: +-125 deg/s, 160 LSB/(deg/s), delta angle +-360 deg.
    Dps125,
    /// -2: +-500 deg/s, 40 LSB/(deg/s), delta angle +-720 deg.
    Dps500,
    /// -3: +-2000 deg/s, 10 LSB/(deg/s), delta angle +-2160 deg.
    Dps2000,
}

impl Range {
    /// Gyro measurement range [deg/s] (datasheet front pages: 125, 500, 2000 deg/s models).
    pub const fn gyro_range_dps(self) -> f64 {
        match self {
            Range::Dps125 => 125.0,
            Range::Dps500 => 500.0,
            Range::Dps2000 => 2000.0,
        }
    }

    /// Gyro sensitivity of the 16-bit `x_GYRO_OUT` word [LSB/(deg/s)] (Linux and no-OS
    /// `160/40/10 << 16` for the 32-bit value).
    pub const fn gyro_lsb_per_dps(self) -> f64 {
        match self {
            Range::Dps125 => 160.0,
            Range::Dps500 => 40.0,
            Range::Dps2000 => 10.0,
        }
    }

    /// Delta-angle range [deg]; the 32-bit LSB is range / 2^31 (Linux and no-OS
    /// `deltang_max_val` 360/720/2160).
    pub const fn delta_angle_range_deg(self) -> f64 {
        match self {
            Range::Dps125 => 360.0,
            Range::Dps500 => 720.0,
            Range::Dps2000 => 2160.0,
        }
    }
}

/// The supported devices: same SPI protocol and register map (Linux drives both with
/// `adis16475.c`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Model {
    /// ADIS16505-1/-2/-3: burst of rates or of delta angles/velocities, 16- or 32-bit.
    Adis16505(Range),
    /// ADIS16465-1/-2/-3: 16-bit burst of rates only (no `BURST_SEL`/`BURST32` in Linux's or
    /// no-OS's chip info for it).
    Adis16465(Range),
}

impl Model {
    /// The part fitted on the navigation board: ADIS16505-2 (+-500 deg/s, +-8 g). The firmware
    /// and the host harness both simulate it.
    pub const BOARD: Model = Model::Adis16505(Range::Dps500);

    /// `PROD_ID` (the part number in binary: 16505 = 0x4079, 16465 = 0x4051; Linux
    /// `ADIS16475_DATA(16505, ...)`).
    pub const fn prod_id(self) -> u16 {
        match self {
            Model::Adis16505(_) => 16505,
            Model::Adis16465(_) => 16465,
        }
    }

    /// The range variant.
    pub const fn range(self) -> Range {
        match self {
            Model::Adis16505(r) | Model::Adis16465(r) => r,
        }
    }

    /// `true` if `MSC_CTRL` bit 8 (`BURST_SEL`) makes the burst carry delta angles and delta
    /// velocities (Linux flag `ADIS16475_HAS_BURST_DELTA_DATA`).
    pub const fn has_delta_burst(self) -> bool {
        matches!(self, Model::Adis16505(_))
    }

    /// `true` if `MSC_CTRL` bit 9 (`BURST32`) selects the 32-bit burst (Linux flag
    /// `ADIS16475_HAS_BURST32`).
    pub const fn has_burst32(self) -> bool {
        matches!(self, Model::Adis16505(_))
    }

    /// Accelerometer measurement range [m/s^2].
    pub const fn accel_range_mps2(self) -> f64 {
        match self {
            Model::Adis16505(_) => ADIS16505_ACCEL_RANGE_MPS2,
            Model::Adis16465(_) => 8.0 * STANDARD_GRAVITY_MPS2,
        }
    }

    /// Accelerometer scale of the 16-bit `x_ACCL_OUT` word [(m/s^2)/LSB].
    pub const fn accel_mps2_per_lsb(self) -> f64 {
        match self {
            Model::Adis16505(_) => ADIS16505_ACCEL_RANGE_MPS2 / ADIS16505_ACCEL_FULL_SCALE_LSB,
            Model::Adis16465(_) => STANDARD_GRAVITY_MPS2 / ADIS16465_ACCEL_LSB_PER_G,
        }
    }

    /// Gyro scale of the 16-bit `x_GYRO_OUT` word [(rad/s)/LSB].
    pub const fn gyro_rad_s_per_lsb(self) -> f64 {
        core::f64::consts::PI / 180.0 / self.range().gyro_lsb_per_dps()
    }

    /// Delta-angle scale of the 16-bit `x_DELTANG_OUT` word [rad/LSB] (range / 2^15).
    pub const fn delta_angle_rad_per_lsb(self) -> f64 {
        self.range().delta_angle_range_deg() * (core::f64::consts::PI / 180.0) / 32768.0
    }

    /// Delta-velocity scale of the 16-bit `x_DELTVEL_OUT` word [(m/s)/LSB] (range / 2^15).
    pub const fn delta_velocity_mps_per_lsb(self) -> f64 {
        DELTA_VELOCITY_RANGE_MPS / 32768.0
    }
}
