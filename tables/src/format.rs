//! The lobefit table file format, version 1 (defined here once; the writer in the
//! `lobefit` crate uses these very types). See `docs/format.md` for a byte-level
//! description a C++ loader can follow.
//!
//! Layout: a fixed 64-byte little-endian header, a postcard-encoded [`Meta`] block,
//! zero padding to a 16-byte boundary, then the payload: `f32` little-endian values
//! in C order over the axes (axis 0 slowest) with the channels interleaved fastest,
//! i.e. `index = ((i0 * n1 + i1) * n2 + i2) * C + c`.

use serde::{Deserialize, Serialize};

use crate::error::{short, LoadError};

/// First eight bytes of every table file. The `\r\n\x1a\n` tail (as in PNG) makes
/// text-mode transfers that rewrite line endings fail loudly.
pub const MAGIC: [u8; 8] = *b"LBFT\r\n\x1a\n";
/// Format major version: readers reject any other major.
pub const FORMAT_MAJOR: u16 = 1;
/// Format minor version: informational. Readers of major 1 accept any minor; a change
/// that a 1.0 reader could not parse (new metadata fields, a new header layout) must
/// bump the major instead, because the metadata block is a fixed postcard record.
pub const FORMAT_MINOR: u16 = 0;
/// Size of the fixed header in bytes.
pub const HEADER_LEN: usize = 64;
/// Payload alignment inside the file, so the payload can be uploaded or mapped as is.
pub const PAYLOAD_ALIGN: usize = 16;
/// Upper bound on any file this reader accepts (1 GiB): a length field beyond it is corrupt.
pub const MAX_FILE_LEN: u64 = 1 << 30;
/// Length of the NUL-padded ASCII kind field in the header.
pub const KIND_LEN: usize = 16;

/// How an axis coordinate `x` maps to the coordinate `u` in which nodes are evenly
/// spaced and in which interpolation is linear.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Mapping {
    /// `u = x`.
    Linear,
    /// `u = ln x` (requires `lo > 0`).
    Log,
    /// `u = ln(1 + x / scale)` (requires `scale > 0`, `lo > -scale`).
    Log1p { scale: f64 },
    /// `u = ln((x - a) / (b - x))`: dense nodes near both ends (requires `a < lo`, `hi < b`).
    Logit { a: f64, b: f64 },
    /// `u = asinh((x - centre) / width)`: nodes dense (spacing ∝ `width`) around
    /// `centre`, relatively even (spacing ∝ distance) away from it (requires
    /// `width > 0`, both finite).
    Asinh { centre: f64, width: f64 },
}

impl Mapping {
    /// Forward map `x -> u`.
    pub fn forward(&self, x: f64) -> f64 {
        match *self {
            Mapping::Linear => x,
            Mapping::Log => x.ln(),
            Mapping::Log1p { scale } => (x / scale).ln_1p(),
            Mapping::Logit { a, b } => ((x - a) / (b - x)).ln(),
            Mapping::Asinh { centre, width } => ((x - centre) / width).asinh(),
        }
    }

    /// Inverse map `u -> x`.
    pub fn inverse(&self, u: f64) -> f64 {
        match *self {
            Mapping::Linear => u,
            Mapping::Log => u.exp(),
            Mapping::Log1p { scale } => scale * u.exp_m1(),
            // x = a + (b - a) * sigmoid(u), written to stay accurate for large |u|.
            Mapping::Logit { a, b } => {
                if u >= 0.0 {
                    b - (b - a) / (1.0 + u.exp())
                } else {
                    a + (b - a) / (1.0 + (-u).exp())
                }
            }
            Mapping::Asinh { centre, width } => centre + width * u.sinh(),
        }
    }

    fn validate(&self, lo: f64, hi: f64) -> Result<(), String> {
        match *self {
            Mapping::Linear => Ok(()),
            Mapping::Log if lo > 0.0 => Ok(()),
            Mapping::Log => Err(format!("log mapping needs lo > 0, got {}", short(lo))),
            Mapping::Log1p { scale } if scale > 0.0 && scale.is_finite() && lo > -scale => Ok(()),
            Mapping::Log1p { scale } => Err(format!("log1p mapping with scale {} on lo {}", short(scale), short(lo))),
            Mapping::Logit { a, b } if a.is_finite() && b.is_finite() && a < lo && hi < b => Ok(()),
            Mapping::Logit { a, b } => Err(format!(
                "logit mapping ({}, {}) must strictly contain [{}, {}]",
                short(a),
                short(b),
                short(lo),
                short(hi)
            )),
            Mapping::Asinh { centre, width } if centre.is_finite() && width.is_finite() && width > 0.0 => Ok(()),
            Mapping::Asinh { centre, width } => Err(format!(
                "asinh mapping with centre {}, width {}",
                short(centre),
                short(width)
            )),
        }
    }
}

