//! Feed arbitrary bytes, in arbitrary chunks, to the wire frame decoder (both message
//! types, a tiny and the default buffer). Any panic is a bug; every decoded message must
//! re-encode into a frame that decodes to the same message.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wiical_wire::{
    encode_frame, DefaultFrameDecoder, FrameDecoder, Request, Response, MAX_FRAME_LEN,
};

fuzz_target!(|data: &[u8]| {
    // First byte chooses the chunk size, the rest is the stream.
    let Some((&chunk, stream)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(chunk).max(1);

    let mut small = FrameDecoder::<24>::new();
    let mut req = DefaultFrameDecoder::new();
    let mut resp = DefaultFrameDecoder::new();
    for part in stream.chunks(chunk) {
        for item in small.feed::<Response>(part) {
            let _ = item;
        }
        for msg in req.feed::<Request>(part).flatten() {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode_frame(&msg, &mut buf).expect("every Request fits MAX_FRAME_LEN");
            let mut again = DefaultFrameDecoder::new();
            let back: Vec<_> = again.feed::<Request>(frame).collect();
            assert_eq!(back, vec![Ok(msg)]);
        }
        for msg in resp.feed::<Response>(part).flatten() {
            let mut buf = [0u8; MAX_FRAME_LEN];
            let frame = encode_frame(&msg, &mut buf).expect("every Response fits MAX_FRAME_LEN");
            let mut again = DefaultFrameDecoder::new();
            let n = again.feed::<Response>(frame).filter(|r| r.is_ok()).count();
            // (f32 NaN payloads make == unreliable; count successful decodes instead.)
            assert_eq!(n, 1);
        }
    }
});
