//! The protocol crate: CRC check value, COBS round trips, every frame
//! type, corruption, loss and overflow counted, commands bounds-checked,
//! typed codes refusing unknown values, the flash record.

use core_nav::aided::GnssFix;
use proptest::prelude::*;
use protocol::frame::{cobs_decode, cobs_encode, crc16};
use protocol::record::{BoardConfig, Record, StoredCalibration, RECORD_LEN};
use protocol::{
    CalStatus, Command, Decoder, Fault, FrameError, ResetCause, SchemeKind, Status, Telemetry,
    MAX_FRAME, MAX_PAYLOAD,
};

fn encode(t: &Telemetry, seq: u16) -> Vec<u8> {
    let mut f = [0u8; MAX_FRAME];
    let m = t.to_frame(seq, &mut f).unwrap();
    f[..m].to_vec()
}

fn decode_all(bytes: &[u8]) -> (Vec<(u16, Telemetry)>, Decoder) {
    let mut d = Decoder::default();
    let mut out = [0u8; MAX_PAYLOAD + 2];
    let mut v = vec![];
    for b in bytes {
        if let Some(n) = d.push(*b, &mut out) {
            match Telemetry::decode(&out[..n]) {
                Ok(x) => v.push(x),
                Err(_) => d.count_corrupt(),
            }
        }
    }
    (v, d)
}

fn samples() -> Vec<Telemetry> {
    vec![
        Telemetry::Imu {
            t_us: 10_000,
            gyro_radps: [1e-4, -0.0, 0.75],
            accel_mps2: [0.0, 1e-3, -9.7936],
            temp_c: 25.25,
        },
        Telemetry::Encoder {
            t_us: 20_000,
            counts: -123_456_789,
            counts_per_rev: 16_384,
        },
        Telemetry::Nav {
            t_us: 30_000,
            q_b_n: [1.0, 0.0, 0.0, 0.0],
            v_n: [0.1, -0.2, 0.0],
            p_n: [10.0, -5.0, 0.25],
        },
        Telemetry::Calibration {
            bias_radps: [1e-3, 2e-3, -3e-3],
            m_k: [1e-3, 0.0, 3e-3],
            status: CalStatus::Accepted,
        },
        Telemetry::CalibrationChange {
            d_bias_radps: [-2e-5, 0.0, 4e-6],
            d_m_k: [1e-4, -3e-5, 0.0],
        },
        Telemetry::Fault {
            t_us: 40_000,
            fault: Fault::ImuStuck,
            count: 7,
        },
        Telemetry::Ack {
            seq: 9,
            status: Status::BadRate,
        },
        Telemetry::Health {
            t_us: 50_000,
            reset: ResetCause::IndependentWatchdog,
            tick_worst: 11_077,
            tick_overruns: 0,
            nav_worst: 553_315,
            nav_overruns: 1,
            samples_dropped: 2,
            samples_duplicated: 3,
            rx_bytes: 12_248,
            rx_lost: 0,
            rx_line_errors: [1, 0, 2],
            init_stack_bytes: 13_652,
            stack_bytes: 10_452,
        },
        Telemetry::Boot {
            reset: ResetCause::Software,
            resets_in_row: 2,
            resets_total: 5,
            safe_mode: 0,
            fault_regs: [
                0x8200,
                0x4000_0000,
                0,
                0x2002_0000,
                0x0800_1234,
                0xFFFF_FFF9,
            ],
        },
        Telemetry::Config {
            lat_e7: -339_000_000,
            height_mm: 25_000,
            base_deg: [0.5, -1.0, 271.0 - 360.0],
            scheme: SchemeKind::Reciprocating,
            rate_dps: 45.0,
            count: 2,
            aided: 1,
            lon_e7: 184_000_000,
        },
    ]
}

#[test]
fn crc_check_value() {
    // CRC-16/CCITT-FALSE of "123456789" is 0x29B1 (the catalogue's check value).
    assert_eq!(crc16(b"123456789"), 0x29B1);
}

#[test]
fn every_frame_type_round_trips() {
    let mut bytes = vec![];
    for (i, t) in samples().iter().enumerate() {
        bytes.extend(encode(t, i as u16));
    }
    let (got, d) = decode_all(&bytes);
    assert_eq!(
        got,
        samples()
            .into_iter()
            .enumerate()
            .map(|(i, t)| (i as u16, t))
            .collect::<Vec<_>>()
    );
    assert_eq!(
        (
            d.stats.frames,
            d.stats.corrupt,
            d.stats.lost,
            d.stats.overflow
        ),
        (samples().len() as u64, 0, 0, 0)
    );
}

