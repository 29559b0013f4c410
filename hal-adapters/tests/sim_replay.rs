//! A recording replayed through a simulated device and the real driver comes back within one
//! register count, with the recording's gaps, bad samples and clipping showing as the driver's
//! flags.

mod common;

use core::f32::consts::PI;

use hal_adapters::drivers::adis16505::{self, Model, Range};
use hal_adapters::drivers::icm42688;
use hal_adapters::drivers::{ImuDriver, Mounting, SignedAxis};
use hal_adapters::recording::{Kind, Record, Replay};
use hal_adapters::sim::{NoDelay, NonFinite, SimAdis16505, SimError, SimulatedImu};
use hal_adapters::{Imu, ImuSample, SampleFlags};

use common::{PERIOD_NS, T0_NS, recording};

const DEG: f32 = PI / 180.0;
const T_S: f32 = 0.0025;
/// Records with special contents.
const GAP_AT: usize = 40; // 3 periods after the previous record
const NAN_AT: usize = 80;
const CLIP_AT: usize = 120; // 700 deg/s about z
const STALE_AT: usize = 160; // same time as the previous record
const LONG_GAP_AT: usize = 200; // 12 periods
const N: usize = 240;

/// A recording of a slow coning-like motion at rest-level gravity, with the special records.
/// `kind` decides whether the records hold increments or rates.
fn records(kind: Kind) -> Vec<Record> {
    let mut t_ns = T0_NS;
    let mut out = Vec::new();
    for i in 0..N {
        let periods = match i {
            GAP_AT => 3,
            STALE_AT => 0,
            LONG_GAP_AT => 12,
            _ => 1,
        };
        t_ns += periods * PERIOD_NS;
        let x = i as f32 * 0.05;
        // Rates [rad/s] and specific force [m/s^2].
        let mut omega = [
            20.0 * DEG * (x).sin(),
            -15.0 * DEG * (1.3 * x).cos(),
            5.0 * DEG + 0.001 * x,
        ];
        let f = [0.3 * (0.7 * x).sin(), -0.2, -9.80665 + 0.05 * x.cos()];
        if i == CLIP_AT {
            omega[2] = 700.0 * DEG;
        }
        let dt = periods as f32 * T_S;
        let (mut gyro, accel) = match kind {
            Kind::Increments => (omega.map(|w| w * dt), f.map(|a| a * dt)),
            Kind::Rates => (omega, f),
        };
        if i == NAN_AT {
            gyro[1] = f32::NAN;
        }
        out.push(Record {
            t_ns,
            gyro,
            accel,
            temperature_c: 30.0 + 0.01 * i as f32,
        });
    }
    out
}

/// `s` as a part of a 500 deg/s range senses it: the z rate (the one [`CLIP_AT`] sets beyond
/// the range; z is z, or -z, in every mounting used here) saturated at the range.
fn saturated_z(s: &ImuSample) -> ImuSample {
    let mut s = *s;
    let limit = 500.0 * DEG;
    match &mut s.motion {
        hal_adapters::Motion::Rates { omega_ib_b, .. } => {
            omega_ib_b[2] = omega_ib_b[2].clamp(-limit, limit);
        }
        hal_adapters::Motion::Increments {
            delta_theta_ib_b, ..
        } => {
            let d = limit * s.dt_s;
            delta_theta_ib_b[2] = delta_theta_ib_b[2].clamp(-d, d);
        }
    }
    s
}

fn replay(bytes: &[u8]) -> Replay<&[u8]> {
    Replay::new(bytes).unwrap()
}

fn all<I: Imu>(imu: &mut I) -> Vec<ImuSample> {
    let mut out = Vec::new();
    while let Some(s) = imu.read_sample().unwrap() {
        out.push(s);
        assert!(out.len() <= N, "the simulation does not end");
    }
    out
}

/// Output periods of an interval.
fn periods(dt_s: f32) -> f32 {
    (dt_s / T_S).round()
}