/// Where the nodes sit in the mapped coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Placement {
    /// Node `i` at `u(lo) + i (u(hi) - u(lo)) / (n - 1)`: first and last node on the range ends.
    Endpoints,
    /// Node `i` at `u(lo) + (i + 1/2) (u(hi) - u(lo)) / n`: cell centres (GPU texel convention).
    Centres,
}

/// One table axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    /// Quantity name, e.g. `"alpha"`.
    pub name: String,
    /// Unit, e.g. `"rad"` or `"1"` for dimensionless.
    pub unit: String,
    /// Smallest covered value.
    pub lo: f64,
    /// Largest covered value.
    pub hi: f64,
    /// Node spacing (uniform in the mapped coordinate).
    pub mapping: Mapping,
    /// Number of nodes (at least 2).
    pub count: u32,
    /// Whether nodes sit on the range ends or on cell centres.
    pub placement: Placement,
}

impl Axis {
    /// Mapped coordinates of the range ends.
    pub fn mapped_range(&self) -> (f64, f64) {
        (self.mapping.forward(self.lo), self.mapping.forward(self.hi))
    }

    /// Continuous node index of `x` (node `i` at index `i`), not clamped.
    pub fn node_coordinate(&self, x: f64) -> f64 {
        let (u0, u1) = self.mapped_range();
        let t = (self.mapping.forward(x) - u0) / (u1 - u0);
        match self.placement {
            Placement::Endpoints => t * (self.count as f64 - 1.0),
            Placement::Centres => t * self.count as f64 - 0.5,
        }
    }

    /// Axis value of node `i`.
    pub fn node(&self, i: u32) -> f64 {
        let (u0, u1) = self.mapped_range();
        let t = match self.placement {
            Placement::Endpoints => i as f64 / (self.count as f64 - 1.0),
            Placement::Centres => (i as f64 + 0.5) / self.count as f64,
        };
        // Exact range ends for the end nodes, so round trips do not drift outside.
        if self.placement == Placement::Endpoints && i == 0 {
            return self.lo;
        }
        if self.placement == Placement::Endpoints && i + 1 == self.count {
            return self.hi;
        }
        self.mapping.inverse(u0 + t * (u1 - u0))
    }

    fn validate(&self) -> Result<(), String> {
        if !(self.lo.is_finite() && self.hi.is_finite() && self.lo < self.hi) {
            return Err(format!(
                "axis '{}' has bad range [{}, {}]",
                self.name,
                short(self.lo),
                short(self.hi)
            ));
        }
        if self.count < 2 {
            return Err(format!("axis '{}' has {} nodes (need >= 2)", self.name, self.count));
        }
        self.mapping
            .validate(self.lo, self.hi)
            .map_err(|m| format!("axis '{}': {m}", self.name))?;
        // An extreme range can round to equal or infinite mapped ends: interpolation
        // would divide by zero.
        let (u0, u1) = self.mapped_range();
        if !(u0.is_finite() && u1.is_finite() && u0 < u1 && (u1 - u0).is_finite()) {
            return Err(format!(
                "axis '{}' maps [{}, {}] to the degenerate [{}, {}]",
                self.name,
                short(self.lo),
                short(self.hi),
                short(u0),
                short(u1)
            ));
        }
        Ok(())
    }
}

/// How a stored channel value relates to the quantity it represents.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Encoding {
    /// Stored as is; interpolated linearly.
    Linear,
    /// Stored as its natural logarithm; interpolated in log space, then exponentiated.
    Log,
}

/// Scalar type of the payload.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Storage {
    /// IEEE-754 binary32, little-endian.
    F32,
}

/// One stored channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Channel {
    /// Channel name, e.g. `"q"`.
    pub name: String,
    /// Unit of the decoded quantity.
    pub unit: String,
    /// Encoding of the stored value.
    pub encoding: Encoding,
    /// What the decoded value means, including any family-specific transform.
    pub description: String,
}

