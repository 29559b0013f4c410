//! Numbers in messages, readable at any magnitude: a refused `1e30` prints as `1e30`, not as
//! thirty-one digits; and texts from files as they are ([`Shown`]).

use core::fmt;

/// `x` exactly (shortest round trip): plain within `[1e-3, 1e6)` and for 0, scientific outside
/// (`1e9`, `2.5e-7`); for values a user gave, so they read as typed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Number(pub f64);

impl fmt::Display for Number {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if plain(x) {
            write!(f, "{x}")
        } else {
            write!(f, "{x:e}")
        }
    }
}

/// `x` to four significant digits: plain within `[1e-3, 1e6)` (`98.07`, `9.806`), scientific
/// outside (`1.000e30`); for computed values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rounded(pub f64);

impl fmt::Display for Rounded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let x = self.0;
        if x == 0.0 || !plain(x) {
            return if x == 0.0 {
                f.write_str("0")
            } else {
                write!(f, "{x:.3e}")
            };
        }
        // Digits after the point for four significant ones, from the decimal exponent after
        // rounding (9.99996 rounds to 10.00, not 10.000).
        let a = libm::fabs(x);
        let mut exponent = libm::floor(libm::log10(a));
        if libm::round(a / libm::pow(10.0, exponent - 3.0)) >= 1e4 {
            exponent += 1.0;
        }
        let decimals = (3.0 - exponent).max(0.0) as usize;
        write!(f, "{x:.decimals$}")
    }
}

/// Whether `x` prints plainly: finite and 0 or within `[1e-3, 1e6)` in magnitude.
fn plain(x: f64) -> bool {
    let a = libm::fabs(x);
    x == 0.0 || (1e-3..1e6).contains(&a)
}

/// A text from a file as a message shows it: control characters written as escapes (`\t`,
/// `\u{0}`, `\u{1b}`), so that the message shows what the file holds (a NUL inside a number was
/// printed raw, invisible: `found '1.2<NUL>45e-7'` read as a valid number).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shown<'a>(pub &'a str);

impl fmt::Display for Shown<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use fmt::Write as _;
        for c in self.0.chars() {
            if matches!(c, '\t' | '\r' | '\n') {
                write!(f, "{}", c.escape_debug())?;
            } else if c.is_control() {
                // `\u{0}`, not `\0`: "1.2\045" would read as an octal escape.
                write!(f, "{}", c.escape_unicode())?;
            } else {
                f.write_char(c)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::format;

    #[test]
    fn large_and_small_values_are_scientific_others_plain() {
        assert_eq!(format!("{}", Number(1e30)), "1e30");
        assert_eq!(format!("{}", Number(-1e9)), "-1e9");
        assert_eq!(format!("{}", Number(2.5e-7)), "2.5e-7");
        assert_eq!(format!("{}", Number(150.0)), "150");
        assert_eq!(format!("{}", Number(0.0)), "0");
        assert_eq!(format!("{}", Number(f64::NAN)), "NaN");
        assert_eq!(format!("{}", Rounded(98.0665)), "98.07");
        assert_eq!(format!("{}", Rounded(9.80665)), "9.807");
        assert_eq!(format!("{}", Rounded(0.980665)), "0.9807");
        assert_eq!(format!("{}", Rounded(1234.56)), "1235");
        assert_eq!(format!("{}", Rounded(1e30)), "1.000e30");
        assert_eq!(format!("{}", Rounded(0.0)), "0");
        assert_eq!(format!("{}", Rounded(9.99999999)), "10.00");
        assert_eq!(format!("{}", Rounded(0.0999996)), "0.1000");
    }

    #[test]
    fn control_characters_are_shown_escaped() {
        assert_eq!(format!("{}", Shown("1.2\u{0}45")), "1.2\\u{0}45");
        assert_eq!(format!("{}", Shown("a\tb é")), "a\\tb é");
    }
}
