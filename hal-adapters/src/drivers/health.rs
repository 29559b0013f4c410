//! Health counters shared by the SPI IMU drivers.

/// Counters of a driver since it was created (all saturate at `u32::MAX`).
///
/// Clip counts are per *sensor* axis (before the mounting rotation), in samples.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Samples delivered (flagged or not).
    pub samples: u32,
    /// Samples flagged [`crate::SampleFlags::STALE`] (the device repeated its data).
    pub stale: u32,
    /// Device samples missed between deliveries: output samples for the ADIS16505 (from
    /// `DATA_CNTR`), 2 kHz FIFO packets for the ICM-42688-P (from the FIFO timestamps).
    pub missed: u32,
    /// Frames rejected by the integrity checks: bad checksum, all-zero frame, bad FIFO header.
    pub checksum_errors: u32,
    /// SPI operations that failed.
    pub bus_errors: u32,
    /// Samples flagged [`crate::SampleFlags::DEVICE_FAULT`] (device diagnostics set).
    pub device_faults: u32,
    /// FIFO overflows (each loses an unknown number of samples).
    pub fifo_overflows: u32,
    /// Samples flagged [`crate::SampleFlags::NON_FINITE`] because the device marked data invalid.
    pub invalid: u32,
    /// Samples with a gyro axis at or beyond its measurement range, per sensor axis x, y, z.
    pub gyro_clips: [u32; 3],
    /// Samples with an accelerometer axis at or beyond its measurement range, per sensor axis.
    pub accel_clips: [u32; 3],
}

impl core::fmt::Display for Health {
    /// The counters as the firmware and the host harness print them: `samples N, checksum
    /// errors N, stale N, device missed N, bus errors N, faults N, FIFO overflows N, invalid N,
    /// gyro clips [x, y, z], accel clips [x, y, z]`.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "samples {}, checksum errors {}, stale {}, device missed {}, bus errors {}, faults {}, \
             FIFO overflows {}, invalid {}, gyro clips {:?}, accel clips {:?}",
            self.samples,
            self.checksum_errors,
            self.stale,
            self.missed,
            self.bus_errors,
            self.device_faults,
            self.fifo_overflows,
            self.invalid,
            self.gyro_clips,
            self.accel_clips
        )
    }
}

impl Health {
    /// Adds the per-axis clip masks (bit `i` = sensor axis `i`).
    pub(crate) fn count_clips(&mut self, gyro_mask: u8, accel_mask: u8) {
        for axis in 0..3 {
            if gyro_mask & (1 << axis) != 0 {
                inc(&mut self.gyro_clips[axis]);
            }
            if accel_mask & (1 << axis) != 0 {
                inc(&mut self.accel_clips[axis]);
            }
        }
    }
}

/// Bit `i` set where `|raw[i]| >= full_scale` (a clipped axis).
#[inline]
pub(crate) fn clip_mask(raw: &[i32; 3], full_scale: i32) -> u8 {
    let mut mask = 0;
    for (axis, r) in raw.iter().enumerate() {
        if r.unsigned_abs() >= full_scale.unsigned_abs() {
            mask |= 1 << axis;
        }
    }
    mask
}

/// `*counter += 1`, saturating.
#[inline]
pub(crate) fn inc(counter: &mut u32) {
    *counter = counter.saturating_add(1);
}

/// `*counter += n`, saturating.
#[inline]
pub(crate) fn add(counter: &mut u32, n: u32) {
    *counter = counter.saturating_add(n);
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use std::format;

    #[test]
    fn display_names_every_counter_in_order() {
        let h = Health {
            samples: 1,
            checksum_errors: 2,
            stale: 3,
            missed: 4,
            bus_errors: 5,
            device_faults: 6,
            fifo_overflows: 7,
            invalid: 8,
            gyro_clips: [9, 10, 11],
            accel_clips: [12, 13, 14],
        };
        assert_eq!(
            format!("{h}"),
            "samples 1, checksum errors 2, stale 3, device missed 4, bus errors 5, faults 6, \
             FIFO overflows 7, invalid 8, gyro clips [9, 10, 11], accel clips [12, 13, 14]"
        );
    }
}
