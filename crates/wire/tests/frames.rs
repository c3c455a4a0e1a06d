//! Round trips of every message, golden encodings, corrupted-frame recovery, split/merged
//! chunk delivery, and "no panic" on arbitrary bytes with arbitrary chunking.

use proptest::prelude::*;
use wiical_core::terms::EFFECT_FLOATS;
use wiical_core::{Calibration, Effects};
use wiical_wire::*;

fn f() -> impl Strategy<Value = f32> {
    -1.0e6f32..1.0e6f32
}

fn v3() -> impl Strategy<Value = [f32; 3]> {
    [f(), f(), f()]
}

fn effects() -> impl Strategy<Value = WireEffects> {
    prop::collection::vec(f(), EFFECT_FLOATS)
        .prop_map(|v| WireEffects(std::array::from_fn(|i| v[i])))
}

fn calibration() -> impl Strategy<Value = WireCalibration> {
    (v3(), [v3(), v3(), v3()], effects()).prop_map(|(bias, matrix, effects)| WireCalibration {
        bias,
        matrix,
        effects,
    })
}

fn gyro_calibration() -> impl Strategy<Value = WireGyroCalibration> {
    (v3(), [v3(), v3(), v3()]).prop_map(|(bias, matrix)| WireGyroCalibration { bias, matrix })
}

fn sample() -> impl Strategy<Value = Sample> {
    (
        any::<u32>(),
        any::<[u16; 3]>(),
        v3(),
        any::<u16>(),
        any::<[u8; 2]>(),
    )
        .prop_map(|(seq, raw, corrected, buttons, stick)| Sample {
            seq,
            raw,
            corrected,
            buttons,
            stick,
        })
}

fn request() -> impl Strategy<Value = Request> {
    prop_oneof![
        (any::<u16>(), any::<u32>()).prop_map(|(protocol_version, schema_key)| {
            Request::Hello(Hello {
                protocol_version,
                schema_key,
            })
        }),
        Just(Request::GetCalibration),
        calibration().prop_map(Request::PutCalibration),
        Just(Request::CommitCalibration),
        any::<u16>().prop_map(|rate_divider| Request::StartStream { rate_divider }),
        Just(Request::StopStream),
        Just(Request::GetStatus),
        Just(Request::EndSession),
        Just(Request::GetBackgroundStatus),
        (
            (any::<bool>(), any::<bool>()),
            (any::<u32>(), any::<u8>(), any::<u32>())
        )
            .prop_map(|((adopt, replace_uploaded), (commit, per_day, fit))| {
                Request::SetBackground(BackgroundSettings {
                    adopt,
                    replace_uploaded,
                    commit_interval_s: commit,
                    commits_per_day: per_day,
                    fit_interval_ms: fit,
                })
            }),
        Just(Request::GetGyroCalibration),
        gyro_calibration().prop_map(Request::PutGyroCalibration),
        Just(Request::CommitGyroCalibration),
    ]
}

fn refusal() -> impl Strategy<Value = RefusalReport> {
    prop_oneof![
        (any::<u8>(), any::<u8>()).prop_map(|(needed, got)| RefusalReport::Coverage(
            CoverageGapReport::TooFewBins { needed, got }
        )),
        (0u8..3, any::<bool>()).prop_map(|(axis, positive)| RefusalReport::Coverage(
            CoverageGapReport::MissingDirection { axis, positive }
        )),
        (f(), f()).prop_map(|(candidate_mg, live_mg)| RefusalReport::NotBetter {
            candidate_mg,
            live_mg
        }),
        any::<u32>().prop_map(|wait_s| RefusalReport::Budget { wait_s }),
        Just(RefusalReport::HostCalibration),
        Just(RefusalReport::Interrupted),
    ]
}

fn background() -> impl Strategy<Value = BackgroundReport> {
    let candidate = (f(), f(), f(), any::<bool>(), any::<u8>()).prop_map(|(c, l, r, full, n)| {
        CandidateReport {
            candidate_mg: c,
            live_mg: l,
            fit_rms_mg: r,
            full_model: full,
            temperature: !full,
            training_bins: n,
            heldout_bins: n / 4,
        }
    });
    (
        (any::<u32>(), any::<u32>(), any::<u64>(), any::<bool>()),
        proptest::collection::vec(any::<u8>(), 0..=BACKGROUND_BINS),
        proptest::option::of(f()),
        proptest::option::of(candidate),
        proptest::option::of((any::<u32>(), f(), f())),
        proptest::option::of(refusal()),
    )
        .prop_map(
            |((play_s, moments, fresh, adopt), bins, t, c, a, r)| BackgroundReport {
                phase: BackgroundPhase::Fitting,
                settings: BackgroundSettings {
                    adopt,
                    replace_uploaded: !adopt,
                    commit_interval_s: play_s,
                    commits_per_day: fresh as u8,
                    fit_interval_ms: moments,
                },
                origin: CalibrationOrigin::Background,
                play_s,
                moments,
                bins_filled: fresh.count_ones() as u8,
                fresh_bins: fresh,
                bin_moments: heapless::Vec::from_slice(&bins).unwrap(),
                temperature_c: t,
                coverage_gap: None,
                candidate: c,
                last_adoption: a.map(|(at_s, before_mg, after_mg)| AdoptionReport {
                    at_s,
                    before_mg,
                    after_mg,
                }),
                last_refusal: r,
            },
        )
}

