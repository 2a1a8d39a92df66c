//! `lobefit eval`: CSV in, CSV out. Every row is validated and computed
//! before anything is written, so a bad row never leaves half an output behind. The
//! input is read a line at a time and the output spooled (in memory up to
//! [`SPOOL_MEMORY`], then in an anonymous temporary file), so memory stays bounded
//! whatever the row count.

use std::io::{BufRead, BufReader, BufWriter, Read, Seek, Write};

use crate::family::{Lookup, Query};

/// Output held in memory before the spool moves to a temporary file.
pub const SPOOL_MEMORY: usize = 4 << 20;
/// Longest accepted input line in bytes (a row of 64 SH coefficients is about
/// 1.6 kB); a longer one is refused rather than buffered.
pub const MAX_LINE_LEN: u64 = 1 << 20;

/// Why an evaluation was refused. Every variant names the offending line.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// The input has no header line.
    #[error("line 1: empty input, expected a header with columns {expected}")]
    Empty { expected: String },
    /// A header column is not an input of the family.
    #[error("line {line}: unknown column '{column}' (expected columns: {expected})")]
    UnknownColumn {
        line: u64,
        column: String,
        expected: String,
    },
    /// A header column appears twice.
    #[error("line {line}: duplicate column '{column}'")]
    DuplicateColumn { line: u64, column: String },
    /// A required input column is missing.
    #[error("line {line}: missing column '{column}' (expected columns: {expected})")]
    MissingColumn {
        line: u64,
        column: String,
        expected: String,
    },
    /// A data row is malformed or outside the domain.
    #[error("line {line}: {message}")]
    Row { line: u64, message: String },
    /// Reading the input failed.
    #[error("i/o error: cannot read the input: {0}")]
    Io(#[from] std::io::Error),
    /// Spooling or writing the output failed.
    #[error("i/o error: cannot write the output: {0}")]
    Output(std::io::Error),
}

/// Evaluates every row of `input` (CSV with a header of input columns) through
/// `lookup` (the runtime) or, when `lookup` is `None`, the family's exact path, and
/// writes the input columns followed by the output columns to `output`. Returns the
/// row count. Nothing is written to `output` unless every row succeeds.
///
/// The accepted CSV is plain and numeric: comma-separated,
/// optional UTF-8 BOM, LF or CRLF line ends, spaces around fields ignored, blank lines
/// skipped, no quoting, lines of at most [`MAX_LINE_LEN`] bytes. Line numbers in
/// errors are physical lines of the input; the first bad line is reported.
pub fn eval_csv(
    family: &dyn Query,
    lookup: Option<&dyn Lookup>,
    input: impl Read,
    mut output: impl Write,
) -> Result<usize, EvalError> {
    let expected = family.inputs().join(", ");
    let mut lines = Lines::new(input);
    let Some((hline, header)) = lines.next_nonblank()? else {
        return Err(EvalError::Empty { expected });
    };
    let columns: Vec<String> = fields(&header, hline)?.into_iter().map(str::to_string).collect();
    let mut slot = Vec::with_capacity(columns.len());
    for (i, c) in columns.iter().enumerate() {
        match family.inputs().iter().position(|n| n == c) {
            None => {
                return Err(EvalError::UnknownColumn {
                    line: hline,
                    column: c.clone(),
                    expected,
                })
            }
            Some(_) if columns[..i].contains(c) => {
                return Err(EvalError::DuplicateColumn {
                    line: hline,
                    column: c.clone(),
                })
            }
            Some(k) => slot.push(k),
        }
    }
    for name in family.inputs() {
        if !columns.iter().any(|c| c == name) {
            return Err(EvalError::MissingColumn {
                line: hline,
                column: name.to_string(),
                expected,
            });
        }
    }
    let mut spool = BufWriter::new(tempfile::SpooledTempFile::new(SPOOL_MEMORY));
    let head: Vec<&str> = columns
        .iter()
        .map(String::as_str)
        .chain(family.outputs().iter().copied())
        .collect();
    writeln!(spool, "{}", head.join(",")).map_err(EvalError::Output)?;
    let mut count = 0;
    let mut x = vec![0.0; family.inputs().len()];
    while let Some((line, l)) = lines.next_nonblank()? {
        let row = fields(&l, line)?;
        if row.len() != columns.len() {
            return Err(EvalError::Row {
                line,
                message: format!("{} fields, header has {}", row.len(), columns.len()),
            });
        }
        for (&text, (&k, name)) in row.iter().zip(slot.iter().zip(&columns)) {
            x[k] = number(text).map_err(|m| EvalError::Row {
                line,
                message: format!("column '{name}': {m}"),
            })?;
        }
        let y = match lookup {
            Some(l) => l.lookup(&x).map_err(|e| e.to_string()),
            None => family.exact(&x),
        }
        .map_err(|message| EvalError::Row { line, message })?;
        write_row(&mut spool, &row, &y).map_err(EvalError::Output)?;
        count += 1;
    }
    // Every row succeeded: only now does anything reach `output`.
    let mut spool = spool.into_inner().map_err(|e| EvalError::Output(e.into_error()))?;
    spool.rewind().map_err(EvalError::Output)?;
    std::io::copy(&mut spool, &mut output).map_err(EvalError::Output)?;
    output.flush().map_err(EvalError::Output)?;
    Ok(count)
}

