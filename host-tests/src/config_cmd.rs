//! `nav config FILE.txt --out config.bin`: a configuration frame
//! ([`hal_adapters::protocol::config`]) from its text form (`key = value` lines,
//! [`hal_adapters::protocol::config_text`]), refused with the file, line and reason when a
//! line does not parse or the configuration is not valid (nav-core's checks of a run and the
//! protocol's own). The frame is written atomically.

use crate::atomic;
use anyhow::{Context, Result, bail};
use hal_adapters::protocol::config::DeviceConfig;
use hal_adapters::protocol::config_text::{key_of, keys_of};
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

/// The configuration of the text `text` (from `name`, for messages), validated.
pub fn parse(name: &Path, text: &str) -> Result<DeviceConfig> {
    let mut config = DeviceConfig::default();
    let mut line_of: HashMap<&str, usize> = HashMap::new();
    // A byte-order mark (Windows editors write one) is not part of the first key.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    for (k, line) in text.lines().enumerate() {
        let n = k + 1;
        config
            .apply_line(line)
            .map_err(|e| anyhow::anyhow!("{}:{n}: {e}", name.display()))?;
        if let Some(key) = key_of(line)
            && let Some(first) = line_of.insert(key, n)
        {
            // Which one the user meant is not for the encoder to guess.
            bail!(
                "{}:{n}: key '{key}' given again (first on line {first})",
                name.display()
            );
        }
    }
    // A file without a key is an empty or truncated one, or the wrong one: its frame would
    // carry the compiled-in configuration as the host's, and the board would not flag it
    // DEFAULT_CONFIG.
    if line_of.is_empty() {
        bail!(
            "{}: no 'key = value' line: a frame of the compiled-in configuration would reach the \
             board as the host's (not flagged DEFAULT_CONFIG); give the keys, or send no frame",
            name.display()
        );
    }
    if let Err(refusal) = config.validate() {
        // The lines of the file's keys the refusal is about, in file order.
        let mut lines: Vec<(usize, &str)> = keys_of(&refusal)
            .filter_map(|k| line_of.get(k).map(|n| (*n, k)))
            .collect();
        lines.sort_unstable();
        match lines.as_slice() {
            [(n, _)] => bail!(
                "{}:{n}: refused (reason code {}): {refusal}",
                name.display(),
                refusal.code() as u8
            ),
            [_, ..] => {
                let numbers: Vec<String> = lines.iter().map(|(n, _)| n.to_string()).collect();
                let keys: Vec<String> = lines
                    .iter()
                    .map(|(n, k)| format!("{k} (line {n})"))
                    .collect();
                bail!(
                    "{}:{}: refused (reason code {}): {refusal} (keys {})",
                    name.display(),
                    numbers.join(","),
                    refusal.code() as u8,
                    keys.join(", ")
                )
            }
            [] => bail!(
                "{}: refused (reason code {}, by the defaults of keys not in the file): {refusal}",
                name.display(),
                refusal.code() as u8
            ),
        }
    }
    Ok(config)
}

/// Encodes the configuration of the text file `file` as a frame into `out`.
pub fn encode_file(file: &Path, out: &Path) -> Result<DeviceConfig> {
    atomic::refuse_same_file(&[file], out).with_context(|| format!("output {}", out.display()))?;
    let text =
        std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
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

    /// A byte-order mark was read as part of the first key ("unknown key '\u{feff}lat-deg'").
    #[test]
    fn a_byte_order_mark_is_not_part_of_the_first_key() {
        let name = Path::new("run.txt");
        let text = "lat-deg = 10\nlon-deg = 20\n";
        let with_bom = format!("\u{feff}{text}");
        assert_eq!(parse(name, &with_bom).unwrap(), parse(name, text).unwrap());
    }

    /// A key given twice was encoded with its last value, and the aided filter's figures out
    /// of range were encoded as valid while aiding was off (found by a probe): both refused,
    /// naming the line.
    #[test]
    fn a_repeated_key_and_figures_out_of_range_are_refused_without_aiding() {
        let name = Path::new("run.txt");
        let e = parse(
            name,
            "lat-deg = 10
lon-deg = 20
lat-deg = 11
",
        )
        .unwrap_err();
        assert!(
            e.to_string()
                .contains("run.txt:3: key 'lat-deg' given again (first on line 1)"),
            "{e}"
        );
        for (key, value) in [
            ("gyro-scale-sigma", "-1"),
            ("gyro-scale-sigma", "1e300"),
            ("accel-scale-sigma", "0.5"),
            ("gyro-cross-coupling-rad", "1e10"),
            ("gyro-g-sensitivity", "-5"),
        ] {
            let e = parse(name, &format!("lat-deg = 10\n{key} = {value}\n")).unwrap_err();
            let text = e.to_string();
            assert!(
                text.starts_with("run.txt:2: refused"),
                "{key} = {value}: {text}"
            );
            assert!(
                text.contains("1-sigma must be 0 to 0.1"),
                "{key} = {value}: {text}"
            );
        }
        assert!(parse(name, "lat-deg = 10\ngyro-scale-sigma = 0.001\n").is_ok());
    }
}
