//! Materials made of other materials: `blend` (two materials mixed by a
//! weight), `mask` (a material and a straight pass-through, by opacity),
//! `null` (only the pass-through) and `back` (another material seen from
//! behind), flattened into a [`Composite`] once every material is read.
//!
//! ```toml
//! [[materials]]
//! name = "leaf"
//! type = "mask"
//! material = "green"              # any material, a composite too
//! opacity_map = "leaf_alpha.png"  # or opacity = 0.8
//!
//! [[materials]]
//! name = "worn"
//! type = "blend"
//! materials = ["paint", "rust"]   # weight 0: all paint; 1: all rust
//! weight_map = "wear.png"         # or weight = 0.3
//!
//! [[materials]]
//! name = "card"
//! type = "diffuse"
//! reflectance = [0.8, 0.8, 0.8]
//! back = "red"                    # seen from behind: the material `red`
//! ```

use super::map::MapKey;
use super::material::MaterialSection;
use super::Builder;
use crate::error::Result;
use crate::material::{Composite, Layer, Weight, WeightFactor};
use crate::scene::{Material, MaterialTextures};
use serde::Deserialize;
use std::collections::HashMap;
use std::sync::Arc;

/// The keys of a `blend` material.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct BlendKeys {
    materials: Vec<String>,
    weight: Option<f32>,
    weight_map: Option<MapKey>,
}

/// The keys of a `mask` material.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct MaskKeys {
    material: String,
    opacity: Option<f32>,
    opacity_map: Option<MapKey>,
}

/// The keys of a `null` material (none).
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct NullKeys {}

/// A composite material's keys, by its type.
#[derive(Debug)]
pub(super) enum CompositeKeys {
    Blend(BlendKeys),
    Mask(MaskKeys),
    Null,
}

/// The types of composite materials.
pub(super) const COMPOSITE_TYPES: &str = "blend, mask, null";

/// The layers of both sides of a material as it is being flattened.
struct Sides {
    front: Vec<Layer>,
    back: Option<Vec<Layer>>,
}

impl Sides {
    fn times(self, factor: WeightFactor) -> Sides {
        let scale = |layers: Vec<Layer>| {
            layers
                .into_iter()
                .map(|l| Layer {
                    weight: l.weight.times(factor.clone()),
                    ..l
                })
                .collect::<Vec<_>>()
        };
        Sides {
            front: scale(self.front),
            back: self.back.map(scale),
        }
    }
}

/// What the materials' first reading leaves to the second: each composite's
/// keys and each `back` key, by material index.
#[derive(Default)]
pub(super) struct PendingComposites {
    pub(super) composites: HashMap<usize, CompositeKeys>,
    pub(super) backs: HashMap<usize, String>,
}

