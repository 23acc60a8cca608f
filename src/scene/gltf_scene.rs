//! glTF 2.0 files (`.gltf` with its buffers and images, or `.glb`): the
//! meshes of the default scene with their node transforms, normals,
//! texture coordinates and vertex colours (`COLOR_0`), the
//! metallic-roughness materials as plsr's `principled` BSDF (base colour,
//! metallic and roughness, factors and textures with their samplers and
//! `KHR_texture_transform`; alpha `MASK`/`BLEND` as coverage; emission
//! with its texture), cameras and punctual point lights. Its bytes come
//! only from the asset's folder, through [`super::gltf_files`].
//!
//! A scene file places a glTF like an OBJ (`type = "gltf"`), and
//! `plsr render model.glb` renders one directly (see
//! [`crate::scene::file`]). What plsr does not model is listed in
//! [`GltfScene::notes`]: occlusion textures, a second UV set, extensions
//! other than [`SUPPORTED_EXTENSIONS`], spot and directional lights,
//! orthographic cameras.
//!
//! Conventions: glTF is y-up, metres, right-handed, as plsr's scenes
//! usually are; texture coordinates have `v` pointing down the image, so
//! plsr's `v` is `1 − v`. glTF's perceptual roughness is plsr's
//! `roughness` (`α = roughness²`) and its dielectric reflectance at normal
//! incidence, 0.04, is plsr's default `specular` (0.5, `η = 1.5`).

use crate::bsdf::PrincipledParams;
use crate::error::FormatError;
use crate::material::{
    decode_normal, Composite, Layer, Material, MaterialTextures, Weight, WeightFactor,
};
use crate::texture::{srgb_to_linear, Filter, ImageTexture, PackedDecode, Sampling, Wrap};
use glam::{Mat4, Vec2, Vec3};
use plsr_base::Vocabulary;
use std::path::Path;
use std::sync::Arc;

/// The glTF extensions plsr reads besides the material extensions of
/// [`super::gltf_materials::MATERIAL_EXTENSIONS`]; others are named in a
/// note, or refused where the file requires them.
pub const SUPPORTED_EXTENSIONS: [&str; 3] = [
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_texture_transform",
];

/// Every extension plsr reads ([`SUPPORTED_EXTENSIONS`] and the material
/// extensions).
fn supported_extensions() -> impl Iterator<Item = &'static str> {
    SUPPORTED_EXTENSIONS
        .into_iter()
        .chain(super::gltf_materials::MATERIAL_EXTENSIONS)
}

/// The luminous efficacy plsr assumes to turn glTF's photometric light
/// intensities (candela) into radiant ones (W/sr): 683 lm/W.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// One triangle primitive of the default scene, in world coordinates (its
/// nodes' transforms applied).
#[derive(Debug, Clone)]
pub struct GltfObject {
    /// The mesh's name (or `mesh N`) and the primitive's index.
    pub name: String,
    /// Vertex positions (metres).
    pub positions: Vec<Vec3>,
    /// Counter-clockwise triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Unit vertex normals, or empty.
    pub normals: Vec<Vec3>,
    /// Texture coordinates (plsr's convention: `v` up) of the UV set the
    /// material's shading textures read (`TEXCOORD_n`), or empty.
    pub uvs: Vec<Vec2>,
    /// Texture coordinates of the UV set the emissive texture reads (often
    /// a second set), or empty.
    pub emission_uvs: Vec<Vec2>,
    /// Unit tangents with the bitangent's sign in `w` (glTF's `TANGENT`),
    /// or empty.
    pub tangents: Vec<glam::Vec4>,
    /// Linear vertex colours (glTF's `COLOR_0`, its alpha dropped), which
    /// multiply the base colour, or empty.
    pub colors: Vec<Vec3>,
    /// Index into [`GltfScene::materials`], or `None` for glTF's default
    /// material (white, metallic 1, roughness 1).
    pub material: Option<usize>,
}

/// A glTF camera, posed in the world.
#[derive(Debug, Clone, Copy)]
pub struct GltfCamera {
    /// Centre of projection.
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit up direction.
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub vfov_deg: f32,
    /// Width over height, if the file gives it.
    pub aspect: Option<f32>,
}

/// A punctual point light (KHR_lights_punctual).
#[derive(Debug, Clone, Copy)]
pub struct GltfPointLight {
    /// Position (metres).
    pub position: Vec3,
    /// Radiant intensity, W/sr per channel (candela ÷ [`LUMENS_PER_WATT`]).
    pub intensity: Vec3,
}

/// Everything plsr takes from a glTF file.
#[derive(Debug, Clone)]
pub struct GltfScene {
    /// Triangle primitives, in world coordinates.
    pub objects: Vec<GltfObject>,
    /// Materials, by glTF index.
    pub materials: Vec<Material>,
    /// What else each material gives (emission, sidedness), by glTF index.
    pub extras: Vec<GltfMaterialExtras>,
    /// Cameras of the default scene.
    pub cameras: Vec<GltfCamera>,
    /// Point lights of the default scene.
    pub point_lights: Vec<GltfPointLight>,
    /// What plsr leaves out, one line each.
    pub notes: Vec<String>,
    /// The other files the glTF file read (buffers, images).
    pub files: Vec<std::path::PathBuf>,
}

impl GltfScene {
    /// The bounds of every object: (min, max), or `None` without objects.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut points = self.objects.iter().flat_map(|o| o.positions.iter());
        let first = *points.next()?;
        Some(points.fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p))))
    }
}

/// Reads a glTF file (`.gltf` or `.glb`) and everything it references. The
/// error message says what is wrong; callers put the file and field in
/// front.
pub fn read_gltf(path: &Path) -> std::result::Result<GltfScene, FormatError> {
    read_gltf_at(path, 0.0)
}

