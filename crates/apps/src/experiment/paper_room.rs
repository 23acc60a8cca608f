//! The paper-room: a furnished room lit by two physical fixtures, in which
//! the paper's experiment ([`crate::experiment::paper`]) is redone.
//!
//! Metres, Z up. The room is 5 m × 4 m × 2.6 m with a table, a bookcase
//! and a cabinet. A flashlight ([`Flashlight`]) clamped above the bookcase
//! points down at the floor; a ceiling lamp ([`Lamp`]) hangs over the
//! table. Object position 1 is on the floor in the flashlight's beam,
//! position 2 on the table under the lamp. The 360° camera of the panorama
//! stands in the middle of the room, outside the flashlight's beam, so the
//! panorama never sees the flashlight shine (the paper's point).
//!
//! Everything is generated here: the meshes (OBJ), the scene files of each
//! step of the experiment and the PLS file derived from the fixtures.
//! `assets/scenes/paper-room/` holds the room, its meshes and its PLS
//! lights as this writes them ([`PaperRoom::write_assets`]).

use crate::error::{Error, Result};
use crate::experiment::fixture::{Flashlight, Lamp};
use crate::experiment::mesh::MeshBuilder;
use glam::Vec3;
use plsr::light::pls::{BrightnessMode, PlsLighting};
use plsr_base::Vocabulary;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The virtual objects of the experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Object {
    /// The Stanford bunny, diffuse, 31 cm tall.
    Bunny,
    /// A rough metal ball, 12 cm in radius.
    Ball,
}

impl Object {
    /// Both objects.
    pub const ALL: [Object; 2] = [Object::Bunny, Object::Ball];

    /// Its name in file names and tables.
    pub fn name(self) -> &'static str {
        match self {
            Object::Bunny => "bunny",
            Object::Ball => "ball",
        }
    }
}

/// How a scene is lit.
#[derive(Debug, Clone, PartialEq)]
pub enum Lighting {
    /// The physical fixtures (the ground truth).
    Fixtures,
    /// The PLS lights of a PLS file.
    Pls(PathBuf),
    /// An equirectangular HDR panorama as an infinitely distant
    /// environment, with the 360° camera's zenith and forward direction.
    Panorama {
        /// The panorama (OpenEXR).
        file: PathBuf,
        /// Its zenith.
        up: Vec3,
        /// Its centre column's direction.
        forward: Vec3,
    },
}

/// Which of the real room's surfaces a scene holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Surroundings {
    /// Floor, walls, ceiling and furniture (the ground truth, and the
    /// proxy of PLS lighting, which is inside the room).
    Room,
    /// Only the surfaces near the objects, floor and table: the proxy of
    /// panorama lighting, where the walls are in the panorama, infinitely
    /// far away.
    Local,
}

/// One scene file of the experiment.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSpec {
    /// First comment line.
    pub title: String,
    /// Folder of the generated meshes, as written into the file.
    pub meshes: PathBuf,
    /// The Stanford bunny's OBJ, as written into the file.
    pub bunny: PathBuf,
    /// Which of the room's cameras takes the picture (0 or 1).
    pub camera: usize,
    /// Image size in pixels.
    pub resolution: (u32, u32),
    /// Samples per pixel.
    pub spp: u32,
    /// Random seed.
    pub seed: u64,
    /// The room's surfaces in the scene.
    pub surroundings: Surroundings,
    /// The lighting.
    pub lighting: Lighting,
    /// The objects at their positions (0 or 1), and whether each is
    /// virtual (inserted) or real.
    pub objects: Vec<(Object, usize, bool)>,
    /// The photo to composite into and its response curve (CSV).
    pub photo: Option<(PathBuf, PathBuf)>,
    /// Reflectances that replace the room's own, by material name (the
    /// albedos fitted from photos, or the fit's starting guesses).
    pub albedos: Vec<(String, [f32; 3])>,
    /// Photos to fit the scene to (instead of `photo`).
    pub fit_photos: Option<FitPhotos>,
}