/// The largest background report: every option present, every varint at its longest.
fn largest_background() -> BackgroundReport {
    BackgroundReport {
        phase: BackgroundPhase::Committing,
        settings: BackgroundSettings {
            adopt: true,
            replace_uploaded: true,
            commit_interval_s: u32::MAX,
            commits_per_day: u8::MAX,
            fit_interval_ms: u32::MAX,
        },
        origin: CalibrationOrigin::Host,
        play_s: u32::MAX,
        moments: u32::MAX,
        bins_filled: u8::MAX,
        fresh_bins: u64::MAX,
        bin_moments: heapless::Vec::from_slice(&[255; BACKGROUND_BINS]).unwrap(),
        temperature_c: Some(f32::MAX),
        coverage_gap: Some(CoverageGapReport::TooFewBins {
            needed: 255,
            got: 255,
        }),
        candidate: Some(CandidateReport {
            candidate_mg: 1.0,
            live_mg: 1.0,
            fit_rms_mg: 1.0,
            full_model: true,
            temperature: true,
            training_bins: 255,
            heldout_bins: 255,
        }),
        last_adoption: Some(AdoptionReport {
            at_s: u32::MAX,
            before_mg: 1.0,
            after_mg: 1.0,
        }),
        last_refusal: Some(RefusalReport::MonitorOnly {
            candidate_mg: 1.0,
            live_mg: 1.0,
        }),
    }
}

fn status() -> impl Strategy<Value = AdapterStatus> {
    let outcome = prop_oneof![
        (f(), any::<u8>()).prop_map(|(rms_mg, poses)| SelfCalOutcome::Done { rms_mg, poses }),
        "[ -~]{0,96}".prop_map(|m| SelfCalOutcome::Failed {
            message: heapless::String::try_from(m.as_str()).unwrap()
        }),
    ];
    (
        0usize..8,
        any::<u8>(),
        proptest::option::of(outcome),
        any::<u32>(),
        f(),
        any::<bool>(),
    )
        .prop_map(
            |(p, poses, last_result, stale_moments, stale_rms_mg, s)| AdapterStatus {
                phase: PHASES[p],
                poses,
                last_result,
                stale_moments,
                stale_rms_mg,
                recalibration_suggested: s,
            },
        )
}

const PHASES: [SelfCalPhase; 8] = [
    SelfCalPhase::Off,
    SelfCalPhase::Arming,
    SelfCalPhase::WaitingForStillness,
    SelfCalPhase::PoseTaken,
    SelfCalPhase::MoveToNewOrientation,
    SelfCalPhase::Committing,
    SelfCalPhase::Done,
    SelfCalPhase::Failed,
];

fn response() -> impl Strategy<Value = Response> {
    prop_oneof![
        (any::<u16>(), any::<u32>(), "[ -~]{0,32}", any::<[u8; 8]>()).prop_map(
            |(protocol_version, schema_key, s, device_id)| Response::Hello(HelloResponse {
                protocol_version,
                schema_key,
                firmware_version: heapless::String::try_from(s.as_str()).unwrap(),
                device_id,
            })
        ),
        (0usize..ErrorCode::ALL.len()).prop_map(|i| Response::Error(ErrorCode::ALL[i])),
        Just(Response::Ack),
        (
            calibration(),
            proptest::option::of(calibration()),
            any::<bool>(),
            prop_oneof![
                Just(BootRecord::Empty),
                Just(BootRecord::Loaded),
                Just(BootRecord::StorageError),
                Just(BootRecord::Rejected(RecordProblem::BadCrc)),
                any::<u16>()
                    .prop_map(|v| BootRecord::Rejected(RecordProblem::UnsupportedVersion(v))),
            ],
            any::<u16>()
        )
            .prop_map(|(live, staged, stored, boot, damaged_records)| {
                Response::Calibration(CalibrationState {
                    live,
                    staged,
                    stored,
                    boot,
                    damaged_records,
                })
            }),
        any::<u32>().prop_map(|sample_rate_mhz| Response::StreamStarted { sample_rate_mhz }),
        sample().prop_map(Response::Sample),
        (
            any::<u32>(),
            any::<[u16; 3]>(),
            0u8..8,
            proptest::option::of(v3())
        )
            .prop_map(|(seq, raw, slow, corrected)| {
                Response::GyroSample(GyroSample {
                    seq,
                    raw,
                    slow,
                    corrected,
                })
            }),
        status().prop_map(Response::Status),
        background().prop_map(Response::Background),
        (
            proptest::option::of(gyro_calibration()),
            proptest::option::of(gyro_calibration()),
            any::<bool>()
        )
            .prop_map(|(live, staged, loaded)| {
                Response::GyroCalibration(GyroCalibrationState {
                    live,
                    staged,
                    boot: if loaded {
                        BootRecord::Loaded
                    } else {
                        BootRecord::Rejected(RecordProblem::BadCrc)
                    },
                })
            }),
    ]
}

