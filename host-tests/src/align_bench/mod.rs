//! Alignment benchmarks (`nav align-bench`): Monte Carlo runs on the simulator's scenarios and
//! the real laser-gyro recording, each table printed with its physical floor beside it.
pub mod lasergyro;
pub mod seed002;
pub mod seed003;