impl Builder<'_> {
    /// The keys of `materials[i]` if its type is a composite one.
    pub(super) fn composite_keys(
        &self,
        field: &str,
        m: &MaterialSection,
    ) -> Result<Option<CompositeKeys>> {
        let (kind, keys) = (m.kind.as_str(), &m.keys);
        let k = match kind {
            "blend" => CompositeKeys::Blend(self.type_keys(field, kind, keys)?),
            "mask" => CompositeKeys::Mask(self.type_keys(field, kind, keys)?),
            "null" => {
                let _: NullKeys = self.type_keys(field, kind, keys)?;
                CompositeKeys::Null
            }
            _ => return Ok(None),
        };
        for (given, key) in [
            (m.two_sided.is_some(), "two_sided"),
            (m.back.is_some(), "back"),
            (m.bump_map.is_some(), "bump_map"),
            (m.bump_scale.is_some(), "bump_scale"),
        ] {
            if given {
                return Err(self.err(
                    format!("{field}.{key}"),
                    format!(
                        "not a parameter of a `{kind}` material: give it to the materials \
                         it is made of"
                    ),
                ));
            }
        }
        Ok(Some(k))
    }

    /// Replaces every composite and every material with a `back` by its
    /// flattened [`Composite`]; `materials` holds every material read, the
    /// composites as placeholders.
    pub(super) fn resolve_composites(
        &self,
        materials: &mut [Material],
        by_name: &HashMap<String, u32>,
        pending: &PendingComposites,
    ) -> Result<()> {
        let leaves: Vec<Material> = materials.to_vec();
        let mut order: Vec<usize> = pending
            .composites
            .keys()
            .chain(pending.backs.keys())
            .copied()
            .collect();
        order.sort_unstable();
        order.dedup();
        for i in order {
            let field = format!("materials[{i}]");
            let mut stack = Vec::new();
            let sides = self.flatten(&field, i, &leaves, by_name, pending, &mut stack)?;
            let textures = self.composite_normal_map(&field, &sides)?;
            let first = sides
                .front
                .iter()
                .chain(sides.back.iter().flatten())
                .find_map(|l| l.material.as_ref());
            let m = &mut materials[i];
            if let Some(first) = first {
                m.bsdf = first.bsdf;
            }
            m.textures = textures;
            m.two_sided = true;
            m.composite = Some(Arc::new(Composite {
                front: sides.front,
                back: sides.back,
            }));
        }
        Ok(())
    }

    /// The layers of material `i` (`stack`: the names being flattened, to
    /// refuse a loop).
    fn flatten(
        &self,
        field: &str,
        i: usize,
        leaves: &[Material],
        by_name: &HashMap<String, u32>,
        pending: &PendingComposites,
        stack: &mut Vec<String>,
    ) -> Result<Sides> {
        let name = &leaves[i].name;
        if stack.contains(name) {
            stack.push(name.clone());
            return Err(self.err(
                field,
                format!(
                    "the materials refer to each other in a loop: {}",
                    stack.join(" → ")
                ),
            ));
        }
        stack.push(name.clone());
        let lookup = |key: &str, wanted: &str| -> Result<usize> {
            by_name.get(wanted).map(|&j| j as usize).ok_or_else(|| {
                self.err(
                    format!("{field}.{key}"),
                    format!("no material named `{wanted}`"),
                )
            })
        };
        let sides = match pending.composites.get(&i) {
            None => {
                let leaf = Material {
                    composite: None,
                    ..leaves[i].clone()
                };
                let back = match pending.backs.get(&i) {
                    None => None,
                    Some(b) => {
                        let j = lookup("back", b)?;
                        let back = &leaves[j];
                        if pending.composites.contains_key(&j) || pending.backs.contains_key(&j) {
                            return Err(self.err(
                                format!("{field}.back"),
                                format!(
                                    "`{b}` is made of other materials or has a back of its own: \
                                     a back must be a plain material"
                                ),
                            ));
                        }
                        if leaf.bsdf.transmits() || back.bsdf.transmits() {
                            return Err(self.err(
                                format!("{field}.back"),
                                "a material with a back and its back must both be opaque \
                                 (light through a surface sees both sides)",
                            ));
                        }
                        Some(vec![Layer {
                            material: Some(back.clone()),
                            weight: Weight::default(),
                        }])
                    }
                };
                Sides {
                    front: vec![Layer {
                        material: Some(leaf),
                        weight: Weight::default(),
                    }],
                    back,
                }
            }
            Some(CompositeKeys::Null) => Sides {
                front: vec![Layer {
                    material: None,
                    weight: Weight::default(),
                }],
                back: None,
            },
            Some(CompositeKeys::Mask(k)) => {
                let f = &format!("{field}.opacity");
                let opacity =
                    self.weight_factor(f, k.opacity, k.opacity_map.as_ref(), "opacity")?;
                let inner = lookup("material", &k.material)?;
                let sides = self.flatten(field, inner, leaves, by_name, pending, stack)?;
                let pass = Layer {
                    material: None,
                    weight: Weight(vec![complement(&opacity)]),
                };
                let mut sides = sides.times(opacity);
                sides.front.push(pass.clone());
                if let Some(back) = &mut sides.back {
                    back.push(pass);
                }
                sides
            }
            Some(CompositeKeys::Blend(k)) => {
                if k.materials.len() != 2 {
                    return Err(self.err(
                        format!("{field}.materials"),
                        format!("a blend mixes two materials, got {}", k.materials.len()),
                    ));
                }
                let f = &format!("{field}.weight");
                let w = self.weight_factor(f, k.weight, k.weight_map.as_ref(), "weight")?;
                let a = lookup("materials", &k.materials[0])?;
                let b = lookup("materials", &k.materials[1])?;
                let a = self.flatten(field, a, leaves, by_name, pending, stack)?;
                let b = self.flatten(field, b, leaves, by_name, pending, stack)?;
                let a = a.times(complement(&w));
                let b = b.times(w);
                let back = match (&a.back, &b.back) {
                    (None, None) => None,
                    _ => Some(
                        a.back
                            .clone()
                            .unwrap_or_else(|| a.front.clone())
                            .into_iter()
                            .chain(b.back.clone().unwrap_or_else(|| b.front.clone()))
                            .collect(),
                    ),
                };
                Sides {
                    front: a.front.into_iter().chain(b.front).collect(),
                    back,
                }
            }
        };
        stack.pop();
        Ok(sides)
    }

    /// A weight or opacity: the constant `value` in `[0, 1]`, or `map`'s
    /// luminance (linear unless the map says `encoding = "srgb"`);
    /// exactly one of them.
    fn weight_factor(
        &self,
        field: &str,
        value: Option<f32>,
        map: Option<&MapKey>,
        key: &str,
    ) -> Result<WeightFactor> {
        match (value, map) {
            (Some(v), None) => {
                let v = self.finite(field, v)?;
                if !(0.0..=1.0).contains(&v) {
                    return Err(self.err(field, format!("must be in [0, 1], got {v}")));
                }
                Ok(WeightFactor::Constant(v))
            }
            (None, Some(map)) => {
                let parent = field.rsplit_once('.').map_or(field, |(p, _)| p);
                let key = format!("{key}_map");
                let t = self.textures(
                    parent,
                    None,
                    Some(map.clone().rebased(self.base)),
                    None,
                    ["", key.as_str(), ""],
                )?;
                let map = t.roughness.expect("a map was given");
                Ok(WeightFactor::Map {
                    map,
                    complement: false,
                })
            }
            (Some(_), Some(_)) => {
                Err(self.err(field, format!("give `{key}` or `{key}_map`, not both")))
            }
            (None, None) => Err(self.err(field, format!("required (or `{key}_map`)"))),
        }
    }

    /// The normal map a composite's surface takes: the one every leaf
    /// shares (none, or the same map with the same settings), since the
    /// shading frame is one for the whole surface.
    fn composite_normal_map(&self, field: &str, sides: &Sides) -> Result<MaterialTextures> {
        let mut leaves = sides
            .front
            .iter()
            .chain(sides.back.iter().flatten())
            .filter_map(|l| l.material.as_ref());
        let Some(first) = leaves.next() else {
            return Ok(MaterialTextures::default());
        };
        let t = &first.textures;
        let same = |m: &Material| {
            let u = &m.textures;
            u.normal == t.normal
                && u.normal_frame == t.normal_frame
                && u.normal_shadowing == t.normal_shadowing
                && u.valid_reflection == t.valid_reflection
                && u.bump == t.bump
                && u.bump_scale == t.bump_scale
        };
        if let Some(other) = leaves.find(|m| !same(m)) {
            return Err(self.err(
                field,
                format!(
                    "`{}` and `{}` have different normal or bump maps: the materials a \
                     blend, mask or back combines share the surface's one shading normal",
                    first.name, other.name
                ),
            ));
        }
        Ok(MaterialTextures {
            normal: t.normal.clone(),
            normal_frame: t.normal_frame,
            normal_shadowing: t.normal_shadowing,
            valid_reflection: t.valid_reflection,
            bump: t.bump.clone(),
            bump_scale: t.bump_scale,
            ..MaterialTextures::default()
        })
    }
}

/// `1 − factor`.
fn complement(f: &WeightFactor) -> WeightFactor {
    match f {
        WeightFactor::Constant(c) => WeightFactor::Constant(1.0 - c),
        WeightFactor::Map { map, complement } => WeightFactor::Map {
            map: map.clone(),
            complement: !complement,
        },
    }
}
