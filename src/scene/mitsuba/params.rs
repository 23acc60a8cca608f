//! Reading a plugin's parameters: numbers, vectors, booleans, strings,
//! points and transforms, each checked against the type Mitsuba expects.

use super::document::Element;
use super::spectrum::SpectrumUse;
use super::texture::Colour;
use super::translator::{Params, Translator};
use crate::error::Result;
use glam::{DMat4, DVec3};
use std::collections::HashSet;

impl<'a> Translator<'a> {
    pub(super) fn required_attr(&self, node: &Element, name: &str) -> Result<String> {
        self.attr(node, name)?
            .ok_or_else(|| self.err(node, format!("the attribute `{name}` is required")))
    }

    pub(super) fn number(&self, node: &Element, text: &str) -> Result<f64> {
        text.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(node, format!("`{text}` is not a finite number")))
    }

    /// A list of numbers, separated by commas and/or spaces.
    pub(super) fn numbers(&self, node: &Element, text: &str) -> Result<Vec<f64>> {
        text.split(|c: char| c == ',' || c.is_whitespace())
            .filter(|s| !s.is_empty())
            .map(|s| self.number(node, s))
            .collect()
    }

    /// A 3-vector from `value="x, y, z"` (or one number for all three, if
    /// `splat`) or from `x`, `y`, `z` attributes (missing ones `missing`).
    pub(super) fn triple(&self, node: &Element, splat: bool, missing: f64) -> Result<[f64; 3]> {
        if let Some(v) = self.attr(node, "value")? {
            let n = self.numbers(node, &v)?;
            return match n.len() {
                3 => Ok([n[0], n[1], n[2]]),
                1 if splat => Ok([n[0]; 3]),
                _ => Err(self.err(
                    node,
                    format!(
                        "value=\"{v}\" must be three numbers{}",
                        if splat { " or one" } else { "" }
                    ),
                )),
            };
        }
        let mut out = [missing; 3];
        for (i, a) in ["x", "y", "z"].iter().enumerate() {
            if let Some(v) = self.attr(node, a)? {
                out[i] = self.number(node, &v)?;
            }
        }
        Ok(out)
    }

    pub(super) fn params(&self, node: &'a Element) -> Result<Params<'a>> {
        let mut named = Vec::new();
        for c in node.children.iter() {
            if let Some(name) = c.attribute("name") {
                if named.iter().any(|(n, _)| n == name) {
                    return Err(self.err(c, format!("`{name}` is given twice")));
                }
                named.push((name.to_string(), c));
            }
        }
        Ok(Params {
            node,
            named,
            used: HashSet::new(),
        })
    }

    pub(super) fn take<'p>(&self, p: &'p mut Params<'a>, name: &str) -> Option<&'a Element> {
        let node = p.named.iter().find(|(n, _)| n == name).map(|(_, c)| *c);
        if node.is_some() {
            p.used.insert(name.to_string());
        }
        node
    }

    pub(super) fn take_float(&self, p: &mut Params<'a>, name: &str) -> Result<Option<f64>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        match c.tag.as_str() {
            "float" | "integer" => {
                let v = self.required_attr(c, "value")?;
                Ok(Some(self.number(c, &v)?))
            }
            "spectrum" | "rgb" => match self.colour_of(c, SpectrumUse::Unbounded)? {
                Colour::Rgb([a, b, d]) if a == b && b == d => Ok(Some(a)),
                _ => Err(self.err(c, format!("`{name}` must be one number here"))),
            },
            other => Err(self.err(c, format!("`{name}` must be a <float>, not <{other}>"))),
        }
    }

    pub(super) fn take_int(&self, p: &mut Params<'a>, name: &str) -> Result<Option<i64>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if c.tag.as_str() != "integer" {
            return Err(self.err(c, format!("`{name}` must be an <integer>")));
        }
        let v = self.required_attr(c, "value")?;
        v.trim()
            .parse::<i64>()
            .map(Some)
            .map_err(|_| self.err(c, format!("`{v}` is not an integer")))
    }

    pub(super) fn take_bool(&self, p: &mut Params<'a>, name: &str) -> Result<Option<bool>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if c.tag.as_str() != "boolean" {
            return Err(self.err(c, format!("`{name}` must be a <boolean>")));
        }
        match self.required_attr(c, "value")?.as_str() {
            "true" => Ok(Some(true)),
            "false" => Ok(Some(false)),
            other => Err(self.err(c, format!("`{other}` is not true or false"))),
        }
    }

    pub(super) fn take_string(&self, p: &mut Params<'a>, name: &str) -> Result<Option<String>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if c.tag.as_str() != "string" {
            return Err(self.err(c, format!("`{name}` must be a <string>")));
        }
        self.required_attr(c, "value").map(Some)
    }

    pub(super) fn take_point(&self, p: &mut Params<'a>, name: &str) -> Result<Option<[f64; 3]>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if !matches!(c.tag.as_str(), "point" | "vector") {
            return Err(self.err(c, format!("`{name}` must be a <point>")));
        }
        self.triple(c, false, 0.0).map(Some)
    }

    pub(super) fn take_transform(&self, p: &mut Params<'a>, name: &str) -> Result<Option<DMat4>> {
        let Some(c) = self.take(p, name) else {
            return Ok(None);
        };
        if c.tag.as_str() != "transform" {
            return Err(self.err(c, format!("`{name}` must be a <transform>")));
        }
        self.transform(c).map(Some)
    }

    /// A `<transform>`: its operations in order, each applied after the
    /// ones before it.
    pub(super) fn transform(&self, node: &Element) -> Result<DMat4> {
        let mut m = DMat4::IDENTITY;
        for c in node.children.iter() {
            let op = match c.tag.as_str() {
                "translate" => DMat4::from_translation(DVec3::from(self.triple(c, false, 0.0)?)),
                "scale" => {
                    let s = self.triple(c, true, 1.0)?;
                    DMat4::from_scale(DVec3::from(s))
                }
                "rotate" => {
                    let axis = DVec3::from(self.triple(c, false, 0.0)?);
                    let angle = self.number(c, &self.required_attr(c, "angle")?)?;
                    if axis.length_squared() == 0.0 {
                        return Err(self.err(c, "the rotation axis is zero"));
                    }
                    DMat4::from_axis_angle(axis.normalize(), angle.to_radians())
                }
                "matrix" => {
                    let v = self.numbers(c, &self.required_attr(c, "value")?)?;
                    match v.len() {
                        16 => DMat4::from_cols_array(&[
                            v[0], v[4], v[8], v[12], v[1], v[5], v[9], v[13], v[2], v[6], v[10],
                            v[14], v[3], v[7], v[11], v[15],
                        ]),
                        9 => DMat4::from_cols_array(&[
                            v[0], v[3], v[6], 0.0, v[1], v[4], v[7], 0.0, v[2], v[5], v[8], 0.0,
                            0.0, 0.0, 0.0, 1.0,
                        ]),
                        n => {
                            return Err(
                                self.err(c, format!("a matrix has 16 (or 9) numbers, not {n}"))
                            )
                        }
                    }
                }
                "lookat" => {
                    let get = |a: &str, required: bool| -> Result<Option<DVec3>> {
                        match self.attr(c, a)? {
                            Some(v) => {
                                let n = self.numbers(c, &v)?;
                                if n.len() != 3 {
                                    return Err(
                                        self.err(c, format!("{a}=\"{v}\" must be three numbers"))
                                    );
                                }
                                Ok(Some(DVec3::new(n[0], n[1], n[2])))
                            }
                            None if required => {
                                Err(self.err(c, format!("the attribute `{a}` is required")))
                            }
                            None => Ok(None),
                        }
                    };
                    let origin = get("origin", true)?.unwrap_or_default();
                    let target = get("target", true)?.unwrap_or_default();
                    let dir = (target - origin)
                        .try_normalize()
                        .ok_or_else(|| self.err(c, "origin and target are the same point"))?;
                    let up = match get("up", false)? {
                        Some(up) => up,
                        // Mitsuba picks any up perpendicular to the direction.
                        None => dir.any_orthonormal_vector(),
                    };
                    let left = up.cross(dir).try_normalize().ok_or_else(|| {
                        self.err(c, "`up` is zero or parallel to the viewing direction")
                    })?;
                    let new_up = dir.cross(left);
                    DMat4::from_cols(
                        left.extend(0.0),
                        new_up.extend(0.0),
                        dir.extend(0.0),
                        origin.extend(1.0),
                    )
                }
                other => {
                    return Err(self.err(
                        c,
                        format!(
                            "<{other}> is not a transform operation \
                             (known: translate, rotate, scale, matrix, lookat)"
                        ),
                    ))
                }
            };
            m = op * m;
        }
        if !m.to_cols_array().iter().all(|x| x.is_finite()) {
            return Err(self.err(node, "the transform is not finite"));
        }
        Ok(m)
    }
}