/// One output row: the input fields as given, then the outputs in shortest
/// round-trip scientific form.
fn write_row(out: &mut impl Write, fields: &[&str], y: &[f64]) -> std::io::Result<()> {
    out.write_all(fields.join(",").as_bytes())?;
    for v in y {
        write!(out, ",{v:e}")?;
    }
    out.write_all(b"\n")
}

/// Physical lines of the input, read one at a time (BOM, CR and length handled).
struct Lines<R> {
    input: BufReader<R>,
    number: u64,
    buf: Vec<u8>,
}

impl<R: Read> Lines<R> {
    fn new(input: R) -> Self {
        Lines {
            input: BufReader::new(input),
            number: 0,
            buf: Vec::new(),
        }
    }

    /// The next line that is not blank, with its 1-based physical line number;
    /// `None` at the end of the input.
    fn next_nonblank(&mut self) -> Result<Option<(u64, String)>, EvalError> {
        loop {
            self.buf.clear();
            let n = (&mut self.input)
                .take(MAX_LINE_LEN + 1)
                .read_until(b'\n', &mut self.buf)?;
            if n == 0 {
                return Ok(None);
            }
            self.number += 1;
            let line = self.number;
            let mut bytes = &self.buf[..];
            if bytes.last() == Some(&b'\n') {
                bytes = &bytes[..bytes.len() - 1];
            } else if n as u64 > MAX_LINE_LEN {
                return Err(EvalError::Row {
                    line,
                    message: format!("line longer than {MAX_LINE_LEN} bytes"),
                });
            }
            let bytes = bytes.strip_suffix(b"\r").unwrap_or(bytes);
            let text = std::str::from_utf8(bytes).map_err(|_| EvalError::Row {
                line,
                message: "input is not UTF-8".into(),
            })?;
            let text = if line == 1 {
                text.strip_prefix('\u{feff}').unwrap_or(text)
            } else {
                text
            };
            if !text.trim().is_empty() {
                return Ok(Some((line, text.to_string())));
            }
        }
    }
}

/// Splits a line into trimmed fields; quoting is not part of the format.
fn fields(line: &str, n: u64) -> Result<Vec<&str>, EvalError> {
    if line.contains('"') {
        return Err(EvalError::Row {
            line: n,
            message: "quoted fields are not supported (plain numbers only)".into(),
        });
    }
    Ok(line.split(',').map(str::trim).collect())
}

