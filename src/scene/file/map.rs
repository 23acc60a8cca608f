//! A material's `*_map` key: an image file's name, or a table that says
//! where the texels come from (an image `file`, a `checkerboard`, or for a
//! base colour the mesh's own colours, `attribute`) and how they are looked
//! up (`filter`, `wrap`, `encoding`, `to_uv`).
//!
//! ```toml
//! base_color_map = "wood.jpg"
//! base_color_map = { file = "wood.jpg", filter = "nearest", wrap = "mirror" }
//! base_color_map = { checkerboard = [[0.2, 0.2, 0.2], [0.4, 0.4, 0.4]], to_uv = [[8, 0, 0], [0, 8, 0]] }
//! roughness_map = { file = "rough.png", encoding = "srgb" }
//! base_color_map = { attribute = "vertex_color" }
//! ```

use crate::texture::{Encoding, Filter, Sampling, Wrap};
use serde::de::Error as _;
use serde::{Deserialize, Deserializer};
use std::path::{Path, PathBuf};

/// Where a map's texels come from.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum MapSource {
    /// An image file (relative to the scene file's folder once rebased).
    File(PathBuf),
    /// Mitsuba's checkerboard of two colours (linear RGB).
    Checkerboard([[f32; 3]; 2]),
    /// Colours the shape's mesh file stores, by name (`vertex_color`,
    /// `face_color`, …; Mitsuba's `mesh_attribute`).
    Attribute(String),
}

/// A `*_map` key as the scene file gives it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct MapKey {
    pub source: MapSource,
    /// `filter`: `"bilinear"` (default for files) or `"nearest"`.
    pub filter: Option<Filter>,
    /// `wrap`: `"repeat"` (default), `"mirror"` or `"clamp"`, or a pair of
    /// them (along `u`, along `v`).
    pub wrap: Option<[Wrap; 2]>,
    /// `encoding`: `"srgb"` or `"linear"` (default: sRGB for colour maps,
    /// linear for data maps; floating-point images are always linear).
    pub encoding: Option<Encoding>,
    /// `to_uv`: `[[a, b, c], [d, e, f]]`, the lookup at
    /// `(a·u + b·v + c, d·u + e·v + f)`.
    pub to_uv: Option<[[f32; 3]; 2]>,
}

impl MapKey {
    /// A plain image file, looked up the default way.
    pub fn file(path: PathBuf) -> MapKey {
        MapKey {
            source: MapSource::File(path),
            filter: None,
            wrap: None,
            encoding: None,
            to_uv: None,
        }
    }

    /// The key with a relative file name taken from `base`.
    pub fn rebased(mut self, base: &Path) -> MapKey {
        if let MapSource::File(p) = &self.source {
            self.source = MapSource::File(base.join(p));
        }
        self
    }

    /// How the texture is looked up (a checkerboard by the nearest texel
    /// unless `filter` says otherwise).
    pub fn sampling(&self) -> Sampling {
        let default_filter = match self.source {
            MapSource::File(_) | MapSource::Attribute(_) => Filter::Bilinear,
            MapSource::Checkerboard(_) => Filter::Nearest,
        };
        Sampling {
            filter: self.filter.unwrap_or(default_filter),
            wrap: self.wrap.unwrap_or_default(),
            to_uv: self.to_uv,
        }
    }
}

/// The keys of a map's table.
/// `wrap`: one mode for both axes, or one for each (`u`, then `v`).
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum WrapKey {
    Both(String),
    Each([String; 2]),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MapTable {
    file: Option<PathBuf>,
    checkerboard: Option<[toml::Value; 2]>,
    attribute: Option<String>,
    filter: Option<String>,
    wrap: Option<WrapKey>,
    encoding: Option<String>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    to_uv: Option<[[f32; 3]; 2]>,
}

impl<'de> Deserialize<'de> for MapKey {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<MapKey, D::Error> {
        let value = toml::Value::deserialize(d)?;
        if let toml::Value::String(s) = &value {
            return Ok(MapKey::file(PathBuf::from(s)));
        }
        let t = MapTable::deserialize(value).map_err(|e| {
            D::Error::custom(format!(
                "a map is a file name or a table of file, checkerboard or attribute, filter, \
                 wrap, encoding, to_uv: {}",
                e.message()
            ))
        })?;
        let source = match (t.file, t.checkerboard, t.attribute) {
            (Some(f), None, None) => MapSource::File(f),
            (None, Some([a, b]), None) => MapSource::Checkerboard([
                colour(&a).map_err(D::Error::custom)?,
                colour(&b).map_err(D::Error::custom)?,
            ]),
            (None, None, Some(name)) => {
                if t.filter.is_some()
                    || t.wrap.is_some()
                    || t.encoding.is_some()
                    || t.to_uv.is_some()
                {
                    return Err(D::Error::custom(
                        "an `attribute` map takes no filter, wrap, encoding or to_uv \
                         (the mesh's colours are linear, interpolated over each triangle)",
                    ));
                }
                MapSource::Attribute(name)
            }
            _ => {
                return Err(D::Error::custom(
                    "give `file`, `checkerboard` or `attribute` (one of them)",
                ))
            }
        };
        let filter = match t.filter.as_deref() {
            None => None,
            Some("bilinear") => Some(Filter::Bilinear),
            Some("nearest") => Some(Filter::Nearest),
            Some(o) => {
                return Err(D::Error::custom(format!(
                    "filter `{o}` is not bilinear or nearest"
                )))
            }
        };
        let wrap_mode = |name: &str| match name {
            "repeat" => Ok(Wrap::Repeat),
            "mirror" => Ok(Wrap::Mirror),
            "clamp" => Ok(Wrap::Clamp),
            o => Err(D::Error::custom(format!(
                "wrap `{o}` is not repeat, mirror or clamp"
            ))),
        };
        let wrap = match &t.wrap {
            None => None,
            Some(WrapKey::Both(m)) => Some([wrap_mode(m)?; 2]),
            Some(WrapKey::Each([u, v])) => Some([wrap_mode(u)?, wrap_mode(v)?]),
        };
        let encoding = match t.encoding.as_deref() {
            None => None,
            Some("srgb") => Some(Encoding::Srgb),
            Some("linear") => Some(Encoding::Linear),
            Some(o) => {
                return Err(D::Error::custom(format!(
                    "encoding `{o}` is not srgb or linear"
                )))
            }
        };
        if t.to_uv
            .is_some_and(|m| m.iter().flatten().any(|x| !x.is_finite()))
        {
            return Err(D::Error::custom("to_uv must be finite"));
        }
        Ok(MapKey {
            source,
            filter,
            wrap,
            encoding,
            to_uv: t.to_uv,
        })
    }
}

/// A checkerboard colour: `[r, g, b]` or one number for grey, finite and
/// not negative.
fn colour(v: &toml::Value) -> Result<[f32; 3], String> {
    let number = |x: &toml::Value| match x {
        toml::Value::Float(f) => Some(*f),
        toml::Value::Integer(i) => Some(*i as f64),
        _ => None,
    };
    let c = match v {
        toml::Value::Array(a) if a.len() == 3 => {
            let n: Option<Vec<f64>> = a.iter().map(number).collect();
            let n = n.ok_or("a checkerboard colour is three numbers or one")?;
            [n[0], n[1], n[2]]
        }
        other => [number(other).ok_or("a checkerboard colour is three numbers or one")?; 3],
    };
    if c.iter().any(|x| !x.is_finite() || *x < 0.0) {
        return Err(format!(
            "checkerboard colour {c:?} must be finite and not negative"
        ));
    }
    Ok(c.map(|x| x as f32))
}
