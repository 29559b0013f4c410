//! `nav config FILE.txt --out config.bin`: a configuration frame
//! ([`hal_adapters::protocol::config`]) from its text form (`key = value` lines,
//! [`hal_adapters::protocol::config_text`]), refused with the file, line and reason when a
//! line does not parse, a key is given twice or with one it excludes, the file does not give
//! the site, or the configuration is not valid (nav-core's checks of a run and the protocol's
//! own). Messages name the file's keys, not `nav replay`'s options. The frame is written
//! atomically.

use crate::atomic;
use anyhow::{Context, Result, anyhow, bail};
use hal_adapters::protocol::config::DeviceConfig;
use hal_adapters::protocol::config_text::{
    AIDING_KEYS, EXCLUSIVE_KEYS, InText, REPLACING_KEYS, SITE_KEYS, key_value, keys_of,
};
use hal_adapters::protocol::{Encoder, Message};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// `nav config`'s arguments.
#[derive(clap::Args, Debug)]
pub struct ConfigArgs {
    /// The configuration's text form (`key = value` lines; see docs/protocol.md).
    pub file: PathBuf,
    /// The configuration frame to write (send it to the board as is).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
}

/// The keys given so far: each one's line and value.
type Given<'a> = HashMap<&'a str, (usize, &'a str)>;

/// Why `key = value` cannot follow the keys `given` before it: a key it excludes
/// ([`EXCLUSIVE_KEYS`]; `aiding = off` and a key that switches aiding on), or one whose value
/// it would replace ([`REPLACING_KEYS`]). The earliest such line is named.
fn conflict(key: &str, value: &str, given: &Given<'_>) -> Option<String> {
    let earliest = |keys: &mut dyn Iterator<Item = &str>| {
        keys.filter_map(|k| given.get(k).map(|(n, _)| (*n, k.to_owned())))
            .min()
    };
    for (a, b, why) in EXCLUSIVE_KEYS {
        let other = if key == a {
            b
        } else if key == b {
            a
        } else {
            continue;
        };
        if let Some((n, _)) = given.get(other) {
            return Some(format!(
                "{key}: cannot be used with {other} (line {n}): {why}"
            ));
        }
    }
    let aiding_off = |v: &str| v == "off";
    if key == "aiding" && aiding_off(value) {
        if let Some((n, k)) = earliest(&mut AIDING_KEYS.into_iter()) {
            return Some(format!(
                "aiding = off: cannot be used with {k} (line {n}), which switches aiding on"
            ));
        }
    } else if AIDING_KEYS.contains(&key)
        && let Some((n, v)) = given.get("aiding")
        && aiding_off(v)
    {
        return Some(format!(
            "{key}: switches aiding on, cannot be used with aiding = off (line {n})"
        ));
    }
    for (replacing, replaced) in REPLACING_KEYS {
        if key == replacing
            && let Some((n, k)) = earliest(&mut replaced.iter().copied())
        {
            return Some(format!(
                "{key}: would replace {k} (line {n}) with its own figures: give {key} before \
                 the figures it sets"
            ));
        }
    }
    None
}

/// The configuration of the text `text` (from `name`, for messages), validated: every line
/// parses, no key is given twice, none conflicts with another (`conflict`), the site is
/// given ([`SITE_KEYS`]), and the configuration is valid ([`DeviceConfig::validate`]).
pub fn parse(name: &Path, text: &str) -> Result<DeviceConfig> {
    let file = name.display();
    let mut config = DeviceConfig::default();
    let mut given: Given<'_> = HashMap::new();
    // A byte-order mark (Windows editors write one) is not part of the first key.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    for (k, line) in text.lines().enumerate() {
        let n = k + 1;
        let Some((key, value)) = key_value(line).map_err(|e| anyhow!("{file}:{n}: {e}"))? else {
            continue;
        };
        config
            .set(key, value)
            .map_err(|e| anyhow!("{file}:{n}: {e}"))?;
        if let Some((first, _)) = given.get(key) {
            // Which one the user meant is not for the encoder to guess.
            bail!("{file}:{n}: key '{key}' given again (first on line {first})");
        }
        if let Some(why) = conflict(key, value, &given) {
            bail!("{file}:{n}: {why}");
        }
        given.insert(key, (n, value));
    }
    // A file without a key is an empty or truncated one, or the wrong one: its frame would
    // carry the compiled-in configuration as the host's, and the board would not flag it
    // DEFAULT_CONFIG.
    if given.is_empty() {
        bail!(
            "{file}: no 'key = value' line: a frame of the compiled-in configuration would reach \
             the board as the host's (not flagged DEFAULT_CONFIG); give the keys, or send no frame"
        );
    }
    // The same for the site: the compiled-in one (latitude 0, longitude 0, height 0) is no
    // board's, and the alignment would level and find north for it.
    let missing: Vec<&str> = SITE_KEYS
        .into_iter()
        .filter(|k| !given.contains_key(k))
        .collect();
    if !missing.is_empty() {
        bail!(
            "{file}: the site is not given ({} missing): the compiled-in site (latitude 0, \
             longitude 0, height 0) would reach the board as the host's; give {}",
            missing.join(", "),
            SITE_KEYS.join(", ")
        );
    }
    if let Err(refusal) = config.validate() {
        let code = refusal.code() as u8;
        let why = InText(&refusal);
        // The lines of the file's keys the refusal is about, in file order.
        let mut lines: Vec<(usize, &str)> = keys_of(&refusal)
            .filter_map(|k| given.get(k).map(|(n, _)| (*n, k)))
            .collect();
        lines.sort_unstable();
        match lines.as_slice() {
            [(n, _)] => bail!("{file}:{n}: refused (reason code {code}): {why}"),
            [_, ..] => {
                let numbers: Vec<String> = lines.iter().map(|(n, _)| n.to_string()).collect();
                let keys: Vec<String> = lines
                    .iter()
                    .map(|(n, k)| format!("{k} (line {n})"))
                    .collect();
                bail!(
                    "{file}:{}: refused (reason code {code}): {why} (keys {})",
                    numbers.join(","),
                    keys.join(", ")
                )
            }
            [] => bail!(
                "{file}: refused (reason code {code}, by the defaults of keys not in the file): \
                 {why}"
            ),
        }
    }
    // After the ranges: a translation the static alignment would ignore (the board took such a
    // frame silently).
    if let Some((n, _)) = given.get("base-translation")
        && !config.run.align_method.takes_base_translation()
    {
        bail!(
            "{file}:{n}: base-translation: {}",
            nav_core::alignment::machine::BASE_TRANSLATION_STATIC
        );
    }
    Ok(config)
}

