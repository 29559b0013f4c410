//! Kahan-compensated running sums (Higham, *Accuracy and Stability of Numerical Algorithms*,
//! §4.3): minutes of 400 Hz `f32` increments sum without losing their small components.

use crate::Scalar;
use nalgebra::Vector3;

/// Kahan-compensated running sum.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Kahan<T: Scalar> {
    pub(crate) sum: T,
    carry: T,
}

impl<T: Scalar> Kahan<T> {
    pub(crate) fn new() -> Self {
        Self {
            sum: T::zero(),
            carry: T::zero(),
        }
    }

    #[inline]
    pub(crate) fn add(&mut self, x: T) {
        let y = x - self.carry;
        let t = self.sum + y;
        self.carry = (t - self.sum) - y;
        self.sum = t;
    }
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct Kahan3<T: Scalar>([Kahan<T>; 3]);

impl<T: Scalar> Kahan3<T> {
    pub(crate) fn new() -> Self {
        Self([Kahan::new(); 3])
    }

    #[inline]
    pub(crate) fn add(&mut self, v: &Vector3<T>) {
        for (k, x) in self.0.iter_mut().zip(v.iter()) {
            k.add(*x);
        }
    }

    pub(crate) fn sum(&self) -> Vector3<T> {
        Vector3::new(self.0[0].sum, self.0[1].sum, self.0[2].sum)
    }
}
