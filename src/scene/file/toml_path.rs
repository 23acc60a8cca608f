//! Field paths (`shapes[2].transform.scale`) of TOML error positions: the
//! tables and keys above a byte offset of the text.

use std::collections::HashMap;

/// The table name of a TOML header line (`[a.b]` or `[[a]]`), with whether
/// it is an array-of-tables header; `None` for any other line (including the
/// rows of a multi-line array such as `[1, 0, 0, 0],`).
fn table_header(line: &str) -> Option<(String, bool)> {
    let l = line.split('#').next().unwrap_or("").trim();
    let (inner, array) = if let Some(r) = l.strip_prefix("[[") {
        (r.strip_suffix("]]")?, true)
    } else {
        (l.strip_prefix('[')?.strip_suffix(']')?, false)
    };
    let inner = inner.trim();
    let valid = inner
        .chars()
        .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | '"' | ' '));
    let starts_well = inner
        .chars()
        .next()
        .is_some_and(|c| c.is_alphabetic() || c == '_' || c == '"');
    (valid && starts_well).then(|| (inner.replace(' ', ""), array))
}

/// Best-effort dotted path (`shapes[2].transform.scale`) of the key at byte
/// `offset` of a TOML text, from the table headers up to its line and the
/// key on that line; empty when it cannot tell.
pub(super) fn field_at(text: &str, offset: usize) -> String {
    let offset = offset.min(text.len());
    let line_start = text[..offset].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[line_start..]
        .find('\n')
        .map_or(text.len(), |i| line_start + i);
    let mut table = String::new();
    let mut arrays: HashMap<String, usize> = HashMap::new();
    // Headers up to and including the error's line (a missing key is
    // reported at its table's header).
    for l in text[..line_end].lines() {
        let Some((name, array)) = table_header(l) else {
            continue;
        };
        if array {
            let n = arrays.entry(name.clone()).or_insert(0);
            table = format!("{name}[{n}]");
            *n += 1;
        } else {
            // `[shapes.transform]` after `[[shapes]]` is in the last shape.
            let (head, rest) = name.split_once('.').unwrap_or((&name, ""));
            table = match arrays.get(head) {
                Some(&n) if n > 0 && !rest.is_empty() => format!("{head}[{}].{rest}", n - 1),
                _ => name.clone(),
            };
        }
    }
    let line = &text[line_start..line_end];
    let key = if table_header(line).is_some() {
        ""
    } else {
        line.split_once('=')
            .map(|(k, _)| k.trim())
            .filter(|k| {
                !k.is_empty()
                    && k.chars()
                        .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | '"'))
            })
            .unwrap_or("")
    };
    match (table.is_empty(), key.is_empty()) {
        (_, true) => table,
        (true, false) => key.to_string(),
        (false, false) => format!("{table}.{key}"),
    }
}

/// Line and column (1-based) of the key at dotted path `path` in a TOML
/// text (`shapes[0].radius`): of the key itself, or with `value` of its
/// value. `None` where the key is not on a line of its own table (inline
/// tables, dotted keys).
pub(super) fn position_of(text: &str, path: &str, value: bool) -> Option<(usize, usize)> {
    let mut offset = 0;
    for (n, line) in text.split('\n').enumerate() {
        let indent = line.len() - line.trim_start().len();
        if !line.trim().is_empty() && field_at(text, offset + indent) == path {
            let column = if value {
                let eq = line.find('=')?;
                eq + 1 + (line[eq + 1..].len() - line[eq + 1..].trim_start().len())
            } else {
                indent
            };
            return Some((n + 1, column + 1));
        }
        offset += line.len() + 1;
    }
    None
}

#[cfg(test)]
mod field_tests {
    use super::{field_at, position_of};

    fn at(text: &str, needle: &str) -> String {
        field_at(text, text.find(needle).unwrap())
    }

    #[test]
    fn positions_of_keys() {
        let t = "[camera]\nup = 1\n\n[[shapes]]\ntype = 1\n\n[[shapes]]\n  radius =  2\n";
        assert_eq!(position_of(t, "shapes[1].radius", false), Some((8, 3)));
        assert_eq!(position_of(t, "shapes[1].radius", true), Some((8, 13)));
        assert_eq!(position_of(t, "shapes[0].radius", true), None);
        assert_eq!(position_of(t, "camera.up", true), Some((2, 6)));
    }

    #[test]
    fn field_paths_follow_tables_and_arrays() {
        let t = "[render]\nspp = 1\n\n[camera]\nup = 1\n\n[[shapes]]\ntype = 1\n\n[[shapes]]\nmatrix = [\n  [1, 0, 0, 0],\n  [0, 1, x, 0],\n]\n[shapes.transform]\nscale = 2\n";
        assert_eq!(at(t, "spp"), "render.spp");
        assert_eq!(at(t, "up"), "camera.up");
        assert_eq!(at(t, "[camera]"), "camera");
        assert_eq!(at(t, "type"), "shapes[0].type");
        assert_eq!(at(t, "x,"), "shapes[1]");
        assert_eq!(at(t, "scale"), "shapes[1].transform.scale");
    }
}
