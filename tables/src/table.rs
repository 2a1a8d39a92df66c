//! A loaded, validated table and its multilinear interpolation.

use std::io::Read;
use std::path::Path;

use crate::error::{in_range, LoadError, LookupError};
use crate::format::{decode_header, Axis, Encoding, Header, Meta, HEADER_LEN, MAX_FILE_LEN};

/// A validated table: header, metadata and the decoded payload.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    header: Header,
    meta: Meta,
    values: Vec<f32>,
    payload: Vec<u8>,
    /// Per-axis constants of the lookup, derived from `meta` once at load time.
    maps: Vec<AxisMap>,
}

/// What [`Table::interpolate`] needs of one axis, computed once at load time rather
/// than per lookup (the mapped range ends alone cost two transcendental calls per axis
/// and call). The arithmetic is the same as [`Axis::node_coordinate`]'s, in the same
/// order, so results are bit-identical.
#[derive(Debug, Clone, Copy, PartialEq)]
struct AxisMap {
    mapping: crate::format::Mapping,
    lo: f64,
    hi: f64,
    /// Mapped coordinate of `lo`.
    u0: f64,
    /// Mapped span u(hi) − u(lo).
    du: f64,
    /// Node-index scale of the normalised coordinate: count − 1 (end-points) or count
    /// (centres).
    k: f64,
    /// Whether nodes sit on cell centres (then the index is shifted by −1/2).
    centres: bool,
    /// Largest node index, as f64 (the clamp bound).
    last: f64,
    /// Largest cell start index, count − 2.
    last_cell: usize,
    /// Flat-index stride of the axis, in nodes.
    stride: usize,
}

impl AxisMap {
    fn new(a: &Axis, stride: usize) -> AxisMap {
        let (u0, u1) = a.mapped_range();
        let centres = a.placement == crate::format::Placement::Centres;
        AxisMap {
            mapping: a.mapping,
            lo: a.lo,
            hi: a.hi,
            u0,
            du: u1 - u0,
            k: if centres { a.count as f64 } else { a.count as f64 - 1.0 },
            centres,
            last: (a.count - 1) as f64,
            last_cell: a.count as usize - 2,
            stride,
        }
    }

    /// Clamped continuous node index of `x`: [`Axis::node_coordinate`] clamped to
    /// [0, count − 1].
    #[inline]
    fn coordinate(&self, x: f64) -> f64 {
        let t = (self.mapping.forward(x) - self.u0) / self.du;
        let s = if self.centres { t * self.k - 0.5 } else { t * self.k };
        s.clamp(0.0, self.last)
    }
}

