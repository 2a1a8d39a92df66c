//! Writers and readers of the export container formats.
//!
//! Every writer is deterministic (same texture, format and storage → same bytes: no
//! timestamps, no versions). Every reader is independent of its writer: KTX2 files
//! are read through the `ktx2` crate, DDS files through `ddsfile`, raw files through
//! their JSON sidecar, C headers through a small parser of the constants and the array
//! literal; so a round trip checks the writer against a second implementation.
//!
//! Texel data is little-endian in every binary format, in the order documented on
//! [`Texture`] (layer, then z, then y, then x, channels fastest), which is also the
//! order KTX2 and DDS prescribe for one mip level.

use std::path::{Path, PathBuf};

use half::f16;
use lobefit_tables::uniform::{LfTex, LF_TEX_SIZE};
use serde::{Deserialize, Serialize};

use super::{Format, Storage, Texture};

/// Largest finite binary16 value; anything beyond is an error, never `inf`.
const F16_MAX: f32 = 65504.0;

/// The `texel_order` of a raw sidecar (and the order of every format's texels).
pub const TEXEL_ORDER: &str = "layer-major, then z, then y, then x, channels fastest: value index = \
((((layer * depth + z) * height + y) * width + x) * channels + c)";

/// The `KTXwriter` value of the KTX2 files (no version, so the bytes stay deterministic).
pub const KTX_WRITER: &str = "lobefit export";

/// The file bytes of `tex` in `format` with `storage` precision.
///
/// For [`Format::Raw`] these are the `.bin` texels only; the JSON sidecar is
/// [`raw_sidecar`]. Errors name the texture and the cause: an invalid shape
/// ([`Texture::validate`]), an f16 overflow (|v| > 65504, with the value and its
/// index in `data`), a shape the container cannot hold (a 3D array texture in KTX2 or
/// DDS; more than 4 GiB of texels in DDS).
pub fn encode(tex: &Texture, format: Format, storage: Storage) -> Result<Vec<u8>, String> {
    tex.validate()?;
    match format {
        Format::Ktx2 => encode_ktx2(tex, storage),
        Format::Dds => encode_dds(tex, storage),
        Format::Inc => encode_inc(tex, storage).map(String::into_bytes),
        Format::Raw => texel_bytes(tex, storage),
    }
}

/// Writes `tex` to `dir/<name>.<ext>` atomically ([`crate::io::write_atomic`]: a
/// temporary in `dir`, renamed over the target) and returns that path. `dir` is
/// created if missing. The name must be a plain file stem (no path separators).
/// For [`Format::Raw`] the texels go to `<name>.bin` (the path
/// returned) and [`raw_sidecar`] to `<name>.json`, each atomically, the sidecar last.
pub fn write(tex: &Texture, format: Format, storage: Storage, dir: &Path) -> Result<PathBuf, String> {
    // The name becomes a file name in `dir`: nothing that could leave it.
    let n = &tex.name;
    if n.is_empty() || n == "." || n == ".." || n.contains(['/', '\\', '\0']) {
        return Err(format!("texture {n:?}: the name is not a plain file stem"));
    }
    let bytes = encode(tex, format, storage)?;
    let path = dir.join(format!("{}.{}", tex.name, format.extension()));
    write_file(tex, &path, &bytes)?;
    if format == Format::Raw {
        let sidecar = raw_sidecar(tex, storage)?;
        write_file(tex, &path.with_extension("json"), sidecar.as_bytes())?;
    }
    Ok(path)
}

fn write_file(tex: &Texture, path: &Path, bytes: &[u8]) -> Result<(), String> {
    crate::io::write_atomic(path, bytes)
        .map_err(|e| format!("texture {}: cannot write {}: {e}", tex.name, path.display()))
}

/// Reads a file written by [`write()`] (for [`Format::Raw`], the `.bin` path; the
/// sidecar is the same path with extension `json`). The texture's name is the file
/// stem; f16 texels are widened to f32 exactly. Any malformed or unsupported file is
/// an `Err` naming the path and the cause.
pub fn read(path: &Path, format: Format) -> Result<(Texture, Storage), String> {
    let err = |e: String| format!("{}: {e}", path.display());
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .ok_or_else(|| err("no file name".into()))?;
    let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read: {e}")))?;
    let (tex, storage) = decode(path, &bytes, format, name).map_err(err)?;
    tex.validate().map_err(err)?;
    Ok((tex, storage))
}

fn decode(path: &Path, bytes: &[u8], format: Format, name: String) -> Result<(Texture, Storage), String> {
    match format {
        Format::Ktx2 => read_ktx2(bytes, name),
        Format::Dds => read_dds(bytes, name),
        Format::Inc => read_inc(
            std::str::from_utf8(bytes).map_err(|e| format!("not UTF-8 text: {e}"))?,
            name,
        ),
        Format::Raw => {
            // A sidecar is a few hundred bytes: a regular file of at most 64 KiB.
            let side = path.with_extension("json");
            let json = crate::io::read_text(&side, 1 << 16).map_err(|e| format!("sidecar: {e}"))?;
            read_raw(bytes, json.as_bytes(), name)
        }
    }
}

