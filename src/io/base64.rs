//! Standard base64 (RFC 4648 §4, with padding): VTK's inline binary arrays
//! (vtkBase64OutputStream) and the report page's `data:` images. Small and
//! dependency-free on purpose.

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Encode `bytes`, appending to `out`.
pub fn encode_into(bytes: &[u8], out: &mut Vec<u8>) {
    out.reserve(bytes.len().div_ceil(3) * 4);
    let mut chunks = bytes.chunks_exact(3);
    for c in &mut chunks {
        let n = (c[0] as u32) << 16 | (c[1] as u32) << 8 | c[2] as u32;
        out.extend_from_slice(&[
            ALPHABET[(n >> 18) as usize & 63],
            ALPHABET[(n >> 12) as usize & 63],
            ALPHABET[(n >> 6) as usize & 63],
            ALPHABET[n as usize & 63],
        ]);
    }
    match *chunks.remainder() {
        [a] => {
            let n = (a as u32) << 16;
            out.extend_from_slice(&[
                ALPHABET[(n >> 18) as usize & 63],
                ALPHABET[(n >> 12) as usize & 63],
                b'=',
                b'=',
            ]);
        }
        [a, b] => {
            let n = (a as u32) << 16 | (b as u32) << 8;
            out.extend_from_slice(&[
                ALPHABET[(n >> 18) as usize & 63],
                ALPHABET[(n >> 12) as usize & 63],
                ALPHABET[(n >> 6) as usize & 63],
                b'=',
            ]);
        }
        _ => {}
    }
}

pub fn encode(bytes: &[u8]) -> String {
    let mut out = Vec::new();
    encode_into(bytes, &mut out);
    String::from_utf8(out).expect("base64 is ASCII")
}

fn value(c: u8) -> Option<u32> {
    Some(match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => return None,
    } as u32)
}

/// Decode, skipping whitespace. Padding may occur in the middle: VTK encodes
/// a compressed array's header and its data as two separately padded runs,
/// so the text is decoded as a sequence of independent 4-character groups.
pub fn decode(text: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(text.len() / 4 * 3);
    let mut group = [0u8; 4];
    let mut n = 0;
    for &c in text {
        if c.is_ascii_whitespace() {
            continue;
        }
        if c != b'=' && value(c).is_none() {
            return Err(format!("invalid base64 character {:?}", c as char));
        }
        group[n] = c;
        n += 1;
        if n == 4 {
            decode_group(&group, &mut out)?;
            n = 0;
        }
    }
    if n != 0 {
        return Err("base64 text ends in the middle of a 4-character group (truncated?)".into());
    }
    Ok(out)
}

fn decode_group(g: &[u8; 4], out: &mut Vec<u8>) -> Result<(), String> {
    let pad = g.iter().rev().take_while(|&&c| c == b'=').count();
    if pad > 2 || g[..4 - pad].contains(&b'=') {
        return Err("misplaced '=' padding in base64 text".into());
    }
    let mut n = 0u32;
    for &c in &g[..4 - pad] {
        n = n << 6 | value(c).expect("checked by caller");
    }
    n <<= 6 * pad as u32;
    let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
    out.extend_from_slice(&bytes[..3 - pad]);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_vectors_round_trip() {
        for (raw, enc) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(encode(raw.as_bytes()), enc);
            assert_eq!(decode(enc.as_bytes()).unwrap(), raw.as_bytes());
        }
        let all: Vec<u8> = (0..=255).collect();
        assert_eq!(decode(encode(&all).as_bytes()).unwrap(), all);
    }

    #[test]
    fn concatenated_runs_and_errors() {
        assert_eq!(decode(b" Zg==\n Zm8= ").unwrap(), b"ffo");
        assert!(decode(b"Zm9").is_err());
        assert!(decode(b"Z=9v").is_err());
        assert!(decode(b"Zm9*").is_err());
    }

    /// The two symbols past the alphanumerics, and high bytes.
    #[test]
    fn last_symbols_and_high_bytes() {
        assert_eq!(encode(&[0xfb, 0xff]), "+/8=");
        assert_eq!(encode(&[0xff, 0xff, 0xff]), "////");
        assert_eq!(encode(&[0x00, 0x00, 0x00]), "AAAA");
        assert_eq!(encode(&[0x14, 0xfb, 0x9c, 0x03, 0xd9, 0x7e]), "FPucA9l+");
    }

    /// Every byte value at every position of a 3-byte group and every
    /// padding length survives the round trip.
    #[test]
    fn round_trip_all_bytes_all_lengths() {
        let all: Vec<u8> = (0..=255u8).collect();
        for start in 0..3 {
            for len in 0..=7 {
                let d = &all[start..start + 250 - len];
                let e = encode(d);
                assert_eq!(e.len() % 4, 0);
                assert_eq!(decode(e.as_bytes()).unwrap(), d);
            }
        }
    }
}