/// The axis maps of a validated description (strides in nodes, slowest axis first).
fn axis_maps(meta: &Meta) -> Vec<AxisMap> {
    let mut maps = Vec::with_capacity(meta.axes.len());
    let mut stride = 1usize;
    for a in meta.axes.iter().rev() {
        maps.push(AxisMap::new(a, stride));
        stride *= a.count as usize;
    }
    maps.reverse();
    maps
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
        let (meta, rest) = postcard::take_from_bytes::<Meta>(meta_bytes)
            .map_err(|e| LoadError::BadMetadata(crate::meta_error::explain(meta_bytes, &e)))?;
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
            maps: axis_maps(&meta),
            meta,
            values,
            payload: payload.to_vec(),
        })
    }

    /// Reads and validates a table file. Anything but a regular file of at most
    /// [`MAX_FILE_LEN`] bytes is refused from its metadata, before it is read.
    pub fn from_path(path: impl AsRef<Path>) -> Result<Table, LoadError> {
        let path = path.as_ref();
        let io = |e: std::io::Error| LoadError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        // Before opening: opening a FIFO blocks until a writer appears.
        check_file(path, &std::fs::metadata(path).map_err(io)?)?;
        let file = std::fs::File::open(path).map_err(io)?;
        // Again on the open file, in case the path was replaced in between.
        let meta = file.metadata().map_err(io)?;
        check_file(path, &meta)?;
        let mut bytes = Vec::with_capacity(meta.len() as usize);
        // One byte past the limit at most, should the file grow while being read:
        // `from_bytes` then refuses it.
        file.take(MAX_FILE_LEN + 1).read_to_end(&mut bytes).map_err(io)?;
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

    /// Checks a one-axis layout: see [`Table::expect_layout`].
    pub fn expect_layout_1d(&self, axis: &Axis, channels: &[(&str, Encoding)]) -> Result<(), LoadError> {
        self.expect_layout(std::slice::from_ref(axis), channels)
    }

    /// Checks that the file has exactly these axes (name, unit, range, mapping and
    /// placement; any node count), slowest first, and these channels in this order,
    /// so a family's runtime never misreads a file laid out differently.
    pub fn expect_layout(&self, axes: &[Axis], channels: &[(&str, Encoding)]) -> Result<(), LoadError> {
        let m = &self.meta;
        let mismatch = |detail: String| LoadError::LayoutMismatch {
            kind: m.kind.clone(),
            detail,
        };
        if m.axes.len() != axes.len() {
            return Err(mismatch(format!("{} axes, expected {}", m.axes.len(), axes.len())));
        }
        for (a, axis) in m.axes.iter().zip(axes) {
            let same = a.name == axis.name
                && a.unit == axis.unit
                && a.lo == axis.lo
                && a.hi == axis.hi
                && a.mapping == axis.mapping
                && a.placement == axis.placement;
            if !same {
                return Err(mismatch(format!("axis {a:?}, expected {axis:?} (any count)")));
            }
        }
        let found: Vec<(&str, Encoding)> = m.channels.iter().map(|c| (c.name.as_str(), c.encoding)).collect();
        if found != channels {
            return Err(mismatch(format!("channels {found:?}, expected {channels:?}")));
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
        &self.payload
    }

    /// Stored (encoded) values of the node with multi-index `idx` (one index per axis,
    /// slowest first). Errors: [`LookupError::Arity`] when `idx` does not have one
    /// entry per axis, [`LookupError::NodeIndex`] for an index past its axis's end.
    pub fn node(&self, idx: &[u32]) -> Result<&[f32], LookupError> {
        let axes = &self.meta.axes;
        if idx.len() != axes.len() {
            return Err(LookupError::Arity {
                expected: axes.len(),
                got: idx.len(),
            });
        }
        let c = self.meta.channels.len();
        let mut flat = 0usize;
        for (a, &i) in axes.iter().zip(idx) {
            if i >= a.count {
                return Err(LookupError::NodeIndex {
                    axis: a.name.clone(),
                    index: i,
                    count: a.count,
                });
            }
            flat = flat * a.count as usize + i as usize;
        }
        Ok(&self.values[flat * c..(flat + 1) * c])
    }

    /// The stored values as an n-dimensional view for analysis code (cargo feature
    /// `ndarray`): shape = (node count of each axis, slowest first..., channel count),
    /// so `view[[i, j, c]] == node(&[i, j])?[c]`. Values are shown as stored: still
    /// encoded (ln of the quantity for a log channel), and families that store a value
    /// as an f32 hi + lo pair (log-zh, wedge, shexp) show both halves as channels.
    #[cfg(feature = "ndarray")]
    pub fn view(&self) -> ndarray::ArrayViewD<'_, f32> {
        let mut shape: Vec<usize> = self.meta.axes.iter().map(|a| a.count as usize).collect();
        shape.push(self.meta.channels.len());
        // Loading checked that the payload holds exactly entries × channels values.
        ndarray::ArrayViewD::from_shape(shape, &self.values).expect("a validated payload matches its layout")
    }

    /// Checks every stored value against its channel's plausible range: `ranges` holds
    /// (channel name, lo, hi) for each channel, bounds on the stored (encoded) value, so
    /// ln of the quantity for a log-encoded channel. Family loaders call it after
    /// [`Table::expect_layout`], so a file whose values are finite but absurd (a
    /// corrupt or hand-edited payload with valid checksums) is refused at load time
    /// instead of turning into infinities in lookups. The error names the channel,
    /// the node (multi-index, slowest axis first) and the value; the first offending
    /// value in payload order is reported.
    pub fn expect_channel_ranges(&self, ranges: &[(&str, f64, f64)]) -> Result<(), LoadError> {
        let m = &self.meta;
        let mut bounds = Vec::with_capacity(m.channels.len());
        for ch in &m.channels {
            match ranges.iter().find(|r| r.0 == ch.name) {
                Some(&(_, lo, hi)) => bounds.push((lo, hi)),
                None => {
                    return Err(LoadError::LayoutMismatch {
                        kind: m.kind.clone(),
                        detail: format!("no plausible range is declared for channel {}", ch.name),
                    })
                }
            }
        }
        let nc = bounds.len().max(1);
        for (i, &v) in self.values.iter().enumerate() {
            let (lo, hi) = bounds[i % nc];
            let v64 = v as f64;
            if !(lo..=hi).contains(&v64) {
                let mut rem = i / nc;
                let mut node = vec![0u32; m.axes.len()];
                for (d, a) in m.axes.iter().enumerate().rev() {
                    node[d] = (rem % a.count as usize) as u32;
                    rem /= a.count as usize;
                }
                return Err(LoadError::ImplausibleValue {
                    kind: m.kind.clone(),
                    channel: m.channels[i % nc].name.clone(),
                    node,
                    value: v,
                    lo,
                    hi,
                });
            }
        }
        Ok(())
    }

    /// Multilinear interpolation (linear in each axis's mapped coordinate) of every
    /// channel at `x` (one coordinate per axis, in axis units), decoded into `out`.
    /// Coordinates must lie in each axis's `[lo, hi]`; between a `Centres` end node
    /// and the range end the value is held constant (clamp-to-edge).
    pub fn interpolate(&self, x: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
        let nc = self.meta.channels.len();
        if x.len() != self.maps.len() {
            return Err(LookupError::Arity {
                expected: self.maps.len(),
                got: x.len(),
            });
        }
        if out.len() != nc {
            return Err(LookupError::Channels {
                expected: nc,
                got: out.len(),
            });
        }
        // Dispatch on the axis count (at most 4, checked at load) so the corner loop
        // is unrolled with fixed-size stack arrays.
        match x.len() {
            1 => self.interpolate_n::<1>(x, out),
            2 => self.interpolate_n::<2>(x, out),
            3 => self.interpolate_n::<3>(x, out),
            _ => self.interpolate_n::<4>(x, out),
        }
    }

    /// [`Table::interpolate`] for `D` axes (`x.len() == D`, `out.len()` = channels).
    #[inline]
    fn interpolate_n<const D: usize>(&self, x: &[f64], out: &mut [f64]) -> Result<(), LookupError> {
        for (d, (m, &xd)) in self.maps.iter().zip(x).enumerate() {
            if !(xd >= m.lo && xd <= m.hi) {
                // Cold path: the error names the axis.
                in_range(&self.meta.axes[d].name, xd, m.lo, m.hi)?;
            }
        }
        let x: &[f64; D] = x.try_into().map_err(|_| LookupError::Arity {
            expected: D,
            got: x.len(),
        })?;
        self.interpolate_valid(x, out);
        Ok(())
    }

    /// [`Table::interpolate`] at coordinates the caller has already checked to lie in
    /// the axes' ranges (`D` = axis count, `out.len()` = channel count): the batch
    /// lookups validate a whole slice first and then call this, with no `Result` per
    /// item. Out-of-range coordinates are clamped to the end nodes; NaN gives NaN.
    #[inline]
    pub(crate) fn interpolate_valid<const D: usize>(&self, x: &[f64; D], out: &mut [f64]) {
        let nc = out.len();
        let mut base = [0usize; D];
        let mut frac = [0f64; D];
        for d in 0..D {
            let m = &self.maps[d];
            let s = m.coordinate(x[d]);
            let i = (s as usize).min(m.last_cell);
            base[d] = i;
            frac[d] = s - i as f64;
        }
        out.iter_mut().for_each(|o| *o = 0.0);
        for corner in 0..(1usize << D) {
            let mut w = 1.0;
            let mut flat = 0usize;
            for d in 0..D {
                let hi = (corner >> d) & 1;
                w *= if hi == 1 { frac[d] } else { 1.0 - frac[d] };
                flat += (base[d] + hi) * self.maps[d].stride;
            }
            if w == 0.0 {
                continue;
            }
            let v = &self.values[flat * nc..flat * nc + nc];
            for (o, &s) in out.iter_mut().zip(v) {
                *o += w * s as f64;
            }
        }
        for (o, ch) in out.iter_mut().zip(&self.meta.channels) {
            if ch.encoding == Encoding::Log {
                *o = o.exp();
            }
        }
    }
}