/// The photos a fit compares its renders with: the first is the scene's
/// `[photo]` (taken by the spec's camera), the others `[[views]]`.
#[derive(Debug, Clone, PartialEq)]
pub struct FitPhotos {
    /// The response curve (CSV) all photos are read through.
    pub curve: PathBuf,
    /// Each photo: the camera that took it (0 or 1), its file and its
    /// exposure `k` (the exposure time: the photo divided by it is in the
    /// panorama's units).
    pub photos: Vec<(usize, PathBuf, f64)>,
}

/// Longest path the experiment traces (bounces after the camera ray).
pub const MAX_DEPTH: u32 = 5;

/// The room, its fixtures, cameras and object positions.
#[derive(Debug, Clone, PartialEq)]
pub struct PaperRoom {
    /// The flashlight.
    pub flashlight: Flashlight,
    /// The ceiling lamp.
    pub lamp: Lamp,
    /// The photographs' cameras, one framing each object position:
    /// position, look-at point, vertical field of view (degrees).
    pub cameras: [(Vec3, Vec3, f32); 2],
    /// Where the 360° camera of the panorama stands.
    pub sensor: Vec3,
    /// The object positions: the point of the floor or table each object
    /// stands on (position 1 in the flashlight's beam, 2 under the lamp).
    pub positions: [Vec3; 2],
}

/// Room extent (metres).
const ROOM: Vec3 = Vec3::new(5.0, 4.0, 2.6);
/// Table top: corners and height range.
const TABLE_MIN: Vec3 = Vec3::new(1.1, 2.0, 0.72);
const TABLE_MAX: Vec3 = Vec3::new(2.3, 2.8, 0.76);

impl Default for PaperRoom {
    fn default() -> Self {
        PaperRoom::new()
    }
}

impl PaperRoom {
    /// The room of the experiment.
    pub fn new() -> PaperRoom {
        let target = Vec3::new(3.45, 2.05, 0.0);
        let emitter = Vec3::new(4.38, 2.95, 1.95);
        let axis = (target - emitter).normalize();
        let length = 0.12;
        PaperRoom {
            flashlight: Flashlight {
                name: "flashlight".into(),
                mouth: emitter + length * axis,
                axis,
                radius: 0.02,
                length,
                radiance: 5000.0,
                color: [0.85, 0.92, 1.0],
            },
            lamp: Lamp {
                name: "lamp".into(),
                emitter_center: Vec3::new(1.7, 2.4, ROOM.z - 0.005),
                normal: Vec3::new(0.0, 0.0, -1.0),
                u: Vec3::X,
                half_size: [0.25, 0.15],
                depth: 0.08,
                radiance: 12.0,
                color: [1.0, 0.86, 0.7],
            },
            cameras: [
                (
                    Vec3::new(2.55, 0.45, 1.05),
                    target + Vec3::new(0.0, 0.0, 0.15),
                    30.0,
                ),
                (Vec3::new(2.6, 0.85, 1.55), Vec3::new(1.7, 2.4, 0.9), 30.0),
            ],
            sensor: Vec3::new(2.4, 1.3, 1.25),
            positions: [target, Vec3::new(1.7, 2.4, TABLE_MAX.z)],
        }
    }

    /// The PLS lights derived from the two fixtures (brightness mode
    /// `radiance`).
    pub fn pls(&self) -> PlsLighting {
        PlsLighting {
            mode: BrightnessMode::Radiance,
            lights: vec![self.flashlight.pls(), self.lamp.pls()],
        }
    }

