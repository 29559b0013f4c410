//! Bus failures, through a hand-written failing `SpiDevice` (the mock cannot inject errors).

use embedded_hal::spi::{ErrorKind, ErrorType, Operation, SpiDevice};
use embedded_hal_mock::eh1::delay::NoopDelay;
use hal_adapters::drivers::Error;
use hal_adapters::drivers::adis16505::{Adis16505, Config, Model, Range};
use hal_adapters::drivers::bmi088::{self, Bmi088};
use hal_adapters::drivers::icm42688::{self, Icm42688};

/// Answers with zeros for `ok` transactions, then fails every one.
struct FailingSpi {
    ok: usize,
    transactions: usize,
}

impl FailingSpi {
    fn failing_after(ok: usize) -> Self {
        FailingSpi {
            ok,
            transactions: 0,
        }
    }
}

impl ErrorType for FailingSpi {
    type Error = ErrorKind;
}

impl SpiDevice for FailingSpi {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), ErrorKind> {
        self.transactions += 1;
        if self.transactions > self.ok {
            return Err(ErrorKind::ChipSelectFault);
        }
        for op in operations {
            match op {
                Operation::Read(buf) | Operation::TransferInPlace(buf) => buf.fill(0),
                Operation::Transfer(read, _) => read.fill(0),
                Operation::Write(_) | Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}

#[test]
fn adis_bus_errors_are_reported_and_counted() {
    let config = Config::new(Model::Adis16505(Range::Dps500));
    let mut imu = Adis16505::new(FailingSpi::failing_after(0), config);
    let err = imu.init(&mut NoopDelay::new()).unwrap_err();
    assert_eq!(err, Error::Spi(ErrorKind::ChipSelectFault));
    assert!(!err.is_transient());
    assert!(err.to_string().contains("SPI"), "{err}");
    assert_eq!(
        imu.read_sample(0),
        Err(Error::Spi(ErrorKind::ChipSelectFault))
    );
    assert_eq!(imu.health().bus_errors, 2);
    assert_eq!(imu.health().samples, 0);

    // Failing in the middle of the init sequence (after the reset word and the PROD_ID
    // request).
    let mut imu = Adis16505::new(FailingSpi::failing_after(2), config);
    assert!(matches!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::Spi(_))
    ));
    assert_eq!(imu.health().bus_errors, 1);
}

#[test]
fn icm_bus_errors_are_reported_and_counted() {
    let mut imu = Icm42688::new(FailingSpi::failing_after(0), icm42688::Config::default());
    assert_eq!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::Spi(ErrorKind::ChipSelectFault))
    );
    assert_eq!(
        imu.read_sample(0),
        Err(Error::Spi(ErrorKind::ChipSelectFault))
    );
    assert_eq!(imu.health().bus_errors, 2);

    // WHO_AM_I reads 0 from a bus that answers with zeros: a wrong ID, not a bus error.
    let mut imu = Icm42688::new(FailingSpi::failing_after(10), icm42688::Config::default());
    assert!(matches!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::WrongId { found: 0, .. })
    ));
}

#[test]
fn bmi088_bus_errors_on_either_chip_select() {
    // The gyro fails at once.
    let mut imu = Bmi088::new(
        FailingSpi::failing_after(0),
        FailingSpi::failing_after(100),
        bmi088::Config::default(),
    );
    assert_eq!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::Spi(ErrorKind::ChipSelectFault))
    );
    assert_eq!(
        imu.read_sample(0),
        Err(Error::Spi(ErrorKind::ChipSelectFault))
    );
    assert_eq!(imu.health().bus_errors, 2);

    // A gyro answering zeros is a wrong ID, not a bus error; then the data read fails on the
    // accelerometer's chip select after the gyro's succeeded.
    let mut imu = Bmi088::new(
        FailingSpi::failing_after(100),
        FailingSpi::failing_after(0),
        bmi088::Config::default(),
    );
    assert_eq!(
        imu.init(&mut NoopDelay::new()),
        Err(Error::WrongId {
            expected: 0x0F,
            found: 0
        })
    );
    assert_eq!(
        imu.read_sample(0),
        Err(Error::Spi(ErrorKind::ChipSelectFault))
    );
    assert_eq!(imu.health().bus_errors, 1);
    assert_eq!(imu.health().samples, 0);
}

#[test]
fn errors_implement_core_error() {
    fn is_error<E: core::error::Error>(_: &E) {}
    let e: Error<ErrorKind> = Error::FifoOverflow;
    is_error(&e);
}