/// [`read_gltf`] with the file's animations shown at `time` seconds
/// ([`super::gltf_animation`]).
pub fn read_gltf_at(path: &Path, time: f32) -> std::result::Result<GltfScene, FormatError> {
    let asset = super::gltf_files::open(path)?;
    let (doc, buffers) = (&asset.doc, &asset.buffers);
    let mut notes = Notes::default();
    for e in doc.extensions_used() {
        if !supported_extensions().any(|s| s == e) {
            let required = doc.extensions_required().any(|r| r == e);
            if required {
                return Err(format!(
                    "extensionsRequired: `{e}` is not supported (plsr reads {})",
                    supported_extensions().collect::<Vec<_>>().join(", ")
                )
                .into());
            }
            notes.add(format!(
                "extension `{e}` is not supported: the file renders without what it adds"
            ));
        }
    }

    // What moves is shown at one time.
    let poses = super::gltf_animation::poses_at(&asset.doc, buffers, time)?;
    if doc.animations().len() > 0 {
        notes.add(format!(
            "its {} animation(s) are shown at t = {time} s, not played (a `gltf` shape's \
             `time` picks another moment)",
            doc.animations().len()
        ));
    }
    if doc.skins().len() > 0 {
        notes.add(
            "its skins are not applied: skinned meshes are rendered as stored (their bind pose)"
                .to_string(),
        );
    }
    if doc
        .meshes()
        .any(|m| m.primitives().any(|p| p.morph_targets().len() > 0))
    {
        notes.add(
            "its morph targets are not applied: meshes are rendered with their base shape"
                .to_string(),
        );
    }

    // Materials: the metallic-roughness model as principled.
    let mut cache = TexelCache {
        asset: &asset,
        decoded: vec![None; doc.images().len()],
        files: Vec::new(),
    };
    let mut materials = Vec::new();
    let mut extras = Vec::new();
    for (i, m) in doc.materials().enumerate() {
        let (material, e) = read_material(i, &m, &mut cache, &mut notes)?;
        extras.push(e);
        materials.push(material);
    }

    // The default scene's nodes, with their transforms.
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or("the file has no scene")?;
    let mut objects = Vec::new();
    let mut cameras = Vec::new();
    let mut point_lights = Vec::new();
    // Depth first, in file order: the stack holds nodes in reverse.
    let mut stack: Vec<(gltf::Node, Mat4, usize)> =
        scene.nodes().map(|n| (n, Mat4::IDENTITY, 0)).collect();
    stack.reverse();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err("nodes nest deeper than 256 levels (a cycle?)".into());
        }
        let local = match poses.get(node.index()) {
            Some(p) if *p != super::gltf_animation::NodePose::default() => {
                let (t, r, sc) = node.transform().decomposed();
                Mat4::from_scale_rotation_translation(
                    p.scale.unwrap_or(Vec3::from_array(sc)),
                    p.rotation.unwrap_or(glam::Quat::from_array(r)),
                    p.translation.unwrap_or(Vec3::from_array(t)),
                )
            }
            _ => Mat4::from_cols_array_2d(&node.transform().matrix()),
        };
        let m = parent * local;
        if !m.is_finite() {
            return Err(format!("node {}: its transform is not finite", node.index()).into());
        }
        if let Some(mesh) = node.mesh() {
            let mesh_name = mesh
                .name()
                .map_or_else(|| format!("mesh {}", mesh.index()), String::from);
            for prim in mesh.primitives() {
                let first = objects.len();
                read_primitive(
                    &mesh_name,
                    &prim,
                    &m,
                    buffers,
                    &extras,
                    &mut objects,
                    &mut notes,
                )?;
                check_coordinates(&objects[first..], node.index(), mesh.index(), prim.index())?;
            }
        }
        if let Some(camera) = node.camera() {
            read_camera(&camera, &m, &mut cameras, &mut notes)?;
        }
        if let Some(light) = node.light() {
            read_light(&light, &m, &mut point_lights, &mut notes)?;
        }
        let children: Vec<_> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, m, depth + 1));
        }
    }
    let mut files = asset.files.clone();
    files.extend(cache.files);
    Ok(GltfScene {
        objects,
        materials,
        extras,
        cameras,
        point_lights,
        notes: notes.0,
        files,
    })
}

/// Every vertex, placed by its node's transform, is within plsr's
/// coordinate limit (±1e12: what Embree traces without losing the
/// scene's precision); the error names the mesh, primitive and node.
fn check_coordinates(
    objects: &[GltfObject],
    node: usize,
    mesh: usize,
    primitive: usize,
) -> std::result::Result<(), FormatError> {
    let limit = crate::accel::MAX_COORDINATE;
    for object in objects {
        if let Some((i, p)) = object
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| p.abs().max_element() > limit)
        {
            return Err(format!(
                "meshes[{mesh}].primitives[{primitive}] (node {node}): vertex {i} lands at \
                 {p}, beyond ±1e12 (plsr's coordinate limit): scale the node down"
            )
            .into());
        }
    }
    Ok(())
}

/// The import's notes, each said once.
#[derive(Default)]
struct Notes(Vec<String>);

impl Notes {
    fn add(&mut self, n: String) {
        if !self.0.contains(&n) {
            self.0.push(n);
        }
    }
}

/// The document's images, each decoded the first time a material uses it.
struct TexelCache<'a> {
    asset: &'a super::gltf_files::GltfAsset,
    decoded: Vec<Option<(u32, u32, Texels)>>,
    /// The image files read.
    files: Vec<std::path::PathBuf>,
}

