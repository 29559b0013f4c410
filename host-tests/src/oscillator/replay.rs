//! `nav osc-replay`: the estimator over a recorded readout file (`osc.csv`), epoch by epoch.
//!
//! The readout rate is the median interval of the file's first [`RATE_PREFIX_READOUTS`] rows
//! (the rows are read one at a time, [`replay_rows`]); a row of `NaN` is a missing readout, and a
//! hole in the times (an interval above 1.5 times the median) counts its missing readouts, so
//! the estimator's clock stays on the file's. Each epoch becomes a row of
//! `t_s,qw,qx,qy,qz,f_x_mps2,f_y_mps2,f_z_mps2,sigma_e1_rad,sigma_e2_rad,sigma_e3_rad,frequency_hz`
//! (`q` is `C_b_e`, body to the ellipse frame).

use super::file::OscRow;
use crate::text_error::number_text;
use anyhow::{Result, anyhow, ensure};
use nav_core::Scalar;
use nav_core::oscillator::{OscillatorConfig, OscillatorEstimator, OscillatorFault};
use std::collections::BTreeMap;
use std::convert::Infallible;
use std::fmt;
use std::io::Write;
use std::time::Instant;

/// Header of the epoch rows.
pub const EPOCH_HEADER: &str = "t_s,qw,qx,qy,qz,f_x_mps2,f_y_mps2,f_z_mps2,sigma_e1_rad,sigma_e2_rad,sigma_e3_rad,frequency_hz";

/// What a replay met.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ReplaySummary {
    /// Readout rate taken from the file [Hz].
    pub rate_hz: f64,
    /// Rows in the file.
    pub readouts: u64,
    /// Missing readouts: NaN rows and the holes between rows.
    pub missing: u64,
    /// Epochs given out.
    pub epochs: u64,
    /// Periods without an epoch, by reason.
    pub faults: BTreeMap<&'static str, u64>,
    /// The measured natural frequency at the end [Hz].
    pub frequency_hz: f64,
    /// Estimator throughput [readouts/s] (one thread, no I/O).
    pub readouts_per_s: f64,
}

impl fmt::Display for ReplaySummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} readouts at {:.1} Hz ({} missing); {} epochs; natural frequency {:.6} Hz",
            self.readouts, self.rate_hz, self.missing, self.epochs, self.frequency_hz
        )?;
        let faults: Vec<String> = self
            .faults
            .iter()
            .map(|(k, n)| format!("{k} {n}"))
            .collect();
        writeln!(
            f,
            "periods without an epoch: {}",
            if faults.is_empty() {
                "none".to_string()
            } else {
                faults.join(", ")
            }
        )?;
        writeln!(f, "estimator speed: {:.0} readouts/s", self.readouts_per_s)
    }
}

/// Readouts whose median interval gives the readout rate: a bounded prefix of the file, so the
/// rows after it are read one at a time.
pub const RATE_PREFIX_READOUTS: usize = 4097;

/// Most readouts a hole in the times may miss in a row; a longer hole is a wrong time (e.g.
/// 1e300 s), not a pause, and would keep the estimator counting missing readouts for ever.
pub const MAX_HOLE_READOUTS: i64 = 10_000_000;

/// The readout interval of `rows`: the median of their time differences [s].
pub fn median_interval(rows: &[OscRow]) -> Result<f64> {
    let mut d: Vec<f64> = rows.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
    ensure!(!d.is_empty(), "the file has fewer than two readouts");
    d.sort_by(f64::total_cmp);
    let dt = d[d.len() / 2];
    ensure!(
        dt.is_finite() && dt > 0.0,
        "the readout times do not increase"
    );
    Ok(dt)
}

/// Runs the estimator in precision `T` over `rows` from an oscillator at `f0_hz`, writing epoch
/// rows to `out` if given.
pub fn replay<T: Scalar>(
    rows: &[OscRow],
    f0_hz: f64,
    compensate: bool,
    out: Option<&mut dyn Write>,
) -> Result<ReplaySummary> {
    replay_rows::<T, Infallible>(rows.iter().copied().map(Ok), f0_hz, compensate, out)
}

