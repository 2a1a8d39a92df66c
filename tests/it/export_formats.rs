//! `lobefit::export::formats`: every format × storage × shape × channel count round
//! trips through the independent readers; the KTX2 and DDS headers hold the values
//! their specifications prescribe at the prescribed offsets; malformed files are
//! errors, never panics; the C header compiles as C99 and C++11.

use std::path::Path;
use std::process::Command;

use half::f16;
use lobefit::export::formats::{self, c_identifier, encode, read, write};
use lobefit::export::{Format, Storage, Texture};

const STORAGES: [Storage; 2] = [Storage::F32, Storage::F16];

/// Deterministic values covering signs, -0, tiny (f16-subnormal) and large
/// (near f16 max) magnitudes, and values f16 must round.
fn values(n: usize, seed: u64) -> Vec<f32> {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|i| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let u = (s >> 40) as f32 / (1u64 << 24) as f32; // [0, 1)
            match i % 7 {
                0 => -0.0,
                1 => u * 60000.0,
                2 => -u * 1e-6,
                3 => 1.0 / 3.0 + u,
                4 => -u * 100.0,
                5 => u * 1e-30, // f32-normal, below f16's range: f16 makes it 0
                _ => u,
            }
        })
        .collect()
}

/// (label, dimension, width, height, depth, layers)
const SHAPES: [(&str, u8, u32, u32, u32, u32); 4] = [
    ("1d", 1, 5, 1, 1, 1),
    ("2d", 2, 3, 4, 1, 1),
    ("3d", 3, 3, 2, 2, 1),
    ("2d-array", 2, 3, 2, 1, 3),
];

fn texture(name: &str, (dimension, width, height, depth, layers): (u8, u32, u32, u32, u32), channels: u32) -> Texture {
    let n = (width * height * depth * layers * channels) as usize;
    Texture {
        name: name.into(),
        dimension,
        width,
        height,
        depth,
        layers,
        channels,
        data: values(n, n as u64 + channels as u64),
    }
}

fn f16_rounded(v: &[f32]) -> Vec<f32> {
    v.iter().map(|&x| f16::from_f32(x).to_f32()).collect()
}

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn u32_at(b: &[u8], off: usize) -> u32 {
    u32::from_le_bytes(b[off..off + 4].try_into().unwrap())
}

fn u64_at(b: &[u8], off: usize) -> u64 {
    u64::from_le_bytes(b[off..off + 8].try_into().unwrap())
}

#[test]
fn every_format_storage_shape_and_channel_count_round_trips_exactly() {
    let dir = tempfile::tempdir().unwrap();
    for format in Format::ALL {
        for storage in STORAGES {
            for (label, d, w, h, z, l) in SHAPES {
                for channels in [1, 2, 4] {
                    let name = format!("t-{label}-{channels}-{storage}");
                    let tex = texture(&name, (d, w, h, z, l), channels);
                    let path = write(&tex, format, storage, dir.path()).unwrap();
                    assert_eq!(path, dir.path().join(format!("{name}.{}", format.extension())));
                    let (back, st) = read(&path, format).unwrap_or_else(|e| panic!("{format} {name}: {e}"));
                    assert_eq!(st, storage, "{format} {name}");
                    let want = match storage {
                        Storage::F32 => tex.data.clone(),
                        Storage::F16 => f16_rounded(&tex.data),
                    };
                    // Bit equality: -0.0 must stay -0.0.
                    assert_eq!(bits(&back.data), bits(&want), "{format} {name}");
                    assert_eq!(
                        (
                            back.name.as_str(),
                            back.dimension,
                            back.width,
                            back.height,
                            back.depth,
                            back.layers
                        ),
                        (name.as_str(), d, w, h, z, l),
                        "{format} {name}"
                    );
                    assert_eq!(back.channels, channels, "{format} {name}");
                }
            }
        }
    }
    // The raw sidecar sits next to the texels.
    assert!(dir.path().join("t-2d-1-f32.json").is_file());
}

#[test]
fn a_3d_array_texture_is_an_error_for_ktx2_and_dds_and_round_trips_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    let tex = texture("vol-array", (3, 2, 2, 2, 2), 1);
    for format in [Format::Ktx2, Format::Dds] {
        let e = encode(&tex, format, Storage::F32).unwrap_err();
        assert!(e.contains("vol-array") && e.contains("3D array"), "{e}");
    }
    for format in [Format::Inc, Format::Raw] {
        let p = write(&tex, format, Storage::F32, dir.path()).unwrap();
        assert_eq!(read(&p, format).unwrap().0, tex);
    }
}

