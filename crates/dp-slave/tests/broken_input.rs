//! Broken and foreign input: arbitrary bytes and arbitrary telegram sequences never panic the
//! slave, never change its state when malformed or addressed elsewhere, and never draw a
//! response they should not.

use dp_slave::testing::EchoApp;
use dp_slave::{Config, Instant, IoSizes, Slave, State};
use fdl::{DataRepr, FrameControl, Repr, Sap};
use proptest::prelude::*;

const ME: u8 = 8;
const IDENT: u16 = 0xD7A1;

fn slave() -> Slave<EchoApp> {
    Slave::new(
        Config {
            address: ME,
            ident_number: IDENT,
            no_add_chg: false,
            dpv1_status_bytes: false,
        },
        EchoApp::default(),
    )
}

/// A slave in Data_Exch with PPO1, locked to master 2.
fn exchanging() -> Slave<EchoApp> {
    let mut s = slave();
    let mut out = [0u8; 256];
    // FCB toggles between the two requests: the same FCB twice would be a repetition.
    let request = |dsap, fc, payload| {
        Repr::Data(DataRepr {
            da: ME,
            sa: 2,
            dsap: Some(dsap),
            ssap: Some(Sap::MASTER_MS0),
            fc: FrameControl::from_byte(fc).unwrap(),
            payload,
        })
    };
    let set_prm = [0x88, 10, 10, 11, 0xD7, 0xA1, 0x00];
    s.process(Instant::ZERO, &request(Sap::SET_PRM, 0x5C, &set_prm))
        .unwrap();
    let reply = s.process(Instant::ZERO, &request(Sap::CHK_CFG, 0x7C, &[0xF3, 0xF1]));
    assert_eq!(reply.unwrap().emit(&mut out), Ok(1));
    assert_eq!(s.state(), State::DataExch);
    s
}

/// Everything a request can change.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Snapshot {
    state: State,
    owner: Option<u8>,
    locked: bool,
    io: IoSizes,
    address: u8,
    min_tsdr: u8,
    outputs: u32,
    fail_safes: usize,
    clear: bool,
    poll_at: Option<Instant>,
}

fn snapshot(s: &Slave<EchoApp>) -> Snapshot {
    Snapshot {
        state: s.state(),
        owner: s.owner(),
        locked: s.is_locked(),
        io: s.io_sizes(),
        address: s.address(),
        min_tsdr: s.min_tsdr_bits(),
        outputs: s.app().output_count,
        fail_safes: s.app().fail_safes.len(),
        clear: s.is_clear(),
        poll_at: s.poll_at(),
    }
}

fn any_sap() -> impl Strategy<Value = Option<Sap>> {
    prop_oneof![
        Just(None),
        (55u8..=62).prop_map(|s| Some(Sap(s))),
        (0u8..=63).prop_map(|s| Some(Sap(s))),
    ]
}

fn any_request(
    payload: Vec<u8>,
) -> impl Strategy<Value = (u8, u8, Option<Sap>, Option<Sap>, u8, Vec<u8>)> {
    (
        prop_oneof![Just(ME), Just(127u8), 0u8..=127],
        prop_oneof![Just(2u8), 0u8..=127],
        any_sap(),
        any_sap(),
        0u8..0x80,
        Just(payload),
    )
}

proptest! {
    #![proptest_config(prop_cases::config(3000))]

    #[test]
    fn malformed_bytes_change_nothing(bytes in prop::collection::vec(any::<u8>(), 0..64), fresh in any::<bool>()) {
        let mut s = if fresh { slave() } else { exchanging() };
        let before = snapshot(&s);
        let mut out = [0u8; 256];
        let parsed = Repr::parse_bytes(&bytes).is_ok();
        let answer = s.handle(Instant::from_millis(1), &bytes, &mut out);
        if !parsed {
            prop_assert_eq!(answer, None);
            prop_assert_eq!(snapshot(&s), before);
        }
    }

    #[test]
    fn telegram_sequences(
        requests in prop::collection::vec(
            prop::collection::vec(any::<u8>(), 0..30).prop_flat_map(any_request), 1..40),
        fresh in any::<bool>(),
    ) {
        let mut s = if fresh { slave() } else { exchanging() };
        let mut out = [0u8; 256];
        for (i, (da, sa, dsap, ssap, fc, payload)) in requests.iter().enumerate() {
            let fc = FrameControl::from_byte(*fc).unwrap();
            let request = Repr::Data(DataRepr { da: *da, sa: *sa, dsap: *dsap, ssap: *ssap, fc, payload });
            let before = snapshot(&s);
            let address = s.address();
            // 1 ms apart: the 1 s watchdog of `exchanging` never expires here.
            let now = Instant::from_millis(i as u64 + 1);
            let response = s.process(now, &request).map(|r| {
                let n = r.emit(&mut out).expect("responses always emit");
                out[..n].to_vec()
            });
            if *da != address && *da != 127 {
                prop_assert_eq!(&response, &None, "answered a telegram for {}", da);
                prop_assert_eq!(snapshot(&s), before);
            }
            // Only Global_Control may act on a broadcast.
            if *da == 127 && *dsap != Some(Sap::GLOBAL_CONTROL) {
                prop_assert_eq!(snapshot(&s), before);
            }
            let expects = matches!(fc, FrameControl::Request { function, .. } if function.expects_response());
            if *da == 127 || !expects {
                prop_assert_eq!(&response, &None);
            }
            if let Some(bytes) = response {
                let (repr, _) = Repr::parse_bytes(&bytes).unwrap();
                match repr {
                    Repr::ShortAck => {}
                    Repr::Data(d) => {
                        prop_assert_eq!(d.da, *sa);
                        prop_assert_eq!(d.sa, address);
                        let is_response = matches!(d.fc, FrameControl::Response { .. });
                        prop_assert!(is_response);
                    }
                    Repr::Token { .. } => prop_assert!(false, "token as response"),
                }
            }
        }
    }
}
