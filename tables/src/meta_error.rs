//! Names the metadata field that failed to decode. postcard reports only what went
//! wrong ("Serde Deserialization Error" for an unknown enum variant), never where,
//! so after a failed decode the record is walked again field by field, in the
//! order `docs/format.md` lists them.

use serde::de::DeserializeOwned;

use crate::format::{Encoding, EntryDiagnostics, Mapping, Placement, Storage, Threshold};

/// Why `meta` (which failed to decode as a whole with `error`) does not decode:
/// the first failing field's path (`axes[1].mapping`) and the cause.
pub(crate) fn explain(meta: &[u8], error: &postcard::Error) -> String {
    let mut w = Walk { rest: meta };
    match w.meta() {
        Err(m) => m,
        // Not expected (the walk decodes what the whole decode does); keep postcard's word.
        Ok(()) => error.to_string(),
    }
}

/// Enum variant names in discriminant order (postcard writes the index as a varint).
const STORAGE: &[&str] = &["F32"];
const MAPPING: &[&str] = &["Linear", "Log", "Log1p", "Logit", "Asinh"];
const PLACEMENT: &[&str] = &["Endpoints", "Centres"];
const ENCODING: &[&str] = &["Linear", "Log"];

/// A cursor over the metadata bytes.
struct Walk<'a> {
    rest: &'a [u8],
}

impl Walk<'_> {
    fn meta(&mut self) -> Result<(), String> {
        self.field::<String>("kind")?;
        self.field::<u32>("table_version")?;
        self.field::<String>("generator")?;
        self.field::<String>("description")?;
        for i in 0..self.len("axes")? {
            let p = |f: &str| format!("axes[{i}].{f}");
            self.field::<String>(&p("name"))?;
            self.field::<String>(&p("unit"))?;
            self.field::<f64>(&p("lo"))?;
            self.field::<f64>(&p("hi"))?;
            self.variant::<Mapping>(&p("mapping"), MAPPING)?;
            self.field::<u32>(&p("count"))?;
            self.variant::<Placement>(&p("placement"), PLACEMENT)?;
        }
        for i in 0..self.len("channels")? {
            let p = |f: &str| format!("channels[{i}].{f}");
            self.field::<String>(&p("name"))?;
            self.field::<String>(&p("unit"))?;
            self.variant::<Encoding>(&p("encoding"), ENCODING)?;
            self.field::<String>(&p("description"))?;
        }
        self.variant::<Storage>("storage", STORAGE)?;
        self.field::<String>("fit.method")?;
        self.peek_len("fit.settings")?;
        self.field::<Vec<(String, String)>>("fit.settings")?;
        self.field::<u64>("fit.settings_hash")?;
        self.field::<String>("diagnostics.residual_meaning")?;
        self.field::<u64>("diagnostics.entries")?;
        self.field::<u64>("diagnostics.converged")?;
        self.field::<f64>("diagnostics.max_residual")?;
        self.field::<f64>("diagnostics.mean_residual")?;
        self.field::<u32>("diagnostics.max_iterations")?;
        self.field::<Option<EntryDiagnostics>>("diagnostics.per_entry")?;
        self.peek_len("thresholds")?;
        self.field::<Vec<Threshold>>("thresholds")?;
        Ok(())
    }

    /// Decodes one `T` at `path`.
    fn field<T: DeserializeOwned>(&mut self, path: &str) -> Result<T, String> {
        match postcard::take_from_bytes::<T>(self.rest) {
            Ok((v, rest)) => {
                self.rest = rest;
                Ok(v)
            }
            Err(e) => Err(format!("field '{path}': {e}")),
        }
    }

    /// Decodes a sequence length at `path` and steps over it.
    fn len(&mut self, path: &str) -> Result<usize, String> {
        let n = self.peek_len(path)?;
        self.field::<usize>(path)?;
        Ok(n)
    }

    /// Reads the sequence length at `path` without stepping over it. Every element
    /// takes at least one byte, so a length beyond the remaining bytes is corrupt.
    fn peek_len(&self, path: &str) -> Result<usize, String> {
        let (n, rest) = postcard::take_from_bytes::<usize>(self.rest).map_err(|e| format!("field '{path}': {e}"))?;
        if n > rest.len() {
            return Err(format!(
                "field '{path}': {n} entries, but only {} bytes of metadata remain",
                rest.len()
            ));
        }
        Ok(n)
    }

    /// Decodes an enum at `path`, naming an unknown discriminant.
    fn variant<T: DeserializeOwned>(&mut self, path: &str, names: &[&str]) -> Result<T, String> {
        let (index, _) = postcard::take_from_bytes::<u32>(self.rest).map_err(|e| format!("field '{path}': {e}"))?;
        if index as usize >= names.len() {
            let known: Vec<String> = names.iter().enumerate().map(|(i, n)| format!("{i} = {n}")).collect();
            return Err(format!(
                "field '{path}': unknown variant {index} (this reader knows {})",
                known.join(", ")
            ));
        }
        self.field(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The variant lists match the enums: every listed index decodes, the next does not.
    #[test]
    fn variant_lists_match_the_enums() {
        fn check<T: DeserializeOwned>(names: &[&str]) {
            let bytes = |i: usize| [&[i as u8][..], &[0u8; 16]].concat();
            for i in 0..names.len() {
                assert!(postcard::take_from_bytes::<T>(&bytes(i)).is_ok(), "{names:?}[{i}]");
            }
            assert!(
                postcard::take_from_bytes::<T>(&bytes(names.len())).is_err(),
                "{names:?}"
            );
        }
        check::<Storage>(STORAGE);
        check::<Mapping>(MAPPING);
        check::<Placement>(PLACEMENT);
        check::<Encoding>(ENCODING);
    }
}
