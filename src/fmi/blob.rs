//! FMU-state envelope (FMI 2.0.x §2.1.8, "Getting and Setting the Complete FMU State") and
//! the hashes used for it and for the GUID.
//!
//! A serialized state can come back from a file, another process or another FMU, so it is
//! wrapped as
//!
//! ```text
//! magic "GDFMUST\0" | format version u32 | total length u64 | GUID (u32 len + bytes)
//! | layer: state u8, flags u8, time f64, start f64, stop f64, last successful f64
//! | model payload (u64 len + bytes) | FNV-1a 64 checksum of everything before
//! ```
//!
//! all little-endian. A blob with a wrong magic, version, length, checksum or GUID (a
//! "foreign" blob from another FMU) is rejected before anything reaches the model. The same
//! bytes are the in-memory `fmi2FMUstate`, so get/set and (de)serialize share one path; only
//! the checksum is written when the state leaves the process ([`seal`], at
//! `fmi2SerializeFMUstate`), and `fmi2SetFMUstate` of a state object does not verify it
//! ([`open`]): the object was made by `fmi2GetFMUstate` in this process or verified by
//! `fmi2DeSerializeFMUstate` ([`decode`]). An error-controlled master saves a state before
//! every step and restores one at every undone step, none of which is ever serialized.

use super::bytes::Reader;
use super::state::FmuState;

const MAGIC: &[u8; 8] = b"GDFMUST\0";
/// Bumped whenever the layout above or the layer section changes.
pub const FORMAT_VERSION: u32 = 1;

/// FNV-1a, 64 bit (Fowler–Noll–Vo; parameters from the IETF draft-eastlake-fnv).
pub fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// FNV-1a, 128 bit.
pub fn fnv1a128(bytes: &[u8]) -> u128 {
    let mut h: u128 = 0x6c62_272e_07bb_0142_62b8_2175_6295_c58d;
    for b in bytes {
        h ^= u128::from(*b);
        h = h.wrapping_mul(0x0000_0000_0100_0000_0000_0000_0000_013b);
    }
    h
}

/// GUID of an FMU: a hash of the crate version and the scene bytes, formatted like a UUID.
/// A binary from another version or a description from another scene is then detected by
/// `fmi2Instantiate` (FMI 2.0.x §2.1.5: "fmuGUID ... must match").
pub fn guid(scene_bytes: &[u8]) -> String {
    let mut data = format!("geardyn {}\0", env!("CARGO_PKG_VERSION")).into_bytes();
    data.extend_from_slice(scene_bytes);
    let h = fnv1a128(&data);
    let s = format!("{h:032x}");
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &s[0..8],
        &s[8..12],
        &s[12..16],
        &s[16..20],
        &s[20..32]
    )
}

/// The layer's part of an FMU state (the model's part is opaque bytes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerSnapshot {
    pub state: FmuState,
    pub time: f64,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub last_successful_time: f64,
    pub terminated: bool,
    pub setup_done: bool,
}

/// The envelope of a state into `out` (cleared first; its buffer is reused: a master saves a
/// state before every step), its checksum slot 0 until [`seal`].
pub fn encode_unsealed(out: &mut Vec<u8>, guid: &str, layer: &LayerSnapshot, model: &[u8]) {
    out.clear();
    out.reserve(96 + guid.len() + model.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&0u64.to_le_bytes()); // total length, patched below
    out.extend_from_slice(&(guid.len() as u32).to_le_bytes());
    out.extend_from_slice(guid.as_bytes());
    out.push(layer.state.to_code());
    let flags = u8::from(layer.terminated)
        | (u8::from(layer.setup_done) << 1)
        | (u8::from(layer.stop_time.is_some()) << 2);
    out.push(flags);
    for x in [
        layer.time,
        layer.start_time,
        layer.stop_time.unwrap_or(0.0),
        layer.last_successful_time,
    ] {
        out.extend_from_slice(&x.to_le_bytes());
    }
    out.extend_from_slice(&(model.len() as u64).to_le_bytes());
    out.extend_from_slice(model);
    let total = (out.len() + 8) as u64;
    out[12..20].copy_from_slice(&total.to_le_bytes());
    out.extend_from_slice(&0u64.to_le_bytes());
}

/// Writes the checksum of an envelope from [`encode_unsealed`] into its last 8 bytes.
pub fn seal(bytes: &mut [u8]) {
    let n = bytes.len() - 8;
    let sum = fnv1a64(&bytes[..n]);
    bytes[n..].copy_from_slice(&sum.to_le_bytes());
}

/// A sealed envelope ([`encode_unsealed`] then [`seal`]): the bytes of a serialized state.
pub fn encode(guid: &str, layer: &LayerSnapshot, model: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    encode_unsealed(&mut out, guid, layer, model);
    seal(&mut out);
    out
}

/// Checks and unpacks an envelope that comes from outside (`fmi2DeSerializeFMUstate`).
/// `expected_guid` is this FMU's GUID.
pub fn decode<'a>(
    bytes: &'a [u8],
    expected_guid: &str,
) -> Result<(LayerSnapshot, &'a [u8]), String> {
    unpack(bytes, expected_guid, true)
}

/// Unpacks the envelope of a state object ([`decode`] without the checksum, which a state
/// made in this process does not carry until [`seal`]); the other checks stay.
pub fn open<'a>(bytes: &'a [u8], expected_guid: &str) -> Result<(LayerSnapshot, &'a [u8]), String> {
    unpack(bytes, expected_guid, false)
}