#[test]
fn corruption_loss_and_overflow_are_counted() {
    let t = samples()[0];
    let mut bytes = vec![];
    for seq in 0..100u16 {
        if seq == 10 || seq == 11 || seq == 50 {
            continue; // lost on the wire: 3
        }
        let mut f = encode(&t, seq);
        if seq == 20 || seq == 70 {
            f[5] ^= 0x40; // a flipped bit: 2 corrupt
        }
        bytes.extend(f);
    }
    // 200 bytes of noise without a zero: an overflow, then a resync.
    bytes.extend(std::iter::repeat_n(0x55u8, 200));
    bytes.push(0);
    bytes.extend(encode(&t, 100));
    let (got, d) = decode_all(&bytes);
    println!("{:?}", d.stats);
    assert_eq!(got.len(), 100 - 3 - 2 + 1);
    assert_eq!(d.stats.corrupt, 2);
    assert_eq!(d.stats.overflow, 1);
    // Lost by sequence: the 3 dropped and the 2 corrupt ones never seen.
    assert_eq!(d.stats.lost, 5);
}

#[test]
fn commands_are_bounds_checked() {
    let enc = |c: Command| {
        let mut p = [0u8; MAX_PAYLOAD];
        let n = c.encode(1, &mut p).unwrap();
        Command::parse(&p[..n])
    };
    assert_eq!(enc(Command::Start {}), Ok((1, Command::Start {})));
    let ok = Command::SetScheme {
        kind: SchemeKind::Reciprocating,
        rate_dps: 30.0,
        count: 1,
    };
    assert_eq!(enc(ok), Ok((1, ok)));
    let scheme = |kind, rate_dps, count| Command::SetScheme {
        kind,
        rate_dps,
        count,
    };
    for (c, why) in [
        (scheme(SchemeKind::Continuous, 0.0, 0), Status::BadRate),
        (scheme(SchemeKind::Continuous, f32::NAN, 0), Status::BadRate),
        (scheme(SchemeKind::Continuous, 500.0, 0), Status::BadRate),
        (scheme(SchemeKind::Indexed, 30.0, 3), Status::BadCount),
        (scheme(SchemeKind::Reciprocating, 30.0, 0), Status::BadCount),
        (
            Command::SetSite {
                lat_e7: 900_000_001,
                height_mm: 0,
            },
            Status::BadSite,
        ),
        (
            Command::SetBase {
                roll_deg: 0.0,
                pitch_deg: 91.0,
                heading_deg: 0.0,
            },
            Status::BadBase,
        ),
    ] {
        assert_eq!(enc(c), Err(FrameError::OutOfBounds(why)), "{c:?}");
    }
    // Negative latitudes and headings are sites like any other.
    let south = Command::SetSite {
        lat_e7: -339_000_000,
        height_mm: -5_000,
    };
    assert_eq!(enc(south), Ok((1, south)));
    // An unknown scheme kind on the wire is refused with BadScheme (the
    // enum cannot hold it).
    let mut p = [0u8; MAX_PAYLOAD];
    let n = ok.encode(1, &mut p).unwrap();
    p[3] = 9;
    assert_eq!(
        Command::parse(&p[..n]),
        Err(FrameError::OutOfBounds(Status::BadScheme))
    );
    assert!(Command::parse(&[0x82]).is_err(), "truncated");
    assert!(Command::parse(&[0x82, 1, 0, 7]).is_err(), "trailing byte");

    // A GNSS fix round-trips with its time of validity (negative longitude
    // and down velocity too); out-of-range coordinates and zero sigmas are
    // refused with BadFix.
    let fix = GnssFix {
        lat_e7: 305_300_000,
        lon_e7: -1_143_000_000,
        height_mm: 20_000,
        v_n_mmps: [12_345, -6_789, -15],
        sigma_h_mm: 1_500,
        sigma_v_mm: 3_000,
        sigma_vel_mmps: 50,
    };
    let at = |fix| Command::GnssFix {
        t_valid_us: 4_294_967_296 + 123,
        fix,
    };
    assert_eq!(enc(at(fix)), Ok((1, at(fix))));
    for bad in [
        GnssFix {
            lat_e7: 900_000_001,
            ..fix
        },
        GnssFix {
            lon_e7: i32::MIN,
            ..fix
        },
        GnssFix {
            sigma_h_mm: 0,
            ..fix
        },
        GnssFix {
            sigma_v_mm: 0,
            ..fix
        },
    ] {
        assert_eq!(
            enc(at(bad)),
            Err(FrameError::OutOfBounds(Status::BadFix)),
            "{bad:?}"
        );
    }
    // A velocity sigma of 0 is a position-only fix: accepted.
    let position_only = GnssFix {
        sigma_vel_mmps: 0,
        ..fix
    };
    assert!(enc(at(position_only)).is_ok());
    let n = at(fix).encode(1, &mut p).unwrap();
    assert!(Command::parse(&p[..n - 1]).is_err(), "truncated fix");
}

#[test]
fn codes_refuse_values_they_do_not_have() {
    for f in Fault::ALL {
        assert_eq!(Fault::try_from(f.code()), Ok(*f));
    }
    assert_eq!(Fault::ALL.len(), protocol::codes::FAULT_KINDS);
    assert_eq!(Fault::try_from(0), Err(0));
    assert_eq!(Fault::try_from(200), Err(200));
    assert_eq!(Status::try_from(11), Err(11));
    assert_eq!(CalStatus::try_from(0x80), Ok(CalStatus::Stored));
    assert_eq!(SchemeKind::try_from(4), Err(4));
    // A fault frame with an unknown code does not decode.
    let mut f = [0u8; MAX_PAYLOAD];
    let n = Telemetry::Fault {
        t_us: 1,
        fault: Fault::MotorStall,
        count: 1,
    }
    .encode(0, &mut f)
    .unwrap();
    f[11] = 99;
    assert_eq!(Telemetry::decode(&f[..n]), Err(FrameError::UnknownCode(99)));
}