/// An image's RGBA texels, decoded once and shared by the textures made
/// of it.
#[derive(Debug, Clone)]
enum Texels {
    /// 8-bit channels (most PNG and every JPEG image), as stored: 4 bytes
    /// a texel, each texture decoding them at lookup.
    Bytes(Arc<[[u8; 4]]>),
    /// 16-bit or float channels, as values in `[0, 1]` (or beyond, for
    /// float images).
    Floats(Arc<Vec<[f32; 4]>>),
}

/// A texture of image `px` (`w × h`) meaning what `decode` says (see
/// [`PackedDecode`]): 8-bit images are shared as they are; others are
/// decoded now, each value clamped to `[0, 1]` when `clamp`.
fn slot_texture(w: u32, h: u32, px: &Texels, decode: PackedDecode, clamp: bool) -> ImageTexture {
    match px {
        Texels::Bytes(bytes) => ImageTexture::packed(w, h, bytes.clone(), decode),
        Texels::Floats(floats) => texture(w, h, floats, |p| {
            let [r, g, b] = decode.channels.map(|c| {
                let v = p[c as usize & 3];
                match decode.srgb {
                    true => srgb_to_linear(v.clamp(0.0, 1.0)),
                    false => v,
                }
            });
            let v = Vec3::new(r, g, b) * decode.scale + decode.offset;
            match clamp {
                true => v.clamp(Vec3::ZERO, Vec3::ONE),
                false => v,
            }
        }),
    }
}

impl TexelCache<'_> {
    /// Image `index`: its width, height and RGBA texels.
    fn texels(&mut self, index: usize) -> std::result::Result<(u32, u32, Texels), FormatError> {
        if self.decoded.get(index).is_none() {
            return Err(format!("images[{index}] does not exist").into());
        }
        if self.decoded[index].is_none() {
            let (bytes, file) = self.asset.image_bytes(index)?;
            let (w, h, texels) = decode(&bytes).map_err(|m| format!("images[{index}]: {m}"))?;
            self.files.extend(file);
            self.decoded[index] = Some((w, h, texels));
        }
        Ok(self.decoded[index].clone().expect("decoded above"))
    }
}

/// What a glTF material gives besides plsr's [`Material`].
#[derive(Debug, Clone)]
pub struct GltfMaterialExtras {
    /// Emitted radiance (the emissive factor times
    /// `KHR_materials_emissive_strength`), W/(m²·sr).
    pub emission: Vec3,
    /// The emissive texture (linear, decoded from sRGB), which multiplies
    /// `emission` over the surface; `None` where there is none or the
    /// factor is zero.
    pub emission_map: Option<Arc<ImageTexture>>,
    /// glTF's `doubleSided`: when false, rays pass through the back faces
    /// (back-face culling, as glTF viewers draw them).
    pub double_sided: bool,
    /// The UV set (`TEXCOORD_n`) the shading textures read (base colour,
    /// metallic-roughness, normal).
    pub uv_set: u32,
    /// The UV set the emissive texture reads.
    pub emission_uv_set: u32,
    /// Whether it has a normal texture (whose meshes need tangents:
    /// MikkTSpace's where the file gives none).
    pub normal_mapped: bool,
}

