//! Typed errors of the runtime crate. Every way a file or a query can be wrong has
//! its own variant, so callers (and tests) can tell them apart.

use std::fmt;

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
    #[error("payload value #{index} ({}) is not finite or decodes to infinity", short32(*.value))]
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
    /// A finite stored value lies outside the plausible range its family declares for
    /// the channel (the stored, encoded value: ln of the quantity for a log-encoded
    /// channel), so the file cannot hold what its kind says.
    #[error(
        "table '{kind}': channel {channel} at node {node:?} holds {}, outside its plausible range [{}, {}]", short32(*.value), short(*.lo), short(*.hi)
    )]
    ImplausibleValue {
        kind: String,
        channel: String,
        /// Multi-index of the node, slowest axis first.
        node: Vec<u32>,
        value: f32,
        lo: f64,
        hi: f64,
    },
}

/// Why a lookup was refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LookupError {
    /// The query holds a NaN or an infinity.
    #[error("{name} is not a finite number ({})", short(*.value))]
    NotFinite { name: String, value: f64 },
    /// The query lies outside the domain the table covers.
    #[error("{name} = {} is outside the domain [{}, {}]", short(*.value), short(*.lo), short(*.hi))]
    OutOfDomain { name: String, value: f64, lo: f64, hi: f64 },
    /// The number of coordinates does not match the number of axes.
    #[error("query has {got} coordinates, table has {expected} axes")]
    Arity { expected: usize, got: usize },
    /// The output buffer does not match the number of channels.
    #[error("output buffer has {got} slots, table has {expected} channels")]
    Channels { expected: usize, got: usize },
    /// A node index is past the end of its axis.
    #[error("node index {index} of axis {axis} is out of range (the axis has {count} nodes)")]
    NodeIndex { axis: String, index: u32, count: u32 },
    /// Finite inputs whose result is not finite (too large for f64, or for f32 in a
    /// single-precision twin): an error, never an `Ok(inf)` or `Ok(NaN)`.
    #[error("{name} overflows ({}): the inputs are too large for a finite result", short(*.value))]
    Overflow { name: String, value: f64 },
    /// A coefficient vector's length is not n² for an SH order n in `1..=max_order`.
    #[error("{got} SH coefficients: not n² for an order n in 1..={max_order}")]
    ShLength { got: usize, max_order: usize },
    /// A coefficient vector does not have the length the operation needs.
    #[error("{name} has {got} coefficients, expected {expected}")]
    Coefficients {
        name: &'static str,
        got: usize,
        expected: String,
    },
    /// An output buffer is shorter than the result (of a function that reads no table).
    #[error("output buffer has {got} slots, needs {needed} {what}")]
    Output {
        got: usize,
        needed: usize,
        what: &'static str,
    },
    /// A pipeline (a composition of tables, e.g. `eval isg-shade`) cannot answer this
    /// query; `reason` says why (an input outside a table it needs, a scene the method
    /// does not cover).
    #[error("{reason}")]
    Refused { reason: String },
    /// A product of lobes whose peak value or exponent overflows f64.
    #[error("the product of lobes with exponents e1 = {} and e2 = {} overflows", short(*.e1), short(*.e2))]
    ProductOverflow { e1: f64, e2: f64 },
    /// A batch lookup's output slice is not as long as its input slice.
    #[error("batch of {inputs} queries has {outputs} output slots; they must be equal")]
    BatchLength { inputs: usize, outputs: usize },
    /// Item `index` (0-based) of a batch lookup was refused, for the reason `error`
    /// (what the one-at-a-time lookup returns for it); the first such item is
    /// reported and the output slice is left unspecified.
    #[error("batch item {index}: {error}")]
    BatchItem { index: usize, error: Box<LookupError> },
}

/// Fails with [`LookupError::BatchLength`] unless `inputs == outputs`.
pub(crate) fn same_length(inputs: usize, outputs: usize) -> Result<(), LookupError> {
    if inputs == outputs {
        Ok(())
    } else {
        Err(LookupError::BatchLength { inputs, outputs })
    }
}