/// Checks one driver sample against its recording sample: increments (the recording's, scaled
/// to the interval the driver reports) within `counts` counts per period plus `f32` rounding
/// (half a count when rounded, one when the device carries its remainder).
fn check_increments(got: &ImuSample, want: &ImuSample, lsb: (f32, f32), counts: f32) {
    let (g_got, a_got) = got.increments();
    let (g_want, a_want) = want.increments();
    let k_got = periods(got.dt_s).max(1.0);
    let k_want = periods(want.dt_s).max(1.0);
    let scale = k_got / k_want;
    for axis in 0..3 {
        for (got, want, lsb, what) in [
            (g_got[axis], g_want[axis] * scale, lsb.0, "dtheta"),
            (a_got[axis], a_want[axis] * scale, lsb.1, "dv"),
        ] {
            let tol = counts * lsb * k_got + 2e-6 * want.abs() + 1e-12;
            assert!(
                (got - want).abs() <= tol,
                "seq {} {what}[{axis}]: {got} vs {want} (tol {tol})",
                got
            );
        }
    }
}

#[test]
fn adis16505_increments_round_trip() {
    let bytes = recording(Kind::Increments, &records(Kind::Increments));
    let model = Model::Adis16505(Range::Dps500);
    let mounting = Mounting::FLU_TO_FRD;
    let config = adis16505::Config::new(model).with_mounting(mounting);
    let mut sim = SimulatedImu::adis16505(replay(&bytes), config).unwrap();
    let got = all(&mut sim);
    let want = all(&mut replay(&bytes));
    // The NaN record's frame is rejected (bad checksum), and the stream delivers the record
    // itself, flagged non-finite as the replay flags it.
    assert_eq!(got.len(), want.len());
    // (Compared as text: NaN is not equal to itself.)
    assert_eq!(format!("{:?}", got[NAN_AT]), format!("{:?}", want[NAN_AT]));
    assert_eq!(got[NAN_AT].flags, SampleFlags::NON_FINITE);

    // 32-bit delta LSBs of the -2 model: 720 deg / 2^31, 100 m/s / 2^31.
    let lsb = (720.0 * DEG / 2f32.powi(31), 100.0 / 2f32.powi(31));
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        if i == NAN_AT {
            continue;
        }
        assert_eq!(g.t_us, w.t_us, "record {i}");
        let expected = match i {
            GAP_AT => SampleFlags::GAP,
            // The lost record shows as a one-sample gap.
            _ if i == NAN_AT + 1 => SampleFlags::GAP,
            CLIP_AT => SampleFlags::GYRO_SATURATED,
            STALE_AT => SampleFlags::STALE,
            LONG_GAP_AT => SampleFlags::BAD_INTERVAL,
            _ => SampleFlags::empty(),
        };
        assert_eq!(g.flags, expected, "record {i}");
        if i != STALE_AT {
            // Delta outputs carry their rounding remainder: up to one count. The part senses
            // the 700 deg/s of `CLIP_AT` at its 500 deg/s range.
            check_increments(g, &saturated_z(w), lsb, 1.0);
        }
        assert!(
            (g.temperature_c - w.temperature_c).abs() <= 0.05 + 1e-4,
            "record {i}"
        );
    }
    let h = sim.driver().health();
    assert_eq!(h.checksum_errors, 1);
    assert_eq!(h.missed, 2 + 1 + 11);
    assert_eq!((h.stale, h.gyro_clips), (1, [0, 0, 1]));
}

