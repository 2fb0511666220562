//! JSON read by haze (scene files, sidecars, fogmap sidecars, asset headers) is refused
//! when an object repeats a key: `serde_json` would keep the last value silently, so a
//! file with two `sigma_t` in one medium would render something its author did not
//! write.

use serde::de::{self, Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use std::collections::HashSet;
use std::fmt;

/// Checks that no object in `text` repeats a key. The error names the key and, through
/// `serde_json`, its line and column: `duplicate key "sigma_t" at line 4 column 21`.
/// Malformed JSON is left to the caller's own parse (this returns its error too).
pub fn unique_keys(text: &str) -> Result<(), serde_json::Error> {
    serde_json::from_str::<UniqueKeys>(text).map(|_| ())
}

/// A JSON value walked for its keys only.
struct UniqueKeys;

impl<'de> Deserialize<'de> for UniqueKeys {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(KeysVisitor)
    }
}

struct KeysVisitor;

impl<'de> Visitor<'de> for KeysVisitor {
    type Value = UniqueKeys;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a JSON value")
    }

    fn visit_bool<E>(self, _: bool) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_i64<E>(self, _: i64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_u64<E>(self, _: u64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_f64<E>(self, _: f64) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_str<E>(self, _: &str) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }
    fn visit_unit<E>(self) -> Result<UniqueKeys, E> {
        Ok(UniqueKeys)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<UniqueKeys, A::Error> {
        while seq.next_element::<UniqueKeys>()?.is_some() {}
        Ok(UniqueKeys)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<UniqueKeys, A::Error> {
        let mut seen = HashSet::new();
        while let Some(key) = map.next_key::<String>()? {
            if !seen.insert(key.clone()) {
                return Err(de::Error::custom(format!("duplicate key \"{key}\"")));
            }
            map.next_value::<UniqueKeys>()?;
        }
        Ok(UniqueKeys)
    }
}

#[cfg(test)]
mod tests {
    use super::unique_keys;

    #[test]
    fn a_repeated_key_is_named_at_any_depth_and_distinct_keys_pass() {
        assert!(unique_keys(r#"{"a": 1, "b": [1, {"a": 2}], "c": {"a": null}}"#).is_ok());
        let e = unique_keys("{\"media\": [{\"sigma_t\": 1,\n \"sigma_t\": 2}]}").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("duplicate key \"sigma_t\" at line 2"),
            "{e}"
        );
        let e = unique_keys(r#"{"camera": {}, "camera": {}}"#).unwrap_err();
        assert!(e.to_string().contains("\"camera\""), "{e}");
        // The same key in two sibling objects is not a repeat.
        assert!(unique_keys(r#"[{"x": 1}, {"x": 2}]"#).is_ok());
        assert!(unique_keys("{").is_err());
    }
}
