//! glTF's `KHR_materials_*` extensions onto plsr's principled models.
//!
//! A glTF material is plsr's energy-conserving two-lobe principled BSDF
//! ([`PrincipledParams`]); the extensions change it where the model can
//! express them:
//!
//! | extension | plsr |
//! | --- | --- |
//! | `KHR_materials_ior` | the dielectric specular's `η` (`specular`, for `η` in [1, 1.79]; clamped beyond, with a note) |
//! | `KHR_materials_specular` | `specularFactor` scales the dielectric `f₀` (through `specular`); a coloured `specularColorFactor` is noted, not applied |
//! | `KHR_materials_transmission` | Mitsuba's `principled` (`principled_full`) with `spec_trans` = `transmissionFactor`; thin-walled (no `KHR_materials_volume` thickness) as `principled_thin` |
//! | `KHR_materials_volume` | a thickness above 0 makes the glass a solid that refracts (clear, untextured glass of transmission 1: plsr's rough `dielectric`, GGX `α = roughness²`); its attenuation is noted, not applied (the glass is clear) |
//! | `KHR_materials_clearcoat` | `principled_full`'s clearcoat, its gloss from `clearcoatRoughnessFactor` |
//! | `KHR_materials_sheen` | `principled_full`'s sheen, white, of the colour's luminance (a coloured sheen is noted) |
//!
//! Textures of these extensions (`transmissionTexture`, `clearcoatTexture`,
//! …) are noted and their factors used alone. The full model is Mitsuba's
//! (not energy-conserving as a dielectric), so a material that needs it is
//! a few per cent brighter at grazing angles than the two-lobe one.

use crate::bsdf::models::DielectricParams;
use crate::bsdf::{
    Bsdf, Distribution, Microfacet, PrincipledFullParams, PrincipledParams, PrincipledThinParams,
};
use crate::error::FormatError;
use glam::Vec3;

/// The extensions this module reads.
pub const MATERIAL_EXTENSIONS: [&str; 6] = [
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
];

/// What a material's `KHR_materials_*` extensions ask for (their factors,
/// checked).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MaterialExtensions {
    /// `KHR_materials_ior`'s `ior`.
    pub ior: Option<f32>,
    /// `KHR_materials_specular`: `specularFactor`, `specularColorFactor`.
    pub specular: Option<(f32, Vec3)>,
    /// `KHR_materials_transmission`'s `transmissionFactor`.
    pub transmission: Option<f32>,
    /// `KHR_materials_volume`: `thicknessFactor`, `attenuationDistance`
    /// (infinite when absent), `attenuationColor`.
    pub volume: Option<(f32, f32, Vec3)>,
    /// `KHR_materials_clearcoat`: `clearcoatFactor`,
    /// `clearcoatRoughnessFactor`.
    pub clearcoat: Option<(f32, f32)>,
    /// `KHR_materials_sheen`: `sheenColorFactor`, `sheenRoughnessFactor`.
    pub sheen: Option<(Vec3, f32)>,
    /// The extensions' textures present (`KHR_materials_clearcoat.clearcoatTexture`, …).
    pub textures: Vec<String>,
}