#[test]
fn adis16465_rates_round_trip() {
    let bytes = recording(Kind::Rates, &records(Kind::Rates));
    let model = Model::Adis16465(Range::Dps500);
    let config = adis16505::Config::new(model);
    // The zero-frame answer to the NaN record this time.
    let bus = SimAdis16505::new(replay(&bytes), model).with_non_finite(NonFinite::ZeroFrame);
    let mut driver = adis16505::Adis16505::new(bus, config);
    driver.init(&mut NoDelay).unwrap();
    let mut sim = SimulatedImu::new(driver);
    let got = all(&mut sim);
    let want = all(&mut replay(&bytes));
    assert_eq!(got.len(), want.len());
    assert_eq!(format!("{:?}", got[NAN_AT]), format!("{:?}", want[NAN_AT]));
    // 16-bit: 40 LSB/(deg/s), 4000 LSB/g.
    let (g_lsb, a_lsb) = (DEG / 40.0, 9.80665 / 4000.0);
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        if i == NAN_AT {
            continue;
        }
        // The part senses the 700 deg/s of `CLIP_AT` at its 500 deg/s range.
        let w = saturated_z(w);
        let (
            hal_adapters::Motion::Rates { omega_ib_b, f_ib_b },
            hal_adapters::Motion::Rates {
                omega_ib_b: w_omega,
                f_ib_b: w_f,
            },
        ) = (g.motion, w.motion)
        else {
            panic!("rates expected");
        };
        for axis in 0..3 {
            assert!(
                (omega_ib_b[axis] - w_omega[axis]).abs() <= 0.5 * g_lsb + 1e-6,
                "{i}"
            );
            assert!(
                (f_ib_b[axis] - w_f[axis]).abs() <= 0.5 * a_lsb + 1e-5,
                "{i}"
            );
        }
        if i == CLIP_AT {
            assert_eq!(g.flags, SampleFlags::GYRO_SATURATED);
        }
    }
    assert_eq!(sim.driver().health().checksum_errors, 1);
}

#[test]
fn icm42688_round_trip() {
    let bytes = recording(Kind::Increments, &records(Kind::Increments));
    let mounting =
        Mounting::from_axes([SignedAxis::PlusY, SignedAxis::MinusX, SignedAxis::PlusZ]).unwrap();
    let config = icm42688::Config { mounting };
    let mut sim = SimulatedImu::icm42688(replay(&bytes), config).unwrap();
    let got = all(&mut sim);
    let want = all(&mut replay(&bytes));
    assert_eq!(got.len(), want.len());
    // 19-bit gyro 131 LSB/(deg/s), 18-bit accel 8192 LSB/g, as increments over one period.
    let lsb = (DEG / 131.0 * T_S, 9.80665 / 8192.0 * T_S);
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        assert_eq!(g.t_us, w.t_us);
        let expected = match i {
            GAP_AT => SampleFlags::GAP,
            NAN_AT => SampleFlags::NON_FINITE,
            STALE_AT => SampleFlags::STALE,
            LONG_GAP_AT => SampleFlags::BAD_INTERVAL,
            _ => SampleFlags::empty(),
        };
        assert_eq!(g.flags, expected, "record {i}");
        match i {
            NAN_AT => assert_eq!(g.increments(), ([0.0; 3], [0.0; 3])),
            STALE_AT => {}
            _ => check_increments(g, w, lsb, 0.5),
        }
        assert!(
            (g.temperature_c - w.temperature_c).abs() <= 0.01,
            "record {i}"
        );
    }
    let h = sim.driver().health();
    assert_eq!((h.invalid, h.stale, h.missed), (1, 1, 5 * 2 + 5 * 11));
}

#[test]
fn icm42688_clips_beyond_2000_deg_s() {
    let mut recs = records(Kind::Rates);
    recs[CLIP_AT].gyro[2] = 2100.0 * DEG;
    recs[CLIP_AT].accel[0] = -17.0 * 9.80665;
    let bytes = recording(Kind::Rates, &recs);
    let mut sim = SimulatedImu::icm42688(replay(&bytes), icm42688::Config::default()).unwrap();
    let got = all(&mut sim);
    assert_eq!(
        got[CLIP_AT].flags,
        SampleFlags::GYRO_SATURATED | SampleFlags::ACCEL_SATURATED
    );
    assert_eq!(sim.driver().health().gyro_clips, [0, 0, 1]);
    assert_eq!(sim.driver().health().accel_clips, [1, 0, 0]);
}