fn unpack<'a>(
    bytes: &'a [u8],
    expected_guid: &str,
    verify: bool,
) -> Result<(LayerSnapshot, &'a [u8]), String> {
    if bytes.len() < MAGIC.len() || &bytes[..MAGIC.len()] != MAGIC {
        return Err("not a geardyn FMU state (bad magic)".into());
    }
    let mut r = Reader::new(bytes);
    r.take(MAGIC.len())?;
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(format!(
            "FMU state format version {version} is not supported (expected {FORMAT_VERSION})"
        ));
    }
    let total = r.u64()?;
    if total != bytes.len() as u64 {
        return Err(format!(
            "FMU state length mismatch: header says {total} bytes, got {}",
            bytes.len()
        ));
    }
    let body = &bytes[..bytes.len() - 8];
    if verify {
        let stored = u64::from_le_bytes(bytes[bytes.len() - 8..].try_into().unwrap_or([0; 8]));
        let sum = fnv1a64(body);
        if stored != sum {
            return Err(format!(
                "FMU state checksum mismatch (stored {stored:016x}, computed {sum:016x}): corrupt"
            ));
        }
    }
    let glen = r.u32()? as usize;
    let g = r.take(glen)?;
    if g != expected_guid.as_bytes() {
        return Err(format!(
            "FMU state belongs to another FMU (GUID {}, this FMU {expected_guid})",
            String::from_utf8_lossy(g)
        ));
    }
    let code = r.u8()?;
    let state = FmuState::from_code(code)
        .ok_or_else(|| format!("FMU state has an invalid state-machine code {code}"))?;
    let flags = r.u8()?;
    let time = r.f64()?;
    let start_time = r.f64()?;
    let stop = r.f64()?;
    let last_successful_time = r.f64()?;
    let mlen = r.u64()?;
    let model =
        r.take(usize::try_from(mlen).map_err(|_| "model payload too large".to_string())?)?;
    if r.pos() != body.len() {
        return Err(format!(
            "FMU state has {} trailing bytes",
            body.len() - r.pos()
        ));
    }
    let layer = LayerSnapshot {
        state,
        time,
        start_time,
        stop_time: (flags & 4 != 0).then_some(stop),
        last_successful_time,
        terminated: flags & 1 != 0,
        setup_done: flags & 2 != 0,
    };
    Ok((layer, model))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snap() -> LayerSnapshot {
        LayerSnapshot {
            state: FmuState::StepComplete,
            time: 0.25,
            start_time: 0.0,
            stop_time: Some(1.0),
            last_successful_time: 0.25,
            terminated: false,
            setup_done: true,
        }
    }

    #[test]
    fn fnv_reference_values() {
        // Published FNV-1a test vectors.
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        assert_eq!(fnv1a128(b""), 0x6c62272e07bb014262b821756295c58d);
        assert_eq!(fnv1a128(b"a"), 0xd228cb696f1a8caf78912b704e4a8964);
    }

    #[test]
    fn guid_shape_and_sensitivity() {
        let g = guid(b"a = 1");
        assert_eq!(g.len(), 38);
        assert!(g.starts_with('{') && g.ends_with('}'));
        assert_ne!(g, guid(b"a = 2"));
        assert_eq!(g, guid(b"a = 1"));
    }

    #[test]
    fn round_trip() {
        let b = encode("{g}", &snap(), &[1, 2, 3]);
        let (l, m) = decode(&b, "{g}").unwrap();
        assert_eq!(l, snap());
        assert_eq!(m, &[1, 2, 3]);
    }

    /// A state object's envelope opens without its checksum, is refused by `decode` until
    /// sealed, and sealed is the envelope `encode` writes, bit for bit; a reused buffer holds
    /// exactly the new envelope.
    #[test]
    fn unsealed_envelopes_open_and_seal() {
        let mut b = vec![7; 500];
        encode_unsealed(&mut b, "{g}", &snap(), &[1, 2, 3]);
        let (l, m) = open(&b, "{g}").unwrap();
        assert_eq!((l, m), (snap(), &[1u8, 2, 3][..]));
        assert!(decode(&b, "{g}").unwrap_err().contains("checksum"));
        assert!(open(&b, "{other}").unwrap_err().contains("another FMU"));
        seal(&mut b);
        assert_eq!(b, encode("{g}", &snap(), &[1, 2, 3]));
        assert_eq!(decode(&b, "{g}").unwrap(), (snap(), &[1u8, 2, 3][..]));
    }

    #[test]
    fn every_single_bit_flip_is_rejected() {
        let b = encode("{g}", &snap(), &[9; 40]);
        for i in 0..b.len() {
            for bit in 0..8 {
                let mut c = b.clone();
                c[i] ^= 1 << bit;
                assert!(
                    decode(&c, "{g}").is_err(),
                    "flip at byte {i} bit {bit} accepted"
                );
            }
        }
    }

    #[test]
    fn truncation_extension_and_foreign_are_rejected() {
        let b = encode("{g}", &snap(), &[9; 40]);
        for n in 0..b.len() {
            assert!(decode(&b[..n], "{g}").is_err());
        }
        let mut longer = b.clone();
        longer.push(0);
        assert!(decode(&longer, "{g}").is_err());
        let e = decode(&b, "{other}").unwrap_err();
        assert!(e.contains("another FMU"), "{e}");
        assert!(decode(b"hello world, not a state", "{g}")
            .unwrap_err()
            .contains("magic"));
    }
}
