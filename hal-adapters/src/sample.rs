//! The IMU sample type.

use bitflags::bitflags;
use nav_core::ins_filter::Clipped;
use nav_core::navigator::{ImuInput, Unusable};

/// The inertial measurement of one sample, body axes forward-right-down (FRD).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Motion {
    /// Integrated outputs over the interval (what good IMUs deliver).
    Increments {
        /// Angle increment, integral of `omega_ib_b` [rad].
        delta_theta_ib_b: [f32; 3],
        /// Velocity increment, integral of `f_ib_b` [m/s].
        delta_v_ib_b: [f32; 3],
    },
    /// Instantaneous outputs at the end of the interval (typical MEMS data registers).
    Rates {
        /// Angular rate `omega_ib_b` [rad/s].
        omega_ib_b: [f32; 3],
        /// Specific force `f_ib_b` [m/s^2].
        f_ib_b: [f32; 3],
    },
}

bitflags! {
    /// Per-sample data-quality flags. A flagged sample is still delivered; consumers decide
    /// (see [`SampleFlags::usable`]).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct SampleFlags: u16 {
        /// A gyro axis was at full scale (clipped).
        const GYRO_SATURATED = 1 << 0;
        /// An accelerometer axis was at full scale (clipped).
        const ACCEL_SATURATED = 1 << 1;
        /// The sensor repeated its previous data (stale counter).
        const STALE = 1 << 2;
        /// One or more samples were missed before this one (the interval is longer).
        const GAP = 1 << 3;
        /// A value is NaN or infinite.
        const NON_FINITE = 1 << 4;
        /// The interval `dt_s` is zero, negative, or implausibly long (time went backwards or
        /// jumped).
        const BAD_INTERVAL = 1 << 5;
        /// The sensor reported an internal fault for this sample.
        const DEVICE_FAULT = 1 << 6;
    }
}

impl SampleFlags {
    /// Flags that make a sample unusable for navigation.
    pub const UNUSABLE: Self = Self::STALE
        .union(Self::NON_FINITE)
        .union(Self::BAD_INTERVAL)
        .union(Self::DEVICE_FAULT);

    /// The [`Self::UNUSABLE`] flags in the order a sample's cause is reported.
    pub const CAUSES: [Self; 4] = [
        Self::NON_FINITE,
        Self::BAD_INTERVAL,
        Self::STALE,
        Self::DEVICE_FAULT,
    ];

    /// `true` when the sample may be fed to the navigation core.
    pub fn usable(self) -> bool {
        !self.intersects(Self::UNUSABLE)
    }

    /// Why the sample is not usable: the first of [`Self::CAUSES`] it has (`None`: usable).
    /// Consumers count flagged samples by this cause, one cause per sample.
    pub fn unusable_cause(self) -> Option<Self> {
        if self.usable() {
            return None;
        }
        let cause = Self::CAUSES.into_iter().find(|&flag| self.contains(flag));
        Some(cause.unwrap_or(self.intersection(Self::UNUSABLE)))
    }
}

/// Logs the raw bits, e.g. `SampleFlags(0x0028)` for `GAP | BAD_INTERVAL`.
#[cfg(feature = "defmt")]
impl defmt::Format for SampleFlags {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "SampleFlags({=u16:#06x})", self.bits());
    }
}

/// One IMU sample, as every source (driver or replay) produces it.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ImuSample {
    /// Time at the end of the interval (data-ready) [us]: the board's monotonic clock for a
    /// driver, the recording's clock for a replay.
    pub t_us: u64,
    /// Sequence number, counting every sample the source produced (gaps show missed samples).
    pub seq: u32,
    /// Length of the interval the measurement covers [s].
    pub dt_s: f32,
    /// The measurement.
    pub motion: Motion,
    /// Sensor temperature [deg C]; NaN when unknown.
    pub temperature_c: f32,
    /// Data-quality flags.
    pub flags: SampleFlags,
}