#[test]
fn encodings_are_deterministic() {
    for format in Format::ALL {
        for storage in STORAGES {
            let a = encode(&texture("det", (2, 4, 3, 1, 2), 4), format, storage).unwrap();
            let b = encode(&texture("det", (2, 4, 3, 1, 2), 4), format, storage).unwrap();
            assert_eq!(a, b, "{format} {storage}");
        }
        let a = formats::raw_sidecar(&texture("det", (1, 4, 1, 1, 1), 2), Storage::F16).unwrap();
        let b = formats::raw_sidecar(&texture("det", (1, 4, 1, 1, 1), 2), Storage::F16).unwrap();
        assert_eq!(a, b);
    }
}

#[test]
fn ktx2_header_fields_match_the_specification() {
    let vk = |ch: u32, st: Storage| match (ch, st) {
        (1, Storage::F32) => (100, ktx2::Format::R32_SFLOAT),
        (2, Storage::F32) => (103, ktx2::Format::R32G32_SFLOAT),
        (4, Storage::F32) => (109, ktx2::Format::R32G32B32A32_SFLOAT),
        (1, Storage::F16) => (76, ktx2::Format::R16_SFLOAT),
        (2, Storage::F16) => (83, ktx2::Format::R16G16_SFLOAT),
        _ => (97, ktx2::Format::R16G16B16A16_SFLOAT),
    };
    for storage in STORAGES {
        for (label, d, w, h, z, l) in SHAPES {
            for channels in [1u32, 2, 4] {
                let tex = texture("k", (d, w, h, z, l), channels);
                let f = encode(&tex, Format::Ktx2, storage).unwrap();
                let what = format!("{label} {channels}ch {storage}");
                let bytes_per = storage.bytes() as u32;
                // Identifier «KTX 20»\r\n\x1A\n.
                assert_eq!(&f[..12], b"\xABKTX 20\xBB\r\n\x1A\n", "{what}");
                assert_eq!(u32_at(&f, 12), vk(channels, storage).0, "vkFormat {what}");
                assert_eq!(u32_at(&f, 16), bytes_per, "typeSize {what}");
                assert_eq!(u32_at(&f, 20), w, "pixelWidth {what}");
                assert_eq!(u32_at(&f, 24), if d == 1 { 0 } else { h }, "pixelHeight {what}");
                assert_eq!(u32_at(&f, 28), if d == 3 { z } else { 0 }, "pixelDepth {what}");
                assert_eq!(u32_at(&f, 32), if l > 1 { l } else { 0 }, "layerCount {what}");
                assert_eq!(u32_at(&f, 36), 1, "faceCount {what}");
                assert_eq!(u32_at(&f, 40), 1, "levelCount {what}");
                assert_eq!(u32_at(&f, 44), 0, "supercompressionScheme {what}");
                // Index: DFD right after the one-entry level index, KVD right after the DFD.
                let (dfd_off, dfd_len) = (u32_at(&f, 48) as usize, u32_at(&f, 52) as usize);
                let (kvd_off, kvd_len) = (u32_at(&f, 56) as usize, u32_at(&f, 60) as usize);
                assert_eq!(dfd_off, 80 + 24, "{what}");
                assert_eq!(kvd_off, dfd_off + dfd_len, "{what}");
                assert_eq!((u64_at(&f, 64), u64_at(&f, 72)), (0, 0), "sgd {what}");
                assert_eq!(kvd_len % 4, 0, "{what}");
                // Level index: aligned to lcm(texel block size, 4), exactly the texels, to the end.
                let texels = tex.data.len() as u64 * bytes_per as u64;
                let (lo, ll, lu) = (u64_at(&f, 80), u64_at(&f, 88), u64_at(&f, 96));
                let block = (channels * bytes_per) as u64;
                let lcm = if block.is_multiple_of(4) { block } else { 4 }; // blocks are 2, 4, 8 or 16 bytes
                assert_eq!(lo % lcm, 0, "level alignment {what}");
                assert!(lo as usize >= kvd_off + kvd_len, "{what}");
                assert_eq!((ll, lu), (texels, texels), "{what}");
                assert_eq!(lo + ll, f.len() as u64, "{what}");
                // DFD: dfdTotalSize, then a basic block.
                let dfd = &f[dfd_off..dfd_off + dfd_len];
                assert_eq!(u32_at(dfd, 0) as usize, dfd_len, "dfdTotalSize {what}");
                assert_eq!(u32_at(dfd, 4), 0, "vendorId/descriptorType {what}");
                assert_eq!(u16::from_le_bytes([dfd[8], dfd[9]]), 2, "versionNumber {what}");
                let block_size = u16::from_le_bytes([dfd[10], dfd[11]]) as usize;
                assert_eq!(block_size, 24 + 16 * channels as usize, "descriptorBlockSize {what}");
                assert_eq!(dfd_len, 4 + block_size, "{what}");
                assert_eq!(dfd[12], 1, "colorModel KHR_DF_MODEL_RGBSDA {what}");
                assert_eq!(dfd[14], 1, "transferFunction linear {what}");
                assert_eq!(&dfd[16..20], &[0, 0, 0, 0], "texelBlockDimension 1×1×1×1 {what}");
                assert_eq!(dfd[20] as u32, channels * bytes_per, "bytesPlane0 {what}");
                for c in 0..channels as usize {
                    let s = &dfd[28 + 16 * c..44 + 16 * c];
                    let bits = bytes_per * 8;
                    assert_eq!(
                        u16::from_le_bytes([s[0], s[1]]) as u32,
                        c as u32 * bits,
                        "bitOffset {what}"
                    );
                    assert_eq!(s[2] as u32, bits - 1, "bitLength {what}");
                    assert_eq!(s[3] & 0x0F, [0, 1, 2, 15][c], "channelId {what}");
                    assert_eq!(s[3] & 0xF0, 0x40 | 0x80, "qualifiers SIGNED|FLOAT {what}");
                    assert_eq!(u32_at(s, 8), 0xBF80_0000, "sampleLower {what}");
                    assert_eq!(u32_at(s, 12), 0x3F80_0000, "sampleUpper {what}");
                }
                // Cross-check against the ktx2 crate's own DFD generator (independent code).
                let (basic, type_size) = ktx2::dfd::Basic::from_format(vk(channels, storage).1).unwrap();
                assert_eq!(type_size, bytes_per, "{what}");
                assert_eq!(
                    &dfd[4..],
                    &ktx2::dfd::Block::Basic(basic).to_vec()[..],
                    "DFD vs ktx2 {what}"
                );
                // KVD: the writer id, through the ktx2 reader.
                let r = ktx2::Reader::new(&f[..]).unwrap();
                let kv: Vec<_> = r.key_value_data().collect();
                assert_eq!(kv, vec![("KTXwriter", &b"lobefit export\0"[..])], "{what}");
            }
        }
    }
}

