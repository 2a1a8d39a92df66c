//! Integration tests of the table loader: the committed files load and round-trip,
//! and every way a byte string can be wrong is reported with its own error variant
//! (never a panic, never a silently wrong table). Lookups refuse bad queries with
//! typed errors.
//!
//! Corrupt files are built by patching the committed files; where a test needs the
//! corruption to get past the checksums, the CRCs are recomputed (CRC-32 IEEE: header
//! CRC over bytes 0..60 stored at 60..64, metadata CRC at 48..52, payload CRC at
//! 52..56), because `format::encode` refuses to write invalid tables.

use std::f64::consts::{FRAC_PI_2, PI};
use std::ops::Range;

use lobefit_tables::format::{self, Mapping, HEADER_LEN, MAGIC};
use lobefit_tables::{cap_exponent, lobe_integral, CapExponent, LoadError, LobeIntegral, LookupError, Meta, Table};
use proptest::prelude::*;
use proptest::sample::Index;

const LOBE: &[u8] = include_bytes!("../../data/lobe-integral.lobefit");
const CAP: &[u8] = include_bytes!("../../data/cap-exponent.lobefit");
const FILES: [(&str, &[u8]); 2] = [("lobe-integral", LOBE), ("cap-exponent", CAP)];

// Header field offsets (format version 1).
const MAJOR_AT: usize = 8;
const MINOR_AT: usize = 10;
const FLAGS_AT: usize = 12;
const KIND_AT: usize = 16;
const META_OFFSET_AT: usize = 32;
const META_LEN_AT: usize = 36;
const PAYLOAD_OFFSET_AT: usize = 40;
const PAYLOAD_LEN_AT: usize = 44;
const META_CRC_AT: usize = 48;
const PAYLOAD_CRC_AT: usize = 52;
const HEADER_CRC_AT: usize = 60;

// ---------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}

fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

fn put_u16(b: &mut [u8], o: usize, v: u16) {
    b[o..o + 2].copy_from_slice(&v.to_le_bytes());
}

fn put_u32(b: &mut [u8], o: usize, v: u32) {
    b[o..o + 4].copy_from_slice(&v.to_le_bytes());
}

/// Byte ranges of the sections of a well-formed file.
#[derive(Debug, Clone)]
struct Sections {
    meta: Range<usize>,
    padding: Range<usize>,
    payload: Range<usize>,
}

fn sections(file: &[u8]) -> Sections {
    let meta_end = HEADER_LEN + u32_at(file, META_LEN_AT) as usize;
    let p0 = u32_at(file, PAYLOAD_OFFSET_AT) as usize;
    let p1 = p0 + u32_at(file, PAYLOAD_LEN_AT) as usize;
    assert_eq!(p1, file.len(), "helper expects a well-formed file");
    Sections {
        meta: HEADER_LEN..meta_end,
        padding: meta_end..p0,
        payload: p0..p1,
    }
}

/// Recomputes the header CRC (bytes 0..60, stored at 60..64).
fn fix_header_crc(b: &mut [u8]) {
    let crc = crc32fast::hash(&b[..HEADER_CRC_AT]);
    put_u32(b, HEADER_CRC_AT, crc);
}

/// Recomputes the metadata and payload CRCs (where the header's ranges lie inside
/// the byte string), then the header CRC. Works on arbitrarily corrupted headers.
fn fix_crcs(b: &mut [u8]) {
    if b.len() < HEADER_LEN {
        return;
    }
    let meta_crc = HEADER_LEN
        .checked_add(u32_at(b, META_LEN_AT) as usize)
        .and_then(|end| b.get(HEADER_LEN..end))
        .map(crc32fast::hash);
    if let Some(crc) = meta_crc {
        put_u32(b, META_CRC_AT, crc);
    }
    let p0 = u32_at(b, PAYLOAD_OFFSET_AT) as usize;
    let payload_crc = p0
        .checked_add(u32_at(b, PAYLOAD_LEN_AT) as usize)
        .and_then(|end| b.get(p0..end))
        .map(crc32fast::hash);
    if let Some(crc) = payload_crc {
        put_u32(b, PAYLOAD_CRC_AT, crc);
    }
    fix_header_crc(b);
}

/// A file with `template`'s header (kind, versions, flags) around the given metadata
/// and payload bytes, with consistent offsets, zero padding and valid CRCs. Unlike
/// `format::encode` it validates nothing, so it can write what the loader must reject.
fn assemble(template: &[u8], meta: &[u8], payload: &[u8]) -> Vec<u8> {
    let mut out = template[..HEADER_LEN].to_vec();
    let p0 = (HEADER_LEN + meta.len()).div_ceil(16) * 16;
    put_u32(&mut out, META_LEN_AT, meta.len() as u32);
    put_u32(&mut out, PAYLOAD_OFFSET_AT, p0 as u32);
    put_u32(&mut out, PAYLOAD_LEN_AT, payload.len() as u32);
    out.extend_from_slice(meta);
    out.resize(p0, 0);
    out.extend_from_slice(payload);
    fix_crcs(&mut out);
    out
}

/// `file` with its metadata replaced by the (unvalidated) postcard encoding of `meta`.
fn with_meta(file: &[u8], meta: &Meta) -> Vec<u8> {
    let meta_bytes = postcard::to_allocvec(meta).expect("meta serialises");
    assemble(file, &meta_bytes, &file[sections(file).payload])
}

/// `file` with the payload value `#index` replaced by `value`, CRCs fixed.
fn with_value(file: &[u8], index: usize, value: f32) -> Vec<u8> {
    let mut b = file.to_vec();
    let at = sections(file).payload.start + 4 * index;
    b[at..at + 4].copy_from_slice(&value.to_le_bytes());
    fix_crcs(&mut b);
    b
}

fn table(file: &[u8]) -> Table {
    Table::from_bytes(file).expect("committed table loads")
}

fn meta_of(file: &[u8]) -> Meta {
    table(file).meta().clone()
}

/// The load error for `bytes`; fails the test if they load.
#[track_caller]
fn load_err(bytes: &[u8]) -> LoadError {
    match Table::from_bytes(bytes) {
        Ok(t) => panic!(
            "{} bytes unexpectedly loaded as a '{}' table",
            bytes.len(),
            t.meta().kind
        ),
        Err(e) => e,
    }
}

/// The lookup error of `r`; fails the test on a value.
#[track_caller]
fn lookup_err(r: Result<f64, LookupError>) -> LookupError {
    match r {
        Ok(v) => panic!("lookup unexpectedly succeeded with {v}"),
        Err(e) => e,
    }
}

/// Checks that `bad`, a same-length corruption of the valid file `orig`, is rejected
/// with exactly the error of the first check it must fail (magic, major version,
/// header CRC, metadata CRC, payload CRC, zero padding). CRC collisions are neglected
/// (CRC-32 catches every single-byte error; random multi-byte ones escape with
/// probability 2^-32).
#[track_caller]
fn assert_corruption_detected(orig: &[u8], bad: &[u8]) {
    assert_eq!(orig.len(), bad.len());
    let s = sections(orig);
    let changed = |r: Range<usize>| orig[r.clone()] != bad[r];
    let e = match Table::from_bytes(bad) {
        Ok(_) => {
            assert!(orig == bad, "a corrupted file loaded");
            return;
        }
        Err(e) => e,
    };
    assert!(orig != bad, "the unmodified file was rejected: {e:?}");
    if changed(0..MAJOR_AT) {
        let found: [u8; 8] = bad[..8].try_into().unwrap();
        assert_eq!(e, LoadError::BadMagic { found });
    } else if changed(MAJOR_AT..MINOR_AT) {
        assert_eq!(
            e,
            LoadError::UnsupportedFormat {
                found_major: u16_at(bad, MAJOR_AT),
                found_minor: u16_at(bad, MINOR_AT),
                supported_major: format::FORMAT_MAJOR,
            }
        );
    } else if changed(MINOR_AT..HEADER_LEN) {
        assert_eq!(
            e,
            LoadError::Checksum {
                section: "header",
                stored: u32_at(bad, HEADER_CRC_AT),
                computed: crc32fast::hash(&bad[..HEADER_CRC_AT]),
            }
        );
    } else if changed(s.meta.clone()) {
        assert_eq!(
            e,
            LoadError::Checksum {
                section: "metadata",
                stored: u32_at(bad, META_CRC_AT),
                computed: crc32fast::hash(&bad[s.meta]),
            }
        );
    } else if changed(s.payload.clone()) {
        assert_eq!(
            e,
            LoadError::Checksum {
                section: "payload",
                stored: u32_at(bad, PAYLOAD_CRC_AT),
                computed: crc32fast::hash(&bad[s.payload]),
            }
        );
    } else {
        assert!(changed(s.padding), "unclassified corruption");
        assert!(matches!(e, LoadError::BadLayout(_)), "non-zero padding gave {e:?}");
    }
}

/// Applies `(index, value)` mutations; `header_only` aims them at bytes 12..60.
fn mutate(file: &[u8], muts: &[(Index, u8)], header_only: bool) -> Vec<u8> {
    let mut b = file.to_vec();
    for (i, v) in muts {
        let at = if header_only {
            FLAGS_AT + i.index(HEADER_CRC_AT - FLAGS_AT)
        } else {
            i.index(b.len())
        };
        b[at] = *v;
    }
    b
}