/// An IMU's full scale, where its axes clip: the largest rate [rad/s] and specific force
/// [m/s^2] it reads. A driver knows its part's; a recording carries none, so its user gives it
/// (`nav replay --imu-range`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FullScale {
    /// Gyro full scale [rad/s].
    pub gyro_rad_s: f32,
    /// Accelerometer full scale [m/s^2].
    pub accel_mps2: f32,
}

impl FullScale {
    /// The share of the full scale from which a recorded reading is taken as clipped [-]: a
    /// clipped axis reads the full scale, in a recording to its last printed digits.
    pub const CLIPPED_FROM: f32 = 0.999;

    /// `sample` with [`SampleFlags::GYRO_SATURATED`] or [`SampleFlags::ACCEL_SATURATED`] set
    /// when an axis reads at (or beyond) this full scale, as a driver flags its part's clips.
    pub fn mark(&self, sample: ImuSample) -> ImuSample {
        let (omega_ib_b, f_ib_b) = match sample.motion {
            Motion::Rates { omega_ib_b, f_ib_b } => (omega_ib_b, f_ib_b),
            Motion::Increments {
                delta_theta_ib_b,
                delta_v_ib_b,
            } if sample.dt_s > 0.0 => (
                delta_theta_ib_b.map(|d| d / sample.dt_s),
                delta_v_ib_b.map(|d| d / sample.dt_s),
            ),
            // No interval, no rate (the sample is flagged for it).
            Motion::Increments { .. } => return sample,
        };
        let at = |v: [f32; 3], fs: f32| v.iter().any(|x| x.abs() >= fs * Self::CLIPPED_FROM);
        let mut flags = sample.flags;
        if at(omega_ib_b, self.gyro_rad_s) {
            flags |= SampleFlags::GYRO_SATURATED;
        }
        if at(f_ib_b, self.accel_mps2) {
            flags |= SampleFlags::ACCEL_SATURATED;
        }
        ImuSample { flags, ..sample }
    }
}

/// A source whose samples are marked clipped at a full scale ([`FullScale::mark`]; `None`:
/// passed on as they are).
pub struct ClipMarked<'a, I> {
    /// The source.
    pub source: &'a mut I,
    /// Where its axes clip.
    pub full_scale: Option<FullScale>,
}

impl<I: crate::Imu> crate::Imu for ClipMarked<'_, I> {
    type Error = I::Error;

    fn read_sample(&mut self) -> Result<Option<ImuSample>, Self::Error> {
        let sample = self.source.read_sample()?;
        Ok(match self.full_scale {
            Some(fs) => sample.map(|s| fs.mark(s)),
            None => sample,
        })
    }
}

/// Whether a velocity increment `delta_v` [m/s] read after an interval of `periods` nominal
/// periods (a gap) covers the whole interval, as an increment recording's records are defined
/// to (a sensor that accumulates between reads), rather than its last period alone (a logger
/// that dropped records: the increments of the lost records are gone, and integrated over the
/// whole interval the one left would lose gravity's balance, `g` times the time lost in the
/// vertical velocity). The specific force's increment grows with the time it covers, and from
/// one sample to the next its size changes far less than the factor `periods` (gravity
/// dominates it for any vehicle short of free fall), so the previous sample's `delta_v_prev`
/// (one period) decides, at the midpoint: covering when `|delta_v| >= (1 + periods) / 2 *
/// |delta_v_prev|`. Near free fall both are small, and for a non-finite increment (flagged as
/// such) nothing can be said: the record's definition (covering) stands.
// NaN-safe on purpose: a NaN norm must leave the definition standing.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
pub fn increment_spans_interval(delta_v: &[f32; 3], delta_v_prev: &[f32; 3], periods: f64) -> bool {
    let norm2 = |v: &[f32; 3]| v.iter().map(|x| f64::from(*x) * f64::from(*x)).sum::<f64>();
    let k = 0.5 * (1.0 + periods);
    !(norm2(delta_v) < k * k * norm2(delta_v_prev))
}

