//! Keys that depend on a table's type: each type's keys are one serde
//! struct (`deny_unknown_fields`), deserialised from the table's remaining
//! keys once its `type` is known, so every key is stated once, with its
//! type. Errors name the failing key (`serde_path_to_error`).

use super::Builder;
use crate::error::Result;
use serde::de::DeserializeOwned;

/// The keys of the struct `T` deserialises, as serde's derive lists them:
/// the one statement of a type's keys also names them in errors.
pub(super) fn key_names<T: serde::de::DeserializeOwned>() -> &'static [&'static str] {
    use serde::de::{Deserializer, Visitor};
    /// A deserialiser that only records the fields a struct asks for.
    struct Fields;
    #[derive(Debug)]
    struct Found(&'static [&'static str]);
    impl std::fmt::Display for Found {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("fields")
        }
    }
    impl std::error::Error for Found {}
    impl serde::de::Error for Found {
        fn custom<M: std::fmt::Display>(_: M) -> Self {
            Found(&[])
        }
    }
    impl<'de> Deserializer<'de> for Fields {
        type Error = Found;
        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> std::result::Result<V::Value, Found> {
            Err(Found(&[]))
        }
        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _: &'static str,
            fields: &'static [&'static str],
            _: V,
        ) -> std::result::Result<V::Value, Found> {
            Err(Found(fields))
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
            bytes byte_buf option unit unit_struct newtype_struct seq tuple
            tuple_struct map enum identifier ignored_any
        }
    }
    match T::deserialize(Fields) {
        Err(Found(fields)) => fields,
        Ok(_) => &[],
    }
}

impl Builder<'_> {
    /// The keys `keys` of the table at `field` as the struct `T`. A key `T`
    /// does not have is an error at `field.key` with the message
    /// `unknown(key)`; a value of the wrong kind an error at its key.
    pub(super) fn typed_keys<T: DeserializeOwned>(
        &self,
        field: &str,
        keys: &toml::Table,
        unknown: impl Fn(&str) -> String,
    ) -> Result<T> {
        serde_path_to_error::deserialize(toml::Value::Table(keys.clone())).map_err(|e| {
            let path = e.path().to_string();
            let message = e.into_inner().to_string();
            // The first line is serde's message; toml adds the key's name below.
            let message = message.lines().next().unwrap_or("");
            // Where the TOML text has the key, the error gives its line, as
            // the parser's own errors do.
            let at = |field: &str, value: bool| {
                self.toml
                    .and_then(|t| super::position_of(t, field, value))
                    .map(|(l, c)| format!("line {l}, column {c}: "))
                    .unwrap_or_default()
            };
            if let Some(rest) = message.strip_prefix("unknown field `") {
                let key = rest.split('`').next().unwrap_or("");
                let field = format!("{field}.{key}");
                let at = at(&field, false);
                return self.err(field, format!("{at}{}", unknown(key)));
            }
            let what = if message.contains("expected an array of length 3") {
                format!("must be an RGB triple [r, g, b] ({message})")
            } else if message.contains("expected f32") {
                format!("must be a number ({message})")
            } else {
                message.to_string()
            };
            let field = if path.is_empty() || path == "." {
                field.to_string()
            } else {
                format!("{field}.{path}")
            };
            let at = at(&field, true);
            self.err(field, format!("{at}{what}"))
        })
    }
}
