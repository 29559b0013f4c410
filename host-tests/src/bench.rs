//! Host benchmark of the mechanization alone: steps per second, one thread, no I/O.

use crate::truth::MeridianFlight;
use nav_core::{ImuIncrement, MechanizationConfig, NavState, Position, Scalar, Strapdown};
use nav_core::{UnitQuaternion, Vector3};
use std::hint::black_box;
use std::time::Instant;

/// The flight the benchmark integrates: 900 km/h at 10 km from 56.2 deg N.
const FLIGHT: MeridianFlight = MeridianFlight {
    lat0: 0.980_875,
    lon0: 0.768,
    h: 10_000.0,
    speed: 250.0,
};

/// 10 min of exact 400 Hz increments of the flight.
pub fn flight_increments() -> Vec<ImuIncrement<f64>> {
    let mut v = Vec::with_capacity(240_000);
    FLIGHT.run(0.0025, 240_000, |inc, _| v.push(*inc));
    v
}

/// Steps per second of the default mechanization in precision `T` over `passes` passes of
/// `increments` (each pass restarts from the flight's initial state).
pub fn steps_per_second<T: Scalar>(increments: &[ImuIncrement<f64>], passes: u32) -> f64 {
    let incs: Vec<ImuIncrement<T>> = increments
        .iter()
        .map(|i| ImuIncrement {
            delta_theta_ib_b: i.delta_theta_ib_b.map(T::c),
            delta_v_ib_b: i.delta_v_ib_b.map(T::c),
            dt: T::c(i.dt),
        })
        .collect();
    let start = NavState {
        q_b_n: UnitQuaternion::identity(),
        v_eb_n: Vector3::new(T::c(FLIGHT.speed), T::zero(), T::zero()),
        position: Position::from_radians(FLIGHT.lat0, FLIGHT.lon0, FLIGHT.h),
    };
    let t0 = Instant::now();
    let mut steps = 0_u64;
    for _ in 0..passes.max(1) {
        let mut nav = Strapdown::new(start, MechanizationConfig::default());
        for inc in &incs {
            if nav.step(black_box(inc)).is_ok() {
                steps += 1;
            }
        }
        black_box(nav.state());
    }
    steps as f64 / t0.elapsed().as_secs_f64().max(1e-9)
}