#[test]
fn simulation_is_deterministic() {
    let bytes = recording(Kind::Increments, &records(Kind::Increments));
    let bits = |samples: Vec<ImuSample>| -> Vec<(u64, u32, u32, [u32; 6], u16)> {
        samples
            .iter()
            .map(|s| {
                let (g, a) = s.increments();
                let v = [g[0], g[1], g[2], a[0], a[1], a[2]].map(f32::to_bits);
                (s.t_us, s.seq, s.dt_s.to_bits(), v, s.flags.bits())
            })
            .collect()
    };
    let config = adis16505::Config::new(Model::Adis16505(Range::Dps2000));
    let a = all(&mut SimulatedImu::adis16505(replay(&bytes), config).unwrap());
    let b = all(&mut SimulatedImu::adis16505(replay(&bytes), config).unwrap());
    assert_eq!(bits(a), bits(b));
    let c = all(&mut SimulatedImu::icm42688(replay(&bytes), Default::default()).unwrap());
    let d = all(&mut SimulatedImu::icm42688(replay(&bytes), Default::default()).unwrap());
    assert_eq!(bits(c), bits(d));
}

#[test]
fn firmware_style_reads_end_with_the_recording() {
    // What the data-ready interrupt does: read at each edge with the board's time.
    let bytes = recording(Kind::Increments, &records(Kind::Increments)[..10]);
    let model = Model::Adis16505(Range::Dps125);
    let mut imu = adis16505::Adis16505::new(
        SimAdis16505::new(replay(&bytes), model),
        adis16505::Config::new(model),
    );
    imu.init(&mut NoDelay).unwrap();
    let mut t_us = 0;
    let mut n = 0;
    loop {
        t_us += 2500;
        match imu.read_sample(t_us) {
            Ok(s) => {
                assert_eq!(s.t_us, t_us);
                assert!(s.flags.usable());
                n += 1;
            }
            Err(hal_adapters::drivers::Error::Spi(SimError::End)) => break,
            Err(e) => panic!("{e}"),
        }
    }
    assert_eq!(n, 10);
    assert_eq!(imu.bus().bursts(), 10);
    assert_eq!(ImuDriver::health(&imu).samples, 10);
}

/// The end of the recording fails the bus once, which the driver counts as a bus error; the
/// simulated IMU reports its health without it, ends for good, and reads nothing more.
#[test]
fn the_end_of_the_recording_is_not_a_bus_error() {
    let bytes = recording(Kind::Increments, &records(Kind::Increments)[..10]);
    let config = adis16505::Config::new(Model::Adis16505(Range::Dps500));
    let mut sim = SimulatedImu::adis16505(replay(&bytes), config).unwrap();
    assert_eq!(all(&mut sim).len(), 10);
    assert_eq!(sim.driver().health().bus_errors, 1);
    for _ in 0..3 {
        assert!(sim.read_sample().unwrap().is_none());
    }
    let h = sim.health();
    assert_eq!((h.samples, h.bus_errors), (10, 0));
    assert_eq!(
        sim.driver().health().bus_errors,
        1,
        "nothing read after the end"
    );
    assert_eq!(sim.driver().bus().bursts(), 10);
}

#[test]
fn icm_sim_answers_nothing_until_configured() {
    // A FIFO read before init finds no data: the driver reports NotReady, not garbage.
    let bytes = recording(Kind::Increments, &records(Kind::Increments)[..3]);
    let mut imu = icm42688::Icm42688::new(
        hal_adapters::sim::SimIcm42688::new(replay(&bytes)),
        icm42688::Config::default(),
    );
    assert!(matches!(
        imu.read_sample(0),
        Err(hal_adapters::drivers::Error::NotReady)
    ));
    imu.init(&mut NoDelay).unwrap();
    assert!(imu.read_sample(0).unwrap().flags.is_empty());
    imu.bus_mut().inject_fifo_overflow();
    assert!(matches!(
        imu.read_sample(0),
        Err(hal_adapters::drivers::Error::FifoOverflow)
    ));
    // After the flush, the next sample reports the loss.
    assert_eq!(imu.read_sample(0).unwrap().flags, SampleFlags::GAP);
}