/// Wraps the error of batch item `index`.
pub(crate) fn at_index(index: usize, error: LookupError) -> LookupError {
    LookupError::BatchItem {
        index,
        error: Box::new(error),
    }
}

/// The first item of a batch for which `single` (the one-at-a-time lookup) fails, as
/// [`LookupError::BatchItem`]; `Ok` when every item passes. Batch APIs call it only
/// after their branch-free pass found a bad input or result, so the error is exactly
/// the one-at-a-time error.
pub(crate) fn first_failure<T, R>(
    items: &[T],
    single: impl Fn(&T) -> Result<R, LookupError>,
) -> Result<(), LookupError> {
    for (i, x) in items.iter().enumerate() {
        if let Err(e) = single(x) {
            return Err(at_index(i, e));
        }
    }
    Ok(())
}

/// A number formatted for a message: the shortest digits that round-trip, plainly
/// for 1e-4 ≤ |x| < 1e16 and in scientific notation otherwise (`{}` alone writes
/// 1e308 as 309 digits and a subnormal as hundreds of zeros).
///
/// ```
/// use lobefit_tables::error::short;
/// assert_eq!(short(0.1).to_string(), "0.1");
/// assert_eq!(short(1e308).to_string(), "1e308");
/// assert_eq!(short(-5e-324).to_string(), "-5e-324");
/// ```
#[cfg_attr(feature = "writer", visibility::make(pub))]
pub(crate) fn short(x: f64) -> impl fmt::Display {
    Short(x)
}

/// [`short`] for an `f32`, with the `f32`'s own shortest digits.
pub(crate) fn short32(x: f32) -> impl fmt::Display {
    Short32(x)
}

struct Short(f64);
struct Short32(f32);

/// Whether `a` (an absolute value) is written plainly rather than in scientific form.
fn plain(a: f64) -> bool {
    !a.is_finite() || a == 0.0 || (1e-4..1e16).contains(&a)
}

impl fmt::Display for Short {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if plain(self.0.abs()) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

impl fmt::Display for Short32 {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if plain(f64::from(self.0.abs())) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
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

/// Fails with [`LookupError::Overflow`] unless the computed `value` is finite.
pub(crate) fn finite_result(name: &str, value: f64) -> Result<f64, LookupError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(LookupError::Overflow {
            name: name.to_string(),
            value,
        })
    }
}

/// Rounds an f64 result to f32 (the f32 twins), refusing a value that is not finite
/// in f32: narrowing can overflow where the f64 result did not.
/// An f32 angle as f64, with `std::f32::consts::PI` (π + 8.7e-8) taken as π: the
/// f32 nearest to π (what `acos(-1.0f32)` returns) must be a valid end of a [0, π]
/// domain. Every `_f32` twin taking an angle reads it through this.
pub fn angle_f32(x: f32) -> f64 {
    if x == std::f32::consts::PI {
        std::f64::consts::PI
    } else {
        x as f64
    }
}

pub(crate) fn narrow(name: &str, value: f64) -> Result<f32, LookupError> {
    let v = value as f32;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(LookupError::Overflow {
            name: format!("{name} (f32)"),
            value,
        })
    }
}

/// [`copy_f32`] that also refuses any value that is not finite in f32 (see [`narrow`]).
pub(crate) fn narrow_all(name: &str, src: &[f64], out: &mut [f32]) -> Result<(), LookupError> {
    for (i, s) in src.iter().enumerate() {
        narrow(&format!("{name}[{i}]"), *s)?;
    }
    copy_f32(src, out)
}

/// Refuses a non-finite entry of a computed vector (see [`finite_result`]).
pub(crate) fn finite_results(name: &str, values: &[f64]) -> Result<(), LookupError> {
    for (i, v) in values.iter().enumerate() {
        finite_result(&format!("{name}[{i}]"), *v)?;
    }
    Ok(())
}