// ---------------------------------------------------------------------------------
// Shared helpers

/// The texels as little-endian bytes in `storage` precision.
fn texel_bytes(tex: &Texture, storage: Storage) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(tex.data.len() * storage.bytes());
    match storage {
        Storage::F32 => tex.data.iter().for_each(|v| out.extend_from_slice(&v.to_le_bytes())),
        Storage::F16 => f16_bits(tex)?
            .iter()
            .for_each(|b| out.extend_from_slice(&b.to_le_bytes())),
    }
    Ok(out)
}

/// binary16 bit patterns of the texels (round to nearest even); |v| > 65504 is an error.
fn f16_bits(tex: &Texture) -> Result<Vec<u16>, String> {
    tex.data
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            if v.abs() > F16_MAX {
                Err(format!(
                    "texture {}: value {v} at index {i} overflows f16 (|v| > {F16_MAX}); export it as f32",
                    tex.name
                ))
            } else {
                Ok(f16::from_f32(v).to_bits())
            }
        })
        .collect()
}

/// Decodes little-endian texels; `bytes.len()` has been checked against the shape.
fn decode_texels(bytes: &[u8], storage: Storage) -> Vec<f32> {
    match storage {
        Storage::F32 => bytes
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
        Storage::F16 => bytes
            .chunks_exact(2)
            .map(|c| f16::from_bits(u16::from_le_bytes([c[0], c[1]])).to_f32())
            .collect(),
    }
}

/// Texel bytes a shape needs, in u64 so hostile headers cannot overflow.
fn byte_count(width: u32, height: u32, depth: u32, layers: u32, channels: u32, storage: Storage) -> Option<u64> {
    [height, depth, layers, channels, storage.bytes() as u32]
        .iter()
        .try_fold(u64::from(width), |acc, &v| acc.checked_mul(u64::from(v)))
}

/// A texture of the given shape whose data is `payload` (checked to be exactly the
/// right length first, so nothing is allocated from header values alone).
#[allow(clippy::too_many_arguments)] // the shape fields of `Texture`, in its order
fn texture_from(
    name: String,
    dimension: u8,
    width: u32,
    height: u32,
    depth: u32,
    layers: u32,
    channels: u32,
    storage: Storage,
    payload: &[u8],
) -> Result<Texture, String> {
    let want = byte_count(width, height, depth, layers, channels, storage)
        .ok_or_else(|| format!("shape {width}×{height}×{depth}, {layers} layers overflows"))?;
    if want != payload.len() as u64 {
        return Err(format!(
            "{} bytes of texel data for {width}×{height}×{depth}, {layers} layers, {channels} channels of {storage} \
             ({want} bytes)",
            payload.len()
        ));
    }
    Ok(Texture {
        name,
        dimension,
        width,
        height,
        depth,
        layers,
        channels,
        data: decode_texels(payload, storage),
    })
}

fn no_3d_arrays(tex: &Texture, container: &str) -> Result<(), String> {
    if tex.dimension == 3 && tex.layers > 1 {
        return Err(format!(
            "texture {}: {container} cannot hold a 3D array texture ({} layers); no GPU API has them",
            tex.name, tex.layers
        ));
    }
    Ok(())
}

fn u32_at(b: &[u8], off: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(off..off + 4)?.try_into().ok()?))
}

// ---------------------------------------------------------------------------------
// KTX2 (KTX 2.0 specification; Khronos Data Format Specification 1.3 for the DFD)

/// KTX2 file identifier «KTX 20»\r\n\x1A\n.
const KTX2_IDENTIFIER: [u8; 12] = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];

/// VkFormat of `channels` channels of `storage` (R, RG, RGBA; signed float).
fn vk_format(channels: u32, storage: Storage) -> u32 {
    match (channels, storage) {
        (1, Storage::F32) => 100, // VK_FORMAT_R32_SFLOAT
        (2, Storage::F32) => 103, // VK_FORMAT_R32G32_SFLOAT
        (4, Storage::F32) => 109, // VK_FORMAT_R32G32B32A32_SFLOAT
        (1, Storage::F16) => 76,  // VK_FORMAT_R16_SFLOAT
        (2, Storage::F16) => 83,  // VK_FORMAT_R16G16_SFLOAT
        (4, Storage::F16) => 97,  // VK_FORMAT_R16G16B16A16_SFLOAT
        _ => unreachable!("validate() admits 1, 2 or 4 channels"),
    }
}