#[test]
fn dds_dx10_header_fields_match_the_specification() {
    let dxgi = |ch: u32, st: Storage| match (ch, st) {
        (1, Storage::F32) => 41,
        (2, Storage::F32) => 16,
        (4, Storage::F32) => 2,
        (1, Storage::F16) => 54,
        (2, Storage::F16) => 34,
        _ => 10,
    };
    for storage in STORAGES {
        for (label, d, w, h, z, l) in SHAPES {
            for channels in [1u32, 2, 4] {
                let tex = texture("d", (d, w, h, z, l), channels);
                let f = encode(&tex, Format::Dds, storage).unwrap();
                let what = format!("{label} {channels}ch {storage}");
                assert_eq!(&f[..4], b"DDS ", "{what}");
                assert_eq!(u32_at(&f, 4), 124, "dwSize {what}");
                assert_eq!((u32_at(&f, 12), u32_at(&f, 16)), (h, w), "height, width {what}");
                assert_eq!(&f[84..88], b"DX10", "ddspf.dwFourCC {what}");
                // DDPF_FOURCC alone: no DDPF_RGB, no bit count (readers that honour
                // them decode float texels as 8-bit RGB, all zeros).
                assert_eq!(u32_at(&f, 80), 0x4, "ddspf.dwFlags {what}");
                assert_eq!(u32_at(&f, 88), 0, "ddspf.dwRGBBitCount {what}");
                assert_eq!(u32_at(&f, 128), dxgi(channels, storage), "dxgiFormat {what}");
                assert_eq!(u32_at(&f, 132), d as u32 + 1, "resourceDimension {what}");
                assert_eq!(u32_at(&f, 136), 0, "miscFlag (no cube) {what}");
                assert_eq!(u32_at(&f, 140), l, "arraySize {what}");
                if d == 3 {
                    assert_eq!(u32_at(&f, 24), z, "dwDepth {what}");
                }
                assert_eq!(f.len(), 148 + tex.data.len() * storage.bytes(), "{what}");
            }
        }
    }
}

