//! ICM-42688-P driver against `embedded-hal-mock` transactions. Register addresses, values and
//! the packet format are written out again here, independently of the driver's constants.

mod common;

use core::f32::consts::PI;

use embedded_hal_mock::eh1::delay::{CheckedDelay, NoopDelay, Transaction as Delay};
use embedded_hal_mock::eh1::spi::{Mock as SpiMock, Transaction as Spi};
use hal_adapters::drivers::icm42688::{Config, Icm42688};
use hal_adapters::drivers::{Error, Mounting};
use hal_adapters::{ImuSample, Motion, SampleFlags};

use common::{assert_close, register_read, register_write};

// Bank 0 (PX4 InvenSense_ICM42688P_registers.hpp, Betaflight accgyro_spi_icm426xx.c).
const DEVICE_CONFIG: u8 = 0x11;
const INT_CONFIG: u8 = 0x14;
const FIFO_CONFIG: u8 = 0x16;
const INT_STATUS: u8 = 0x2D;
const SIGNAL_PATH_RESET: u8 = 0x4B;
const INTF_CONFIG1: u8 = 0x4D;
const PWR_MGMT0: u8 = 0x4E;
const GYRO_CONFIG0: u8 = 0x4F;
const ACCEL_CONFIG0: u8 = 0x50;
const TMST_CONFIG: u8 = 0x54;
const FIFO_CONFIG1: u8 = 0x5F;
const FIFO_CONFIG2: u8 = 0x60;
const FIFO_CONFIG3: u8 = 0x61;
const INT_CONFIG0: u8 = 0x63;
const INT_CONFIG1: u8 = 0x64;
const INT_SOURCE0: u8 = 0x65;
const WHO_AM_I: u8 = 0x75;
const REG_BANK_SEL: u8 = 0x76;

/// 20-bit scales: 131 LSB/(deg/s) x 2, 8192 LSB/g x 4; packet period 0.5 ms.
const GYRO_RAD_S_PER_LSB: f32 = PI / 180.0 / 262.0;
const ACCEL_MPS2_PER_LSB: f32 = 9.806_65 / 32768.0;
const PACKET_S: f32 = 0.0005;

fn write(reg: u8, value: u8) -> Vec<Spi<u8>> {
    register_write(reg, value)
}

fn read(reg: u8, value: u8) -> Vec<Spi<u8>> {
    register_read(reg, vec![value])
}

/// One FIFO read: INT_STATUS, FIFO_COUNT (big-endian) and packet bytes.
fn fifo_read(int_status: u8, count: u16, packets: &[[u8; 20]]) -> Vec<Spi<u8>> {
    let mut bytes = vec![int_status];
    bytes.extend_from_slice(&count.to_be_bytes());
    for p in packets {
        bytes.extend_from_slice(p);
    }
    register_read(INT_STATUS, bytes)
}

/// A 20-byte high-resolution packet: header 0x78, accel and gyro 20-bit, temperature,
/// timestamp.
fn packet(accel: [i32; 3], gyro: [i32; 3], temp: i16, ts: u16) -> [u8; 20] {
    let mut p = [0u8; 20];
    p[0] = 0x78;
    for i in 0..3 {
        let a = (accel[i] as u32) & 0xFFFFF;
        let g = (gyro[i] as u32) & 0xFFFFF;
        p[1 + 2 * i] = (a >> 12) as u8;
        p[2 + 2 * i] = (a >> 4) as u8;
        p[7 + 2 * i] = (g >> 12) as u8;
        p[8 + 2 * i] = (g >> 4) as u8;
        p[17 + i] = (((a & 0xF) << 4) | (g & 0xF)) as u8;
    }
    p[13..15].copy_from_slice(&temp.to_be_bytes());
    p[15..17].copy_from_slice(&ts.to_be_bytes());
    p
}

/// Five identical packets from timestamp `ts0` on, 500 us apart.
fn group(accel: [i32; 3], gyro: [i32; 3], ts0: u16) -> Vec<[u8; 20]> {
    (0..5u16)
        .map(|i| packet(accel, gyro, 1325, ts0 + 500 * i))
        .collect()
}

fn increments(s: &ImuSample) -> ([f32; 3], [f32; 3]) {
    match s.motion {
        Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => (delta_theta_ib_b, delta_v_ib_b),
        Motion::Rates { .. } => panic!("expected increments"),
    }
}