/// Material `i`, the metallic-roughness model as principled with its
/// textures (each with its sampler and `KHR_texture_transform`), alpha
/// `MASK` and `BLEND` as a stochastic pass-through, and what else it gives.
fn read_material(
    i: usize,
    m: &gltf::Material,
    cache: &mut TexelCache,
    notes: &mut Notes,
) -> std::result::Result<(Material, GltfMaterialExtras), FormatError> {
    let name = m
        .name()
        .map_or_else(|| format!("material {i}"), String::from);
    let field = format!("materials[{i}]");
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, alpha] = pbr.base_color_factor();
    let factor = Vec3::new(r, g, b);
    let params = PrincipledParams {
        base_color: factor.clamp(Vec3::ZERO, Vec3::ONE),
        roughness: pbr.roughness_factor().clamp(0.0, 1.0),
        metallic: pbr.metallic_factor().clamp(0.0, 1.0),
        anisotropic: 0.0,
        specular: 0.5,
        spec_tint: 0.0,
        // glTF's BRDF mixes diffuse and specular by the Fresnel term: the
        // diffuse lobe takes what the specular one leaves.
        energy_conserving: true,
    };
    let mut t = MaterialTextures::default();
    // The UV set of each slot read, by slot.
    let mut sets: Vec<(String, u32)> = Vec::new();
    let mut slot = |slot: &str,
                    texture: gltf::Texture,
                    tex_coord: u32,
                    transform: Option<&gltf::json::Value>|
     -> std::result::Result<_, FormatError> {
        let slot_field = format!("{field}.{slot}");
        let (sampling, set) = slot_sampling(&texture, tex_coord, transform, &slot_field)?;
        sets.push((slot.to_string(), set));
        let (w, h, px) = cache.texels(texture.source().index())?;
        Ok((w, h, px, sampling))
    };
    let mut alpha_map = None;
    if let Some(info) = pbr.base_color_texture() {
        let (w, h, px, sampling) = slot(
            "pbrMetallicRoughness.baseColorTexture",
            info.texture(),
            info.tex_coord(),
            info.extension_value("KHR_texture_transform"),
        )?;
        let decode = PackedDecode::srgb_color(factor.clamp(Vec3::ZERO, Vec3::ONE));
        t.base_color = Some(Arc::new(
            slot_texture(w, h, &px, decode, true).with_sampling(sampling),
        ));
        alpha_map = Some((w, h, px, sampling));
    }
    if let Some(info) = pbr.metallic_roughness_texture() {
        let (w, h, px, sampling) = slot(
            "pbrMetallicRoughness.metallicRoughnessTexture",
            info.texture(),
            info.tex_coord(),
            info.extension_value("KHR_texture_transform"),
        )?;
        // Roughness in green, metallic in blue, each times its factor.
        let rf = params.roughness;
        let mf = params.metallic;
        t.roughness = Some(Arc::new(
            slot_texture(w, h, &px, PackedDecode::channel(1, rf), true).with_sampling(sampling),
        ));
        t.metallic = Some(Arc::new(
            slot_texture(w, h, &px, PackedDecode::channel(2, mf), true).with_sampling(sampling),
        ));
    }
    if let Some(info) = m.normal_texture() {
        let scale = info.scale();
        if !(scale.is_finite() && scale.abs() <= 10.0) {
            return Err(format!(
                "{field}.normalTexture.scale: {scale} is not in [-10, 10] (material `{name}`)"
            )
            .into());
        }
        let (w, h, px, sampling) = slot(
            "normalTexture",
            info.texture(),
            info.tex_coord(),
            info.extension_value("KHR_texture_transform"),
        )?;
        t.valid_reflection = true;
        // glTF's decoding, (2c − 1)·(scale, scale, 1): an affine map,
        // its offset the value at c = 0 and its slope from there to c = 1.
        let offset = decode_normal(Vec3::ZERO, scale);
        let decode = PackedDecode {
            channels: [0, 1, 2],
            srgb: false,
            scale: decode_normal(Vec3::ONE, scale) - offset,
            offset,
        };
        t.normal = Some(Arc::new(
            slot_texture(w, h, &px, decode, false).with_sampling(sampling),
        ));
    }
    if m.occlusion_texture().is_some() {
        notes.add(format!("material `{name}`: its occlusion texture is not used (light transport computes occlusion)"));
    }
    let strength = m.emissive_strength().unwrap_or(1.0);
    let e = Vec3::from_array(m.emissive_factor()) * strength;
    if !e.is_finite() || e.min_element() < 0.0 {
        return Err(format!(
            "{field}.emissiveFactor: {e} is not finite and non-negative (material `{name}`)"
        )
        .into());
    }
    // The emissive texture, decoded only where it can make light.
    let mut emission_map = None;
    if let Some(info) = m.emissive_texture().filter(|_| e.max_element() > 0.0) {
        let (w, h, px, sampling) = slot(
            "emissiveTexture",
            info.texture(),
            info.tex_coord(),
            info.extension_value("KHR_texture_transform"),
        )?;
        let map = slot_texture(w, h, &px, PackedDecode::srgb_color(Vec3::ONE), false);
        emission_map = Some(Arc::new(map.with_sampling(sampling)));
    }
    // The emissive texture has UVs of its own (each emitting triangle
    // carries them); the shading textures share one set per mesh.
    let emission_uv_set = sets
        .iter()
        .find(|(s, _)| s == "emissiveTexture")
        .map_or(0, |&(_, k)| k);
    let shading: Vec<&(String, u32)> = sets
        .iter()
        .filter(|(s, _)| s != "emissiveTexture")
        .collect();
    let uv_set = shading.first().map_or(0, |&&(_, k)| k);
    if shading.iter().any(|&&(_, k)| k != uv_set) {
        let list: Vec<String> = shading
            .iter()
            .map(|(s, k)| format!("{s} on TEXCOORD_{k}"))
            .collect();
        notes.add(format!(
            "material `{name}`: its textures read different UV sets ({}); plsr shades with one \
             set per mesh, so all are looked up with TEXCOORD_{uv_set}",
            list.join(", ")
        ));
    }
    let normal_mapped = t.normal.is_some();
    // The KHR_materials_* extensions (`gltf_materials`).
    let extensions = super::gltf_materials::read(m, &field)?;
    let textured = t.base_color.is_some() || t.metallic.is_some() || t.roughness.is_some();
    let (bsdf, extension_notes) = super::gltf_materials::bsdf(params, &extensions, &name, textured);
    for n in extension_notes {
        notes.add(n);
    }
    let leaf = Material {
        name,
        bsdf,
        textures: t,
        two_sided: true,
        composite: None,
    };
    let material = match alpha_coverage(m, alpha, alpha_map) {
        None => leaf,
        Some(opacity) => with_coverage(leaf, opacity),
    };
    Ok((
        material,
        GltfMaterialExtras {
            emission: e,
            emission_map,
            // Light that enters glass leaves through the back faces: a
            // transmissive material is never culled (glTF's culling hides
            // the back faces of opaque surfaces only, which no ray can see
            // from inside a closed mesh).
            double_sided: m.double_sided() || extensions.transmission.is_some_and(|t| t > 0.0),
            uv_set,
            emission_uv_set,
            normal_mapped,
        },
    ))
}

/// `m` with its base colour (and that of every part of a composite)
/// multiplied by the mesh's vertex colours (glTF's `COLOR_0`).
pub fn with_vertex_colors(mut m: Material) -> Material {
    m.textures.base_color_attribute = Some("vertex_color".into());
    if let Some(c) = &m.composite {
        let mut c = Composite::clone(c);
        for layer in c.front.iter_mut().chain(c.back.iter_mut().flatten()) {
            if let Some(leaf) = &mut layer.material {
                leaf.textures.base_color_attribute = Some("vertex_color".into());
            }
        }
        m.composite = Some(Arc::new(c));
    }
    m
}