/// Exercises a table that loaded: it re-encodes (the writer accepts whatever the
/// reader accepts), the re-encoding loads and is a fixed point, and lookups at the
/// ends and the middle of the domain return (a value or a typed error) without panicking.
fn exercise_loaded(t: &Table) {
    let re = format::encode(t.meta(), t.values()).expect("a table the reader accepts re-encodes");
    let t2 = Table::from_bytes(&re).expect("a re-encoded table loads");
    assert_eq!(format::encode(t2.meta(), t2.values()).unwrap(), re);
    let axes = &t.meta().axes;
    let mut out = vec![0.0; t.meta().channels.len()];
    for pick in [0.0, 0.5, 1.0] {
        let x: Vec<f64> = axes.iter().map(|a| a.lo + pick * (a.hi - a.lo)).collect();
        let _ = t.interpolate(&x, &mut out);
    }
    let _ = LobeIntegral::from_table(t.clone()).map(|l| l.integral(1.0));
    let _ = CapExponent::from_table(t.clone()).map(|c| c.e_cap(0.5));
}

fn file_of(cap: bool) -> &'static [u8] {
    if cap {
        CAP
    } else {
        LOBE
    }
}

// ---------------------------------------------------------------------------------
// 1. Valid files
// ---------------------------------------------------------------------------------

#[test]
fn committed_files_load_and_describe_themselves() {
    for (kind, file) in FILES {
        let t = table(file);
        let h = t.header();
        assert_eq!(h.kind, kind);
        assert_eq!(t.meta().kind, kind);
        assert_eq!((h.major, h.minor), (format::FORMAT_MAJOR, format::FORMAT_MINOR));
        assert_eq!(t.meta().table_version, 1);
        assert_eq!(h.meta_offset as usize, HEADER_LEN);
        assert_eq!(h.payload_offset as usize % format::PAYLOAD_ALIGN, 0);
        let s = sections(file);
        assert_eq!(t.payload_bytes(), &file[s.payload.clone()]);
        assert_eq!(t.values().len() * 4, s.payload.len());
        assert_eq!(Some(s.payload.len() as u64), t.meta().payload_len());
        assert!(t.values().iter().all(|v| v.is_finite()));
        assert!(file[s.padding].iter().all(|&b| b == 0));
    }
}

#[test]
fn family_loaders_accept_their_own_files() {
    let lobes = LobeIntegral::from_bytes(LOBE).expect("lobe-integral loads");
    let i = lobes.integral(10.0).unwrap();
    assert!((i - 2.0 * PI / 11.0).abs() < 1e-6 * i, "I(10) = {i}");
    let caps = CapExponent::from_bytes(CAP).expect("cap-exponent loads");
    let e = caps.e_cap(0.1).unwrap();
    assert!((e - 191.6426).abs() < 0.05, "e_cap(0.1) = {e}");

    assert!(LobeIntegral::from_table(table(LOBE)).is_ok());
    assert!(CapExponent::from_table(table(CAP)).is_ok());
}

#[test]
fn encode_reproduces_committed_files_byte_for_byte() {
    for (kind, file) in FILES {
        let t = table(file);
        let re = format::encode(t.meta(), t.values()).expect("committed table re-encodes");
        assert!(re == file, "{kind}: re-encoding differs from the committed file");
        // The test helper that writes unvalidated files agrees with the writer.
        assert!(
            with_meta(file, t.meta()) == file,
            "{kind}: helper `with_meta` is not faithful"
        );
    }
}

// That the embedded tables are the committed files, for every kind: `table_types`.

// ---------------------------------------------------------------------------------
// 2. Truncation
// ---------------------------------------------------------------------------------

#[test]
fn every_prefix_is_truncated() {
    for (kind, file) in FILES {
        for n in 0..file.len() {
            let e = load_err(&file[..n]);
            // Short of the header, the header is what is missing; after it, the header's
            // own lengths say the whole file is needed.
            let needed = if n < HEADER_LEN { HEADER_LEN } else { file.len() } as u64;
            assert_eq!(
                e,
                LoadError::Truncated { needed, have: n as u64 },
                "{kind} cut to {n} bytes"
            );
        }
    }
}

#[test]
fn short_files_with_the_magic_are_truncated() {
    for (_, file) in FILES {
        for n in MAGIC.len()..HEADER_LEN {
            let e = load_err(&file[..n]);
            assert!(
                matches!(e, LoadError::Truncated { needed: 64, have } if have == n as u64),
                "{n} bytes: {e:?}"
            );
        }
    }
}

#[test]
fn cut_inside_the_payload_is_truncated() {
    for (kind, file) in FILES {
        let s = sections(file);
        for n in [
            s.payload.start,
            s.payload.start + 1,
            s.payload.start + 4,
            file.len() - 1,
        ] {
            let e = load_err(&file[..n]);
            assert!(
                matches!(e, LoadError::Truncated { needed, have } if needed == file.len() as u64 && have == n as u64),
                "{kind} cut to {n}: {e:?}"
            );
        }
        // Inside the metadata too.
        let n = s.meta.start + s.meta.len() / 2;
        assert!(matches!(load_err(&file[..n]), LoadError::Truncated { .. }));
    }
    // The family loaders pass the error on unchanged.
    let n = LOBE.len() - 3;
    let e = LobeIntegral::from_bytes(&LOBE[..n]).unwrap_err();
    assert!(
        matches!(e, LoadError::Truncated { needed, .. } if needed == LOBE.len() as u64),
        "{e:?}"
    );
    let e = CapExponent::from_bytes(&CAP[..10]).unwrap_err();
    assert!(matches!(e, LoadError::Truncated { needed: 64, have: 10 }), "{e:?}");
}

#[test]
fn header_promising_more_than_the_file_holds_is_truncated() {
    for (_, file) in FILES {
        let len = file.len() as u64;
        let mut b = file.to_vec();
        put_u32(&mut b, PAYLOAD_LEN_AT, u32_at(file, PAYLOAD_LEN_AT) + 16);
        fix_header_crc(&mut b);
        assert_eq!(
            load_err(&b),
            LoadError::Truncated {
                needed: len + 16,
                have: len
            }
        );

        // Offsets near u32::MAX must not overflow anything; the payload has exactly one
        // valid offset (the first 16-byte boundary after the metadata).
        let mut b = file.to_vec();
        put_u32(&mut b, PAYLOAD_OFFSET_AT, 0xFFFF_FFF0);
        put_u32(&mut b, PAYLOAD_LEN_AT, 0xFFFF_FFFC);
        fix_header_crc(&mut b);
        match load_err(&b) {
            LoadError::BadLayout(m) => assert!(m.contains("payload offset 4294967280"), "{m}"),
            e => panic!("expected BadLayout, got {e:?}"),
        }
        let mut b = file.to_vec();
        put_u32(&mut b, PAYLOAD_LEN_AT, 0xFFFF_FFFC);
        fix_header_crc(&mut b);
        let needed = u32_at(file, PAYLOAD_OFFSET_AT) as u64 + 0xFFFF_FFFC;
        assert_eq!(load_err(&b), LoadError::Truncated { needed, have: len });

        let mut b = file.to_vec();
        put_u32(&mut b, META_LEN_AT, u32::MAX);
        fix_header_crc(&mut b);
        assert!(matches!(load_err(&b), LoadError::BadLayout(_)));
    }
}

// ---------------------------------------------------------------------------------
// 3. Trailing bytes
// ---------------------------------------------------------------------------------

#[test]
fn trailing_bytes_are_rejected() {
    for (kind, file) in FILES {
        for (extra, fill) in [(1usize, 0u8), (3, 0xAB), (16, 0), (4096, 0x55)] {
            let mut b = file.to_vec();
            b.resize(file.len() + extra, fill);
            assert_eq!(
                load_err(&b),
                LoadError::TrailingBytes { extra: extra as u64 },
                "{kind} + {extra}"
            );
        }
        // Two files concatenated.
        let both = [file, file].concat();
        assert_eq!(
            load_err(&both),
            LoadError::TrailingBytes {
                extra: file.len() as u64
            }
        );
    }
    let mut b = LOBE.to_vec();
    b.push(0);
    assert!(matches!(
        LobeIntegral::from_bytes(&b),
        Err(LoadError::TrailingBytes { extra: 1 })
    ));
}

#[test]
fn header_promising_less_than_the_file_holds_gives_trailing_bytes() {
    let mut b = LOBE.to_vec();
    put_u32(&mut b, PAYLOAD_LEN_AT, u32_at(LOBE, PAYLOAD_LEN_AT) - 4);
    fix_header_crc(&mut b);
    assert_eq!(load_err(&b), LoadError::TrailingBytes { extra: 4 });
}

// ---------------------------------------------------------------------------------
// 4. Magic
// ---------------------------------------------------------------------------------

#[test]
fn wrong_magic_is_rejected() {
    for (_, file) in FILES {
        for i in 0..MAGIC.len() {
            let mut b = file.to_vec();
            b[i] ^= 0x20;
            let found: [u8; 8] = b[..8].try_into().unwrap();
            assert_eq!(load_err(&b), LoadError::BadMagic { found });
        }
    }
    // A text-mode transfer that turned \r\n into \n.
    let mut b = LOBE.to_vec();
    b.remove(4);
    assert!(matches!(load_err(&b), LoadError::BadMagic { found } if found == *b"LBFT\n\x1a\n\x01"));
    // Other file types.
    let png = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR";
    assert!(matches!(load_err(png), LoadError::BadMagic { found } if found == png[..8]));
    let mut zeros = vec![0u8; LOBE.len()];
    assert!(matches!(load_err(&zeros), LoadError::BadMagic { found } if found == [0; 8]));
    zeros[..8].copy_from_slice(b"LBFT\r\n\x1a\r");
    assert!(matches!(load_err(&zeros), LoadError::BadMagic { .. }));
    // Fewer than eight bytes cannot be told apart from a truncated table.
    assert!(matches!(
        load_err(b"PK\x03"),
        LoadError::Truncated { needed: 64, have: 3 }
    ));
    assert!(matches!(CapExponent::from_bytes(png), Err(LoadError::BadMagic { .. })));
}