fn init_expectations() -> Vec<Spi<u8>> {
    [
        write(REG_BANK_SEL, 0),
        write(DEVICE_CONFIG, 0x01),
        read(WHO_AM_I, 0x47),
        read(INT_STATUS, 0x10),
        read(INTF_CONFIG1, 0x91),
        write(INTF_CONFIG1, 0x51),  // AFSR bits 7:6 = 0b01, the rest kept
        write(GYRO_CONFIG0, 0x05),  // +-2000 deg/s, 2 kHz
        write(ACCEL_CONFIG0, 0x05), // +-16 g, 2 kHz
        read(TMST_CONFIG, 0x23),
        write(TMST_CONFIG, 0x21), // 1 us, absolute, no FSYNC, enabled
        write(FIFO_CONFIG1, 0x3F),
        write(FIFO_CONFIG2, 100), // watermark: 5 packets of 20 bytes
        write(FIFO_CONFIG3, 0),
        write(INT_CONFIG, 0x03),
        write(INT_CONFIG0, 0x08),
        write(INT_CONFIG1, 0x00),
        write(INT_SOURCE0, 0x04),
        write(FIFO_CONFIG, 0x80), // stop on full
        write(PWR_MGMT0, 0x0F),
        write(SIGNAL_PATH_RESET, 0x02),
    ]
    .concat()
}

#[test]
fn init_sequence() {
    let delays = [
        Delay::delay_ms(1),
        Delay::delay_us(200),
        Delay::delay_ms(50),
    ];
    let mut delay = CheckedDelay::new(&delays);
    let mut imu = Icm42688::new(SpiMock::new(&init_expectations()), Config::default());
    imu.init(&mut delay).unwrap();
    imu.release().done();
    delay.done();
}

#[test]
fn wrong_who_am_i() {
    let spi = [
        write(REG_BANK_SEL, 0),
        write(DEVICE_CONFIG, 0x01),
        read(WHO_AM_I, 0x44),
    ]
    .concat();
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    assert_eq!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::WrongId {
            expected: 0x47,
            found: 0x44
        })
    );
    imu.release().done();
}

#[test]
fn reset_never_done_is_a_timeout() {
    let mut spi = [
        write(REG_BANK_SEL, 0),
        write(DEVICE_CONFIG, 0x01),
        read(WHO_AM_I, 0x47),
    ]
    .concat();
    for _ in 0..10 {
        spi.extend(read(INT_STATUS, 0x00));
    }
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    assert_eq!(imu.init(&mut NoopDelay::new()), Err(Error::Timeout));
    imu.release().done();
}

#[test]
fn five_packets_make_one_increment() {
    // 10 deg/s about x, -3 deg/s about z; 1 g down on z, 0.5 g on y.
    let gyro = [2620, 0, -786];
    let accel = [0, 16384, 32768];
    let spi = fifo_read(0x04, 100, &group(accel, gyro, 1000));
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    let s = imu.read_sample(777).unwrap();
    let (dtheta, dv) = increments(&s);
    let expect_g = gyro.map(|g| 5.0 * g as f32 * GYRO_RAD_S_PER_LSB * PACKET_S);
    let expect_a = accel.map(|a| 5.0 * a as f32 * ACCEL_MPS2_PER_LSB * PACKET_S);
    assert_close(dtheta, expect_g, [1e-9; 3], "dtheta");
    assert_close(dv, expect_a, [1e-7; 3], "dv");
    assert!((dtheta[0] - 10.0 * PI / 180.0 * 0.0025).abs() < 1e-7);
    assert_eq!((s.t_us, s.seq, s.dt_s), (777, 0, 0.0025));
    assert!(s.flags.is_empty());
    // 1325 / 132.48 + 25
    assert!(
        (s.temperature_c - 35.0015).abs() < 1e-3,
        "{}",
        s.temperature_c
    );
    imu.release().done();
}

#[test]
fn mounting_applies() {
    let spi = fifo_read(0, 100, &group([0, 0, 32768], [2620, 0, 0], 0));
    let config = Config {
        mounting: Mounting::FLU_TO_FRD,
    };
    let mut imu = Icm42688::new(SpiMock::new(&spi), config);
    let (dtheta, dv) = increments(&imu.read_sample(0).unwrap());
    assert!(dtheta[0] > 0.0 && dv[2] < 0.0);
    imu.release().done();
}

#[test]
fn fifo_overflow_flushes_and_next_sample_is_a_gap() {
    let mut spi = fifo_read(0x02, 100, &group([0; 3], [0; 3], 0));
    spi.extend(write(SIGNAL_PATH_RESET, 0x02));
    spi.extend(fifo_read(0x04, 100, &group([0; 3], [0; 3], 0)));
    spi.extend(fifo_read(0x04, 100, &group([0; 3], [0; 3], 9000)));
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    // Before any sample: no gap to report afterwards.
    let err = imu.read_sample(0).unwrap_err();
    assert_eq!(err, Error::FifoOverflow);
    assert!(err.is_transient());
    assert!(imu.read_sample(0).unwrap().flags.is_empty());
    assert_eq!(imu.read_sample(0).unwrap().flags, SampleFlags::GAP);
    assert_eq!(imu.health().fifo_overflows, 1);
    imu.release().done();
}

