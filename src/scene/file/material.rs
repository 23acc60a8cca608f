//! `[[materials]]`: named BSDFs with their parameters and textures, and
//! the materials of OBJ files' MTL libraries.

use super::keys::key_names;
use super::map::{MapKey, MapSource};
use super::Builder;
use crate::bsdf::METALS;
use crate::bsdf::{
    BlinnPhongParams, Bsdf, CookTorranceParams, DielectricParams, Distribution, Fresnel,
    Microfacet, PrincipledFullParams, PrincipledParams, PrincipledThinParams,
};
use crate::error::Result;
use crate::material::{decode_normal, NormalFrame, ScalarMap, ScalarParam};
use crate::scene::shapes::{self};
use crate::scene::{Material, MaterialTextures};
use crate::texture::{self, Encoding, ImageTexture};
use glam::Vec3;
use serde::Deserialize;
use std::path::PathBuf;
use std::sync::Arc;

/// Default albedo of OBJ objects whose MTL material has no `Kd`.
pub const DEFAULT_REFLECTANCE: f32 = 0.8;

/// `[[materials]]` as read: the name, the type, and the type's own keys,
/// which [`MaterialKeys::parse`] checks against the type.
#[derive(Debug, Deserialize)]
pub(super) struct MaterialSection {
    pub(super) name: String,
    #[serde(rename = "type")]
    pub(super) kind: String,
    /// `false`: black seen from behind (see [`Material::two_sided`]).
    pub(super) two_sided: Option<bool>,
    /// The material seen from behind (see `composite.rs`).
    pub(super) back: Option<String>,
    /// A height field tilting the shading normal (any type).
    pub(super) bump_map: Option<MapKey>,
    /// The height field's scale (default 1).
    pub(super) bump_scale: Option<f32>,
    #[serde(flatten)]
    pub(super) keys: toml::Table,
}

/// The keys of a `diffuse` material.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DiffuseKeys {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    reflectance: Option<[f32; 3]>,
    base_color_map: Option<MapKey>,
    normal_map: Option<PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<String>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
}

/// The keys of a `blinn_phong` material.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct BlinnPhongKeys {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    diffuse: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    specular: Option<[f32; 3]>,
    exponent: Option<f32>,
    base_color_map: Option<MapKey>,
    normal_map: Option<PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<String>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
}

/// The keys of a `cook_torrance` material.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct CookTorranceKeys {
    distribution: Option<String>,
    roughness: Option<f32>,
    alpha: Option<f32>,
    alpha_u: Option<f32>,
    alpha_v: Option<f32>,
    fresnel: Option<String>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    f0: Option<[f32; 3]>,
    ior: Option<f32>,
    metal: Option<String>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    eta: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    k: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    specular_reflectance: Option<[f32; 3]>,
    roughness_map: Option<MapKey>,
    alpha_map: Option<MapKey>,
    alpha_u_map: Option<MapKey>,
    alpha_v_map: Option<MapKey>,
    normal_map: Option<PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<String>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
}

/// The keys of a `dielectric` material.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DielectricKeys {
    ior: Option<f32>,
    distribution: Option<String>,
    roughness: Option<f32>,
    alpha: Option<f32>,
    alpha_u: Option<f32>,
    alpha_v: Option<f32>,
    alpha_map: Option<MapKey>,
    alpha_u_map: Option<MapKey>,
    alpha_v_map: Option<MapKey>,
    normal_map: Option<PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<String>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
}

/// The keys of a `thin_dielectric` material (Mitsuba's `thindielectric`).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ThinDielectricKeys {
    ior: Option<f32>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    specular_reflectance: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    specular_transmittance: Option<[f32; 3]>,
}

/// The keys of a `principled` material.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PrincipledKeys {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    base_color: Option<[f32; 3]>,
    roughness: Option<f32>,
    metallic: Option<f32>,
    anisotropic: Option<f32>,
    specular: Option<f32>,
    eta: Option<f32>,
    spec_tint: Option<f32>,
    sheen: Option<f32>,
    sheen_tint: Option<f32>,
    clearcoat: Option<f32>,
    clearcoat_gloss: Option<f32>,
    spec_trans: Option<f32>,
    flatness: Option<f32>,
    energy_conserving: Option<bool>,
    base_color_map: Option<MapKey>,
    roughness_map: Option<MapKey>,
    metallic_map: Option<MapKey>,
    anisotropic_map: Option<MapKey>,
    specular_map: Option<MapKey>,
    spec_tint_map: Option<MapKey>,
    sheen_map: Option<MapKey>,
    sheen_tint_map: Option<MapKey>,
    clearcoat_map: Option<MapKey>,
    clearcoat_gloss_map: Option<MapKey>,
    spec_trans_map: Option<MapKey>,
    flatness_map: Option<MapKey>,
    normal_map: Option<PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<String>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
}

/// The keys of a `principled_thin` material (Mitsuba's `principledthin`).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PrincipledThinKeys {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    base_color: Option<[f32; 3]>,
    roughness: Option<f32>,
    anisotropic: Option<f32>,
    spec_trans: Option<f32>,
    eta: Option<f32>,
    spec_tint: Option<f32>,
    sheen: Option<f32>,
    sheen_tint: Option<f32>,
    flatness: Option<f32>,
    diff_trans: Option<f32>,
    base_color_map: Option<MapKey>,
    roughness_map: Option<MapKey>,
    anisotropic_map: Option<MapKey>,
    spec_trans_map: Option<MapKey>,
    spec_tint_map: Option<MapKey>,
    sheen_map: Option<MapKey>,
    sheen_tint_map: Option<MapKey>,
    flatness_map: Option<MapKey>,
    normal_map: Option<PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<String>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
}

