//! A loaded, validated table and its multilinear interpolation.

use std::path::Path;

use crate::error::{in_range, LoadError, LookupError};
use crate::format::{decode_header, Encoding, Header, Meta, HEADER_LEN};

/// A validated table: header, metadata and the decoded payload.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    header: Header,
    meta: Meta,
    values: Vec<f32>,
    payload_offset: usize,
    bytes: Vec<u8>,
}

impl Table {
    /// Parses and validates a table file held in memory. Never panics: every
    /// malformed byte string yields a [`LoadError`].
    pub fn from_bytes(bytes: &[u8]) -> Result<Table, LoadError> {
        let header = decode_header(bytes)?;
        let meta_bytes = &bytes[HEADER_LEN..HEADER_LEN + header.meta_len as usize];
        let computed = crc32fast::hash(meta_bytes);
        if computed != header.meta_crc {
            return Err(LoadError::Checksum {
                section: "metadata",
                stored: header.meta_crc,
                computed,
            });
        }
        let p0 = header.payload_offset as usize;
        let payload = &bytes[p0..p0 + header.payload_len as usize];
        let computed = crc32fast::hash(payload);
        if computed != header.payload_crc {
            return Err(LoadError::Checksum {
                section: "payload",
                stored: header.payload_crc,
                computed,
            });
        }
        if bytes[HEADER_LEN + meta_bytes.len()..p0].iter().any(|&b| b != 0) {
            return Err(LoadError::BadLayout("padding before the payload is not zero".into()));
        }
        let (meta, rest) =
            postcard::take_from_bytes::<Meta>(meta_bytes).map_err(|e| LoadError::BadMetadata(e.to_string()))?;
        if !rest.is_empty() {
            return Err(LoadError::BadMetadata(format!(
                "{} bytes after the metadata record",
                rest.len()
            )));
        }
        if meta.kind != header.kind {
            return Err(LoadError::Invalid(format!(
                "header kind '{}' differs from metadata kind '{}'",
                header.kind, meta.kind
            )));
        }
        meta.validate().map_err(LoadError::Invalid)?;
        if meta.payload_len() != Some(header.payload_len as u64) {
            return Err(LoadError::Invalid(format!(
                "payload is {} bytes, the axes and channels need {:?}",
                header.payload_len,
                meta.payload_len()
            )));
        }
        let values: Vec<f32> = payload
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if let Some((index, value)) = crate::format::first_unstorable(&meta, &values) {
            return Err(LoadError::NonFinite { index, value });
        }
        Ok(Table {
            header,
            meta,
            values,
            payload_offset: p0,
            bytes: bytes.to_vec(),
        })
    }

    /// Reads and validates a table file.
    pub fn from_path(path: impl AsRef<Path>) -> Result<Table, LoadError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| LoadError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Table::from_bytes(&bytes)
    }

    /// Like [`Table::from_bytes`], and also checks the kind and the family version.
    pub fn from_bytes_of_kind(bytes: &[u8], kind: &str, version: u32) -> Result<Table, LoadError> {
        let t = Table::from_bytes(bytes)?;
        t.expect_kind(kind, version)?;
        Ok(t)
    }

    /// Fails unless this table is of `kind` at family version `version`.
    pub fn expect_kind(&self, kind: &str, version: u32) -> Result<(), LoadError> {
        if self.meta.kind != kind {
            return Err(LoadError::WrongKind {
                expected: kind.to_string(),
                found: self.meta.kind.clone(),
            });
        }
        if self.meta.table_version != version {
            return Err(LoadError::UnsupportedTableVersion {
                kind: kind.to_string(),
                found: self.meta.table_version,
                supported: version,
            });
        }
        Ok(())
    }

    /// The decoded fixed header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The self-description.
    pub fn meta(&self) -> &Meta {
        &self.meta
    }

    /// Stored values in payload order (C order, channels fastest), still encoded.
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// The raw little-endian payload bytes, ready for a texture upload.
    pub fn payload_bytes(&self) -> &[u8] {
        &self.bytes[self.payload_offset..]
    }

    /// Stored (encoded) values of the node with multi-index `idx`.
    pub fn node(&self, idx: &[u32]) -> &[f32] {
        let c = self.meta.channels.len();
        let mut flat = 0usize;
        for (a, &i) in self.meta.axes.iter().zip(idx) {
            flat = flat * a.count as usize + i as usize;
        }
        &self.values[flat * c..(flat + 1) * c]
    }

    /// Multilinear interpolation (linear in each axis's mapped coordinate) of every
    /// channel at `x` (one coordinate per axis, in axis units), decoded into `out`.
    /// Coordinates must lie in each axis's `[lo, hi]`; between a `Centres` end node
    /// and the range end the value is held constant (clamp-to-edge).
    pub fn interpolate(&self, x: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
        let axes = &self.meta.axes;
        let nc = self.meta.channels.len();
        if x.len() != axes.len() {
            return Err(LookupError::Arity {
                expected: axes.len(),
                got: x.len(),
            });
        }
        if out.len() != nc {
            return Err(LookupError::Arity {
                expected: nc,
                got: out.len(),
            });
        }
        let mut base = [0usize; 4];
        let mut frac = [0f64; 4];
        for (d, (a, &xd)) in axes.iter().zip(x).enumerate() {
            in_range(&a.name, xd, a.lo, a.hi)?;
            let n = a.count as usize;
            let s = a.node_coordinate(xd).clamp(0.0, (n - 1) as f64);
            let i = (s.floor() as usize).min(n - 2);
            base[d] = i;
            frac[d] = s - i as f64;
        }
        out.iter_mut().for_each(|o| *o = 0.0);
        for corner in 0..(1usize << axes.len()) {
            let mut w = 1.0;
            let mut flat = 0usize;
            for (d, a) in axes.iter().enumerate() {
                let hi = (corner >> d) & 1;
                w *= if hi == 1 { frac[d] } else { 1.0 - frac[d] };
                flat = flat * a.count as usize + base[d] + hi;
            }
            if w == 0.0 {
                continue;
            }
            for (c, o) in out.iter_mut().enumerate() {
                *o += w * self.values[flat * nc + c] as f64;
            }
        }
        for (o, ch) in out.iter_mut().zip(&self.meta.channels) {
            if ch.encoding == Encoding::Log {
                *o = o.exp();
            }
        }
        Ok(())
    }
}
