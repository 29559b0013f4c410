//! Least-squares identification of a sway: one sinusoid on a line, its frequency searched
//! over a band (a grid of spacing `pi / (4 window)`, then a golden section around the best),
//! both at once ([`identify`]) and a few fits at a time ([`Search`], so that the firmware's
//! low-priority task is never held for long).

use nalgebra::{Matrix4, Vector4};

/// Most samples a search keeps.
pub const BUFFER_LEN: usize = 128;

/// Golden-section steps after the grid: they narrow the bracket of two grid spacings by
/// `0.618^40 = 4e-9` (about 1e-10 rad/s for a 25 s window, far below what the fit's noise
/// resolves).
pub const GOLDEN_STEPS: u32 = 40;

/// A least-squares fit `y = mean + trend (t - t0) + cos a(t) + sin b(t)` over `a(t) =
/// w (t - t0)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinusoidFit {
    /// Angular frequency [rad/s] (NaN if none could be fitted).
    pub omega: f64,
    /// Value of the mean line at `t0` [rad].
    pub mean: f64,
    /// Trend [rad/s].
    pub trend: f64,
    /// Cosine amplitude [rad] (the sinusoid's value at `t0`).
    pub cos: f64,
    /// Sine amplitude [rad] (its rate at `t0` over `w`).
    pub sin: f64,
    /// RMS of the residual [rad].
    pub residual_rms: f64,
    /// How much the sinusoid's columns inflate the trend's variance over a line fit alone:
    /// `[(X^T X)^-1]_tt` with them over without them [-] (1 for a window of many periods).
    pub trend_inflation: f64,
}

impl SinusoidFit {
    /// Amplitude [rad].
    pub fn amplitude(&self) -> f64 {
        libm::hypot(self.cos, self.sin)
    }
}

/// `(cos, sin)` of `omega tau` along increasing `tau`, by rotation: the first value and the
/// first step's rotation by `libm`, every later step as that rotation corrected by the small
/// rotation of its difference (samples a filter step apart differ by the rounding of their
/// intervals: `|x| < 1e-4` rad, where `cos x = 1 - x^2/2` and `sin x = x - x^3/6` are exact to
/// `f64` rounding), a step that is not close by `libm` again. Two trigonometric calls per fit
/// instead of four per sample (an MCU does `f64` in software: the fits were the alignment
/// task's largest cost).
struct Rotor {
    omega: f64,
    tau: f64,
    c: f64,
    s: f64,
    /// The first step [s] and its rotation.
    step: Option<(f64, f64, f64)>,
}

impl Rotor {
    /// Below this [rad] a step's difference from the first is rotated by its Taylor series.
    const SMALL: f64 = 1e-4;

    fn new(omega: f64, tau: f64) -> Self {
        let (s, c) = (libm::sin(omega * tau), libm::cos(omega * tau));
        Self {
            omega,
            tau,
            c,
            s,
            step: None,
        }
    }

    /// `(cos, sin)` of `omega tau` for `tau` at or after the last.
    fn at(&mut self, tau: f64) -> (f64, f64) {
        let d = tau - self.tau;
        if d == 0.0 {
            return (self.c, self.s);
        }
        let (step, cd, sd) = *self
            .step
            .get_or_insert_with(|| (d, libm::cos(self.omega * d), libm::sin(self.omega * d)));
        let x = self.omega * (d - step);
        let (cr, sr) = if x.abs() < Self::SMALL {
            let x2 = x * x;
            let (cx, sx) = (1.0 - 0.5 * x2, x - x * x2 / 6.0);
            (cd * cx - sd * sx, sd * cx + cd * sx)
        } else {
            (libm::cos(self.omega * d), libm::sin(self.omega * d))
        };
        let (c, s) = (self.c * cr - self.s * sr, self.s * cr + self.c * sr);
        self.tau = tau;
        self.c = c;
        self.s = s;
        (c, s)
    }
}

