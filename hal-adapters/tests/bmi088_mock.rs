//! BMI088 driver against `embedded-hal-mock` transactions on its two chip selects. Register
//! addresses, values and scales are written out again here, independently of the driver's
//! constants (datasheet rev. 1.3, Bosch BMI08x sensor API).

mod common;

use core::f32::consts::PI;

use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as Delay};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as Spi};
use hal_adapters::drivers::bmi088::{AccelRange, Bmi088, Config, GyroRange};
use hal_adapters::drivers::{Error, Mounting};
use hal_adapters::{ImuSample, Motion, SampleFlags};

use common::{assert_close, register_read, register_write};

// Gyroscope (CSB2).
const GYRO_CHIP_ID: u8 = 0x00;
const RATE_X_LSB: u8 = 0x02;
const GYRO_RANGE: u8 = 0x0F;
const GYRO_BANDWIDTH: u8 = 0x10;
const GYRO_LPM1: u8 = 0x11;
const GYRO_SOFTRESET: u8 = 0x14;
const GYRO_INT_CTRL: u8 = 0x15;
const INT3_INT4_IO_CONF: u8 = 0x16;
const INT3_INT4_IO_MAP: u8 = 0x18;
// Accelerometer (CSB1).
const ACC_CHIP_ID: u8 = 0x00;
const ACC_ERR_REG: u8 = 0x02;
const ACC_X_LSB: u8 = 0x12;
const ACC_CONF: u8 = 0x40;
const ACC_RANGE: u8 = 0x41;
const ACC_PWR_CONF: u8 = 0x7C;
const ACC_PWR_CTRL: u8 = 0x7D;
const ACC_SOFTRESET: u8 = 0x7E;
const RESET: u8 = 0xB6;
/// What the accelerometer sends as its dummy byte (anything).
const DUMMY: u8 = 0x5A;

/// +-2000 deg/s: 32768 LSB at the range; +-24 g: 32768 LSB at 24 g.
const GYRO_RAD_S_PER_LSB: f32 = PI / 180.0 * 2000.0 / 32768.0;
const ACCEL_MPS2_PER_LSB: f32 = 9.806_65 * 24.0 / 32768.0;

fn write(reg: u8, value: u8) -> Vec<Spi<u8>> {
    register_write(reg, value)
}

fn gyro_read(reg: u8, value: u8) -> Vec<Spi<u8>> {
    register_read(reg, vec![value])
}

/// An accelerometer register read: the dummy byte comes first.
fn accel_read(reg: u8, value: u8) -> Vec<Spi<u8>> {
    register_read(reg, vec![DUMMY, value])
}

/// One sample's reads: 6 gyro bytes from RATE_X_LSB; the dummy byte and 18 accelerometer
/// bytes from ACC_X_LSB (data, 24-bit sensor time at 0x18, 0x1B..=0x21, TEMP_MSB, TEMP_LSB).
fn data(gyro: [i16; 3], accel: [i16; 3], sensortime: u32, temp: [u8; 2]) -> [Vec<Spi<u8>>; 2] {
    let g: Vec<u8> = gyro.iter().flat_map(|v| v.to_le_bytes()).collect();
    let mut a = vec![DUMMY];
    a.extend(accel.iter().flat_map(|v| v.to_le_bytes()));
    a.extend(&sensortime.to_le_bytes()[..3]);
    a.extend([0u8; 7]);
    a.extend(temp);
    [register_read(RATE_X_LSB, g), register_read(ACC_X_LSB, a)]
}

/// Several samples' reads, split into the gyro's and the accelerometer's expectations.
fn samples(reads: &[[Vec<Spi<u8>>; 2]]) -> (Vec<Spi<u8>>, Vec<Spi<u8>>) {
    let g = reads.iter().flat_map(|r| r[0].clone()).collect();
    let a = reads.iter().flat_map(|r| r[1].clone()).collect();
    (g, a)
}

fn rates(s: &ImuSample) -> ([f32; 3], [f32; 3]) {
    match s.motion {
        Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b),
        Motion::Increments { .. } => panic!("expected rates"),
    }
}

fn driver(gyro: &[Spi<u8>], accel: &[Spi<u8>], config: Config) -> Bmi088<SpiMock<u8>, SpiMock<u8>> {
    Bmi088::new(SpiMock::new(gyro), SpiMock::new(accel), config)
}

fn done(imu: Bmi088<SpiMock<u8>, SpiMock<u8>>) {
    let (mut g, mut a) = imu.release();
    g.done();
    a.done();
}

