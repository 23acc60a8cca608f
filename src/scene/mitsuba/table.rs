//! The TOML the translation writes: tables whose keys keep the order they
//! were set in, and the values they hold.

use glam::{DVec3, DVec4};
use toml::Value;

/// A TOML table that keeps its keys in the order they were set (so that
/// the translation reads like a hand-written scene: `type` first).
#[derive(Debug, Clone, Default)]
pub(super) struct Table(pub Vec<(String, Value)>);

impl Table {
    pub fn new() -> Table {
        Table::default()
    }

    /// Sets `key` (replacing its value if it is set already).
    pub fn insert(&mut self, key: impl Into<String>, value: Value) {
        let key = key.into();
        match self.0.iter_mut().find(|(k, _)| *k == key) {
            Some((_, v)) => *v = value,
            None => self.0.push((key, value)),
        }
    }

    pub fn get(&self, key: &str) -> Option<&Value> {
        self.0.iter().find(|(k, _)| k == key).map(|(_, v)| v)
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The table's `key = value` lines (keys are bare; nested arrays one
    /// row per line).
    pub fn write(&self, out: &mut String) {
        for (k, v) in &self.0 {
            match v {
                Value::Array(rows) if rows.iter().all(|r| r.is_array()) && !rows.is_empty() => {
                    out.push_str(&format!("{k} = [\n"));
                    for r in rows {
                        out.push_str(&format!("    {r},\n"));
                    }
                    out.push_str("]\n");
                }
                v => out.push_str(&format!("{k} = {v}\n")),
            }
        }
    }
}

/// Sets `t[k] = v`.
pub(super) fn set(t: &mut Table, k: &str, v: Value) {
    t.insert(k, v);
}

pub(super) fn float(v: f64) -> Value {
    Value::Float(v)
}

pub(super) fn string(v: impl Into<String>) -> Value {
    Value::String(v.into())
}

pub(super) fn vec3(v: [f64; 3]) -> Value {
    Value::Array(v.iter().map(|&x| float(x)).collect())
}

pub(super) fn dvec(v: DVec3) -> Value {
    vec3(v.to_array())
}

pub(super) fn vec3_row(r: DVec4) -> Value {
    Value::Array(r.to_array().iter().map(|&x| float(x)).collect())
}