#[test]
fn reset_causes_follow_rcc_csr() {
    // RM0090 6.3.21: a power-on sets POR, PIN and BOR; a watchdog reset
    // sets IWDG and PIN; a reset button PIN alone.
    let bit = |n: u32| 1u32 << n;
    assert_eq!(
        ResetCause::from_rcc_csr(bit(27) | bit(26) | bit(25)),
        ResetCause::PowerOn
    );
    assert_eq!(
        ResetCause::from_rcc_csr(bit(29) | bit(26)),
        ResetCause::IndependentWatchdog
    );
    assert_eq!(ResetCause::from_rcc_csr(bit(26)), ResetCause::Pin);
    assert_eq!(
        ResetCause::from_rcc_csr(bit(25) | bit(26)),
        ResetCause::BrownOut
    );
    assert_eq!(
        ResetCause::from_rcc_csr(bit(28) | bit(26)),
        ResetCause::Software
    );
    assert_eq!(ResetCause::from_rcc_csr(0), ResetCause::Unknown);
}

#[test]
fn the_flash_record_round_trips_and_any_damage_is_refused() {
    let r = Record {
        seq: 41,
        config: BoardConfig {
            lat_e7: -339_250_000,
            height_mm: 31_000,
            base_deg: [0.2, -0.4, -75.0],
            scheme: SchemeKind::Indexed,
            rate_dps: 60.0,
            count: 4,
            aided: true,
            lon_e7: 184_230_000,
        },
        calibration: Some(StoredCalibration {
            bias_radps: [1e-3, -2e-3, 3e-4],
            m_k: [4e-3, -1e-3, 2e-3],
        }),
    };
    let b = r.encode();
    assert_eq!(b.len(), RECORD_LEN);
    assert_eq!(RECORD_LEN % 4, 0, "whole flash words");
    assert_eq!(Record::decode(&b), Ok(r));
    for i in 0..RECORD_LEN {
        for bit in 0..8 {
            let mut d = b;
            d[i] ^= 1 << bit;
            assert!(Record::decode(&d).is_err(), "byte {i} bit {bit}");
        }
    }
    assert!(Record::decode(&[0xFF; RECORD_LEN]).is_err(), "blank flash");
}

proptest! {
    #[test]
    fn cobs_round_trips_and_never_emits_zero(data in proptest::collection::vec(any::<u8>(), 0..600)) {
        let mut enc = vec![0u8; data.len() + data.len() / 254 + 2];
        let n = cobs_encode(&data, &mut enc).unwrap();
        prop_assert!(!enc[..n].contains(&0));
        let mut dec = vec![0u8; data.len() + 1];
        let m = cobs_decode(&enc[..n], &mut dec).unwrap();
        prop_assert_eq!(&dec[..m], &data[..]);
    }

    #[test]
    fn cobs_matches_the_cobs_crate_on_full_blocks(
        runs in proptest::collection::vec(1usize..600, 1..4),
        fill in 1u8..=255,
    ) {
        // Runs of non-zero bytes around the 254-byte block length, split by
        // zeros: where encoders differ (a trailing empty block or not).
        let mut data = vec![];
        for (k, r) in runs.iter().enumerate() {
            let len = if k % 2 == 0 { 254 * (r % 3 + 1) } else { *r };
            data.extend(std::iter::repeat_n(fill, len));
            data.push(0);
        }
        data.pop();
        let mut ours = vec![0u8; cobs::max_encoding_length(data.len())];
        let n = cobs_encode(&data, &mut ours).unwrap();
        prop_assert_eq!(&ours[..n], &cobs::encode_vec(&data)[..]);
    }

    #[test]
    fn cobs_matches_the_cobs_crate(data in proptest::collection::vec(any::<u8>(), 0..600)) {
        // An independent implementation (jamesmunns/cobs.rs): byte for byte
        // the same encoding, and each decodes the other's.
        let mut ours = vec![0u8; cobs::max_encoding_length(data.len())];
        let n = cobs_encode(&data, &mut ours).unwrap();
        let theirs = cobs::encode_vec(&data);
        prop_assert_eq!(&ours[..n], &theirs[..]);
        let mut back = vec![0u8; data.len() + 1];
        let m = cobs_decode(&theirs, &mut back).unwrap();
        prop_assert_eq!(&back[..m], &data[..]);
        prop_assert_eq!(cobs::decode_vec(&ours[..n]).unwrap(), data);
    }

    #[test]
    fn decoder_never_panics_on_noise(noise in proptest::collection::vec(any::<u8>(), 0..2000)) {
        let (got, d) = decode_all(&noise);
        prop_assert!(got.len() as u64 <= d.stats.frames);
    }
}