/// The keys of a `plastic` and a `rough_plastic` material (Mitsuba's
/// `plastic` and `roughplastic`; the rough one's microfacet keys only).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PlasticKeys {
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    diffuse_reflectance: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    specular_reflectance: Option<[f32; 3]>,
    int_ior: Option<f32>,
    ext_ior: Option<f32>,
    nonlinear: Option<bool>,
    distribution: Option<String>,
    alpha: Option<f32>,
    sample_visible: Option<bool>,
    base_color_map: Option<MapKey>,
    normal_map: Option<PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<String>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
}

/// A material's keys, by its type (the `type` key is the tag).
#[derive(Debug)]
pub(super) enum MaterialKeys {
    Diffuse(DiffuseKeys),
    BlinnPhong(BlinnPhongKeys),
    CookTorrance(CookTorranceKeys),
    Dielectric(DielectricKeys),
    Principled(Box<PrincipledKeys>),
    PrincipledThin(PrincipledThinKeys),
    Plastic(PlasticKeys),
    RoughPlastic(PlasticKeys),
    ThinDielectric(ThinDielectricKeys),
}

/// The material types, by their `type` names.
const MATERIAL_TYPES: &str =
    "diffuse, blinn_phong, cook_torrance, dielectric, thin_dielectric, principled, \
     principled_thin, plastic, rough_plastic";

/// The keys of a microfacet distribution, shared by several types.
struct MicrofacetKeys<'a> {
    distribution: &'a Option<String>,
    roughness: Option<f32>,
    alpha: Option<f32>,
    alpha_u: Option<f32>,
    alpha_v: Option<f32>,
}

/// The [`MicrofacetKeys`] of a material type's keys (any struct with the
/// five microfacet fields).
macro_rules! microfacet_keys {
    ($m:expr) => {
        MicrofacetKeys {
            distribution: &$m.distribution,
            roughness: $m.roughness,
            alpha: $m.alpha,
            alpha_u: $m.alpha_u,
            alpha_v: $m.alpha_v,
        }
    };
}

/// The texture keys of a material.
#[derive(Default)]
struct TextureKeys<'a> {
    base_color_map: Option<&'a MapKey>,
    roughness_map: Option<&'a MapKey>,
    metallic_map: Option<&'a MapKey>,
    alpha_map: Option<&'a MapKey>,
    alpha_u_map: Option<&'a MapKey>,
    alpha_v_map: Option<&'a MapKey>,
    normal_map: Option<&'a PathBuf>,
    normal_scale: Option<f32>,
    normal_frame: Option<&'a str>,
    normal_shadowing: Option<bool>,
    normal_valid_reflection: Option<bool>,
    /// Maps of the principled models' weights.
    scalars: Vec<(ScalarParam, &'a MapKey)>,
}

/// The maps among `maps` that are given.
fn given_maps<const N: usize>(
    maps: [(ScalarParam, &Option<MapKey>); N],
) -> Vec<(ScalarParam, &MapKey)> {
    maps.into_iter()
        .filter_map(|(p, m)| m.as_ref().map(|m| (p, m)))
        .collect()
}