/// The simulated ADIS16505 carries the rounding remainder of its delta outputs like an
/// integrating sensor: a constant input of 10.3 counts per sample (about the Earth rate) sums
/// to within one count after 4000 samples, where plain rounding would lose 0.3 count per sample
/// (a 3 % bias, 1.2 deg of gyrocompass heading).
#[test]
fn adis16505_deltas_carry_their_rounding() {
    let lsb_rad = 720.0 * DEG / 2f32.powi(31);
    let dtheta = 10.3 * lsb_rad;
    let mut t_ns = T0_NS;
    let recs: Vec<Record> = (0..4000)
        .map(|_| {
            t_ns += PERIOD_NS;
            Record {
                t_ns,
                gyro: [dtheta, 0.0, 0.0],
                accel: [0.0, 0.0, -9.8 * T_S],
                temperature_c: 25.0,
            }
        })
        .collect();
    let bytes = recording(Kind::Increments, &recs);
    let model = Model::Adis16505(Range::Dps500);
    let mut sim = SimulatedImu::adis16505(replay(&bytes), adis16505::Config::new(model)).unwrap();
    let mut got = Vec::new();
    while let Some(s) = sim.read_sample().unwrap() {
        got.push(s);
    }
    assert_eq!(got.len(), 4000);
    let sum_counts: f64 = got
        .iter()
        .map(|s| f64::from(s.increments().0[0]) / f64::from(lsb_rad))
        .sum();
    assert!((sum_counts - 4000.0 * 10.3).abs() <= 1.0, "{sum_counts}");
}

/// The BMI088's rates (gyro and accelerometer on their two chip selects, one source) come
/// back within half a count, with the recording's events as flags.
#[test]
fn bmi088_round_trip() {
    use hal_adapters::drivers::bmi088::{self, AccelRange, GyroRange};
    use hal_adapters::sim::SimBmi088;

    for kind in [Kind::Rates, Kind::Increments] {
        let bytes = recording(kind, &records(kind));
        let mounting =
            Mounting::from_axes([SignedAxis::PlusY, SignedAxis::MinusX, SignedAxis::PlusZ])
                .unwrap();
        let config = bmi088::Config {
            gyro_range: GyroRange::Dps500,
            accel_range: AccelRange::G3,
            mounting,
        };
        let device = SimBmi088::new(replay(&bytes));
        let mut sim = SimulatedImu::bmi088(&device, config).unwrap();
        let got = all(&mut sim);
        let want = all(&mut replay(&bytes));
        assert_eq!(got.len(), want.len());
        // 65.536 LSB/(deg/s) at +-500 deg/s, 10922.67 LSB/g at +-3 g.
        let (g_lsb, a_lsb) = (DEG * 500.0 / 32768.0, 9.80665 * 3.0 / 32768.0);
        for (i, (g, w)) in got.iter().zip(&want).enumerate() {
            assert_eq!(g.t_us, w.t_us, "record {i}");
            let expected = match i {
                GAP_AT => SampleFlags::GAP,
                // A non-finite record: the device holds its data and sensor time (and the
                // stream flags it non-finite); the next sample shows the time lost.
                NAN_AT => SampleFlags::STALE | SampleFlags::NON_FINITE,
                STALE_AT => SampleFlags::STALE,
                _ if i == NAN_AT + 1 => SampleFlags::GAP,
                CLIP_AT => SampleFlags::GYRO_SATURATED,
                LONG_GAP_AT => SampleFlags::BAD_INTERVAL,
                _ => SampleFlags::empty(),
            };
            assert_eq!(g.flags, expected, "{kind:?} record {i}");
            if matches!(i, NAN_AT | STALE_AT | CLIP_AT) {
                continue;
            }
            let (hal_adapters::Motion::Rates { omega_ib_b, f_ib_b }, Some((w_omega, w_f))) =
                (g.motion, rates_of(w))
            else {
                panic!("rates expected");
            };
            for axis in 0..3 {
                let (dg, da) = (
                    (omega_ib_b[axis] - w_omega[axis]).abs(),
                    (f_ib_b[axis] - w_f[axis]).abs(),
                );
                assert!(dg <= 0.5 * g_lsb + 1e-6, "{kind:?} {i} omega[{axis}] {dg}");
                assert!(da <= 0.5 * a_lsb + 1e-5, "{kind:?} {i} f[{axis}] {da}");
            }
            assert!(
                (g.temperature_c - w.temperature_c).abs() <= 0.0625 + 1e-4,
                "record {i}"
            );
        }
        let h = sim.driver().health();
        assert_eq!((h.stale, h.missed), (2, 2 + 1 + 11));
        assert_eq!(h.gyro_clips, [0, 0, 1]);
        assert_eq!(device.samples_served(), N as u32);
    }
}