/// Parses a number, naming overflow and underflow instead of passing on ±inf or 0.
fn number(text: &str) -> Result<f64, String> {
    if text.is_empty() {
        return Err("empty value".into());
    }
    let v: f64 = text.parse().map_err(|_| format!("'{text}' is not a number"))?;
    let lower = text.to_ascii_lowercase();
    let unsigned = lower.trim_start_matches(['+', '-']);
    if v.is_infinite() && !unsigned.starts_with("inf") {
        return Err(format!("'{text}' overflows f64"));
    }
    let mantissa = unsigned.split('e').next().unwrap_or("");
    if v == 0.0 && mantissa.chars().any(|c| ('1'..='9').contains(&c)) {
        return Err(format!("'{text}' underflows f64 to 0"));
    }
    Ok(v)
}

/// The columns of every family `lobefit eval` serves, shown by `lobefit eval --help`
/// (units and meaning; the definitions are in docs/math.md §2). A test checks that
/// every family's input and output column names appear here.
pub const COLUMNS: &str = "\
Input: a header line naming the input columns (any order), then one query per line,
comma-separated numbers. Output: a header line (the input columns, then the outputs
below), then one row per query, in order.
Nothing is printed unless every row succeeds. Angles in rad, solid angles in sr;
definitions in docs/math.md §2.

lobe-integral
  in   `e`        lobe exponent, [0, 1e5]
  out  `integral` ∫ max(a·v, 0)^e dω (sr) = 2π/(e + 1)
cap-exponent
  in   `alpha`    half-angle of a spherical cap (rad), [1e-3, π]
  out  `e_cap`    exponent of the cosine lobe closest (L2 over the sphere) to the
                  cap's indicator; 0 for alpha ≥ π/2