/// The Data Format Descriptor: dfdTotalSize, then one basic descriptor block
/// (KHR_DF_MODEL_RGBSDA, BT.709 primaries, linear transfer, straight alpha, 1×1×1×1
/// texel block, one plane) with one sample per channel: bit offset c × bits, signed
/// float, sample lower/upper the f32 bit patterns of -1.0 and 1.0 (the DFD spec stores
/// float bounds as f32 whatever the sample's width, as libktx does for f16).
fn ktx2_dfd(channels: u32, storage: Storage) -> Vec<u8> {
    let bits = storage.bytes() as u32 * 8;
    let block_size = 24 + 16 * channels;
    let mut d = Vec::with_capacity(4 + block_size as usize);
    d.extend_from_slice(&(4 + block_size).to_le_bytes()); // dfdTotalSize
    d.extend_from_slice(&0u32.to_le_bytes()); // vendorId 0 (Khronos) | descriptorType 0 (basic) << 17
    d.extend_from_slice(&2u16.to_le_bytes()); // versionNumber: KHR_DF_VERSIONNUMBER_1_3
    d.extend_from_slice(&(block_size as u16).to_le_bytes()); // descriptorBlockSize
    d.extend_from_slice(&[1, 1, 1, 0]); // colorModel RGBSDA, primaries BT709, transfer LINEAR, flags straight alpha
    d.extend_from_slice(&[0, 0, 0, 0]); // texelBlockDimension0..3, each value − 1: 1×1×1×1
    d.extend_from_slice(&[(channels * bits / 8) as u8, 0, 0, 0, 0, 0, 0, 0]); // bytesPlane0..7
    for c in 0..channels {
        let channel_id: u8 = [0, 1, 2, 15][c as usize]; // KHR_DF_CHANNEL_RGBSDA_R, G, B, ALPHA
        d.extend_from_slice(&((c * bits) as u16).to_le_bytes()); // bitOffset
        d.push((bits - 1) as u8); // bitLength − 1
        d.push(channel_id | 0x40 | 0x80); // channelType | qualifiers SIGNED | FLOAT
        d.extend_from_slice(&[0, 0, 0, 0]); // samplePosition0..3
        d.extend_from_slice(&(-1.0f32).to_bits().to_le_bytes()); // sampleLower 0xBF800000
        d.extend_from_slice(&1.0f32.to_bits().to_le_bytes()); // sampleUpper 0x3F800000
    }
    d
}

/// Key/value data: one `KTXwriter` entry (keys must be sorted; there is one).
fn ktx2_kvd() -> Vec<u8> {
    let mut kv = Vec::new();
    let (key, value) = ("KTXwriter", KTX_WRITER);
    let len = key.len() + 1 + value.len() + 1; // key NUL value NUL
    kv.extend_from_slice(&(len as u32).to_le_bytes());
    kv.extend_from_slice(key.as_bytes());
    kv.push(0);
    kv.extend_from_slice(value.as_bytes());
    kv.push(0);
    kv.resize(kv.len().next_multiple_of(4), 0); // valuePadding
    kv
}

fn encode_ktx2(tex: &Texture, storage: Storage) -> Result<Vec<u8>, String> {
    no_3d_arrays(tex, "KTX2")?;
    let texels = texel_bytes(tex, storage)?;
    let dfd = ktx2_dfd(tex.channels, storage);
    let kvd = ktx2_kvd();
    const HEADER: usize = 80;
    const LEVEL_INDEX: usize = 24; // one level
    let dfd_offset = HEADER + LEVEL_INDEX;
    let kvd_offset = dfd_offset + dfd.len();
    // Level data aligned to lcm(texel block size, 4); block sizes are 2, 4, 8 or 16.
    let block = tex.channels as usize * storage.bytes();
    let align = block.max(4);
    let data_offset = (kvd_offset + kvd.len()).next_multiple_of(align);

    let mut f = Vec::with_capacity(data_offset + texels.len());
    f.extend_from_slice(&KTX2_IDENTIFIER);
    let u32s = [
        vk_format(tex.channels, storage),
        storage.bytes() as u32, // typeSize
        tex.width,
        if tex.dimension >= 2 { tex.height } else { 0 }, // pixelHeight: 0 for 1D
        if tex.dimension == 3 { tex.depth } else { 0 },  // pixelDepth: 0 unless 3D
        if tex.layers > 1 { tex.layers } else { 0 },     // layerCount: 0 when not an array
        1,                                               // faceCount
        1,                                               // levelCount
        0,                                               // supercompressionScheme: none
        dfd_offset as u32,
        dfd.len() as u32,
        kvd_offset as u32,
        kvd.len() as u32,
    ];
    u32s.iter().for_each(|v| f.extend_from_slice(&v.to_le_bytes()));
    f.extend_from_slice(&0u64.to_le_bytes()); // sgdByteOffset: no supercompression global data
    f.extend_from_slice(&0u64.to_le_bytes()); // sgdByteLength
    f.extend_from_slice(&(data_offset as u64).to_le_bytes()); // level 0 byteOffset
    f.extend_from_slice(&(texels.len() as u64).to_le_bytes()); // byteLength
    f.extend_from_slice(&(texels.len() as u64).to_le_bytes()); // uncompressedByteLength
    f.extend_from_slice(&dfd);
    f.extend_from_slice(&kvd);
    f.resize(data_offset, 0); // mipPadding
    f.extend_from_slice(&texels);
    Ok(f)
}