/// Reads material `m`'s extensions; `field` is its glTF path
/// (`materials[3]`) for errors.
pub fn read(m: &gltf::Material, field: &str) -> Result<MaterialExtensions, FormatError> {
    let mut out = MaterialExtensions::default();
    for name in MATERIAL_EXTENSIONS {
        let Some(v) = m.extension_value(name) else {
            continue;
        };
        let at = format!("{field}.extensions.{name}");
        let Some(obj) = v.as_object() else {
            return Err(format!("{at}: not an object").into());
        };
        for (key, value) in obj {
            if key.ends_with("Texture") && value.is_object() {
                out.textures.push(format!("{name}.{key}"));
            }
        }
        let number = |key: &str, default: f32, lo: f32, hi: f32| -> Result<f32, FormatError> {
            match obj.get(key) {
                None => Ok(default),
                Some(v) => match v.as_f64().map(|x| x as f32) {
                    Some(x) if x >= lo && x <= hi => Ok(x),
                    _ => Err(format!("{at}.{key}: {v} is not a number in [{lo}, {hi}]").into()),
                },
            }
        };
        let colour = |key: &str, default: Vec3, hi: f32| -> Result<Vec3, FormatError> {
            match obj.get(key) {
                None => Ok(default),
                Some(v) => {
                    let c: Option<Vec<f32>> = v.as_array().filter(|a| a.len() == 3).map(|a| {
                        a.iter()
                            .filter_map(|x| x.as_f64().map(|x| x as f32))
                            .collect()
                    });
                    match c {
                        Some(c) if c.len() == 3 && c.iter().all(|x| (0.0..=hi).contains(x)) => {
                            Ok(Vec3::new(c[0], c[1], c[2]))
                        }
                        _ => {
                            Err(format!("{at}.{key}: {v} is not three numbers in [0, {hi}]").into())
                        }
                    }
                }
            }
        };
        match name {
            "KHR_materials_ior" => {
                let ior = number("ior", 1.5, 0.0, 1e3)?;
                // The spec allows 0 (a special value) or at least 1.
                if ior != 0.0 && ior < 1.0 {
                    return Err(format!("{at}.ior: {ior} is below 1").into());
                }
                out.ior = Some(if ior == 0.0 { 1.5 } else { ior });
            }
            "KHR_materials_specular" => {
                out.specular = Some((
                    number("specularFactor", 1.0, 0.0, 1.0)?,
                    colour("specularColorFactor", Vec3::ONE, f32::MAX)?,
                ));
            }
            "KHR_materials_transmission" => {
                out.transmission = Some(number("transmissionFactor", 0.0, 0.0, 1.0)?);
            }
            "KHR_materials_volume" => {
                out.volume = Some((
                    number("thicknessFactor", 0.0, 0.0, f32::MAX)?,
                    number(
                        "attenuationDistance",
                        f32::INFINITY,
                        f32::MIN_POSITIVE,
                        f32::INFINITY,
                    )?,
                    colour("attenuationColor", Vec3::ONE, 1.0)?,
                ));
            }
            "KHR_materials_clearcoat" => {
                out.clearcoat = Some((
                    number("clearcoatFactor", 0.0, 0.0, 1.0)?,
                    number("clearcoatRoughnessFactor", 0.0, 0.0, 1.0)?,
                ));
            }
            _ => {
                out.sheen = Some((
                    colour("sheenColorFactor", Vec3::ZERO, 1.0)?,
                    number("sheenRoughnessFactor", 0.0, 0.0, 1.0)?,
                ));
            }
        }
    }
    Ok(out)
}