#[test]
fn f16_overflow_is_an_error_naming_texture_value_and_index() {
    let mut tex = texture("hot", (1, 6, 1, 1, 1), 1);
    tex.data[3] = -70000.0;
    for format in Format::ALL {
        let e = encode(&tex, format, Storage::F16).unwrap_err();
        assert!(
            e.contains("hot") && e.contains("-70000") && e.contains("index 3"),
            "{format}: {e}"
        );
        encode(&tex, format, Storage::F32).unwrap();
    }
    // The largest f16 is fine; anything beyond it is not, even what would round down.
    tex.data[3] = 65504.0;
    encode(&tex, Format::Raw, Storage::F16).unwrap();
    tex.data[3] = 65505.0;
    assert!(encode(&tex, Format::Raw, Storage::F16).is_err());
}

#[test]
fn textures_beyond_api_limits_are_errors() {
    let one_row = |dimension: u8, width: u32| Texture {
        name: "big".into(),
        dimension,
        width,
        height: 1,
        depth: 1,
        layers: 1,
        channels: 1,
        data: vec![0.0; width as usize],
    };
    for format in Format::ALL {
        for storage in STORAGES {
            for tex in [one_row(3, 2049), one_row(2, 16385), one_row(1, 16385)] {
                let e = encode(&tex, format, storage).unwrap_err();
                assert!(e.contains("big") && e.contains("exceeds"), "{format}: {e}");
            }
            encode(&one_row(3, 2048), format, storage).unwrap();
        }
    }
    let mut tex = one_row(2, 4);
    tex.data.pop();
    assert!(encode(&tex, Format::Ktx2, Storage::F32).unwrap_err().contains("big"));
}

#[test]
fn an_unwritable_directory_is_an_error_naming_the_path() {
    // A regular file where a directory should be: fails even as root.
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("blocker");
    std::fs::write(&blocker, b"not a directory").unwrap();
    let target = blocker.join("out");
    let tex = texture("w", (1, 3, 1, 1, 1), 1);
    for format in Format::ALL {
        let e = write(&tex, format, Storage::F32, &target).unwrap_err();
        assert!(
            e.contains(&*target.to_string_lossy()) && e.contains('w'),
            "{format}: {e}"
        );
    }
}

#[test]
fn a_name_that_is_not_a_plain_file_stem_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    for name in ["", "..", "a/b", "../up", "a\\b"] {
        let mut tex = texture("x", (1, 2, 1, 1, 1), 1);
        tex.name = name.into();
        assert!(write(&tex, Format::Raw, Storage::F32, dir.path()).is_err(), "{name:?}");
    }
}

/// Writes `bytes` to `dir/name` and reads it back as `format`; must not panic.
fn read_bytes(dir: &Path, name: &str, bytes: &[u8], format: Format) -> Result<(Texture, Storage), String> {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    read(&p, format)
}