/// Least-squares fit of a line plus a sinusoid of angular frequency `omega` [rad/s] to
/// `(t, y)` (times increasing), times relative to `t0`; `None` if singular. The normal
/// equations (their upper triangle), then the residual sample by sample (`sum y^2 - sol . b`
/// would lose it to cancellation on a sway the fit describes well).
fn fit_at(t: &[f64], y: &[f64], t0: f64, omega: f64) -> Option<SinusoidFit> {
    let mut a = Matrix4::<f64>::zeros();
    let mut b = Vector4::<f64>::zeros();
    let first = t.first().map_or(0.0, |&t1| t1 - t0);
    let mut rotor = Rotor::new(omega, first);
    for (&ti, &yi) in t.iter().zip(y) {
        let tau = ti - t0;
        let (c, s) = rotor.at(tau);
        let row = [1.0, tau, c, s];
        for i in 0..4 {
            b[i] += row[i] * yi;
            for j in i..4 {
                a[(i, j)] += row[i] * row[j];
            }
        }
    }
    for i in 1..4 {
        for j in 0..i {
            a[(i, j)] = a[(j, i)];
        }
    }
    let chol = a.cholesky()?;
    let sol = chol.solve(&b);
    // The trend's variance factor with and without the sinusoid (the 2x2 line block).
    let with = chol.inverse()[(1, 1)];
    let (n, st, stt) = (a[(0, 0)], a[(0, 1)], a[(1, 1)]);
    let without = n / (n * stt - st * st);
    let trend_inflation = if without > 0.0 {
        with / without
    } else {
        f64::INFINITY
    };
    let mut rotor = Rotor::new(omega, first);
    let mut sse = 0.0;
    for (&ti, &yi) in t.iter().zip(y) {
        let tau = ti - t0;
        let (c, s) = rotor.at(tau);
        let e = yi - (sol[0] + sol[1] * tau + sol[2] * c + sol[3] * s);
        sse += e * e;
    }
    Some(SinusoidFit {
        omega,
        mean: sol[0],
        trend: sol[1],
        cos: sol[2],
        sin: sol[3],
        residual_rms: libm::sqrt(sse / t.len().max(1) as f64),
        trend_inflation,
    })
}

/// The sway of one axis: the frequency in `[w_min, w_max]` [rad/s] whose line-plus-sinusoid
/// fit leaves the least residual (a grid of spacing `pi / (4 window)`, then a golden-section
/// search around the best), computed in `f64` (a one-off cost).
pub fn identify(t: &[f64], y: &[f64], t0: f64, w_min: f64, w_max: f64) -> SinusoidFit {
    let none = SinusoidFit {
        omega: f64::NAN,
        mean: y.iter().sum::<f64>() / y.len().max(1) as f64,
        trend: 0.0,
        cos: 0.0,
        sin: 0.0,
        residual_rms: f64::INFINITY,
        trend_inflation: f64::INFINITY,
    };
    let window = t.last().copied().unwrap_or(t0) - t0;
    let usable = window > 0.0 && w_max > w_min; // false for NaN too
    if t.len() < 8 || !usable {
        return none;
    }
    let step = core::f64::consts::PI / (4.0 * window);
    let cost = |w: f64| fit_at(t, y, t0, w).map_or(f64::INFINITY, |f| f.residual_rms);
    let (mut best_w, mut best) = (f64::NAN, f64::INFINITY);
    let mut w = w_min;
    while w <= w_max {
        let c = cost(w);
        if c < best {
            (best_w, best) = (w, c);
        }
        w += step;
    }
    if !best_w.is_finite() {
        return none;
    }
    // Golden section on [best - step, best + step].
    let g = 0.5 * (libm::sqrt(5.0) - 1.0);
    let (mut lo, mut hi) = ((best_w - step).max(w_min), (best_w + step).min(w_max));
    let (mut a, mut b) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut ca, mut cb) = (cost(a), cost(b));
    for _ in 0..GOLDEN_STEPS {
        if ca < cb {
            hi = b;
            b = a;
            cb = ca;
            a = hi - g * (hi - lo);
            ca = cost(a);
        } else {
            lo = a;
            a = b;
            ca = cb;
            b = lo + g * (hi - lo);
            cb = cost(b);
        }
    }
    fit_at(t, y, t0, 0.5 * (lo + hi)).unwrap_or(none)
}

/// The golden-section bracket of a [`Search`].
#[derive(Clone, Copy, Debug, PartialEq)]
struct Golden {
    lo: f64,
    hi: f64,
    a: f64,
    b: f64,
    ca: f64,
    cb: f64,
    iter: u32,
}

/// Where a [`Search`] is.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Step {
    /// Done (first: a blank search, [`Search::BLANK`], is then all zero bytes).
    Done,
    /// Evaluating the grid at `w`.
    Grid { w: f64 },
    /// The first golden point to evaluate.
    GoldenStart,
    /// Inside the golden section.
    Golden(Golden),
}

/// [`identify`] one fit at a time, for every axis of a buffer: the same grid, the same golden
/// section, the same result.
#[derive(Clone, Debug)]
pub struct Search<const AXES: usize> {
    t: [f64; BUFFER_LEN],
    y: [[f64; BUFFER_LEN]; AXES],
    n: usize,
    w_min: f64,
    w_max: f64,
    axis: usize,
    step: Step,
    best_w: f64,
    best: f64,
    results: [Option<SinusoidFit>; AXES],
}

