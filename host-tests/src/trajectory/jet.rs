//! Scalar functions of time with their first three derivatives ("jets"), so that a trajectory
//! written as smooth analytic profiles yields exact rates and accelerations without numerical
//! differentiation: a lever arm's acceleration is the second derivative of `C_b_n(t) R`, a
//! flight-path angle's rate is the derivative of `atan2(climb, speed)`.
//!
//! Arithmetic follows the Leibniz and Faà di Bruno rules up to the third derivative.

use core::ops::{Add, Mul, Neg, Sub};

/// `f(t)` and `f'(t)`, `f''(t)`, `f'''(t)` at one instant.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Jet {
    /// Value.
    pub v: f64,
    /// First derivative [1/s].
    pub d1: f64,
    /// Second derivative [1/s^2].
    pub d2: f64,
    /// Third derivative [1/s^3].
    pub d3: f64,
}

impl Jet {
    /// A constant.
    pub const fn constant(v: f64) -> Self {
        Self {
            v,
            d1: 0.0,
            d2: 0.0,
            d3: 0.0,
        }
    }

    /// The time itself at `t`.
    pub const fn time(t: f64) -> Self {
        Self {
            v: t,
            d1: 1.0,
            d2: 0.0,
            d3: 0.0,
        }
    }

    /// The derivative as a jet (its third derivative unknown, set to 0: use only `v`, `d1`,
    /// `d2` of the result).
    pub const fn derivative(self) -> Self {
        Self {
            v: self.d1,
            d1: self.d2,
            d2: self.d3,
            d3: 0.0,
        }
    }

    /// `g(f(t))` given `g, g', g'', g'''` at `f(t)` (Faà di Bruno).
    pub fn compose(self, g: [f64; 4]) -> Self {
        let (a, b, c) = (self.d1, self.d2, self.d3);
        Self {
            v: g[0],
            d1: g[1] * a,
            d2: g[2] * a * a + g[1] * b,
            d3: g[3] * a * a * a + 3.0 * g[2] * a * b + g[1] * c,
        }
    }

    /// `sin(f)`.
    pub fn sin(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.compose([s, c, -s, -c])
    }

    /// `cos(f)`.
    pub fn cos(self) -> Self {
        let (s, c) = self.v.sin_cos();
        self.compose([c, -s, -c, s])
    }

    /// `1 / f` (for `f != 0`).
    pub fn recip(self) -> Self {
        let r = 1.0 / self.v;
        self.compose([r, -r * r, 2.0 * r * r * r, -6.0 * r * r * r * r])
    }

    /// `atan(f)`.
    pub fn atan(self) -> Self {
        let x = self.v;
        let q = 1.0 / (1.0 + x * x);
        // d/dx atan = q, q' = -2x q^2, q'' = (6x^2 - 2) q^3.
        self.compose([
            x.atan(),
            q,
            -2.0 * x * q * q,
            (6.0 * x * x - 2.0) * q * q * q,
        ])
    }

    /// `atan2(self, x)` for `x > 0`, i.e. `atan(self / x)`.
    pub fn atan2_pos(self, x: Jet) -> Self {
        (self * x.recip()).atan()
    }
}

impl Add for Jet {
    type Output = Jet;
    fn add(self, o: Jet) -> Jet {
        Jet {
            v: self.v + o.v,
            d1: self.d1 + o.d1,
            d2: self.d2 + o.d2,
            d3: self.d3 + o.d3,
        }
    }
}

impl Sub for Jet {
    type Output = Jet;
    fn sub(self, o: Jet) -> Jet {
        self + (-o)
    }
}

impl Neg for Jet {
    type Output = Jet;
    fn neg(self) -> Jet {
        Jet {
            v: -self.v,
            d1: -self.d1,
            d2: -self.d2,
            d3: -self.d3,
        }
    }
}

impl Mul for Jet {
    type Output = Jet;
    /// Leibniz: `(fg)''' = f'''g + 3f''g' + 3f'g'' + fg'''`.
    fn mul(self, o: Jet) -> Jet {
        Jet {
            v: self.v * o.v,
            d1: self.d1 * o.v + self.v * o.d1,
            d2: self.d2 * o.v + 2.0 * self.d1 * o.d1 + self.v * o.d2,
            d3: self.d3 * o.v + 3.0 * self.d2 * o.d1 + 3.0 * self.d1 * o.d2 + self.v * o.d3,
        }
    }
}

impl Mul<f64> for Jet {
    type Output = Jet;
    fn mul(self, k: f64) -> Jet {
        Jet {
            v: self.v * k,
            d1: self.d1 * k,
            d2: self.d2 * k,
            d3: self.d3 * k,
        }
    }
}