/// `ktx2::Reader::new` unwraps a texel block dimension of 255 + 1 (a panic on
/// hostile input); this walk over the DFD blocks rejects that first.
fn ktx2_precheck_dfd(b: &[u8]) -> Result<(), String> {
    let (Some(off), Some(len)) = (u32_at(b, 48), u32_at(b, 52)) else {
        return Ok(()); // too short: the reader says so
    };
    let (start, end) = (off as usize + 4, off as usize + len as usize);
    let mut p = start;
    while p + 8 <= end.min(b.len()) {
        let size = u16::from_le_bytes([b[p + 6], b[p + 7]]) as usize;
        if size == 0 {
            break;
        }
        if u32_at(b, p) == Some(0) {
            if let Some(dims) = b.get(p + 12..p + 16) {
                if dims.contains(&255) {
                    return Err("malformed KTX2 data format descriptor (texel block dimension 256)".into());
                }
            }
        }
        p += size;
    }
    Ok(())
}

fn read_ktx2(b: &[u8], name: String) -> Result<(Texture, Storage), String> {
    ktx2_precheck_dfd(b)?;
    // Belt and braces: a panic inside the parser on some input we did not foresee
    // is still an error here, not an abort of the caller.
    let reader = std::panic::catch_unwind(|| ktx2::Reader::new(b))
        .map_err(|_| "malformed KTX2 file (the parser panicked)".to_string())?
        .map_err(|e| format!("malformed KTX2 file: {e}"))?;
    let h = reader.header();
    let vk = h.format.map_or(0, |f| f.value());
    let (channels, storage) = match vk {
        100 => (1, Storage::F32),
        103 => (2, Storage::F32),
        109 => (4, Storage::F32),
        76 => (1, Storage::F16),
        83 => (2, Storage::F16),
        97 => (4, Storage::F16),
        v => {
            return Err(format!(
                "unsupported KTX2 vkFormat {v} (R/RG/RGBA 16- or 32-bit SFLOAT only)"
            ))
        }
    };
    if h.type_size != storage.bytes() as u32 {
        return Err(format!("KTX2 typeSize {} for vkFormat {vk}", h.type_size));
    }
    if h.face_count != 1 {
        return Err(format!("KTX2 cube map ({} faces) not supported", h.face_count));
    }
    if h.level_count > 1 {
        return Err(format!("KTX2 with {} mip levels not supported (1 only)", h.level_count));
    }
    if h.supercompression_scheme.is_some() {
        return Err("supercompressed KTX2 not supported".into());
    }
    let dfd = reader
        .basic_dfd()
        .ok_or("KTX2 without a basic data format descriptor")?;
    if dfd.sample_information.len() != channels as usize {
        return Err(format!(
            "KTX2 data format descriptor has {} samples for {channels} channels",
            dfd.sample_information.len()
        ));
    }
    let (dimension, height, depth) = match (h.pixel_height, h.pixel_depth) {
        (0, 0) => (1, 1, 1),
        (hh, 0) => (2, hh, 1),
        (0, _) => return Err("KTX2 pixelDepth without pixelHeight".into()),
        (hh, d) => (3, hh, d),
    };
    let level = reader.levels().next().ok_or("KTX2 without a level")?;
    if level.uncompressed_byte_length != level.data.len() as u64 {
        return Err("KTX2 level byteLength and uncompressedByteLength differ".into());
    }
    let layers = h.layer_count.max(1);
    let tex = texture_from(
        name,
        dimension,
        h.pixel_width,
        height,
        depth,
        layers,
        channels,
        storage,
        level.data,
    )?;
    Ok((tex, storage))
}

// ---------------------------------------------------------------------------------
// DDS (DX10 header)

fn dxgi_format(channels: u32, storage: Storage) -> ddsfile::DxgiFormat {
    use ddsfile::DxgiFormat as D;
    match (channels, storage) {
        (1, Storage::F32) => D::R32_Float,          // 41
        (2, Storage::F32) => D::R32G32_Float,       // 16
        (4, Storage::F32) => D::R32G32B32A32_Float, // 2
        (1, Storage::F16) => D::R16_Float,          // 54
        (2, Storage::F16) => D::R16G16_Float,       // 34
        (4, Storage::F16) => D::R16G16B16A16_Float, // 10
        _ => unreachable!("validate() admits 1, 2 or 4 channels"),
    }
}

