//! Telemetry framing: CRC check value, COBS round trips, every frame type,
//! corruption, loss and overflow counted, commands bounds-checked.

use core_nav::aided::GnssFix;
use firmware::telemetry::{
    cobs_decode, cobs_encode, crc16, frame, reason, Command, Decoder, FrameError, Telemetry,
    MAX_FRAME, MAX_PAYLOAD,
};
use proptest::prelude::*;

fn encode(t: &Telemetry, seq: u16) -> Vec<u8> {
    let mut p = [0u8; MAX_PAYLOAD];
    let n = t.payload(seq, &mut p).unwrap();
    let mut f = [0u8; MAX_FRAME];
    let m = frame(&p[..n], &mut f).unwrap();
    f[..m].to_vec()
}

fn decode_all(bytes: &[u8]) -> (Vec<(u16, Telemetry)>, Decoder) {
    let mut d = Decoder::default();
    let mut out = [0u8; MAX_PAYLOAD + 2];
    let mut v = vec![];
    for b in bytes {
        if let Some(n) = d.push(*b, &mut out) {
            match Telemetry::parse(&out[..n]) {
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
            status: 0,
        },
        Telemetry::CalibrationChange {
            d_bias_radps: [-2e-5, 0.0, 4e-6],
            d_m_k: [1e-4, -3e-5, 0.0],
        },
        Telemetry::Fault {
            t_us: 40_000,
            code: 3,
            count: 7,
        },
        Telemetry::Ack {
            seq: 9,
            status: reason::BAD_RATE,
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
        let n = c.payload(1, &mut p).unwrap();
        Command::parse(&p[..n])
    };
    assert_eq!(enc(Command::Start), Ok((1, Command::Start)));
    let ok = Command::SetScheme {
        kind: 2,
        rate_dps: 30.0,
        count: 1,
    };
    assert_eq!(enc(ok), Ok((1, ok)));
    for (c, why) in [
        (
            Command::SetScheme {
                kind: 9,
                rate_dps: 30.0,
                count: 1,
            },
            reason::BAD_SCHEME,
        ),
        (
            Command::SetScheme {
                kind: 1,
                rate_dps: 0.0,
                count: 0,
            },
            reason::BAD_RATE,
        ),
        (
            Command::SetScheme {
                kind: 1,
                rate_dps: f32::NAN,
                count: 0,
            },
            reason::BAD_RATE,
        ),
        (
            Command::SetScheme {
                kind: 1,
                rate_dps: 500.0,
                count: 0,
            },
            reason::BAD_RATE,
        ),
        (
            Command::SetScheme {
                kind: 3,
                rate_dps: 30.0,
                count: 3,
            },
            reason::BAD_COUNT,
        ),
        (
            Command::SetScheme {
                kind: 2,
                rate_dps: 30.0,
                count: 0,
            },
            reason::BAD_COUNT,
        ),
    ] {
        assert_eq!(enc(c), Err(FrameError::OutOfBounds(why)), "{c:?}");
    }
    assert!(Command::parse(&[0x82]).is_err(), "truncated");
    assert!(Command::parse(&[0x82, 1, 0, 7]).is_err(), "trailing byte");

    // A GNSS fix round-trips (negative longitude and down velocity too);
    // out-of-range coordinates and zero sigmas are refused with BAD_FIX.
    let fix = GnssFix {
        lat_e7: 305_300_000,
        lon_e7: -1_143_000_000,
        height_mm: 20_000,
        v_n_mmps: [12_345, -6_789, -15],
        sigma_h_mm: 1_500,
        sigma_v_mm: 3_000,
        sigma_vel_mmps: 50,
    };
    assert_eq!(enc(Command::GnssFix(fix)), Ok((1, Command::GnssFix(fix))));
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
            sigma_vel_mmps: 0,
            ..fix
        },
    ] {
        assert_eq!(
            enc(Command::GnssFix(bad)),
            Err(FrameError::OutOfBounds(reason::BAD_FIX)),
            "{bad:?}"
        );
    }
    let mut p = [0u8; MAX_PAYLOAD];
    let n = Command::GnssFix(fix).payload(1, &mut p).unwrap();
    assert!(Command::parse(&p[..n - 1]).is_err(), "truncated fix");
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