/// Refuses non-regular files and files over [`MAX_FILE_LEN`] from their metadata.
fn check_file(path: &Path, meta: &std::fs::Metadata) -> Result<(), LoadError> {
    let t = meta.file_type();
    if !t.is_file() {
        return Err(LoadError::NotAFile {
            path: path.display().to_string(),
            what: file_type_name(t),
        });
    }
    if meta.len() > MAX_FILE_LEN {
        return Err(LoadError::TooLarge {
            path: path.display().to_string(),
            len: meta.len(),
            limit: MAX_FILE_LEN,
        });
    }
    Ok(())
}

/// "a directory", "a FIFO", ...: what a non-regular file is, for an error message
/// (the loader's, and the writers' refusal to replace one).
pub fn file_type_name(t: std::fs::FileType) -> &'static str {
    if t.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a directory"
    } else {
        "a special file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::format::{self, Axis, Channel, Diagnostics, FitInfo, Mapping, Placement, Storage};

    fn axis(name: &str, lo: f64, hi: f64, mapping: Mapping, count: u32, placement: Placement) -> Axis {
        Axis {
            name: name.into(),
            unit: "1".into(),
            lo,
            hi,
            mapping,
            count,
            placement,
        }
    }

    /// A table whose channels are `f(u-coordinates)` at the nodes, encoded and reloaded.
    fn synthetic(axes: Vec<Axis>, encodings: &[Encoding], f: impl Fn(&[f64], usize) -> f64) -> Table {
        let channels: Vec<Channel> = encodings
            .iter()
            .enumerate()
            .map(|(i, &encoding)| Channel {
                name: format!("c{i}"),
                unit: "1".into(),
                encoding,
                description: String::new(),
            })
            .collect();
        let n: usize = axes.iter().map(|a| a.count as usize).product();
        let mut payload = Vec::new();
        for flat in 0..n {
            let mut rem = flat;
            let mut u = vec![0.0; axes.len()];
            for d in (0..axes.len()).rev() {
                let i = (rem % axes[d].count as usize) as u32;
                rem /= axes[d].count as usize;
                u[d] = axes[d].mapping.forward(axes[d].node(i));
            }
            for (c, enc) in encodings.iter().enumerate() {
                let v = f(&u, c);
                payload.push(if *enc == Encoding::Log { v.ln() as f32 } else { v as f32 });
            }
        }
        let settings = vec![];
        let meta = format::Meta {
            kind: "synthetic".into(),
            table_version: 1,
            generator: "test".into(),
            description: String::new(),
            axes,
            channels,
            storage: Storage::F32,
            fit: FitInfo {
                method: "none".into(),
                settings_hash: format::settings_hash("none", &settings),
                settings,
            },
            diagnostics: Diagnostics {
                residual_meaning: String::new(),
                entries: n as u64,
                converged: n as u64,
                max_residual: 0.0,
                mean_residual: 0.0,
                max_iterations: 0,
                per_entry: None,
            },
            thresholds: vec![],
        };
        Table::from_bytes(&format::encode(&meta, &payload).unwrap()).unwrap()
    }

    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Multilinear interpolation reproduces any function that is affine in each mapped
    /// coordinate separately (here u0 + 2u1 − u2 + u0·u1·u2), in 1, 2 and 3 dimensions,
    /// on every mapping, to f32 precision.
    #[test]
    fn multilinear_is_exact_for_multiaffine_functions() {
        let all = [
            axis("a", 0.5, 3.0, Mapping::Linear, 5, Placement::Endpoints),
            axis("b", 0.01, 100.0, Mapping::Log, 7, Placement::Endpoints),
            axis("c", 0.0, 1e4, Mapping::Log1p { scale: 2.0 }, 4, Placement::Endpoints),
        ];
        for dims in 1..=3 {
            let axes: Vec<Axis> = all[..dims].to_vec();
            let f = |u: &[f64]| {
                let g = |k: usize| u.get(k).copied().unwrap_or(0.0);
                g(0) + 2.0 * g(1) - g(2) + g(0) * g(1) * g(2)
            };
            let t = synthetic(axes.clone(), &[Encoding::Linear], |u, _| f(u));
            let mut s = 7u64;
            for _ in 0..500 {
                let x: Vec<f64> = axes.iter().map(|a| a.lo + (a.hi - a.lo) * lcg(&mut s)).collect();
                let u: Vec<f64> = axes.iter().zip(&x).map(|(a, &x)| a.mapping.forward(x)).collect();
                let mut out = [0.0];
                t.interpolate(&x, &mut out).unwrap();
                assert!((out[0] - f(&u)).abs() < 1e-5 * (1.0 + f(&u).abs()), "{dims}D at {x:?}");
            }
        }
    }

    /// Log-encoded channels interpolate ln(value): exp of an affine function is exact.
    #[test]
    fn log_channels_interpolate_in_log_space() {
        let axes = vec![axis(
            "x",
            0.0,
            1e5,
            Mapping::Log1p { scale: 1.0 },
            9,
            Placement::Endpoints,
        )];
        let t = synthetic(axes, &[Encoding::Log, Encoding::Linear], |u, c| {
            if c == 0 {
                (3.0 - u[0]).exp()
            } else {
                u[0]
            }
        });
        let mut out = [0.0; 2];
        for x in [0.0, 0.37, 12.0, 999.0, 1e5] {
            t.interpolate(&[x], &mut out).unwrap();
            let u = x.ln_1p();
            assert!((out[0] / (3.0 - u).exp() - 1.0).abs() < 1e-6, "{x}");
            assert!((out[1] - u).abs() < 1e-5, "{x}");
        }
    }

    /// Cell-centred nodes: exact between the first and last centre, held constant
    /// (clamp-to-edge, the GPU convention) between a centre and the range end.
    #[test]
    fn centred_nodes_clamp_to_edge() {
        let axes = vec![axis("x", 0.0, 1.0, Mapping::Linear, 4, Placement::Centres)];
        let t = synthetic(axes.clone(), &[Encoding::Linear], |u, _| 10.0 * u[0]);
        let mut out = [0.0];
        for (x, want) in [
            (0.0, 1.25),
            (0.1, 1.25),
            (0.125, 1.25),
            (0.5, 5.0),
            (0.8, 8.0),
            (1.0, 8.75),
        ] {
            t.interpolate(&[x], &mut out).unwrap();
            assert!((out[0] - want).abs() < 1e-6, "x={x}: {}", out[0]);
        }
        assert!((axes[0].node(0) - 0.125).abs() < 1e-15 && (axes[0].node(3) - 0.875).abs() < 1e-15);
    }

    /// Axis mapping round trips: node i sits at node coordinate i, and forward/inverse agree.
    #[test]
    fn axis_mappings_round_trip() {
        let axes = [
            axis("lin", -2.0, 5.0, Mapping::Linear, 11, Placement::Endpoints),
            axis("log", 1e-3, 1e3, Mapping::Log, 13, Placement::Centres),
            axis(
                "l1p",
                0.0,
                1e5,
                Mapping::Log1p { scale: 1.0 },
                641,
                Placement::Endpoints,
            ),
            axis(
                "asinh",
                0.0,
                std::f64::consts::PI,
                Mapping::Asinh {
                    centre: std::f64::consts::FRAC_PI_2,
                    width: 1e-3,
                },
                97,
                Placement::Endpoints,
            ),
            axis(
                "logit",
                1e-3,
                std::f64::consts::FRAC_PI_2 - 1e-7,
                Mapping::Logit {
                    a: 0.0,
                    b: std::f64::consts::FRAC_PI_2,
                },
                1000,
                Placement::Endpoints,
            ),
        ];
        for a in &axes {
            for i in 0..a.count {
                let x = a.node(i);
                assert!(x >= a.lo && x <= a.hi, "{} node {i} = {x} outside", a.name);
                let s = a.node_coordinate(x);
                assert!((s - i as f64).abs() < 1e-6, "{} node {i}: coordinate {s}", a.name);
                let back = a.mapping.inverse(a.mapping.forward(x));
                // asinh round trips are accurate relative to the range, not to x (x = 0
                // comes back as ±1e-15).
                let scale = if matches!(a.mapping, Mapping::Asinh { .. }) {
                    a.hi.abs()
                } else {
                    x.abs()
                };
                assert!(
                    (back - x).abs() <= 1e-12 * scale.max(1e-300) + 1e-300,
                    "{}: {x} -> {back}",
                    a.name
                );
            }
        }
    }

    #[test]
    fn out_of_range_coordinates_are_refused_per_axis() {
        let axes = vec![
            axis("x", 0.0, 1.0, Mapping::Linear, 3, Placement::Endpoints),
            axis("y", 1.0, 2.0, Mapping::Log, 3, Placement::Endpoints),
        ];
        let t = synthetic(axes, &[Encoding::Linear], |u, _| u[0] + u[1]);
        let mut out = [0.0];
        match t.interpolate(&[0.5, 2.5], &mut out) {
            Err(LookupError::OutOfDomain { name, .. }) => assert_eq!(name, "y"),
            r => panic!("{r:?}"),
        }
        match t.interpolate(&[f64::NAN, 1.5], &mut out) {
            Err(LookupError::NotFinite { name, .. }) => assert_eq!(name, "x"),
            r => panic!("{r:?}"),
        }
    }
    /// The straightforward evaluation (mapped range ends recomputed per call through
    /// [`Axis::node_coordinate`], corners in the same order): the per-axis constants
    /// cached at load time must not change a single bit.
    fn reference_interpolate(t: &Table, x: &[f64], out: &mut [f64]) {
        let axes = &t.meta().axes;
        let nc = t.meta().channels.len();
        let (mut base, mut frac) = ([0usize; 4], [0f64; 4]);
        for (d, (a, &xd)) in axes.iter().zip(x).enumerate() {
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
                *o += w * t.values()[flat * nc + c] as f64;
            }
        }
        for (o, ch) in out.iter_mut().zip(&t.meta().channels) {
            if ch.encoding == Encoding::Log {
                *o = o.exp();
            }
        }
    }

    #[test]
    fn interpolation_is_bit_identical_to_the_reference() {
        let all = [
            axis("a", 0.5, 3.0, Mapping::Linear, 5, Placement::Centres),
            axis("b", 0.01, 100.0, Mapping::Log, 7, Placement::Endpoints),
            axis("c", 0.0, 1e4, Mapping::Log1p { scale: 2.0 }, 4, Placement::Centres),
            axis(
                "d",
                0.1,
                1.4,
                Mapping::Logit { a: 0.0, b: 1.5 },
                6,
                Placement::Endpoints,
            ),
        ];
        let mut s = 11u64;
        for dims in 1..=4 {
            let axes: Vec<Axis> = all[..dims].to_vec();
            let t = synthetic(axes.clone(), &[Encoding::Linear, Encoding::Log], |u, c| {
                (0.3 * u.iter().sum::<f64>() + c as f64).sin() + 2.0
            });
            for _ in 0..2000 {
                let x: Vec<f64> = axes.iter().map(|a| a.lo + (a.hi - a.lo) * lcg(&mut s)).collect();
                let (mut got, mut want) = ([0.0; 2], [0.0; 2]);
                t.interpolate(&x, &mut got).unwrap();
                reference_interpolate(&t, &x, &mut want);
                assert_eq!(got.map(f64::to_bits), want.map(f64::to_bits), "{dims}D at {x:?}");
            }
        }
    }

    #[cfg(all(feature = "ndarray", feature = "embedded-disk-light"))]
    #[test]
    fn view_matches_node_on_a_2d_table() {
        let t = Table::from_bytes(crate::embedded::DISK_LIGHT).unwrap();
        let (n0, n1, nc) = (t.meta().axes[0].count, t.meta().axes[1].count, t.meta().channels.len());
        let v = t.view();
        assert_eq!(v.shape(), &[n0 as usize, n1 as usize, nc]);
        for i in 0..n0 {
            for j in 0..n1 {
                let node = t.node(&[i, j]).unwrap();
                for (c, &x) in node.iter().enumerate() {
                    assert_eq!(
                        v[[i as usize, j as usize, c]].to_bits(),
                        x.to_bits(),
                        "node ({i}, {j}), channel {c}"
                    );
                }
            }
        }
    }
}
