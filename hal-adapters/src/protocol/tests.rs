//! Round trips of every message, the decoder's refusals and resynchronisation, the validator's
//! refusals and the text form.

extern crate std;

use super::config::{ConfigRefusal, DeviceConfig, ReasonCode};
use super::config_text::{InText, LineError, keys_of};
use super::decoder::{Decoder, Received, Refusal};
use super::frame::{CRC, Encoder, MAX_FRAME, VERSION};
use super::messages::*;
use nav_core::alignment::machine::AlignMethod;
use nav_core::navigator::ConfigError;
use nav_core::output::Row;
use std::vec::Vec;

/// One of every message (the target's self-test's list).
pub(super) fn every_message() -> Vec<Message> {
    super::selftest::every_message().to_vec()
}

/// The frames of `messages`, one after the other.
pub(super) fn stream(messages: &[Message]) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut out = Vec::new();
    for m in messages {
        enc.append(m, &mut out).unwrap();
    }
    out
}

fn decode_all(bytes: &[u8]) -> (Vec<Result<Received, Refusal>>, Decoder) {
    let mut d = Decoder::new();
    let mut out = Vec::new();
    d.push(bytes, |r| out.push(r));
    d.finish();
    (out, d)
}

/// Equality that sees NaN payloads as equal (bitwise compare of the encoded payloads).
fn same(a: &Message, b: &Message) -> bool {
    let mut x = [0u8; 256];
    let mut y = [0u8; 256];
    let n = a.write_payload(&mut x).unwrap();
    let m = b.write_payload(&mut y).unwrap();
    a.id() == b.id() && x[..n] == y[..m]
}

#[test]
fn every_message_round_trips_with_its_declared_length() {
    let messages = every_message();
    for m in &messages {
        let mut buf = [0u8; 256];
        assert_eq!(
            m.write_payload(&mut buf).unwrap(),
            m.id().payload_len(),
            "{m:?}"
        );
    }
    let bytes = stream(&messages);
    let (out, d) = decode_all(&bytes);
    assert_eq!(out.len(), messages.len());
    for (k, (r, m)) in out.iter().zip(&messages).enumerate() {
        let r = r.as_ref().unwrap();
        assert_eq!(r.seq, k as u16);
        assert!(same(&r.message, m), "{:?} vs {m:?}", r.message);
        if !matches!(
            m,
            Message::NavSolution(NavSolution {
                row: Row::Free(_),
                ..
            })
        ) {
            assert_eq!(&r.message, m); // no NaN inside: plain equality
        }
    }
    let s = d.stats();
    assert_eq!((s.skipped_bytes, s.crc_failures, s.frames_lost), (0, 0, 0));
    assert_eq!(s.frames_total() as usize, messages.len());
    assert_eq!(s.frames[MessageId::NavSolution.index()], 2);
    // A zero only ends a frame.
    let zeros = bytes.iter().filter(|b| **b == 0).count();
    assert_eq!(zeros, messages.len());
}

#[test]
fn solution_rows_print_identically_after_the_trip() {
    let messages = every_message();
    let (out, _) = decode_all(&stream(&messages[..2]));
    for (r, m) in out.iter().zip(&messages) {
        let (Message::NavSolution(a), Message::NavSolution(b)) = (&r.as_ref().unwrap().message, m)
        else {
            panic!()
        };
        assert_eq!(std::format!("{}", a.row), std::format!("{}", b.row));
    }
}

/// A raw frame with the given header fields and payload, its CRC, COBS and delimiter.
fn raw_frame(version: u8, id: u8, seq: u16, len: u16, payload: &[u8], crc_ok: bool) -> Vec<u8> {
    let mut raw = vec_u8(&[version, id]);
    raw.extend_from_slice(&seq.to_le_bytes());
    raw.extend_from_slice(&len.to_le_bytes());
    raw.extend_from_slice(payload);
    let crc = CRC.checksum(&raw) ^ u32::from(!crc_ok);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut out = std::vec![0u8; cobs::max_encoding_length(raw.len()) + 1];
    let n = cobs::encode(&raw, &mut out);
    out.truncate(n);
    out.push(0);
    out
}

fn vec_u8(b: &[u8]) -> Vec<u8> {
    b.to_vec()
}