// ---------------------------------------------------------------------------------
// 5. Format version
// ---------------------------------------------------------------------------------

#[test]
fn future_major_format_version_is_rejected() {
    for (_, file) in FILES {
        for major in [2u16, 0, 0xFFFF] {
            let mut b = file.to_vec();
            put_u16(&mut b, MAJOR_AT, major); // CRCs deliberately left stale
            let e = load_err(&b);
            assert!(
                matches!(e, LoadError::UnsupportedFormat { found_major, found_minor: 0, supported_major: 1 } if found_major == major),
                "major {major}: {e:?}"
            );
        }
    }
    let mut b = LOBE.to_vec();
    put_u16(&mut b, MAJOR_AT, 2);
    let e = load_err(&b);
    assert!(
        matches!(e, LoadError::UnsupportedFormat { found_major: 2, .. }),
        "{e:?}"
    );
    // A future major may have a shorter header: the version is checked first.
    assert!(matches!(
        load_err(&b[..12]),
        LoadError::UnsupportedFormat { found_major: 2, .. }
    ));
    put_u16(&mut b, MINOR_AT, 7);
    assert!(matches!(
        load_err(&b[..16]),
        LoadError::UnsupportedFormat {
            found_major: 2,
            found_minor: 7,
            supported_major: 1
        }
    ));
    assert!(matches!(
        LobeIntegral::from_bytes(&b),
        Err(LoadError::UnsupportedFormat { found_major: 2, .. })
    ));
}

#[test]
fn newer_minor_format_version_loads() {
    // The minor version is informational: any minor of major 1 loads.
    for (_, file) in FILES {
        let mut b = file.to_vec();
        put_u16(&mut b, MINOR_AT, 3);
        fix_header_crc(&mut b);
        let t = Table::from_bytes(&b).expect("minor version 3 loads");
        assert_eq!(t.header().minor, 3);
        assert_eq!(t.values(), table(file).values());
    }
}

// ---------------------------------------------------------------------------------
// 6. Checksums
// ---------------------------------------------------------------------------------

#[test]
fn flipped_header_byte_fails_the_header_checksum() {
    for (_, file) in FILES {
        // Minor, flags, kind, offsets, lengths, CRC fields, reserved, the CRC itself.
        for i in MINOR_AT..HEADER_LEN {
            let mut b = file.to_vec();
            b[i] ^= 0x04;
            let e = load_err(&b);
            assert!(
                matches!(e, LoadError::Checksum { section: "header", stored, computed } if stored != computed),
                "byte {i}: {e:?}"
            );
        }
    }
    // Inside the kind field: "lobe-integral" -> "lobe-integrbl".
    let mut b = LOBE.to_vec();
    b[KIND_AT + 11] = b'b';
    assert!(matches!(load_err(&b), LoadError::Checksum { section: "header", .. }));
    // An offset.
    let mut b = LOBE.to_vec();
    b[PAYLOAD_OFFSET_AT] ^= 0x10;
    assert!(matches!(load_err(&b), LoadError::Checksum { section: "header", .. }));
}

#[test]
fn flipped_metadata_byte_fails_the_metadata_checksum() {
    for (_, file) in FILES {
        let s = sections(file);
        for i in [
            s.meta.start,
            s.meta.start + 5,
            s.meta.start + s.meta.len() / 2,
            s.meta.end - 1,
        ] {
            let mut b = file.to_vec();
            b[i] ^= 0x01;
            let e = load_err(&b);
            assert!(
                matches!(e, LoadError::Checksum { section: "metadata", stored, computed }
                    if stored == u32_at(file, META_CRC_AT) && computed == crc32fast::hash(&b[s.meta.clone()])),
                "byte {i}: {e:?}"
            );
        }
    }
}

#[test]
fn flipped_payload_byte_fails_the_payload_checksum() {
    for (_, file) in FILES {
        let s = sections(file);
        for i in [s.payload.start, s.payload.start + 7, s.payload.end - 1] {
            let mut b = file.to_vec();
            b[i] ^= 0x80;
            let e = load_err(&b);
            assert!(
                matches!(e, LoadError::Checksum { section: "payload", stored, computed }
                    if stored == u32_at(file, PAYLOAD_CRC_AT) && computed == crc32fast::hash(&b[s.payload.clone()])),
                "byte {i}: {e:?}"
            );
        }
    }
}

#[test]
fn every_single_byte_corruption_is_caught_with_the_right_error() {
    for (_, file) in FILES {
        let mut b = file.to_vec();
        for i in 0..file.len() {
            for mask in [0x01u8, 0x80, 0xFF] {
                b[i] ^= mask;
                assert_corruption_detected(file, &b);
                b[i] ^= mask;
            }
        }
    }
}

// ---------------------------------------------------------------------------------
// 7. Non-finite payload behind valid checksums
// ---------------------------------------------------------------------------------

#[test]
fn non_finite_payload_with_valid_checksums_is_rejected() {
    for (_, file) in FILES {
        let n = table(file).values().len();
        for index in [0, n / 2, n - 1] {
            for value in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                let b = with_value(file, index, value);
                let e = load_err(&b);
                assert!(
                    matches!(e, LoadError::NonFinite { index: i, value: v }
                        if i == index && (v.to_bits() == value.to_bits())),
                    "#{index} = {value}: {e:?}"
                );
            }
        }
        // A quiet NaN with a payload, and the first bad value is the one reported.
        let b = with_value(&with_value(file, 9, f32::from_bits(0x7FC0_1234)), 3, f32::NAN);
        let e = load_err(&b);
        assert!(
            matches!(e, LoadError::NonFinite { index: 3, value } if value.is_nan()),
            "{e:?}"
        );
    }
    let b = with_value(LOBE, 0, f32::NAN);
    assert!(matches!(
        LobeIntegral::from_bytes(&b),
        Err(LoadError::NonFinite { index: 0, value }) if value.is_nan()
    ));
}

// ---------------------------------------------------------------------------------
// 8. Kind and family version
// ---------------------------------------------------------------------------------

#[test]
fn wrong_kind_is_rejected() {
    let e = CapExponent::from_bytes(LOBE).unwrap_err();
    assert!(
        matches!(&e, LoadError::WrongKind { expected, found } if expected == "cap-exponent" && found == "lobe-integral"),
        "{e:?}"
    );
    let e = LobeIntegral::from_bytes(CAP).unwrap_err();
    assert!(
        matches!(&e, LoadError::WrongKind { expected, found } if expected == "lobe-integral" && found == "cap-exponent"),
        "{e:?}"
    );
    let e = CapExponent::from_table(table(LOBE)).unwrap_err();
    assert!(
        matches!(&e, LoadError::WrongKind { expected, .. } if expected == cap_exponent::KIND),
        "{e:?}"
    );
    let e = LobeIntegral::from_table(table(CAP)).unwrap_err();
    assert!(
        matches!(&e, LoadError::WrongKind { expected, .. } if expected == lobe_integral::KIND),
        "{e:?}"
    );
    let e = Table::from_bytes_of_kind(LOBE, "sg-fit", 1).unwrap_err();
    assert!(
        matches!(&e, LoadError::WrongKind { found, .. } if found == "lobe-integral"),
        "{e:?}"
    );
}

#[test]
fn unsupported_table_version_is_rejected() {
    for (kind, file) in FILES {
        let mut meta = meta_of(file);
        meta.table_version = 99;
        let b = format::encode(&meta, table(file).values()).expect("version 99 encodes");
        // The generic loader does not care about family versions...
        assert_eq!(table(&b).meta().table_version, 99);
        // ...the family loaders do.
        let e = if kind == lobe_integral::KIND {
            LobeIntegral::from_bytes(&b).unwrap_err()
        } else {
            CapExponent::from_bytes(&b).unwrap_err()
        };
        assert_eq!(
            e,
            LoadError::UnsupportedTableVersion {
                kind: kind.to_string(),
                found: 99,
                supported: 1
            }
        );
        let e = Table::from_bytes_of_kind(&b, kind, 1).unwrap_err();
        assert!(
            matches!(
                e,
                LoadError::UnsupportedTableVersion {
                    found: 99,
                    supported: 1,
                    ..
                }
            ),
            "{e:?}"
        );
        // The kind is checked before the version.
        let other = if kind == lobe_integral::KIND {
            CapExponent::from_bytes(&b).unwrap_err()
        } else {
            LobeIntegral::from_bytes(&b).unwrap_err()
        };
        assert!(
            matches!(&other, LoadError::WrongKind { found, .. } if found == kind),
            "{other:?}"
        );
    }
}

// ---------------------------------------------------------------------------------
// 9. Metadata that is garbage, or decodes but is invalid
// ---------------------------------------------------------------------------------