fn encode_dds(tex: &Texture, storage: Storage) -> Result<Vec<u8>, String> {
    use ddsfile::{AlphaMode, Caps2, D3D10ResourceDimension as Dim, Dds, NewDxgiParams};
    no_3d_arrays(tex, "DDS")?;
    let texels = texel_bytes(tex, storage)?;
    // ddsfile sizes the data in u32 (and would overflow past it).
    if texels.len() > u32::MAX as usize {
        return Err(format!(
            "texture {}: {} bytes of texels exceed DDS's 4 GiB",
            tex.name,
            texels.len()
        ));
    }
    let (resource_dimension, depth, caps2) = match tex.dimension {
        1 => (Dim::Texture1D, None, None),
        2 => (Dim::Texture2D, None, None),
        _ => (Dim::Texture3D, Some(tex.depth), Some(Caps2::VOLUME)),
    };
    let mut dds = Dds::new_dxgi(NewDxgiParams {
        height: tex.height,
        width: tex.width,
        depth,
        format: dxgi_format(tex.channels, storage),
        mipmap_levels: Some(1),
        array_layers: Some(tex.layers),
        caps2,
        is_cubemap: false,
        resource_dimension,
        // A fourth channel is data, not coverage: DDS_ALPHA_MODE_CUSTOM says so.
        alpha_mode: if tex.channels == 4 {
            AlphaMode::Custom
        } else {
            AlphaMode::Unknown
        },
    })
    .map_err(|e| format!("texture {}: DDS header: {e}", tex.name))?;
    // The DX10 extension alone names the format: DDS_PIXELFORMAT carries only
    // DDPF_FOURCC "DX10", no RGB flag or bit count (ddsfile sets both, and readers
    // that honour them decode a 128-bit float texel as 8-bit RGB: zeros).
    dds.header.spf.flags = ddsfile::PixelFormatFlags::FOURCC;
    dds.header.spf.rgb_bit_count = None;
    if dds.data.len() != texels.len() {
        return Err(format!(
            "texture {}: ddsfile sized the data {} bytes, not {}",
            tex.name,
            dds.data.len(),
            texels.len()
        ));
    }
    dds.data = texels;
    let mut out = Vec::with_capacity(148 + dds.data.len());
    dds.write(&mut out)
        .map_err(|e| format!("texture {}: DDS write: {e}", tex.name))?;
    Ok(out)
}

fn read_dds(b: &[u8], name: String) -> Result<(Texture, Storage), String> {
    use ddsfile::{D3D10ResourceDimension as Dim, DxgiFormat as D, MiscFlag};
    let dds = ddsfile::Dds::read(b).map_err(|e| format!("malformed DDS file: {e}"))?;
    let h10 = dds
        .header10
        .as_ref()
        .ok_or("DDS without a DX10 header (legacy formats not supported)")?;
    let (channels, storage) = match h10.dxgi_format {
        D::R32_Float => (1, Storage::F32),
        D::R32G32_Float => (2, Storage::F32),
        D::R32G32B32A32_Float => (4, Storage::F32),
        D::R16_Float => (1, Storage::F16),
        D::R16G16_Float => (2, Storage::F16),
        D::R16G16B16A16_Float => (4, Storage::F16),
        f => {
            return Err(format!(
                "unsupported DXGI format {f:?} (R/RG/RGBA 16- or 32-bit FLOAT only)"
            ))
        }
    };
    if h10.misc_flag.contains(MiscFlag::TEXTURECUBE) {
        return Err("DDS cube map not supported".into());
    }
    if dds.header.mip_map_count.unwrap_or(1) > 1 {
        return Err(format!(
            "DDS with {:?} mip levels not supported (1 only)",
            dds.header.mip_map_count
        ));
    }
    let (width, height, depth) = (dds.header.width, dds.header.height, dds.header.depth.unwrap_or(1));
    let dimension = match h10.resource_dimension {
        Dim::Texture1D => 1,
        Dim::Texture2D => 2,
        Dim::Texture3D => 3,
        d => return Err(format!("DDS resource dimension {d:?} is not a texture")),
    };
    let tex = texture_from(
        name,
        dimension,
        width,
        height,
        depth,
        h10.array_size,
        channels,
        storage,
        &dds.data,
    )?;
    Ok((tex, storage))
}

// ---------------------------------------------------------------------------------
// C header

/// The C identifier of a texture: `LOBEFIT_` + the name upper-cased, every other
/// character than ASCII letters and digits made `_` (`cap-exponent` →
/// `LOBEFIT_CAP_EXPONENT`). The constants are this plus `_WIDTH` etc.
pub fn c_identifier(name: &str) -> String {
    let tail: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_uppercase()
            } else {
                '_'
            }
        })
        .collect();
    format!("LOBEFIT_{tail}")
}

/// A C99 / C++ literal that converts back to exactly `v`: Rust's shortest round-trip
/// digits in exponent form, `f` suffix, the sign of -0 kept (`-0e0f`).
fn c_float(v: f32) -> String {
    format!("{v:e}f")
}