/// The coverage of an alpha `MASK` or `BLEND` material: the base colour's
/// alpha (factor times texture), or for `MASK` whether it reaches the
/// cutoff; `None` when the surface is opaque everywhere.
fn alpha_coverage(
    m: &gltf::Material,
    factor: f32,
    map: Option<(u32, u32, Texels, Sampling)>,
) -> Option<WeightFactor> {
    use gltf::material::AlphaMode;
    let cutoff = m.alpha_cutoff().unwrap_or(0.5);
    let coverage = |a: f32| match m.alpha_mode() {
        AlphaMode::Mask => f32::from(u8::from(a >= cutoff)),
        _ => a.clamp(0.0, 1.0),
    };
    if m.alpha_mode() == AlphaMode::Opaque {
        return None;
    }
    let factor = factor.clamp(0.0, 1.0);
    match map {
        Some((w, h, px, sampling)) => Some(WeightFactor::Map {
            map: Arc::new(
                match (&px, m.alpha_mode()) {
                    // Blended: the alpha channel times the factor, as stored.
                    (Texels::Bytes(_), AlphaMode::Blend) => {
                        slot_texture(w, h, &px, PackedDecode::channel(3, factor), true)
                    }
                    // Masked: whether each texel reaches the cutoff, stored
                    // as 0 or 255 in an image of its own.
                    (Texels::Bytes(bytes), _) => {
                        let mask: Arc<[[u8; 4]]> = bytes
                            .iter()
                            .map(|p| {
                                [255 * u8::from(coverage(p[3] as f32 / 255.0 * factor) >= 1.0); 4]
                            })
                            .collect();
                        ImageTexture::packed(w, h, mask, PackedDecode::channel(0, 1.0))
                    }
                    (Texels::Floats(floats), _) => {
                        texture(w, h, floats, |p| Vec3::splat(coverage(p[3] * factor)))
                    }
                }
                .with_sampling(sampling),
            ),
            complement: false,
        }),
        None if coverage(factor) >= 1.0 => None,
        None => Some(WeightFactor::Constant(coverage(factor))),
    }
}

/// `leaf` covering the surface by `opacity`, the rest a straight
/// pass-through (as plsr's `mask` material).
fn with_coverage(leaf: Material, opacity: WeightFactor) -> Material {
    let pass = match &opacity {
        WeightFactor::Constant(c) => WeightFactor::Constant(1.0 - c),
        WeightFactor::Map { map, complement } => WeightFactor::Map {
            map: map.clone(),
            complement: !complement,
        },
    };
    let composite = Composite {
        front: vec![
            Layer {
                material: Some(leaf.clone()),
                weight: Weight(vec![opacity]),
            },
            Layer {
                material: None,
                weight: Weight(vec![pass]),
            },
        ],
        back: None,
    };
    Material {
        composite: Some(Arc::new(composite)),
        ..leaf
    }
}

/// How a texture slot looks its image up: the texture's sampler (`wrapS`,
/// `wrapT`, `magFilter`) and the slot's `KHR_texture_transform`, in plsr's
/// texture coordinates (`v` up); and the UV set it reads.
fn slot_sampling(
    texture: &gltf::Texture,
    tex_coord: u32,
    transform: Option<&gltf::json::Value>,
    field: &str,
) -> std::result::Result<(Sampling, u32), FormatError> {
    use gltf::texture::{MagFilter, WrappingMode};
    let sampler = texture.sampler();
    let wrap = |m: WrappingMode| match m {
        WrappingMode::ClampToEdge => Wrap::Clamp,
        WrappingMode::MirroredRepeat => Wrap::Mirror,
        WrappingMode::Repeat => Wrap::Repeat,
    };
    let filter = match sampler.mag_filter() {
        Some(MagFilter::Nearest) => Filter::Nearest,
        _ => Filter::Bilinear,
    };
    let mut sampling = Sampling {
        filter,
        wrap: [wrap(sampler.wrap_s()), wrap(sampler.wrap_t())],
        to_uv: None,
    };
    let Some(tt) = transform else {
        return Ok((sampling, tex_coord));
    };
    let field = format!("{field}.extensions.KHR_texture_transform");
    let number = |key: &str, default: f32| -> std::result::Result<f32, FormatError> {
        match tt.get(key) {
            None => Ok(default),
            Some(v) => v
                .as_f64()
                .map(|x| x as f32)
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{field}.{key}: {v} is not a finite number").into()),
        }
    };
    let pair = |key: &str, default: f32| -> std::result::Result<[f32; 2], FormatError> {
        match tt.get(key) {
            None => Ok([default; 2]),
            Some(v) => {
                let xs: Option<Vec<f32>> = v.as_array().and_then(|a| {
                    a.iter()
                        .map(|x| x.as_f64().map(|x| x as f32).filter(|x| x.is_finite()))
                        .collect()
                });
                match xs.as_deref() {
                    Some(&[a, b]) => Ok([a, b]),
                    _ => Err(format!("{field}.{key}: {v} is not two finite numbers").into()),
                }
            }
        }
    };
    let [ox, oy] = pair("offset", 0.0)?;
    let [sx, sy] = pair("scale", 1.0)?;
    let rotation = number("rotation", 0.0)?;
    let set = match tt.get("texCoord") {
        None => tex_coord,
        Some(v) => v
            .as_u64()
            .filter(|&s| s < 8)
            .ok_or_else(|| format!("{field}.texCoord: {v} is not a UV set 0 to 7"))?
            as u32,
    };
    // glTF's lookup (s', t') = T·R·S·(s, t) with t = 1 − v (plsr's v is
    // up), and v' = 1 − t'.
    let (sin, cos) = rotation.sin_cos();
    let (a, b, c, d) = (cos * sx, sin * sy, -sin * sx, cos * sy);
    sampling.to_uv = Some([[a, -b, b + ox], [-c, d, 1.0 - d - oy]]);
    Ok((sampling, set))
}

