//! Integrating quantiser of an increment output (a delta-angle / delta-velocity register).
//!
//! A real sensor accumulates the increment internally at high resolution and outputs it rounded
//! to its LSB; what is not output stays in the accumulator. Hence each output is
//! `round((x_k + r_{k-1}) / lsb) lsb` and the remainder `r_k = x_k + r_{k-1} - output_k` is
//! carried: the sum of the outputs differs from the sum of the inputs by `-r_n`,
//! `|r_n| <= lsb / 2`.

/// The accumulator of one axis.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct IntegratingQuantizer {
    /// Remainder not yet output [same unit as the input].
    pub remainder: f64,
}

impl IntegratingQuantizer {
    /// Outputs `x` quantised to `lsb` and carries the rounding remainder. `lsb == 0` passes `x`
    /// through. A non-finite sum is passed through and the remainder reset to 0, so one bad value
    /// does not poison the following samples.
    pub fn quantize(&mut self, x: f64, lsb: f64) -> f64 {
        if lsb <= 0.0 {
            return x;
        }
        let total = x + self.remainder;
        let out = (total / lsb).round() * lsb;
        if !out.is_finite() || !total.is_finite() {
            self.remainder = 0.0;
            return total;
        }
        self.remainder = total - out;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn running_sum_stays_within_one_lsb() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let lsb = 1e-3;
        let mut q = IntegratingQuantizer::default();
        let (mut sum_in, mut sum_out) = (0.0, 0.0);
        for _ in 0..100_000 {
            let x: f64 = rng.random_range(-0.0123..0.0456);
            let y = q.quantize(x, lsb);
            // Each output is a whole number of LSBs.
            assert!(((y / lsb).round() - y / lsb).abs() < 1e-6);
            sum_in += x;
            sum_out += y;
            assert!((sum_out - sum_in).abs() <= lsb, "{sum_out} vs {sum_in}");
        }
    }

    #[test]
    fn sub_lsb_inputs_come_out_eventually() {
        // 0.3 LSB per sample: single outputs are 0 or 1 LSB, and after 10 samples exactly 3 LSB.
        let mut q = IntegratingQuantizer::default();
        let total: f64 = (0..10).map(|_| q.quantize(0.3, 1.0)).sum();
        assert_eq!(total, 3.0);
        assert!((q.remainder - 0.0).abs() < 1e-12);
    }

    #[test]
    fn non_finite_passes_and_resets() {
        let mut q = IntegratingQuantizer { remainder: 0.25 };
        assert!(q.quantize(f64::INFINITY, 1.0).is_infinite());
        assert_eq!(q.remainder, 0.0);
        assert!(q.quantize(f64::NAN, 1.0).is_nan());
        assert_eq!(q.quantize(2.2, 1.0), 2.0);
        assert_eq!(q.quantize(2.0, 0.0), 2.0);
    }
}