fn frame_of<T: serde::Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    encode_frame(msg, &mut buf).unwrap().to_vec()
}

fn decode_all<T: serde::de::DeserializeOwned>(
    dec: &mut DefaultFrameDecoder,
    chunks: &[&[u8]],
) -> Vec<Result<T, FrameError>> {
    let mut out = Vec::new();
    for c in chunks {
        out.extend(dec.feed::<T>(c));
    }
    out
}

fn example_calibration() -> WireCalibration {
    let mut c = Calibration::from_inverse(
        &wiical_core::Mat3::new(
            1.0 / 106.0,
            0.0,
            0.001,
            0.0,
            1.0 / 105.0,
            0.0,
            -0.002,
            0.0,
            1.0 / 111.0,
        ),
        &wiical_core::Vec3::new(521.0, 521.0, 521.0),
    );
    c.effects.temp_ref_c = 25.0;
    c.effects.cubic = [0.01, 0.0, -0.02];
    c.into()
}

fn hello_response() -> HelloResponse {
    HelloResponse {
        protocol_version: PROTOCOL_VERSION,
        schema_key: SCHEMA_KEY,
        firmware_version: heapless::String::try_from("0.1.0+g1234abc").unwrap(),
        device_id: [0xE6, 0x61, 0x38, 0x52, 0x83, 0x4C, 0x2A, 0x2F],
    }
}

#[test]
fn every_message_round_trips() {
    let reqs = [
        Request::Hello(Hello::CURRENT),
        Request::GetCalibration,
        Request::PutCalibration(example_calibration()),
        Request::CommitCalibration,
        Request::StartStream { rate_divider: 4 },
        Request::StopStream,
        Request::EndSession,
    ];
    let mut stream = Vec::new();
    for r in &reqs {
        stream.extend(frame_of(r));
    }
    let mut dec = DefaultFrameDecoder::new();
    let got: Vec<Request> = decode_all(&mut dec, &[&stream])
        .into_iter()
        .map(Result::unwrap)
        .collect();
    assert_eq!(got, reqs);

    let resps = [
        Response::Hello(hello_response()),
        Response::Error(ErrorCode::NothingStaged),
        Response::Ack,
        Response::Calibration(CalibrationState {
            live: example_calibration(),
            staged: None,
            stored: true,
            boot: BootRecord::Rejected(RecordProblem::BadCrc),
            damaged_records: 2,
        }),
        Response::StreamStarted {
            sample_rate_mhz: 100_000,
        },
        Response::Sample(Sample {
            seq: 7,
            raw: [695, 511, 494],
            corrected: [0.97, 0.05, 0.0],
            buttons: Sample::BUTTON_C,
            stick: [129, 129],
        }),
    ];
    let mut stream = Vec::new();
    for r in &resps {
        stream.extend(frame_of(r));
    }
    let got: Vec<Response> = decode_all(&mut dec, &[&stream])
        .into_iter()
        .map(Result::unwrap)
        .collect();
    assert_eq!(got, resps);
}

