//! ADIS16505 / ADIS16465 driver against `embedded-hal-mock` transactions. The register map and
//! scale factors are written out again here, independently of the driver's constants.

mod common;

use core::f32::consts::PI;

use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as Delay};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as Spi};
use hal_adapters::drivers::adis16505::{Adis16505, Config, Model, Range};
use hal_adapters::drivers::{Error, Mounting};
use hal_adapters::{Motion, SampleFlags};

use common::assert_close;

// Register map (Linux adis16475.c, no-OS adis1650x.c), written out again.
const DIAG_STAT: u8 = 0x02;
const MSC_CTRL: u8 = 0x60;
const DEC_RATE: u8 = 0x64;
const GLOB_CMD: u8 = 0x68;
const PROD_ID: u8 = 0x72;
const WRITE: u8 = 0x80;
const ADIS16505_ID: u16 = 16505; // 0x4079
const ADIS16465_ID: u16 = 16465; // 0x4051
const STALL_US: u32 = 16;
const DEG: f32 = PI / 180.0;
const G: f32 = 9.806_65;

/// One 16-bit register word in its own chip-select frame.
fn word(mosi: [u8; 2], miso: [u8; 2]) -> Vec<Spi<u8>> {
    vec![
        Spi::transaction_start(),
        Spi::transfer_in_place(mosi.to_vec(), miso.to_vec()),
        Spi::transaction_end(),
    ]
}

/// A burst: the 0x6800 command then `frame` under one chip select.
fn burst(frame: &[u8]) -> Vec<Spi<u8>> {
    vec![
        Spi::transaction_start(),
        Spi::write_vec(vec![0x68, 0x00]),
        Spi::read_vec(frame.to_vec()),
        Spi::transaction_end(),
    ]
}

/// A 16-bit burst frame of nine words plus their byte sum.
fn frame16(words: [u16; 9]) -> Vec<u8> {
    let mut f: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
    let sum = f.iter().fold(0u16, |s, &b| s.wrapping_add(b as u16));
    f.extend_from_slice(&sum.to_be_bytes());
    f
}

/// A 32-bit burst frame: DIAG_STAT, six values as LOW then OUT words, TEMP_OUT, DATA_CNTR, sum.
fn frame32(diag: u16, values: [i32; 6], temp: i16, cntr: u16) -> Vec<u8> {
    let mut f = diag.to_be_bytes().to_vec();
    for v in values {
        f.extend_from_slice(&(v as u16).to_be_bytes());
        f.extend_from_slice(&((v >> 16) as u16).to_be_bytes());
    }
    f.extend_from_slice(&(temp as u16).to_be_bytes());
    f.extend_from_slice(&cntr.to_be_bytes());
    let sum = f.iter().fold(0u16, |s, &b| s.wrapping_add(b as u16));
    f.extend_from_slice(&sum.to_be_bytes());
    f
}

fn rates(sample: &hal_adapters::ImuSample) -> ([f32; 3], [f32; 3]) {
    match sample.motion {
        Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b),
        Motion::Increments { .. } => panic!("expected rates"),
    }
}

fn increments(sample: &hal_adapters::ImuSample) -> ([f32; 3], [f32; 3]) {
    match sample.motion {
        Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => (delta_theta_ib_b, delta_v_ib_b),
        Motion::Rates { .. } => panic!("expected increments"),
    }
}

