//! Which transfer syntaxes coapt reads a CT from, decided from the file's
//! meta header before any pixel is decoded, so a refusal names the syntax
//! and says why instead of surfacing a decoder's error.

/// Why images in transfer syntax `uid` are not read; `None` when they are.
pub fn refusal(uid: &str) -> Option<String> {
    let why = match uid {
        // Uncompressed (implicit/explicit little, explicit big endian),
        // deflated, RLE lossless, and JPEG lossless (Process 14, any
        // predictor, and its selection value 1): pure-Rust decoders, exact.
        "1.2.840.10008.1.2"
        | "1.2.840.10008.1.2.1"
        | "1.2.840.10008.1.2.2"
        | "1.2.840.10008.1.2.1.99"
        | "1.2.840.10008.1.2.5"
        | "1.2.840.10008.1.2.4.57"
        | "1.2.840.10008.1.2.4.70" => return None,
        // A CT's Hounsfield units span −1024…3071 and more: 12 bits at
        // least. Baseline JPEG holds 8-bit samples, so such an image was
        // windowed to 256 grey levels before it was compressed (and then
        // compressed lossily): the HU cannot be recovered, and segmenting
        // grey levels as if they were HU would be wrong without a warning.
        "1.2.840.10008.1.2.4.50" => {
            "JPEG baseline (1.2.840.10008.1.2.4.50) holds 8-bit, lossy samples, and a CT's \
             Hounsfield units need 12 bits or more: the HU cannot be recovered from it; export \
             the series uncompressed or lossless (JPEG lossless, RLE) from the PACS"
        }
        // The decoder coapt links has no 12-bit DCT (the only reason a CT
        // would use Process 4), and 8-bit Process 2 is baseline's problem.
        "1.2.840.10008.1.2.4.51" => {
            "JPEG extended (1.2.840.10008.1.2.4.51) is lossy and its 12-bit form is not \
             decoded by coapt; export the series uncompressed or lossless from the PACS, or \
             convert it with dcm2niix or `gdcmconv --raw`"
        }
        _ => {
            let name = match uid {
                "1.2.840.10008.1.2.4.80" => "JPEG-LS lossless",
                "1.2.840.10008.1.2.4.81" => "JPEG-LS near-lossless",
                "1.2.840.10008.1.2.4.90" => "JPEG 2000 lossless",
                "1.2.840.10008.1.2.4.91" => "JPEG 2000",
                "1.2.840.10008.1.2.4.201" | "1.2.840.10008.1.2.4.202" => "HTJ2K lossless",
                "1.2.840.10008.1.2.4.203" => "HTJ2K",
                "1.2.840.10008.1.2.4.110" | "1.2.840.10008.1.2.4.111" => "JPEG XL lossless",
                "1.2.840.10008.1.2.4.112" => "JPEG XL",
                u if u.starts_with("1.2.840.10008.1.2.4.10") => "MPEG video",
                u if u.starts_with("1.2.840.10008.1.2.4.") => "a JPEG variant",
                _ => "a transfer syntax coapt does not know",
            };
            return Some(format!(
                "its transfer syntax {uid} ({name}) is not decoded by coapt (it decodes \
                 uncompressed, deflated, RLE and JPEG lossless images); convert the series \
                 with dcm2niix or `gdcmconv --raw`"
            ));
        }
    };
    Some(why.to_string())
}

#[cfg(test)]
mod tests {
    use super::refusal;

    #[test]
    fn lossless_syntaxes_are_read_and_refusals_name_the_syntax() {
        for ok in [
            "1.2.840.10008.1.2.1",
            "1.2.840.10008.1.2.5",
            "1.2.840.10008.1.2.4.70",
        ] {
            assert_eq!(refusal(ok), None, "{ok}");
        }
        let m = refusal("1.2.840.10008.1.2.4.50").unwrap();
        assert!(m.contains("8-bit") && m.contains("12 bits"), "{m}");
        for (uid, name) in [
            ("1.2.840.10008.1.2.4.80", "JPEG-LS"),
            ("1.2.840.10008.1.2.4.91", "JPEG 2000"),
            ("1.2.3.4", "does not know"),
        ] {
            let m = refusal(uid).unwrap();
            assert!(m.contains(uid) && m.contains(name), "{m}");
        }
    }
}
