//! Inputs of `nav` that were taken wrongly or silently: grades without noise, streams, data
//! sets mixed from two folders, repeated time tags, headers in capitals, holes in a truth file,
//! long output names, fixes just before the data. Each is refused with a message that names
//! the file and what was expected, warned about, or counted where the README says.

mod common;

use common::{nav, output_text};

/// `nav args`, which must succeed; its stdout and stderr.
fn ok(args: &[&str]) -> String {
    let o = nav(args);
    let text = output_text(&o);
    assert!(o.status.success(), "nav {args:?}: {text}");
    assert!(!text.contains("panicked"), "nav {args:?}: {text}");
    text
}

/// The constant-gain level filter with noise-free sensors: its time constant was 0, its gain
/// infinite, and the table printed NaN and 90 deg errors with status 0.
#[test]
fn the_ship_bench_with_ideal_sensors_prints_numbers() {
    let text = ok(&["align-bench", "seed002", "--grade", "ideal", "--runs", "1"]);
    assert!(!text.contains("NaN"), "{text}");
    // Every const row is within a millidegree (exact data).
    for row in text.lines().filter(|l| l.contains(" const ")) {
        let worst = row
            .split(['|', ' '])
            .filter_map(|f| f.parse::<f64>().ok())
            .skip(2)
            .fold(0.0_f64, |m, x| m.max(x.abs()));
        assert!(worst < 1e-3, "{row}");
    }
}