#[test]
fn init_sequence() {
    let gyro = [
        write(GYRO_SOFTRESET, RESET),
        gyro_read(GYRO_CHIP_ID, 0x0F),
        write(GYRO_RANGE, 0x02),        // +-500 deg/s
        write(GYRO_BANDWIDTH, 0x03),    // 400 Hz ODR, 47 Hz filter
        write(GYRO_LPM1, 0x00),         // normal mode
        write(GYRO_INT_CTRL, 0x80),     // data-ready interrupt on
        write(INT3_INT4_IO_CONF, 0x01), // INT3 push-pull, active high
        write(INT3_INT4_IO_MAP, 0x01),  // data ready to INT3
    ]
    .concat();
    let accel = [
        accel_read(ACC_CHIP_ID, 0xFF), // dummy read: I2C -> SPI
        write(ACC_SOFTRESET, RESET),
        accel_read(ACC_CHIP_ID, 0xFF), // again after the reset
        accel_read(ACC_CHIP_ID, 0x1E),
        write(ACC_PWR_CONF, 0x00), // active
        write(ACC_PWR_CTRL, 0x04), // on
        write(ACC_CONF, 0xAA),     // normal filter, 400 Hz
        write(ACC_RANGE, 0x00),    // +-3 g
        accel_read(ACC_ERR_REG, 0x00),
    ]
    .concat();
    let delays = [
        Delay::delay_ms(30),
        Delay::delay_ms(1),
        Delay::delay_ms(5),
        Delay::delay_ms(5),
    ];
    let mut delay = CheckedDelay::new(&delays);
    let config = Config {
        gyro_range: GyroRange::Dps500,
        accel_range: AccelRange::G3,
        mounting: Mounting::IDENTITY,
    };
    let mut imu = driver(&gyro, &accel, config);
    imu.init(&mut delay).unwrap();
    done(imu);
    delay.done();
}

#[test]
fn wrong_gyro_id() {
    let gyro = [write(GYRO_SOFTRESET, RESET), gyro_read(GYRO_CHIP_ID, 0x1E)].concat();
    let mut imu = driver(&gyro, &[], Config::default());
    assert_eq!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::WrongId {
            expected: 0x0F,
            found: 0x1E
        })
    );
    done(imu);
}

#[test]
fn wrong_accel_id() {
    let gyro = [write(GYRO_SOFTRESET, RESET), gyro_read(GYRO_CHIP_ID, 0x0F)].concat();
    let accel = [
        accel_read(ACC_CHIP_ID, 0xFF),
        write(ACC_SOFTRESET, RESET),
        accel_read(ACC_CHIP_ID, 0xFF),
        accel_read(ACC_CHIP_ID, 0xFF), // still not in SPI mode: nobody answers
    ]
    .concat();
    let mut imu = driver(&gyro, &accel, Config::default());
    assert_eq!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::WrongId {
            expected: 0x1E,
            found: 0xFF
        })
    );
    done(imu);
}

#[test]
fn accel_error_register_is_a_device_fault() {
    let gyro = [
        write(GYRO_SOFTRESET, RESET),
        gyro_read(GYRO_CHIP_ID, 0x0F),
        write(GYRO_RANGE, 0x00),
        write(GYRO_BANDWIDTH, 0x03),
        write(GYRO_LPM1, 0x00),
        write(GYRO_INT_CTRL, 0x80),
        write(INT3_INT4_IO_CONF, 0x01),
        write(INT3_INT4_IO_MAP, 0x01),
    ]
    .concat();
    let accel = [
        accel_read(ACC_CHIP_ID, 0x00),
        write(ACC_SOFTRESET, RESET),
        accel_read(ACC_CHIP_ID, 0x00),
        accel_read(ACC_CHIP_ID, 0x1E),
        write(ACC_PWR_CONF, 0x00),
        write(ACC_PWR_CTRL, 0x04),
        write(ACC_CONF, 0xAA),
        write(ACC_RANGE, 0x03),
        accel_read(ACC_ERR_REG, 0x04), // error code 1: invalid ACC_CONF
    ]
    .concat();
    let mut imu = driver(&gyro, &accel, Config::default());
    let err = imu.init(&mut NoopDelay::new()).unwrap_err();
    assert_eq!(err, Error::DeviceFault(0x04));
    assert!(!err.is_transient());
    done(imu);
}

