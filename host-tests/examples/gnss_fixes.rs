//! GNSS fix files for an existing truth file (the demo's): `nav sim --gnss-rate` simulates the
//! receiver with the recording, `nav convert --gnss` converts a GNSS text file.
//!
//! ```text
//! cargo run --release -p host-tests --example gnss_fixes -- simulate TRUTH_CSV OUT_DIR [RATE_HZ [SEED]]
//! ```
//!
//! `simulate` writes `OUT_DIR/gnss.csv` (the project's GNSS CSV) and `OUT_DIR/gnss.bin` (the
//! firmware's binary fix file, `docs/gnss-record-format.md`) of a receiver at the IMU
//! (`host_tests::gnss_sim`: 0.5, 0.5, 1 m and 0.05, 0.05, 0.1 m/s 1-sigma; by default at 1 Hz
//! with seed 1) from a truth file `nav sim` wrote.

use anyhow::{Context, Result, bail};
use host_tests::gnss_sim::{self, GnssSimOptions};
use host_tests::{gnss, gnss_file, truth_csv};
use std::path::Path;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let words: Vec<&str> = args.iter().map(String::as_str).collect();
    match words.as_slice() {
        ["simulate", truth, out, rest @ ..] if rest.len() <= 2 => {
            let rate_hz = match rest.first() {
                Some(r) => r.parse().context("RATE_HZ is not a number")?,
                None => 1.0,
            };
            let seed = match rest.get(1) {
                Some(s) => s.parse().context("SEED is not a whole number")?,
                None => 1,
            };
            let truth = truth_csv::read(Path::new(truth))?;
            let options = GnssSimOptions {
                rate_hz,
                sigma_ned_m: [0.5, 0.5, 1.0],
                sigma_v_ned_m_s: Some([0.05, 0.05, 0.1]),
                seed,
                ..GnssSimOptions::default()
            };
            let fixes = gnss_sim::simulate(&truth, &options)?.fixes;
            let out = Path::new(out);
            std::fs::create_dir_all(out)?;
            gnss::write_gnss_csv(&out.join("gnss.csv"), &fixes)?;
            gnss_file::convert(&out.join("gnss.csv"), &out.join("gnss.bin"), None)?;
            println!(
                "{} fixes at {rate_hz} Hz -> {}/gnss.csv, gnss.bin",
                fixes.len(),
                out.display()
            );
        }
        _ => bail!("usage: gnss_fixes simulate TRUTH_CSV OUT_DIR [RATE_HZ [SEED]]"),
    }
    Ok(())
}