impl<const AXES: usize> Search<AXES> {
    /// An empty buffer, all zero (an empty band, no search running): the storage
    /// [`Self::init_in`] starts in place (the sway filters' [`super::SwayModel`]).
    pub const BLANK: Self = Self {
        t: [0.0; BUFFER_LEN],
        y: [[0.0; BUFFER_LEN]; AXES],
        n: 0,
        w_min: 0.0,
        w_max: 0.0,
        axis: 0,
        step: Step::Done,
        best_w: 0.0,
        best: 0.0,
        results: [None; AXES],
    };

    /// An empty buffer for frequencies in `[w_min, w_max]` [rad/s].
    pub fn new(w_min: f64, w_max: f64) -> Self {
        let mut search = Self::BLANK;
        search.init_in(w_min, w_max);
        search
    }

    /// Empties the buffer in place, as [`Self::new`] leaves it, for frequencies in
    /// `[w_min, w_max]` [rad/s].
    pub fn init_in(&mut self, w_min: f64, w_max: f64) {
        let Self {
            t,
            y,
            n,
            w_min: w_min_in,
            w_max: w_max_in,
            axis,
            step,
            best_w,
            best,
            results,
        } = self;
        t.fill(0.0);
        for y in y.iter_mut() {
            y.fill(0.0);
        }
        *n = 0;
        *w_min_in = w_min;
        *w_max_in = w_max;
        *axis = 0;
        *step = Step::Done;
        *best_w = f64::NAN;
        *best = f64::INFINITY;
        *results = [None; AXES];
    }

    /// Keeps one sample `(t [s], y [rad] per axis)`; `false` once the buffer is full.
    pub fn push(&mut self, t: f64, y: [f64; AXES]) -> bool {
        if self.n >= BUFFER_LEN {
            return false;
        }
        self.t[self.n] = t;
        for (a, v) in y.iter().enumerate() {
            self.y[a][self.n] = *v;
        }
        self.n += 1;
        true
    }

    /// The times of the samples kept [s].
    pub fn times(&self) -> &[f64] {
        &self.t[..self.n]
    }

    /// The values of axis `axis` kept [rad].
    pub fn values(&self, axis: usize) -> &[f64] {
        &self.y[axis][..self.n]
    }

    /// Samples kept.
    pub fn len(&self) -> usize {
        self.n
    }

    /// No samples kept.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Time of the first sample [s] (the fits' `t0`).
    pub fn t0(&self) -> f64 {
        self.t[0]
    }

    /// Starts the search over the samples kept.
    pub fn start(&mut self) {
        self.axis = 0;
        self.results = [None; AXES];
        self.begin_axis();
    }