    /// The generated meshes: file name and OBJ text.
    pub fn meshes(&self) -> Vec<(&'static str, String)> {
        let mut out = Vec::new();
        let mut add = |name: &'static str, what: &str, m: MeshBuilder| {
            out.push((
                name,
                m.to_obj(&format!(
                    "plsr paper-room: {what}. Metres, Z up. Generated by\nplsr::experiment::paper_room; do not edit."
                )),
            ))
        };
        let (x, y, z) = (ROOM.x, ROOM.y, ROOM.z);
        let p = Vec3::new;
        let mut floor = MeshBuilder::new();
        floor.quad(p(0., 0., 0.), p(x, 0., 0.), p(x, y, 0.), p(0., y, 0.));
        add("floor.obj", "the floor", floor);
        let mut ceiling = MeshBuilder::new();
        ceiling.quad(p(0., 0., z), p(0., y, z), p(x, y, z), p(x, 0., z));
        add("ceiling.obj", "the ceiling", ceiling);
        let mut walls = MeshBuilder::new();
        walls.quad(p(0., 0., 0.), p(0., 0., z), p(x, 0., z), p(x, 0., 0.));
        walls.quad(p(0., y, 0.), p(x, y, 0.), p(x, y, z), p(0., y, z));
        walls.quad(p(0., 0., 0.), p(0., y, 0.), p(0., y, z), p(0., 0., z));
        walls.quad(p(x, 0., 0.), p(x, 0., z), p(x, y, z), p(x, y, 0.));
        add("walls.obj", "the four walls", walls);
        let mut table = MeshBuilder::new();
        table.cuboid(TABLE_MIN, TABLE_MAX);
        for (lx, ly) in [
            (TABLE_MIN.x + 0.05, TABLE_MIN.y + 0.05),
            (TABLE_MAX.x - 0.1, TABLE_MIN.y + 0.05),
            (TABLE_MIN.x + 0.05, TABLE_MAX.y - 0.1),
            (TABLE_MAX.x - 0.1, TABLE_MAX.y - 0.1),
        ] {
            table.cuboid(p(lx, ly, 0.0), p(lx + 0.05, ly + 0.05, TABLE_MIN.z));
        }
        add("table.obj", "a table", table);
        let mut bookcase = MeshBuilder::new();
        bookcase.cuboid(p(4.45, 3.0, 0.0), p(4.95, 3.95, 1.7));
        add("bookcase.obj", "a bookcase", bookcase);
        let mut cabinet = MeshBuilder::new();
        cabinet.cuboid(p(0.15, 3.45, 0.0), p(1.05, 3.95, 0.9));
        add("cabinet.obj", "a cabinet", cabinet);
        add(
            "flashlight-emitter.obj",
            "the flashlight's emitting disk",
            self.flashlight.emitter_mesh(),
        );
        add(
            "flashlight-tube.obj",
            "the flashlight's absorbing tube",
            self.flashlight.body_mesh(),
        );
        add(
            "lamp-emitter.obj",
            "the ceiling lamp's emitting rectangle",
            self.lamp.emitter_mesh(),
        );
        add(
            "lamp-rim.obj",
            "the ceiling lamp's absorbing rim",
            self.lamp.body_mesh(),
        );
        out
    }

    /// The scene file of `spec` (TOML).
    pub fn scene_text(&self, spec: &SceneSpec) -> String {
        let mut s = String::new();
        let q = |p: &Path| toml_string(&p.to_string_lossy());
        let mesh = |name: &str| q(&spec.meshes.join(name));
        let _ = writeln!(s, "# {}", spec.title);
        let _ = writeln!(
            s,
            "# plsr's paper experiment (`plsr experiment paper`, docs/paper-experiment.md).\n# Metres, Z up. Generated by plsr::experiment::paper_room."
        );
        let _ = writeln!(
            s,
            "\n[render]\nspp = {}\nmax_depth = {MAX_DEPTH}\nseed = {}\n",
            spec.spp, spec.seed
        );
        let (pos, look, vfov) = self.cameras[spec.camera];
        let _ = writeln!(
            s,
            "[camera]\nposition = {}\nlook_at = {}\nup = [0, 0, 1]\nvfov = {vfov}\nresolution = [{}, {}]\n",
            vec3(pos),
            vec3(look),
            spec.resolution.0,
            spec.resolution.1
        );
        if let Some((photo, curve)) = &spec.photo {
            let _ = writeln!(
                s,
                "[photo]\nfile = {}\nresponse = {}\nexposure = \"auto\"\n",
                q(photo),
                q(curve)
            );
        }
        if let Some(fit) = &spec.fit_photos {
            for (i, (camera, photo, k)) in fit.photos.iter().enumerate() {
                let (file, curve) = (q(photo), q(&fit.curve));
                if i == 0 {
                    assert_eq!(*camera, spec.camera, "the first photo is the camera's");
                    let _ = writeln!(
                        s,
                        "[photo]\nfile = {file}\nresponse = {curve}\nexposure = {k}\n"
                    );
                    continue;
                }
                let photo = format!("file = {file}, response = {curve}, exposure = {k}");
                let (pos, look, vfov) = self.cameras[*camera];
                let _ = writeln!(
                    s,
                    "[[views]]\ncamera = {{ position = {}, look_at = {}, up = [0, 0, 1], vfov = {vfov}, resolution = [{}, {}] }}\nphoto = {{ {photo} }}\n",
                    vec3(pos),
                    vec3(look),
                    spec.resolution.0,
                    spec.resolution.1
                );
            }
        }
        let albedo = |name: &str, own: &'static str| -> String {
            match spec.albedos.iter().find(|(n, _)| n == name) {
                Some((_, rgb)) => format!(
                    "type = \"diffuse\"\nreflectance = [{}, {}, {}]",
                    rgb[0], rgb[1], rgb[2]
                ),
                None => own.to_string(),
            }
        };
        for (name, body) in [
            ("floor", "type = \"diffuse\"\nreflectance = [0.42, 0.33, 0.24]"),
            ("wall", "type = \"diffuse\"\nreflectance = [0.72, 0.71, 0.68]"),
            ("ceiling", "type = \"diffuse\"\nreflectance = [0.8, 0.8, 0.8]"),
            ("table", "type = \"diffuse\"\nreflectance = [0.45, 0.28, 0.16]"),
            ("bookcase", "type = \"diffuse\"\nreflectance = [0.25, 0.3, 0.4]"),
            ("cabinet", "type = \"diffuse\"\nreflectance = [0.6, 0.58, 0.5]"),
            ("black", "type = \"diffuse\"\nreflectance = [0, 0, 0]"),
            ("bunny", "type = \"diffuse\"\nreflectance = [0.78, 0.75, 0.7]"),
            (
                "metal",
                "type = \"principled\"\nbase_color = [0.92, 0.92, 0.95]\nmetallic = 1\nroughness = 0.3",
            ),
        ] {
            let body = albedo(name, body);
            let _ = writeln!(s, "[[materials]]\nname = \"{name}\"\n{body}\n");
        }
        let mut shape = |name: &str, file: &str, material: &str, extra: &str| {
            let _ = writeln!(
                s,
                "[[shapes]]\nname = \"{name}\"\ntype = \"obj\"\nfile = {}\nmaterial = \"{material}\"\n{extra}",
                mesh(file)
            );
        };
        shape("floor", "floor.obj", "floor", "");
        shape("table", "table.obj", "table", "");
        if spec.surroundings == Surroundings::Room {
            shape("walls", "walls.obj", "wall", "");
            shape("ceiling", "ceiling.obj", "ceiling", "");
            shape("bookcase", "bookcase.obj", "bookcase", "");
            shape("cabinet", "cabinet.obj", "cabinet", "");
        }
        match &spec.lighting {
            Lighting::Fixtures => {
                let f = &self.flashlight;
                let l = &self.lamp;
                let emission =
                    |c: [f32; 3], r: f32| format!("emission = {}\n", vec3(Vec3::from(c) * r));
                shape("flashlight tube", "flashlight-tube.obj", "black", "");
                shape(
                    "flashlight emitter",
                    "flashlight-emitter.obj",
                    "black",
                    &emission(f.color, f.radiance),
                );
                shape("lamp rim", "lamp-rim.obj", "black", "");
                shape(
                    "lamp emitter",
                    "lamp-emitter.obj",
                    "black",
                    &emission(l.color, l.radiance),
                );
            }
            Lighting::Pls(file) => {
                let _ = writeln!(s, "[[pls]]\nfile = {}\n", q(file));
            }
            Lighting::Panorama { file, up, forward } => {
                let _ = writeln!(
                    s,
                    "[environment]\nfile = {}\nup = {}\nforward = {}\n",
                    q(file),
                    vec3(*up),
                    vec3(*forward)
                );
            }
        }
        for &(object, position, is_virtual) in &spec.objects {
            let base = self.positions[position];
            let virtual_line = if is_virtual { "virtual = true\n" } else { "" };
            let name = format!("{} at position {}", object.name(), position + 1);
            match object {
                Object::Bunny => {
                    // Y-up in its file, 15.4 cm tall, its feet at y = 0.033:
                    // turned Z-up, doubled, and stood on `base`.
                    let t = base + Vec3::new(0.034, 0.0, -0.066);
                    let _ = writeln!(
                        s,
                        "[[shapes]]\nname = \"{name}\"\ntype = \"obj\"\nfile = {}\nmaterial = \"bunny\"\ntransform = {{ rotate = {{ axis = [1, 0, 0], angle = 90 }}, scale = 2.0, translate = {} }}\n{virtual_line}",
                        q(&spec.bunny),
                        vec3(t)
                    );
                }
                Object::Ball => {
                    let r = 0.12;
                    let _ = writeln!(
                        s,
                        "[[shapes]]\nname = \"{name}\"\ntype = \"sphere\"\nmaterial = \"metal\"\ncenter = {}\nradius = {r}\n{virtual_line}",
                        vec3(base + Vec3::new(0.0, 0.0, r))
                    );
                }
            }
        }
        s
    }

    /// Writes the meshes into `dir/meshes/`, the derived PLS lights as
    /// `dir/lights.pls.toml` and the ground-truth room (fixtures, no
    /// objects, seen by the camera of position 1) as `dir/room.toml`, at a
    /// preview's size and samples.
    pub fn write_assets(&self, dir: &Path, bunny: &Path) -> Result<()> {
        let meshes = dir.join("meshes");
        create_dir(&meshes)?;
        let mesh_files = self.meshes();
        for (name, _) in &mesh_files {
            let path = meshes.join(name);
            if plsr_base::atomic_write::same_file(&path, bunny) {
                return Err(Error::input(
                    bunny,
                    "",
                    format!(
                        "the bunny would be overwritten by the generated {}",
                        path.display()
                    ),
                ));
            }
        }
        for (name, text) in mesh_files {
            write_file(&meshes.join(name), &text)?;
        }
        let pls = self.pls();
        let pls_path = dir.join("lights.pls.toml");
        let text = plsr::light::pls::file::to_string(&pls, &pls_path)?;
        write_file(
            &pls_path,
            &format!(
                "# The PLS lights derived from the paper-room's two fixtures (generated by\n# plsr::experiment::fixture; see docs/paper-experiment.md).\n{text}"
            ),
        )?;
        let room = SceneSpec {
            title: "The paper-room as it is: both fixtures, no objects.".into(),
            meshes: PathBuf::from("meshes"),
            bunny: bunny.to_path_buf(),
            camera: 0,
            resolution: (512, 384),
            spp: 256,
            seed: 1,
            surroundings: Surroundings::Room,
            lighting: Lighting::Fixtures,
            objects: Vec::new(),
            photo: None,
            albedos: Vec::new(),
            fit_photos: None,
        };
        write_file(&dir.join("room.toml"), &self.scene_text(&room))
    }
}