#[test]
fn swapped_axis_range_patched_in_place_is_invalid() {
    // Patch the bytes of the axis range in place (lo <-> hi), then fix the CRCs.
    for (_, file) in FILES {
        let axis = &meta_of(file).axes[0];
        let needle = [axis.lo.to_le_bytes(), axis.hi.to_le_bytes()].concat();
        let swapped = [axis.hi.to_le_bytes(), axis.lo.to_le_bytes()].concat();
        let s = sections(file);
        let hits: Vec<usize> = (s.meta.start..s.meta.end - 16)
            .filter(|&i| file[i..i + 16] == needle[..])
            .collect();
        assert_eq!(hits.len(), 1, "axis range found {} times", hits.len());
        let mut b = file.to_vec();
        b[hits[0]..hits[0] + 16].copy_from_slice(&swapped);
        fix_crcs(&mut b);
        let e = load_err(&b);
        assert!(matches!(e, LoadError::Invalid(_)), "{e:?}");
    }
}

#[test]
fn metadata_that_decodes_but_is_invalid_is_rejected() {
    type Edit = fn(&mut Meta);
    let edits: [(&str, Edit); 17] = [
        ("axis count 1", |m| m.axes[0].count = 1),
        ("axis count 0", |m| m.axes[0].count = 0),
        ("lo > hi", |m| {
            let a = &mut m.axes[0];
            std::mem::swap(&mut a.lo, &mut a.hi);
        }),
        ("lo == hi", |m| m.axes[0].lo = m.axes[0].hi),
        ("lo NaN", |m| m.axes[0].lo = f64::NAN),
        ("hi infinite", |m| m.axes[0].hi = f64::INFINITY),
        ("log mapping with lo <= 0", |m| {
            m.axes[0].lo = 0.0;
            m.axes[0].mapping = Mapping::Log;
        }),
        ("log1p scale 0", |m| m.axes[0].mapping = Mapping::Log1p { scale: 0.0 }),
        ("log1p scale NaN", |m| {
            m.axes[0].mapping = Mapping::Log1p { scale: f64::NAN }
        }),
        ("logit not containing the range", |m| {
            let (lo, hi) = (m.axes[0].lo, m.axes[0].hi);
            m.axes[0].mapping = Mapping::Logit { a: lo, b: hi };
        }),
        ("no axes", |m| m.axes.clear()),
        ("five axes", |m| {
            let a = m.axes[0].clone();
            m.axes = vec![a; 5];
        }),
        ("no channels", |m| m.channels.clear()),
        ("diagnostics entry count off by one", |m| m.diagnostics.entries += 1),
        ("settings hash mismatch", |m| m.fit.settings_hash ^= 1),
        ("metadata kind differs from header kind", |m| {
            m.kind = if m.kind == lobe_integral::KIND {
                cap_exponent::KIND.into()
            } else {
                lobe_integral::KIND.into()
            }
        }),
        ("extra channel: payload too short", |m| {
            let c = m.channels[0].clone();
            m.channels.push(c);
        }),
    ];
    for (kind, file) in FILES {
        for (what, edit) in edits {
            let mut meta = meta_of(file);
            edit(&mut meta);
            let b = with_meta(file, &meta);
            let e = load_err(&b);
            assert!(matches!(e, LoadError::Invalid(_)), "{kind}, {what}: {e:?}");
        }
        // Per-entry diagnostics shorter than the grid.
        let mut meta = meta_of(file);
        if let Some(p) = meta.diagnostics.per_entry.as_mut() {
            p.residual.pop();
            let e = load_err(&with_meta(file, &meta));
            assert!(matches!(e, LoadError::Invalid(_)), "{kind}, per-entry: {e:?}");
        }
        // Payload one value short of what the axes and channels need.
        let s = sections(file);
        let b = assemble(file, &file[s.meta.clone()], &file[s.payload.start..s.payload.end - 4]);
        let e = load_err(&b);
        assert!(matches!(e, LoadError::Invalid(_)), "{kind}, short payload: {e:?}");
    }
}

#[test]
fn garbage_metadata_with_valid_checksums_is_rejected() {
    for (kind, file) in FILES {
        let s = sections(file);
        let meta = &file[s.meta.clone()];
        let payload = &file[s.payload.clone()];
        let cases: [(&str, Vec<u8>); 6] = [
            ("empty", vec![]),
            ("0xFF bytes", vec![0xFF; 64]),
            ("zero bytes", vec![0; 64]),
            ("cut by one byte", meta[..meta.len() - 1].to_vec()),
            ("one byte too many", [meta, &[0]].concat()),
            (
                "kind not UTF-8",
                [&[4u8, 0xFF, 0xFE, 0xFD, 0xFC][..], &meta[1 + kind.len()..]].concat(),
            ),
        ];
        for (what, m) in cases {
            let e = load_err(&assemble(file, &m, payload));
            assert!(matches!(e, LoadError::BadMetadata(_)), "{kind}, {what}: {e:?}");
        }
    }
}

#[test]
fn inconsistent_layout_is_rejected() {
    for (kind, file) in FILES {
        type Patch = fn(&mut Vec<u8>);
        let patches: [(&str, Patch); 8] = [
            ("metadata offset 65", |b| put_u32(b, META_OFFSET_AT, 65)),
            ("payload offset not aligned", |b| {
                let p = u32_at(b, PAYLOAD_OFFSET_AT);
                put_u32(b, PAYLOAD_OFFSET_AT, p - 1);
            }),
            ("payload offset inside the metadata", |b| {
                put_u32(b, PAYLOAD_OFFSET_AT, 64)
            }),
            ("payload length not a multiple of 4", |b| {
                let n = u32_at(b, PAYLOAD_LEN_AT);
                put_u32(b, PAYLOAD_LEN_AT, n - 2);
            }),
            ("kind empty", |b| b[KIND_AT..KIND_AT + 16].fill(0)),
            ("kind not NUL padded", |b| b[KIND_AT + 15] = b'x'),
            ("kind not ASCII", |b| b[KIND_AT] = 0xC3),
            ("kind without padding but bytes after a NUL", |b| {
                b[KIND_AT..KIND_AT + 16].copy_from_slice(b"lobe\0integral\0\0x")
            }),
        ];
        for (what, patch) in patches {
            let mut b = file.to_vec();
            patch(&mut b);
            fix_header_crc(&mut b);
            let e = load_err(&b);
            assert!(matches!(e, LoadError::BadLayout(_)), "{kind}, {what}: {e:?}");
        }
        // Padding is not covered by a CRC but must be zero.
        let s = sections(file);
        assert!(!s.padding.is_empty());
        let mut b = file.to_vec();
        b[s.padding.end - 1] = 1;
        let e = load_err(&b);
        assert!(matches!(e, LoadError::BadLayout(_)), "{kind}, padding: {e:?}");
    }
}

// ---------------------------------------------------------------------------------
// 10. Lookups
// ---------------------------------------------------------------------------------

#[test]
fn lobe_integral_refuses_bad_exponents() {
    let lobes = LobeIntegral::from_bytes(LOBE).unwrap();
    let e_max = lobe_integral::E_MAX;
    for e in [-1.0, -1e-300, e_max * 1.0001, 1e300] {
        let err = lookup_err(lobes.integral(e));
        assert!(
            matches!(&err, LookupError::OutOfDomain { name, value, lo, hi }
                if name == "e" && *value == e && *lo == 0.0 && *hi == e_max),
            "I({e}): {err:?}"
        );
    }
    for e in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let err = lookup_err(lobes.integral(e));
        assert!(
            matches!(&err, LookupError::NotFinite { name, value } if name == "e" && value.to_bits() == e.to_bits()),
            "I({e}): {err:?}"
        );
    }
    assert!(matches!(
        lobes.integral_f32(f32::NAN),
        Err(LookupError::NotFinite { .. })
    ));
    assert!(matches!(lobes.integral_f32(-2.0), Err(LookupError::OutOfDomain { .. })));
    assert!(matches!(lobe_integral::exact(-1.0), Err(LookupError::OutOfDomain { ref name, .. }) if name == "e"));
    assert!(matches!(lobe_integral::exact(f64::NAN), Err(LookupError::NotFinite { ref name, .. }) if name == "e"));
    // The ends of the domain are fine.
    for e in [0.0, e_max] {
        let i = lobes.integral(e).unwrap();
        let exact = lobe_integral::exact(e).unwrap();
        assert!((i - exact).abs() <= 1e-6 * exact, "I({e}) = {i}, exact {exact}");
    }
}

#[test]
fn cap_exponent_refuses_bad_angles() {
    let caps = CapExponent::from_bytes(CAP).unwrap();
    for a in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let err = lookup_err(caps.e_cap(a));
        assert!(
            matches!(&err, LookupError::NotFinite { name, value } if name == "alpha" && value.to_bits() == a.to_bits()),
            "e_cap({a}): {err:?}"
        );
    }
    for a in [1e-4, 0.0, -0.5, 4.0, PI * (1.0 + 1e-12)] {
        let err = lookup_err(caps.e_cap(a));
        assert!(
            matches!(&err, LookupError::OutOfDomain { name, value, lo, hi }
                if name == "alpha" && *value == a && *lo == cap_exponent::ALPHA_MIN && *hi == PI),
            "e_cap({a}): {err:?}"
        );
    }
    assert!(matches!(caps.e_cap_f32(f32::NAN), Err(LookupError::NotFinite { .. })));
    // The ratio's domain ends at π/2.
    let err = lookup_err(caps.ratio(FRAC_PI_2 + 0.01));
    assert!(
        matches!(&err, LookupError::OutOfDomain { name, hi, .. } if name == "alpha" && *hi == FRAC_PI_2),
        "{err:?}"
    );
    assert!(matches!(caps.ratio(f64::NAN), Err(LookupError::NotFinite { .. })));
}