#[test]
fn refusals_name_their_reason_and_count_their_bytes() {
    let end = [5u8, 0, 0, 0];
    let cases: [(Vec<u8>, Refusal); 7] = [
        (raw_frame(VERSION, 6, 0, 4, &end, false), Refusal::Crc),
        (
            raw_frame(VERSION + 1, 6, 0, 4, &end, true),
            Refusal::Version(VERSION + 1),
        ),
        (
            raw_frame(VERSION, 0x7f, 0, 4, &end, true),
            Refusal::UnknownId(0x7f),
        ),
        (
            raw_frame(VERSION, 6, 0, 3, &end[..3], true),
            Refusal::Length {
                id: MessageId::EndOfRun,
                len: 3,
            },
        ),
        (
            raw_frame(VERSION, 0x11, 0, 3, &[0, 0, 99], true),
            Refusal::Payload(PayloadError::Field("reason code")),
        ),
        (std::vec![1, 1, 1, 0], Refusal::TooShort),
        (std::vec![5, 1, 0], Refusal::Cobs),
    ];
    for (bytes, want) in cases {
        let (out, d) = decode_all(&bytes);
        assert_eq!(out, std::vec![Err(want)], "{bytes:?}");
        assert_eq!(d.stats().skipped_bytes, bytes.len() as u64);
        assert_eq!(d.stats().crc_failures, u32::from(want == Refusal::Crc));
        // Every refusal has a message.
        assert!(!std::format!("{want}").is_empty());
    }
    // Too long: bounded, then ready again.
    let mut bytes = std::vec![0x55u8; MAX_FRAME + 10];
    bytes.push(0);
    let good = stream(&every_message()[6..7]);
    bytes.extend_from_slice(&good);
    let (out, d) = decode_all(&bytes);
    assert_eq!(out[0], Err(Refusal::TooLong));
    assert!(matches!(
        out[1],
        Ok(Received {
            message: Message::EndOfRun(_),
            ..
        })
    ));
    assert_eq!(d.stats().skipped_bytes, MAX_FRAME as u64 + 11);
}

#[test]
fn sequence_gaps_and_cut_off_frames_are_counted() {
    let messages = every_message();
    let frames: Vec<Vec<u8>> = {
        let mut enc = Encoder::new();
        messages
            .iter()
            .map(|m| {
                let mut buf = [0u8; MAX_FRAME];
                let n = enc.encode(m, &mut buf).unwrap();
                buf[..n].to_vec()
            })
            .collect()
    };
    // Frames 2 and 3 lost, the last cut off.
    let mut bytes: Vec<u8> = [&frames[0][..], &frames[1][..], &frames[4][..]].concat();
    let last = &frames[5];
    bytes.extend_from_slice(&last[..last.len() - 3]);
    let (out, d) = decode_all(&bytes);
    assert_eq!(out.len(), 3);
    assert_eq!(d.stats().frames_lost, 2);
    assert_eq!(d.stats().skipped_bytes, last.len() as u64 - 3);
}

/// A repeated sequence number, and one going back, are counted as out of order, not as a
/// loss of 65535 frames; the frames after them are counted from the latest number.
#[test]
fn repeated_and_going_back_sequence_numbers_are_out_of_order_not_lost() {
    // End-of-run frames (id 6, 4 bytes) with chosen sequence numbers.
    let frames = |seqs: &[u16]| -> Vec<u8> {
        seqs.iter()
            .flat_map(|&seq| raw_frame(VERSION, 6, seq, 4, &[5, 0, 0, 0], true))
            .collect()
    };
    let (out, d) = decode_all(&frames(&[0, 1, 1, 2, 0, 1, 4]));
    assert_eq!(out.len(), 7);
    assert!(out.iter().all(|r| r.is_ok()));
    // 1 repeated, 0 going back; then 4 after 1: frames 2 and 3 lost.
    assert_eq!(
        (d.stats().frames_out_of_order, d.stats().frames_lost),
        (2, 2)
    );
    // Wrapping at 65536 is a step forward, not going back.
    let (_, d) = decode_all(&frames(&[65534, 65535, 0, 2]));
    assert_eq!(
        (d.stats().frames_out_of_order, d.stats().frames_lost),
        (0, 1)
    );
}

#[test]
fn encoder_refuses_a_small_buffer_and_unknown_filter_names() {
    let m = &every_message()[0];
    let mut small = [0u8; 20];
    assert_eq!(
        Encoder::new().encode(m, &mut small),
        Err(EncodeError::BufferTooSmall)
    );
    let Message::NavSolution(mut s) = every_message()[1] else {
        panic!()
    };
    if let Row::Aided(_, c) = &mut s.row {
        c.status = "SOMETHING";
    }
    let mut buf = [0u8; MAX_FRAME];
    assert_eq!(
        Encoder::new().encode(&Message::NavSolution(s), &mut buf),
        Err(EncodeError::UnknownFilterStatus)
    );
}