#[test]
fn truncated_corrupted_and_random_files_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut rng = 0x1234_5678_9ABC_DEF1u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    for storage in STORAGES {
        for format in Format::ALL {
            let tex = texture("m", (2, 3, 2, 1, 2), 2);
            let good = encode(&tex, format, storage).unwrap();
            let ext = format.extension();
            let file = format!("m.{ext}");
            if format == Format::Raw {
                std::fs::write(d.join("m.json"), formats::raw_sidecar(&tex, storage).unwrap()).unwrap();
            }
            read_bytes(d, &file, &good, format).unwrap();
            // Every strict truncation is an error (a header may lose its tail
            // after the array and still be complete).
            let complete = match format {
                Format::Inc => std::str::from_utf8(&good).unwrap().find("};").unwrap() + 2,
                _ => good.len(),
            };
            for len in 0..good.len() {
                let r = read_bytes(d, &file, &good[..len], format);
                if len < complete {
                    let e = r.unwrap_err();
                    assert!(e.contains(&file), "{format} {len}: {e}");
                }
            }
            // Any single byte set to 0x00, 0xFF or a random value: Ok or Err, no panic.
            for pos in 0..good.len().min(400) {
                for v in [0x00, 0xFF, next() as u8] {
                    let mut bad = good.clone();
                    bad[pos] = v;
                    let _ = read_bytes(d, &file, &bad, format);
                }
            }
            // Random files, some starting with the right magic.
            for i in 0..300 {
                let len = (next() % 600) as usize;
                let mut bad: Vec<u8> = (0..len).map(|_| next() as u8).collect();
                if i % 2 == 0 {
                    let keep = good.len().min(len).min(150);
                    bad[..keep].copy_from_slice(&good[..keep]);
                }
                let _ = read_bytes(d, &file, &bad, format);
            }
            std::fs::write(d.join(&file), &good).unwrap();
            if format == Format::Raw {
                // A broken or missing sidecar.
                let side = formats::raw_sidecar(&tex, storage).unwrap();
                let trimmed = side.trim_end().len();
                for len in 0..trimmed {
                    std::fs::write(d.join("m.json"), &side.as_bytes()[..len]).unwrap();
                    assert!(read(&d.join(&file), format).is_err(), "sidecar cut at {len}");
                }
                for (from, to) in [
                    ("\"raw\"", "\"ktx2\""),
                    ("little", "big"),
                    ("\"width\": 3", "\"width\": 4"),
                ] {
                    std::fs::write(d.join("m.json"), side.replace(from, to)).unwrap();
                    assert!(read(&d.join(&file), format).is_err(), "{from} → {to}");
                }
                std::fs::remove_file(d.join("m.json")).unwrap();
                assert!(read(&d.join(&file), format).unwrap_err().contains("sidecar"));
            }
        }
    }
    // A file that is not there.
    assert!(read(&d.join("absent.ktx2"), Format::Ktx2)
        .unwrap_err()
        .contains("absent.ktx2"));
}

#[test]
fn ktx2_hostile_texel_block_dimension_is_an_error() {
    // ktx2's parser would compute 255 + 1 in a u8 here.
    let dir = tempfile::tempdir().unwrap();
    let mut f = encode(&texture("h", (2, 2, 2, 1, 1), 1), Format::Ktx2, Storage::F32).unwrap();
    let dfd = u32_at(&f, 48) as usize;
    f[dfd + 4 + 8 + 4] = 255;
    let e = read_bytes(dir.path(), "h.ktx2", &f, Format::Ktx2).unwrap_err();
    assert!(e.contains("texel block"), "{e}");
}

