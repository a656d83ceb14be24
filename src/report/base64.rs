//! Standard base64 (RFC 4648 §4: alphabet `A–Z a–z 0–9 + /`, `=` padding),
//! encode only: the report page embeds its figures as `data:` URLs, and one
//! small function does not justify a dependency.

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Encode `data` as padded standard base64.
pub fn encode(data: &[u8]) -> String {
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    let sym = |v: u32| ALPHABET[(v & 63) as usize] as char;
    let mut chunks = data.chunks_exact(3);
    for c in &mut chunks {
        let v = (c[0] as u32) << 16 | (c[1] as u32) << 8 | c[2] as u32;
        out.push(sym(v >> 18));
        out.push(sym(v >> 12));
        out.push(sym(v >> 6));
        out.push(sym(v));
    }
    match *chunks.remainder() {
        [a] => {
            let v = (a as u32) << 16;
            out.push(sym(v >> 18));
            out.push(sym(v >> 12));
            out.push_str("==");
        }
        [a, b] => {
            let v = (a as u32) << 16 | (b as u32) << 8;
            out.push(sym(v >> 18));
            out.push(sym(v >> 12));
            out.push(sym(v >> 6));
            out.push('=');
        }
        _ => {}
    }
    out
}

#[cfg(test)]
mod tests {
    use super::encode;

    /// The test vectors of RFC 4648 §10.
    #[test]
    fn rfc4648_vectors() {
        let cases = [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ];
        for (plain, coded) in cases {
            assert_eq!(encode(plain.as_bytes()), coded, "{plain:?}");
        }
    }

    /// The two symbols past the alphanumerics, and high bytes.
    #[test]
    fn last_symbols_and_high_bytes() {
        assert_eq!(encode(&[0xfb, 0xff]), "+/8=");
        assert_eq!(encode(&[0xff, 0xff, 0xff]), "////");
        assert_eq!(encode(&[0x00, 0x00, 0x00]), "AAAA");
        assert_eq!(encode(&[0x14, 0xfb, 0x9c, 0x03, 0xd9, 0x7e]), "FPucA9l+");
    }

    /// Decoding by hand (6 bits per symbol) gives back every byte value at
    /// every position of a 3-byte group and every padding length.
    #[test]
    fn round_trip_all_bytes_all_lengths() {
        fn decode(s: &str) -> Vec<u8> {
            let val = |c: u8| super::ALPHABET.iter().position(|&a| a == c).unwrap() as u32;
            let mut out = Vec::new();
            for q in s.as_bytes().chunks(4) {
                let pad = q.iter().filter(|&&c| c == b'=').count();
                let mut v = 0u32;
                for &c in q {
                    v = v << 6 | if c == b'=' { 0 } else { val(c) };
                }
                let bytes = [(v >> 16) as u8, (v >> 8) as u8, v as u8];
                out.extend_from_slice(&bytes[..3 - pad]);
            }
            out
        }
        let all: Vec<u8> = (0..=255u8).collect();
        for start in 0..3 {
            for len in 0..=7 {
                let d = &all[start..start + 250 - len];
                let e = encode(d);
                assert_eq!(e.len() % 4, 0);
                assert_eq!(decode(&e), d);
            }
        }
    }
}