#[test]
fn cap_exponent_is_zero_from_half_pi_to_pi() {
    let caps = CapExponent::from_bytes(CAP).unwrap();
    for k in 0..=100 {
        let a = FRAC_PI_2 + (PI - FRAC_PI_2) * k as f64 / 100.0;
        assert_eq!(caps.e_cap(a), Ok(0.0), "e_cap({a})");
    }
    assert_eq!(caps.e_cap(FRAC_PI_2), Ok(0.0));
    assert_eq!(caps.e_cap(PI), Ok(0.0));
    assert_eq!(caps.e_cap_f32(2.0), Ok(0.0));
    // Just inside the domain the exponent is finite and positive (large near ALPHA_MIN).
    for a in [cap_exponent::ALPHA_MIN, 0.5, FRAC_PI_2 - 1e-9] {
        let e = caps.e_cap(a).unwrap();
        assert!(e.is_finite() && e >= 0.0, "e_cap({a}) = {e}");
    }
    assert!(caps.e_cap(cap_exponent::ALPHA_MIN).unwrap() > 1e6);
}

// ---------------------------------------------------------------------------------
// 12. Table::interpolate arity
// ---------------------------------------------------------------------------------

#[test]
fn interpolate_checks_arity() {
    for (_, file) in FILES {
        let t = table(file);
        let a = &t.meta().axes[0];
        let mid = 0.5 * (a.lo + a.hi);
        let mut one = [0.0];
        assert_eq!(
            t.interpolate(&[], &mut one),
            Err(LookupError::Arity { expected: 1, got: 0 })
        );
        assert_eq!(
            t.interpolate(&[mid, mid], &mut one),
            Err(LookupError::Arity { expected: 1, got: 2 })
        );
        assert_eq!(
            t.interpolate(&[mid], &mut []),
            Err(LookupError::Channels { expected: 1, got: 0 })
        );
        assert_eq!(
            t.interpolate(&[mid], &mut [0.0; 2]),
            Err(LookupError::Channels { expected: 1, got: 2 })
        );
        // Arity is checked before the coordinates.
        assert!(matches!(
            t.interpolate(&[f64::NAN, f64::NAN], &mut one),
            Err(LookupError::Arity { expected: 1, got: 2 })
        ));
        // And the coordinates are checked against the axis, by name.
        let err = t.interpolate(&[f64::NAN], &mut one).unwrap_err();
        assert!(
            matches!(&err, LookupError::NotFinite { name, .. } if *name == a.name),
            "{err:?}"
        );
        let err = t.interpolate(&[a.lo - 1.0], &mut one).unwrap_err();
        assert!(
            matches!(&err, LookupError::OutOfDomain { name, .. } if *name == a.name),
            "{err:?}"
        );
        t.interpolate(&[mid], &mut one).unwrap();
        assert!(one[0].is_finite());
    }
}

// ---------------------------------------------------------------------------------
// Validation gaps these tests found (fixed in the loader since)
// ---------------------------------------------------------------------------------

#[test]
fn axis_with_non_finite_mapped_range_is_invalid() {
    // lo, hi finite and lo < hi, but hi - lo overflows: node_coordinate(hi) = inf/inf.
    let mut meta = meta_of(LOBE);
    meta.axes[0].lo = -1e308;
    meta.axes[0].hi = 1e308;
    meta.axes[0].mapping = Mapping::Linear;
    let b = with_meta(LOBE, &meta);
    match Table::from_bytes(&b) {
        Err(LoadError::Invalid(_)) => {}
        Err(e) => panic!("expected Invalid, got {e:?}"),
        Ok(t) => {
            let mut out = [0.0];
            let r = t.interpolate(&[1e308], &mut out);
            panic!("table loaded; interpolate(1e308) = {r:?}, value {}", out[0]);
        }
    }
}

#[test]
fn log_channel_that_decodes_to_infinity_is_rejected() {
    // Every stored ln I = 1000 (finite f32), but exp(1000) = inf.
    let n = table(LOBE).values().len();
    let mut b = LOBE.to_vec();
    for i in 0..n {
        let at = sections(LOBE).payload.start + 4 * i;
        b[at..at + 4].copy_from_slice(&1000.0f32.to_le_bytes());
    }
    fix_crcs(&mut b);
    match LobeIntegral::from_bytes(&b) {
        Err(LoadError::Invalid(_) | LoadError::NonFinite { .. }) => {}
        Err(e) => panic!("expected Invalid or NonFinite, got {e:?}"),
        Ok(l) => panic!("table loaded; integral(1) = {:?}", l.integral(1.0)),
    }
}

// ---------------------------------------------------------------------------------
// 11. Property tests: no input panics the loader
// ---------------------------------------------------------------------------------

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 256,
        // Do not write regression files into the source tree.
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    /// (a) Arbitrary bytes: never a panic; short ones are truncated, the rest lack the magic.
    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..2048)) {
        match Table::from_bytes(&bytes) {
            Err(LoadError::Truncated { needed: 64, have }) if bytes.len() < 8 => {
                prop_assert_eq!(have, bytes.len() as u64)
            }
            Err(LoadError::BadMagic { found }) => prop_assert_eq!(&found[..], &bytes[..8]),
            other => prop_assert!(false, "{:?}", other.map(|_| ())),
        }
    }

    /// (a') Arbitrary bytes after the magic (and after magic + version 1): never a panic.
    #[test]
    fn arbitrary_bytes_after_the_magic_never_panic(
        with_version in any::<bool>(),
        tail in prop::collection::vec(any::<u8>(), 0..2048),
    ) {
        let mut bytes = MAGIC.to_vec();
        if with_version {
            bytes.extend_from_slice(&[1, 0]);
        }
        bytes.extend_from_slice(&tail);
        let r = Table::from_bytes(&bytes);
        prop_assert!(
            matches!(
                r,
                Err(LoadError::Truncated { .. }
                    | LoadError::UnsupportedFormat { .. }
                    | LoadError::Checksum { section: "header", .. })
            ),
            "{:?}",
            r.map(|_| ())
        );
    }

    /// (b) Arbitrary bytes behind the valid header of a real file: never a panic, and
    /// since the header's lengths cannot match, always `Truncated`.
    #[test]
    fn arbitrary_bytes_behind_a_real_header_never_panic(
        cap in any::<bool>(),
        tail in prop::collection::vec(any::<u8>(), 0..2048),
    ) {
        let file = file_of(cap);
        let bytes = [&file[..HEADER_LEN], &tail[..]].concat();
        let r = Table::from_bytes(&bytes);
        prop_assert_eq!(
            r.map(|_| ()),
            Err(LoadError::Truncated { needed: file.len() as u64, have: bytes.len() as u64 })
        );
    }

    /// (b') Random metadata (a random cut of the real one plus random bytes) behind a
    /// consistent header with valid CRCs: postcard decoding and validation never panic.
    #[test]
    fn random_metadata_with_valid_checksums_never_panics(
        cap in any::<bool>(),
        cut in any::<Index>(),
        tail in prop::collection::vec(any::<u8>(), 0..512),
        payload_words in prop::collection::vec(any::<u32>(), 0..64),
        real_payload in any::<bool>(),
    ) {
        let file = file_of(cap);
        let s = sections(file);
        let meta = [&file[s.meta.start..s.meta.start + cut.index(s.meta.len() + 1)], &tail[..]].concat();
        let random_payload: Vec<u8> = payload_words.iter().flat_map(|w| w.to_le_bytes()).collect();
        let payload = if real_payload { &file[s.payload.clone()] } else { &random_payload[..] };
        match Table::from_bytes(&assemble(file, &meta, payload)) {
            Ok(t) => exercise_loaded(&t),
            Err(LoadError::BadMetadata(_) | LoadError::Invalid(_) | LoadError::NonFinite { .. }) => {}
            Err(e) => prop_assert!(false, "{:?}", e),
        }
    }

    /// (c) A valid file with 1..8 random byte mutations: never a panic; loads only if
    /// the bytes are unchanged, otherwise fails the first check it must fail.
    #[test]
    fn mutated_files_never_panic(
        cap in any::<bool>(),
        muts in prop::collection::vec((any::<Index>(), any::<u8>()), 1..=8),
    ) {
        let file = file_of(cap);
        let bad = mutate(file, &muts, false);
        assert_corruption_detected(file, &bad);
    }

    /// (d) Random mutations with all three CRCs recomputed, so layout checks, postcard
    /// decoding and validation are exercised: never a panic, never a checksum error,
    /// and whatever loads re-encodes and can be looked up without panicking.
    #[test]
    fn mutated_files_with_valid_checksums_never_panic(
        cap in any::<bool>(),
        header_only in prop::bool::weighted(0.25),
        muts in prop::collection::vec((any::<Index>(), any::<u8>()), 1..=8),
    ) {
        let file = file_of(cap);
        let mut bad = mutate(file, &muts, header_only);
        fix_crcs(&mut bad);
        match Table::from_bytes(&bad) {
            Ok(t) => exercise_loaded(&t),
            Err(e @ (LoadError::Checksum { .. } | LoadError::Io { .. })) => prop_assert!(false, "{:?}", e),
            Err(_) => {}
        }
    }
}