#[test]
fn calibration_conversions_are_lossless() {
    let core = Calibration {
        bias: [1.0, 2.0, 3.0],
        matrix: [[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 10.0]],
        effects: Effects {
            quadratic: [0.1, 0.2, 0.3],
            cubic: [0.4, 0.5, 0.6],
            bias_drift: [0.7, 0.8, 0.9],
            temp_ref_c: 21.5,
            bias_temp: [1.1, 1.2, 1.3],
            scale_temp: [1.4, 1.5, 1.6],
            cross_quadratic: std::array::from_fn(|i| std::array::from_fn(|j| (10 * i + j) as f32)),
            cross_cubic: std::array::from_fn(|i| std::array::from_fn(|j| -((10 * i + j) as f32))),
        },
    };
    let wire: WireCalibration = core.into();
    // The wire order: 3 + 3 + 3 + 1 + 3 coefficients before scale_temp, 15 cross-quadratic
    // ones (row 2, column 4 is the last) before the cross-cubic ones.
    assert_eq!(wire.effects.0[13..16], [1.4, 1.5, 1.6]);
    assert_eq!(wire.effects.0[16 + 14], 24.0);
    assert_eq!(wire.effects.0[31 + 9 + 8], -18.0);
    assert_eq!(Calibration::from(wire), core);
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// Pins the postcard bytes (before CRC/COBS) of one instance of each message. If this
/// fails you changed the wire format: update `SCHEMA` (the key changes) and
/// `PROTOCOL_VERSION`, then these expected strings.
#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn golden_encodings() {
    let enc = |m: &dyn erased::Ser| m.bytes();
    assert_eq!(
        hex(&enc(&Request::Hello(Hello {
            protocol_version: 1,
            schema_key: 0x01020304
        }))),
        "000184868808"
    );
    assert_eq!(hex(&enc(&Request::GetCalibration)), "01");
    assert_eq!(hex(&enc(&Request::CommitCalibration)), "03");
    assert_eq!(
        hex(&enc(&Request::StartStream { rate_divider: 300 })),
        "04ac02"
    );
    assert_eq!(hex(&enc(&Request::StopStream)), "05");
    assert_eq!(hex(&enc(&Request::EndSession)), "07");
    let cal = WireCalibration {
        bias: [1.0, 0.0, 0.0],
        matrix: [[0.0; 3]; 3],
        effects: WireEffects::default(),
    };
    // Protocol 3: 28 floats as in protocol 2, then the 15 + 27 cross coefficients.
    let cal_hex = format!("0000803f{}", "00".repeat(4 * (2 + 9 + 16 + 42)));
    assert_eq!(
        hex(&enc(&Request::PutCalibration(cal))),
        format!("02{cal_hex}")
    );
    let mut cross = cal;
    let mut e = Effects::from(cross.effects);
    e.cross_quadratic[0][0] = 1.0;
    e.cross_cubic[2][8] = 2.0;
    cross.effects = e.into();
    assert_eq!(
        hex(&enc(&Request::PutCalibration(cross))),
        format!(
            "020000803f{}0000803f{}00000040",
            "00".repeat(4 * (2 + 9 + 16)),
            "00".repeat(4 * 40)
        )
    );
    let hr = HelloResponse {
        protocol_version: 1,
        schema_key: 2,
        firmware_version: heapless::String::try_from("v1").unwrap(),
        device_id: [1, 2, 3, 4, 5, 6, 7, 8],
    };
    assert_eq!(
        hex(&enc(&Response::Hello(hr))),
        "0001020276310102030405060708"
    );
    assert_eq!(
        hex(&enc(&Response::Error(ErrorCode::SchemaMismatch))),
        "0101"
    );
    assert_eq!(hex(&enc(&Response::Error(ErrorCode::Internal))), "010a");
    assert_eq!(hex(&enc(&Response::Ack)), "02");
    assert_eq!(
        hex(&enc(&Response::Calibration(CalibrationState {
            live: cal,
            staged: None,
            stored: true,
            boot: BootRecord::Rejected(RecordProblem::UnsupportedVersion(3)),
            damaged_records: 1,
        }))),
        // Option None, true, Rejected (2) of UnsupportedVersion (2) 3, then 1 (varint).
        format!("03{cal_hex}000102020301")
    );
    assert_eq!(
        hex(&enc(&Response::StreamStarted { sample_rate_mhz: 1 })),
        "0401"
    );
    let s = Sample {
        seq: 1,
        raw: [1, 2, 3],
        corrected: [0.0; 3],
        buttons: 3,
        stick: [4, 5],
    };
    assert_eq!(
        hex(&enc(&Response::Sample(s))),
        format!("0501010203{}030405", "00".repeat(12))
    );
    // Protocol 2 additions, at the end of each enum.
    assert_eq!(hex(&enc(&Request::GetStatus)), "06");
    assert_eq!(
        hex(&enc(&Response::Error(ErrorCode::ImplausibleCalibration))),
        "010b"
    );
    let st = AdapterStatus {
        phase: SelfCalPhase::Failed,
        poses: 5,
        last_result: Some(SelfCalOutcome::Failed {
            message: heapless::String::try_from("no").unwrap(),
        }),
        stale_moments: 300,
        stale_rms_mg: 1.0,
        recalibration_suggested: true,
    };
    // 06 Status, 07 Failed, 05 poses, 01 Some, 01 Failed, 02 "no", varint 300, 1.0f32, true.
    assert_eq!(
        hex(&enc(&Response::Status(st))),
        "0607050101026e6fac020000803f01"
    );
    // Protocol 5 additions, at the end of each enum.
    assert_eq!(hex(&enc(&Request::GetBackgroundStatus)), "08");
    // Protocol 6: the settings' budget (1800 s = varint 88 0e, 8 per day) and fit interval
    // (60,000 ms = varint e0 d4 03) after the two flags.
    let settings = BackgroundSettings {
        adopt: true,
        replace_uploaded: false,
        commit_interval_s: 1800,
        commits_per_day: 8,
        fit_interval_ms: 60_000,
    };
    let set = Request::SetBackground(settings);
    assert_eq!(hex(&enc(&set)), "090100880e08e0d403");
    let bg = BackgroundReport {
        phase: BackgroundPhase::Fitting,
        settings,
        origin: CalibrationOrigin::Host,
        play_s: 300,
        moments: 5,
        bins_filled: 2,
        fresh_bins: 3,
        bin_moments: heapless::Vec::from_slice(&[1, 2]).unwrap(),
        temperature_c: Some(1.0),
        coverage_gap: None,
        candidate: None,
        last_adoption: Some(AdoptionReport {
            at_s: 1,
            before_mg: 1.0,
            after_mg: 1.0,
        }),
        last_refusal: Some(RefusalReport::Budget { wait_s: 300 }),
    };
    // 07 Background, 01 Fitting, 01 00 88 0e 08 e0 d4 03 settings, 03 Host, varint 300, 05,
    // 02, varint 3,
    // vec [1, 2], Some 1.0, None, None, Some {1, 1.0, 1.0}, Some Budget (07) varint 300.
    assert_eq!(
        hex(&enc(&Response::Background(bg))),
        "07010100880e08e0d40303ac02050203020102010000803f000001010000803f0000803f0107ac02"
    );
    // Protocol 7 additions, at the end of each enum: the gyro calibration, 12 floats (bias,
    // then K row-major) and no effect terms (the g-sensitivity stays on the host).
    assert_eq!(hex(&enc(&Request::GetGyroCalibration)), "0a");
    assert_eq!(hex(&enc(&Request::CommitGyroCalibration)), "0c");
    let gyro = WireGyroCalibration {
        bias: [1.0, 0.0, 0.0],
        matrix: [[0.0, 0.0, 2.0], [0.0; 3], [0.0; 3]],
    };
    let gyro_hex = format!(
        "0000803f{}00000040{}",
        "00".repeat(4 * 4),
        "00".repeat(4 * 6)
    );
    assert_eq!(
        hex(&enc(&Request::PutGyroCalibration(gyro))),
        format!("0b{gyro_hex}")
    );
    // 08 GyroCalibration, Some live, None staged, Rejected (2) of BadCrc (3).
    assert_eq!(
        hex(&enc(&Response::GyroCalibration(GyroCalibrationState {
            live: Some(gyro),
            staged: None,
            boot: BootRecord::Rejected(RecordProblem::BadCrc),
        }))),
        format!("0801{gyro_hex}000203")
    );
    // Protocol 8 addition, at the end of Response: 09 GyroSample, seq 300 (varint ac 02), raw
    // 8192 (varint 80 40), 1, 16383 (ff 7f), slow 0b101, Some 1.0, 0.0, -2.0.
    assert_eq!(
        hex(&enc(&Response::GyroSample(GyroSample {
            seq: 300,
            raw: [8192, 1, 16383],
            slow: GyroSample::SLOW_YAW | GyroSample::SLOW_PITCH,
            corrected: Some([1.0, 0.0, -2.0]),
        }))),
        "09ac02804001ff7f05010000803f00000000000000c0"
    );
    assert_eq!(
        hex(&enc(&Response::GyroSample(GyroSample {
            seq: 0,
            raw: [0; 3],
            slow: 0,
            corrected: None,
        }))),
        "09000000000000"
    );
}

