//! `[[lights]]` (point and spot lights) and `[[pls]]` (parametric light
//! sources from PLS files).

use super::shape::TransformSection;
use super::Builder;
use crate::bsdf::Bsdf;
use crate::error::Result;
use crate::scene::{Material, Mesh};
use glam::Vec3;
use serde::Deserialize;
use std::path::PathBuf;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightSection {
    #[serde(rename = "type")]
    pub(super) kind: String,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) position: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) intensity: Option<[f32; 3]>,
    /// A spot light's beam axis.
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) direction: Option<[f32; 3]>,
    /// A spot light's cutoff, degrees (default 20).
    pub(super) cutoff_angle: Option<f32>,
    /// A spot light's full-intensity width, degrees (default ¾ cutoff).
    pub(super) beam_width: Option<f32>,
    /// A directional light's irradiance, W/m².
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) irradiance: Option<[f32; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PlsSection {
    pub(super) file: PathBuf,
    pub(super) nf: Option<u32>,
    pub(super) transform: Option<TransformSection>,
}

impl Builder<'_> {
    /// A `directional` light: `direction` (the way the light travels) and
    /// `irradiance` (W/m² on a surface facing it), as Mitsuba's
    /// `directional`.
    pub(super) fn directional_light(
        &self,
        field: &str,
        l: &LightSection,
    ) -> Result<crate::light::DirectionalLight> {
        for (key, present) in [
            ("position", l.position.is_some()),
            ("intensity", l.intensity.is_some()),
            ("cutoff_angle", l.cutoff_angle.is_some()),
            ("beam_width", l.beam_width.is_some()),
        ] {
            if present {
                return Err(self.err(
                    format!("{field}.{key}"),
                    "not used by a directional light (direction, irradiance)",
                ));
            }
        }
        let direction = l.direction.ok_or_else(|| {
            self.err(
                format!("{field}.direction"),
                "required for a directional light: the way the light travels",
            )
        })?;
        let irradiance = l.irradiance.ok_or_else(|| {
            self.err(
                format!("{field}.irradiance"),
                "required for a directional light: W/m² on a surface facing it",
            )
        })?;
        let direction = self
            .vec3(&format!("{field}.direction"), direction)?
            .try_normalize()
            .ok_or_else(|| self.err(format!("{field}.direction"), "must not be the zero vector"))?;
        Ok(crate::light::DirectionalLight {
            direction,
            irradiance: self.colour(&format!("{field}.irradiance"), irradiance, None)?,
        })
    }

    /// A `spot` light: `position`, `direction` (the beam's axis),
    /// `intensity` on the axis (W/sr), `cutoff_angle` (degrees, default 20,
    /// at most 180) and `beam_width` (degrees, default ¾ of the cutoff, at
    /// most the cutoff), as Mitsuba's `spot`.
    pub(super) fn spot_light(
        &self,
        field: &str,
        l: &LightSection,
    ) -> Result<crate::light::PointLight> {
        let required = |key: &str, v: Option<[f32; 3]>, what: &str| {
            v.ok_or_else(|| {
                self.err(
                    format!("{field}.{key}"),
                    format!("required for a spot light: {what}"),
                )
            })
        };
        if l.irradiance.is_some() {
            return Err(self.err(
                format!("{field}.irradiance"),
                "not used by a spot light (its intensity is in W/sr)",
            ));
        }
        let position = required("position", l.position, "where it is")?;
        let direction = required("direction", l.direction, "the beam's axis")?;
        let intensity = required("intensity", l.intensity, "W/sr on the axis")?;
        let position = self.vec3(&format!("{field}.position"), position)?;
        let direction = self.vec3(&format!("{field}.direction"), direction)?;
        let axis = direction
            .try_normalize()
            .ok_or_else(|| self.err(format!("{field}.direction"), "must not be the zero vector"))?;
        let intensity = self.colour(&format!("{field}.intensity"), intensity, None)?;
        let cutoff = self.finite(
            &format!("{field}.cutoff_angle"),
            l.cutoff_angle.unwrap_or(20.0),
        )?;
        if !(cutoff > 0.0 && cutoff <= 180.0) {
            return Err(self.err(
                format!("{field}.cutoff_angle"),
                format!("must be in (0, 180] degrees, got {cutoff}"),
            ));
        }
        let beam = self.finite(
            &format!("{field}.beam_width"),
            l.beam_width.unwrap_or(0.75 * cutoff),
        )?;
        if !(0.0..=cutoff).contains(&beam) {
            return Err(self.err(
                format!("{field}.beam_width"),
                format!("must be between 0 and the cutoff angle {cutoff} degrees, got {beam}"),
            ));
        }
        Ok(crate::light::PointLight {
            position,
            intensity,
            cone: Some(crate::light::spot_cone(
                axis,
                cutoff.to_radians(),
                beam.to_radians(),
            )),
        })
    }

    /// Adds the lights of a PLS file as cone-limited emissive meshes.
    pub(super) fn pls(
        &self,
        index: usize,
        s: &PlsSection,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let field = format!("pls[{index}]");
        let path = self.base.join(&s.file);
        crate::input::check_regular_file(&path).map_err(|m| {
            self.err(
                format!("{field}.file"),
                format!(
                    "{}: PLS file {m} (paths are relative to the scene file)",
                    path.display()
                ),
            )
        })?;
        // Errors inside the PLS file keep its name, light and parameter,
        // behind the scene field that referred to it.
        self.read_input(&path);
        let mut lighting = crate::light::pls::file::load(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        if let Some(t) = &s.transform {
            let m = self.transform(&format!("{field}.transform"), t)?;
            lighting = lighting.transform(&m);
            lighting.validate().map_err(|e| {
                self.err(
                    format!("{field}.transform"),
                    format!("makes {} invalid: {}", e.light, e.message),
                )
            })?;
        }
        let nf = crate::light::pls::check_nf(s.nf.unwrap_or(crate::light::pls::DEFAULT_NF) as u64)
            .map_err(|m| self.err(format!("{field}.nf"), m.to_string()))?;
        // PLS emitters do not reflect: a black material.
        let black = match materials.iter().position(|m| m.name == "(pls)") {
            Some(i) => i as u32,
            None => {
                materials.push(Material::new("(pls)", Bsdf::diffuse(Vec3::ZERO)));
                (materials.len() - 1) as u32
            }
        };
        for (k, light) in lighting.lights.iter().enumerate() {
            let name = format!("{field}/{}", light.label(k));
            meshes.push(crate::scene::pls_mesh(
                light,
                lighting.mode,
                nf,
                black,
                name,
            ));
        }
        Ok(())
    }
}