/// Encodes the configuration of the text file `file` as a frame into `out`.
pub fn encode_file(file: &Path, out: &Path) -> Result<DeviceConfig> {
    // Its text names the output already ("output X: output X is the input X" before).
    atomic::refuse_same_file(&[file], out)?;
    let text = crate::text_error::read_text(file)?;
    let config = parse(file, &text)?;
    let mut frame = Vec::new();
    Encoder::new()
        .append(&Message::Config(config), &mut frame)
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    atomic::write(out, |w| w.write_all(&frame))
        .with_context(|| format!("cannot write {}", out.display()))?;
    Ok(config)
}

/// `nav config`.
pub fn run(args: &ConfigArgs) -> Result<()> {
    encode_file(&args.file, &args.out)?;
    println!(
        "configuration {} valid: frame written to {}",
        args.file.display(),
        args.out.display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The site every test file gives.
    const SITE: &str = "lat-deg = 10\nlon-deg = 20\nh-m = 30\n";

    /// A byte-order mark was read as part of the first key ("unknown key '\u{feff}lat-deg'").
    #[test]
    fn a_byte_order_mark_is_not_part_of_the_first_key() {
        let name = Path::new("run.txt");
        let with_bom = format!("\u{feff}{SITE}");
        assert_eq!(parse(name, &with_bom).unwrap(), parse(name, SITE).unwrap());
    }

    /// A key given twice was encoded with its last value, and the aided filter's figures out
    /// of range were encoded as valid while aiding was off (found by a probe): both refused,
    /// naming the line. A scale factor's 1-sigma of 0 too (it was encoded as valid).
    #[test]
    fn a_repeated_key_and_figures_out_of_range_are_refused_without_aiding() {
        let name = Path::new("run.txt");
        let e = parse(name, &format!("{SITE}lat-deg = 11\n")).unwrap_err();
        assert!(
            e.to_string()
                .contains("run.txt:4: key 'lat-deg' given again (first on line 1)"),
            "{e}"
        );
        let scale = "a scale-factor 1-sigma (gyro-scale-sigma, accel-scale-sigma) must be above 0";
        let coupling = "1-sigma must be 0 to 0.1";
        for (key, value, want) in [
            ("gyro-scale-sigma", "0", scale),
            ("gyro-scale-sigma", "-1", scale),
            ("accel-scale-sigma", "0.5", scale),
            ("gyro-cross-coupling-rad", "1e10", coupling),
            ("gyro-g-sensitivity", "-5", coupling),
        ] {
            let e = parse(name, &format!("{SITE}{key} = {value}\n")).unwrap_err();
            let text = e.to_string();
            assert!(
                text.starts_with("run.txt:4: refused (reason code 9)"),
                "{key} = {value}: {text}"
            );
            assert!(text.contains(want), "{key} = {value}: {text}");
        }
        // Beyond f32 (the frame's): refused as typed, not as an infinite 1-sigma.
        let e = parse(name, &format!("{SITE}gyro-scale-sigma = 1e300\n")).unwrap_err();
        assert!(
            e.to_string()
                .contains("run.txt:4: gyro-scale-sigma: takes a finite number within f32's range"),
            "{e}"
        );
        assert!(parse(name, &format!("{SITE}gyro-scale-sigma = 0.001\n")).is_ok());
    }

    /// A file that set no site (only `log-every = 40`) gave a valid frame of latitude 0,
    /// longitude 0, height 0, the compiled-in site: refused now, naming the missing keys.
    #[test]
    fn a_file_without_the_site_is_refused_naming_the_missing_keys() {
        let name = Path::new("run.txt");
        for (text, missing) in [
            ("log-every = 40\n", "lat-deg, lon-deg, h-m missing"),
            ("lat-deg = 45\nlon-deg = 7\n", "h-m missing"),
            (
                "h-m = 0\n# lat-deg = 45\nlog-every = 40\n",
                "lat-deg, lon-deg missing",
            ),
        ] {
            let e = parse(name, text).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("run.txt: the site is not given ({missing})")),
                "{text}: {e}"
            );
            assert!(e.contains("latitude 0, longitude 0, height 0"), "{e}");
        }
        // Given, at 0 too (a site on the equator at sea level is one).
        let c = parse(name, "h-m = 0\nlon-deg = 0\nlat-deg = 0\nlog-every = 40\n").unwrap();
        assert_eq!(
            (c.run.lat_deg, c.run.lon_deg, c.run.h_m, c.run.log_every),
            (0.0, 0.0, 0.0, 40)
        );
    }

    /// `lever-arm` with `lever-arm-sigma` was encoded (the later one winning), where `nav
    /// replay` refuses the two options together; so was `aiding = off` with a key that
    /// switches aiding on (the later one winning), and `imu-model` or `imu-noise` after a
    /// figure it replaces (the figure lost). Refused, naming both lines; the orders that lose
    /// nothing pass.
    #[test]
    fn keys_that_exclude_or_replace_each_other_are_refused_naming_both_lines() {
        let name = Path::new("run.txt");
        for (lines, want) in [
            (
                "lever-arm = 1,0,0\nlever-arm-sigma = 2\n",
                "run.txt:5: lever-arm-sigma: cannot be used with lever-arm (line 4)",
            ),
            (
                "lever-arm-sigma = 2\nlever-arm = 1,0,0\n",
                "run.txt:5: lever-arm: cannot be used with lever-arm-sigma (line 4)",
            ),
            (
                "gnss-correlated = 1,1,2\ngnss-lever-arm = 0,0,-1\naiding = off\n",
                "run.txt:6: aiding = off: cannot be used with gnss-correlated (line 4)",
            ),
            (
                "aiding = off\npropagation-rate = 10\n",
                "run.txt:5: propagation-rate: switches aiding on, cannot be used with aiding = \
                 off (line 4)",
            ),
            (
                "imu-noise = fog\nimu-model = adis16505\n",
                "run.txt:5: imu-model: would replace imu-noise (line 4)",
            ),
            (
                "gyro-bias-rad-s = 1e-5\nimu-noise = fog\n",
                "run.txt:5: imu-noise: would replace gyro-bias-rad-s (line 4)",
            ),
        ] {
            let e = parse(name, &format!("{SITE}{lines}"))
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(want), "{lines}: {e}");
        }
        for lines in [
            "lever-arm = 1,0,0\n",
            "lever-arm-sigma = 2\n",
            "aiding = on\ngnss-lever-arm = 0,0,-1\n",
            "aiding = off\n",
            "imu-model = adis16505\nimu-noise = fog\ngyro-bias-rad-s = 1e-5\n",
        ] {
            assert!(parse(name, &format!("{SITE}{lines}")).is_ok(), "{lines}");
        }
    }

    /// A file's errors named `nav replay`'s options ("--log-every takes a whole number") or
    /// nav-core's field ("log_every must be at least 1", "--lever-arm X,Y,Z"): they name the
    /// file, the line and the file's key now, with the value given.
    #[test]
    fn errors_name_the_file_the_line_and_the_key() {
        let name = Path::new("run.txt");
        for (line, want) in [
            (
                "log-every = -1",
                "run.txt:4: log-every: takes a whole number within 1 to 4294967295, got -1",
            ),
            (
                "log-every = 0",
                "run.txt:4: log-every: takes a whole number within 1 to 4294967295, got 0",
            ),
            (
                "align-method = foo",
                "run.txt:4: align-method: takes static, inertial, fine or sway, got foo",
            ),
            (
                "propagation-rate = 0",
                "run.txt:4: propagation-rate: takes a rate within 1 to 1000 Hz, got 0",
            ),
            (
                "align-method = sway",
                "run.txt:4: refused (reason code 8): the sway method needs the lever arm \
                 (lever-arm = X,Y,Z;",
            ),
        ] {
            let e = parse(name, &format!("{SITE}{line}\n"))
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(want), "{line}: {e}");
            assert!(!e.contains("--") && !e.contains("log_every"), "{line}: {e}");
        }
    }
}