fn encode_inc(tex: &Texture, storage: Storage) -> Result<String, String> {
    use std::fmt::Write as _;
    let id = c_identifier(&tex.name);
    let (ctype, per_line, values): (&str, usize, Vec<String>) = match storage {
        Storage::F32 => ("float", 8, tex.data.iter().map(|&v| c_float(v)).collect()),
        Storage::F16 => (
            "unsigned short",
            12,
            f16_bits(tex)?.iter().map(|b| format!("0x{b:04x}")).collect(),
        ),
    };
    let channel_names = ["R", "RG", "", "RGBA"][tex.channels as usize - 1];
    let mut s = String::new();
    // Writing to a String cannot fail; `let _` keeps the builder linear.
    // The name as a quoted literal, so no character of it can end the comment.
    let shown = format!("{:?}", tex.name).replace("*/", "*\\/");
    let _ = writeln!(s, "/* {shown}: generated by lobefit export; do not edit.");
    let _ = writeln!(s, " *");
    let _ = writeln!(
        s,
        " * {}D texture, width {}, height {}, depth {}, {} layer(s), {} channel(s) ({channel_names}), storage {storage}.",
        tex.dimension, tex.width, tex.height, tex.depth, tex.layers, tex.channels
    );
    let _ = writeln!(s, " * Texel order: {TEXEL_ORDER}.");
    match storage {
        Storage::F32 => {
            let _ = writeln!(s, " * Values: IEEE binary32.");
        }
        Storage::F16 => {
            let _ = writeln!(
                s,
                " * Values: IEEE binary16 bit patterns (round to nearest even); upload as half floats."
            );
        }
    }
    let _ = writeln!(s, " */");
    let _ = writeln!(s, "#ifndef {id}_INC");
    let _ = writeln!(s, "#define {id}_INC");
    let _ = writeln!(s);
    for (what, v) in [
        ("DIMENSION", u32::from(tex.dimension)),
        ("WIDTH", tex.width),
        ("HEIGHT", tex.height),
        ("DEPTH", tex.depth),
        ("LAYERS", tex.layers),
        ("CHANNELS", tex.channels),
        ("STORAGE_BITS", storage.bytes() as u32 * 8),
    ] {
        let _ = writeln!(s, "#define {id}_{what} {v}");
    }
    let _ = writeln!(s, "#define {id}_COUNT {}", tex.data.len());
    let _ = writeln!(s);
    let _ = writeln!(s, "static const {ctype} {id}[{id}_COUNT] = {{");
    for chunk in values.chunks(per_line) {
        let _ = writeln!(s, "    {},", chunk.join(", "));
    }
    let _ = writeln!(s, "}};");
    let _ = writeln!(s);
    let _ = writeln!(s, "#endif /* {id}_INC */");
    Ok(s)
}

/// File name of an export's C header of uniforms ([`uniforms_header`]).
pub const UNIFORMS_HEADER: &str = "lobefit_uniforms.h";

/// The C header (C99, C++11) declaring the shader library's uniform `LobefitLfTex`
/// (the WGSL `LfTex`, 640 bytes) and, per texture, its initializers for manual and
/// hardware filtering, `<ID>_LFTEX_MANUAL` and `<ID>_LFTEX_HARDWARE` (`ID` the
/// texture's [`c_identifier`]): a C or C++ renderer uploads one as the uniform buffer
/// with no code of its own. `textures`: (texture name, manual, hardware).
pub fn uniforms_header(textures: &[(String, LfTex, LfTex)]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "/* lobefit export: the LfTex uniform of every texture here (the shader library's"
    );
    let _ = writeln!(
        s,
        " * textured functions take it). Generated by lobefit export; do not edit."
    );
    let _ = writeln!(
        s,
        " * Upload <TEXTURE>_LFTEX_MANUAL (or _HARDWARE) as the uniform buffer bound with"
    );
    let _ = writeln!(
        s,
        " * the texture: 39 vec4 of float, then a uvec4 (std140), 640 bytes. */"
    );
    let _ = writeln!(s, "#ifndef LOBEFIT_UNIFORMS_H");
    let _ = writeln!(s, "#define LOBEFIT_UNIFORMS_H");
    let _ = writeln!(s);
    let _ = writeln!(s, "typedef struct LobefitLfTex {{");
    for (name, rows) in [
        ("axis", 3),
        ("map", 3),
        ("offset", 3),
        ("scale", 3),
        ("trend", 24),
        ("decode", 3),
    ] {
        let _ = writeln!(s, "    float {name}[{rows}][4];");
    }
    let _ = writeln!(s, "    unsigned int mode[4];");
    let _ = writeln!(s, "}} LobefitLfTex;");
    let _ = writeln!(
        s,
        "typedef char lobefit_lftex_is_640_bytes[sizeof(LobefitLfTex) == {LF_TEX_SIZE} ? 1 : -1];"
    );
    let block = |rows: &[[f32; 4]]| {
        let r: Vec<String> = rows
            .iter()
            .map(|r| format!("{{{}}}", r.iter().map(|&v| c_float(v)).collect::<Vec<_>>().join(", ")))
            .collect();
        format!("{{{}}}", r.join(", "))
    };
    for (name, manual, hardware) in textures {
        let id = c_identifier(name);
        for (what, u) in [("MANUAL", manual), ("HARDWARE", hardware)] {
            let _ = writeln!(s);
            let _ = writeln!(s, "static const LobefitLfTex {id}_LFTEX_{what} = {{");
            for rows in [&u.axis[..], &u.map, &u.offset, &u.scale, &u.trend, &u.decode] {
                let _ = writeln!(s, "    {},", block(rows));
            }
            let m: Vec<String> = u.mode.iter().map(|v| format!("{v}u")).collect();
            let _ = writeln!(s, "    {{{}}}", m.join(", "));
            let _ = writeln!(s, "}};");
        }
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "#endif /* LOBEFIT_UNIFORMS_H */");
    s
}