/// A quintic smooth step from 0 to 1 over `[0, 1]`, `s(u) = 10u^3 - 15u^4 + 6u^5`, flat to the
/// second derivative at both ends (so accelerations are continuous), as a jet of `u`.
pub fn smoothstep(u: Jet) -> Jet {
    if u.v <= 0.0 {
        return Jet::constant(0.0);
    }
    if u.v >= 1.0 {
        return Jet::constant(1.0);
    }
    let x = u.v;
    let x2 = x * x;
    u.compose([
        x2 * x * (10.0 - 15.0 * x + 6.0 * x2),
        30.0 * x2 * (1.0 - x) * (1.0 - x),
        60.0 * x * (1.0 - x) * (1.0 - 2.0 * x),
        60.0 * (1.0 - 6.0 * x + 6.0 * x2),
    ])
}

/// One smooth change of a quantity from `from` to `to` during `[t0, t0 + duration]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ramp {
    /// Start [s].
    pub t0: f64,
    /// Duration [s] (> 0).
    pub duration: f64,
    /// Value before.
    pub from: f64,
    /// Value after.
    pub to: f64,
}

/// A piecewise-smooth profile: an initial value changed by successive [`Ramp`]s (each starts
/// from where the previous ended; gaps between ramps hold the value).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Profile {
    initial: f64,
    ramps: Vec<Ramp>,
}

impl Profile {
    /// A profile holding `initial`.
    pub fn new(initial: f64) -> Self {
        Self {
            initial,
            ramps: Vec::new(),
        }
    }

    /// Appends a ramp to `to` starting at `t0` [s] lasting `duration` [s]; returns its end.
    ///
    /// # Panics
    /// If the ramp starts before the previous one ends or `duration <= 0` (a programming error
    /// in a scenario definition).
    pub fn ramp(&mut self, t0: f64, duration: f64, to: f64) -> f64 {
        assert!(duration > 0.0, "ramp duration must be positive");
        assert!(
            t0 >= self.end_time(),
            "ramps must not overlap ({t0} < {})",
            self.end_time()
        );
        self.ramps.push(Ramp {
            t0,
            duration,
            from: self.final_value(),
            to,
        });
        t0 + duration
    }

    /// End of the last ramp [s] (0 without ramps).
    pub fn end_time(&self) -> f64 {
        self.ramps.last().map_or(0.0, |r| r.t0 + r.duration)
    }

    /// Value after the last ramp.
    pub fn final_value(&self) -> f64 {
        self.ramps.last().map_or(self.initial, |r| r.to)
    }

    /// The profile at `t` [s].
    pub fn at(&self, t: f64) -> Jet {
        let i = self.ramps.partition_point(|r| r.t0 <= t);
        if i == 0 {
            return Jet::constant(self.initial);
        }
        let r = &self.ramps[i - 1];
        let u = (Jet::time(t) - Jet::constant(r.t0)) * (1.0 / r.duration);
        Jet::constant(r.from) + smoothstep(u) * (r.to - r.from)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of `f` at `t` for the first three derivatives.
    fn numeric(f: impl Fn(f64) -> f64, t: f64) -> [f64; 3] {
        let h = 1e-3;
        [
            (f(t + h) - f(t - h)) / (2.0 * h),
            (f(t + h) - 2.0 * f(t) + f(t - h)) / (h * h),
            (f(t + 2.0 * h) - 2.0 * f(t + h) + 2.0 * f(t - h) - f(t - 2.0 * h)) / (2.0 * h * h * h),
        ]
    }

    fn check(j: impl Fn(f64) -> Jet, t: f64) {
        let n = numeric(|t| j(t).v, t);
        let a = j(t);
        for (k, (x, y)) in [a.d1, a.d2, a.d3].iter().zip(n).enumerate() {
            assert!(
                (x - y).abs() < 1e-4 * (1.0 + y.abs()),
                "d{}: {x} vs {y}",
                k + 1
            );
        }
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let f = |t: f64| {
            let x = Jet::time(t);
            (x * 0.7).sin() * (x * 0.3 + Jet::constant(1.0)).cos()
                + (x * x * 0.1).atan2_pos(x + Jet::constant(2.0))
        };
        for t in [0.1, 0.9, 2.3] {
            check(f, t);
        }
        let mut p = Profile::new(1.0);
        p.ramp(1.0, 2.0, 3.0);
        p.ramp(4.0, 1.0, -1.0);
        for t in [1.3, 2.0, 2.9, 4.5] {
            check(|t| p.at(t), t);
        }
        assert_eq!(p.at(0.5).v, 1.0);
        assert_eq!(p.at(3.5), Jet::constant(3.0));
        assert_eq!(p.at(9.0).v, -1.0);
        // The step's integral over its span is half the change (symmetric profile).
        let n = 10_000;
        let s: f64 = (0..n)
            .map(|k| smoothstep(Jet::constant((k as f64 + 0.5) / n as f64)).v)
            .sum::<f64>()
            / n as f64;
        assert!((s - 0.5).abs() < 1e-9);
    }
}