/// Tiny object-safe helper so the golden test can take any message.
mod erased {
    pub trait Ser {
        fn bytes(&self) -> Vec<u8>;
    }
    impl<T: serde::Serialize> Ser for T {
        fn bytes(&self) -> Vec<u8> {
            let mut buf = [0u8; 512];
            postcard::to_slice(self, &mut buf).unwrap().to_vec()
        }
    }
}

#[test]
fn frame_layout_is_cobs_of_body_and_le_crc() {
    let msg = Response::Error(ErrorCode::BadFrame);
    let frame = frame_of(&msg);
    assert_eq!(*frame.last().unwrap(), 0, "terminated by 0x00");
    assert!(!frame[..frame.len() - 1].contains(&0), "no 0x00 inside");
    let mut inner = frame[..frame.len() - 1].to_vec();
    let n = cobs::decode_in_place(&mut inner).unwrap();
    let body = postcard::to_slice(&msg, &mut [0u8; 16]).unwrap().to_vec();
    // Independent CRC-16/IBM-3740 (CCITT-FALSE) bit-by-bit reference.
    let mut crc: u16 = 0xFFFF;
    for &b in &body {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    let mut expected = body.clone();
    expected.extend_from_slice(&crc.to_le_bytes());
    assert_eq!(&inner[..n], &expected[..]);
    // Cross-check against postcard's own CRC deserialization flavor.
    let back: Response =
        postcard::de_flavors::crc::from_bytes_u16(&inner[..n], frame::CRC16.digest()).unwrap();
    assert_eq!(back, msg);
}

#[test]
fn largest_messages_fit() {
    // Worst cases: all varints at their longest, full strings, both calibrations.
    let cal = WireCalibration {
        bias: [f32::MAX; 3],
        matrix: [[f32::MIN; 3]; 3],
        effects: WireEffects([1.0; EFFECT_FLOATS]),
    };
    let big = [
        Response::Calibration(CalibrationState {
            live: cal,
            staged: Some(cal),
            stored: true,
            boot: BootRecord::Rejected(RecordProblem::UnsupportedVersion(u16::MAX)),
            damaged_records: u16::MAX,
        }),
        Response::Hello(HelloResponse {
            protocol_version: u16::MAX,
            schema_key: u32::MAX,
            firmware_version: heapless::String::try_from("x".repeat(32).as_str()).unwrap(),
            device_id: [0xFF; 8],
        }),
        Response::Sample(Sample {
            seq: u32::MAX,
            raw: [u16::MAX; 3],
            corrected: [f32::MAX; 3],
            buttons: u16::MAX,
            stick: [255; 2],
        }),
        Response::Background(largest_background()),
    ];
    for m in &big {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let f = encode_frame(m, &mut buf).unwrap();
        // The decoder's buffer holds the frame without its delimiter.
        assert!(f.len() - 1 <= MAX_FRAME_LEN);
        let mut dec = DefaultFrameDecoder::new();
        let got: Vec<_> = dec.feed::<Response>(f).collect();
        assert_eq!(got, vec![Ok(m.clone())]);
    }
    let mut small = [0u8; 8];
    assert_eq!(
        encode_frame(&big[0], &mut small).unwrap_err(),
        FrameError::BufferTooSmall
    );
}

#[test]
fn hello_handshake_checks_keys() {
    assert_eq!(Hello::CURRENT.check(), Ok(()));
    assert_eq!(hello_response().check(), Ok(()));
    let other = Hello {
        protocol_version: 2,
        schema_key: SCHEMA_KEY ^ 1,
    };
    assert_eq!(other.check(), Err(ErrorCode::SchemaMismatch));
    assert_eq!(
        HelloResponse {
            schema_key: 0,
            ..hello_response()
        }
        .check(),
        Err(ErrorCode::SchemaMismatch)
    );
}

#[test]
fn error_codes_are_explicit_and_unknown_codes_are_rejected() {
    for (i, c) in ErrorCode::ALL.iter().enumerate() {
        assert_eq!(*c as u8, i as u8 + 1);
        assert_eq!(ErrorCode::try_from(*c as u8), Ok(*c));
    }
    assert!(ErrorCode::try_from(0).is_err());
    assert!(ErrorCode::try_from(200).is_err());
    // A frame carrying an unknown code is a Deserialize error, not a panic or wrong code.
    let body = [1u8, 200];
    let crc = frame::CRC16.checksum(&body).to_le_bytes();
    let raw = [body[0], body[1], crc[0], crc[1]];
    let mut enc = [0u8; 8];
    let n = cobs::encode(&raw, &mut enc);
    let mut stream = enc[..n].to_vec();
    stream.push(0);
    let mut dec = DefaultFrameDecoder::new();
    let got: Vec<Result<Response, _>> = dec.feed(&stream).collect();
    assert_eq!(got, vec![Err(FrameError::Deserialize)]);
}

#[test]
fn corrupted_frames_are_reported_and_the_next_frame_is_recovered() {
    let a = frame_of(&Response::Sample(Sample {
        seq: 1,
        raw: [500, 501, 502],
        corrected: [0.0, 0.0, 1.0],
        buttons: 0,
        stick: [128, 128],
    }));
    let b = frame_of(&Response::Ack);

    // One flipped data bit: COBS still valid, CRC catches it.
    let mut bad = a.clone();
    bad[5] ^= 0x10;
    assert_ne!(bad[5], 0);
    let mut dec = DefaultFrameDecoder::new();
    let got: Vec<Result<Response, _>> = decode_all(&mut dec, &[&bad, &b]);
    assert_eq!(got, vec![Err(FrameError::Crc), Ok(Response::Ack)]);

    // Bad COBS: a code byte pointing past the end of the frame.
    let got: Vec<Result<Response, _>> = decode_all(&mut dec, &[&[0x09, 1, 2, 0], &b]);
    assert_eq!(got, vec![Err(FrameError::Cobs), Ok(Response::Ack)]);

    // Too short to hold a CRC.
    let got: Vec<Result<Response, _>> = decode_all(&mut dec, &[&[0x02, 0x07, 0], &b]);
    assert_eq!(got, vec![Err(FrameError::Crc), Ok(Response::Ack)]);

    // Frame truncated by a lost tail: the remainder joins the next frame -> one error,
    // then the stream is back in sync.
    let got: Vec<Result<Response, _>> = decode_all(&mut dec, &[&a[..a.len() / 2], &b, &b]);
    assert_eq!(got.len(), 2);
    assert!(got[0].is_err());
    assert_eq!(got[1], Ok(Response::Ack));

    // Valid CRC over a body with trailing bytes.
    let mut body = postcard::to_slice(&Response::Ack, &mut [0u8; 4])
        .unwrap()
        .to_vec();
    body.push(0x55);
    let crc = frame::CRC16.checksum(&body).to_le_bytes();
    body.extend_from_slice(&crc);
    let mut enc = [0u8; 16];
    let n = cobs::encode(&body, &mut enc);
    let mut f = enc[..n].to_vec();
    f.push(0);
    let got: Vec<Result<Response, _>> = decode_all(&mut dec, &[&f, &b]);
    assert_eq!(got, vec![Err(FrameError::TrailingBytes), Ok(Response::Ack)]);
}

#[test]
fn oversize_frame_is_reported_once_then_discarded_to_the_next_delimiter() {
    let ack = frame_of(&Response::Ack);
    let mut dec = FrameDecoder::<16>::new();
    let junk = [0x55u8; 40];
    let got: Vec<Result<Response, _>> = dec.feed(&junk).collect();
    assert_eq!(got, vec![Err(FrameError::Oversize)]);
    let got: Vec<Result<Response, _>> = dec.feed(&[0x55; 100]).collect();
    assert!(got.is_empty(), "still discarding, nothing new to report");
    let mut tail = vec![0x55, 0x00];
    tail.extend_from_slice(&ack);
    let got: Vec<Result<Response, _>> = dec.feed(&tail).collect();
    assert_eq!(got, vec![Ok(Response::Ack)]);
    assert_eq!(dec.buffered(), 0);
}

#[test]
fn split_and_merged_chunks() {
    let msgs: Vec<Response> = (0..20)
        .map(|i| {
            Response::Sample(Sample {
                seq: i,
                raw: [i as u16; 3],
                corrected: [i as f32; 3],
                buttons: 0,
                stick: [0, 255],
            })
        })
        .collect();
    let stream: Vec<u8> = msgs.iter().flat_map(frame_of).collect();
    // One byte at a time.
    let mut dec = DefaultFrameDecoder::new();
    let mut got = Vec::new();
    for b in &stream {
        got.extend(
            dec.feed::<Response>(std::slice::from_ref(b))
                .map(Result::unwrap),
        );
    }
    assert_eq!(got, msgs);
    // Leading zeros / empty frames are ignored; a partial frame survives between calls.
    let mut dec = DefaultFrameDecoder::new();
    let first = frame_of(&msgs[0]);
    let got: Vec<_> = dec.feed::<Response>(&[0, 0, 0]).collect();
    assert!(got.is_empty());
    let got: Vec<_> = dec.feed::<Response>(&first[..3]).collect();
    assert!(got.is_empty());
    assert_eq!(dec.buffered(), 3);
    let got: Vec<_> = dec.feed::<Response>(&first[3..]).collect();
    assert_eq!(got, vec![Ok(msgs[0].clone())]);
    // reset() drops a partial frame.
    let _ = dec.feed::<Response>(&first[..3]).count();
    dec.reset();
    let got: Vec<_> = dec.feed::<Response>(&first).collect();
    assert_eq!(got, vec![Ok(msgs[0].clone())]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn requests_round_trip(m in request()) {
        let mut dec = DefaultFrameDecoder::new();
        let got: Vec<_> = dec.feed::<Request>(&frame_of(&m)).collect();
        prop_assert_eq!(got, vec![Ok(m)]);
    }

    #[test]
    fn responses_round_trip(m in response()) {
        let mut dec = DefaultFrameDecoder::new();
        let got: Vec<_> = dec.feed::<Response>(&frame_of(&m)).collect();
        prop_assert_eq!(got, vec![Ok(m)]);
    }

    #[test]
    fn arbitrary_chunking_yields_the_same_messages(
        msgs in proptest::collection::vec(response(), 1..8),
        cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..12),
    ) {
        let stream: Vec<u8> = msgs.iter().flat_map(frame_of).collect();
        let mut points: Vec<usize> = cuts.iter().map(|i| i.index(stream.len() + 1)).collect();
        points.sort_unstable();
        let mut dec = DefaultFrameDecoder::new();
        let mut got = Vec::new();
        let mut start = 0;
        for p in points.into_iter().chain([stream.len()]) {
            for item in dec.feed::<Response>(&stream[start..p]) {
                got.push(item.unwrap());
            }
            start = p;
        }
        prop_assert_eq!(got, msgs);
    }

    #[test]
    fn garbage_never_panics_and_a_delimiter_resyncs(
        garbage in proptest::collection::vec(any::<u8>(), 0..700),
        cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..8),
        m in response(),
    ) {
        let mut stream = garbage.clone();
        stream.push(0);
        stream.extend(frame_of(&m));
        let mut points: Vec<usize> = cuts.iter().map(|i| i.index(stream.len() + 1)).collect();
        points.sort_unstable();
        let mut dec = FrameDecoder::<64>::new();
        let mut items = Vec::new();
        let mut start = 0;
        for p in points.into_iter().chain([stream.len()]) {
            items.extend(dec.feed::<Response>(&stream[start..p]));
            start = p;
        }
        // Garbage of any kind only produces errors or unrelated messages; the frame after
        // the delimiter always comes through intact (64 bytes hold any small response,
        // larger ones legitimately overflow).
        let fits = frame_of(&m).len() - 1 <= 64;
        if fits {
            prop_assert_eq!(items.last().cloned(), Some(Ok(m)));
        } else {
            prop_assert_eq!(items.last().cloned(), Some(Err(FrameError::Oversize)));
        }
        prop_assert_eq!(dec.buffered(), 0);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        let mut dec = FrameDecoder::<32>::new();
        for item in dec.feed::<Request>(&bytes) {
            let _ = item;
        }
        let mut dec = DefaultFrameDecoder::new();
        let n = dec.feed::<Response>(&bytes).count();
        prop_assert!(n <= bytes.len());
    }
}

