//! Metadata that does not decode is reported with the failing field's path, not
//! postcard's bare "Serde Deserialization Error".

use lobefit_tables::format::HEADER_LEN;
use lobefit_tables::{LoadError, Table};

const CAP: &[u8] = include_bytes!("../../data/cap-exponent.lobefit");

fn put_u32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

/// `CAP` with its metadata replaced by `meta`, offsets and every CRC consistent, so
/// that only the metadata decode can fail.
fn with_meta_bytes(meta: &[u8]) -> Vec<u8> {
    let t = Table::from_bytes(CAP).unwrap();
    let payload = t.payload_bytes();
    let mut out = CAP[..HEADER_LEN].to_vec();
    let p0 = (HEADER_LEN + meta.len()).div_ceil(16) * 16;
    put_u32(&mut out, 36, meta.len() as u32);
    put_u32(&mut out, 40, p0 as u32);
    put_u32(&mut out, 44, payload.len() as u32);
    put_u32(&mut out, 48, crc32fast_hash(meta));
    put_u32(&mut out, 52, crc32fast_hash(payload));
    let crc = crc32fast_hash(&out[..60]);
    put_u32(&mut out, 60, crc);
    out.extend_from_slice(meta);
    out.resize(p0, 0);
    out.extend_from_slice(payload);
    out
}

/// CRC-32 (IEEE), bitwise: the test stays independent of the loader's crc32fast.
fn crc32fast_hash(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
        }
    }
    !c
}

/// The committed metadata bytes and the offset where `axes` begins (after kind,
/// table_version, generator, description).
fn meta_and_axes_offset() -> (Vec<u8>, usize) {
    let m = Table::from_bytes(CAP).unwrap().meta().clone();
    let bytes = postcard::to_allocvec(&m).unwrap();
    let before = postcard::to_allocvec(&(&m.kind, m.table_version, &m.generator, &m.description)).unwrap();
    (bytes, before.len())
}

fn bad_metadata(meta: &[u8]) -> String {
    match Table::from_bytes(&with_meta_bytes(meta)) {
        Err(e @ LoadError::BadMetadata(_)) => e.to_string(),
        other => panic!("expected BadMetadata, got {other:?}"),
    }
}

#[test]
fn unknown_storage_variant_names_the_field() {
    let m = Table::from_bytes(CAP).unwrap().meta().clone();
    let (mut bytes, _) = meta_and_axes_offset();
    let at = postcard::to_allocvec(&(
        &m.kind,
        m.table_version,
        &m.generator,
        &m.description,
        &m.axes,
        &m.channels,
    ))
    .unwrap()
    .len();
    assert_eq!(bytes[at], 0, "storage F32");
    bytes[at] = 1;
    assert_eq!(
        bad_metadata(&bytes),
        "metadata does not decode: field 'storage': unknown variant 1 (this reader knows 0 = F32)"
    );
}

#[test]
fn huge_axis_count_names_the_field() {
    let (bytes, at) = meta_and_axes_offset();
    assert_eq!(bytes[at], 1, "one axis");
    // varint 0xFFFF_FFFF in place of the one-byte count 1.
    let patched = [&bytes[..at], &[0xFF, 0xFF, 0xFF, 0xFF, 0x0F][..], &bytes[at + 1..]].concat();
    let msg = bad_metadata(&patched);
    assert!(
        msg.starts_with("metadata does not decode: field 'axes': 4294967295 entries, but only "),
        "{msg}"
    );
}

#[test]
fn unknown_mapping_variant_names_the_axis_field() {
    let m = Table::from_bytes(CAP).unwrap().meta().clone();
    let (mut bytes, at) = meta_and_axes_offset();
    let a = &m.axes[0];
    let at = at
        + postcard::to_allocvec(&(1u8, &a.name, &a.unit, a.lo, a.hi))
            .unwrap()
            .len();
    bytes[at] = 9;
    let msg = bad_metadata(&bytes);
    assert!(
        msg.starts_with("metadata does not decode: field 'axes[0].mapping': unknown variant 9 (this reader knows 0 = Linear, 1 = Log, 2 = Log1p, 3 = Logit, 4 = Asinh)"),
        "{msg}"
    );
}

#[test]
fn truncated_metadata_names_the_field_it_ends_in() {
    let (bytes, at) = meta_and_axes_offset();
    let msg = bad_metadata(&bytes[..at + 3]);
    assert!(
        msg.starts_with("metadata does not decode: field 'axes[0].name': "),
        "{msg}"
    );
}