#[test]
fn encoder_writes_to_an_embedded_io_writer() {
    let m = every_message();
    let mut out = [0u8; 2 * MAX_FRAME];
    let mut w: &mut [u8] = &mut out;
    let mut enc = Encoder::new();
    enc.write(&m[6], &mut w).unwrap();
    let left = w.len();
    let n = out.len() - left;
    let (dec, _) = decode_all(&out[..n]);
    assert_eq!(dec[0].as_ref().unwrap().message, m[6]);
    assert_eq!(enc.next_seq(), 1);
}

/// xorshift64* (seeded, no dependency): the protocol tests' random draws.
pub(super) struct Rng(pub(super) u64);
impl Rng {
    pub(super) fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    /// Uniform in [-1, 1).
    pub(super) fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Garbage without a zero, so it can only be skipped as whole frames: it is cut off by the
/// zero of the valid frame that follows, which that frame's own bytes do not include... so
/// garbage is always followed by a zero before a valid frame.
fn garbage(rng: &mut Rng, max: usize) -> Vec<u8> {
    let n = rng.below(max);
    (0..n).map(|_| rng.next() as u8).collect()
}

#[test]
fn random_bytes_never_panic_and_valid_frames_in_garbage_are_all_recovered() {
    let messages = every_message();
    let mut rng = Rng(0x5eed_1234_abcd_ef01);
    for case in 0..3000 {
        // Pure noise: never a panic, every byte accounted for.
        let noise = garbage(&mut rng, 600);
        let (out, d) = decode_all(&noise);
        let s = d.stats();
        let accepted = out.iter().filter(|r| r.is_ok()).count();
        assert!(
            accepted <= 1,
            "case {case}: noise decoded as {accepted} frames"
        );
        assert_eq!(s.bytes, noise.len() as u64);

        // Valid frames between garbage, each garbage run ended by a zero.
        let picks: Vec<Message> = (0..1 + rng.below(6))
            .map(|_| messages[rng.below(messages.len())])
            .collect();
        let mut enc = Encoder::new();
        let mut bytes = Vec::new();
        for m in &picks {
            bytes.extend(garbage(&mut rng, 80));
            bytes.push(0);
            enc.append(m, &mut bytes).unwrap();
        }
        let (out, _) = decode_all(&bytes);
        let got: Vec<&Received> = out.iter().filter_map(|r| r.as_ref().ok()).collect();
        assert_eq!(got.len(), picks.len(), "case {case}");
        for (r, m) in got.iter().zip(&picks) {
            assert!(same(&r.message, m));
        }

        // Mutations of a valid stream: flipped, dropped, inserted bytes. No panic; frames
        // untouched by a mutation still decode.
        let mut mutated = stream(&picks);
        for _ in 0..1 + rng.below(4) {
            let at = rng.below(mutated.len());
            match rng.below(3) {
                0 => mutated[at] ^= 1 << rng.below(8),
                1 => {
                    mutated.remove(at);
                }
                _ => mutated.insert(at, rng.next() as u8),
            }
            if mutated.is_empty() {
                break;
            }
        }
        let (out, d) = decode_all(&mutated);
        assert!(out.len() <= mutated.len());
        assert_eq!(d.stats().bytes, mutated.len() as u64);
    }
}

#[test]
fn defaults_are_valid_and_each_refusal_has_its_code() {
    let base = DeviceConfig::default();
    assert_eq!(base.validate(), Ok(()));
    let refused = |f: fn(&mut DeviceConfig)| {
        let mut c = base;
        f(&mut c);
        c.validate().unwrap_err()
    };
    let cases = super::selftest::refusal_cases();
    for (k, (f, code)) in cases.iter().enumerate() {
        let r = refused(*f);
        assert_eq!(r.code(), *code, "case {k}: {r}");
    }
    // A reflection is not a rotation.
    let r = refused(|c| c.mounting.c_s_b[2][2] = -1.0);
    assert_eq!(r, ConfigRefusal::Mounting);
    // nav-core's own message comes through.
    let r = refused(|c| c.run.lat_deg = 91.0);
    assert_eq!(r, ConfigRefusal::Run(ConfigError::Latitude(91.0)));
    assert_eq!(keys_of(&r).collect::<Vec<_>>(), ["lat-deg"]);
    // Codes round trip.
    for c in ReasonCode::ALL {
        assert_eq!(ReasonCode::from_code(c as u8), Some(c));
    }
    assert_eq!(ReasonCode::from_code(0), None);
}

/// A zero, negative, vanishing (1e-300 was taken: audit L12) or absurd gyro ARW or
/// accelerometer VRW, or a negative or absurd bias 1-sigma, is refused with the alignment's
/// reason and a message naming the figure and its range; the grades' and parts' figures and the
/// range's ends pass.
#[test]
fn noise_figures_beyond_an_imu_are_refused() {
    for (line, density) in [
        ("gyro-arw-rad-per-sqrt-s = 0", true),
        ("gyro-arw-rad-per-sqrt-s = 1e-300", true),
        ("gyro-arw-rad-per-sqrt-s = 9e-10", true),
        ("accel-vrw-mps-per-sqrt-s = 1e-300", true),
        ("gyro-arw-rad-per-sqrt-s = -1e-4", true),
        ("gyro-arw-rad-per-sqrt-s = 1e9", true),
        ("accel-vrw-mps-per-sqrt-s = 0", true),
        ("accel-vrw-mps-per-sqrt-s = 1e9", true),
        ("gyro-bias-rad-s = -1e-5", false),
        ("gyro-bias-rad-s = 1e9", false),
        ("accel-bias-mps2 = -0.01", false),
        ("accel-bias-mps2 = 1e9", false),
    ] {
        let mut c = DeviceConfig::default();
        c.apply_line(line).unwrap();
        let r = c.validate().unwrap_err();
        assert_eq!(r.code(), ReasonCode::Alignment, "{line}: {r}");
        let key = line.split(' ').next().unwrap();
        let text = std::format!("{r}");
        assert!(
            text.starts_with(key) && text.contains("more than any IMU's"),
            "{line}: {text}"
        );
        assert_eq!(text.contains("overconfident"), density, "{line}: {text}");
        assert!(keys_of(&r).any(|k| k == key), "{line}");
    }
    for line in [
        "imu-noise = mems-consumer",
        "imu-noise = fog",
        "imu-model = bmi088",
        "gyro-arw-rad-per-sqrt-s = 0.1",
        "gyro-arw-rad-per-sqrt-s = 1e-9",
        "accel-vrw-mps-per-sqrt-s = 10",
        "accel-vrw-mps-per-sqrt-s = 1e-8",
        "gyro-bias-rad-s = 0",
        "gyro-bias-rad-s = 0.1",
        "accel-bias-mps2 = 10",
    ] {
        // The inertial method: the static one refuses gyros that cannot find north (a
        // consumer part's, a 0.1 rad/s bias), whatever their range.
        let mut c = DeviceConfig::default();
        c.apply_line("align-method = inertial").unwrap();
        c.apply_line(line).unwrap();
        assert_eq!(c.validate(), Ok(()), "{line}");
    }
}

#[test]
fn text_lines_set_values_and_refuse_bad_ones() {
    let mut c = DeviceConfig::default();
    for line in [
        "# a comment",
        "",
        "lat-deg = 45.5",
        "lon-deg=7.25",
        "imu-model = icm42688",
        "align-method = inertial",
        "align-seconds = 300",
        "log-every = 4",
        "aiding = on",
        "raw-every = 0",
    ] {
        c.apply_line(line).unwrap();
    }
    assert_eq!((c.run.lat_deg, c.run.lon_deg), (45.5, 7.25));
    assert_eq!(c.imu_model, super::config::ImuModel::Icm42688);
    assert_eq!(c.run.align_method, AlignMethod::Inertial);
    assert_eq!(c.run.log_every, 4);
    assert!(c.run.aiding.is_some());
    assert_eq!(c.rates.raw_every, 0);
    assert_eq!(c.validate(), Ok(()));
    // nav-core refuses to gyrocompass with a consumer part's gyros.
    c.apply_line("imu-model = bmi088").unwrap();
    c.apply_line("align-method = fine").unwrap();
    assert_eq!(
        c.validate().map_err(|e| e.code()),
        Err(ReasonCode::Alignment)
    );
    assert_eq!(c.apply_line("lat-deg 45"), Err(LineError::NoEquals));
    assert_eq!(
        c.apply_line("colour = red"),
        Err(LineError::UnknownKey("colour"))
    );
    assert!(matches!(
        c.apply_line("lat-deg = north"),
        Err(LineError::Invalid { key: "lat-deg", .. })
    ));
    assert!(matches!(
        c.apply_line("imu-model = mpu6050"),
        Err(LineError::Invalid { .. })
    ));
    assert!(matches!(
        c.apply_line("mounting = 1,0,0"),
        Err(LineError::Invalid { .. })
    ));
    assert!(matches!(
        c.apply_line("raw-every = -1"),
        Err(LineError::Invalid { .. })
    ));
    assert!(matches!(
        c.apply_line("align-method = magic"),
        Err(LineError::Invalid {
            key: "align-method",
            ..
        })
    ));
}

/// A line's refusal names the file's key and the value given; it named nav-core's
/// command-line option ("--log-every takes a whole number"), and a `log-every` of 0 passed the
/// line to be refused by the run's check as "log_every must be at least 1".
#[test]
fn line_errors_name_the_key_and_the_value_not_an_option() {
    for (line, want) in [
        (
            "log-every = -1",
            "log-every: takes a whole number within 1 to 4294967295, got -1",
        ),
        (
            "log-every = 0",
            "log-every: takes a whole number within 1 to 4294967295, got 0",
        ),
        (
            "align-method = foo",
            "align-method: takes static, inertial, fine or sway, got foo",
        ),
        (
            "propagation-rate = 0",
            "propagation-rate: takes a rate within 1 to 1000 Hz, got 0",
        ),
        (
            "lever-arm = 1,2 # short",
            "lever-arm: takes X,Y,Z (three numbers), got 1,2",
        ),
        ("lat-deg =", "lat-deg: takes a finite number, got nothing"),
    ] {
        let mut c = DeviceConfig::default();
        let e = c.apply_line(line).unwrap_err();
        assert_eq!(std::format!("{e}"), want, "{line}");
        assert_eq!(c, DeviceConfig::default(), "{line}: applied");
    }
    let mut c = DeviceConfig::default();
    c.apply_line("log-every = 1").unwrap();
    assert_eq!(c.run.log_every, 1);
}

/// A scale-factor 1-sigma of 0 was carried as valid with aiding off (nav-core's check of the
/// other figures allows 0, "none"), while the text form's documentation says above 0 and the
/// aided filter refuses it (a zero variance): refused now with or without aiding, naming the
/// key and not the aiding line; the other figures' 0 ("none", a FOG's) and a zero bias
/// 1-sigma without aiding (biases compensated) still pass.
#[test]
fn a_zero_scale_factor_sigma_is_refused_with_or_without_aiding() {
    for aiding in ["off", "on"] {
        for line in [
            "gyro-scale-sigma = 0",
            "accel-scale-sigma = 0",
            "gyro-scale-sigma = -1e-3",
            "accel-scale-sigma = 0.2",
        ] {
            let mut c = DeviceConfig::default();
            c.apply_line(&std::format!("aiding = {aiding}")).unwrap();
            c.apply_line(line).unwrap();
            let r = c.validate().unwrap_err();
            assert_eq!(r.code(), ReasonCode::Aiding, "{line}: {r}");
            assert!(
                std::format!("{r}").contains("must be above 0 and at most 0.1"),
                "{line}: {r}"
            );
            let key = line.split(' ').next().unwrap();
            let keys: Vec<&str> = keys_of(&r).collect();
            assert!(keys.contains(&key), "{line}: {keys:?}");
            assert!(!keys.contains(&"aiding"), "{line}: {keys:?}");
        }
    }
    for line in [
        "gyro-scale-sigma = 1e-6",
        "accel-scale-sigma = 0.05",
        "gyro-cross-coupling-rad = 0",
        "accel-cross-coupling-rad = 0",
        "gyro-g-sensitivity = 0",
        "gyro-bias-rad-s = 0",
    ] {
        let mut c = DeviceConfig::default();
        c.apply_line(line).unwrap();
        assert_eq!(c.validate(), Ok(()), "{line}");
    }
}

/// An alignment refusal about one value names that value's key alone (a file's site lines
/// were listed with an IMU rate's or a window's refusal).
#[test]
fn alignment_refusals_about_one_value_name_its_key_alone() {
    for (line, key) in [
        ("imu-rate-hz = 5", "imu-rate-hz"),
        ("align-seconds = 1e9", "align-seconds"),
        ("lat-deg = 90", "lat-deg"),
        ("lever-arm = 1e3, 0, 0", "lever-arm"),
        ("lever-arm-sigma = 1e3", "lever-arm-sigma"),
    ] {
        let mut c = DeviceConfig::default();
        c.apply_line(line).unwrap();
        let r = c.validate().unwrap_err();
        assert_eq!(r.code(), ReasonCode::Alignment, "{line}: {r}");
        assert_eq!(keys_of(&r).collect::<Vec<_>>(), [key], "{line}: {r}");
    }
}

/// A refusal in the text's words names the file's key where nav-core's text names the
/// command-line option (`--lever-arm`) or the field (`log_every`).
#[test]
fn refusals_in_the_texts_words_name_its_keys() {
    let mut c = DeviceConfig::default();
    c.run.lat_deg = 45.0;
    c.apply_line("align-method = sway").unwrap();
    let r = c.validate().unwrap_err();
    let text = std::format!("{}", InText(&r));
    assert!(
        text.contains("lever-arm = X,Y,Z") && !text.contains("--"),
        "{text}"
    );
    assert_eq!(
        keys_of(&r).collect::<Vec<_>>(),
        ["align-method", "lever-arm-sigma"]
    );
    let r = ConfigRefusal::Run(ConfigError::LogEvery);
    assert_eq!(
        std::format!("{}", InText(&r)),
        "log-every must be at least 1"
    );
    // Others as they are.
    let r = ConfigRefusal::Run(ConfigError::Latitude(91.0));
    assert_eq!(std::format!("{}", InText(&r)), std::format!("{r}"));
}

#[test]
fn malformed_config_payloads_are_refused() {
    let m = Message::Config(DeviceConfig::default());
    let mut payload = [0u8; 256];
    let n = m.write_payload(&mut payload).unwrap();
    // The IMU model byte (after lat, lon, h).
    let mut bad = payload;
    bad[24] = 9;
    assert_eq!(
        Message::read_payload(MessageId::Config, &bad[..n]),
        Err(PayloadError::Field("IMU model"))
    );
    assert_eq!(
        Message::read_payload(MessageId::Config, &payload[..n]),
        Ok(m)
    );
}

/// The GNSS correlated error travels in the frame: declared (1-sigma and time) or not (the
/// default time), bit for bit; the text keys set it and a refusal of it names them (a time
/// without the error is one); an unknown aiding bit is malformed.
/// `config` validates, and its frame's payload, [`super::config::CONFIG_LEN`] bytes, reads
/// back as it.
fn assert_valid_config_round_trips(config: DeviceConfig) {
    assert_eq!(config.validate(), Ok(()));
    let m = Message::Config(config);
    let mut payload = [0u8; 256];
    let n = m.write_payload(&mut payload).unwrap();
    assert_eq!(n, super::config::CONFIG_LEN);
    assert_eq!(
        Message::read_payload(MessageId::Config, &payload[..n]),
        Ok(m)
    );
}

/// The IMU's figures beyond its noise (scale factors, cross-axis coupling, g-sensitivity) go
/// with `imu-noise` and `imu-model` (a grade's own, a part's data-sheet defaults), each can be
/// set by its key, they round-trip in the frame, and an aided configuration with one out of
/// range (or a zero scale factor, a zero variance) is refused naming the keys. Before, the
/// frame carried the four noise figures alone and the aided phase always assumed a MEMS data
/// sheet's defaults: a FOG's heading 1-sigma grew several times its error.
#[test]
fn the_imus_other_figures_follow_its_noise_and_round_trip() {
    use crate::drivers::noise::grade;
    use nav_core::navigator::SensorFigures;
    let mut c = DeviceConfig::default();
    assert_eq!(c.run.figures, SensorFigures::DATASHEET);
    c.apply_line("aiding = on").unwrap();
    c.apply_line("imu-noise = mems-consumer").unwrap();
    assert_eq!(c.run.figures, grade::MEMS_CONSUMER.figures);
    c.apply_line("imu-noise = fog").unwrap();
    assert_eq!(c.run.figures, grade::FOG.figures);
    c.apply_line("gyro-g-sensitivity = 2e-5").unwrap();
    c.apply_line("accel-cross-coupling-rad = 1e-3").unwrap();
    assert_eq!(c.run.figures.gyro_g_sensitivity, 2e-5);
    assert_eq!(c.run.figures.accel_cross_coupling_rad, 1e-3);
    assert_valid_config_round_trips(c);
    let mut part = c;
    part.apply_line("imu-model = bmi088").unwrap();
    assert_eq!(part.run.figures, SensorFigures::DATASHEET);
    for (line, key) in [
        ("gyro-scale-sigma = 0", "gyro-scale-sigma"),
        ("accel-scale-sigma = -1e-3", "accel-scale-sigma"),
        ("gyro-cross-coupling-rad = 0.5", "gyro-cross-coupling-rad"),
    ] {
        let mut bad = c;
        bad.apply_line(line).unwrap();
        let r = bad.validate().unwrap_err();
        assert_eq!(r.code(), ReasonCode::Aiding, "{line}: {r}");
        assert!(keys_of(&r).any(|k| k == key), "{line}: {r}");
    }
    // Beyond single precision (infinite as f32): refused as the line's, with the value typed.
    let mut bad = c;
    let e = bad.apply_line("gyro-g-sensitivity = 1e300").unwrap_err();
    let text = std::format!("{e}");
    assert!(
        text.starts_with("gyro-g-sensitivity:") && text.contains("1e300"),
        "{text}"
    );
}

#[test]
fn the_gnss_correlated_error_round_trips_and_its_keys_are_named() {
    let mut c = DeviceConfig::default();
    c.apply_line("gnss-correlated-time = 90").unwrap();
    c.apply_line("gnss-correlated = 1.5, 2, 4 # a code receiver")
        .unwrap();
    let a = c.run.aiding.unwrap();
    assert_eq!(a.gnss_correlated_sigma_ned_m, Some([1.5, 2.0, 4.0]));
    assert_eq!(a.gnss_correlated_time_s, 90.0);
    let mut without = c;
    without.run.aiding = Some(nav_core::navigator::AidingConfig {
        gnss_correlated_sigma_ned_m: None,
        gnss_correlated_time_s: nav_core::navigator::config::DEFAULT_GNSS_CORRELATION_TIME_S,
        ..a
    });
    // A time of its own without the error is refused (it would be silently ignored).
    let mut lone = DeviceConfig::default();
    lone.apply_line("gnss-correlated-time = 30").unwrap();
    let r = lone.validate().unwrap_err();
    assert_eq!(r.code(), ReasonCode::Aiding, "{r}");
    assert!(
        std::format!("{r}").contains("gnss-correlated-time needs gnss-correlated"),
        "{r}"
    );
    for config in [c, without] {
        assert_valid_config_round_trips(config);
    }
    let mut bad = c;
    bad.apply_line("gnss-correlated-time = 0.5").unwrap();
    let r = bad.validate().unwrap_err();
    assert_eq!(r.code(), ReasonCode::Aiding, "{r}");
    assert!(
        std::format!("{r}").contains("correlation time must be 1 s to 86,400 s"),
        "{r}"
    );
    assert!(keys_of(&r).any(|k| k == "gnss-correlated-time"));
    assert!(keys_of(&r).any(|k| k == "gnss-correlated"));
    assert!(matches!(
        c.apply_line("gnss-correlated = 1, 2"),
        Err(LineError::Invalid {
            key: "gnss-correlated",
            ..
        })
    ));
    // The aiding bits' byte (after the solution rate): bit 4 is no flag.
    let m = Message::Config(c);
    let mut payload = [0u8; 256];
    let n = m.write_payload(&mut payload).unwrap();
    payload[162] |= 1 << 4;
    assert_eq!(
        Message::read_payload(MessageId::Config, &payload[..n]),
        Err(PayloadError::Field("aiding bits"))
    );
}

/// A configuration frame of protocol version 1 (201 bytes, without the GNSS correlated
/// error) is refused by its version, with a message naming both versions, not misread; its
/// old length under the new version is refused by length.
#[test]
fn a_version_1_config_frame_is_refused_by_its_version() {
    let m = Message::Config(DeviceConfig::default());
    let mut payload = [0u8; 256];
    let n = m.write_payload(&mut payload).unwrap();
    // Version 1's layout: the same fields without the correlated error's 32 bytes at 195 and
    // the IMU's other figures' 20 at 233.
    assert_eq!(n, 253);
    let old: Vec<u8> = [&payload[..195], &payload[227..233]].concat();
    assert_eq!(old.len(), 201);
    for (version, want) in [
        (1, Refusal::Version(1)),
        // Version 2 had this config frame; its status frames lacked IMU_LOST.
        (2, Refusal::Version(2)),
        // Version 3 had version 4's config frame; its status frames lacked NEAR_POLE.
        (3, Refusal::Version(3)),
        // Version 4's config frame lacked the IMU's other figures.
        (4, Refusal::Version(4)),
        (
            VERSION,
            Refusal::Length {
                id: MessageId::Config,
                len: 201,
            },
        ),
    ] {
        let mut d = Decoder::new();
        let mut out = Vec::new();
        d.push_config(&raw_frame(version, 0x10, 0, 201, &old, true), |r| {
            out.push(r)
        });
        assert_eq!(out, std::vec![Err(want)]);
    }
    assert_eq!(
        std::format!("{}", Refusal::Version(1)),
        std::format!("unknown protocol version 1 (this is {VERSION})")
    );
    assert_eq!(VERSION, 5);
}

mod properties {
    use super::*;
    use proptest::collection::vec;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        /// No byte sequence panics the decoder; every byte is counted, and what it refuses
        /// is at most what it was given.
        #[test]
        fn any_bytes_decode_without_panic(bytes in vec(any::<u8>(), 0..1500)) {
            let (out, d) = decode_all(&bytes);
            let s = d.stats();
            prop_assert_eq!(s.bytes, bytes.len() as u64);
            prop_assert!(s.skipped_bytes <= s.bytes);
            let refused = out.iter().filter(|r| r.is_err()).count() as u32;
            prop_assert_eq!(refused, s.crc_failures + s.other_refusals);
        }