fn create_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|source| Error::io(dir.to_path_buf(), source))
}

fn write_file(path: &Path, text: &str) -> Result<()> {
    plsr_base::atomic_write::write_atomically(path, |w| {
        use std::io::Write as _;
        w.write_all(text.as_bytes())
            .map_err(|source| Error::io(path.to_path_buf(), source))
    })
}

fn toml_string(s: &str) -> String {
    toml::Value::String(s.to_string()).to_string()
}

fn vec3(v: Vec3) -> String {
    let f = |x: f32| {
        let r = (x as f64 * 1e6).round() / 1e6;
        if r == 0.0 {
            "0".to_string()
        } else {
            format!("{r}")
        }
    };
    format!("[{}, {}, {}]", f(v.x), f(v.y), f(v.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_panoramas_camera_is_outside_the_flashlights_beam_and_position_1_inside() {
        let room = PaperRoom::new();
        let f = &room.flashlight;
        let angle = |p: Vec3| (p - f.mouth).normalize().dot(f.axis).acos() as f64;
        assert!(angle(room.sensor) > f.cutoff() + 10f64.to_radians());
        let pls = f.pls();
        assert!(angle(room.positions[0]) < (pls.a_deg as f64 / 2.0).to_radians());
        // Position 2 is under the lamp, outside the flashlight's beam.
        assert!(angle(room.positions[1]) > f.cutoff());
        let lamp = room.lamp.emitter_center;
        assert!(
            (lamp.x - room.positions[1].x).abs() < 1e-6
                && (lamp.y - room.positions[1].y).abs() < 1e-6
        );
    }

    #[test]
    fn scene_text_is_valid_toml_naming_the_paths_given() {
        let room = PaperRoom::new();
        let spec = SceneSpec {
            title: "t".into(),
            meshes: PathBuf::from("m\"eshes"),
            bunny: PathBuf::from("b.obj"),
            camera: 1,
            resolution: (32, 24),
            spp: 4,
            seed: 9,
            surroundings: Surroundings::Local,
            lighting: Lighting::Panorama {
                file: PathBuf::from("p.exr"),
                up: Vec3::Z,
                forward: Vec3::Y,
            },
            objects: vec![(Object::Bunny, 0, true), (Object::Ball, 1, false)],
            photo: Some((PathBuf::from("photo.png"), PathBuf::from("curve.csv"))),
            albedos: Vec::new(),
            fit_photos: None,
        };
        let text = room.scene_text(&spec);
        let v: toml::Value = toml::from_str(&text).unwrap();
        assert_eq!(v["shapes"].as_array().unwrap().len(), 4);
        assert_eq!(v["shapes"][0]["file"].as_str(), Some("m\"eshes/floor.obj"));
        assert_eq!(v["environment"]["file"].as_str(), Some("p.exr"));
        assert_eq!(v["shapes"][2]["virtual"].as_bool(), Some(true));
        assert_eq!(v["photo"]["response"].as_str(), Some("curve.csv"));
    }

    #[test]
    fn a_fit_scene_names_its_photos_their_exposures_and_the_guessed_albedos() {
        let room = PaperRoom::new();
        let spec = SceneSpec {
            title: "fit".into(),
            meshes: PathBuf::from("meshes"),
            bunny: PathBuf::from("b.obj"),
            camera: 0,
            resolution: (32, 24),
            spp: 1,
            seed: 5,
            surroundings: Surroundings::Room,
            lighting: Lighting::Pls("guess.pls.toml".into()),
            objects: Vec::new(),
            photo: None,
            albedos: vec![("wall".into(), [0.5, 0.5, 0.5])],
            fit_photos: Some(FitPhotos {
                curve: PathBuf::from("../panorama/curve.csv"),
                photos: vec![
                    (0, PathBuf::from("../photos/empty-1.png"), 0.25),
                    (1, PathBuf::from("../photos/empty-2.png"), 0.125),
                ],
            }),
        };
        let v: toml::Value = toml::from_str(&room.scene_text(&spec)).unwrap();
        assert_eq!(v["photo"]["file"].as_str(), Some("../photos/empty-1.png"));
        assert_eq!(v["photo"]["exposure"].as_float(), Some(0.25));
        assert_eq!(
            v["photo"]["response"].as_str(),
            Some("../panorama/curve.csv")
        );
        let views = v["views"].as_array().unwrap();
        assert_eq!(views.len(), 1);
        assert_eq!(views[0]["photo"]["exposure"].as_float(), Some(0.125));
        assert_eq!(
            views[0]["camera"]["resolution"].as_array().unwrap().len(),
            2
        );
        let (position, _, vfov) = room.cameras[1];
        let fov = &views[0]["camera"]["vfov"];
        let fov = fov.as_float().or(fov.as_integer().map(|i| i as f64));
        assert_eq!(fov, Some(vfov as f64));
        let x = views[0]["camera"]["position"][0].as_float().unwrap();
        assert!((x - position.x as f64).abs() < 1e-6, "{x}");
        let material = |name: &str| {
            v["materials"]
                .as_array()
                .unwrap()
                .iter()
                .find(|m| m["name"].as_str() == Some(name))
                .unwrap()
                .clone()
        };
        assert_eq!(material("wall")["reflectance"][0].as_float(), Some(0.5));
        assert_eq!(material("floor")["reflectance"][0].as_float(), Some(0.42));
    }
}
