//! `[[lights]]` (point lights) and `[[pls]]` (parametric light sources
//! from PLS files).

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
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PlsSection {
    pub(super) file: PathBuf,
    pub(super) nf: Option<u32>,
    pub(super) transform: Option<TransformSection>,
}

impl Builder<'_> {
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
