//! JSON read strictly: a key given twice in one object is an error naming it and
//! where it is. serde_json keeps the last of two equal keys, another reader may keep
//! the first, so a file with both says two things (a manifest promising `f16` and
//! `f32`); lobefit refuses it rather than pick one.

use serde::de::{DeserializeOwned, DeserializeSeed, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};

/// `text` parsed as `T` after [`check_keys`].
pub fn from_str<T: DeserializeOwned>(text: &str) -> Result<T, String> {
    check_keys(text)?;
    serde_json::from_str(text).map_err(|e| e.to_string())
}

/// [`from_str`] into a `serde_json::Value`.
pub fn value(text: &str) -> Result<serde_json::Value, String> {
    from_str(text)
}

/// An error when an object of `text` holds a key twice (or `text` is not JSON): the
/// key, its object's path (`$.families[0]`) and serde_json's line and column.
pub fn check_keys(text: &str) -> Result<(), String> {
    let mut de = serde_json::Deserializer::from_str(text);
    Keys("$".into()).deserialize(&mut de).map_err(|e| e.to_string())?;
    de.end().map_err(|e| e.to_string())
}

/// A value at a JSON path, visited for its keys.
struct Keys(String);

impl<'de> DeserializeSeed<'de> for Keys {
    type Value = ();
    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<'de> Visitor<'de> for Keys {
    type Value = ();
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<(), E> {
        Ok(())
    }
    fn visit_i64<E>(self, _: i64) -> Result<(), E> {
        Ok(())
    }
    fn visit_u64<E>(self, _: u64) -> Result<(), E> {
        Ok(())
    }
    fn visit_f64<E>(self, _: f64) -> Result<(), E> {
        Ok(())
    }
    fn visit_str<E>(self, _: &str) -> Result<(), E> {
        Ok(())
    }
    fn visit_unit<E>(self) -> Result<(), E> {
        Ok(())
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let mut i = 0usize;
        while seq.next_element_seed(Keys(format!("{}[{i}]", self.0)))?.is_some() {
            i += 1;
        }
        Ok(())
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let mut seen = std::collections::HashSet::new();
        while let Some(k) = map.next_key::<String>()? {
            let path = format!("{}.{k}", self.0);
            if !seen.insert(k) {
                return Err(A::Error::custom(format!(
                    "{path} is given twice (a key appears once in an object)"
                )));
            }
            map.next_value_seed(Keys(path))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A repeated key is refused at any depth, named with its path; the same key in
    /// two objects, nesting, escapes and every value type pass.
    #[test]
    fn repeated_keys_are_refused_where_they_are() {
        for ok in [
            r#"{"a": 1, "b": [{"a": 2}, {"a": 3}], "c": {"a": null, "b": true, "c": "x\"y"}}"#,
            "[]",
            "1.5e300",
        ] {
            check_keys(ok).unwrap();
        }
        for (bad, want) in [
            (r#"{"storage": "f16", "storage": "f32"}"#, "$.storage is given twice"),
            (r#"{"f": [{"x": 1}, {"x": 1, "x": 2}]}"#, "$.f[1].x is given twice"),
            (r#"{"a": {"b": {"c": 1, "c": 1}}}"#, "$.a.b.c is given twice"),
            (r#"{"\u0061": 1, "a": 2}"#, "$.a is given twice"),
        ] {
            let e = check_keys(bad).unwrap_err();
            assert!(e.contains(want), "{bad}: {e}");
        }
        assert!(check_keys(r#"{"a": 1} x"#).is_err());
        assert!(check_keys(r#"{"a": "#).is_err());
    }
}