/// A recording sample as rates [rad/s], [m/s^2].
fn rates_of(s: &ImuSample) -> Option<([f32; 3], [f32; 3])> {
    match s.motion {
        hal_adapters::Motion::Rates { omega_ib_b, f_ib_b } => Some((omega_ib_b, f_ib_b)),
        hal_adapters::Motion::Increments {
            delta_theta_ib_b,
            delta_v_ib_b,
        } => (s.dt_s > 0.0).then(|| {
            (
                delta_theta_ib_b.map(|d| d / s.dt_s),
                delta_v_ib_b.map(|d| d / s.dt_s),
            )
        }),
    }
}

/// The simulated accelerometer answers in I2C mode (0xFF) until a chip-select edge, then with
/// a dummy byte before each read.
#[test]
fn bmi088_sim_accelerometer_needs_the_switch_to_spi() {
    use embedded_hal::spi::{Operation, SpiDevice};
    use hal_adapters::sim::SimBmi088;

    let bytes = recording(Kind::Increments, &records(Kind::Increments)[..2]);
    let device = SimBmi088::new(replay(&bytes));
    let mut accel = device.accel();
    let mut read_id = || {
        let mut buf = [0u8; 2];
        accel
            .transaction(&mut [Operation::Write(&[0x80]), Operation::Read(&mut buf)])
            .unwrap();
        buf[1]
    };
    assert_eq!(read_id(), 0xFF);
    assert_eq!(read_id(), 0x1E);
    // No data before both sensors are switched on.
    let mut gyro = device.gyro();
    let mut rate = [0u8; 6];
    gyro.transaction(&mut [Operation::Write(&[0x82]), Operation::Read(&mut rate)])
        .unwrap();
    assert_eq!(device.samples_served(), 0);
}

/// A source is served by a simulated device only at the devices' 400 Hz (within 1 %): each
/// data read takes the next sample, so a 100 Hz recording reached the driver as gaps of four
/// output periods.
#[test]
fn a_source_at_another_rate_than_the_devices_is_refused() {
    use hal_adapters::sim::{DEVICE_RATE_HZ, check_source_rate};
    assert_eq!(PERIOD_NS as f64, 1e9 / DEVICE_RATE_HZ);
    for ok in [400.0, 396.5, 403.5] {
        assert!(check_source_rate(ok).is_ok(), "{ok}");
    }
    for bad in [
        100.0,
        200.0,
        395.0,
        405.0,
        800.0,
        0.0,
        -400.0,
        f64::NAN,
        f64::INFINITY,
    ] {
        let e = check_source_rate(bad).unwrap_err();
        assert!(
            e.to_string()
                .contains("is not the simulated IMU's output rate of 400 Hz"),
            "{bad}: {e}"
        );
    }
}