/// [`replay`] over rows read one at a time (e.g. [`super::file::OscReader`]): the rate from the
/// first [`RATE_PREFIX_READOUTS`], the rows after them never held together; a reading error ends
/// the replay with that error.
pub fn replay_rows<T: Scalar, E>(
    rows: impl IntoIterator<Item = Result<OscRow, E>>,
    f0_hz: f64,
    compensate: bool,
    mut out: Option<&mut dyn Write>,
) -> Result<ReplaySummary>
where
    E: std::error::Error + Send + Sync + 'static,
{
    let mut rows = rows.into_iter();
    let mut prefix = Vec::with_capacity(RATE_PREFIX_READOUTS);
    for row in rows.by_ref().take(RATE_PREFIX_READOUTS) {
        prefix.push(row?);
    }
    let dt = median_interval(&prefix)?;
    let t_first = prefix[0].t_s;
    let mut cfg = OscillatorConfig::<T>::new(1.0 / dt, f0_hz);
    cfg.start_s = t_first;
    cfg.compensate = compensate;
    let mut est = OscillatorEstimator::new(cfg).map_err(|e| anyhow!("oscillator: {e}"))?;
    let mut s = ReplaySummary {
        rate_hz: 1.0 / dt,
        ..ReplaySummary::default()
    };
    if let Some(o) = out.as_mut() {
        writeln!(o, "{EPOCH_HEADER}")?;
    }
    let started = Instant::now();
    let mut last_t = t_first - dt;
    for row in prefix.into_iter().map(Ok).chain(rows) {
        let row = row?;
        // A hole in the times: its readouts are missing.
        let skipped = ((row.t_s - last_t) / dt).round() as i64 - 1;
        ensure!(
            skipped <= MAX_HOLE_READOUTS,
            "the readout times jump from {} s to {} s: {skipped} readouts missing in a row \
             (more than {MAX_HOLE_READOUTS}; a wrong time?)",
            number_text(last_t),
            number_text(row.t_s)
        );
        for _ in 0..skipped.max(0) {
            s.missing += 1;
            note(&mut s, est.missing(), &mut out)?;
        }
        last_t = row.t_s;
        s.readouts += 1;
        let result = match row.r_b_m {
            Some(r) => est.add(&r.map(T::c)),
            None => {
                s.missing += 1;
                est.missing()
            }
        };
        note(&mut s, result, &mut out)?;
    }
    let seconds = started.elapsed().as_secs_f64();
    s.readouts_per_s = (s.readouts + s.missing) as f64 / seconds.max(1e-9);
    s.frequency_hz = est.frequency_hz();
    // An estimator that gave no epoch answered nothing: a failure, with the counts by cause.
    if s.epochs == 0 {
        let hint = if s.faults.contains_key("force beyond range") {
            " (force beyond range: the ellipse's centre gave a specific force beyond 50 g: \
             readouts in another unit than metres, or a wrong --f0-hz)"
        } else {
            ""
        };
        return Err(anyhow!(
            "no attitude epoch from {} readouts: {}{hint}",
            s.readouts + s.missing,
            s.to_string().trim_end().replace('\n', "; ")
        ));
    }
    Ok(s)
}

fn note<T: Scalar>(
    s: &mut ReplaySummary,
    result: Option<Result<nav_core::oscillator::OscillatorEpoch<T>, OscillatorFault>>,
    out: &mut Option<&mut dyn Write>,
) -> Result<()> {
    match result {
        Some(Ok(e)) => {
            s.epochs += 1;
            if let Some(o) = out.as_mut() {
                let q = e.q_b_e.quaternion();
                let f = e.f_ib_b.map(T::to_f64);
                let sg = e.sigma_rad.map(T::to_f64);
                writeln!(
                    o,
                    "{:.9},{:.12},{:.12},{:.12},{:.12},{:.7},{:.7},{:.7},{:.3e},{:.3e},{:.3e},{:.6}",
                    e.t_s,
                    q.w.to_f64(),
                    q.i.to_f64(),
                    q.j.to_f64(),
                    q.k.to_f64(),
                    f.x,
                    f.y,
                    f.z,
                    sg.x,
                    sg.y,
                    sg.z,
                    e.frequency_hz
                )?;
            }
        }
        Some(Err(f)) => *s.faults.entry(f.kind()).or_default() += 1,
        None => {}
    }
    Ok(())
}