lobe-product  [--variant energy|l2]   (energy: the product's integral is kept);
lobe-product-l2: as --variant l2
  in   `e1`, `e2` exponents of the two lobes, [0, 1e5]
       `alpha`    angle between their axes (rad), [0, π]
  out  `p`        scale of the product lobe for unit-scale lobes (s1·s2·p in general)
       `t`        where its axis lies on the great arc from axis 1 to axis 2, as a
                  fraction of alpha (0 = axis 1, 1 = axis 2): the product's peak
       `e_r`      exponent of the product lobe
isg  [--model paper|refit|best] (default best); isg-refit, isg-best: that model
  in   `gamma`    SG sharpness, [0.5, 1e4]
       `theta`, `phi`  corner of the patch [0, theta] × [0, phi] (rad, each [0, π]):
                  theta from +y, phi the azimuth about +y from +x; SG axis +z
  out  `s_hat`    normalised integral S/S(π, π), in [0, 1]
       `s`        the integral S of exp(gamma (ω·z − 1)) over the patch (sr)
sg-fit
  in   `e`        lobe exponent, [0, 1e5]
  out  `lambda`   sharpness and `mu` amplitude of the spherical Gaussian
                  mu·exp(lambda (a·v − 1)) closest (L2) to the unit-scale lobe
log-zh  [--kind diffuse|phong|blocker] (default phong)  [--order N] (1..8, default 4)
  in   `eps`      clamp ε of the log, [0.01, 0.99]
       `r`        (phong) normalised Phong exponent, ≥ 1
       `theta_b`  (blocker) angular radius of a spherical blocker (rad)
  out  `z0` … `z7`  (the first N) zonal coefficients ∫ ln(max(f, ε)) y_l^0 dω of
                  the clamped function's log, axis +z
wedge  [--order N] (1..8, default 4)
  in   `sigma`    horizon elevation of a height-field slice (rad), [−π/2, π/2]
       `eps`      log-visibility value ε of blocked directions, [0.01, 0.99]
  out  `v0` … `v7`  (the first N) the slice's log-visibility vector v_l^log(σ)
wrap  [--order N] (1..8, default 4)
  in   `a`        wrap parameter, [0, 1]
  out  `l0` … `l7`  (the first N) λ̂_l(a): the wrap kernel's Funk–Hecke eigenvalue
                  per band, divided by π
disk-light
  in   `r_over_d` disk radius over the distance to its centre, > 0 (tabulated on
                  [0.01, 10])
       `tau`      angle between the disk's normal and the direction from the disk
                  to the receiver (rad), [0, π]; ≥ π/2 sees the back (zeros)
  out  `y00`, `y10`, `y11`, `y20`, `y21`, `y22`  the non-zero SH coefficients
                  ∫ y_lm dω over the disk (receiver at the origin, disk centre on +z,
                  normal in the xz-plane)
shexp  [--order N] (3..8, default 4)  [--log ren|naive] (default ren)
  in   `theta_b`  angular radius of a spherical-cap blocker about +z (rad), [0, π/2]
       `eps`      (naive) clamp ε of the projected log
  out  `f0` … `f7`  (the first N) the log-ZH vector f of the cap's visibility
       `norm`     ‖f̂‖, f without its DC term
       `a`, `b`   optimal-linear coefficients of exp*(f̂) ≈ a·1 + b·f̂
mask-weights
  in   `dist`     the visibility mask's 1/(2 tan α) for a light of half-angle α,
                  [0.25, 10]
  out  weights w_l (level l = 1..D) of eq. 39 for masks of maximal depth D,
       fitted (`fit_`) or by the paper's procedure (`paper_`), aggressive (`agg`)
       or conservative (`con`):
       `fit_agg_d1_w1` `fit_agg_d2_w1` `fit_agg_d2_w2` `fit_agg_d3_w1` `fit_agg_d3_w2`
       `fit_agg_d3_w3` `fit_agg_d4_w1` `fit_agg_d4_w2` `fit_agg_d4_w3` `fit_agg_d4_w4`
       `fit_agg_d5_w1` `fit_agg_d5_w2` `fit_agg_d5_w3` `fit_agg_d5_w4` `fit_agg_d5_w5`
       `fit_con_d1_w1` `fit_con_d2_w1` `fit_con_d2_w2` `fit_con_d3_w1` `fit_con_d3_w2`
       `fit_con_d3_w3` `fit_con_d4_w1` `fit_con_d4_w2` `fit_con_d4_w3` `fit_con_d4_w4`
       `fit_con_d5_w1` `fit_con_d5_w2` `fit_con_d5_w3` `fit_con_d5_w4` `fit_con_d5_w5`
       `paper_agg_d1_w1` `paper_agg_d2_w1` `paper_agg_d2_w2` `paper_agg_d3_w1` `paper_agg_d3_w2`
       `paper_agg_d3_w3` `paper_agg_d4_w1` `paper_agg_d4_w2` `paper_agg_d4_w3` `paper_agg_d4_w4`
       `paper_agg_d5_w1` `paper_agg_d5_w2` `paper_agg_d5_w3` `paper_agg_d5_w4` `paper_agg_d5_w5`
       `paper_con_d1_w1` `paper_con_d2_w1` `paper_con_d2_w2` `paper_con_d3_w1` `paper_con_d3_w2`
       `paper_con_d3_w3` `paper_con_d4_w1` `paper_con_d4_w2` `paper_con_d4_w3` `paper_con_d4_w4`
       `paper_con_d5_w1` `paper_con_d5_w2` `paper_con_d5_w3` `paper_con_d5_w4` `paper_con_d5_w5`
direct-light  [--depth N] (1..5, default 5)  [--mask aggressive|conservative]
              [--weights fitted|paper|one]   (reads the mask-weights table)
  in   `px`, `py`, `pz`  shading point;  `nx`, `ny`, `nz`  its unit normal
       `lx`, `ly`, `lz`, `lr`  centre and radius of a spherical light of radiance 1
       `bx`, `by`, `bz`, `br`  centre and radius of a spherical blocker (br = 0: none)
  out  `irradiance`  ∫ L V max(n·ω, 0) dω through the lobe pipeline (docs/meunier.md);
                  --exact: by quadrature with exact ray–sphere visibility
";