impl MaterialKeys {
    fn textures(&self) -> TextureKeys<'_> {
        match self {
            MaterialKeys::Diffuse(k) => TextureKeys {
                base_color_map: k.base_color_map.as_ref(),
                normal_map: k.normal_map.as_ref(),
                normal_scale: k.normal_scale,
                normal_frame: k.normal_frame.as_deref(),
                normal_shadowing: k.normal_shadowing,
                normal_valid_reflection: k.normal_valid_reflection,
                ..Default::default()
            },
            MaterialKeys::BlinnPhong(k) => TextureKeys {
                base_color_map: k.base_color_map.as_ref(),
                normal_map: k.normal_map.as_ref(),
                normal_scale: k.normal_scale,
                normal_frame: k.normal_frame.as_deref(),
                normal_shadowing: k.normal_shadowing,
                normal_valid_reflection: k.normal_valid_reflection,
                ..Default::default()
            },
            MaterialKeys::CookTorrance(k) => TextureKeys {
                roughness_map: k.roughness_map.as_ref(),
                alpha_map: k.alpha_map.as_ref(),
                alpha_u_map: k.alpha_u_map.as_ref(),
                alpha_v_map: k.alpha_v_map.as_ref(),
                normal_map: k.normal_map.as_ref(),
                normal_scale: k.normal_scale,
                normal_frame: k.normal_frame.as_deref(),
                normal_shadowing: k.normal_shadowing,
                normal_valid_reflection: k.normal_valid_reflection,
                ..Default::default()
            },
            MaterialKeys::Dielectric(k) => TextureKeys {
                alpha_map: k.alpha_map.as_ref(),
                alpha_u_map: k.alpha_u_map.as_ref(),
                alpha_v_map: k.alpha_v_map.as_ref(),
                normal_map: k.normal_map.as_ref(),
                normal_scale: k.normal_scale,
                normal_frame: k.normal_frame.as_deref(),
                normal_shadowing: k.normal_shadowing,
                normal_valid_reflection: k.normal_valid_reflection,
                ..Default::default()
            },
            MaterialKeys::Plastic(k) | MaterialKeys::RoughPlastic(k) => TextureKeys {
                base_color_map: k.base_color_map.as_ref(),
                normal_map: k.normal_map.as_ref(),
                normal_scale: k.normal_scale,
                normal_frame: k.normal_frame.as_deref(),
                normal_shadowing: k.normal_shadowing,
                normal_valid_reflection: k.normal_valid_reflection,
                ..Default::default()
            },
            MaterialKeys::ThinDielectric(_) => TextureKeys::default(),
            MaterialKeys::Principled(k) => TextureKeys {
                base_color_map: k.base_color_map.as_ref(),
                roughness_map: k.roughness_map.as_ref(),
                metallic_map: k.metallic_map.as_ref(),
                normal_map: k.normal_map.as_ref(),
                normal_scale: k.normal_scale,
                normal_frame: k.normal_frame.as_deref(),
                normal_shadowing: k.normal_shadowing,
                normal_valid_reflection: k.normal_valid_reflection,
                scalars: given_maps([
                    (ScalarParam::Anisotropic, &k.anisotropic_map),
                    (ScalarParam::Specular, &k.specular_map),
                    (ScalarParam::SpecTint, &k.spec_tint_map),
                    (ScalarParam::Sheen, &k.sheen_map),
                    (ScalarParam::SheenTint, &k.sheen_tint_map),
                    (ScalarParam::Clearcoat, &k.clearcoat_map),
                    (ScalarParam::ClearcoatGloss, &k.clearcoat_gloss_map),
                    (ScalarParam::SpecTrans, &k.spec_trans_map),
                    (ScalarParam::Flatness, &k.flatness_map),
                ]),
                ..Default::default()
            },
            MaterialKeys::PrincipledThin(k) => TextureKeys {
                base_color_map: k.base_color_map.as_ref(),
                roughness_map: k.roughness_map.as_ref(),
                normal_map: k.normal_map.as_ref(),
                normal_scale: k.normal_scale,
                normal_frame: k.normal_frame.as_deref(),
                normal_shadowing: k.normal_shadowing,
                normal_valid_reflection: k.normal_valid_reflection,
                scalars: given_maps([
                    (ScalarParam::Anisotropic, &k.anisotropic_map),
                    (ScalarParam::SpecTrans, &k.spec_trans_map),
                    (ScalarParam::SpecTint, &k.spec_tint_map),
                    (ScalarParam::Sheen, &k.sheen_map),
                    (ScalarParam::SheenTint, &k.sheen_tint_map),
                    (ScalarParam::Flatness, &k.flatness_map),
                ]),
                ..Default::default()
            },
        }
    }
}