impl ImuSample {
    /// The sample with its motion turned by `r` (`v' = r v`, both vectors): from the axes of
    /// the driver's mounting to the run's ([`crate::drivers::Mounting::relative_to`]).
    pub fn remounted(&self, r: &crate::drivers::Mounting) -> ImuSample {
        let motion = match self.motion {
            Motion::Increments {
                delta_theta_ib_b,
                delta_v_ib_b,
            } => Motion::Increments {
                delta_theta_ib_b: r.to_body(delta_theta_ib_b),
                delta_v_ib_b: r.to_body(delta_v_ib_b),
            },
            Motion::Rates { omega_ib_b, f_ib_b } => Motion::Rates {
                omega_ib_b: r.to_body(omega_ib_b),
                f_ib_b: r.to_body(f_ib_b),
            },
        };
        ImuSample { motion, ..*self }
    }

    /// Angle [rad] and velocity [m/s] increments over the interval (rates are multiplied by
    /// `dt_s`).
    pub fn increments(&self) -> ([f32; 3], [f32; 3]) {
        match self.motion {
            Motion::Increments {
                delta_theta_ib_b,
                delta_v_ib_b,
            } => (delta_theta_ib_b, delta_v_ib_b),
            Motion::Rates { omega_ib_b, f_ib_b } => (
                omega_ib_b.map(|w| w * self.dt_s),
                f_ib_b.map(|f| f * self.dt_s),
            ),
        }
    }

    /// The navigator's input of this sample: its increments, and why it is not usable / that
    /// samples were lost before it, from its flags. The one conversion, for the firmware and
    /// the harness alike.
    pub fn nav_input(&self) -> ImuInput {
        let (delta_theta_ib_b, delta_v_ib_b) = self.increments();
        ImuInput::new(
            self.t_us,
            delta_theta_ib_b,
            delta_v_ib_b,
            self.dt_s,
            self.flags.unusable(),
            self.flags.contains(SampleFlags::GAP),
        )
        .with_clipped(self.flags.clipped())
    }
}

impl SampleFlags {
    /// The sensors these flags say were at full scale, in nav-core's terms.
    pub fn clipped(self) -> Clipped {
        Clipped {
            gyro: self.contains(Self::GYRO_SATURATED),
            accel: self.contains(Self::ACCEL_SATURATED),
        }
    }

    /// Why these flags make a sample unusable, in nav-core's terms ([`Self::unusable_cause`];
    /// `None`: usable).
    pub fn unusable(self) -> Option<Unusable> {
        let cause = self.unusable_cause()?;
        Some(if cause == Self::NON_FINITE {
            Unusable::NonFinite
        } else if cause == Self::BAD_INTERVAL {
            Unusable::BadInterval
        } else if cause == Self::STALE {
            Unusable::Stale
        } else if cause == Self::DEVICE_FAULT {
            Unusable::DeviceFault
        } else {
            Unusable::Other
        })
    }
}

#[cfg(test)]
mod tests {
    use super::{ImuSample, Motion, SampleFlags, increment_spans_interval};

