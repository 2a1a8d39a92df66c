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
    #[error("line 1: unknown column '{column}' (expected columns: {expected})")]
    UnknownColumn { column: String, expected: String },
    /// A header column appears twice.
    #[error("line 1: duplicate column '{column}'")]
    DuplicateColumn { column: String },
    /// A required input column is missing.
    #[error("line 1: missing column '{column}' (expected columns: {expected})")]
    MissingColumn { column: String, expected: String },
    /// A data row is malformed or outside the domain.
    #[error("line {line}: {message}")]
    Row { line: u64, message: String },
    /// Writing the output failed.
    #[error("cannot write output: {0}")]
    Io(#[from] std::io::Error),
}

/// Evaluates every row of `input` (CSV with a header of input columns) through
/// `lookup` (the runtime) or, with `exact`, the family's exact path, and writes the
/// input columns followed by the output columns to `output`. Returns the row count.
pub fn eval_csv(
    family: &dyn Family,
    lookup: Option<&dyn Lookup>,
    input: impl Read,
    mut output: impl Write,
) -> Result<usize, EvalError> {
    let expected = family.inputs().join(", ");
    let mut rdr = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .flexible(true)
        .from_reader(input);
    let mut records = rdr.records();
    let header = match records.next() {
        None => return Err(EvalError::Empty { expected }),
        Some(Err(e)) => {
            return Err(EvalError::Row {
                line: 1,
                message: e.to_string(),
            })
        }
        Some(Ok(h)) => h,
    };
    let columns: Vec<String> = header.iter().map(str::to_string).collect();
    let mut slot = Vec::with_capacity(columns.len());
    for (i, c) in columns.iter().enumerate() {
        match family.inputs().iter().position(|n| n == c) {
            None => {
                return Err(EvalError::UnknownColumn {
                    column: c.clone(),
                    expected,
                })
            }
            Some(_) if columns[..i].contains(c) => return Err(EvalError::DuplicateColumn { column: c.clone() }),
            Some(k) => slot.push(k),
        }
    }
    for name in family.inputs() {
        if !columns.iter().any(|c| c == name) {
            return Err(EvalError::MissingColumn {
                column: name.to_string(),
                expected,
            });
        }
    }
    let mut rows: Vec<(Vec<String>, Vec<f64>)> = Vec::new();
    for rec in records {
        let rec = rec.map_err(|e| EvalError::Row {
            line: e.position().map(|p| p.line()).unwrap_or(0),
            message: e.to_string(),
        })?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        if rec.len() == 1 && rec.get(0) == Some("") {
            continue; // blank line
        }
        if rec.len() != columns.len() {
            return Err(EvalError::Row {
                line,
                message: format!("{} fields, header has {}", rec.len(), columns.len()),
            });
        }
        let mut x = vec![0.0; family.inputs().len()];
        for (field, (&k, name)) in rec.iter().zip(slot.iter().zip(&columns)) {
            x[k] = field.parse::<f64>().map_err(|_| EvalError::Row {
                line,
                message: format!("column '{name}': '{field}' is not a number"),
            })?;
        }
        let y = match lookup {
            Some(l) => l.lookup(&x).map_err(|e| e.to_string()),
            None => family.exact(&x),
        }
        .map_err(|message| EvalError::Row { line, message })?;
        rows.push((rec.iter().map(str::to_string).collect(), y));
    }
    let mut buf = String::new();
    let head: Vec<&str> = columns
        .iter()
        .map(String::as_str)
        .chain(family.outputs().iter().copied())
        .collect();
    buf.push_str(&head.join(","));
    buf.push('\n');
    for (fields, y) in &rows {
        let mut line: Vec<String> = fields.clone();
        line.extend(y.iter().map(|v| format!("{v:e}")));
        buf.push_str(&line.join(","));
        buf.push('\n');
    }
    output.write_all(buf.as_bytes())?;
    output.flush()?;
    Ok(rows.len())
}