#[test]
fn init_sequence_adis16505() {
    let mut spi = Vec::new();
    spi.extend(word([WRITE | GLOB_CMD, 0x80], [0, 0])); // software reset
    spi.extend(word([PROD_ID, 0x00], [0, 0]));
    spi.extend(word([0x00, 0x00], ADIS16505_ID.to_be_bytes()));
    spi.extend(word([WRITE | DEC_RATE, 4], [0, 0]));
    spi.extend(word([WRITE | (DEC_RATE + 1), 0], [0, 0]));
    spi.extend(word([MSC_CTRL, 0x00], [0, 0]));
    spi.extend(word([0x00, 0x00], [0x00, 0xC1])); // reset value
    // BURST_SEL (bit 8) and BURST32 (bit 9) set, the rest kept.
    spi.extend(word([WRITE | MSC_CTRL, 0xC1], [0, 0]));
    spi.extend(word([WRITE | (MSC_CTRL + 1), 0x03], [0, 0]));
    let delays = [
        Delay::delay_us(STALL_US),
        Delay::delay_ms(260),
        Delay::delay_us(STALL_US),
        Delay::delay_us(STALL_US),
        Delay::delay_us(STALL_US),
        Delay::delay_us(STALL_US),
        Delay::delay_us(30),
        Delay::delay_us(STALL_US),
        Delay::delay_us(STALL_US),
        Delay::delay_us(STALL_US),
        Delay::delay_us(STALL_US),
        Delay::delay_us(200),
    ];
    let mut delay = CheckedDelay::new(&delays);
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16505(Range::Dps500)),
    );
    imu.init(&mut delay).unwrap();
    imu.release().done();
    delay.done();
}

#[test]
fn init_sequence_adis16465_leaves_msc_ctrl_alone() {
    let mut spi = Vec::new();
    spi.extend(word([WRITE | GLOB_CMD, 0x80], [0, 0]));
    spi.extend(word([PROD_ID, 0x00], [0, 0]));
    spi.extend(word([0x00, 0x00], ADIS16465_ID.to_be_bytes()));
    spi.extend(word([WRITE | DEC_RATE, 4], [0, 0]));
    spi.extend(word([WRITE | (DEC_RATE + 1), 0], [0, 0]));
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16465(Range::Dps125)),
    );
    imu.init(&mut NoopDelay::new()).unwrap();
    assert!(!imu.config().burst32);
    imu.release().done();
}

#[test]
fn wrong_product_id() {
    let mut spi = Vec::new();
    spi.extend(word([WRITE | GLOB_CMD, 0x80], [0, 0]));
    spi.extend(word([PROD_ID, 0x00], [0, 0]));
    spi.extend(word([0x00, 0x00], ADIS16465_ID.to_be_bytes()));
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16505(Range::Dps125)),
    );
    let err = imu.init(&mut NoopDelay::new()).unwrap_err();
    assert_eq!(
        err,
        Error::WrongId {
            expected: ADIS16505_ID,
            found: ADIS16465_ID
        }
    );
    assert!(err.to_string().contains("0x4079"), "{err}");
    imu.release().done();
}

#[test]
fn no_answer_is_a_timeout() {
    let mut spi = Vec::new();
    spi.extend(word([WRITE | GLOB_CMD, 0x80], [0, 0]));
    for _ in 0..4 {
        spi.extend(word([PROD_ID, 0x00], [0, 0]));
        spi.extend(word([0x00, 0x00], [0xFF, 0xFF]));
    }
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16505(Range::Dps125)),
    );
    assert_eq!(imu.init(&mut NoopDelay::new()), Err(Error::Timeout));
    imu.release().done();
}

#[test]
fn self_test_pass_and_fail() {
    let mut spi = Vec::new();
    for diag in [0x0000u16, 0x0120] {
        spi.extend(word([WRITE | GLOB_CMD, 0x04], [0, 0]));
        spi.extend(word([DIAG_STAT, 0x00], [0, 0]));
        spi.extend(word([0x00, 0x00], diag.to_be_bytes()));
    }
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16505(Range::Dps125)),
    );
    let mut delay = NoopDelay::new();
    assert!(imu.self_test(&mut delay).unwrap().is_empty());
    // Sensor failure (bit 5) and gyro 1 failure (bit 8).
    assert_eq!(imu.self_test(&mut delay), Err(Error::DeviceFault(0x0120)));
    imu.release().done();
}