/// The BSDF of a material whose two-lobe parameters are `p` and whose
/// extensions are `ext` (see the module's table), with a note for each
/// part plsr does not model (`name` names the material in them);
/// `textured` says whether textures vary its base colour, metallic or
/// roughness.
pub fn bsdf(
    p: PrincipledParams,
    ext: &MaterialExtensions,
    name: &str,
    textured: bool,
) -> (Bsdf, Vec<String>) {
    let mut notes = Vec::new();
    for t in &ext.textures {
        notes.push(format!(
            "material `{name}`: {t} is not used (its factor applies everywhere)"
        ));
    }
    let ior = ext.ior.unwrap_or(1.5);
    let mut f0_scale = 1.0;
    if let Some((factor, colour)) = ext.specular {
        f0_scale = factor;
        if colour != Vec3::ONE {
            notes.push(format!(
                "material `{name}`: KHR_materials_specular's specularColorFactor {colour} is not \
                 applied (plsr's principled tints its specular by the base colour only)"
            ));
        }
    }
    let transmission = ext.transmission.unwrap_or(0.0);
    let clearcoat = ext.clearcoat.filter(|c| c.0 > 0.0);
    let sheen = ext.sheen.filter(|s| s.0.max_element() > 0.0);
    let thin = ext.volume.is_none_or(|v| v.0 == 0.0);
    if let Some((_, distance, colour)) = ext.volume {
        if distance.is_finite() && colour != Vec3::ONE {
            notes.push(format!(
                "material `{name}`: KHR_materials_volume's attenuation is not applied (the glass \
                 is clear)"
            ));
        }
    }
    // Clearcoat: Mitsuba's gloss maps 0 → α = 0.1 and 1 → α = 0.001;
    // glTF's roughness r gives α = r².
    let gloss = |r: f32| ((0.1 - r * r) / 0.099).clamp(0.0, 1.0);
    // Mitsuba's sheen is white, or tinted by the base colour's hue
    // (`sheen_tint`), never by a colour of its own: a white sheen of the
    // colour's luminance, and a note where the colour is not grey.
    let (sheen_weight, sheen_tint) = match sheen {
        Some((c, _)) => {
            if c.max_element() - c.min_element() > 1e-3 {
                notes.push(format!(
                    "material `{name}`: KHR_materials_sheen's colour {c} is applied as a white \
                     sheen of its luminance (plsr's sheen takes no colour of its own)"
                ));
            }
            (crate::color::luminance(c).clamp(0.0, 1.0), 0.0)
        }
        None => (0.0, 0.0),
    };
    if transmission > 0.0 && thin {
        if clearcoat.is_some() {
            notes.push(format!(
                "material `{name}`: thin-walled glass has no clearcoat in plsr"
            ));
        }
        let bsdf = Bsdf::PrincipledThin(PrincipledThinParams {
            base_color: p.base_color,
            roughness: p.roughness,
            anisotropic: 0.0,
            spec_trans: transmission * (1.0 - p.metallic),
            eta: ior.clamp(1.0001, 10.0),
            spec_tint: 0.0,
            sheen: sheen_weight,
            sheen_tint,
            flatness: 0.0,
            diff_trans: 0.0,
        });
        return (bsdf, notes);
    }
    // Clear solid glass and nothing else: plsr's rough dielectric, which
    // agrees with Cycles' glass within 4 % on a sphere, where
    // `principled_full`'s transmission (Mitsuba's) is 10 % brighter.
    let clear = p.base_color.min_element() >= 0.999 && p.metallic == 0.0 && !textured;
    if transmission >= 0.999 && clear && clearcoat.is_none() && sheen.is_none() {
        let alpha = p.roughness * p.roughness;
        let bsdf = Bsdf::Dielectric(DielectricParams {
            eta: ior.clamp(1.0001, 10.0),
            microfacet: (alpha > 0.0).then(|| Microfacet::isotropic(Distribution::Ggx, alpha)),
        });
        return (bsdf, notes);
    }
    if transmission > 0.0 || clearcoat.is_some() || sheen.is_some() {
        let bsdf = Bsdf::PrincipledFull(PrincipledFullParams {
            base_color: p.base_color,
            roughness: p.roughness,
            metallic: p.metallic,
            anisotropic: 0.0,
            eta: ior.clamp(1.0001, 10.0),
            spec_tint: 0.0,
            sheen: sheen_weight,
            sheen_tint,
            clearcoat: clearcoat.map_or(0.0, |c| c.0),
            clearcoat_gloss: clearcoat.map_or(0.0, |c| gloss(c.1)),
            spec_trans: transmission,
            flatness: 0.0,
            has_transmission: transmission > 0.0,
        });
        return (bsdf, notes);
    }
    if ext.ior.is_none() && ext.specular.is_none() {
        return (Bsdf::Principled(p), notes);
    }
    // The two-lobe model: `specular` sets f₀ = 0.08·specular.
    let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2) * f0_scale;
    let specular = f0 / 0.08;
    if specular > 1.0 {
        notes.push(format!(
            "material `{name}`: an index of refraction of {ior} is above what plsr's principled \
             model reaches (about 1.79); it renders with 1.79"
        ));
    }
    let bsdf = Bsdf::Principled(PrincipledParams {
        specular: specular.clamp(0.0, 1.0),
        ..p
    });
    (bsdf, notes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> PrincipledParams {
        PrincipledParams {
            base_color: Vec3::new(0.8, 0.6, 0.4),
            roughness: 0.3,
            metallic: 0.0,
            anisotropic: 0.0,
            specular: 0.5,
            spec_tint: 0.0,
            energy_conserving: true,
        }
    }

    #[test]
    fn ior_and_specular_set_the_dielectric_f0() {
        // glTF's default, η = 1.5: f₀ = 0.04, plsr's `specular` 0.5.
        let (b, notes) = bsdf(base(), &MaterialExtensions::default(), "m", false);
        assert_eq!(b, Bsdf::Principled(base()));
        assert!(notes.is_empty());
        let ext = MaterialExtensions {
            ior: Some(1.33),
            specular: Some((0.5, Vec3::ONE)),
            ..Default::default()
        };
        let Bsdf::Principled(p) = bsdf(base(), &ext, "m", false).0 else {
            panic!("not the two-lobe model")
        };
        let f0 = (0.33f32 / 2.33).powi(2) * 0.5;
        assert!((p.specular - f0 / 0.08).abs() < 1e-6, "{}", p.specular);
        // Beyond what `specular` reaches: clamped, with a note.
        let ext = MaterialExtensions {
            ior: Some(2.4),
            ..Default::default()
        };
        let (b, notes) = bsdf(base(), &ext, "diamond", false);
        assert!(matches!(b, Bsdf::Principled(p) if p.specular == 1.0));
        assert!(
            notes[0].contains("diamond") && notes[0].contains("2.4"),
            "{notes:?}"
        );
    }

    #[test]
    fn clear_solid_glass_is_a_rough_dielectric() {
        let glass = PrincipledParams {
            base_color: Vec3::ONE,
            roughness: 0.1,
            ..base()
        };
        let ext = MaterialExtensions {
            transmission: Some(1.0),
            volume: Some((1.0, f32::INFINITY, Vec3::ONE)),
            ior: Some(1.45),
            ..Default::default()
        };
        let Bsdf::Dielectric(d) = bsdf(glass, &ext, "m", false).0 else {
            panic!("not a dielectric")
        };
        assert_eq!(d.eta, 1.45);
        assert_eq!(d.microfacet.map(|m| m.alpha_x), Some(0.1f32 * 0.1));
        // Tinted, textured or partly transmissive: the full model.
        assert!(matches!(
            bsdf(base(), &ext, "m", false).0,
            Bsdf::PrincipledFull(_)
        ));
        assert!(matches!(
            bsdf(glass, &ext, "m", true).0,
            Bsdf::PrincipledFull(_)
        ));
    }

    #[test]
    fn transmission_clearcoat_and_sheen_take_the_full_models() {
        // Thin-walled glass (no volume thickness).
        let ext = MaterialExtensions {
            transmission: Some(1.0),
            ior: Some(1.45),
            ..Default::default()
        };
        let Bsdf::PrincipledThin(t) = bsdf(base(), &ext, "m", false).0 else {
            panic!("not thin")
        };
        assert_eq!((t.spec_trans, t.eta), (1.0, 1.45));
        // A solid, with attenuation noted.
        let ext = MaterialExtensions {
            transmission: Some(0.8),
            volume: Some((0.1, 0.5, Vec3::new(0.9, 0.5, 0.5))),
            clearcoat: Some((1.0, 0.2)),
            sheen: Some((Vec3::new(0.5, 0.25, 0.5), 0.3)),
            textures: vec!["KHR_materials_clearcoat.clearcoatTexture".into()],
            ..Default::default()
        };
        let (b, notes) = bsdf(base(), &ext, "glass", false);
        let Bsdf::PrincipledFull(f) = b else {
            panic!("not the full model")
        };
        assert_eq!((f.spec_trans, f.clearcoat), (0.8, 1.0));
        let luminance = crate::color::luminance(Vec3::new(0.5, 0.25, 0.5));
        assert!((f.sheen - luminance).abs() < 1e-6 && f.sheen_tint == 0.0);
        assert!(f.has_transmission);
        // α = 0.2² = 0.04 → gloss (0.1 − 0.04)/0.099.
        assert!((f.clearcoat_gloss - 0.06 / 0.099).abs() < 1e-6);
        assert_eq!(notes.len(), 3, "{notes:?}");
        assert!(notes.iter().any(|n| n.contains("white sheen")));
        assert!(notes.iter().any(|n| n.contains("clearcoatTexture")));
        assert!(notes.iter().any(|n| n.contains("attenuation")));
    }
}
