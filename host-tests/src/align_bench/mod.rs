//! Alignment benchmarks (`nav align-bench`): Monte Carlo runs on the simulator's scenarios and
//! the real laser-gyro recording, each table printed with its physical floor beside it.
//!
//! - [`seed002`]: level alignment on a rocking ship.
//! - [`seed003`]: fine and sway alignment on the AUV bench, against the Cramér–Rao floor.
//! - [`lasergyro`]: heading repeatability over windows of the real laser-gyro recording.
//! - [`family`]: every method on a seeded family of still and swaying bases (random sites,
//!   lever arms, grades, biases), each result against its own 1-sigma and the floor.
pub mod family;
pub mod lasergyro;
pub mod seed002;
pub mod seed003;