/// A triangle primitive of mesh `mesh_name`, placed by the node's
/// transform `m`, into `objects`; other primitives are skipped with a note.
fn read_primitive(
    mesh_name: &str,
    prim: &gltf::Primitive,
    m: &Mat4,
    buffers: &[Vec<u8>],
    extras: &[GltfMaterialExtras],
    objects: &mut Vec<GltfObject>,
    notes: &mut Notes,
) -> std::result::Result<(), FormatError> {
    let m = *m;
    let name = format!("{mesh_name}/{}", prim.index());
    if prim.mode() != gltf::mesh::Mode::Triangles {
        notes.add(format!(
            "`{name}`: {:?} primitives are skipped (plsr renders triangles)",
            prim.mode()
        ));
        return Ok(());
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d[..]));
    let mut positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| format!("`{name}` has no POSITION attribute"))?
        .map(Vec3::from_array)
        .collect();
    let n = positions.len();
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if !indices.len().is_multiple_of(3) {
        return Err(format!(
            "`{name}`: {} indices is not a whole number of triangles",
            indices.len()
        )
        .into());
    }
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(format!("`{name}`: index {bad} is past its {n} vertices").into());
    }
    let mut triangles: Vec<[u32; 3]> = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    let mut normals: Vec<Vec3> = reader
        .read_normals()
        .map(|it| it.map(Vec3::from_array).collect())
        .unwrap_or_default();
    // The UV sets the material reads: the shading textures' and the
    // emissive texture's (glTF's `v` runs down, plsr's up).
    let extra = prim.material().index().and_then(|i| extras.get(i));
    let (uv_set, emission_uv_set) = extra.map_or((0, 0), |e| (e.uv_set, e.emission_uv_set));
    let read_uvs = |set: u32| -> Option<Vec<Vec2>> {
        let t = reader.read_tex_coords(set)?;
        Some(t.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)).collect())
    };
    let read_set = |set: u32, notes: &mut Notes| -> Vec<Vec2> {
        read_uvs(set)
            .or_else(|| {
                if set != 0 {
                    notes.add(format!(
                        "`{name}`: its material reads TEXCOORD_{set}, which it does not have; \
                         TEXCOORD_0 is used"
                    ));
                }
                read_uvs(0)
            })
            .unwrap_or_default()
    };
    let mut uvs = read_set(uv_set, notes);
    let mut emission_uvs = match extra.is_some_and(|e| e.emission_map.is_some()) {
        false => Vec::new(),
        true if emission_uv_set == uv_set => uvs.clone(),
        true => read_set(emission_uv_set, notes),
    };
    // Without normals, glTF's tangents are ignored (its rule).
    let mut tangents: Vec<glam::Vec4> = match normals.is_empty() {
        true => Vec::new(),
        false => reader
            .read_tangents()
            .map(|it| it.map(glam::Vec4::from_array).collect())
            .unwrap_or_default(),
    };
    let mut colors: Vec<Vec3> = reader
        .read_colors(0)
        .map(|c| c.into_rgb_f32().map(Vec3::from_array).collect())
        .unwrap_or_default();
    if (!normals.is_empty() && normals.len() != n)
        || (!colors.is_empty() && colors.len() != n)
        || (!uvs.is_empty() && uvs.len() != n)
        || (!emission_uvs.is_empty() && emission_uvs.len() != n)
        || (!tangents.is_empty() && tangents.len() != n)
    {
        return Err(format!("`{name}`: attributes of different lengths").into());
    }
    if positions.iter().any(|p| !p.is_finite())
        || normals.iter().any(|v| !v.is_finite())
        || uvs.iter().chain(&emission_uvs).any(|v| !v.is_finite())
        || colors.iter().any(|v| !v.is_finite())
        || tangents.iter().any(|v| !v.is_finite())
    {
        return Err(format!("`{name}` has non-finite vertex data").into());
    }
    if triangles.is_empty() {
        return Ok(());
    }
    // A normal map without tangents: MikkTSpace's, as glTF asks (vertices
    // split where a seam gives their corners different tangents).
    if tangents.is_empty()
        && !normals.is_empty()
        && !uvs.is_empty()
        && extra.is_some_and(|e| e.normal_mapped)
    {
        if let Some((source, t, tris)) =
            super::gltf_tangents::mikktspace(&positions, &normals, &uvs, &triangles)
        {
            fn pick<T: Copy>(v: &[T], source: &[u32]) -> Vec<T> {
                match v.is_empty() {
                    true => Vec::new(),
                    false => source.iter().map(|&i| v[i as usize]).collect(),
                }
            }
            positions = pick(&positions, &source);
            normals = pick(&normals, &source);
            uvs = pick(&uvs, &source);
            colors = pick(&colors, &source);
            emission_uvs = pick(&emission_uvs, &source);
            tangents = t;
            triangles = tris;
        }
    }
    let world: Vec<Vec3> = positions.iter().map(|p| m.transform_point3(*p)).collect();
    if m.determinant() < 0.0 {
        // A mirroring transform turns the winding round.
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    let nm = glam::Mat3::from_mat4(m).inverse().transpose();
    for v in &mut normals {
        *v = (nm * *v).normalize_or_zero();
    }
    tangents = transform_tangents(&m, tangents);
    objects.push(GltfObject {
        name,
        positions: world,
        triangles,
        normals,
        uvs,
        emission_uvs,
        tangents,
        colors,
        material: prim.material().index(),
    });
    Ok(())
}

