//! `lobefit eval`: CSV in, CSV out (SPEC §6). All rows are validated and computed
//! before anything is written, so a bad row never leaves half an output behind.

use std::io::{Read, Write};

use crate::family::{Family, Lookup};

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
    /// Reading the input or writing the output failed.
    #[error("i/o error: {0}")]
    Io(#[from] std::io::Error),
}

/// Evaluates every row of `input` (CSV with a header of input columns) through
/// `lookup` (the runtime) or, when `lookup` is `None`, the family's exact path, and
/// writes the input columns followed by the output columns to `output`. Returns the
/// row count.
///
/// The accepted CSV is the plain numeric kind SPEC §6 describes: comma-separated,
/// optional UTF-8 BOM, LF or CRLF line ends, spaces around fields ignored, blank lines
/// skipped, no quoting. Line numbers in errors are physical lines of the input.
pub fn eval_csv(
    family: &dyn Family,
    lookup: Option<&dyn Lookup>,
    mut input: impl Read,
    mut output: impl Write,
) -> Result<usize, EvalError> {
    let expected = family.inputs().join(", ");
    let mut raw = Vec::new();
    input.read_to_end(&mut raw)?;
    let text = String::from_utf8(raw).map_err(|e| EvalError::Row {
        line: 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count() as u64,
        message: "input is not UTF-8".into(),
    })?;
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    let mut lines = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i as u64 + 1, l.strip_suffix('\r').unwrap_or(l)))
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((hline, header)) = lines.next() else {
        return Err(EvalError::Empty { expected });
    };
    let columns = fields(header, hline)?;
    let mut slot = Vec::with_capacity(columns.len());
    for (i, &c) in columns.iter().enumerate() {
        match family.inputs().iter().position(|n| *n == c) {
            None => {
                return Err(EvalError::UnknownColumn {
                    line: hline,
                    column: c.to_string(),
                    expected,
                })
            }
            Some(_) if columns[..i].contains(&c) => {
                return Err(EvalError::DuplicateColumn {
                    line: hline,
                    column: c.to_string(),
                })
            }
            Some(k) => slot.push(k),
        }
    }
    for name in family.inputs() {
        if !columns.contains(name) {
            return Err(EvalError::MissingColumn {
                line: hline,
                column: name.to_string(),
                expected,
            });
        }
    }
    let mut rows: Vec<(Vec<&str>, Vec<f64>)> = Vec::new();
    for (line, l) in lines {
        let row = fields(l, line)?;
        if row.len() != columns.len() {
            return Err(EvalError::Row {
                line,
                message: format!("{} fields, header has {}", row.len(), columns.len()),
            });
        }
        let mut x = vec![0.0; family.inputs().len()];
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
        rows.push((row, y));
    }
    let mut buf = String::new();
    let head: Vec<&str> = columns
        .iter()
        .copied()
        .chain(family.outputs().iter().copied())
        .collect();
    buf.push_str(&head.join(","));
    buf.push('\n');
    for (fields, y) in &rows {
        let mut line: Vec<String> = fields.iter().map(|f| f.to_string()).collect();
        line.extend(y.iter().map(|v| format!("{v:e}")));
        buf.push_str(&line.join(","));
        buf.push('\n');
    }
    output.write_all(buf.as_bytes())?;
    output.flush()?;
    Ok(rows.len())
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