/// Removes `/* … */` and `// …` comments (the layout comment may say anything).
fn strip_c_comments(text: &str) -> Result<String, String> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    loop {
        let block = rest.find("/*");
        let line = rest.find("//");
        match (block, line) {
            (Some(b), l) if l.is_none_or(|l| b < l) => {
                out.push_str(&rest[..b]);
                let end = rest[b + 2..].find("*/").ok_or("unterminated /* comment")?;
                out.push(' ');
                rest = &rest[b + 2 + end + 2..];
            }
            (_, Some(l)) => {
                out.push_str(&rest[..l]);
                rest = rest[l..].find('\n').map_or("", |n| &rest[l + n..]);
            }
            _ => {
                out.push_str(rest);
                return Ok(out);
            }
        }
    }
}

fn read_inc(text: &str, name: String) -> Result<(Texture, Storage), String> {
    let code = strip_c_comments(text)?;
    // The array: `static const <type> <ID>[...] = { ... };`
    let decl_at = code
        .find("static const ")
        .ok_or("no `static const` array in the header")?;
    let decl = &code[decl_at + "static const ".len()..];
    let (storage, decl) = if let Some(r) = decl.strip_prefix("float ") {
        (Storage::F32, r)
    } else if let Some(r) = decl.strip_prefix("unsigned short ") {
        (Storage::F16, r)
    } else {
        return Err("array type is neither `float` nor `unsigned short`".into());
    };
    let id_end = decl.find('[').ok_or("array declaration without `[`")?;
    let id = decl[..id_end].trim();
    if id.is_empty() || !id.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!("array name {id:?} is not a C identifier"));
    }
    let open = decl.find('{').ok_or("array without `{`")?;
    let close = decl[open..].find("};").ok_or("array without closing `};`")? + open;
    let literal = &decl[open + 1..close];

    let constant = |what: &str| -> Result<u64, String> {
        let key = format!("{id}_{what}");
        for line in code.lines() {
            let mut words = line.split_whitespace();
            if words.next() == Some("#define") && words.next() == Some(key.as_str()) {
                let v = words.next().ok_or_else(|| format!("#define {key} without a value"))?;
                return v
                    .parse()
                    .map_err(|_| format!("#define {key} {v}: not an unsigned integer"));
            }
        }
        Err(format!("no #define {key}"))
    };
    let small = |what: &str| -> Result<u32, String> {
        u32::try_from(constant(what)?).map_err(|_| format!("{id}_{what} out of range"))
    };
    let dimension = u8::try_from(constant("DIMENSION")?).map_err(|_| "DIMENSION out of range".to_string())?;
    let (width, height, depth, layers, channels) = (
        small("WIDTH")?,
        small("HEIGHT")?,
        small("DEPTH")?,
        small("LAYERS")?,
        small("CHANNELS")?,
    );
    let bits = constant("STORAGE_BITS")?;
    if bits != storage.bytes() as u64 * 8 {
        return Err(format!("{id}_STORAGE_BITS {bits} does not match the array type"));
    }
    let count = constant("COUNT")?;
    let want = byte_count(width, height, depth, layers, channels, Storage::F16).map(|b| b / 2);
    if want != Some(count) {
        return Err(format!("{id}_COUNT {count} does not match the extents"));
    }
    // Parse lazily against `count`, so a bogus literal cannot make us allocate more.
    let mut data = Vec::with_capacity(literal.len().min(count as usize) / 4);
    for (i, tok) in literal.split(',').map(str::trim).enumerate() {
        if tok.is_empty() {
            // Only a trailing comma may leave an empty token.
            if literal.split(',').skip(i + 1).any(|t| !t.trim().is_empty()) {
                return Err(format!("empty value at index {i}"));
            }
            break;
        }
        if data.len() as u64 >= count {
            return Err(format!("more than {id}_COUNT = {count} values"));
        }
        let v = match storage {
            Storage::F32 => tok
                .strip_suffix('f')
                .and_then(|t| t.parse::<f32>().ok())
                .ok_or_else(|| format!("value {i} `{tok}` is not a float literal with an f suffix"))?,
            Storage::F16 => tok
                .strip_prefix("0x")
                .and_then(|t| u16::from_str_radix(t, 16).ok())
                .map(|b| f16::from_bits(b).to_f32())
                .ok_or_else(|| format!("value {i} `{tok}` is not a 16-bit hex literal"))?,
        };
        data.push(v);
    }
    if data.len() as u64 != count {
        return Err(format!("{} values for {id}_COUNT = {count}", data.len()));
    }
    let tex = Texture {
        name,
        dimension,
        width,
        height,
        depth,
        layers,
        channels,
        data,
    };
    Ok((tex, storage))
}