#[test]
fn invalid_marker_is_non_finite() {
    let mut packets = group([0, 0, 32768], [262, 0, 0], 0);
    packets[2] = packet([-524_288, 0, 32768], [262, 0, 0], -32768, 1000);
    let spi = fifo_read(0, 100, &packets);
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    let s = imu.read_sample(0).unwrap();
    assert_eq!(s.flags, SampleFlags::NON_FINITE);
    // The four valid packets are extrapolated over the five periods.
    let (dtheta, _) = increments(&s);
    assert!((dtheta[0] - 5.0 * 262.0 * GYRO_RAD_S_PER_LSB * PACKET_S).abs() < 1e-9);
    assert_eq!(imu.health().invalid, 1);
    imu.release().done();
}

#[test]
fn timestamp_gap_and_stale() {
    let mut packets = group([0; 3], [2620, 0, 0], 0);
    // Packet 3 comes 1500 us after packet 2: two packets missed.
    for (i, p) in packets.iter_mut().enumerate().skip(3) {
        *p = packet([0; 3], [2620, 0, 0], 1325, 2500 + 500 * (i as u16 - 3));
    }
    let mut spi = fifo_read(0, 100, &packets);
    let last = 3000;
    let stale: Vec<_> = (0..5).map(|_| packet([0; 3], [0; 3], 0, last)).collect();
    spi.extend(fifo_read(0, 100, &stale));
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    let s = imu.read_sample(0).unwrap();
    assert_eq!(s.flags, SampleFlags::GAP);
    assert_eq!(s.dt_s, 0.0035);
    let (dtheta, _) = increments(&s);
    let full = 10.0 * PI / 180.0 * 0.0035;
    assert!((dtheta[0] - full).abs() < 1e-7, "{} {full}", dtheta[0]);
    let s2 = imu.read_sample(0).unwrap();
    assert_eq!(s2.flags, SampleFlags::STALE);
    assert_eq!(s2.seq, 1);
    let h = imu.health();
    assert_eq!((h.missed, h.stale, h.samples), (2, 1, 2));
    imu.release().done();
}

#[test]
fn partial_fifo_is_not_ready_then_completes() {
    let packets = group([0; 3], [2620, 0, 0], 0);
    // Three packets in the FIFO; the rest of the read is empty slots.
    let mut first: Vec<[u8; 20]> = packets[..3].to_vec();
    first.push([0xFF; 20]);
    first.push([0xFF; 20]);
    let mut spi = fifo_read(0, 60, &first);
    spi.extend(fifo_read(0x04, 40, &packets[3..]));
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    let err = imu.read_sample(0).unwrap_err();
    assert_eq!(err, Error::NotReady);
    let s = imu.read_sample(0).unwrap();
    assert!(s.flags.is_empty());
    let (dtheta, _) = increments(&s);
    assert!((dtheta[0] - 10.0 * PI / 180.0 * 0.0025).abs() < 1e-7);
    imu.release().done();
}

#[test]
fn bad_header_flushes() {
    let mut packets = group([0; 3], [0; 3], 0);
    packets[1][0] = 0x68; // no 20-bit flag
    let mut spi = fifo_read(0, 100, &packets);
    spi.extend(write(SIGNAL_PATH_RESET, 0x02));
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    assert_eq!(imu.read_sample(0), Err(Error::BadFrame));
    assert_eq!(imu.health().checksum_errors, 1);
    imu.release().done();
}

#[test]
fn clipping_per_axis() {
    // 19-bit gyro full scale 262143 -> 524286; 18-bit accel 131071 -> 524284.
    let mut packets = group([0; 3], [0; 3], 0);
    packets[4] = packet([0, 0, -524_284], [0, 524_286, 0], 0, 2000);
    let spi = fifo_read(0, 100, &packets);
    let mut imu = Icm42688::new(SpiMock::new(&spi), Config::default());
    let s = imu.read_sample(0).unwrap();
    assert_eq!(
        s.flags,
        SampleFlags::GYRO_SATURATED | SampleFlags::ACCEL_SATURATED
    );
    assert_eq!(imu.health().gyro_clips, [0, 1, 0]);
    assert_eq!(imu.health().accel_clips, [0, 0, 1]);
    imu.release().done();
}