/// A protocol-2 `PutCalibration` (28 floats, no cross terms) is not half-read as protocol 3:
/// its frame is too short for the new layout and decodes as an error (the adapter answers
/// `BadFrame`), never as a calibration with zero cross terms. Sessions never get that far:
/// the Hello exchange already refuses the protocol-2 key (`SchemaMismatch`).
#[test]
fn a_protocol_2_calibration_frame_is_refused() {
    let mut body = vec![2u8];
    for x in [
        1.0f32, 2.0, 3.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0,
    ] {
        body.extend(x.to_le_bytes());
    }
    body.extend([0u8; 4 * 16]);
    let crc = frame::CRC16.checksum(&body);
    body.extend(crc.to_le_bytes());
    let mut enc = vec![0u8; body.len() + body.len() / 254 + 2];
    let n = cobs::encode(&body, &mut enc);
    enc.truncate(n);
    enc.push(0);
    let mut dec = DefaultFrameDecoder::new();
    let got: Vec<Result<Request, _>> = dec.feed(&enc).collect();
    assert_eq!(got.len(), 1);
    assert!(got[0].is_err(), "{got:?}");
    // The Hello exchange refuses every earlier protocol's key (3: the first with these
    // cross terms; 7: the newest before this one).
    for (k, v) in [(4, 3), (3, 4), (2, 5), (1, 6), (0, 7)] {
        assert_eq!(protocol_of_key(PREVIOUS_SCHEMA_KEYS[k].1), Some(v));
        assert_eq!(
            check_schema_key(PREVIOUS_SCHEMA_KEYS[k].1),
            Err(ErrorCode::SchemaMismatch)
        );
    }
}

