//! Property tests of both CoLa parsers: any scan written in either dialect parses back to
//! itself; any bytes after a scan's command either parse (and then write back to themselves)
//! or give an error, never a panic; any telegrams, framed and cut anywhere, come out of the
//! framer whole and in order.

use mimnav_sick::cola::{Dialect, ETX, Framer, STX, frame};
use mimnav_sick::scandata::{Channel, ScanData};
use proptest::prelude::*;

fn dialect() -> impl Strategy<Value = Dialect> {
    prop_oneof![Just(Dialect::ColaA), Just(Dialect::ColaB)]
}

fn channel() -> impl Strategy<Value = Channel> {
    (
        prop_oneof![
            Just(*b"DIST1"),
            Just(*b"DIST2"),
            Just(*b"RSSI1"),
            Just(*b"ANGL1")
        ],
        any::<bool>(),
        any::<f32>().prop_filter("finite", |f| f.is_finite()),
        any::<i32>(),
        any::<u16>(),
        prop::collection::vec(any::<u16>(), 0..300),
    )
        .prop_map(|(name, wide, scale, start, step, values)| {
            let bits = if wide { 16 } else { 8 };
            let values = values
                .into_iter()
                .map(|v| if wide { v } else { v & 0xFF })
                .collect();
            Channel {
                name,
                bits,
                scale,
                offset: 0.0,
                start_angle: start,
                step,
                values,
            }
        })
}

fn scan() -> impl Strategy<Value = ScanData> {
    (
        (any::<u16>(), any::<u16>(), any::<u32>(), any::<[u8; 2]>()),
        (any::<u16>(), any::<u16>(), any::<u32>(), any::<u32>()),
        (
            any::<[u8; 2]>(),
            any::<[u8; 2]>(),
            any::<u16>(),
            any::<u32>(),
            any::<u32>(),
        ),
        prop::collection::vec((any::<u32>(), any::<u16>()), 0..3),
        prop::collection::vec(channel(), 0..5),
    )
        .prop_map(|(a, b, c, encoders, channels)| {
            let mut s = ScanData::default();
            (s.version, s.device_number, s.serial, s.device_status) = a;
            (
                s.telegram_counter,
                s.scan_counter,
                s.time_since_startup_us,
                s.time_of_transmission_us,
            ) = b;
            (
                s.inputs,
                s.outputs,
                s.layer_angle,
                s.scan_frequency,
                s.measurement_frequency,
            ) = c;
            s.encoders = encoders;
            // the 16-bit channels come first in a telegram
            let (wide, narrow): (Vec<Channel>, Vec<Channel>) =
                channels.into_iter().partition(|c| c.bits == 16);
            for ch in wide.into_iter().chain(narrow) {
                s.push_channel(ch);
            }
            s
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn any_scan_round_trips_in_both_dialects(s in scan(), d in dialect()) {
        let mut wire = Vec::new();
        s.encode(d, b"sSN", &mut wire);
        let mut back = ScanData::default();
        back.parse(d, &wire).expect("parses");
        prop_assert_eq!(back, s);
    }

    #[test]
    fn any_bytes_after_the_command_parse_or_fail_cleanly(
        body in prop::collection::vec(any::<u8>(), 0..600),
        d in dialect(),
        ascii in any::<bool>(),
    ) {
        let mut p = b"sSN LMDscandata ".to_vec();
        if ascii {
            // CoLa-A-like text: hex digits, signs and spaces
            let alphabet = b"0123456789ABCDEF+- ";
            p.extend(body.iter().map(|b| alphabet[usize::from(*b) % alphabet.len()]));
        } else {
            p.extend(&body);
        }
        let mut s = ScanData::default();
        if s.parse(d, &p).is_ok() {
            let mut wire = Vec::new();
            s.encode(d, b"sSN", &mut wire);
            let mut back = ScanData::default();
            back.parse(d, &wire).expect("written back, it parses");
            prop_assert_eq!(back, s);
        }
    }

    #[test]
    fn framed_telegrams_come_out_whole_wherever_the_stream_is_cut(
        payloads in prop::collection::vec(prop::collection::vec(any::<u8>(), 1..200), 1..6),
        cuts in prop::collection::vec(1usize..64, 1..8),
        d in dialect(),
    ) {
        // CoLa-A text never holds STX or ETX
        let payloads: Vec<Vec<u8>> = payloads
            .into_iter()
            .map(|p| match d {
                Dialect::ColaA => p.into_iter().map(|b| if b == STX || b == ETX { b'x' } else { b }).collect(),
                Dialect::ColaB => p,
            })
            .collect();
        let mut wire = Vec::new();
        for p in &payloads {
            frame(d, p, &mut wire);
        }
        let mut f = Framer::new(d, 4096);
        let (mut got, mut rest, mut i) = (Vec::new(), &wire[..], 0);
        while !rest.is_empty() {
            let (piece, tail) = rest.split_at(cuts[i % cuts.len()].min(rest.len()));
            (rest, i) = (tail, i + 1);
            f.push(piece);
            while let Some(r) = f.next() {
                got.push(r.expect("no error in a clean stream").to_vec());
            }
        }
        prop_assert_eq!(got, payloads);
        prop_assert_eq!(f.pending(), 0);
    }
}
