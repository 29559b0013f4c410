//! `host-tests`: the desktop harness around `nav-core` and `hal-adapters`.
//!
//! A recording's way through the harness: a file ([`imu_csv`], [`kf_gins`], [`psins`] or the
//! project's binary format) -> records of the binary format ->
//! [`hal_adapters::recording::Replay`] (flags NaN samples and bad intervals, measures `dt`) ->
//! [`pipeline::run`] (static alignment, then strapdown navigation) -> solution log (CSV rows of
//! [`nav_core::Solution`]). Binary files are replayed straight from disk; text files are read
//! line by line and each record encoded as the replay reads it ([`text_recording`]), so every
//! format goes through the same flagging and `dt` code in memory independent of its length.
//!
//! - [`imu_csv`]: the CSV increment format (reader and writer).
//! - [`psins`]: reader of PSINS `.imu` text recordings.
//! - [`recording_io`]: format detection, the common in-memory recording, binary writer, replay
//!   sources.
//! - [`generate`]: exact synthetic recordings of a stationary body.
//! - [`pipeline`]: the replay pipeline (the same semantics as the firmware's tasks).
//! - [`replay`]: a file replayed end to end (open, run, attach the replay counters).
//! - [`gnss_file`]: GNSS fix files as the navigator takes them (text or the firmware's binary
//!   fix file) and the binary file's writer.
//! - [`bench`]: the mechanization's host benchmark (`nav bench`).
//! - [`decode`]: the board's binary output stream back to the solution CSV (`nav decode`).
//! - [`config_cmd`]: a configuration frame from its text form (`nav config`).
//! - [`truth`]: exactly known trajectories and their exact increments (physics tests).
//! - [`oscillator`]: the isotropic-oscillator sensor simulator ([Oscillator INS]) and its `osc.csv`
//!   readout file.
//! - [`text_error`]: the error of the text-format readers and writers (file, line, what went
//!   wrong).
//! - [`text_recording`]: CSV, KF-GINS and PSINS files as streams of binary records (replay).
//! - [`text_stream`]: text files one record at a time, and the test of a cut-off last line.
//!
//! The `nav` binary (`src/bin/nav.rs`) is the command-line front end.
#![deny(unsafe_code)]
// Units are written `[m/s]` in docs (project convention), which rustdoc would read as links.
#![allow(rustdoc::broken_intra_doc_links)]
#![warn(missing_docs)]

pub mod aided;
pub mod aided_bench;
pub mod aided_cmd;
pub mod align_bench;
pub mod atomic;
pub mod bench;
pub mod config_cmd;
pub mod decode;
pub mod emulate;
pub mod filter_bench;
pub mod gap_bench;
pub mod generate;
pub mod gnss;
pub mod gnss_bench;
pub mod gnss_file;
pub mod gnss_ins_sim;
pub mod gnss_sim;
pub mod imu_csv;
pub mod kf_gins;
pub mod kf_gins_config;
pub mod kf_gins_run;
pub mod nav_writer;
pub mod oscillator;
pub mod output_check;
pub mod pipeline;
pub mod psins;
pub mod recording_io;
pub mod replay;
pub mod report;
pub mod sensor_model;
pub mod sigma_log;
pub mod simulate;
pub mod simulate_family;
pub mod text_error;
pub mod text_recording;
pub mod text_stream;
pub mod trajectory;
pub mod truth;
pub mod truth_csv;

/// Most threads a Monte Carlo bench runs (`--threads` of `nav bench` and `nav align-bench`: one
/// range for both, which took 1-256 and 1-64).
pub const MAX_THREADS: usize = 256;