    /// A recorded reading at the full scale (to 0.1 %) or beyond it is marked clipped, per
    /// sensor, from increments or rates; one below it, or a sample without an interval, is not.
    #[test]
    fn a_reading_at_the_full_scale_is_marked_clipped() {
        use super::FullScale;
        let fs = FullScale {
            gyro_rad_s: 500f32.to_radians(),
            accel_mps2: 80.0,
        };
        let dt = 0.0025;
        let sample = |w_deg_s: f32, f: f32, dt_s: f32| ImuSample {
            t_us: 1,
            seq: 0,
            dt_s,
            motion: Motion::Increments {
                delta_theta_ib_b: [0.0, w_deg_s.to_radians() * dt, 0.0],
                delta_v_ib_b: [0.0, 0.0, f * dt],
            },
            temperature_c: f32::NAN,
            flags: SampleFlags::empty(),
        };
        let marked = |s: ImuSample| fs.mark(s).flags;
        let gyro = SampleFlags::GYRO_SATURATED;
        let accel = SampleFlags::ACCEL_SATURATED;
        assert_eq!(marked(sample(499.6, -9.8, dt)), gyro);
        assert_eq!(marked(sample(-1000.0, -9.8, dt)), gyro);
        assert_eq!(marked(sample(499.0, -9.8, dt)), SampleFlags::empty());
        assert_eq!(marked(sample(10.0, -80.0, dt)), accel);
        assert_eq!(marked(sample(600.0, 81.0, dt)), gyro | accel);
        assert_eq!(marked(sample(600.0, 81.0, 0.0)), SampleFlags::empty());
        let rates = ImuSample {
            motion: Motion::Rates {
                omega_ib_b: [0.0, 0.0, -9.0],
                f_ib_b: [0.0, 0.0, -9.8],
            },
            ..sample(0.0, 0.0, dt)
        };
        assert_eq!(marked(rates), gyro);
    }

    /// One period's increment after a 3-period interval is short; three periods' covers it;
    /// in free fall, or for a NaN, the definition (covering) stands.
    #[test]
    fn an_increment_spans_its_interval_by_its_size() {
        let one = [0.0, 0.0, -0.049];
        assert!(!increment_spans_interval(&one, &one, 3.0));
        assert!(increment_spans_interval(&one.map(|x| 3.0 * x), &one, 3.0));
        // A braking car (0.3 g more for the sample) is still one period.
        assert!(!increment_spans_interval(&[0.015, 0.0, -0.049], &one, 2.0));
        assert!(increment_spans_interval(&[0.0; 3], &[0.0; 3], 3.0));
        assert!(increment_spans_interval(&[f32::NAN, 0.0, 0.0], &one, 3.0));
    }
    use crate::drivers::Mounting;

    /// Both kinds of motion are turned, both vectors; the rest of the sample is kept.
    #[test]
    fn remounting_turns_the_motion_only() {
        let r = Mounting::FLU_TO_FRD;
        let s = ImuSample {
            t_us: 7,
            seq: 3,
            dt_s: 0.0025,
            motion: Motion::Rates {
                omega_ib_b: [1.0, 2.0, 3.0],
                f_ib_b: [4.0, 5.0, 6.0],
            },
            temperature_c: 25.0,
            flags: SampleFlags::GAP,
        };
        let turned = s.remounted(&r);
        assert_eq!(
            turned.motion,
            Motion::Rates {
                omega_ib_b: [1.0, -2.0, -3.0],
                f_ib_b: [4.0, -5.0, -6.0],
            }
        );
        assert_eq!(
            (turned.t_us, turned.seq, turned.flags),
            (7, 3, SampleFlags::GAP)
        );
        let inc = ImuSample {
            motion: Motion::Increments {
                delta_theta_ib_b: [1.0, 2.0, 3.0],
                delta_v_ib_b: [4.0, 5.0, 6.0],
            },
            ..s
        };
        assert_eq!(
            inc.remounted(&r).increments(),
            ([1.0, -2.0, -3.0], [4.0, -5.0, -6.0])
        );
    }

    #[test]
    fn one_cause_per_unusable_sample() {
        let all = SampleFlags::CAUSES
            .into_iter()
            .fold(SampleFlags::empty(), SampleFlags::union);
        assert_eq!(all, SampleFlags::UNUSABLE);
        let f = SampleFlags::STALE | SampleFlags::NON_FINITE | SampleFlags::GAP;
        assert_eq!(f.unusable_cause(), Some(SampleFlags::NON_FINITE));
        assert_eq!(
            (SampleFlags::DEVICE_FAULT | SampleFlags::STALE).unusable_cause(),
            Some(SampleFlags::STALE)
        );
        assert_eq!(
            (SampleFlags::GAP | SampleFlags::GYRO_SATURATED).unusable_cause(),
            None
        );
    }
}