#[test]
fn non_zero_flags_or_reserved_words_are_rejected() {
    for (_, file) in FILES {
        for at in [12usize, 56] {
            let mut b = file.to_vec();
            b[at] = 7;
            fix_header_crc(&mut b);
            match load_err(&b) {
                LoadError::BadLayout(m) => assert!(m.contains("flags or reserved"), "{m}"),
                e => panic!("expected BadLayout, got {e:?}"),
            }
        }
    }
}

#[test]
fn unconverged_entries_are_rejected() {
    let mut meta = meta_of(LOBE);
    meta.diagnostics.converged -= 1;
    match load_err(&with_meta(LOBE, &meta)) {
        LoadError::Invalid(m) => assert!(m.contains("unconverged"), "{m}"),
        e => panic!("expected Invalid, got {e:?}"),
    }
    let mut meta = meta_of(LOBE);
    meta.diagnostics.per_entry.as_mut().unwrap().converged[17] = false;
    match load_err(&with_meta(LOBE, &meta)) {
        LoadError::Invalid(m) => assert!(m.contains("entry 17 is flagged unconverged"), "{m}"),
        e => panic!("expected Invalid, got {e:?}"),
    }
}

/// Right kind and version but a layout the runtime would misread: refused at load.
#[test]
fn family_loaders_reject_foreign_layouts() {
    let expect_mismatch = |bytes: &[u8], what: &str| {
        let r = if what.starts_with("cap") {
            CapExponent::from_bytes(bytes).map(|_| ())
        } else {
            LobeIntegral::from_bytes(bytes).map(|_| ())
        };
        match r {
            Err(LoadError::LayoutMismatch { detail, .. }) => detail,
            other => panic!("{what}: expected LayoutMismatch, got {other:?}"),
        }
    };
    // Channel encoding flipped (ln I read as I).
    let mut meta = meta_of(LOBE);
    meta.channels[0].encoding = lobefit_tables::Encoding::Linear;
    assert!(expect_mismatch(&with_meta(LOBE, &meta), "lobe encoding").contains("channels"));
    // Axis mapping changed (values at logit nodes read on a linear axis).
    let mut meta = meta_of(CAP);
    meta.axes[0].mapping = Mapping::Linear;
    assert!(expect_mismatch(&with_meta(CAP, &meta), "cap mapping").contains("axis"));
    // Axis range changed.
    let mut meta = meta_of(CAP);
    meta.axes[0].lo = 0.01;
    expect_mismatch(&with_meta(CAP, &meta), "cap range");
    // A second channel.
    let t = table(CAP);
    let mut meta = t.meta().clone();
    let mut extra = meta.channels[0].clone();
    extra.name = "extra".into();
    meta.channels.push(extra);
    let values: Vec<f32> = t.values().iter().flat_map(|&v| [v, v]).collect();
    let bytes = lobefit_tables::format::encode(&meta, &values).unwrap();
    assert!(expect_mismatch(&bytes, "cap channels").contains("channels"));
    // A finer grid of the same layout is accepted (node count is free).
    let t = table(CAP);
    let mut meta = t.meta().clone();
    meta.axes[0].count = 2;
    meta.diagnostics.entries = 2;
    meta.diagnostics.converged = 2;
    meta.diagnostics.per_entry = None;
    let bytes = lobefit_tables::format::encode(&meta, &t.values()[..2]).unwrap();
    assert!(CapExponent::from_bytes(&bytes).is_ok());
}

// ---------------------------------------------------------------------------------
// 12. Plausible channel ranges: finite but absurd payloads, and lookups that stay finite
// ---------------------------------------------------------------------------------

use lobefit_tables::glam::{DVec3, Vec3};
use lobefit_tables::mask_weights::{self, MaskMode, MaskWeights, WeightSet, MAX_DEPTH};
use lobefit_tables::{
    disk_light, embedded, isg, lobe_product, log_zh, sg_fit, shexp, wedge, wrap, BestIsg, DiskLight, IsgModel, Lobe,
    Lobe32, LobeProduct, RefitIsg, SgFit, KINDS,
};

use crate::table_types::committed;