/// The fit that produced the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitInfo {
    /// Method and backend, e.g. `"brent(argmin) on closed-form L2"`.
    pub method: String,
    /// Every setting that influences the payload, as `(key, value)` in a fixed order.
    pub settings: Vec<(String, String)>,
    /// FNV-1a 64 of the postcard encoding of `(method, settings)`: see `settings_hash`.
    pub settings_hash: u64,
}

/// Per-entry fit diagnostics (one value per grid node, in payload order).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EntryDiagnostics {
    /// Family-defined residual of each entry (documented in `residual_meaning`).
    pub residual: Vec<f32>,
    /// Optimizer iterations (or function evaluations) per entry.
    pub iterations: Vec<u32>,
    /// Whether each entry's fit converged (every written entry must have).
    pub converged: Vec<bool>,
}

/// Summary of the fit diagnostics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnostics {
    /// What `residual` measures.
    pub residual_meaning: String,
    /// Number of grid entries.
    pub entries: u64,
    /// Entries whose fit converged.
    pub converged: u64,
    /// Largest residual over all entries.
    pub max_residual: f64,
    /// Mean residual.
    pub mean_residual: f64,
    /// Largest iteration count.
    pub max_iterations: u32,
    /// Per-entry detail, when small enough to keep.
    pub per_entry: Option<EntryDiagnostics>,
}

/// An accuracy promise the checker enforces: `metric` of `output` must stay `<= limit`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Threshold {
    /// Output quantity (a column of `lobefit eval`).
    pub output: String,
    /// `grid.max_rel`, `offgrid.max_rel`, `offgrid.median_rel`, `offgrid.max_abs`, ...
    pub metric: String,
    /// Largest allowed value.
    pub limit: f64,
}

/// The self-description of a table file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Meta {
    /// Family name, same as the header's kind, e.g. `"cap-exponent"`.
    pub kind: String,
    /// The family's own version of layout and semantics.
    pub table_version: u32,
    /// Generator name and version, e.g. `"lobefit 0.1.0"` (no timestamps: builds are reproducible).
    pub generator: String,
    /// One-paragraph description of what the table holds and how to use it.
    pub description: String,
    /// Axes, slowest-varying first.
    pub axes: Vec<Axis>,
    /// Channels, interleaved fastest.
    pub channels: Vec<Channel>,
    /// Payload scalar type.
    pub storage: Storage,
    /// The fit and its settings.
    pub fit: FitInfo,
    /// Fit diagnostics.
    pub diagnostics: Diagnostics,
    /// Accuracy thresholds the checker enforces.
    pub thresholds: Vec<Threshold>,
}

impl Meta {
    /// Number of grid nodes (product of axis counts), `None` on overflow.
    pub fn entries(&self) -> Option<u64> {
        self.axes
            .iter()
            .try_fold(1u64, |acc, a| acc.checked_mul(a.count as u64))
    }

    /// Checks everything that can be checked without the payload.
    pub fn validate(&self) -> Result<(), String> {
        if self.axes.is_empty() || self.axes.len() > 4 {
            return Err(format!("{} axes (supported: 1 to 4)", self.axes.len()));
        }
        for a in &self.axes {
            a.validate()?;
        }
        if self.channels.is_empty() || self.channels.len() > 64 {
            return Err(format!("{} channels (supported: 1 to 64)", self.channels.len()));
        }
        let n = self.entries().ok_or("entry count overflows")?;
        if self.diagnostics.entries != n {
            return Err(format!(
                "diagnostics cover {} entries, grid has {n}",
                self.diagnostics.entries
            ));
        }
        // Unconverged fits are never written, so a file claiming one is corrupt or forged.
        if self.diagnostics.converged != n {
            return Err(format!(
                "{} of {n} entries are flagged unconverged",
                n.saturating_sub(self.diagnostics.converged)
            ));
        }
        if let Some(p) = &self.diagnostics.per_entry {
            let ok = p.residual.len() as u64 == n && p.iterations.len() as u64 == n && p.converged.len() as u64 == n;
            if !ok {
                return Err("per-entry diagnostics length differs from the grid".into());
            }
            if let Some(i) = p.converged.iter().position(|&c| !c) {
                return Err(format!("entry {i} is flagged unconverged"));
            }
        }
        if settings_hash(&self.fit.method, &self.fit.settings) != self.fit.settings_hash {
            return Err("fit settings hash does not match the settings".into());
        }
        Ok(())
    }