#[test]
fn rates_burst_adis16465() {
    // ADIS16465-2: 40 LSB/(deg/s), 4000 LSB/g, 0.1 deg C/LSB.
    let f = frame16([0, 400, 0xFFD8, 0, 0, 400, (-4000i16) as u16, 253, 7]);
    let spi = SpiMock::new(&burst(&f));
    let mut imu = Adis16505::new(spi, Config::new(Model::Adis16465(Range::Dps500)));
    let s = imu.read_sample(12_345).unwrap();
    let (omega, force) = rates(&s);
    assert_close(omega, [10.0 * DEG, -DEG, 0.0], [1e-6; 3], "omega");
    assert_close(force, [0.0, 0.1 * G, -G], [1e-5; 3], "f");
    assert!((s.temperature_c - 25.3).abs() < 1e-5);
    assert_eq!((s.t_us, s.seq, s.dt_s), (12_345, 0, 0.0025));
    assert!(s.flags.is_empty());
    imu.release().done();
}

#[test]
fn increments_burst32_adis16505() {
    // ADIS16505-1: delta angle +-360 deg / 2^31, delta velocity +-100 m/s / 2^31.
    let dtheta_lsb = 360.0 / 2f64.powi(31) * std::f64::consts::PI / 180.0;
    let dv_lsb = 100.0 / 2f64.powi(31);
    let values = [0x0010_0000, -0x0000_8001, 1, 0, -0x0040_0000, 0x7FFF_FFFF];
    let f = frame32(0, values, -100, 42);
    let spi = SpiMock::new(&burst(&f));
    let mut imu = Adis16505::new(spi, Config::new(Model::Adis16505(Range::Dps125)));
    let s = imu.read_sample(0).unwrap();
    let (dtheta, dv) = increments(&s);
    let expect = |v: i32, lsb: f64| (f64::from(v) * lsb) as f32;
    assert_close(
        dtheta,
        [0, 1, 2].map(|i| expect(values[i], dtheta_lsb)),
        [1e-9; 3],
        "dtheta",
    );
    assert_close(
        dv,
        [3, 4, 5].map(|i| expect(values[i], dv_lsb)),
        [1e-6; 3],
        "dv",
    );
    assert!((s.temperature_c + 10.0).abs() < 1e-5);
    imu.release().done();
}

#[test]
fn mounting_rotates_into_body_axes() {
    let f = frame16([0, 160, 320, 480, 0, 0, 0, 0, 1]);
    let spi = SpiMock::new(&burst(&f));
    let config = Config::new(Model::Adis16465(Range::Dps125)).with_mounting(Mounting::FLU_TO_FRD);
    let mut imu = Adis16505::new(spi, config);
    let (omega, _) = rates(&imu.read_sample(0).unwrap());
    assert_close(omega, [DEG, -2.0 * DEG, -3.0 * DEG], [1e-7; 3], "omega");
    imu.release().done();
}

#[test]
fn checksum_failure_and_zero_frame_are_rejected() {
    let mut bad = frame16([0, 1, 2, 3, 4, 5, 6, 7, 8]);
    bad[5] ^= 0x01;
    let mut spi = burst(&bad);
    spi.extend(burst(&[0u8; 20]));
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16465(Range::Dps125)),
    );
    let err = imu.read_sample(0).unwrap_err();
    assert!(
        matches!(err, Error::Checksum { .. }) && err.is_transient(),
        "{err}"
    );
    assert_eq!(imu.read_sample(0), Err(Error::ZeroFrame));
    assert_eq!(imu.health().checksum_errors, 2);
    assert_eq!(imu.health().samples, 0);
    imu.release().done();
}