/// One record of a still increment recording whose time tag steps back two periods (its
/// increment the true one period's), the next record's on time: through each simulated device
/// and its driver, the record shows as a repeated sample (`STALE`), and the next sample spans
/// both records' time with both increments. Before, the stale record's increment was dropped
/// while the next sample's interval covered its time: the vertical velocity lost `g` times 5 ms
/// and a still base's alignment was refused as "base not still". Over the whole recording the
/// increments and the time a navigator takes add up to those of the same recording on time,
/// through the same device, within a register count.
#[test]
fn a_time_tag_stepping_back_loses_no_increment_on_any_device() {
    use hal_adapters::drivers::bmi088::{self, AccelRange, GyroRange};
    use hal_adapters::sim::SimBmi088;
    const BACK_AT: usize = 100;
    let f = [0.02, -0.03, -9.80665];
    let omega = [1e-4, -2e-4, 5e-5];
    let recording_with = |back: bool| {
        let records: Vec<Record> = (0..N)
            .map(|i| {
                let on_time = T0_NS + (i as u64 + 1) * PERIOD_NS;
                Record {
                    t_ns: if back && i == BACK_AT {
                        on_time - 3 * PERIOD_NS
                    } else {
                        on_time
                    },
                    gyro: omega.map(|w| w * T_S),
                    accel: f.map(|a| a * T_S),
                    temperature_c: 25.0,
                }
            })
            .collect();
        recording(Kind::Increments, &records)
    };
    let (back, on_time) = (recording_with(true), recording_with(false));
    // What a navigator takes (every sample but a repeated one): increments and time summed.
    let sums = |got: &[ImuSample]| {
        let (mut dtheta, mut dv, mut t) = ([0.0f64; 3], [0.0f64; 3], 0.0f64);
        for s in got.iter().filter(|s| !s.flags.contains(SampleFlags::STALE)) {
            let (g, a) = s.increments();
            for k in 0..3 {
                dtheta[k] += f64::from(g[k]);
                dv[k] += f64::from(a[k]);
            }
            t += f64::from(s.dt_s);
        }
        (dtheta, dv, t)
    };
    // `samples` reads a recording's bytes through a device and its driver.
    let check = |name: &str, samples: &dyn Fn(&[u8]) -> Vec<ImuSample>, count: [f32; 2]| {
        let got = samples(&back);
        let stale: Vec<usize> = (0..got.len())
            .filter(|&i| got[i].flags.contains(SampleFlags::STALE))
            .collect();
        assert_eq!(stale, [BACK_AT], "{name}");
        let after = &got[BACK_AT + 1];
        assert!((after.dt_s - 2.0 * T_S).abs() < 1e-6, "{name}: {after:?}");
        let (g, a, t) = sums(&got);
        let (g0, a0, t0) = sums(&samples(&on_time));
        assert!((t - t0).abs() < 1e-6, "{name}: time {t} vs {t0}");
        for k in 0..3 {
            // A register count over the two records' 5 ms, and rounding.
            let [g_tol, a_tol] = count.map(|c| f64::from(c) * 2.0 * f64::from(T_S) + 1e-9);
            assert!(
                (a[k] - a0[k]).abs() <= a_tol,
                "{name}: dv[{k}] {} vs {}",
                a[k],
                a0[k]
            );
            assert!(
                (g[k] - g0[k]).abs() <= g_tol,
                "{name}: dtheta[{k}] {} vs {}",
                g[k],
                g0[k]
            );
        }
    };
    let model = Model::Adis16505(Range::Dps500);
    let adis = |bytes: &[u8]| {
        all(&mut SimulatedImu::adis16505(replay(bytes), adis16505::Config::new(model)).unwrap())
    };
    // Delta outputs, as rates per count: 720 deg / 2^31 and 100 m/s / 2^31 per period.
    let per_s = |lsb: f32| lsb / T_S;
    check(
        "ADIS16505",
        &adis,
        [
            per_s(720.0 * DEG / 2f32.powi(31)),
            per_s(100.0 / 2f32.powi(31)),
        ],
    );
    let icm = |bytes: &[u8]| {
        all(&mut SimulatedImu::icm42688(replay(bytes), icm42688::Config::default()).unwrap())
    };
    // 20-bit FIFO data: 2000 deg/s and 16 g over 2^19 counts.
    check(
        "ICM-42688-P",
        &icm,
        [2000.0 * DEG / 524_288.0, 16.0 * 9.80665 / 524_288.0],
    );
    let config = bmi088::Config {
        gyro_range: GyroRange::Dps500,
        accel_range: AccelRange::G3,
        mounting: Mounting::IDENTITY,
    };
    let bmi = |bytes: &[u8]| {
        let device = SimBmi088::new(replay(bytes));
        all(&mut SimulatedImu::bmi088(&device, config).unwrap())
    };
    check(
        "BMI088",
        &bmi,
        [500.0 * DEG / 32768.0, 3.0 * 9.80665 / 32768.0],
    );
}