    /// Payload size in bytes, `None` on overflow.
    pub fn payload_len(&self) -> Option<u64> {
        self.entries()?.checked_mul(self.channels.len() as u64)?.checked_mul(4)
    }
}

/// Largest stored value allowed in a [`Encoding::Log`] channel: its decoded value
/// `exp(v)` must stay finite in f32 (no table may hand a renderer an infinity).
pub const MAX_LOG_VALUE: f32 = 88.0;

/// Index and value of the first stored value that is non-finite, or whose decoded
/// value would overflow f32 (log channels), in payload order.
pub(crate) fn first_unstorable(meta: &Meta, payload: &[f32]) -> Option<(usize, f32)> {
    let nc = meta.channels.len().max(1);
    payload.iter().copied().enumerate().find(|&(i, v)| {
        !v.is_finite() || (meta.channels.get(i % nc).map(|c| c.encoding) == Some(Encoding::Log) && v > MAX_LOG_VALUE)
    })
}

/// FNV-1a 64-bit hash of the postcard encoding of `(method, settings)`: a stable
/// fingerprint of how a table was fitted.
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn settings_hash(method: &str, settings: &[(String, String)]) -> u64 {
    let bytes = postcard::to_allocvec(&(method, settings)).unwrap_or_default();
    fnv1a64(&bytes)
}

/// FNV-1a, 64-bit.
pub(crate) fn fnv1a64(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// Decoded fixed header.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// Format major version.
    pub major: u16,
    /// Format minor version.
    pub minor: u16,
    /// Table kind (ASCII, at most 16 bytes).
    pub kind: String,
    /// Offset of the metadata block (always 64 in version 1).
    pub meta_offset: u32,
    /// Length of the metadata block.
    pub meta_len: u32,
    /// Offset of the payload (multiple of 16).
    pub payload_offset: u32,
    /// Length of the payload in bytes.
    pub payload_len: u32,
    /// CRC-32 (IEEE) of the metadata block.
    pub meta_crc: u32,
    /// CRC-32 (IEEE) of the payload.
    pub payload_crc: u32,
}

fn u16_at(b: &[u8], o: usize) -> u16 {
    u16::from_le_bytes([b[o], b[o + 1]])
}
fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]])
}