/// A family's declared channel ranges: (channel, lo, hi).
type Ranges = Vec<(&'static str, f64, f64)>;

/// The committed table of `kind` (one of `KINDS`, so every committed table) with its
/// family's declared channel ranges.
fn ranged_table(kind: &str) -> (Vec<u8>, Ranges) {
    let ranges = match kind {
        "lobe-integral" => lobe_integral::CHANNEL_RANGES.to_vec(),
        "cap-exponent" => cap_exponent::CHANNEL_RANGES.to_vec(),
        "isg-refit" => isg::REFIT_CHANNEL_RANGES.to_vec(),
        "isg-best" => isg::BEST_CHANNEL_RANGES.to_vec(),
        "sg-fit" => sg_fit::CHANNEL_RANGES.to_vec(),
        "log-zh" => log_zh::CHANNEL_RANGES.to_vec(),
        "wedge" => wedge::CHANNEL_RANGES.to_vec(),
        "shexp" => shexp::CHANNEL_RANGES.to_vec(),
        "lobe-product" | "lobe-product-l2" => lobe_product::CHANNEL_RANGES.to_vec(),
        "disk-light" => disk_light::CHANNEL_RANGES.to_vec(),
        "wrap" => wrap::CHANNEL_RANGES.to_vec(),
        // One range for every weight channel.
        "mask-weights" => {
            let (lo, hi) = mask_weights::WEIGHT_RANGE;
            mask_weights::channel_names()
                .iter()
                .map(|c| (c.as_str(), lo, hi))
                .collect()
        }
        other => panic!("no channel ranges for kind {other}"),
    };
    (committed(kind), ranges)
}

/// (lo, hi) of each channel of `t`, in channel order, from `ranges`.
fn channel_bounds(t: &Table, ranges: &[(&str, f64, f64)]) -> Vec<(f64, f64)> {
    t.meta()
        .channels
        .iter()
        .map(|c| {
            let r = ranges
                .iter()
                .find(|r| r.0 == c.name)
                .expect("every channel has a range");
            (r.1, r.2)
        })
        .collect()
}

/// `file` with its whole payload replaced by `values`, CRCs fixed.
fn with_payload(file: &[u8], values: &[f32]) -> Vec<u8> {
    let mut b = file.to_vec();
    let s = sections(file);
    assert_eq!(s.payload.len(), 4 * values.len());
    for (chunk, v) in b[s.payload].chunks_exact_mut(4).zip(values) {
        chunk.copy_from_slice(&v.to_le_bytes());
    }
    fix_crcs(&mut b);
    b
}

/// Loads `bytes` with the family loader of `kind`, and on success runs that family's
/// lookups at a few query points (including huge finite scales and radiances),
/// returning every number the lookups produced (errors are dropped: they are allowed).
fn family_lookups(kind: &str, bytes: &[u8]) -> Result<Vec<f64>, LoadError> {
    let mut got: Vec<f64> = Vec::new();
    let mut put = |r: Result<Vec<f64>, LookupError>| {
        if let Ok(v) = r {
            got.extend(v);
        }
    };
    let z = DVec3::Z;
    match kind {
        "lobe-integral" => {
            let t = LobeIntegral::from_bytes(bytes)?;
            for e in [0.0, 1.0, 333.3, 1e5] {
                put(t.integral(e).map(|v| vec![v]));
                put(t.integral_f32(e as f32).map(|v| vec![v as f64]));
            }
        }
        "cap-exponent" => {
            let t = CapExponent::from_bytes(bytes)?;
            for a in [1e-3, 0.1, 1.0, FRAC_PI_2 - 1e-8, 2.0] {
                put(t.e_cap(a).map(|v| vec![v]));
                put(t.ratio(a.min(FRAC_PI_2)).map(|v| vec![v]));
                put(t.e_cap_f32(a as f32).map(|v| vec![v as f64]));
            }
        }
        "isg-refit" | "isg-best" => {
            let refit;
            let best;
            let m: &dyn IsgModel = if kind == "isg-refit" {
                refit = RefitIsg::from_bytes(bytes)?;
                &refit
            } else {
                best = BestIsg::from_bytes(bytes)?;
                &best
            };
            for (th, ph, g) in [
                (0.0, 0.0, 0.5),
                (1.0, 2.0, 7.0),
                (FRAC_PI_2, FRAC_PI_2, 1e4),
                (PI, 0.3, 300.0),
            ] {
                put(m.s_hat(th, ph, g).map(|v| vec![v]));
                put(m.s(th, ph, g).map(|v| vec![v]));
                put(m.patch(0.0, th, ph, PI, g).map(|v| vec![v]));
                put(m.limiting_angle(g, 0.01).map(|v| vec![v]));
                put(m.s_f32(th as f32, ph as f32, g as f32).map(|v| vec![v as f64]));
            }
        }
        "sg-fit" => {
            let t = SgFit::from_bytes(bytes)?;
            for e in [0.0, 1.0, 1e5] {
                put(t.fit(e).map(|(l, m)| vec![l, m]));
                put(t.fit_f32(e as f32).map(|(l, m)| vec![l as f64, m as f64]));
                for s in [1.0, 1e300, f64::MAX] {
                    put(t
                        .lobe_to_sg([0.0, 0.0, 1.0], e, s)
                        .map(|g| vec![g.sharpness, g.amplitude]));
                }
            }
        }
        "log-zh" => {
            let t = log_zh::LogZh::from_bytes(bytes)?;
            let mut out = [0.0; 8];
            for (eps, r) in [(0.01, 1.0), (0.3, 17.5), (0.99, 128.0)] {
                put(t.table_lookup(8, eps, r, &mut out).map(|_| out.to_vec()));
            }
        }
        "wedge" => {
            let t = wedge::Wedge::from_bytes(bytes)?;
            let mut out = [0.0; 64];
            put(t.m_lin(16, 8, 63, 15).map(|v| vec![v]));
            put(t.wedge(4, &[f64::MAX; 8], &[1.0; 8], &mut out).map(|_| out.to_vec()));
            put(t
                .compose(&[0.3, -1.0, 1.5, 0.0], 0.01, 8, &mut out)
                .map(|_| out.to_vec()));
        }
        "shexp" => {
            let t = shexp::ShExp::from_bytes(bytes)?;
            let mut out = [0.0; 64];
            for n in [3, 8] {
                for th in [0.0, 0.7, FRAC_PI_2] {
                    put(t.log_zh(th, n, &mut out).map(|_| out[..n].to_vec()));
                    put(t.norm_ab(th, n).map(|(a, b, c)| vec![a, b, c]));
                }
                let top = t.norm_max(n).unwrap();
                put(t.ab_for_norm(0.5 * top, n).map(|(a, b)| vec![a, b]));
                let mut f = vec![0.0; n * n];
                f[0] = -2.0;
                f[1] = 0.8;
                f[n * n - 1] = -5.0;
                put(t.hyb(&f, &mut out).map(|_| out[..n * n].to_vec()));
            }
        }
        "lobe-product" | "lobe-product-l2" => {
            let t = LobeProduct::from_bytes(bytes)?;
            let lobe = |s: f64, a: DVec3, e: f64| Lobe {
                scale: s,
                axis: a,
                exponent: e,
            };
            let tilted = DVec3::new(0.6, 0.0, 0.8);
            for (e1, e2, al) in [(0.0, 0.0, 0.0), (3.0, 70.0, 0.5), (1e5, 1e5, PI), (0.1, 1e5, FRAC_PI_2)] {
                put(t.params(e1, e2, al).map(|p| vec![p.p, p.t, p.e_r, p.integral]));
            }
            put(t
                .product(&lobe(1e200, z, 2.0), &lobe(1e200, z, 3.0))
                .map(|l| vec![l.scale, l.exponent]));
            let huge = [lobe(1.0, z, 1e300), lobe(f64::MAX, tilted, 1.0)];
            put(t
                .product_sums(&huge, &huge, 0.0)
                .map(|v| v.iter().flat_map(|l| [l.scale, l.exponent]).collect()));
            put(t.triple_product(&huge, &huge, &huge, z, 0.0).map(|v| vec![v]));
            let f32_lobe = |s: f32| Lobe32 {
                scale: s,
                axis: Vec3::Z,
                exponent: 4.0,
            };
            put(t
                .product_f32(&f32_lobe(f32::MAX), &f32_lobe(2.0))
                .map(|l| vec![l.scale as f64, l.exponent as f64]));
        }
        "disk-light" => {
            let t = DiskLight::from_bytes(bytes)?;
            for (r, tau) in [(1e-3, 0.0), (0.01, 1.0), (0.7, 1.5), (10.0, 1.5706), (1e6, 0.2)] {
                put(t.canonical(r, tau).map(|c| c.to_vec()));
            }
            let (c, n) = (DVec3::new(0.0, 0.0, 2.0), DVec3::new(0.3, 0.0, -1.0));
            for radiance in [1.0, 1e300, f64::MAX] {
                put(t.radiance_sh(DVec3::ZERO, c, n, 0.5, radiance).map(|v| v.to_vec()));
                put(t.irradiance(DVec3::ZERO, z, c, n, 0.5, radiance).map(|v| vec![v]));
            }
            let (c32, n32) = (c.as_vec3(), n.as_vec3());
            for radiance in [1.0, f32::MAX] {
                put(t
                    .radiance_sh_f32(Vec3::ZERO, c32, n32, 0.5, radiance)
                    .map(|v| v.iter().map(|&x| x as f64).collect()));
                put(t
                    .irradiance_sh_f32(Vec3::ZERO, c32, n32, 0.5, radiance)
                    .map(|v| v.iter().map(|&x| x as f64).collect()));
            }
        }
        "wrap" => {
            let t = wrap::Wrap::from_bytes(bytes)?;
            let mut out = [0.0; 8];
            for a in [0.0, 0.37, 1.0] {
                put(t.table_lookup(8, a, &mut out).map(|_| out.to_vec()));
            }
        }
        "mask-weights" => {
            let t = MaskWeights::from_bytes(bytes)?;
            let mut out = [0.0; MAX_DEPTH as usize];
            for set in [WeightSet::Fitted, WeightSet::Paper] {
                for mode in MaskMode::ALL {
                    for depth in 1..=MAX_DEPTH {
                        for dist in [1e-300, 0.25, 1.3, 10.0, f64::MAX] {
                            put(t
                                .weights(set, mode, depth, dist, &mut out)
                                .map(|_| out[..depth as usize].to_vec()));
                        }
                    }
                }
            }
        }
        other => panic!("no lookups for kind {other}"),
    }
    Ok(got)
}

/// Every committed table lies inside its family's declared channel ranges. Prints the
/// measured min/max per channel next to the range, so the margin is visible
/// (`cargo test -p lobefit-tables --test it loader::committed_tables_lie -- --nocapture`).
#[test]
fn committed_tables_lie_inside_their_channel_ranges() {
    for kind in KINDS {
        let (file, ranges) = ranged_table(kind);
        let t = table(&file);
        assert_eq!(t.meta().kind, kind);
        let bounds = channel_bounds(&t, &ranges);
        let nc = bounds.len();
        for (c, (ch, &(lo, hi))) in t.meta().channels.iter().zip(&bounds).enumerate() {
            let vals = t.values().iter().skip(c).step_by(nc).map(|&v| v as f64);
            let (min, max) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
            println!(
                "{kind:16} {:24} measured [{min:+.6e}, {max:+.6e}]  range [{lo:+e}, {hi:+e}]",
                ch.name
            );
            assert!(
                lo <= min && max <= hi,
                "{kind} {}: [{min}, {max}] outside [{lo}, {hi}]",
                ch.name
            );
        }
        // The family loader accepts it, and its lookups are finite.
        let got = family_lookups(kind, &file).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert!(got.iter().all(|v| v.is_finite()), "{kind}: non-finite lookup");
    }
}

/// Finite but absurd stored values (valid checksums) are refused by the family loader
/// with an error naming kind, channel and node; nothing reaches a lookup.
#[test]
fn finite_but_absurd_payload_values_are_refused_naming_channel_and_node() {
    // One stored 1000.0 in lobe-product's exponent channel (it used to become e_r = inf).
    let t = table(embedded::LOBE_PRODUCT);
    let (n_e, n_a) = (t.meta().axes[0].count, t.meta().axes[2].count);
    let node = [3u32, 5, 40];
    let index = ((node[0] * n_e + node[1]) * n_a + node[2]) as usize * 2 + 1;
    let bad = with_value(embedded::LOBE_PRODUCT, index, 1000.0);
    match LobeProduct::from_bytes(&bad) {
        Err(LoadError::ImplausibleValue {
            kind,
            channel,
            node: at,
            value,
            lo,
            hi,
        }) => {
            assert_eq!(
                (kind.as_str(), channel.as_str(), at.as_slice(), value),
                ("lobe-product", lobe_product::CHANNEL_E, &node[..], 1000.0)
            );
            assert!(lo < hi && (hi as f32) < value);
        }
        other => panic!("expected ImplausibleValue, got {:?}", other.map(|_| ())),
    }
    // Disk-light ratios at f32::MAX (they used to give Ok(inf) radiance and Ok(NaN)
    // irradiance).
    let t = table(embedded::DISK_LIGHT);
    let mut values = t.values().to_vec();
    for (i, v) in values.iter_mut().enumerate() {
        if i % 6 != 0 {
            *v = f32::MAX;
        }
    }
    let e = DiskLight::from_bytes(&with_payload(embedded::DISK_LIGHT, &values)).unwrap_err();
    assert!(
        matches!(&e, LoadError::ImplausibleValue { channel, node, .. } if channel == "r10" && node == &[0, 0]),
        "{e:?}"
    );
    assert!(e.to_string().contains("r10") && e.to_string().contains("[0, 0]"), "{e}");
    // Every family refuses a value just past either end of each channel's range.
    for kind in KINDS {
        let (file, ranges) = ranged_table(kind);
        let t = table(&file);
        let bounds = channel_bounds(&t, &ranges);
        let nc = bounds.len();
        let last = t.values().len() / nc - 1;
        for (c, &(lo, hi)) in bounds.iter().enumerate() {
            for v in [lo - 1e-3 * (hi - lo), hi + 1e-3 * (hi - lo)] {
                let bad = with_value(&file, last * nc + c, v as f32);
                match family_lookups(kind, &bad) {
                    Err(LoadError::ImplausibleValue { channel, .. }) => {
                        assert_eq!(channel, t.meta().channels[c].name, "{kind}")
                    }
                    other => panic!("{kind} channel {c} = {v}: {other:?}"),
                }
            }
        }
    }
}

/// A random finite f32 of any magnitude (random bits, NaN and infinities excluded).
fn random_finite(bits: u32) -> f32 {
    let v = f32::from_bits(bits);
    if v.is_finite() {
        v
    } else {
        f32::MAX.copysign(v)
    }
}

fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The f32 at fraction `u` ∈ [0, 1] of [lo, hi] that is in range as the loader sees
/// it: widened to f64 it lies in [lo, hi] (an f64 bound rounded to f32 may fall just
/// outside, e.g. 1e-7, which the loader then refuses).
fn f32_in_range(lo: f64, hi: f64, u: f64) -> f32 {
    let mut v = (lo + u * (hi - lo)) as f32;
    if f64::from(v) > hi {
        v = v.next_down();
    }
    if f64::from(v) < lo {
        v = v.next_up();
    }
    v
}

/// Regression (a CI run): shexp's kink channels span ±1e-7, and 1e-7 rounded to f32
/// exceeds 1e-7; the generator drew that value as "in range" and the loader, rightly,
/// refused it.
#[test]
fn generated_in_range_values_stay_in_range() {
    for (lo, hi) in [(-1e-7, 1e-7), (-4.0, 4.0), (0.1, 0.3), (-1e30, 1e-30)] {
        for u in [0.0, 1e-12, 0.5, 1.0 - 1e-12, 1.0] {
            let v = f64::from(f32_in_range(lo, hi, u));
            assert!((lo..=hi).contains(&v), "[{lo}, {hi}] at {u}: {v}");
        }
    }
}

fn range_config() -> ProptestConfig {
    ProptestConfig {
        cases: 96,
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(range_config())]

    /// (e) Valid CRCs, random finite payload values: (0) every value uniform in its
    /// channel's range, (1) the committed payload with a few values replaced by values
    /// in range, (2) the committed payload with a few values replaced by arbitrary
    /// finite f32 (huge ones included). Either the loader refuses the file (at the
    /// first implausible value, naming its channel and node) or every lookup is an
    /// error or finite.
    #[test]
    fn random_finite_payload_values_give_errors_or_finite_lookups(
        which in 0..KINDS.len(),
        mode in 0u8..3,
        seed in any::<u64>(),
        count in 1usize..8,
    ) {
        let kind = KINDS[which];
        let (file, ranges) = ranged_table(kind);
        let t = table(&file);
        let bounds = channel_bounds(&t, &ranges);
        let nc = bounds.len();
        let mut s = seed;
        let uniform = |i: usize, s: &mut u64| {
            let (lo, hi) = bounds[i % nc];
            f32_in_range(lo, hi, (splitmix(s) >> 11) as f64 / (1u64 << 53) as f64)
        };
        let mut values = t.values().to_vec();
        let mut first_bad: Option<usize> = None;
        if mode == 0 {
            for (i, v) in values.iter_mut().enumerate() {
                *v = uniform(i, &mut s);
            }
        } else {
            for _ in 0..count {
                let i = (splitmix(&mut s) % values.len() as u64) as usize;
                let v = if mode == 1 {
                    uniform(i, &mut s)
                } else {
                    let pick = [f32::MAX, -f32::MAX, 1e30, -1000.0, 1000.0, random_finite(splitmix(&mut s) as u32)];
                    pick[(splitmix(&mut s) % pick.len() as u64) as usize]
                };
                values[i] = v;
            }
            for (i, &v) in values.iter().enumerate() {
                let (lo, hi) = bounds[i % nc];
                if !(lo..=hi).contains(&(v as f64)) {
                    first_bad = Some(i);
                    break;
                }
            }
        }
        match (family_lookups(kind, &with_payload(&file, &values)), first_bad) {
            (Ok(got), None) => {
                prop_assert!(got.iter().all(|v| v.is_finite()), "{} mode {}: {:?}", kind, mode, got);
            }
            (Err(LoadError::ImplausibleValue { channel, node, value, .. }), Some(i)) => {
                prop_assert_eq!(&channel, &t.meta().channels[i % nc].name);
                prop_assert_eq!(value.to_bits(), values[i].to_bits());
                let mut flat = 0usize;
                for (a, &k) in t.meta().axes.iter().zip(&node) {
                    flat = flat * a.count as usize + k as usize;
                }
                prop_assert_eq!(flat, i / nc);
            }
            // A log-encoded value above ln f32::MAX fails the generic loader's own
            // (earlier) pass, at the first such value.
            (Err(LoadError::NonFinite { index, value }), Some(i)) => {
                let log = |j: usize| t.meta().channels[j % nc].encoding == lobefit_tables::Encoding::Log;
                let over = |j: usize| log(j) && values[j] > format::MAX_LOG_VALUE;
                prop_assert!(index >= i && over(index) && value == values[index]);
                prop_assert!(!(0..index).any(over));
            }
            // Values in range can still break a family's structural check (the shexp
            // monotone branch): a load error, never a non-finite lookup.
            (Err(LoadError::Invalid(_)), None) => {}
            (other, bad) => prop_assert!(false, "{} mode {}: {:?} (first out of range {:?})", kind, mode, other.map(|_| ()), bad),
        }
    }
}

// ---------------------------------------------------------------------------------
// 13. API misuse: overflow after narrowing, node indices, gaunt::one
// ---------------------------------------------------------------------------------

#[track_caller]
fn assert_overflow<T: std::fmt::Debug>(r: Result<T, LookupError>, what: &str) {
    match r {
        Err(LookupError::Overflow { name, value }) => {
            assert!(
                !name.is_empty() && !(value as f32).is_finite(),
                "{what}: {name} {value}"
            )
        }
        other => panic!("{what}: expected Overflow, got {other:?}"),
    }
}

/// Finite inputs whose result overflows (in f64, or only once narrowed to f32) are
/// errors, never Ok(inf) or Ok(NaN).
#[test]
fn overflowing_results_are_errors_in_f64_and_after_narrowing_to_f32() {
    let lp = LobeProduct::embedded().unwrap();
    let l = Lobe32 {
        scale: 1e20,
        axis: Vec3::Z,
        exponent: 2.0,
    };
    assert_overflow(lp.product_f32(&l, &l), "product_f32 1e20 × 1e20");
    let dl = DiskLight::embedded().unwrap();
    let (c, n) = (Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -1.0));
    assert_overflow(
        dl.irradiance_sh_f32(Vec3::ZERO, c, n, 100.0, f32::MAX),
        "irradiance_sh_f32",
    );
    assert_overflow(dl.radiance_sh_f32(Vec3::ZERO, c, n, 100.0, f32::MAX), "radiance_sh_f32");
    let (c, n) = (c.as_dvec3(), n.as_dvec3());
    assert_overflow(dl.radiance_sh(DVec3::ZERO, c, n, 100.0, f64::MAX), "radiance_sh");
    assert_overflow(
        dl.irradiance(DVec3::ZERO, DVec3::Z, c, n, 100.0, f64::MAX),
        "irradiance",
    );
    let mut o = [0.0; 9];
    assert_overflow(wrap::convolve(&[f64::MAX; 9], 0.5, &mut o), "wrap::convolve");
    assert_overflow(
        wrap::rewrap_irradiance(&[f64::MAX; 9], 0.5, &mut o),
        "rewrap_irradiance",
    );
    let mut o32 = [0.0f32; 9];
    assert_overflow(wrap::convolve_f32(&[f32::MAX; 9], 0.5, &mut o32), "convolve_f32");
    use lobefit_tables::sh;
    assert_overflow(sh::rotate_z_f32(&[f32::MAX; 9], 0.7, &mut o32), "rotate_z_f32");
    assert_overflow(sh::rotate_z(&[f64::MAX; 9], 0.7, &mut o), "rotate_z");
    // Moderate inputs still give values.
    assert!(lp.product_f32(&Lobe32 { scale: 2.0, ..l }, &l).is_ok());
    assert!(wrap::convolve_f32(&[1e30; 9], 0.5, &mut o32).is_ok());
}