        /// Valid frames between runs of garbage (each ended by a zero) are all recovered, in
        /// order, and exactly the garbage is skipped.
        #[test]
        fn frames_in_garbage_are_recovered(
            parts in vec((vec(1u8..=255, 0..120), 0usize..10), 1..8),
        ) {
            let messages = every_message();
            let mut enc = Encoder::new();
            let mut bytes = Vec::new();
            let mut junk = 0u64;
            let mut sent = Vec::new();
            for (garbage, pick) in &parts {
                if !garbage.is_empty() {
                    bytes.extend_from_slice(garbage);
                    bytes.push(0);
                    junk += garbage.len() as u64 + 1;
                }
                let m = messages[pick % messages.len()];
                enc.append(&m, &mut bytes).unwrap();
                sent.push(m);
            }
            let (out, d) = decode_all(&bytes);
            let got: Vec<&Received> = out.iter().filter_map(|r| r.as_ref().ok()).collect();
            // Garbage may decode as a frame only with a CRC match (2^-32 per run): none here.
            prop_assert_eq!(got.len(), sent.len());
            for (r, m) in got.iter().zip(&sent) {
                prop_assert!(same(&r.message, m));
            }
            prop_assert_eq!(d.stats().skipped_bytes, junk);
            prop_assert_eq!(d.stats().frames_lost, 0);
        }
    }
}

