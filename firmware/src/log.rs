//! The firmware's defmt summaries of the run: its configuration, the alignment, the driver's
//! health and the final solution.

use hal_adapters::drivers::Health;
use nav_core::alignment::{AlignMethod, AlignOutcome, LeverArm};
use nav_core::ins_filter::sequencer::{FixCounters, Realignments};
use nav_core::navigator::{FilterReport, RunConfig};
use nav_core::output::Solution;

/// Logs the run configuration: the site, the window, the noise and lever arm assumed.
#[inline(never)]
pub fn config(run: &RunConfig) {
    defmt::info!(
        "config: lat {=f64} deg, lon {=f64} deg, h {=f64} m, align {=f64} s ({=str}), log every {=u32}",
        run.lat_deg,
        run.lon_deg,
        run.h_m,
        run.align_seconds,
        run.align_method.name(),
        run.log_every
    );
    let n = run.align_noise();
    defmt::info!(
        "alignment assumes ARW {=f64} rad/sqrt(s), VRW {=f64} m/s/sqrt(s), bias 1-sigma {=f64} rad/s, {=f64} m/s^2 (bias prior {=f64})",
        n.arw_rad_per_sqrt_s,
        n.vrw_mps_per_sqrt_s,
        n.gyro_bias_rad_s,
        n.accel_bias_mps2,
        run.bias_prior
    );
    match run.lever_arm {
        LeverArm::Known(r) => {
            defmt::info!("lever arm known: {=f64} {=f64} {=f64} m", r.x, r.y, r.z)
        }
        LeverArm::Unknown { sigma_m } => {
            defmt::info!("lever arm unknown: 1-sigma {=f64} m per axis", sigma_m)
        }
    }
}

/// Logs the alignment's result: stages, attitude, attitude and hand-over 1-sigma.
#[inline(never)]
pub fn aligned(r: &AlignOutcome<f32>) {
    let (roll, pitch, yaw) = nav_core::attitude::euler(&r.estimate.q_b_n);
    let sigma = r.estimate.sigma_rad.map(|x| x.to_degrees());
    let (v, p) = (r.velocity_sigma_m_s, r.position_sigma_m);
    defmt::info!(
        "alignment stage ALIGNED after {=u32} samples (coarse {=f64} s, fine {=f64} s): roll {=f32} deg, pitch {=f32} deg, yaw {=f32} deg; 1-sigma {=f32} {=f32} {=f32} deg, v {=f32} {=f32} {=f32} m/s, p {=f32} {=f32} {=f32} m",
        r.times.coarse_samples + r.times.fine_samples,
        r.times.coarse_s,
        r.times.fine_s,
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees(),
        sigma.x,
        sigma.y,
        sigma.z,
        v.x,
        v.y,
        v.z,
        p.x,
        p.y,
        p.z
    );
    // How the result was reached, in `nav replay`'s words (sway: the general filter's answer
    // where the sway model is off or refuted).
    // Only the sway method notes: its text (with figures) where the method is in the build.
    if let Some(note) = &r.note {
        if const { AlignMethod::Sway.compiled_in() } {
            defmt::info!("note: {}", defmt::Display2Format(note));
        } else {
            defmt::info!("note: {=str}", note.reason());
        }
    }
}

/// Logs the aided phase's settings and the GNSS file's fix count, and the static RAM of its
/// largest parts: the filter (covariance, error state, settings; it takes the aligner's place
/// in the background, on the `align` task's stack), the fix queue, the channel of
/// `filter_cap` messages to the background and the GNSS file's reader [B].
#[inline(never)]
pub fn gnss(fixes: u32, run: &RunConfig, filter_cap: usize) {
    use core::mem::size_of;
    use nav_core::ins_filter::ErrorFilter;
    use nav_core::ins_filter::sequencer::FixQueue;
    use nav_core::navigator::ToBackground;
    let Some(a) = &run.aiding else { return };
    defmt::info!(
        "aided phase static RAM [B]: filter {=usize} (in the alignment's slot: none of its own), fix queue {=usize}, filter channel {=usize}, GNSS reader {=usize}",
        size_of::<ErrorFilter<f32>>(),
        size_of::<FixQueue<f32>>(),
        filter_cap * size_of::<ToBackground<f32>>(),
        size_of::<crate::board::Fixes>()
    );
    let l = a.antenna_lever_arm_b_m;
    defmt::info!(
        "GNSS-aided after the alignment: {=u32} fixes; antenna lever arm {=f64} {=f64} {=f64} m, covariance propagation every {=f64} s, scale factors {=bool}, stop updates {=bool}",
        fixes,
        l[0],
        l[1],
        l[2],
        a.propagation_interval_s,
        a.scale_factors,
        a.zero_motion
    );
    if let Some(s) = a.gnss_correlated_sigma_ned_m {
        defmt::info!(
            "GNSS correlated error: 1-sigma {=f64} {=f64} {=f64} m (north, east, down), correlation time {=f64} s",
            s[0],
            s[1],
            s[2],
            a.gnss_correlated_time_s
        );
    }
}