#[test]
fn stale_and_missed_counters() {
    let cntrs = [100u16, 100, 103, 104, 120];
    let mut spi = Vec::new();
    for c in cntrs {
        spi.extend(burst(&frame32(0, [1000, 0, 0, 0, 0, 2000], 0, c)));
    }
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16505(Range::Dps2000)),
    );
    let samples: Vec<_> = cntrs.iter().map(|_| imu.read_sample(0).unwrap()).collect();
    let flags: Vec<_> = samples.iter().map(|s| s.flags).collect();
    assert_eq!(
        flags,
        [
            SampleFlags::empty(),
            SampleFlags::STALE,
            SampleFlags::GAP,
            SampleFlags::empty(),
            SampleFlags::BAD_INTERVAL
        ]
    );
    let seqs: Vec<_> = samples.iter().map(|s| s.seq).collect();
    assert_eq!(seqs, [0, 0, 3, 4, 20]);
    let dts: Vec<_> = samples.iter().map(|s| s.dt_s).collect();
    assert_eq!(dts, [0.0025, 0.0, 0.0075, 0.0025, 0.04]);
    // The gap sample's increments cover the 3 periods.
    let (one, _) = increments(&samples[0]);
    let (three, _) = increments(&samples[2]);
    assert_eq!(three[0], one[0] * 3.0);
    let h = imu.health();
    assert_eq!((h.samples, h.stale, h.missed), (5, 1, 2 + 15));
    imu.release().done();
}

#[test]
fn clipping_per_axis_and_device_fault() {
    // ADIS16465-3: +-2000 deg/s = 20000 LSB, +-8 g = 32000 LSB; DIAG_STAT bit 5 sensor failure.
    let f1 = frame16([0, 20000, 19999, 0, 0, 0, (-32000i16) as u16, 0, 1]);
    let f2 = frame16([0x0020, 0, (-20001i16) as u16, 0, 32000, 0, 0, 0, 2]);
    let mut spi = burst(&f1);
    spi.extend(burst(&f2));
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16465(Range::Dps2000)),
    );
    let s1 = imu.read_sample(0).unwrap();
    assert_eq!(
        s1.flags,
        SampleFlags::GYRO_SATURATED | SampleFlags::ACCEL_SATURATED
    );
    let s2 = imu.read_sample(0).unwrap();
    assert_eq!(
        s2.flags,
        SampleFlags::GYRO_SATURATED | SampleFlags::ACCEL_SATURATED | SampleFlags::DEVICE_FAULT
    );
    assert!(!s2.flags.usable());
    let h = imu.health();
    assert_eq!(h.gyro_clips, [1, 1, 0]);
    assert_eq!(h.accel_clips, [1, 0, 1]);
    assert_eq!(h.device_faults, 1);
    assert_eq!(imu.last_diag().bits(), 0x0020);
    imu.release().done();
}

#[test]
fn increments_clip_at_range_times_period() {
    // ADIS16505-1: 125 deg/s over 2.5 ms = 0.3125 deg; 78.4 m/s^2 over 2.5 ms = 0.196 m/s.
    let dtheta_lsb = 360.0 / 2f64.powi(31);
    let dv_lsb = 100.0 / 2f64.powi(31);
    let at = |v: f64, lsb: f64| (v / lsb) as i32;
    let below = [at(0.3124, dtheta_lsb), 0, 0, at(0.1959, dv_lsb), 0, 0];
    let above = [0, -at(0.3126, dtheta_lsb), 0, 0, 0, -at(0.1961, dv_lsb)];
    let mut spi = burst(&frame32(0, below, 0, 1));
    spi.extend(burst(&frame32(0, above, 0, 2)));
    let mut imu = Adis16505::new(
        SpiMock::new(&spi),
        Config::new(Model::Adis16505(Range::Dps125)),
    );
    assert!(imu.read_sample(0).unwrap().flags.is_empty());
    assert_eq!(
        imu.read_sample(0).unwrap().flags,
        SampleFlags::GYRO_SATURATED | SampleFlags::ACCEL_SATURATED
    );
    assert_eq!(imu.health().gyro_clips, [0, 1, 0]);
    assert_eq!(imu.health().accel_clips, [0, 0, 1]);
    imu.release().done();
}