impl Builder<'_> {
    /// The microfacet distribution of a material: `distribution` (`ggx` or
    /// `beckmann`) and `roughness` (α = roughness²), `alpha`, or
    /// `alpha_u`/`alpha_v` (anisotropic).
    fn microfacet(
        &self,
        field: &str,
        m: &MicrofacetKeys,
        default_roughness: Option<f32>,
    ) -> Result<Option<Microfacet>> {
        let kind = match m.distribution.as_deref().unwrap_or("ggx") {
            "ggx" => Distribution::Ggx,
            "beckmann" => Distribution::Beckmann,
            other => {
                return Err(self.err(
                    format!("{field}.distribution"),
                    format!("unknown distribution `{other}` (known: ggx, beckmann)"),
                ))
            }
        };
        let given = [
            m.roughness.is_some(),
            m.alpha.is_some(),
            m.alpha_u.is_some() || m.alpha_v.is_some(),
        ];
        if given.iter().filter(|&&g| g).count() > 1 {
            return Err(self.err(
                format!("{field}.roughness"),
                "give one of roughness, alpha, or alpha_u with alpha_v",
            ));
        }
        let alpha = |name: &str, v: f32| -> Result<f32> {
            let v = self.finite(&format!("{field}.{name}"), v)?;
            if !(0.0..=4.0).contains(&v) {
                return Err(self.err(
                    format!("{field}.{name}"),
                    format!("must be in [0, 4], got {v}"),
                ));
            }
            Ok(v)
        };
        let (ax, ay) = if let Some(r) = m.roughness {
            let r = self.unit(&format!("{field}.roughness"), Some(r), 0.0)?;
            (r * r, r * r)
        } else if let Some(a) = m.alpha {
            let a = alpha("alpha", a)?;
            (a, a)
        } else if m.alpha_u.is_some() || m.alpha_v.is_some() {
            let (Some(u), Some(v)) = (m.alpha_u, m.alpha_v) else {
                return Err(self.err(
                    format!("{field}.alpha_u"),
                    "alpha_u and alpha_v go together",
                ));
            };
            (alpha("alpha_u", u)?, alpha("alpha_v", v)?)
        } else if let Some(r) = default_roughness {
            (r * r, r * r)
        } else {
            if m.distribution.is_some() {
                return Err(self.err(
                    format!("{field}.distribution"),
                    "only used with a roughness",
                ));
            }
            return Ok(None);
        };
        Ok(Some(Microfacet::new(kind, ax, ay)))
    }

    /// The keys `T` of a material of type `kind`: a key `T` lacks, or a
    /// value of the wrong kind, is an error naming the key and listing the
    /// type's keys.
    pub(super) fn type_keys<T: serde::de::DeserializeOwned>(
        &self,
        field: &str,
        kind: &str,
        keys: &toml::Table,
    ) -> Result<T> {
        self.typed_keys::<T>(field, keys, |_| {
            format!(
                "not a parameter of a `{kind}` material (its keys: {})",
                key_names::<T>().join(", ")
            )
        })
    }

    /// The keys of `materials[i]`, checked against its type: an unknown
    /// type, a key the type does not have, or a value of the wrong kind is
    /// an error naming the key.
    pub(super) fn material_keys(&self, field: &str, m: &MaterialSection) -> Result<MaterialKeys> {
        let (kind, keys) = (m.kind.as_str(), &m.keys);
        Ok(match kind {
            "diffuse" => MaterialKeys::Diffuse(self.type_keys(field, kind, keys)?),
            "blinn_phong" => MaterialKeys::BlinnPhong(self.type_keys(field, kind, keys)?),
            "cook_torrance" => MaterialKeys::CookTorrance(self.type_keys(field, kind, keys)?),
            "dielectric" => MaterialKeys::Dielectric(self.type_keys(field, kind, keys)?),
            "thin_dielectric" => MaterialKeys::ThinDielectric(self.type_keys(field, kind, keys)?),
            "principled" => MaterialKeys::Principled(self.type_keys(field, kind, keys)?),
            "principled_thin" => MaterialKeys::PrincipledThin(self.type_keys(field, kind, keys)?),
            "plastic" => {
                let k: PlasticKeys = self.type_keys(field, kind, keys)?;
                for (given, key) in [
                    (k.distribution.is_some(), "distribution"),
                    (k.alpha.is_some(), "alpha"),
                    (k.sample_visible.is_some(), "sample_visible"),
                ] {
                    if given {
                        return Err(self.err(
                            format!("{field}.{key}"),
                            "a smooth `plastic` has no roughness: use `rough_plastic`",
                        ));
                    }
                }
                MaterialKeys::Plastic(k)
            }
            "rough_plastic" => MaterialKeys::RoughPlastic(self.type_keys(field, kind, keys)?),
            other => {
                return Err(self.err(
                    format!("{field}.type"),
                    format!(
                        "unknown material type `{other}` (known: {MATERIAL_TYPES}, {})",
                        super::composite::COMPOSITE_TYPES
                    ),
                ))
            }
        })
    }

    /// Builds the BSDF of a material from its checked keys.
    pub(super) fn material(&self, field: &str, keys: &MaterialKeys) -> Result<Bsdf> {
        // The parser checks that each value is a finite number; the ranges
        // are the model's own rule (`validate`), reported here by key.
        let number = |name: &str, v: Option<f32>, default: f32| {
            self.finite(&format!("{field}.{name}"), v.unwrap_or(default))
        };
        let out_of_range = |e: crate::bsdf::ParamError| {
            self.err(
                format!("{field}.{}", e.parameter),
                format!("must be in {}, got {}", e.range, e.value),
            )
        };
        let colour = |name: &str, v: Option<[f32; 3]>, default: f32| {
            self.colour(
                &format!("{field}.{name}"),
                v.unwrap_or([default; 3]),
                Some(1.0),
            )
        };
        let ior = |given: Option<f32>, default: f32| -> Result<f32> {
            let v = self.finite(&format!("{field}.ior"), given.unwrap_or(default))?;
            if v <= 0.0 || v == 1.0 {
                return Err(self.err(
                    format!("{field}.ior"),
                    format!("must be positive and not 1, got {v}"),
                ));
            }
            Ok(v)
        };
        Ok(match keys {
            MaterialKeys::Diffuse(m) => {
                Bsdf::diffuse(colour("reflectance", m.reflectance, DEFAULT_REFLECTANCE)?)
            }
            MaterialKeys::BlinnPhong(m) => {
                let diffuse = colour("diffuse", m.diffuse, 0.5)?;
                let specular = match m.specular {
                    None => Vec3::splat(0.2),
                    Some(arr) => colour("specular", Some(arr), 0.0)?,
                };
                if (diffuse + specular).max_element() > 1.0 {
                    return Err(self.err(
                        format!("{field}.specular"),
                        "diffuse + specular must not exceed 1 in any channel (energy)",
                    ));
                }
                let exponent =
                    self.finite(&format!("{field}.exponent"), m.exponent.unwrap_or(30.0))?;
                if !(0.0..=1e5).contains(&exponent) {
                    return Err(self.err(
                        format!("{field}.exponent"),
                        format!("must be in [0, 100000], got {exponent}"),
                    ));
                }
                Bsdf::BlinnPhong(BlinnPhongParams {
                    diffuse,
                    specular,
                    exponent,
                })
            }
            MaterialKeys::CookTorrance(m) => {
                let ior = |default| ior(m.ior, default);
                let facets = microfacet_keys!(m);
                let microfacet = self
                    .microfacet(field, &facets, Some(0.3))?
                    .expect("a default roughness");
                let fresnel = match m.fresnel.as_deref().unwrap_or("conductor") {
                    "schlick" => Fresnel::Schlick { f0: colour("f0", m.f0, 0.04)? },
                    "dielectric" => Fresnel::Dielectric { eta: ior(1.5)? },
                    "conductor" => {
                        let (eta, k) = match (&m.metal, m.eta, m.k) {
                            // Reflectance 1 (then specular_reflectance is the
                            // reflectance): Mitsuba's `material = "none"`.
                            (Some(name), None, None) if name == "none" => (Vec3::ZERO, Vec3::ONE),
                            (Some(name), None, None) => {
                                let Some((_, e, k)) = METALS.iter().find(|(n, _, _)| n == name) else {
                                    return Err(self.err(
                                        format!("{field}.metal"),
                                        format!("unknown metal `{name}` (known: Au, Ag, Cu, Al, none)"),
                                    ));
                                };
                                (Vec3::from(*e), Vec3::from(*k))
                            }
                            (None, Some(e), Some(k)) => (
                                self.colour(&format!("{field}.eta"), e, None)?,
                                self.colour(&format!("{field}.k"), k, None)?,
                            ),
                            (None, None, None) => (Vec3::from(METALS[3].1), Vec3::from(METALS[3].2)),
                            _ => {
                                return Err(self.err(
                                    format!("{field}.metal"),
                                    "give either metal, or eta together with k",
                                ))
                            }
                        };
                        Fresnel::Conductor {
                            eta,
                            k,
                            specular_reflectance: colour(
                                "specular_reflectance",
                                m.specular_reflectance,
                                1.0,
                            )?,
                        }
                    }
                    other => {
                        return Err(self.err(
                            format!("{field}.fresnel"),
                            format!("unknown Fresnel term `{other}` (known: schlick, dielectric, conductor)"),
                        ))
                    }
                };
                let used = match fresnel {
                    Fresnel::Schlick { .. } => &["f0"][..],
                    Fresnel::Dielectric { .. } => &["ior"][..],
                    Fresnel::Conductor { .. } => &["metal", "eta", "k", "specular_reflectance"][..],
                };
                let given = [
                    ("f0", m.f0.is_some()),
                    ("ior", m.ior.is_some()),
                    ("metal", m.metal.is_some()),
                    ("eta", m.eta.is_some()),
                    ("k", m.k.is_some()),
                    ("specular_reflectance", m.specular_reflectance.is_some()),
                ];
                if let Some((k, _)) = given.iter().find(|(k, g)| *g && !used.contains(k)) {
                    return Err(self.err(format!("{field}.{k}"), "not used by this Fresnel term"));
                }
                Bsdf::CookTorrance(CookTorranceParams {
                    microfacet,
                    fresnel,
                })
            }
            MaterialKeys::Dielectric(m) => {
                let facets = microfacet_keys!(m);
                // Alpha maps make a rough interface (their α at each point).
                let mapped = m.alpha_map.is_some() || m.alpha_u_map.is_some();
                Bsdf::Dielectric(DielectricParams {
                    eta: ior(m.ior, 1.5)?,
                    microfacet: self.microfacet(field, &facets, mapped.then_some(0.1))?,
                })
            }
            MaterialKeys::Plastic(m) | MaterialKeys::RoughPlastic(m) => {
                self.plastic(field, m, matches!(keys, MaterialKeys::RoughPlastic(_)))?
            }
            MaterialKeys::ThinDielectric(m) => {
                let params = crate::bsdf::ThinDielectricParams {
                    eta: ior(m.ior, 1.5)?,
                    reflectance: colour("specular_reflectance", m.specular_reflectance, 1.0)?,
                    transmittance: colour("specular_transmittance", m.specular_transmittance, 1.0)?,
                };
                Bsdf::ThinDielectric(params.validate().map_err(|e| self.err(field, e))?)
            }
            MaterialKeys::Principled(m) => {
                if m.eta.is_some() && (m.specular.is_some() || m.specular_map.is_some()) {
                    return Err(self.err(
                        format!("{field}.eta"),
                        "give one of eta and specular (they set the same index of refraction)",
                    ));
                }
                let specular = number("specular", m.specular, 0.5)?;
                let eta = match m.eta {
                    Some(e) => Some(number("eta", Some(e), 1.5)?),
                    None => None,
                };
                // The two-lobe model's specular for η, if it has one.
                let specular_of_eta = eta.map(crate::bsdf::albedo::specular_from_eta);
                let eta_in_range = specular_of_eta.is_none_or(|s| s.is_some());
                let specular_of_eta = specular_of_eta.flatten();
                let extra_lobes = [m.sheen, m.clearcoat, m.spec_trans, m.flatness]
                    .iter()
                    .any(|v| v.is_some_and(|v| v != 0.0))
                    || [
                        &m.sheen_map,
                        &m.sheen_tint_map,
                        &m.clearcoat_map,
                        &m.clearcoat_gloss_map,
                        &m.spec_trans_map,
                        &m.flatness_map,
                    ]
                    .iter()
                    .any(|k| k.is_some());
                let two_lobes = !extra_lobes && eta_in_range;
                if two_lobes {
                    let params = PrincipledParams {
                        base_color: colour("base_color", m.base_color, 0.5)?,
                        roughness: number("roughness", m.roughness, 0.5)?,
                        metallic: number("metallic", m.metallic, 0.0)?,
                        anisotropic: number("anisotropic", m.anisotropic, 0.0)?,
                        specular: specular_of_eta.unwrap_or(specular),
                        spec_tint: number("spec_tint", m.spec_tint, 0.0)?,
                        energy_conserving: m.energy_conserving.unwrap_or(false),
                    };
                    Bsdf::Principled(params.validate().map_err(out_of_range)?)
                } else {
                    if m.energy_conserving == Some(true) {
                        return Err(self.err(
                            format!("{field}.energy_conserving"),
                            "the energy-conserving diffuse lobe is for the two-lobe model: \
                             not with sheen, clearcoat, spec_trans, flatness or an eta \
                             beyond specular's range",
                        ));
                    }
                    let spec_trans = number("spec_trans", m.spec_trans, 0.0)?;
                    let has_transmission = spec_trans != 0.0 || m.spec_trans_map.is_some();
                    let eta = match eta {
                        Some(e) => e,
                        None => {
                            // Mitsuba: specular 0 (η = 1) is no interface to
                            // transmit through; it takes 0.001.
                            let s = if has_transmission && specular == 0.0 {
                                1e-3
                            } else {
                                specular
                            };
                            if !(0.0..=1.0).contains(&s) {
                                return Err(out_of_range(crate::bsdf::ParamError {
                                    parameter: "specular",
                                    value: s,
                                    range: "[0, 1]",
                                }));
                            }
                            crate::bsdf::albedo::eta_from_specular(s)
                        }
                    };
                    let params = PrincipledFullParams {
                        base_color: colour("base_color", m.base_color, 0.5)?,
                        roughness: number("roughness", m.roughness, 0.5)?,
                        metallic: number("metallic", m.metallic, 0.0)?,
                        anisotropic: number("anisotropic", m.anisotropic, 0.0)?,
                        // Mitsuba: η = 1 with transmission takes 1.001.
                        eta: if has_transmission && eta == 1.0 {
                            1.001
                        } else {
                            eta
                        },
                        spec_tint: number("spec_tint", m.spec_tint, 0.0)?,
                        sheen: number("sheen", m.sheen, 0.0)?,
                        sheen_tint: number("sheen_tint", m.sheen_tint, 0.0)?,
                        clearcoat: number("clearcoat", m.clearcoat, 0.0)?,
                        clearcoat_gloss: number("clearcoat_gloss", m.clearcoat_gloss, 0.0)?,
                        spec_trans,
                        flatness: number("flatness", m.flatness, 0.0)?,
                        has_transmission,
                    };
                    Bsdf::PrincipledFull(params.validate().map_err(out_of_range)?)
                }
            }
            MaterialKeys::PrincipledThin(m) => {
                let params = PrincipledThinParams {
                    base_color: colour("base_color", m.base_color, 0.5)?,
                    roughness: number("roughness", m.roughness, 0.5)?,
                    anisotropic: number("anisotropic", m.anisotropic, 0.0)?,
                    spec_trans: number("spec_trans", m.spec_trans, 0.0)?,
                    eta: number("eta", m.eta, 1.5)?,
                    spec_tint: number("spec_tint", m.spec_tint, 0.0)?,
                    sheen: number("sheen", m.sheen, 0.0)?,
                    sheen_tint: number("sheen_tint", m.sheen_tint, 0.0)?,
                    flatness: number("flatness", m.flatness, 0.0)?,
                    diff_trans: number("diff_trans", m.diff_trans, 0.0)?,
                };
                Bsdf::PrincipledThin(params.validate().map_err(out_of_range)?)
            }
        })
    }

    /// A `plastic` (or, `rough`, a `rough_plastic`) with Mitsuba's defaults:
    /// substrate 0.5, coating 1, polypropylene (1.49) in air, linear; rough:
    /// Beckmann, α 0.1, visible normals sampled.
    fn plastic(&self, field: &str, m: &PlasticKeys, rough: bool) -> Result<Bsdf> {
        use crate::bsdf::plastic::{AIR_IOR, POLYPROPYLENE_IOR};
        use crate::bsdf::{PlasticParams, RoughPlasticParams};
        let colour = |name: &str, v: Option<[f32; 3]>, default: f32| {
            self.colour(
                &format!("{field}.{name}"),
                v.unwrap_or([default; 3]),
                Some(1.0),
            )
        };
        let number = |name: &str, v: Option<f32>, default: f32| {
            self.finite(&format!("{field}.{name}"), v.unwrap_or(default))
        };
        let checked = |e: crate::bsdf::ParamError| {
            self.err(
                format!("{field}.{}", e.parameter),
                format!("must be in {}, got {}", e.range, e.value),
            )
        };
        let diffuse_reflectance = colour("diffuse_reflectance", m.diffuse_reflectance, 0.5)?;
        let specular_reflectance = colour("specular_reflectance", m.specular_reflectance, 1.0)?;
        let int_ior = number("int_ior", m.int_ior, POLYPROPYLENE_IOR)?;
        let ext_ior = number("ext_ior", m.ext_ior, AIR_IOR)?;
        let nonlinear = m.nonlinear.unwrap_or(false);
        if !rough {
            let p = PlasticParams {
                diffuse_reflectance,
                specular_reflectance,
                int_ior,
                ext_ior,
                nonlinear,
            };
            return Ok(Bsdf::Plastic(p.validate().map_err(checked)?));
        }
        let distribution = match m.distribution.as_deref().unwrap_or("beckmann") {
            "ggx" => Distribution::Ggx,
            "beckmann" => Distribution::Beckmann,
            other => {
                return Err(self.err(
                    format!("{field}.distribution"),
                    format!("unknown distribution `{other}` (known: ggx, beckmann)"),
                ))
            }
        };
        let p = RoughPlasticParams {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            ext_ior,
            nonlinear,
            distribution,
            alpha: number("alpha", m.alpha, 0.1)?,
            sample_visible: m.sample_visible.unwrap_or(true),
        };
        Ok(Bsdf::RoughPlastic(p.validate().map_err(checked)?))
    }

    /// Loads the textures a material names (`*_map`, relative to the scene
    /// file); data maps must hold values in `[0, 1]`. A normal map is
    /// decoded with `normal_scale` (default 1, in [0, 10]).
    pub(super) fn material_textures(
        &self,
        field: &str,
        keys: &MaterialKeys,
        section: &MaterialSection,
    ) -> Result<MaterialTextures> {
        let m = keys.textures();
        let mut textures = self.textures(
            field,
            m.base_color_map.map(|k| k.clone().rebased(self.base)),
            m.roughness_map.map(|k| k.clone().rebased(self.base)),
            m.metallic_map.map(|k| k.clone().rebased(self.base)),
            ["base_color_map", "roughness_map", "metallic_map"],
        )?;
        if m.normal_scale.is_some() && m.normal_map.is_none() {
            return Err(self.err(
                format!("{field}.normal_scale"),
                "only used with a normal_map",
            ));
        }
        let scale = self.finite(
            &format!("{field}.normal_scale"),
            m.normal_scale.unwrap_or(1.0),
        )?;
        if !(0.0..=10.0).contains(&scale) {
            return Err(self.err(
                format!("{field}.normal_scale"),
                format!("must be in [0, 10], got {scale}"),
            ));
        }
        if m.normal_frame.is_some() && m.normal_map.is_none() {
            return Err(self.err(
                format!("{field}.normal_frame"),
                "only used with a normal_map",
            ));
        }
        if m.normal_shadowing.is_some() && m.normal_map.is_none() && section.bump_map.is_none() {
            return Err(self.err(
                format!("{field}.normal_shadowing"),
                "only used with a normal_map or a bump_map",
            ));
        }
        if m.normal_valid_reflection.is_some()
            && m.normal_map.is_none()
            && section.bump_map.is_none()
        {
            return Err(self.err(
                format!("{field}.normal_valid_reflection"),
                "only used with a normal_map or a bump_map",
            ));
        }
        textures.alpha_u = None;
        let alpha = |key: &str, map: Option<&MapKey>| -> Result<Option<Arc<ImageTexture>>> {
            let Some(map) = map else { return Ok(None) };
            let keys = ["", key, ""];
            let t = self.textures(
                field,
                None,
                Some(map.clone().rebased(self.base)),
                None,
                keys,
            )?;
            Ok(t.roughness)
        };
        match (m.alpha_map, m.alpha_u_map, m.alpha_v_map) {
            (None, None, None) => {}
            (Some(map), None, None) => {
                let a = alpha("alpha_map", Some(map))?;
                textures.alpha_v = a.clone();
                textures.alpha_u = a;
            }
            (None, Some(u), Some(v)) => {
                textures.alpha_u = alpha("alpha_u_map", Some(u))?;
                textures.alpha_v = alpha("alpha_v_map", Some(v))?;
            }
            (Some(_), _, _) => {
                return Err(self.err(
                    format!("{field}.alpha_map"),
                    "give alpha_map, or alpha_u_map with alpha_v_map, not both",
                ))
            }
            (None, _, _) => {
                return Err(self.err(
                    format!("{field}.alpha_u_map"),
                    "alpha_u_map and alpha_v_map go together",
                ))
            }
        }
        if textures.alpha_u.is_some() && m.roughness_map.is_some() {
            return Err(self.err(
                format!("{field}.roughness_map"),
                "give roughness_map or alpha maps, not both",
            ));
        }
        if let Some(map) = &section.bump_map {
            if m.normal_map.is_some() {
                return Err(self.err(
                    format!("{field}.bump_map"),
                    "a material has a normal_map or a bump_map, not both",
                ));
            }
            let key = ["", "bump_map", ""];
            let t = self.textures(field, None, Some(map.clone().rebased(self.base)), None, key)?;
            textures.bump = t.roughness;
            let scale = self.finite(
                &format!("{field}.bump_scale"),
                section.bump_scale.unwrap_or(1.0),
            )?;
            textures.bump_scale = scale;
        } else if section.bump_scale.is_some() {
            return Err(self.err(format!("{field}.bump_scale"), "only used with a bump_map"));
        }
        for (param, map) in &m.scalars {
            let key = format!("{}_map", param.name());
            let keys = ["", key.as_str(), ""];
            let t = self.textures(
                field,
                None,
                Some((*map).clone().rebased(self.base)),
                None,
                keys,
            )?;
            // Read by its luminance, as Mitsuba reads a colour map of a weight.
            let texture = t.roughness.expect("a given map is loaded");
            textures.scalars.push(ScalarMap {
                param: *param,
                texture,
            });
        }
        textures.normal_shadowing = m.normal_shadowing.unwrap_or(false);
        textures.valid_reflection = m.normal_valid_reflection.unwrap_or(false);
        textures.normal_frame = match m.normal_frame {
            None | Some("uv") => NormalFrame::Uv,
            Some("tangent") => NormalFrame::Tangent,
            Some(other) => {
                return Err(self.err(
                    format!("{field}.normal_frame"),
                    format!("unknown frame `{other}` (known: uv, tangent)"),
                ))
            }
        };
        if let Some(path) = m.normal_map.map(|p| self.base.join(p)) {
            let f = format!("{field}.normal_map");
            let t = texture::load_for(self.file, &f, &path, Encoding::Linear)?;
            self.read_input(&path);
            if t.max_value() > 1.0 {
                return Err(self.err(f, format!("{}: values must be in [0, 1]", path.display())));
            }
            textures.normal = Some(Arc::new(t.map(|c| decode_normal(c, scale))));
        }
        Ok(textures)
    }

    /// Loads base colour (sRGB unless said otherwise), roughness and
    /// metallic (linear unless said otherwise) textures; `keys` name them in
    /// errors, under `field`.
    pub(super) fn textures(
        &self,
        field: &str,
        base_color: Option<MapKey>,
        roughness: Option<MapKey>,
        metallic: Option<MapKey>,
        keys: [&str; 3],
    ) -> Result<MaterialTextures> {
        let load = |map: Option<MapKey>,
                    key: &str,
                    encoding: Encoding|
         -> Result<Option<Arc<ImageTexture>>> {
            let Some(map) = map else {
                return Ok(None);
            };
            let f = format!("{field}.{key}");
            let encoding = map.encoding.unwrap_or(encoding);
            let t = match &map.source {
                MapSource::Attribute(name) => {
                    return Err(self.err(
                        f,
                        format!(
                            "attribute `{name}`: only base_color_map can take the mesh's colours"
                        ),
                    ))
                }
                MapSource::File(path) => {
                    let t = texture::load_for(self.file, &f, path, encoding)?;
                    self.read_input(path);
                    if encoding == Encoding::Linear && t.max_value() > 1.0 {
                        return Err(
                            self.err(f, format!("{}: values must be in [0, 1]", path.display()))
                        );
                    }
                    t
                }
                MapSource::Checkerboard([a, b]) => {
                    let decode = |c: [f32; 3]| match encoding {
                        Encoding::Srgb => Vec3::from(c.map(texture::srgb_to_linear)),
                        Encoding::Linear => Vec3::from(c),
                    };
                    // The colours are linear already unless `encoding`
                    // says they are sRGB-encoded.
                    let (a, b) = match map.encoding {
                        Some(_) => (decode(*a), decode(*b)),
                        None => (Vec3::from(*a), Vec3::from(*b)),
                    };
                    if key != "base_color_map" && a.max(b).max_element() > 1.0 {
                        return Err(self.err(f, "checkerboard values must be in [0, 1]"));
                    }
                    ImageTexture::checkerboard(a, b)
                }
            };
            Ok(Some(Arc::new(t.with_sampling(map.sampling()))))
        };
        let (base_color, base_color_attribute) = match base_color {
            Some(MapKey {
                source: MapSource::Attribute(name),
                ..
            }) => {
                if !(name.starts_with("vertex_") || name.starts_with("face_")) {
                    return Err(self.err(
                        format!("{field}.{}", keys[0]),
                        format!(
                            "attribute `{name}`: mesh colours are named vertex_… or face_… \
                             (vertex_color, face_color)"
                        ),
                    ));
                }
                (None, Some(name))
            }
            other => (other, None),
        };
        Ok(MaterialTextures {
            base_color_attribute,
            base_color: load(base_color, keys[0], Encoding::Srgb)?,
            roughness: load(roughness, keys[1], Encoding::Linear)?,
            metallic: load(metallic, keys[2], Encoding::Linear)?,
            normal: None,
            normal_frame: NormalFrame::Uv,
            normal_shadowing: false,
            valid_reflection: false,
            bump: None,
            bump_scale: 1.0,
            alpha_u: None,
            alpha_v: None,
            scalars: Vec::new(),
        })
    }

    /// The material of an MTL entry: `principled` when it has PBR keys
    /// (`Pr`, `Pm`, `map_Pr`, `map_Pm`), `blinn_phong` when it has a
    /// non-zero `Ks` (scaled down where `Kd + Ks` exceeds 1, to conserve
    /// energy), `diffuse` otherwise; `map_Kd` textures the base colour.
    pub(super) fn mtl_material(
        &self,
        field: &str,
        name: String,
        mtl: &shapes::ObjMaterial,
    ) -> Result<Material> {
        let kd = mtl.diffuse.unwrap_or(Vec3::splat(DEFAULT_REFLECTANCE));
        let pbr = mtl.roughness.is_some()
            || mtl.metallic.is_some()
            || mtl.roughness_map.is_some()
            || mtl.metallic_map.is_some();
        let ks = mtl.specular.filter(|ks| ks.max_element() > 0.0);
        let bsdf = if pbr {
            Bsdf::Principled(PrincipledParams {
                base_color: kd,
                roughness: mtl.roughness.unwrap_or(0.5),
                metallic: mtl.metallic.unwrap_or(0.0),
                anisotropic: 0.0,
                specular: 0.5,
                spec_tint: 0.0,
                energy_conserving: false,
            })
        } else if let Some(ks) = ks {
            let total = (kd + ks).max_element();
            let scale = if total > 1.0 { 1.0 / total } else { 1.0 };
            Bsdf::BlinnPhong(BlinnPhongParams {
                diffuse: kd * scale,
                specular: ks * scale,
                exponent: mtl.shininess.unwrap_or(30.0).min(1e5),
            })
        } else {
            Bsdf::diffuse(kd)
        };
        let textures = self.textures(
            &format!("{field} (MTL `{}`)", mtl.name),
            mtl.diffuse_map.clone().map(MapKey::file),
            if pbr {
                mtl.roughness_map.clone().map(MapKey::file)
            } else {
                None
            },
            if pbr {
                mtl.metallic_map.clone().map(MapKey::file)
            } else {
                None
            },
            ["map_Kd", "map_Pr", "map_Pm"],
        )?;
        Ok(Material {
            composite: None,
            name,
            bsdf,
            textures,
            two_sided: true,
        })
    }
}