/// Logs the filter's final report and the fixes' counts (the lines `nav replay --gnss`
/// prints).
#[inline(never)]
pub fn filter(
    r: &FilterReport<f32>,
    fixes: &FixCounters,
    realignments: &Realignments,
    unused: u32,
    after_data: u32,
) {
    let c = &r.counters;
    defmt::info!(
        "aided navigation: status {=str}, {=u32} covariance propagations, {=u32} covariance faults",
        r.status.name(),
        c.propagations,
        r.covariance_faults
    );
    for (name, a) in [
        ("GNSS position", &c.position),
        ("GNSS velocity", &c.velocity),
        ("zero velocity", &c.zero_velocity),
        ("zero rate", &c.zero_rate),
    ] {
        // The words of `AidCounters`' Display, which the harness prints.
        if a.window_rejected > 0 || a.cluster_rejected > 0 {
            defmt::info!(
                "  {=str}: {=u32} accepted, {=u32} rejected ({=u32} by the window test, {=u32} as a refused cluster), {=u32} invalid",
                name,
                a.accepted,
                a.rejected,
                a.window_rejected,
                a.cluster_rejected,
                a.invalid
            );
        } else {
            defmt::info!(
                "  {=str}: {=u32} accepted, {=u32} rejected, {=u32} invalid",
                name,
                a.accepted,
                a.rejected,
                a.invalid
            );
        }
    }
    defmt::info!(
        "  fixes: {=u32} received while aided, {=u32} out of order, {=u32} dropped from a full queue, {=u32} late; {=u32} before the aided phase, {=u32} after the data",
        fixes.received,
        fixes.out_of_order,
        fixes.queue_full,
        fixes.late,
        unused,
        after_data
    );
    // The figures of the harness's line (`host_tests::aided_cmd::realignment_line`).
    let g = realignments;
    if g.begun > 0 && g.completed == g.begun {
        defmt::info!(
            "re-aligned in motion {=u32} time(s) ({=u32} after a divergence, {=u32} started over by another lost gap): the filter navigates again from t = {=u64} us; from t = {=u64} us until then the rows are the set-aside solution's, DEGRADED",
            g.completed,
            g.diverged,
            g.started_over,
            g.navigating_us,
            g.begun_us
        );
    } else if g.begun > 0 {
        defmt::warn!(
            "re-aligning in motion since t = {=u64} us ({=u32} begun, {=u32} completed): the rows since are the set-aside solution's, DEGRADED",
            g.begun_us,
            g.begun,
            g.completed
        );
    }
    // The harness's warnings (`host_tests::aided_cmd::position_warning`), in its words.
    let p = &c.position;
    if p.accepted == 0 {
        defmt::warn!(
            "no GNSS position fix was used ({=u32} refused, {=u32} invalid, {=u32} before the aided phase, {=u32} after the data): the solution is free-inertial",
            p.rejected,
            p.invalid,
            unused,
            after_data
        );
    } else if p.rejected + p.invalid > p.accepted {
        defmt::warn!(
            "more GNSS position fixes refused ({=u32}) or invalid ({=u32}) than used ({=u32}): the filter's IMU noise (--imu-noise, imunoise), the start and its 1-sigma (--init-*, init*, or the alignment's), the antenna lever arm or the fixes' 1-sigma do not match the data, and the solution may be far off",
            p.rejected,
            p.invalid,
            p.accepted
        );
    }
    let (p, v, a) = (r.sigma_ned_m, r.sigma_v_ned_m_s, r.sigma_att_rad);
    defmt::info!(
        "  final 1-sigma: position {=f32} {=f32} {=f32} m, velocity {=f32} {=f32} {=f32} m/s (N E D), roll {=f32} pitch {=f32} yaw {=f32} deg",
        p.x,
        p.y,
        p.z,
        v.x,
        v.y,
        v.z,
        a.x.to_degrees(),
        a.y.to_degrees(),
        a.z.to_degrees()
    );
}

/// Logs the IMU driver's counters (their `Display`, which `nav replay --device` prints too).
#[inline(never)]
pub fn health(h: &Health) {
    defmt::info!("IMU driver: {}", crate::errors::DriverHealth(h));
}

/// Logs the alignment's attitude and the last solution.
#[inline(never)]
pub fn end(aligned: &AlignOutcome<f32>, last: &Solution) {
    let (roll, pitch, yaw) = nav_core::attitude::euler(&aligned.estimate.q_b_n);
    defmt::info!(
        "alignment: roll {=f32} deg, pitch {=f32} deg, yaw {=f32} deg",
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    );
    defmt::info!(
        "solution at t={=u64} us: lat {=i64} ndeg, lon {=i64} ndeg, h {=f64} m, v_n {=f64} v_e {=f64} v_d {=f64} m/s, roll {=f64} pitch {=f64} yaw {=f64} deg",
        last.t_us,
        last.lat_ndeg,
        last.lon_ndeg,
        last.h_m,
        last.v_eb_n[0],
        last.v_eb_n[1],
        last.v_eb_n[2],
        last.roll_deg,
        last.pitch_deg,
        last.yaw_deg
    );
}

/// Not one GNSS fix (the file's span `fixes` [us]) within the IMU data's span `data` [us]:
/// on another clock ([`nav_core::gap::on_another_clock`]), or a run that would be
/// free-inertial (the qemu board's fix file; the harness refuses the same).
#[cfg(feature = "qemu")]
pub fn no_fix_in_span(fixes: (u64, u64), data: (u64, u64)) {
    let s = |t_us: u64| t_us as f64 * 1e-6;
    if nav_core::gap::on_another_clock(fixes, data) {
        defmt::error!(
            "GNSS file: no GNSS fix within the IMU data's time span: the fixes are at {=f64} .. {=f64} s, the IMU data cover {=f64} .. {=f64} s: the GNSS time tags are on another clock than the recording's (e.g. GNSS seconds of week against a recording that starts at 0); give the fixes the recording's time",
            s(fixes.0),
            s(fixes.1),
            s(data.0),
            s(data.1)
        );
    } else {
        defmt::error!(
            "GNSS file: no GNSS fix within the IMU data's time span: the fixes are at {=f64} .. {=f64} s, the IMU data cover {=f64} .. {=f64} s: the run would be free-inertial",
            s(fixes.0),
            s(fixes.1),
            s(data.0),
            s(data.1)
        );
    }
}