    /// Time spanned by the samples kept [s].
    pub fn window(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.t[self.n - 1] - self.t[0]
        }
    }

    fn begin_axis(&mut self) {
        self.best_w = f64::NAN;
        self.best = f64::INFINITY;
        let usable = self.window() > 0.0 && self.w_max > self.w_min;
        self.step = if self.n < 8 || !usable {
            self.results[self.axis] = Some(self.none());
            Step::Done
        } else {
            Step::Grid { w: self.w_min }
        };
    }

    fn none(&self) -> SinusoidFit {
        let y = &self.y[self.axis][..self.n];
        SinusoidFit {
            omega: f64::NAN,
            mean: y.iter().sum::<f64>() / y.len().max(1) as f64,
            trend: 0.0,
            cos: 0.0,
            sin: 0.0,
            residual_rms: f64::INFINITY,
            trend_inflation: f64::INFINITY,
        }
    }

    fn cost(&self, w: f64) -> f64 {
        fit_at(
            &self.t[..self.n],
            &self.y[self.axis][..self.n],
            self.t[0],
            w,
        )
        .map_or(f64::INFINITY, |f| f.residual_rms)
    }

    /// Runs up to `fits` least-squares fits; `true` when every axis is done.
    pub fn run(&mut self, fits: u32) -> bool {
        let g = 0.5 * (libm::sqrt(5.0) - 1.0);
        let spacing = core::f64::consts::PI / (4.0 * self.window().max(1e-9));
        for _ in 0..fits {
            match self.step {
                Step::Done => {
                    if self.axis + 1 >= AXES {
                        return true;
                    }
                    self.axis += 1;
                    self.begin_axis();
                }
                Step::Grid { w } => {
                    let c = self.cost(w);
                    if c < self.best {
                        (self.best_w, self.best) = (w, c);
                    }
                    let next = w + spacing;
                    self.step = if next <= self.w_max {
                        Step::Grid { w: next }
                    } else if self.best_w.is_finite() {
                        Step::GoldenStart
                    } else {
                        self.results[self.axis] = Some(self.none());
                        Step::Done
                    };
                }
                Step::GoldenStart => {
                    let lo = (self.best_w - spacing).max(self.w_min);
                    let hi = (self.best_w + spacing).min(self.w_max);
                    let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
                    let ca = self.cost(a);
                    self.step = Step::Golden(Golden {
                        lo,
                        hi,
                        a,
                        b,
                        ca,
                        cb: f64::NAN,
                        iter: 0,
                    });
                }
                Step::Golden(mut s) => {
                    if s.cb.is_nan() {
                        s.cb = self.cost(s.b);
                    } else if s.iter < GOLDEN_STEPS {
                        if s.ca < s.cb {
                            s.hi = s.b;
                            s.b = s.a;
                            s.cb = s.ca;
                            s.a = s.hi - g * (s.hi - s.lo);
                            s.ca = self.cost(s.a);
                        } else {
                            s.lo = s.a;
                            s.a = s.b;
                            s.ca = s.cb;
                            s.b = s.lo + g * (s.hi - s.lo);
                            s.cb = self.cost(s.b);
                        }
                        s.iter += 1;
                    } else {
                        let w = 0.5 * (s.lo + s.hi);
                        let fit = fit_at(
                            &self.t[..self.n],
                            &self.y[self.axis][..self.n],
                            self.t[0],
                            w,
                        )
                        .unwrap_or_else(|| self.none());
                        self.results[self.axis] = Some(fit);
                        self.step = Step::Done;
                        continue;
                    }
                    self.step = Step::Golden(s);
                }
            }
        }
        false
    }

    /// The fit of `axis`, once [`Self::run`] returned `true`.
    pub fn result(&self, axis: usize) -> Option<SinusoidFit> {
        self.results.get(axis).copied().flatten()
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    /// The rotation recurrence gives `omega tau`'s cosine and sine as `libm` does, on steps
    /// that jitter, repeat and jump (a gap).
    #[test]
    fn the_rotor_follows_the_angle_through_jitter_and_gaps() {
        let omega = core::f64::consts::TAU / 7.3;
        let mut tau = 0.37;
        let mut rotor = Rotor::new(omega, tau);
        let mut worst: f64 = 0.0;
        for k in 0..400 {
            tau += match k % 50 {
                49 => 3.1,                          // a gap
                7 => 0.0,                           // the same time again
                _ => 0.2 + 1e-7 * f64::from(k % 3), // the intervals' rounding
            };
            let (c, s) = rotor.at(tau);
            worst = worst
                .max((c - libm::cos(omega * tau)).abs())
                .max((s - libm::sin(omega * tau)).abs());
        }
        assert!(worst < 1e-13, "{worst}");
    }

    #[test]
    fn identifies_a_sinusoid_on_a_trend() {
        let w = core::f64::consts::TAU / 11.0;
        let t: Vec<f64> = (1..=125).map(|k| 0.2 * k as f64).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|&t| 0.01 + 1e-5 * t + 0.087 * libm::sin(w * t + 0.3))
            .collect();
        let fit = identify(
            &t,
            &y,
            t[0],
            core::f64::consts::TAU / 20.0,
            core::f64::consts::PI,
        );
        assert!((fit.omega - w).abs() < 1e-9 * w, "{fit:?}");
        assert!((fit.amplitude() - 0.087).abs() < 1e-9 && fit.residual_rms < 1e-9);
        assert!((fit.trend - 1e-5).abs() < 1e-12);
        // No sway: nothing above the noise.
        let flat: Vec<f64> = t.iter().map(|&t| 0.01 + 1e-5 * t).collect();
        let fit = identify(
            &t,
            &flat,
            t[0],
            core::f64::consts::TAU / 20.0,
            core::f64::consts::PI,
        );
        assert!(fit.amplitude() < 1e-12, "{fit:?}");
    }

    #[test]
    fn the_incremental_search_finds_what_identify_finds() {
        let (wr, wp) = (core::f64::consts::TAU / 9.3, core::f64::consts::TAU / 6.1);
        let (lo, hi) = (core::f64::consts::TAU / 20.0, core::f64::consts::PI);
        let mut s = Search::<2>::new(lo, hi);
        let (mut t, mut r, mut p) = (Vec::new(), Vec::new(), Vec::new());
        for k in 1..=125 {
            let tk = 0.2 * k as f64;
            let (a, b) = (
                0.05 * libm::sin(wr * tk),
                0.02 * libm::cos(wp * tk + 1.0) + 1e-3,
            );
            assert!(s.push(tk, [a, b]));
            t.push(tk);
            r.push(a);
            p.push(b);
        }
        s.start();
        let mut calls = 0;
        while !s.run(3) {
            calls += 1;
            assert!(calls < 1000);
        }
        for (axis, y) in [(0, &r), (1, &p)] {
            let direct = identify(&t, y, t[0], lo, hi);
            assert_eq!(s.result(axis), Some(direct), "axis {axis}");
        }
        assert!((s.result(0).unwrap().omega - wr).abs() < 1e-6);
    }
}