/// A perspective camera placed by the node's transform `m`, into
/// `cameras`; orthographic ones are skipped with a note.
fn read_camera(
    camera: &gltf::Camera,
    m: &Mat4,
    cameras: &mut Vec<GltfCamera>,
    notes: &mut Notes,
) -> std::result::Result<(), FormatError> {
    match camera.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let forward = m.transform_vector3(-Vec3::Z).normalize_or_zero();
            let up = m.transform_vector3(Vec3::Y).normalize_or_zero();
            let vfov_deg = p.yfov().to_degrees();
            if forward == Vec3::ZERO || up == Vec3::ZERO || !(vfov_deg > 0.0 && vfov_deg < 180.0) {
                return Err(format!(
                    "camera {}: degenerate pose or field of view",
                    camera.index()
                )
                .into());
            }
            cameras.push(GltfCamera {
                position: m.transform_point3(Vec3::ZERO),
                forward,
                up,
                vfov_deg,
                aspect: p.aspect_ratio().filter(|a| a.is_finite() && *a > 0.0),
            });
        }
        gltf::camera::Projection::Orthographic(_) => {
            notes.add(format!(
                "camera {}: orthographic cameras are skipped",
                camera.index()
            ));
        }
    }
    Ok(())
}

/// A point light placed by the node's transform `m`, into `point_lights`;
/// other kinds are skipped with a note.
fn read_light(
    light: &gltf::khr_lights_punctual::Light,
    m: &Mat4,
    point_lights: &mut Vec<GltfPointLight>,
    notes: &mut Notes,
) -> std::result::Result<(), FormatError> {
    let colour = Vec3::from_array(light.color()) * light.intensity() / LUMENS_PER_WATT;
    match light.kind() {
        gltf::khr_lights_punctual::Kind::Point => {
            if !colour.is_finite() || colour.min_element() < 0.0 {
                return Err(format!(
                    "light {}: intensity is not finite and non-negative",
                    light.index()
                )
                .into());
            }
            point_lights.push(GltfPointLight {
                position: m.transform_point3(Vec3::ZERO),
                intensity: colour,
            });
        }
        other => notes.add(format!(
            "light {}: {} lights are skipped (plsr imports point lights)",
            light.index(),
            match other {
                gltf::khr_lights_punctual::Kind::Directional => "directional",
                _ => "spot",
            }
        )),
    }
    Ok(())
}

/// An image's texels as RGBA in `[0, 1]` (not yet decoded from sRGB).
fn decode(bytes: &[u8]) -> std::result::Result<(u32, u32, Texels), String> {
    use image::DynamicImage::*;
    let reader = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| e.to_string())
    };
    let (w, h) = reader()?
        .into_dimensions()
        .map_err(|e| format!("not an image plsr can read: {e}"))?;
    let texels = w as u64 * h as u64;
    if texels == 0 || texels > MAX_TEXELS {
        return Err(format!(
            "an image of {w}×{h} texels (plsr reads 1 to {MAX_TEXELS})"
        ));
    }
    let mut reader = reader()?;
    let mut limits = image::Limits::default();
    limits.max_alloc = Some(texels * 16 + (1 << 20));
    reader.limits(limits);
    let image = reader
        .decode()
        .map_err(|e| format!("not an image plsr can read: {e}"))?;
    let texels = match &image {
        ImageRgb32F(_) | ImageRgba32F(_) => {
            Texels::Floats(Arc::new(image.to_rgba32f().pixels().map(|p| p.0).collect()))
        }
        ImageLuma16(_) | ImageLumaA16(_) | ImageRgb16(_) | ImageRgba16(_) => {
            Texels::Floats(Arc::new(
                image
                    .to_rgba16()
                    .pixels()
                    .map(|p| p.0.map(|c| c as f32 / 65535.0))
                    .collect(),
            ))
        }
        _ => Texels::Bytes(image.to_rgba8().pixels().map(|p| p.0).collect()),
    };
    Ok((w, h, texels))
}

/// The most texels of one glTF image (2²⁸: 16384²).
const MAX_TEXELS: u64 = 1 << 28;

/// Tangents (with the bitangent's sign in `w`) under the transform `m`: the
/// direction by its linear part, renormalised; the sign turned round by a
/// mirroring transform, so that the bitangent `w·(n × t)` of the
/// transformed normal and tangent is the transformed bitangent.
pub fn transform_tangents(m: &glam::Mat4, tangents: Vec<glam::Vec4>) -> Vec<glam::Vec4> {
    let l = glam::Mat3::from_mat4(*m);
    let mirror = if l.determinant() < 0.0 { -1.0 } else { 1.0 };
    tangents
        .into_iter()
        .map(|t| {
            let d = (l * t.truncate()).normalize_or_zero();
            let w = if t.w < 0.0 { -mirror } else { mirror };
            d.extend(w)
        })
        .collect()
}

/// A texture from RGBA texels through `f`.
fn texture(w: u32, h: u32, px: &[[f32; 4]], f: impl Fn(&[f32; 4]) -> Vec3) -> ImageTexture {
    ImageTexture::from_texels(
        w,
        h,
        px.iter()
            .map(|p| {
                let v = f(p);
                if v.is_finite() {
                    v
                } else {
                    Vec3::ZERO
                }
            })
            .collect(),
    )
}

