//! Property tests of the no-panic contract and of parse(emit(x)) == x.

use fdl::{DataRepr, FrameControl, Repr, RequestFunction, Sap, Telegram};
use proptest::prelude::*;

fn frame_control() -> impl Strategy<Value = FrameControl> {
    (0u8..0x80).prop_map(|b| FrameControl::from_byte(b).unwrap())
}

fn sap() -> impl Strategy<Value = Option<Sap>> {
    prop::option::of((0u8..=63).prop_map(Sap))
}

proptest! {
    #![proptest_config(prop_cases::config(2000))]

    #[test]
    fn parse_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        if let Ok((repr, len)) = Repr::parse_bytes(&bytes) {
            // Whatever parses re-emits to exactly the bytes it came from, unless SD2 was used
            // for a data unit that SD1 or SD3 would carry (the delimiter is not in the Repr).
            let mut out = [0u8; 300];
            let n = repr.emit(&mut out).unwrap();
            let view = Telegram::new_checked(&bytes[..]).unwrap();
            let canonical_sd = n == len;
            if canonical_sd {
                prop_assert_eq!(&out[..n], &bytes[..len]);
            } else {
                prop_assert_eq!(view.delimiter(), dp_consts::SD2);
            }
        }
    }

    #[test]
    fn parse_of_emit_is_identity(
        payload in prop::collection::vec(any::<u8>(), 0..250),
        da in 0u8..=127, sa in 0u8..=127, dsap in sap(), ssap in sap(), fc in frame_control(),
    ) {
        let repr = Repr::Data(DataRepr { da, sa, dsap, ssap, fc, payload: &payload });
        let mut out = [0u8; 300];
        match repr.check() {
            Ok(()) => {
                let n = repr.emit(&mut out).unwrap();
                prop_assert_eq!(n, repr.buffer_len());
                let (back, len) = Repr::parse_bytes(&out[..n]).unwrap();
                prop_assert_eq!(back, repr);
                prop_assert_eq!(len, n);
            }
            // Only a data unit over 246 bytes is refused here.
            Err(e) => {
                prop_assert_eq!(e, fdl::Error::DataTooLong);
                prop_assert!(repr.emit(&mut out).is_err());
            }
        }
    }

    #[test]
    fn emit_never_panics_on_short_buffers(
        payload in prop::collection::vec(any::<u8>(), 0..250),
        da in any::<u8>(), sa in any::<u8>(), dsap in any::<Option<u8>>(), fc in any::<u8>(),
        short in 0usize..300,
    ) {
        let fc = FrameControl::from_byte(fc & 0x7F).unwrap();
        let repr = Repr::Data(DataRepr { da, sa, dsap: dsap.map(Sap), ssap: None, fc, payload: &payload });
        let mut out = vec![0u8; short];
        let _ = repr.emit(&mut out);
    }

    #[test]
    fn any_single_byte_change_is_detected_or_changes_the_repr(
        payload in prop::collection::vec(any::<u8>(), 1..40),
        at in any::<prop::sample::Index>(),
        flip in 1u8..=255,
    ) {
        let repr = Repr::Data(DataRepr {
            da: 8, sa: 2, dsap: None, ssap: None,
            fc: FrameControl::Request { fcb: true, fcv: true, function: RequestFunction::SrdHigh },
            payload: &payload,
        });
        let mut out = [0u8; 300];
        let n = repr.emit(&mut out).unwrap();
        let i = at.index(n);
        out[i] ^= flip;
        // A single corrupted byte never yields the original telegram back.
        if let Ok((back, _)) = Repr::parse_bytes(&out[..n]) {
            prop_assert_ne!(back, repr);
        }
    }
}