/// The bounds of the background settings, checked against values written out here: the
/// defaults and the time-scaled session's values pass, an interval of 0 s, 0 or more than
/// 16 commits a day and a fit interval below half a second are refused, each naming its field.
#[test]
#[allow(clippy::too_many_lines, reason = "a test reads top to bottom")]
fn background_settings_bounds() {
    let ok = BackgroundSettings {
        adopt: true,
        replace_uploaded: false,
        commit_interval_s: 1800,
        commits_per_day: 8,
        fit_interval_ms: 60_000,
    };
    assert_eq!(ok.out_of_bounds(), None);
    let scaled = BackgroundSettings {
        commit_interval_s: 45,
        commits_per_day: 16,
        fit_interval_ms: 1500,
        ..ok
    };
    assert_eq!(scaled.out_of_bounds(), None);
    use wiical_wire::BackgroundSettingsField as F;
    for (bad, field) in [
        (
            BackgroundSettings {
                commit_interval_s: 0,
                ..ok
            },
            F::CommitInterval,
        ),
        (
            BackgroundSettings {
                commit_interval_s: 9,
                ..ok
            },
            F::CommitInterval,
        ),
        (
            BackgroundSettings {
                commit_interval_s: 604_801,
                ..ok
            },
            F::CommitInterval,
        ),
        (
            BackgroundSettings {
                commits_per_day: 0,
                ..ok
            },
            F::CommitsPerDay,
        ),
        (
            BackgroundSettings {
                commits_per_day: 17,
                ..ok
            },
            F::CommitsPerDay,
        ),
        (
            BackgroundSettings {
                commits_per_day: 255,
                ..ok
            },
            F::CommitsPerDay,
        ),
        (
            BackgroundSettings {
                fit_interval_ms: 0,
                ..ok
            },
            F::FitInterval,
        ),
        (
            BackgroundSettings {
                fit_interval_ms: 499,
                ..ok
            },
            F::FitInterval,
        ),
        (
            BackgroundSettings {
                fit_interval_ms: 3_600_001,
                ..ok
            },
            F::FitInterval,
        ),
    ] {
        assert_eq!(bad.out_of_bounds(), Some(field), "{bad:?}");
    }
    // The edges are inside.
    for edge in [
        BackgroundSettings {
            commit_interval_s: 10,
            commits_per_day: 1,
            fit_interval_ms: 500,
            ..ok
        },
        BackgroundSettings {
            commit_interval_s: 604_800,
            commits_per_day: 16,
            fit_interval_ms: 3_600_000,
            ..ok
        },
    ] {
        assert_eq!(edge.out_of_bounds(), None, "{edge:?}");
    }
}