#[test]
fn the_c_header_compiles_as_c99_and_cpp11_and_holds_the_exact_values() {
    let have = |tool: &str| {
        Command::new(tool)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !have("cc") {
        println!("note: no `cc` on PATH; the C header compile check is skipped");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A name with comment-closing characters (encode allows it; write would not).
    let odd = texture("evil*/name", (1, 2, 1, 1, 1), 1);
    std::fs::write(d.join("odd.inc"), encode(&odd, Format::Inc, Storage::F32).unwrap()).unwrap();
    let a = texture("cap-exponent", (2, 5, 3, 1, 2), 4);
    let b = texture("cap-exponent-half", (3, 2, 2, 3, 1), 2);
    write(&a, Format::Inc, Storage::F32, d).unwrap();
    write(&b, Format::Inc, Storage::F16, d).unwrap();
    let (ia, ib) = (c_identifier(&a.name), c_identifier(&b.name));
    assert_eq!(ia, "LOBEFIT_CAP_EXPONENT");
    // Both headers twice (the include guards), every constant used; the program
    // prints the f32 values' bit patterns and the f16 words.
    let src = format!(
        "#include <stdio.h>\n#include <string.h>\n\
         #include \"cap-exponent.inc\"\n#include \"cap-exponent.inc\"\n#include \"cap-exponent-half.inc\"\n\
         #include \"cap-exponent-half.inc\"\n#include \"odd.inc\"\n\
         int main(void) {{\n\
           unsigned long i;\n\
           unsigned long n = (unsigned long){ia}_WIDTH * {ia}_HEIGHT * {ia}_DEPTH * {ia}_LAYERS * {ia}_CHANNELS;\n\
           if (n != {ia}_COUNT || {ia}_DIMENSION != 2 || {ia}_STORAGE_BITS != 32) return 1;\n\
           if (sizeof({ib}) / sizeof({ib}[0]) != {ib}_COUNT || {ib}_STORAGE_BITS != 16) return 1;\n\
           for (i = 0; i < {ia}_COUNT; i++) {{ unsigned int u; memcpy(&u, &{ia}[i], 4); printf(\"%08x\\n\", u); }}\n\
           for (i = 0; i < {ib}_COUNT; i++) printf(\"%04x\\n\", (unsigned int){ib}[i]);\n\
           return 0;\n\
         }}\n"
    );
    std::fs::write(d.join("t.c"), &src).unwrap();
    std::fs::write(d.join("t.cpp"), &src).unwrap();
    let warn = ["-Wall", "-Wextra", "-pedantic", "-Werror"];
    let run = |cmd: &mut Command| {
        let o = cmd.current_dir(d).output().unwrap();
        assert!(o.status.success(), "{cmd:?}: {}", String::from_utf8_lossy(&o.stderr));
        o
    };
    run(Command::new("cc")
        .args(["-std=c99", "-fsyntax-only"])
        .args(warn)
        .arg("t.c"));
    if have("c++") {
        run(Command::new("c++")
            .args(["-std=c++11", "-fsyntax-only"])
            .args(warn)
            .arg("t.cpp"));
    } else {
        println!("note: no `c++` on PATH; the C++ compile check is skipped");
    }
    // The compiler's own reading of the literals must give the exact bits.
    run(Command::new("cc").args(["-std=c99", "-o", "t"]).args(warn).arg("t.c"));
    let out = run(&mut Command::new(d.join("t")));
    let lines: Vec<String> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    let mut want: Vec<String> = a.data.iter().map(|v| format!("{:08x}", v.to_bits())).collect();
    want.extend(b.data.iter().map(|&v| format!("{:04x}", f16::from_f32(v).to_bits())));
    assert_eq!(lines, want);
}

/// The export's C header of uniforms compiles as C99 and C++11 (warnings as errors),
/// and the compiler's reading of each initializer is, byte for byte, the uniform the
/// runtime builds from the manifest (`TextureEntry::lf_tex`): a C renderer needs no
/// code to fill it.
#[test]
fn the_uniforms_header_compiles_and_holds_the_manifest_uniforms() {
    use lobefit::export::layout::Filter;
    use lobefit::export::run::{export, ExportOptions};
    if !Command::new("cc")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        println!("note: no `cc` on PATH; the uniforms header check is skipped");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let opts = ExportOptions {
        only: vec!["cap-exponent".into(), "lobe-product".into()],
        format: Format::Inc,
        storage: Storage::F16,
        scale: 0.25,
        allow_lossy: true,
    };
    let m = export(&opts, d).unwrap();
    assert_eq!(m.uniforms_header, formats::UNIFORMS_HEADER);
    let textures: Vec<_> = m.families.iter().flat_map(|f| &f.textures).collect();
    let mut body = String::new();
    for t in &textures {
        let id = c_identifier(t.file.split('.').next().unwrap());
        for what in ["MANUAL", "HARDWARE"] {
            body += &format!("    dump(&{id}_LFTEX_{what});\n");
        }
    }
    let src = format!(
        "#include <stdio.h>\n#include \"{h}\"\n#include \"{h}\"\n\
         static void dump(const LobefitLfTex *u) {{\n\
           const unsigned char *b = (const unsigned char *)u; unsigned long i;\n\
           for (i = 0; i < sizeof *u; i++) printf(\"%02x\", b[i]);\n\
           printf(\"\\n\");\n\
         }}\n\
         int main(void) {{\n{body}    return 0;\n}}\n",
        h = formats::UNIFORMS_HEADER
    );
    std::fs::write(d.join("u.c"), &src).unwrap();
    std::fs::write(d.join("u.cpp"), &src).unwrap();
    let warn = ["-Wall", "-Wextra", "-pedantic", "-Werror"];
    let run = |cmd: &mut Command| {
        let o = cmd.current_dir(d).output().unwrap();
        assert!(o.status.success(), "{cmd:?}: {}", String::from_utf8_lossy(&o.stderr));
        o
    };
    if Command::new("c++")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
    {
        run(Command::new("c++")
            .args(["-std=c++11", "-fsyntax-only"])
            .args(warn)
            .arg("u.cpp"));
    }
    run(Command::new("cc").args(["-std=c99", "-o", "u"]).args(warn).arg("u.c"));
    let out = String::from_utf8(run(&mut Command::new(d.join("u"))).stdout).unwrap();
    let mut lines = out.lines();
    for t in &textures {
        for filter in [Filter::Manual, Filter::Hardware] {
            let want: String = t
                .lf_tex(filter)
                .unwrap()
                .to_bytes()
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect();
            assert_eq!(lines.next(), Some(want.as_str()), "{} {filter:?}", t.file);
        }
    }
    assert_eq!(lines.next(), None);
}