// ---------------------------------------------------------------------------------
// Raw texels + JSON sidecar

/// The JSON sidecar of a raw export: the shape and encoding of the `.bin` file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSidecar {
    /// Always `"raw"`.
    format: String,
    storage: Storage,
    dimension: u8,
    width: u32,
    height: u32,
    depth: u32,
    layers: u32,
    channels: u32,
    /// Always `"little-endian"`.
    byte_order: String,
    /// [`TEXEL_ORDER`].
    texel_order: String,
}

/// The `<name>.json` sidecar of a [`Format::Raw`] export (pretty JSON, trailing
/// newline): `format` "raw", `storage` "f32"/"f16", `dimension`, `width`, `height`,
/// `depth`, `layers`, `channels`, `byte_order` "little-endian", `texel_order`
/// ([`TEXEL_ORDER`]).
pub fn raw_sidecar(tex: &Texture, storage: Storage) -> Result<String, String> {
    tex.validate()?;
    let side = RawSidecar {
        format: "raw".into(),
        storage,
        dimension: tex.dimension,
        width: tex.width,
        height: tex.height,
        depth: tex.depth,
        layers: tex.layers,
        channels: tex.channels,
        byte_order: "little-endian".into(),
        texel_order: TEXEL_ORDER.into(),
    };
    serde_json::to_string_pretty(&side)
        .map(|s| s + "\n")
        .map_err(|e| format!("texture {}: sidecar: {e}", tex.name))
}

fn read_raw(bin: &[u8], json: &[u8], name: String) -> Result<(Texture, Storage), String> {
    let s: RawSidecar = serde_json::from_slice(json).map_err(|e| format!("malformed raw sidecar: {e}"))?;
    if s.format != "raw" {
        return Err(format!("sidecar format {:?}, not \"raw\"", s.format));
    }
    if s.byte_order != "little-endian" {
        return Err(format!("sidecar byte_order {:?}, not \"little-endian\"", s.byte_order));
    }
    if s.texel_order != TEXEL_ORDER {
        return Err(format!("sidecar texel_order {:?} is not lobefit's", s.texel_order));
    }
    let tex = texture_from(
        name,
        s.dimension,
        s.width,
        s.height,
        s.depth,
        s.layers,
        s.channels,
        s.storage,
        bin,
    )?;
    Ok((tex, s.storage))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn c_float_round_trips() {
        for v in [
            0.0f32,
            -0.0,
            1.0,
            0.1,
            -3.4028235e38,
            1e-45,
            f32::MIN_POSITIVE,
            65504.0,
            123456.79,
        ] {
            let s = c_float(v);
            let back: f32 = s.strip_suffix('f').unwrap().parse().unwrap();
            assert_eq!(back.to_bits(), v.to_bits(), "{v} → {s}");
        }
        assert_eq!(c_float(-0.0), "-0e0f");
    }

    #[test]
    fn header_text() {
        let tex = Texture {
            name: "t".into(),
            dimension: 1,
            width: 3,
            height: 1,
            depth: 1,
            layers: 1,
            channels: 1,
            data: vec![1.0, -0.0, 0.1],
        };
        let s = encode_inc(&tex, Storage::F32).unwrap();
        assert!(s.contains("#ifndef LOBEFIT_T_INC\n#define LOBEFIT_T_INC\n"));
        assert!(s.contains("#define LOBEFIT_T_WIDTH 3\n"));
        assert!(s.contains("static const float LOBEFIT_T[LOBEFIT_T_COUNT] = {\n    1e0f, -0e0f, 1e-1f,\n};"));
        let h = encode_inc(&tex, Storage::F16).unwrap();
        assert!(
            h.contains("static const unsigned short LOBEFIT_T[LOBEFIT_T_COUNT] = {\n    0x3c00, 0x8000, 0x2e66,\n};")
        );
    }

    #[test]
    fn identifiers() {
        assert_eq!(c_identifier("cap-exponent"), "LOBEFIT_CAP_EXPONENT");
        assert_eq!(c_identifier("sg.2d v1"), "LOBEFIT_SG_2D_V1");
    }

    #[test]
    fn comments_are_stripped() {
        let s = strip_c_comments("a /* { } */ b // c };\nd").unwrap();
        assert_eq!(s, "a   b \nd");
        assert!(strip_c_comments("a /* b").is_err());
    }

    #[test]
    fn dfd_sizes() {
        for ch in [1, 2, 4] {
            for st in [Storage::F32, Storage::F16] {
                let d = ktx2_dfd(ch, st);
                assert_eq!(d.len() as u32, u32_at(&d, 0).unwrap());
                assert_eq!(d.len() % 4, 0);
            }
        }
    }
}