#[test]
fn decodes_a_sample() {
    // 100 deg/s about x (1638.4 LSB), -10 deg/s about z; 1 g down on z (1365.33 LSB).
    let gyro = [1638, 0, -164];
    let accel = [0, 683, 1365];
    // Temperature 0x00 0x60: 23.375 deg C (datasheet table).
    let (g, a) = samples(&[data(gyro, accel, 5000, [0x00, 0x60])]);
    let mut imu = driver(&g, &a, Config::default());
    let s = imu.read_sample(777).unwrap();
    let (omega, f) = rates(&s);
    let expect_g = gyro.map(|v| f32::from(v) * GYRO_RAD_S_PER_LSB);
    let expect_a = accel.map(|v| f32::from(v) * ACCEL_MPS2_PER_LSB);
    assert_close(omega, expect_g, [1e-6; 3], "omega");
    assert_close(f, expect_a, [1e-5; 3], "f");
    assert!((omega[0] - 100.0 * PI / 180.0).abs() < 5e-4);
    assert!((f[2] - 9.806_65).abs() < 0.01);
    assert_eq!((s.t_us, s.seq, s.dt_s), (777, 0, 0.0025));
    assert!(s.flags.is_empty());
    assert_eq!(s.temperature_c, 23.375);
    done(imu);
}

#[test]
fn mounting_applies() {
    let (g, a) = samples(&[data([1638, 0, 0], [0, 0, 1365], 0x40, [0, 0])]);
    let config = Config {
        mounting: Mounting::FLU_TO_FRD,
        ..Config::default()
    };
    let mut imu = driver(&g, &a, config);
    let (omega, f) = rates(&imu.read_sample(0).unwrap());
    assert!(omega[0] > 0.0 && f[2] < 0.0);
    done(imu);
}

#[test]
fn sensor_time_gives_stale_gaps_and_wraps() {
    // 64 sensor-time counts (of 39.0625 us) per 2.5 ms period.
    let t0 = 0xFF_FFD0; // wraps to 0x10 one period later
    let reads = [
        data([0; 3], [0, 0, 1365], t0, [0, 0]),
        data([0; 3], [0, 0, 1365], (t0 + 64) & 0xFF_FFFF, [0, 0]),
        data([0; 3], [0, 0, 1365], (t0 + 70) & 0xFF_FFFF, [0, 0]), // read again too soon
        data(
            [0; 3],
            [0, 0, 1365],
            (t0 + 64 + 3 * 64 + 5) & 0xFF_FFFF,
            [0, 0],
        ),
        data(
            [0; 3],
            [0, 0, 1365],
            (t0 + 64 + 15 * 64) & 0xFF_FFFF,
            [0, 0],
        ),
    ];
    let (g, a) = samples(&reads);
    let mut imu = driver(&g, &a, Config::default());
    let got: Vec<_> = (0..5).map(|t| imu.read_sample(t).unwrap()).collect();
    let flags: Vec<_> = got.iter().map(|s| s.flags).collect();
    assert_eq!(
        flags,
        [
            SampleFlags::empty(),
            SampleFlags::empty(),
            SampleFlags::STALE,
            SampleFlags::GAP,
            SampleFlags::BAD_INTERVAL
        ]
    );
    let seq: Vec<_> = got.iter().map(|s| s.seq).collect();
    assert_eq!(seq, [0, 1, 1, 4, 16]);
    let dt: Vec<_> = got.iter().map(|s| s.dt_s).collect();
    assert_eq!(dt, [0.0025, 0.0025, 0.0, 0.0075, 0.03]);
    let h = imu.health();
    assert_eq!((h.samples, h.stale, h.missed), (5, 1, 2 + 11));
    done(imu);
}

#[test]
fn clipping_per_axis() {
    let (g, a) = samples(&[data([0, 32767, 0], [0, 0, -32768], 64, [0, 0])]);
    let mut imu = driver(&g, &a, Config::default());
    let s = imu.read_sample(0).unwrap();
    assert_eq!(
        s.flags,
        SampleFlags::GYRO_SATURATED | SampleFlags::ACCEL_SATURATED
    );
    assert_eq!(imu.health().gyro_clips, [0, 1, 0]);
    assert_eq!(imu.health().accel_clips, [0, 0, 1]);
    done(imu);
    // One count below full scale is not a clip.
    let (g, a) = samples(&[data([32766, -32766, 0], [32766, 0, 0], 64, [0, 0])]);
    let mut imu = driver(&g, &a, Config::default());
    assert!(imu.read_sample(0).unwrap().flags.is_empty());
    done(imu);
}

#[test]
fn zero_accel_frame_and_invalid_temperature() {
    let (g, a) = samples(&[
        data([1, 2, 3], [0; 3], 0, [0, 0]),
        data([1, 2, 3], [0, 0, 1365], 64, [0x80, 0x00]),
    ]);
    let mut imu = driver(&g, &a, Config::default());
    let err = imu.read_sample(0).unwrap_err();
    assert_eq!(err, Error::ZeroFrame);
    assert!(err.is_transient());
    let s = imu.read_sample(0).unwrap();
    assert!(s.temperature_c.is_nan());
    assert!(s.flags.is_empty());
    assert_eq!(imu.health().checksum_errors, 1);
    done(imu);
}