#[test]
fn aiding_events_of_the_filter_answers() {
    use nav_core::ins_filter::aiding::AidResult;
    let e = AidingEvent::of(5, Aid::Position, &AidResult::Accepted { nis: 2.5f64 });
    assert_eq!((e.outcome, e.nis), (AidOutcome::Accepted, 2.5));
    let e = AidingEvent::of(5, Aid::Velocity, &AidResult::Rejected { nis: 40.0f32 });
    assert_eq!(
        (e.aid, e.outcome, e.nis),
        (Aid::Velocity, AidOutcome::RejectedGate, 40.0)
    );
    let e = AidingEvent::of(5, Aid::Position, &AidResult::<f64>::Invalid);
    assert_eq!(e.outcome, AidOutcome::Invalid);
    assert!(e.nis.is_nan());
}

/// Frames shorter than 254 bytes take exactly one COBS byte and the delimiter more than the
/// raw frame: the wire sizes `docs/protocol.md` gives for the bandwidth, printed.
#[test]
fn wire_sizes_are_payload_plus_twelve() {
    let mut total_at_defaults = 0;
    for m in every_message() {
        let mut buf = [0u8; MAX_FRAME];
        let n = Encoder::new().encode(&m, &mut buf).unwrap();
        assert_eq!(n, m.id().payload_len() + 6 + 4 + 2, "{:?}", m.id());
        // Default rates at 400 Hz: raw every sample, a solution every 40, health every 400.
        total_at_defaults += match m.id() {
            MessageId::RawIncrements => 400 * n,
            MessageId::NavSolution
                if matches!(
                    m,
                    Message::NavSolution(NavSolution {
                        row: Row::Aided(..),
                        ..
                    })
                ) =>
            {
                10 * n
            }
            MessageId::Health => n,
            _ => 0,
        };
    }
    std::println!("stream at the default rates: {total_at_defaults} bytes/s");
    assert_eq!(total_at_defaults, 400 * 58 + 10 * 132 + 103);
}

#[test]
fn the_target_self_checks_pass_on_the_host() {
    for (name, check) in super::selftest::CHECKS {
        if let Err(e) = check() {
            panic!("{name}: {e}");
        }
    }
}
