//! `lobefit eval`: CSV in, CSV out. Every row is validated and computed
//! before anything is written, so a bad row never leaves half an output behind. The
//! input is read a line at a time and the output spooled (in memory up to
//! [`SPOOL_MEMORY`], then in an anonymous temporary file), so memory stays bounded
//! whatever the row count.

use std::io::{BufRead, BufReader, BufWriter, Read, Seek, Write};

use crate::family::{Lookup, View};

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
    family: &dyn View,
    lookup: Option<&dyn Lookup>,
    input: impl Read,
    mut output: impl Write,
) -> Result<Evaluated, EvalError> {
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
    let mut caveats: Vec<Caveat> = Vec::new();
    let mut notes: Vec<(u64, String)> = Vec::new();
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
            None => family.exact_noted(&x).map(|(y, note)| {
                notes.extend(note.map(|n| (line, n)));
                y
            }),
        }
        .map_err(|message| EvalError::Row { line, message })?;
        write_row(&mut spool, &row, &y).map_err(EvalError::Output)?;
        if lookup.is_some() {
            if let Some(what) = family.caveat(&x) {
                match caveats.iter_mut().find(|c| c.what == what) {
                    Some(c) => c.rows += 1,
                    None => caveats.push(Caveat {
                        what,
                        first_line: line,
                        rows: 1,
                    }),
                }
            }
        }
        count += 1;
    }
    // Every row succeeded: only now does anything reach `output`.
    let mut spool = spool.into_inner().map_err(|e| EvalError::Output(e.into_error()))?;
    spool.rewind().map_err(EvalError::Output)?;
    std::io::copy(&mut spool, &mut output).map_err(EvalError::Output)?;
    output.flush().map_err(EvalError::Output)?;
    Ok(Evaluated {
        rows: count,
        caveats,
        notes,
    })
}

/// What [`eval_csv`] did: rows written, and the caveats of rows where the family's
/// answer is known to be less accurate ([`View::caveat`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Evaluated {
    /// Rows evaluated.
    pub rows: usize,
    /// One entry per distinct caveat.
    pub caveats: Vec<Caveat>,
    /// `--exact`'s notes on single rows ([`View::exact_noted`]): (line, note).
    pub notes: Vec<(u64, String)>,
}

/// Rows sharing one caveat.
#[derive(Debug, Clone, PartialEq)]
pub struct Caveat {
    /// The caveat.
    pub what: &'static str,
    /// Line of the first such row.
    pub first_line: u64,
    /// How many rows.
    pub rows: usize,
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

/// The start of `lobefit eval --help` (the families' and pipelines' paragraphs follow:
/// `crate::catalog::eval_help`).
pub const HELP_HEADER: &str = "\
Input: a header line naming the input columns (any order), then one query per line,
comma-separated numbers. Output: a header line (the input columns, then the outputs
below), then one row per query, in order.
Nothing is printed unless every row succeeds. Angles in rad, solid angles in sr;
definitions in docs/math.md §2.

";
