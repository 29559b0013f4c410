//! Property: no byte pattern from the bus makes a driver or decoder panic, or deliver a NaN or
//! infinite value.

use embedded_hal::spi::{ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::delay::NoopDelay;
use hal_adapters::ImuSample;
use hal_adapters::drivers::adis16505::{self, Adis16505, Model, Range, checksum, decode_burst};
use hal_adapters::drivers::bmi088::{
    self, AccelRange, Bmi088, GyroRange, decode_accel, decode_gyro, temperature_c,
};
use hal_adapters::drivers::icm42688::{self, Icm42688, decode_packet, raw20};
use proptest::prelude::*;

/// Answers every read with the next bytes of `bytes` (cycled); never fails.
struct NoiseSpi {
    bytes: Vec<u8>,
    pos: usize,
}

impl NoiseSpi {
    fn new(mut bytes: Vec<u8>) -> Self {
        if bytes.is_empty() {
            bytes.push(0);
        }
        NoiseSpi { bytes, pos: 0 }
    }

    fn next(&mut self) -> u8 {
        let b = self.bytes[self.pos % self.bytes.len()];
        self.pos += 1;
        b
    }
}

impl ErrorType for NoiseSpi {
    type Error = core::convert::Infallible;
}

impl SpiDevice for NoiseSpi {
    fn transaction(&mut self, ops: &mut [Operation<'_, u8>]) -> Result<(), Self::Error> {
        for op in ops {
            if let Operation::Read(miso)
            | Operation::TransferInPlace(miso)
            | Operation::Transfer(miso, _) = op
            {
                miso.fill_with(|| self.next());
            }
        }
        Ok(())
    }
}

fn check(sample: &ImuSample) {
    // Rates times a finite dt_s: finite exactly when the rates are.
    let (a, b) = sample.increments();
    assert!(
        a.iter().chain(b.iter()).all(|v| v.is_finite()),
        "{sample:?}"
    );
    assert!(sample.dt_s.is_finite() && sample.dt_s >= 0.0, "{sample:?}");
    // Temperature: finite, or NaN for "unknown" (never infinite).
    assert!(!sample.temperature_c.is_infinite(), "{sample:?}");
}

fn adis_configs() -> impl Strategy<Value = adis16505::Config> {
    let ranges = prop_oneof![
        Just(Range::Dps125),
        Just(Range::Dps500),
        Just(Range::Dps2000)
    ];
    (ranges, any::<bool>(), any::<bool>(), any::<bool>()).prop_map(|(r, adis05, inc, wide)| {
        let model = if adis05 {
            Model::Adis16505(r)
        } else {
            Model::Adis16465(r)
        };
        let output = if inc {
            adis16505::Output::Increments
        } else {
            adis16505::Output::Rates
        };
        adis16505::Config::new(model)
            .with_output(output)
            .with_burst32(wide)
    })
}

fn bmi088_configs() -> impl Strategy<Value = bmi088::Config> {
    (0u8..8, 0u8..4).prop_map(|(g, a)| bmi088::Config {
        gyro_range: GyroRange::from_code(g),
        accel_range: AccelRange::from_code(a),
        ..Default::default()
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn bmi088_driver_survives_any_bytes(
        config in bmi088_configs(),
        gyro in proptest::collection::vec(any::<u8>(), 0..200),
        accel in proptest::collection::vec(any::<u8>(), 0..400),
    ) {
        let mut imu = Bmi088::new(NoiseSpi::new(gyro), NoiseSpi::new(accel), config);
        let _ = imu.init(&mut NoopDelay::new());
        for t in 0..16 {
            match imu.read_sample(t) {
                Ok(s) => check(&s),
                Err(e) => prop_assert!(e.is_transient(), "{e}"),
            }
        }
    }

    #[test]
    fn bmi088_decoders_are_total_and_finite(
        gyro in proptest::array::uniform6(any::<u8>()),
        accel in proptest::collection::vec(any::<u8>(), 18),
    ) {
        let mut frame = [0u8; 18];
        frame.copy_from_slice(&accel);
        let a = decode_accel(&frame);
        prop_assert!(a.sensortime <= 0xFF_FFFF);
        prop_assert!((-1024..=1023).contains(&a.temp));
        let t = temperature_c(a.temp);
        prop_assert!(t.is_finite() || a.temp == -1024);
        for v in decode_gyro(&gyro).into_iter().chain(a.accel) {
            prop_assert!((-32768..=32767).contains(&v));
        }
    }

    #[test]
    fn adis_driver_survives_any_bytes(
        config in adis_configs(),
        bytes in proptest::collection::vec(any::<u8>(), 0..400),
    ) {
        let mut imu = Adis16505::new(NoiseSpi::new(bytes), config);
        let _ = imu.init(&mut NoopDelay::new());
        for t in 0..16 {
            if let Ok(s) = imu.read_sample(t) {
                check(&s);
            }
        }
    }

    #[test]
    fn adis_conversion_of_any_valid_frame_is_finite(
        config in adis_configs(),
        frames in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 30), 1..8),
    ) {
        // Random contents with a correct checksum: every frame reaches the conversion.
        let n = config.frame_len();
        let mut stream = Vec::new();
        for mut f in frames {
            f.truncate(n - 2);
            let sum = checksum(&f);
            f.extend_from_slice(&sum.to_be_bytes());
            stream.extend(f);
        }
        let count = stream.len() / n;
        let mut imu = Adis16505::new(NoiseSpi::new(stream), config);
        for t in 0..count as u64 {
            match imu.read_sample(t) {
                Ok(s) => check(&s),
                Err(e) => prop_assert!(e.is_transient(), "{e}"),
            }
        }
    }

    #[test]
    fn icm_driver_survives_any_bytes(
        bytes in proptest::collection::vec(any::<u8>(), 0..600),
        status in proptest::collection::vec(any::<u8>(), 3),
    ) {
        // Half the runs start each read with a plausible status (count of 100 bytes).
        let mut bytes = bytes;
        if status[0] & 1 == 0 {
            let mut framed = vec![0x04, 0x00, 100];
            framed.extend(bytes);
            bytes = framed;
        }
        let mut imu = Icm42688::new(NoiseSpi::new(bytes), icm42688::Config::default());
        let _ = imu.init(&mut NoopDelay::new());
        for t in 0..16 {
            if let Ok(s) = imu.read_sample(t) {
                check(&s);
            }
        }
    }

    #[test]
    fn icm_packets_with_valid_headers_convert_finitely(
        packets in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 20), 5..=10),
    ) {
        let mut stream = Vec::new();
        for chunk in packets.chunks(5).filter(|c| c.len() == 5) {
            stream.extend([0x00, 0x00, 100]);
            for p in chunk {
                let mut p = p.clone();
                p[0] = 0x78 | (p[0] & 0x03);
                stream.extend(p);
            }
        }
        let reads = stream.len() / 103;
        let mut imu = Icm42688::new(NoiseSpi::new(stream), icm42688::Config::default());
        for t in 0..reads as u64 {
            let s = imu.read_sample(t).unwrap();
            check(&s);
        }
    }

    #[test]
    fn decoders_never_panic(frame in proptest::collection::vec(any::<u8>(), 0..40)) {
        let _ = decode_burst(&frame);
        if frame.len() >= 20 {
            let mut p = [0u8; 20];
            p.copy_from_slice(&frame[..20]);
            let _ = decode_packet(&p);
            let v = raw20(p[0], p[1], p[2]);
            prop_assert!((-524_288..=524_287).contains(&v));
        }
    }
}