/// Whether `path` names a glTF file (`.gltf`, `.glb`, or binary glTF's
/// magic bytes).
pub fn looks_like_gltf(path: &Path, bytes: &[u8]) -> bool {
    bytes.starts_with(b"glTF")
        || path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

/// A plsr scene that renders a glTF file as it is: the file as a `gltf`
/// shape, its first camera (or one framing its bounds), its point lights,
/// and a white sky if it has no light of its own.
#[derive(Debug, Clone)]
pub struct GltfWrapper {
    /// The scene, as TOML.
    pub toml: String,
    /// What was approximated.
    pub notes: Vec<String>,
}

/// Image width of a directly rendered glTF (its height follows the
/// camera's aspect ratio, 4:3 if it gives none).
pub const DIRECT_WIDTH: u32 = 960;

/// The radiance of the studio's sky (W/(m²·sr)): a dim fill.
pub const STUDIO_SKY: f32 = 0.3;

/// The radiance of the studio's key light (W/(m²·sr)): a square softbox
/// as wide as the model's bounding radius, 2.5 radii from its centre,
/// subtending about 0.16 sr, so that it gives about 2.5 W/m² where it
/// faces the model (the sky gives 0.94 on a surface facing up).
pub const STUDIO_KEY: f32 = 16.0;

/// The `[environment]` and key light of plsr's studio, which lights a glTF
/// without lights of its own as a viewer does: a dim grey sky, and a
/// square softbox above the camera and to its left, facing the model's
/// centre (its reflection shows the form of metals).
fn studio_toml(position: Vec3, look_at: Vec3, up: Vec3, (lo, hi): (Vec3, Vec3)) -> String {
    let centre = 0.5 * (lo + hi);
    let radius = (0.5 * (hi - lo).length()).max(1e-3);
    let forward = (look_at - position).normalize_or(Vec3::NEG_Z);
    let right = forward.cross(up).normalize_or(Vec3::X);
    let up = right.cross(forward);
    let towards = (-forward + up - 0.8 * right).normalize();
    let key = centre + 2.5 * radius * towards;
    // The rectangle's +z (its emitting side) faces the centre.
    let z = -towards;
    let x = z.any_orthonormal_vector();
    let y = z.cross(x);
    let half = 0.5 * radius;
    let row = |i: usize| {
        let (a, b, c) = (x[i] * half, y[i] * half, z[i]);
        format!("[{a}, {b}, {c}, {}]", key[i])
    };
    format!(
        "\n[environment]\nradiance = [{STUDIO_SKY}, {STUDIO_SKY}, {STUDIO_SKY}]\n\n\
         # The studio's key light: a softbox facing the model.\n[[shapes]]\n\
         type = \"rectangle\"\nemission = [{STUDIO_KEY}, {STUDIO_KEY}, {STUDIO_KEY}]\n\
         transform.matrix = [{}, {}, {}, [0, 0, 0, 1]]\n",
        row(0),
        row(1),
        row(2)
    )
}

/// The scene [`GltfWrapper`] of the glTF file `path`.
pub fn scene_toml(path: &Path) -> crate::error::Result<GltfWrapper> {
    scene_toml_at(path, 0.0)
}

/// [`scene_toml`] with the file's animations shown at `time` seconds
/// (`plsr render model.glb --anim-time 1.5`).
pub fn scene_toml_at(path: &Path, time: f32) -> crate::error::Result<GltfWrapper> {
    crate::input::check_input_file(path)?;
    if !time.is_finite() {
        return Err(crate::error::Error::invalid_argument(format!(
            "--anim-time {time}: a time in seconds must be a finite number"
        )));
    }
    let scene = read_gltf_at(path, time)
        .map_err(|m| crate::error::Error::input(path, "", m.to_string()))?;
    let mut notes = Vec::new();
    let file = path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (lo, hi) = scene.bounds().ok_or_else(|| {
        crate::error::Error::input(path, "", "the default scene has no triangles")
    })?;
    let fmt = |v: Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
    let (position, look_at, up, vfov, aspect) = match scene.cameras.first() {
        Some(c) => (
            c.position,
            c.position + c.forward,
            c.up,
            c.vfov_deg,
            c.aspect,
        ),
        None => {
            // Frame the bounding sphere from the front (+z), a little above.
            let centre = 0.5 * (lo + hi);
            let radius = (0.5 * (hi - lo).length()).max(1e-3);
            let vfov = 40.0f32;
            let distance = radius / (0.5 * vfov).to_radians().sin();
            let dir = Vec3::new(0.0, 0.25, 1.0).normalize();
            notes.push(format!(
                "{file} has no camera: one frames it from +z (vfov {vfov}°, {distance:.3} m from its centre)"
            ));
            (centre + distance * dir, centre, Vec3::Y, vfov, None)
        }
    };
    let aspect = aspect.unwrap_or(4.0 / 3.0);
    let height = ((DIRECT_WIDTH as f32 / aspect).round() as u32).clamp(1, 65536);
    let mut toml = format!(
        "# {file} rendered as it is (glTF 2.0).\n\n[camera]\nposition = {}\nlook_at = {}\nup = {}\nvfov = {vfov}\nresolution = [{DIRECT_WIDTH}, {height}]\n",
        fmt(position),
        fmt(look_at),
        fmt(up)
    );
    // Emissive materials glow, but rarely light a model as a viewer's
    // environment does: without punctual lights, the studio lights it.
    if scene.point_lights.is_empty() {
        notes.push(format!(
            "{file} has no lights: plsr's studio lights it (a grey sky of radiance \
             {STUDIO_SKY} and a key light above the camera, to its left)"
        ));
        toml.push_str(&studio_toml(position, look_at, up, (lo, hi)));
    }
    toml.push_str(&format!(
        "\n[[shapes]]\ntype = \"gltf\"\nfile = {}\n",
        toml::Value::String(file.clone())
    ));
    if time != 0.0 {
        toml.push_str(&format!("time = {time:?}\n"));
    }
    for l in &scene.point_lights {
        toml.push_str(&format!(
            "\n[[lights]]\ntype = \"point\"\nposition = {}\nintensity = {}\n",
            fmt(l.position),
            fmt(l.intensity)
        ));
    }
    Ok(GltfWrapper { toml, notes })
}
