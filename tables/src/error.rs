//! Typed errors of the runtime crate. Every way a file or a query can be wrong has
//! its own variant, so callers (and tests) can tell them apart.

use thiserror::Error;

/// Why a table file was rejected by [`crate::Table::from_bytes`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LoadError {
    /// The byte string is shorter than a field the header says must be there.
    #[error("truncated table file: need at least {needed} bytes, have {have}")]
    Truncated { needed: u64, have: u64 },
    /// The file is longer than header + metadata + payload.
    #[error("table file has {extra} unexpected trailing bytes (oversized or concatenated file)")]
    TrailingBytes { extra: u64 },
    /// The first eight bytes are not the lobefit magic.
    #[error("not a lobefit table (bad magic {found:02x?})")]
    BadMagic { found: [u8; 8] },
    /// A major format version this reader does not understand.
    #[error("unsupported table format version {found_major}.{found_minor} (this reader reads {supported_major}.x)")]
    UnsupportedFormat {
        found_major: u16,
        found_minor: u16,
        supported_major: u16,
    },
    /// A checksum did not match: the named section is corrupt.
    #[error("checksum mismatch in {section}: stored {stored:#010x}, computed {computed:#010x}")]
    Checksum {
        section: &'static str,
        stored: u32,
        computed: u32,
    },
    /// Offsets or lengths in the header are inconsistent.
    #[error("bad header layout: {0}")]
    BadLayout(String),
    /// The metadata block does not decode.
    #[error("metadata does not decode: {0}")]
    BadMetadata(String),
    /// The metadata decodes but describes an impossible table.
    #[error("invalid table description: {0}")]
    Invalid(String),
    /// The payload holds a NaN or infinite value, or a log-encoded value whose
    /// decoded value would overflow f32.
    #[error("payload value #{index} ({value}) is not finite or decodes to infinity")]
    NonFinite { index: usize, value: f32 },
    /// A family loader was handed a table of another kind.
    #[error("wrong table kind: expected '{expected}', file holds '{found}'")]
    WrongKind { expected: String, found: String },
    /// The family's own table version is not one this runtime reads.
    #[error("table '{kind}' has version {found}; this runtime reads version {supported}")]
    UnsupportedTableVersion { kind: String, found: u32, supported: u32 },
    /// The file is of the right kind and version but its axes or channels are not the
    /// layout this runtime interprets (mapping, range, encoding, channel count).
    #[error("table '{kind}' has an unexpected layout: {detail}")]
    LayoutMismatch { kind: String, detail: String },
    /// The path names a directory, FIFO, device or socket: refused before it is
    /// opened (opening a FIFO blocks; a device can be read without end).
    #[error("cannot read table file {path}: it is {what}, not a regular file")]
    NotAFile { path: String, what: &'static str },
    /// The file is larger than any table may be: refused before it is read.
    #[error("table file {path} is {len} bytes, over the format's limit of {limit} bytes")]
    TooLarge { path: String, len: u64, limit: u64 },
    /// Reading the file from disk failed (message of the I/O error).
    #[error("cannot read table file {path}: {message}")]
    Io { path: String, message: String },
}

/// Why a lookup was refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LookupError {
    /// The query holds a NaN or an infinity.
    #[error("{name} is not a finite number ({value})")]
    NotFinite { name: String, value: f64 },
    /// The query lies outside the domain the table covers.
    #[error("{name} = {value} is outside the domain [{lo}, {hi}]")]
    OutOfDomain { name: String, value: f64, lo: f64, hi: f64 },
    /// The number of coordinates does not match the number of axes.
    #[error("query has {got} coordinates, table has {expected} axes")]
    Arity { expected: usize, got: usize },
    /// The output buffer does not match the number of channels.
    #[error("output buffer has {got} slots, table has {expected} channels")]
    Channels { expected: usize, got: usize },
}

/// Rejects NaN and infinities with an error naming the quantity.
pub(crate) fn finite(name: &str, value: f64) -> Result<f64, LookupError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(LookupError::NotFinite {
            name: name.to_string(),
            value,
        })
    }
}

/// Writes an f64 result into an f32 output buffer (the f32 twins: computed in f64,
/// rounded once). Errors when `out` is shorter than `src`.
pub(crate) fn copy_f32(src: &[f64], out: &mut [f32]) -> Result<(), LookupError> {
    if out.len() < src.len() {
        return Err(LookupError::Channels {
            expected: src.len(),
            got: out.len(),
        });
    }
    for (o, s) in out.iter_mut().zip(src) {
        *o = *s as f32;
    }
    Ok(())
}

/// Checks `lo <= value <= hi` (and finiteness).
pub(crate) fn in_range(name: &str, value: f64, lo: f64, hi: f64) -> Result<f64, LookupError> {
    let v = finite(name, value)?;
    if v < lo || v > hi {
        return Err(LookupError::OutOfDomain {
            name: name.to_string(),
            value: v,
            lo,
            hi,
        });
    }
    Ok(v)
}