/// Serialises a table. `payload` holds the stored (already encoded) values in
/// payload order. Fails when the description is invalid or does not match the
/// payload, so a writer can never produce a file the reader rejects.
#[cfg(feature = "writer")]
pub fn encode(meta: &Meta, payload: &[f32]) -> Result<Vec<u8>, String> {
    meta.validate()?;
    let kind = meta.kind.as_bytes();
    if kind.is_empty() || kind.len() > KIND_LEN || !meta.kind.is_ascii() {
        return Err(format!("kind '{}' must be 1..=16 ASCII bytes", meta.kind));
    }
    if meta.payload_len() != Some(payload.len() as u64 * 4) {
        return Err(format!(
            "payload has {} values, description needs {:?} bytes",
            payload.len(),
            meta.payload_len()
        ));
    }
    if let Some((i, v)) = first_unstorable(meta, payload) {
        return Err(format!(
            "payload value #{i} ({}) is not finite or decodes to infinity",
            crate::error::short32(v)
        ));
    }
    let meta_bytes = postcard::to_allocvec(meta).map_err(|e| e.to_string())?;
    let meta_end = HEADER_LEN + meta_bytes.len();
    let payload_offset = meta_end.div_ceil(PAYLOAD_ALIGN) * PAYLOAD_ALIGN;
    let payload_bytes: Vec<u8> = payload.iter().flat_map(|v| v.to_le_bytes()).collect();
    let total = payload_offset + payload_bytes.len();
    if total as u64 > MAX_FILE_LEN {
        return Err(format!("table of {total} bytes exceeds the format's limit"));
    }
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&FORMAT_MAJOR.to_le_bytes());
    out.extend_from_slice(&FORMAT_MINOR.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // flags, reserved
    let mut kind_field = [0u8; KIND_LEN];
    kind_field[..kind.len()].copy_from_slice(kind);
    out.extend_from_slice(&kind_field);
    out.extend_from_slice(&(HEADER_LEN as u32).to_le_bytes());
    out.extend_from_slice(&(meta_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&(payload_offset as u32).to_le_bytes());
    out.extend_from_slice(&(payload_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&meta_bytes).to_le_bytes());
    out.extend_from_slice(&crc32fast::hash(&payload_bytes).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // reserved
    let header_crc = crc32fast::hash(&out[..60]);
    out.extend_from_slice(&header_crc.to_le_bytes());
    debug_assert_eq!(out.len(), HEADER_LEN);
    out.extend_from_slice(&meta_bytes);
    out.resize(payload_offset, 0);
    out.extend_from_slice(&payload_bytes);
    Ok(out)
}

/// Parses and validates the fixed header against the byte string's length.
pub fn decode_header(bytes: &[u8]) -> Result<Header, LoadError> {
    let have = bytes.len() as u64;
    if have > MAX_FILE_LEN {
        return Err(LoadError::BadLayout(format!(
            "{have} bytes exceeds the format's {MAX_FILE_LEN}-byte limit"
        )));
    }
    if bytes.len() < 8 {
        return Err(LoadError::Truncated {
            needed: HEADER_LEN as u64,
            have,
        });
    }
    if bytes[..8] != MAGIC {
        let mut found = [0u8; 8];
        found.copy_from_slice(&bytes[..8]);
        return Err(LoadError::BadMagic { found });
    }
    if bytes.len() < 12 {
        return Err(LoadError::Truncated {
            needed: HEADER_LEN as u64,
            have,
        });
    }
    // Version before the header CRC: a future major may have a different header.
    let (major, minor) = (u16_at(bytes, 8), u16_at(bytes, 10));
    if major != FORMAT_MAJOR {
        return Err(LoadError::UnsupportedFormat {
            found_major: major,
            found_minor: minor,
            supported_major: FORMAT_MAJOR,
        });
    }
    if bytes.len() < HEADER_LEN {
        return Err(LoadError::Truncated {
            needed: HEADER_LEN as u64,
            have,
        });
    }
    let stored = u32_at(bytes, 60);
    let computed = crc32fast::hash(&bytes[..60]);
    if stored != computed {
        return Err(LoadError::Checksum {
            section: "header",
            stored,
            computed,
        });
    }
    // Flags and the reserved word are zero in every 1.x file; anything else is
    // corruption that happened to keep the CRC or a writer this reader cannot honour.
    if u32_at(bytes, 12) != 0 || u32_at(bytes, 56) != 0 {
        return Err(LoadError::BadLayout(
            "flags or reserved header words are not zero".into(),
        ));
    }
    let kind_raw = &bytes[16..16 + KIND_LEN];
    let kind_len = kind_raw.iter().position(|&b| b == 0).unwrap_or(KIND_LEN);
    if kind_raw[kind_len..].iter().any(|&b| b != 0) || !kind_raw[..kind_len].is_ascii() || kind_len == 0 {
        return Err(LoadError::BadLayout("kind field is not NUL-padded ASCII".into()));
    }
    let kind = String::from_utf8_lossy(&kind_raw[..kind_len]).into_owned();
    let h = Header {
        major,
        minor,
        kind,
        meta_offset: u32_at(bytes, 32),
        meta_len: u32_at(bytes, 36),
        payload_offset: u32_at(bytes, 40),
        payload_len: u32_at(bytes, 44),
        meta_crc: u32_at(bytes, 48),
        payload_crc: u32_at(bytes, 52),
    };
    if h.meta_offset as usize != HEADER_LEN {
        return Err(LoadError::BadLayout(format!(
            "metadata offset {} (must be {HEADER_LEN})",
            h.meta_offset
        )));
    }
    // One valid place for the payload: the first 16-byte boundary after the metadata.
    let meta_end = h.meta_offset as u64 + h.meta_len as u64;
    let aligned = meta_end.div_ceil(PAYLOAD_ALIGN as u64) * PAYLOAD_ALIGN as u64;
    if h.payload_offset as u64 != aligned {
        return Err(LoadError::BadLayout(format!(
            "payload offset {} (must be {aligned}: the metadata ends at {meta_end}, payload is 16-aligned)",
            h.payload_offset
        )));
    }
    if !h.payload_len.is_multiple_of(4) {
        return Err(LoadError::BadLayout(format!(
            "payload length {} is not a multiple of 4",
            h.payload_len
        )));
    }
    let end = h.payload_offset as u64 + h.payload_len as u64;
    if have < end {
        return Err(LoadError::Truncated { needed: end, have });
    }
    if have > end {
        return Err(LoadError::TrailingBytes { extra: have - end });
    }
    Ok(h)
}