/// `Table::node` checks the number of indices and each index against its axis.
#[test]
fn table_node_refuses_bad_indices_with_specific_errors() {
    let cap = table(CAP);
    assert_eq!(cap.node(&[999]).unwrap(), &cap.values()[999..1000]);
    for i in [1000, u32::MAX] {
        assert_eq!(
            cap.node(&[i]),
            Err(LookupError::NodeIndex {
                axis: "alpha".into(),
                index: i,
                count: 1000
            })
        );
    }
    assert_eq!(cap.node(&[]), Err(LookupError::Arity { expected: 1, got: 0 }));
    assert_eq!(cap.node(&[0, 5]), Err(LookupError::Arity { expected: 1, got: 2 }));
    let lp = table(embedded::LOBE_PRODUCT);
    assert_eq!(
        lp.node(&[0, 0, 96]),
        Err(LookupError::NodeIndex {
            axis: "alpha".into(),
            index: 96,
            count: 96
        })
    );
    assert_eq!(lp.node(&[47, 47, 95]).unwrap().len(), 2);
}

/// `gaunt::one` accepts the supported orders 1..=8 only.
#[test]
fn gaunt_one_refuses_unsupported_orders() {
    use lobefit_tables::gaunt;
    for order in [0, 9, usize::MAX] {
        match gaunt::one(order) {
            Err(LookupError::OutOfDomain { name, .. }) => assert!(name.contains("order"), "{name}"),
            other => panic!("order {order}: {other:?}"),
        }
    }
    let v = gaunt::one(3).unwrap();
    assert_eq!(v.len(), 9);
    assert_eq!(v[0], (4.0 * PI).sqrt());
}
