//! Structure-aware fuzzing of every parser a user's file reaches: scene
//! files (TOML, JSON and Mitsuba 3 XML), PLS files, OBJ meshes with their MTL libraries,
//! and bracket sets for `hdr merge`.
//!
//! Each generator builds inputs the way users write them — the real
//! sections, keys and value types, with values drawn from the edges
//! (zero, negative, NaN, infinity, huge, the wrong type, the wrong length)
//! — and then mutates some (a line deleted or repeated, the text cut short,
//! a byte changed, stray syntax inserted). Every input must end in `Ok` or
//! in an error that names its file; never a panic or a hang. What parses
//! must also make sense downstream: a scene that loads builds and renders
//! without NaN, a PLS light that passes tessellates into a valid mesh, a
//! merged panorama holds finite, non-negative radiance.
//!
//! The seed is fixed so that `make test` is reproducible; set
//! `PLSR_FUZZ_SEED=random` (or a number) and `PLSR_FUZZ_CASES=N` to search
//! further (`make fuzz`). A failing case is shrunk and its seed stored in
//! `proptest-regressions/`, which is committed and replayed first on every
//! run; inputs that once failed are also kept as literal cases at the end
//! of this file.

use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use plsr_hdr::merge::{merge, MergeOptions};
use plsr_hdr::oiio::{write_image, AttrValue, PixelType};
use plsr_hdr::response::ResponseMethod;
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, RngSeed};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::thread::ThreadId;
use std::time::{Duration, Instant};

// ---------------------------------------------------------------------
// Running cases: configuration, a watchdog for hangs, fixtures.
// ---------------------------------------------------------------------

/// The proptest configuration: `default_cases` cases from a fixed seed,
/// unless `PLSR_FUZZ_CASES` / `PLSR_FUZZ_SEED` say otherwise.
fn config(default_cases: u32) -> Config {
    let cases = std::env::var("PLSR_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default_cases);
    let rng_seed = match std::env::var("PLSR_FUZZ_SEED").as_deref() {
        Ok("random") => RngSeed::Random,
        Ok(n) => RngSeed::Fixed(n.parse().expect("PLSR_FUZZ_SEED: a number or `random`")),
        Err(_) => RngSeed::Fixed(DEFAULT_SEED),
    };
    Config {
        cases,
        rng_seed,
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource(
            "proptest-regressions",
        ))),
        max_shrink_iters: 4096,
        ..Config::default()
    }
}

/// The seed of `make test`'s cases (any fixed number).
const DEFAULT_SEED: u64 = 0x0915_1313;

/// How a case ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Outcome {
    /// Parsed, and what was checked downstream held.
    Accepted,
    /// Refused with a clean error.
    Refused,
}

/// Runs `cases` cases of `strategy` through `test` (shrinking and
/// persisting failures like `proptest!`), prints how they ended, and
/// checks that the generator reached both outcomes: at least `min_share`
/// of the cases of each, so that a generator that only ever produced
/// garbage (or only valid files) fails instead of passing vacuously.
fn fuzz<S: Strategy>(
    name: &'static str,
    default_cases: u32,
    min_share: f64,
    strategy: S,
    test: impl Fn(S::Value) -> Result<Outcome, TestCaseError>,
) where
    S::Value: std::fmt::Debug,
{
    let mut config = proptest::test_runner::contextualize_config(config(default_cases));
    config.source_file = Some(file!());
    config.test_name = Some(name);
    let counts = Mutex::new(HashMap::<Outcome, u32>::new());
    let mut runner = proptest::test_runner::TestRunner::new(config.clone());
    let result = runner.run(&strategy, |value| {
        let outcome = test(value)?;
        *counts.lock().unwrap().entry(outcome).or_default() += 1;
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    let counts = counts.into_inner().unwrap();
    let total: u32 = counts.values().sum();
    eprintln!("{name}: {total} cases, {counts:?}");
    for outcome in [Outcome::Accepted, Outcome::Refused] {
        let n = counts.get(&outcome).copied().unwrap_or(0);
        assert!(
            n as f64 >= min_share * total as f64,
            "{name}: only {n} of {total} cases {outcome:?}: the generator does not reach it"
        );
    }
}

/// How long one case may run before it counts as a hang.
const HANG: Duration = Duration::from_secs(60);

/// The case each test thread is running: when it started and what it is.
fn running() -> &'static Mutex<HashMap<ThreadId, (Instant, String)>> {
    static RUNNING: OnceLock<Mutex<HashMap<ThreadId, (Instant, String)>>> = OnceLock::new();
    RUNNING.get_or_init(|| {
        // A watchdog: a case past HANG prints its input and aborts the
        // test binary (a hang cannot be caught like a panic).
        std::thread::spawn(|| loop {
            std::thread::sleep(Duration::from_secs(1));
            let cases = running().lock().unwrap_or_else(|e| e.into_inner());
            for (started, input) in cases.values() {
                if started.elapsed() > HANG {
                    eprintln!("a case ran for more than {HANG:?} (a hang): {input}");
                    std::process::abort();
                }
            }
        });
        Mutex::new(HashMap::new())
    })
}

/// Runs `f` as one case described by `input`, under the watchdog.
fn case<T>(input: &str, f: impl FnOnce() -> T) -> T {
    // An abort (in C code) cannot be caught: `PLSR_FUZZ_TRACE=FILE` keeps
    // the input of the case in progress there, to find it afterwards.
    if let Some(trace) = std::env::var_os("PLSR_FUZZ_TRACE") {
        // One file per test (libtest names its threads after the tests).
        let mut trace = std::path::PathBuf::from(trace).into_os_string();
        trace.push(format!(
            ".{}",
            std::thread::current().name().unwrap_or("main")
        ));
        std::fs::write(trace, input).unwrap();
    }
    let id = std::thread::current().id();
    running()
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .insert(id, (Instant::now(), input.to_owned()));
    let out = f();
    running()
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .remove(&id);
    out
}

/// A folder holding what generated files may refer to: a valid PLS file
/// (`lights.toml`), a texture (`tex.png`), an environment (`sky.exr`), a
/// mesh (`mesh.obj` with `m.mtl`), a file of the wrong kind
/// (`notamesh.obj`, TOML text) and a folder (`folder.obj`).
fn fixtures() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy("assets/lights/paper.toml", d.join("lights.toml")).unwrap();
    let mut film = plsr::film::Film::new(4, 2);
    for (i, c) in film.color.iter_mut().enumerate() {
        *c = glam::Vec3::splat(i as f32 * 0.25);
    }
    film.write_exr(&d.join("sky.exr")).unwrap();
    film.write_png(&d.join("tex.png"), Default::default())
        .unwrap();
    std::fs::write(d.join("m.mtl"), "newmtl a\nKd 0.5 0.5 0.5\n").unwrap();
    std::fs::write(
        d.join("mesh.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(d.join("notamesh.obj"), "[camera]\ntype = \"lens\"\n").unwrap();
    std::fs::create_dir(d.join("folder.obj")).unwrap();
    dir
}

/// The error's message, checked to be clean: not empty, and naming one of
/// `names` (the file it is about).
fn clean_error(
    error: &plsr::error::Error,
    names: &[&str],
    input: &str,
) -> Result<Outcome, TestCaseError> {
    let message = error.to_string();
    if std::env::var_os("PLSR_FUZZ_VERBOSE").is_some() {
        eprintln!("refused: {message}");
    }
    prop_assert!(!message.trim().is_empty(), "empty error for {input}");
    prop_assert!(
        names.iter().any(|n| message.contains(n)),
        "the error does not name the file ({names:?}): {message}\ninput: {input}"
    );
    Ok(Outcome::Refused)
}

// ---------------------------------------------------------------------
// Values from the edges, and mutations.
// ---------------------------------------------------------------------

/// A TOML number as users write them, and the values that break code.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (-20.0f64..20.0).prop_map(|v| format!("{v:.3}")),
        2 => (0.0f64..1.0).prop_map(|v| format!("{v:.3}")),
        1 => (0i64..100).prop_map(|v| v.to_string()),
        3 => prop::sample::select(vec![
            "0", "0.0", "-0.0", "1", "-1", "0.5", "1e-30", "-1e-30", "1e30", "3.5e38",
            "1e300", "nan", "inf", "-inf", "90", "180", "65536", "4294967296",
            "-9223372036854775808", "9223372036854775807",
        ])
        .prop_map(String::from),
        1 => prop::sample::select(vec!["\"1\"", "true", "[]", "[1, 2]", "{}", "\"\""])
            .prop_map(String::from),
    ]
}

/// A TOML integer (counts: spp, depth, resolution, nf, subdivisions).
fn integer() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (1i64..16).prop_map(|v| v.to_string()),
        2 => prop::sample::select(vec![
            "0", "-1", "8", "9", "32", "4096", "4097", "65536", "16777216", "16777217",
            "4294967295", "4294967296", "9223372036854775807", "-9223372036854775808",
        ])
        .prop_map(String::from),
        1 => prop::sample::select(vec!["1.5", "\"4\"", "true", "nan"]).prop_map(String::from),
    ]
}

/// A three-vector, sometimes of the wrong length or type.
fn vec3() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => prop::collection::vec(number(), 3).prop_map(|v| format!("[{}]", v.join(", "))),
        1 => prop::collection::vec(number(), 0..6).prop_map(|v| format!("[{}]", v.join(", "))),
        1 => number(),
    ]
}

/// A colour: mostly in [0, 1].
fn colour() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => prop::collection::vec((0.0f64..1.0).prop_map(|v| format!("{v:.3}")), 3)
            .prop_map(|v| format!("[{}]", v.join(", "))),
        2 => vec3(),
    ]
}

/// A boolean, or not.
fn boolean() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => prop::sample::select(vec!["true", "false"]),
        1 => prop::sample::select(vec!["1", "\"yes\""]),
    ]
    .prop_map(String::from)
}

/// A quoted string from `choices`, or an odd one.
fn word(choices: &'static [&'static str]) -> impl Strategy<Value = String> {
    prop_oneof![
        8 => prop::sample::select(choices).prop_map(|s| format!("\"{s}\"")),
        1 => prop::sample::select(vec!["\"\"", "\"bogus\"", "1", "\"(x)\"", "\"é\""])
            .prop_map(String::from),
    ]
}

/// `key = value` lines: each of `keys` present or not.
fn keys(keys: Vec<(&'static str, BoxedStrategy<String>)>) -> BoxedStrategy<String> {
    let parts: Vec<BoxedStrategy<Option<String>>> = keys
        .into_iter()
        .map(|(k, v)| {
            prop::option::weighted(0.5, v)
                .prop_map(move |v| v.map(|v| format!("{k} = {v}\n")))
                .boxed()
        })
        .collect();
    parts
        .prop_map(|lines| lines.into_iter().flatten().collect::<String>())
        .boxed()
}

/// How a generated text is damaged, if at all.
#[derive(Debug, Clone)]
enum Mutation {
    DeleteLine(prop::sample::Index),
    RepeatLine(prop::sample::Index),
    Truncate(prop::sample::Index),
    SetByte(prop::sample::Index, u8),
    Insert(prop::sample::Index, &'static str),
}

/// No mutation (most inputs stay well-formed, to reach the deeper checks)
/// or a few.
fn mutations() -> impl Strategy<Value = Vec<Mutation>> {
    let one = prop_oneof![
        any::<prop::sample::Index>().prop_map(Mutation::DeleteLine),
        any::<prop::sample::Index>().prop_map(Mutation::RepeatLine),
        any::<prop::sample::Index>().prop_map(Mutation::Truncate),
        (any::<prop::sample::Index>(), any::<u8>()).prop_map(|(i, b)| Mutation::SetByte(i, b)),
        (
            any::<prop::sample::Index>(),
            prop::sample::select(vec![
                "[[shapes]]\n",
                "=",
                "\"",
                "]",
                "[",
                "\n[camera]\n",
                "\u{0}",
                "\u{feff}",
                "\\",
                "#",
                "'''",
                "{",
                "é",
                "\r\n",
                " = nan\n",
                "\nx = 1\n",
            ])
        )
            .prop_map(|(i, s)| Mutation::Insert(i, s)),
    ];
    prop_oneof![
        4 => Just(Vec::new()),
        1 => prop::collection::vec(one, 1..4),
    ]
}

/// `text` with `mutations` applied (bytes: a mutation may break UTF-8).
fn mutate(text: &str, mutations: &[Mutation]) -> Vec<u8> {
    let mut bytes = text.as_bytes().to_vec();
    for m in mutations {
        if bytes.is_empty() {
            break;
        }
        match m {
            Mutation::DeleteLine(i) | Mutation::RepeatLine(i) => {
                let mut lines: Vec<Vec<u8>> =
                    bytes.split(|&b| b == b'\n').map(|l| l.to_vec()).collect();
                let k = i.index(lines.len());
                if matches!(m, Mutation::DeleteLine(_)) {
                    lines.remove(k);
                } else {
                    let line = lines[k].clone();
                    lines.insert(k, line);
                }
                bytes = lines.join(&b'\n');
            }
            Mutation::Truncate(i) => bytes.truncate(i.index(bytes.len())),
            Mutation::SetByte(i, b) => {
                let k = i.index(bytes.len());
                bytes[k] = *b;
            }
            Mutation::Insert(i, s) => {
                let k = i.index(bytes.len() + 1);
                bytes.splice(k..k, s.bytes());
            }
        }
    }
    bytes
}

// ---------------------------------------------------------------------
// Scene files.
// ---------------------------------------------------------------------

/// A value that is usually `good` and now and then anything from `edge`.
fn mostly<G, E>(good: G, edge: E) -> BoxedStrategy<String>
where
    G: Strategy<Value = String> + 'static,
    E: Strategy<Value = String> + 'static,
{
    prop_oneof![24 => good, 1 => edge].boxed()
}

/// A number in `[lo, hi)`, written with three decimals.
fn within(lo: f64, hi: f64) -> BoxedStrategy<String> {
    (lo..hi).prop_map(|v| format!("{v:.3}")).boxed()
}

/// An integer in `[lo, hi)`.
fn count(lo: i64, hi: i64) -> BoxedStrategy<String> {
    (lo..hi).prop_map(|v| v.to_string()).boxed()
}

/// A three-vector with components in the given ranges.
fn point(x: (f64, f64), y: (f64, f64), z: (f64, f64)) -> BoxedStrategy<String> {
    (x.0..x.1, y.0..y.1, z.0..z.1)
        .prop_map(|(x, y, z)| format!("[{x:.3}, {y:.3}, {z:.3}]"))
        .boxed()
}

/// A colour in [0, 1]³.
fn good_colour() -> BoxedStrategy<String> {
    point((0.0, 1.0), (0.0, 1.0), (0.0, 1.0))
}

/// Now and then, one more key of any name the schema knows (or not), with
/// any value: unknown keys, keys of another type, duplicates.
fn stray_key() -> BoxedStrategy<String> {
    prop::option::weighted(
        0.08,
        (
            prop::sample::select(vec![
                "spp",
                "type",
                "position",
                "vfov",
                "fov",
                "hfov",
                "resolution",
                "radius",
                "reflectance",
                "roughness",
                "ior",
                "file",
                "emission",
                "nf",
                "up",
                "scale",
                "bogus",
                "preset",
                "alpha",
                "metal",
            ]),
            prop_oneof![number(), vec3(), word(&["x"])],
        )
            .prop_map(|(k, v)| format!("{k} = {v}\n")),
    )
    .prop_map(Option::unwrap_or_default)
    .boxed()
}

fn render_section() -> BoxedStrategy<String> {
    (
        keys(vec![
            ("spp", mostly(count(1, 4), integer())),
            ("max_depth", mostly(count(1, 6), integer())),
            ("rr_depth", mostly(count(1, 8), integer())),
            ("seed", mostly(count(0, 1000), integer())),
            ("robust", mostly(boolean(), number())),
        ]),
        stray_key(),
    )
        .prop_map(|(k, x)| format!("[render]\n{k}{x}\n"))
        .boxed()
}

fn camera_section() -> BoxedStrategy<String> {
    let resolution = mostly(
        (1i64..12, 1i64..12).prop_map(|(w, h)| format!("[{w}, {h}]")),
        prop::collection::vec(integer(), 0..4).prop_map(|v| format!("[{}]", v.join(", "))),
    );
    let kind = prop_oneof![
        12 => Just(("pinhole", "vfov")),
        4 => Just(("thin_lens", "vfov")),
        1 => Just(("dual_fisheye", "fov")),
        1 => Just(("equirectangular", "")),
        1 => Just(("perspective", "vfov")),
    ];
    (
        kind,
        mostly(point((-3.0, 3.0), (-5.0, -2.0), (0.0, 3.0)), vec3()),
        mostly(point((-0.5, 0.5), (-0.5, 0.5), (-0.5, 0.5)), vec3()),
        mostly(Just("[0, 0, 1]".to_string()), vec3()),
        mostly(within(10.0, 120.0), number()),
        resolution,
        keys(vec![
            ("aperture_radius", mostly(within(0.0, 0.1), number())),
            ("focus_distance", mostly(within(0.5, 5.0), number())),
        ]),
        stray_key(),
        prop::option::weighted(0.2, camera_path()),
    )
        .prop_map(
            |((kind, fov_key), position, look_at, up, fov, resolution, lens, stray, path)| {
                let mut s = format!(
                    "[camera]\ntype = \"{kind}\"\nposition = {position}\nlook_at = {look_at}\n\
                 up = {up}\nresolution = {resolution}\n"
                );
                if !fov_key.is_empty() {
                    s += &format!("{fov_key} = {fov}\n");
                }
                if kind == "thin_lens" {
                    s += &lens;
                }
                s + &stray + &path.unwrap_or_default()
            },
        )
        .boxed()
}

/// `[[camera.path]]` keyframes: frames mostly increasing and small, poses
/// mostly valid.
fn camera_path() -> BoxedStrategy<String> {
    let key = (
        mostly((-2i64..60).prop_map(|f| f.to_string()), integer()),
        mostly(point((-3.0, 3.0), (-5.0, -2.0), (0.0, 3.0)), vec3()),
        mostly(point((-0.5, 0.5), (-0.5, 0.5), (-0.5, 0.5)), vec3()),
        prop::option::weighted(0.3, mostly(Just("[0, 0, 1]".to_string()), vec3())),
        stray_key(),
    )
        .prop_map(|(frame, position, look_at, up, stray)| {
            let mut s = format!(
                "[[camera.path]]\nframe = {frame}\nposition = {position}\nlook_at = {look_at}\n"
            );
            if let Some(up) = up {
                s += &format!("up = {up}\n");
            }
            s + &stray
        });
    prop::collection::vec(key, 0..4)
        .prop_map(|keys| keys.concat())
        .boxed()
}

fn film_section() -> BoxedStrategy<String> {
    (
        keys(vec![
            (
                "filter",
                mostly(word(&["box", "gaussian"]), word(&["tent"])),
            ),
            ("filter_sigma", mostly(within(0.2, 1.0), number())),
            ("exposure_ev", mostly(within(-3.0, 3.0), number())),
            ("white_balance", mostly(within(3000.0, 9000.0), number())),
        ]),
        stray_key(),
    )
        .prop_map(|(k, x)| format!("[film]\n{k}{x}\n"))
        .boxed()
}

/// A material named `name`, of a random type with keys that suit it.
fn material_section(name: String) -> BoxedStrategy<String> {
    let map = || {
        mostly(
            word(&["tex.png"]),
            word(&["missing.png", "sky.exr", "folder.obj"]),
        )
    };
    let unit = || mostly(within(0.0, 1.0), number());
    let kind = prop_oneof![
        keys(vec![
            ("reflectance", mostly(good_colour(), colour())),
            ("base_color_map", map()),
            ("normal_map", map()),
            ("normal_scale", mostly(within(0.0, 2.0), number())),
        ])
        .prop_map(|k| format!("type = \"diffuse\"\n{k}")),
        keys(vec![
            (
                "diffuse",
                mostly(point((0.0, 0.5), (0.0, 0.5), (0.0, 0.5)), colour())
            ),
            (
                "specular",
                mostly(point((0.0, 0.4), (0.0, 0.4), (0.0, 0.4)), colour())
            ),
            ("exponent", mostly(within(1.0, 200.0), number())),
        ])
        .prop_map(|k| format!("type = \"blinn_phong\"\n{k}")),
        keys(vec![
            ("roughness", mostly(within(0.05, 1.0), number())),
            ("f0", mostly(good_colour(), colour())),
            (
                "distribution",
                mostly(word(&["ggx", "beckmann"]), word(&["phong"]))
            ),
        ])
        .prop_map(|k| format!("type = \"cook_torrance\"\n{k}")),
        keys(vec![
            ("ior", mostly(within(1.0, 2.5), number())),
            ("roughness", mostly(within(0.05, 1.0), number())),
        ])
        .prop_map(|k| format!("type = \"dielectric\"\n{k}")),
        keys(vec![
            ("base_color", mostly(good_colour(), colour())),
            ("roughness", unit()),
            ("metallic", unit()),
            ("anisotropic", unit()),
            ("specular", unit()),
            ("energy_conserving", mostly(boolean(), number())),
            ("roughness_map", map()),
        ])
        .prop_map(|k| format!("type = \"principled\"\n{k}")),
        Just("type = \"velvet\"\n".to_string()),
    ];
    (kind, stray_key())
        .prop_map(move |(k, x)| format!("[[materials]]\nname = \"{name}\"\n{k}{x}\n"))
        .boxed()
}

fn transform() -> BoxedStrategy<String> {
    keys(vec![
        (
            "translate",
            mostly(point((-1.0, 1.0), (-1.0, 1.0), (-1.0, 1.0)), vec3()),
        ),
        (
            "scale",
            mostly(within(0.5, 2.0), prop_oneof![number(), vec3()]),
        ),
        (
            "rotate",
            mostly(
                within(0.0, 360.0).prop_map(|a| format!("{{ axis = [0, 0, 1], angle = {a} }}")),
                (vec3(), number())
                    .prop_map(|(axis, angle)| format!("{{ axis = {axis}, angle = {angle} }}")),
            ),
        ),
    ])
}

/// A shape; `materials` are the names it may use.
fn shape_section(materials: Vec<String>) -> BoxedStrategy<String> {
    let kind = prop_oneof![
        4 => keys(vec![
            ("center", mostly(point((-1.0, 1.0), (-1.0, 1.0), (-1.0, 1.0)), vec3())),
            ("radius", mostly(within(0.1, 2.0), number())),
            ("subdivisions", mostly(count(0, 4), integer())),
            ("flip_normals", mostly(boolean(), number())),
        ])
        .prop_map(|k| format!("type = \"sphere\"\n{k}")),
        2 => Just("type = \"rectangle\"\n".to_string()),
        1 => keys(vec![
            ("segments", mostly(count(3, 64), integer())),
            ("flip_normals", mostly(boolean(), number())),
        ])
        .prop_map(|k| format!("type = \"disk\"\n{k}")),
        1 => keys(vec![("flip_normals", mostly(boolean(), number()))])
            .prop_map(|k| format!("type = \"cube\"\n{k}")),
        2 => mostly(word(&["mesh.obj"]), word(&["missing.obj", "notamesh.obj", "folder.obj"]))
            .prop_map(|f| format!("type = \"obj\"\nfile = {f}\nsmooth_normals = true\n")),
        1 => Just("type = \"teapot\"\n".to_string()),
    ];
    let material = if materials.is_empty() {
        Just(None).boxed()
    } else {
        prop::option::weighted(0.5, prop::sample::select(materials)).boxed()
    };
    (
        kind,
        material,
        keys(vec![
            ("emission", mostly(good_colour(), colour())),
            ("two_sided", mostly(boolean(), number())),
            ("virtual", mostly(boolean(), number())),
        ]),
        prop::option::weighted(0.3, transform()),
        stray_key(),
    )
        .prop_map(|(kind, material, keys, transform, stray)| {
            let mut s = format!("[[shapes]]\n{kind}{keys}{stray}");
            if let Some(m) = material {
                s += &format!("material = \"{m}\"\n");
            }
            if let Some(t) = transform {
                s += &format!("[shapes.transform]\n{t}");
            }
            s + "\n"
        })
        .boxed()
}

fn light_section() -> BoxedStrategy<String> {
    (
        mostly(Just("\"point\"".to_string()), word(&["spot"])),
        mostly(point((-3.0, 3.0), (-3.0, 3.0), (1.0, 3.0)), vec3()),
        mostly(point((0.0, 10.0), (0.0, 10.0), (0.0, 10.0)), vec3()),
        stray_key(),
    )
        .prop_map(|(kind, position, intensity, stray)| {
            format!("[[lights]]\ntype = {kind}\nposition = {position}\nintensity = {intensity}\n{stray}\n")
        })
        .boxed()
}

fn pls_section() -> BoxedStrategy<String> {
    (
        mostly(
            word(&["lights.toml"]),
            word(&["missing.toml", "mesh.obj", "sky.exr"]),
        ),
        keys(vec![("nf", mostly(count(1, 64), integer()))]),
        prop::option::weighted(0.3, transform()),
        stray_key(),
    )
        .prop_map(|(file, keys, t, stray)| {
            let mut s = format!("[[pls]]\nfile = {file}\n{keys}{stray}");
            if let Some(t) = t {
                s += &format!("[pls.transform]\n{t}");
            }
            s + "\n"
        })
        .boxed()
}

fn photo_section() -> BoxedStrategy<String> {
    (
        mostly(
            word(&["tex.png"]),
            word(&["missing.png", "sky.exr", "folder.obj"]),
        ),
        keys(vec![
            (
                "response",
                mostly(word(&["srgb", "linear"]), word(&["curve.csv", "gamma"])),
            ),
            (
                "exposure",
                mostly(within(0.1, 4.0), prop_oneof![word(&["auto"]), number()]),
            ),
        ]),
        stray_key(),
    )
        .prop_map(|(file, k, x)| format!("[photo]\nfile = {file}\n{k}{x}\n"))
        .boxed()
}

/// A `[[views]]` entry: a camera and a photo, as sub-tables.
fn view_section() -> BoxedStrategy<String> {
    (camera_section(), photo_section())
        .prop_map(|(camera, photo)| {
            format!(
                "[[views]]\n{}{}",
                camera.replacen("[camera]", "[views.camera]", 1),
                photo.replacen("[photo]", "[views.photo]", 1)
            )
        })
        .boxed()
}

fn environment_section() -> BoxedStrategy<String> {
    let source = prop_oneof![
        mostly(good_colour(), colour()).prop_map(|r| format!("radiance = {r}\n")),
        (
            mostly(
                word(&["sky.exr"]),
                word(&["tex.png", "missing.exr", "folder.obj"])
            ),
            mostly(Just("[0, 0, 1]".to_string()), vec3()),
            mostly(Just("[0, 1, 0]".to_string()), vec3()),
        )
            .prop_map(|(f, up, forward)| format!("file = {f}\nup = {up}\nforward = {forward}\n")),
    ];
    (
        source,
        keys(vec![
            ("scale", mostly(within(0.1, 2.0), number())),
            (
                "filter",
                mostly(word(&["nearest", "bilinear"]), word(&["cubic", "1"])),
            ),
        ]),
        stray_key(),
    )
        .prop_map(|(source, k, x)| format!("[environment]\n{source}{k}{x}\n"))
        .boxed()
}

/// A scene file: every section, each present or not, in file order.
fn scene_text() -> impl Strategy<Value = String> {
    (0usize..3, 0usize..4, 0usize..2, 0usize..2)
        .prop_flat_map(|(n_materials, n_shapes, n_lights, n_pls)| {
            let names: Vec<String> = ["a", "b", "c"][..n_materials]
                .iter()
                .map(|n| n.to_string())
                .collect();
            let materials: Vec<BoxedStrategy<String>> =
                names.iter().map(|n| material_section(n.clone())).collect();
            (
                prop::option::weighted(0.5, render_section()),
                prop::option::weighted(0.97, camera_section()),
                prop::option::weighted(0.3, film_section()),
                prop::option::weighted(0.4, environment_section()),
                prop::option::weighted(0.15, photo_section()),
                prop::option::weighted(0.1, view_section()),
                materials,
                prop::collection::vec(shape_section(names), n_shapes),
                prop::collection::vec(light_section(), n_lights),
                prop::collection::vec(pls_section(), n_pls),
            )
        })
        .prop_map(|(r, c, f, e, photo, view, m, s, l, p)| {
            let mut text = String::new();
            for part in [r, c, f, e, photo, view].into_iter().flatten() {
                text += &part;
            }
            for part in m.iter().chain(&s).chain(&l).chain(&p) {
                text += part;
            }
            text
        })
}

/// Loads, builds and (when small) renders a scene file; checks the outcome.
fn check_scene(
    dir: &Path,
    name: &str,
    bytes: &[u8],
    input: &str,
) -> Result<Outcome, TestCaseError> {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let desc = match plsr::scene::file::load_contents(&path) {
        Ok(contents) => contents.description,
        Err(e) => return clean_error(&e, &[name], input),
    };
    let scene = match Scene::build(desc) {
        Ok(s) => s,
        Err(e) => {
            prop_assert!(!e.to_string().is_empty());
            return Ok(Outcome::Refused);
        }
    };
    let cam = scene.camera();
    if cam.width() * cam.height() <= 144 {
        let job = RenderJob {
            spp: 1,
            max_depth: 3,
            ..scene.default_job()
        };
        let options = RenderOptions {
            threads: Some(1),
            ..Default::default()
        };
        match render(&scene, &job, &options, &|_, _| true) {
            Ok((film, _)) => {
                let bad = film.color.iter().position(|c| !c.is_finite());
                prop_assert!(bad.is_none(), "pixel {bad:?} is not finite\ninput: {input}");
            }
            Err(e) => {
                prop_assert!(!e.to_string().is_empty());
                return Ok(Outcome::Refused);
            }
        }
    }
    Ok(Outcome::Accepted)
}

/// Scene files in TOML, and the same documents in JSON.
#[test]
fn scene_files_end_in_ok_or_a_clean_error() {
    fuzz(
        "scene_files",
        3000,
        0.05,
        (scene_text(), mutations()),
        |(text, mutations)| {
            let dir = scene_fixtures();
            let bytes = mutate(&text, &mutations);
            let input = String::from_utf8_lossy(&bytes).into_owned();
            let outcome = case(&input, || {
                check_scene(dir.path(), "scene.toml", &bytes, &input)
            })?;
            // The same document as JSON (where it is a TOML document at all),
            // with the same outcome (JSON has no NaN or infinity: they
            // become null, which means absent, so those are skipped).
            if let Ok(value) = std::str::from_utf8(&bytes)
                .map_err(|_| ())
                .and_then(|t| toml::from_str::<toml::Value>(t).map_err(|_| ()))
            {
                let json = serde_json::to_string(&value).unwrap();
                if json.contains("null") {
                    return Ok(outcome);
                }
                let json_outcome = case(&json, || {
                    check_scene(dir.path(), "scene.json", json.as_bytes(), &json)
                })?;
                prop_assert_eq!(json_outcome, outcome, "TOML and JSON differ: {}", input);
            }
            Ok(outcome)
        },
    );
}

// ---------------------------------------------------------------------
// Mitsuba 3 XML scenes.
// ---------------------------------------------------------------------

/// An XML attribute value: mostly sensible, now and then from the edges
/// (TOML syntax, quotes and markup are escaped by the caller's format).
fn xml_number(lo: f64, hi: f64) -> BoxedStrategy<String> {
    prop_oneof![
        40 => within(lo, hi),
        1 => number().prop_map(|s| s.replace('"', "")),
        1 => prop::sample::select(vec!["$spp", "$nowhere", "", "1, 2", "1 2 3"]).prop_map(String::from),
    ]
    .boxed()
}

fn xml_int(lo: i64, hi: i64) -> BoxedStrategy<String> {
    prop_oneof![
        20 => count(lo, hi),
        1 => integer().prop_map(|s| s.replace('"', "")),
    ]
    .boxed()
}

fn xml_triple(lo: f64, hi: f64) -> BoxedStrategy<String> {
    prop_oneof![
        8 => (xml_number(lo, hi), xml_number(lo, hi), xml_number(lo, hi))
            .prop_map(|(a, b, c)| format!("{a}, {b}, {c}")),
        1 => xml_number(lo, hi),
    ]
    .boxed()
}

fn xml_word(choices: &'static [&'static str]) -> BoxedStrategy<String> {
    prop_oneof![
        20 => prop::sample::select(choices).prop_map(String::from),
        1 => prop::sample::select(vec!["", "bogus", "é"]).prop_map(String::from),
    ]
    .boxed()
}

fn xml_transform() -> BoxedStrategy<String> {
    let op = prop_oneof![
        xml_triple(-2.0, 2.0).prop_map(|v| format!("<translate value=\"{v}\"/>")),
        xml_triple(-2.0, 2.0).prop_map(|v| format!("<scale value=\"{v}\"/>")),
        (xml_triple(-1.0, 1.0), xml_number(-180.0, 180.0))
            .prop_map(|(a, d)| format!("<rotate value=\"{a}\" angle=\"{d}\"/>")),
        prop::collection::vec(xml_number(-2.0, 2.0), 16)
            .prop_map(|v| format!("<matrix value=\"{}\"/>", v.join(" "))),
        (xml_triple(-3.0, 3.0), xml_triple(-3.0, 3.0))
            .prop_map(|(o, t)| format!("<lookat origin=\"{o}\" target=\"{t}\" up=\"0, 1, 0\"/>")),
    ];
    prop::collection::vec(op, 0..3)
        .prop_map(|ops| format!("<transform name=\"to_world\">{}</transform>", ops.join("")))
        .boxed()
}

fn xml_bsdf() -> BoxedStrategy<String> {
    let inner = prop_oneof![
        xml_triple(0.0, 1.0).prop_map(|c| format!(
            "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{c}\"/></bsdf>"
        )),
        (xml_word(&["Au", "Ag", "Cu", "Al", "none"]), xml_word(&["ggx", "beckmann"]), xml_number(0.0, 1.0))
            .prop_map(|(m, d, a)| format!(
                "<bsdf type=\"roughconductor\"><string name=\"material\" value=\"{m}\"/>\
                 <string name=\"distribution\" value=\"{d}\"/><float name=\"alpha\" value=\"{a}\"/></bsdf>"
            )),
        xml_number(1.0, 2.0).prop_map(|i| format!(
            "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"{i}\"/></bsdf>"
        )),
        (xml_word(&["bk7", "water", "air", "diamond"]), xml_number(0.0, 1.0)).prop_map(|(i, a)| format!(
            "<bsdf type=\"roughdielectric\"><string name=\"int_ior\" value=\"{i}\"/>\
             <float name=\"alpha\" value=\"{a}\"/></bsdf>"
        )),
        (xml_triple(0.0, 1.0), xml_number(0.0, 1.0), xml_number(0.0, 1.0), xml_number(0.0, 1.0))
            .prop_map(|(c, r, m, sh)| format!(
                "<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"{c}\"/>\
                 <float name=\"roughness\" value=\"{r}\"/><float name=\"metallic\" value=\"{m}\"/>\
                 <float name=\"sheen\" value=\"{sh}\"/></bsdf>"
            )),
        Just("<bsdf type=\"plastic\"/>".to_string()),
        Just("<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\
              <string name=\"filename\" value=\"tex.png\"/></texture></bsdf>".to_string()),
    ];
    (inner, any::<bool>())
        .prop_map(|(b, two)| {
            if two {
                format!("<bsdf type=\"twosided\">{b}</bsdf>")
            } else {
                b
            }
        })
        .boxed()
}

fn xml_shape() -> BoxedStrategy<String> {
    let kind = prop_oneof![
        4 => xml_word(&["rectangle", "sphere", "disk", "cube"]).prop_map(|k| format!("<shape type=\"{k}\">")),
        1 => xml_word(&["mesh.obj", "notamesh.obj", "folder.obj", "missing.obj"]).prop_map(|f| format!(
            "<shape type=\"obj\"><string name=\"filename\" value=\"{f}\"/>"
        )),
        1 => Just("<shape type=\"ply\"><string name=\"filename\" value=\"mesh.obj\"/>".to_string()),
    ];
    let emitter = prop::option::weighted(
        0.3,
        xml_triple(0.0, 20.0).prop_map(|r| {
            format!("<emitter type=\"area\"><rgb name=\"radiance\" value=\"{r}\"/></emitter>")
        }),
    );
    (
        kind,
        xml_transform(),
        prop::option::weighted(0.8, xml_bsdf()),
        emitter,
    )
        .prop_map(|(k, t, b, e)| {
            format!(
                "{k}{t}{}{}</shape>",
                b.unwrap_or_default(),
                e.unwrap_or_default()
            )
        })
        .boxed()
}

fn xml_emitter() -> BoxedStrategy<String> {
    prop_oneof![
        (xml_triple(-3.0, 3.0), xml_triple(0.0, 10.0)).prop_map(|(p, i)| format!(
            "<emitter type=\"point\"><point name=\"position\" value=\"{p}\"/>\
             <rgb name=\"intensity\" value=\"{i}\"/></emitter>"
        )),
        xml_triple(0.0, 1.0).prop_map(|r| format!(
            "<emitter type=\"constant\"><rgb name=\"radiance\" value=\"{r}\"/></emitter>"
        )),
        (xml_transform(), xml_number(0.0, 2.0)).prop_map(|(t, s)| format!(
            "<emitter type=\"envmap\"><string name=\"filename\" value=\"sky.exr\"/>{t}\
             <float name=\"scale\" value=\"{s}\"/></emitter>"
        )),
        Just("<emitter type=\"spot\"/>".to_string()),
    ]
    .boxed()
}

fn xml_sensor() -> BoxedStrategy<String> {
    (
        xml_word(&["perspective", "thinlens"]),
        xml_number(1.0, 120.0),
        xml_word(&["x", "y", "diagonal", "smaller", "larger"]),
        xml_transform(),
        (xml_int(1, 12), xml_int(1, 12)),
        xml_word(&["box", "gaussian", "tent"]),
        xml_int(1, 4),
    )
        .prop_map(|(k, fov, axis, t, (w, h), filter, spp)| {
            format!(
                "<sensor type=\"{k}\"><float name=\"fov\" value=\"{fov}\"/>\
                 <string name=\"fov_axis\" value=\"{axis}\"/>{t}\
                 <film type=\"hdrfilm\"><integer name=\"width\" value=\"{w}\"/>\
                 <integer name=\"height\" value=\"{h}\"/><rfilter type=\"{filter}\"/></film>\
                 <sampler type=\"independent\"><integer name=\"sample_count\" value=\"{spp}\"/>\
                 </sampler></sensor>"
            )
        })
        .boxed()
}

/// A Mitsuba 3 scene from the subset plsr imports, with now and then what
/// it does not.
fn mitsuba_text() -> impl Strategy<Value = String> {
    (
        prop::option::weighted(0.5, xml_int(1, 4)),
        prop::option::weighted(0.7, xml_int(-1, 8).prop_map(|d| if d == "0" || d == "1" { "2".into() } else { d })),
        prop::option::weighted(0.9, xml_sensor()),
        prop::collection::vec(xml_shape(), 0..4),
        prop::collection::vec(xml_emitter(), 0..3),
    )
        .prop_map(|(spp, depth, sensor, shapes, emitters)| {
            let mut s = String::from("<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n");
            if let Some(spp) = spp {
                s.push_str(&format!("<default name=\"spp\" value=\"{spp}\"/>\n"));
            }
            if let Some(d) = depth {
                s.push_str(&format!(
                    "<integrator type=\"path\"><integer name=\"max_depth\" value=\"{d}\"/></integrator>\n"
                ));
            }
            for part in sensor.into_iter().chain(shapes).chain(emitters) {
                s.push_str(&part);
                s.push('\n');
            }
            s.push_str("</scene>\n");
            s
        })
}

/// Mitsuba 3 XML scenes: translated and built, or refused cleanly.
#[test]
fn mitsuba_scenes_end_in_ok_or_a_clean_error() {
    fuzz(
        "mitsuba_scenes",
        1500,
        0.05,
        (mitsuba_text(), mutations()),
        |(text, mutations)| {
            let dir = scene_fixtures();
            let bytes = mutate(&text, &mutations);
            let input = String::from_utf8_lossy(&bytes).into_owned();
            case(&input, || {
                check_scene(dir.path(), "scene.xml", &bytes, &input)
            })
        },
    );
}

/// The fixtures of the scene cases, made once per test binary.
fn scene_fixtures() -> &'static tempfile::TempDir {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(fixtures)
}

// ---------------------------------------------------------------------
// PLS files.
// ---------------------------------------------------------------------

fn pls_light() -> BoxedStrategy<String> {
    let unit = || {
        prop_oneof![
            4 => (0.0f64..=1.0).prop_map(|v| format!("{v:.3}")),
            1 => number(),
        ]
    };
    let width = || {
        prop_oneof![
            4 => (0.0f64..0.1).prop_map(|v| format!("{v:.4}")),
            1 => number(),
        ]
    };
    let d = prop_oneof![
        6 => prop::collection::vec(width(), 4).prop_map(|v| format!("[{}]", v.join(", "))),
        1 => prop::collection::vec(width(), 0..6).prop_map(|v| format!("[{}]", v.join(", "))),
    ];
    (
        keys(vec![
            ("name", word(&["lamp", "flashlight"]).boxed()),
            ("n", vec3().boxed()),
            ("a", number().boxed()),
            ("c", colour().boxed()),
            ("b", number().boxed()),
            ("e1", vec3().boxed()),
            ("e2", vec3().boxed()),
            ("alpha1", unit().boxed()),
            ("alpha2", unit().boxed()),
            ("d", d.boxed()),
            ("extra", number().boxed()),
        ]),
        // Most lights get a sensible core so that the deeper checks run.
        prop::bool::weighted(0.7),
    )
        .prop_map(|(keys, sensible)| {
            let core = if sensible {
                "n = [0, 0, -1]\na = 45\nc = [1, 1, 1]\nb = 5\ne1 = [0, 0, 2]\ne2 = [0.2, 0, 2]\n\
                 alpha1 = 0.3\nalpha2 = 0.6\nd = [0.01, 0.02, 0.02, 0.01]\n"
            } else {
                ""
            };
            // Generated keys come first: TOML refuses a key given twice,
            // which is one of the faults exercised.
            format!("[[lights]]\n{keys}{core}\n")
        })
        .boxed()
}

fn pls_text() -> impl Strategy<Value = String> {
    (
        prop::option::weighted(0.6, word(&["intensity", "power", "radiance"])),
        prop::collection::vec(pls_light(), 0..4),
    )
        .prop_map(|(mode, lights)| {
            let mut s = mode
                .map(|m| format!("brightness = {m}\n"))
                .unwrap_or_default();
            for l in lights {
                s += &l;
            }
            s
        })
}

/// PLS files; every light that passes gives a valid, finite emitter.
#[test]
fn pls_files_end_in_ok_or_a_clean_error() {
    fuzz(
        "pls_files",
        4000,
        0.05,
        (pls_text(), mutations(), 1u32..64),
        |(text, mutations, nf)| {
            let dir = tempfile::tempdir().unwrap();
            let bytes = mutate(&text, &mutations);
            let input = String::from_utf8_lossy(&bytes).into_owned();
            let path = dir.path().join("lights.toml");
            std::fs::write(&path, &bytes).unwrap();
            case(&input, || -> Result<Outcome, TestCaseError> {
                let lighting = match plsr::light::pls::file::load(&path) {
                    Err(e) => return clean_error(&e, &["lights.toml"], &input),
                    Ok(l) => l,
                };
                for light in &lighting.lights {
                    let mesh = plsr::scene::pls_mesh(light, lighting.mode, nf, 0, "fuzz".into());
                    prop_assert!(
                        mesh.validate().is_ok(),
                        "{:?}\ninput: {}",
                        mesh.validate(),
                        input
                    );
                    let e = mesh.emission.unwrap();
                    prop_assert!(
                        e.radiance.is_finite() && e.radiance.min_element() >= 0.0,
                        "radiance {}\ninput: {}",
                        e.radiance,
                        input
                    );
                }
                Ok(Outcome::Accepted)
            })
        },
    );
}

// ---------------------------------------------------------------------
// PLY meshes.
// ---------------------------------------------------------------------

/// An ASCII PLY file: vertices with or without normals and texture
/// coordinates, polygons of 3 to 5 corners, indices mostly in range.
fn ply_text() -> impl Strategy<Value = String> {
    (
        1usize..12,
        prop::bool::ANY,
        prop::bool::ANY,
        prop::collection::vec((3usize..6, prop::collection::vec(0u32..14, 5)), 0..10),
        prop::collection::vec(-2.0f32..2.0, 40),
    )
        .prop_map(|(nv, normals, uvs, faces, numbers)| {
            let mut s = format!(
                "ply\nformat ascii 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
            );
            if normals {
                s += "property float nx\nproperty float ny\nproperty float nz\n";
            }
            if uvs {
                s += "property float u\nproperty float v\n";
            }
            s += &format!(
                "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
                faces.len()
            );
            let per = 3 + 3 * normals as usize + 2 * uvs as usize;
            for v in 0..nv {
                let row: Vec<String> = (0..per)
                    .map(|k| numbers[(v * per + k) % numbers.len()].to_string())
                    .collect();
                s += &(row.join(" ") + "\n");
            }
            for (n, idx) in &faces {
                let row: Vec<String> = idx[..*n].iter().map(|i| i.to_string()).collect();
                s += &format!("{n} {}\n", row.join(" "));
            }
            s
        })
}

#[test]
fn ply_files_end_in_a_mesh_or_a_clean_error() {
    fuzz(
        "ply_files",
        3000,
        0.05,
        (ply_text(), mutations()),
        |(text, mutations)| {
            let bytes = mutate(&text, &mutations);
            let input = String::from_utf8_lossy(&bytes).into_owned();
            case(&input, || -> Result<Outcome, TestCaseError> {
                match plsr::scene::ply::parse_ply(&bytes) {
                    Err(e) => {
                        prop_assert!(!e.to_string().is_empty());
                        Ok(Outcome::Refused)
                    }
                    Ok(m) => {
                        let n = m.positions.len();
                        prop_assert!(m.triangles.iter().flatten().all(|&i| (i as usize) < n));
                        prop_assert!(m.normals.is_empty() || m.normals.len() == n);
                        prop_assert!(m.uvs.is_empty() || m.uvs.len() == n);
                        prop_assert!(m.positions.iter().all(|p| p.is_finite()));
                        Ok(Outcome::Accepted)
                    }
                }
            })
        },
    );
}

// ---------------------------------------------------------------------
// OBJ meshes and MTL libraries.
// ---------------------------------------------------------------------

fn obj_number() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (-2.0f64..2.0).prop_map(|v| format!("{v:.3}")),
        1 => prop::sample::select(vec!["nan", "inf", "-inf", "1e39", "0", "x", "1,5", ""])
            .prop_map(String::from),
    ]
}

fn obj_index() -> impl Strategy<Value = String> {
    prop_oneof![
        8 => (1i64..6).prop_map(|v| v.to_string()),
        2 => (-6i64..0).prop_map(|v| v.to_string()),
        1 => prop::sample::select(vec!["0", "99", "4294967296", "-99", "a", ""])
            .prop_map(String::from),
    ]
}

fn obj_line() -> impl Strategy<Value = String> {
    let vertex_ref =
        (obj_index(), 0usize..4, obj_index(), obj_index()).prop_map(|(v, form, t, n)| match form {
            0 => v,
            1 => format!("{v}/{t}"),
            2 => format!("{v}//{n}"),
            _ => format!("{v}/{t}/{n}"),
        });
    prop_oneof![
        6 => prop::collection::vec(obj_number(), 3).prop_map(|v| format!("v {}", v.join(" "))),
        1 => prop::collection::vec(obj_number(), 0..5).prop_map(|v| format!("v {}", v.join(" "))),
        2 => prop::collection::vec(obj_number(), 2..4).prop_map(|v| format!("vt {}", v.join(" "))),
        2 => prop::collection::vec(obj_number(), 3).prop_map(|v| format!("vn {}", v.join(" "))),
        6 => prop::collection::vec(vertex_ref, 1..6).prop_map(|v| format!("f {}", v.join(" "))),
        1 => prop::sample::select(vec![
            "o part", "g group", "s 1", "s off", "usemtl a", "usemtl b", "usemtl missing",
            "mtllib m.mtl", "mtllib missing.mtl", "mtllib m.mtl other.mtl", "mtllib",
            "l 1 2", "p 1", "", "# caf\u{e9}", "f", "v", "usemtl", "o", "\t",
        ])
        .prop_map(String::from),
    ]
}

fn mtl_line() -> impl Strategy<Value = String> {
    prop_oneof![
        2 => prop::sample::select(vec!["newmtl a", "newmtl b", "newmtl"]).prop_map(String::from),
        4 => (
            prop::sample::select(vec!["Kd", "Ka", "Ks", "Ke", "Tf"]),
            prop::collection::vec(obj_number(), 0..5)
        )
            .prop_map(|(k, v)| format!("{k} {}", v.join(" "))),
        3 => (
            prop::sample::select(vec!["Ns", "Ni", "d", "Tr", "illum", "Pr", "Pm", "Ps"]),
            prop::collection::vec(obj_number(), 0..3)
        )
            .prop_map(|(k, v)| format!("{k} {}", v.join(" "))),
        1 => (
            prop::sample::select(vec!["map_Kd", "map_Pr", "map_Pm", "map_Bump", "norm"]),
            prop::sample::select(vec!["tex.png", "missing.png", "sky.exr", "", "a b.png"])
        )
            .prop_map(|(k, f)| format!("{k} {f}")),
        1 => prop::sample::select(vec!["", "# x", "garbage", "Kd", "\u{0}"]).prop_map(String::from),
    ]
}

/// OBJ files and their MTL libraries, through a scene that loads them.
#[test]
fn obj_and_mtl_files_end_in_ok_or_a_clean_error() {
    // Most files start from a valid mesh, so that the stray lines after
    // it meet a parser in a meaningful state.
    let obj = prop_oneof![
        3 => prop::collection::vec(obj_line(), 0..4).prop_map(|extra| {
            let mut lines: Vec<String> = [
                "v 0 0 0", "v 1 0 0", "v 0 1 0", "v 1 1 0", "vt 0 0", "vt 1 0", "vt 0 1",
                "vn 0 0 1", "usemtl a", "f 1/1/1 2/2/1 3/3/1", "f 2 4 3",
            ]
            .iter()
            .map(|l| l.to_string())
            .collect();
            lines.extend(extra);
            lines
        }),
        1 => prop::collection::vec(obj_line(), 0..14),
    ];
    let mtl = prop_oneof![
        3 => prop::collection::vec(mtl_line(), 0..3).prop_map(|extra| {
            let mut lines = vec!["newmtl a".to_string(), "Kd 0.5 0.5 0.5".to_string()];
            lines.extend(extra);
            lines
        }),
        1 => prop::collection::vec(mtl_line(), 0..8),
    ];
    let strategy = (
        obj,
        mtl,
        mutations(),
        mutations(),
        prop::bool::weighted(0.7),
    );
    fuzz(
        "obj_and_mtl_files",
        4000,
        0.05,
        strategy,
        |(obj, mtl, obj_mutations, mtl_mutations, with_library)| {
            let dir = scene_fixtures();
            let sub = tempfile::tempdir_in(dir.path()).unwrap();
            let mut obj = obj.join("\n");
            if with_library {
                obj = format!("mtllib m.mtl\n{obj}");
            }
            let obj_bytes = mutate(&obj, &obj_mutations);
            let mtl_bytes = mutate(&mtl.join("\n"), &mtl_mutations);
            std::fs::write(sub.path().join("t.obj"), &obj_bytes).unwrap();
            std::fs::write(sub.path().join("m.mtl"), &mtl_bytes).unwrap();
            std::fs::copy(dir.path().join("tex.png"), sub.path().join("tex.png")).unwrap();
            let scene = "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\n\
                         vfov = 40\nresolution = [6, 6]\n\n[[shapes]]\ntype = \"obj\"\n\
                         file = \"t.obj\"\nemission = [0, 0, 0]\n\n[[shapes]]\ntype = \"sphere\"\n\
                         emission = [1, 1, 1]\ncenter = [0, 0, -5]\n";
            let input = format!(
                "OBJ:\n{}\nMTL:\n{}",
                String::from_utf8_lossy(&obj_bytes),
                String::from_utf8_lossy(&mtl_bytes)
            );
            case(&input, || {
                check_scene(sub.path(), "scene.toml", scene.as_bytes(), &input)
            })
        },
    );
}

// ---------------------------------------------------------------------
// glTF files.
// ---------------------------------------------------------------------

/// Standard base64 (the glTF's `data:` URI of its buffer).
fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ABC[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A JSON number: mostly in `[lo, hi)`, now and then from the edges.
fn json_number(lo: f64, hi: f64) -> BoxedStrategy<String> {
    mostly(
        within(lo, hi),
        prop::sample::select(vec![
            "0",
            "-0",
            "1e-45",
            "1e39",
            "-1e39",
            "1e308",
            "4294967296",
            "-1",
            "\"1\"",
            "null",
            "[]",
        ])
        .prop_map(String::from),
    )
}

/// A JSON array of `n` numbers in `[lo, hi)`.
fn json_array(n: usize, lo: f64, hi: f64) -> BoxedStrategy<String> {
    prop::collection::vec(json_number(lo, hi), n)
        .prop_map(|v| format!("[{}]", v.join(", ")))
        .boxed()
}

/// One triangle mesh's glTF: positions (and maybe normals and texture
/// coordinates) in one buffer given as a `data:` URI, indices or none, a
/// material with the extensions plsr reads, a node with its transform, a
/// camera and a punctual light. The accessors' counts, offsets, strides
/// and component types are mostly right and now and then not.
fn gltf_text() -> impl Strategy<Value = String> {
    let vertices = prop::collection::vec(prop::collection::vec(-2.0f32..2.0, 8), 3..9);
    // Whole triangles, mostly of the vertices there are (taken modulo
    // their count), now and then of any, now and then cut short.
    let indices = prop::option::weighted(
        0.7,
        (
            prop::collection::vec(0u16..10, 1..5),
            prop::bool::weighted(0.9),
            prop::sample::select(vec![0usize, 0, 0, 0, 0, 0, 0, 0, 1, 2]),
        ),
    );
    let accessor = (
        mostly(
            Just(String::new()),
            count(0, 40).prop_map(|c| format!(", \"count\": {c}")),
        ),
        mostly(
            Just("5126".to_string()),
            prop::sample::select(vec!["5120", "5121", "5123", "5125", "1"]).prop_map(String::from),
        ),
        mostly(
            Just(String::new()),
            count(0, 64).prop_map(|o| format!(", \"byteOffset\": {o}")),
        ),
        mostly(
            Just(String::new()),
            prop::sample::select(vec![", \"byteStride\": 32", ", \"byteStride\": 4"])
                .prop_map(String::from),
        ),
    );
    let material = keys(vec![
        ("baseColorFactor", json_array(4, 0.0, 1.0)),
        ("metallicFactor", json_number(0.0, 1.0)),
        ("roughnessFactor", json_number(0.0, 1.0)),
    ]);
    let extras = keys(vec![
        ("emissiveFactor", json_array(3, 0.0, 1.0)),
        ("doubleSided", boolean().boxed()),
        ("alphaMode", word(&["OPAQUE", "MASK", "BLEND"]).boxed()),
        ("alphaCutoff", json_number(0.0, 1.0)),
        (
            "extensions",
            (
                json_number(0.0, 20.0),
                json_number(1.0, 2.5),
                json_number(0.0, 1.0),
            )
                .prop_map(|(s, ior, t)| {
                    format!(
                        "{{\"KHR_materials_emissive_strength\": {{\"emissiveStrength\": {s}}}, \
                         \"KHR_materials_ior\": {{\"ior\": {ior}}}, \
                         \"KHR_materials_transmission\": {{\"transmissionFactor\": {t}}}}}"
                    )
                })
                .boxed(),
        ),
    ]);
    let node = keys(vec![
        ("translation", json_array(3, -1.0, 1.0)),
        ("rotation", json_array(4, -1.0, 1.0)),
        ("scale", json_array(3, -2.0, 2.0)),
    ]);
    let camera = (
        json_number(0.1, 1.5),
        json_number(0.001, 1.0),
        json_array(3, -1.0, 1.0),
    );
    let light = (
        word(&["point", "spot", "directional"]),
        json_number(0.0, 100.0),
    )
        .prop_map(|(kind, intensity)| {
            let spot = if kind == "\"spot\"" {
                ", \"spot\": {\"outerConeAngle\": 0.7}"
            } else {
                ""
            };
            format!("{{\"type\": {kind}, \"intensity\": {intensity}{spot}}}")
        });
    (vertices, indices, accessor, material, extras, node, camera, light, 0u8..8)
        .prop_map(|(vertices, indices, accessor, material, extras, node, camera, light, layout)| {
            let (count, component, offset, stride) = accessor;
            let n = vertices.len();
            let (normals, uvs) = (layout & 1 != 0, layout & 2 != 0);
            let mut buffer = Vec::new();
            for v in &vertices {
                buffer.extend(v[..3].iter().flat_map(|x| x.to_le_bytes()));
            }
            let normals_at = buffer.len();
            if normals {
                for v in &vertices {
                    buffer.extend(v[3..6].iter().flat_map(|x| x.to_le_bytes()));
                }
            }
            let uvs_at = buffer.len();
            if uvs {
                for v in &vertices {
                    buffer.extend(v[6..8].iter().flat_map(|x| x.to_le_bytes()));
                }
            }
            // Triples of indices, wrapped into range when `tame`, the last
            // `cut` dropped (not a whole number of triangles).
            let indices = indices.map(|(seeds, tame, cut)| {
                let mut i: Vec<u16> = seeds
                    .iter()
                    .flat_map(|&s| [s, s.wrapping_add(1), s.wrapping_add(2)])
                    .map(|v| if tame { v % n as u16 } else { v })
                    .collect();
                i.truncate(i.len() - cut.min(i.len() - 1));
                i
            });
            let indices_at = buffer.len();
            if let Some(i) = &indices {
                buffer.extend(i.iter().flat_map(|x| x.to_le_bytes()));
                while buffer.len() % 4 != 0 {
                    buffer.push(0);
                }
            }
            let mut views = vec![format!(
                "{{\"buffer\": 0, \"byteLength\": {}{stride}}}",
                12 * n
            )];
            let mut accessors = vec![format!(
                "{{\"bufferView\": 0, \"componentType\": {component}, \"type\": \"VEC3\", \
                 \"min\": [-2, -2, -2], \"max\": [2, 2, 2]{offset}{}}}",
                if count.is_empty() { format!(", \"count\": {n}") } else { count },
            )];
            let mut attributes = vec!["\"POSITION\": 0".to_string()];
            if normals {
                views.push(format!(
                    "{{\"buffer\": 0, \"byteOffset\": {normals_at}, \"byteLength\": {}}}",
                    12 * n
                ));
                accessors.push(format!(
                    "{{\"bufferView\": {}, \"componentType\": 5126, \"count\": {n}, \"type\": \"VEC3\"}}",
                    views.len() - 1
                ));
                attributes.push(format!("\"NORMAL\": {}", accessors.len() - 1));
            }
            if uvs {
                views.push(format!(
                    "{{\"buffer\": 0, \"byteOffset\": {uvs_at}, \"byteLength\": {}}}",
                    8 * n
                ));
                accessors.push(format!(
                    "{{\"bufferView\": {}, \"componentType\": 5126, \"count\": {n}, \"type\": \"VEC2\"}}",
                    views.len() - 1
                ));
                attributes.push(format!("\"TEXCOORD_0\": {}", accessors.len() - 1));
            }
            let mut primitive = format!("\"attributes\": {{{}}}, \"material\": 0", attributes.join(", "));
            if let Some(i) = &indices {
                views.push(format!(
                    "{{\"buffer\": 0, \"byteOffset\": {indices_at}, \"byteLength\": {}}}",
                    2 * i.len()
                ));
                accessors.push(format!(
                    "{{\"bufferView\": {}, \"componentType\": 5123, \"count\": {}, \"type\": \"SCALAR\"}}",
                    views.len() - 1,
                    i.len()
                ));
                primitive += &format!(", \"indices\": {}", accessors.len() - 1);
            }
            let material = material.replace(" = ", "\": ").replace('\n', ", \"");
            let extras = extras.replace(" = ", "\": ").replace('\n', ", \"");
            let node = node.replace(" = ", "\": ").replace('\n', ", \"");
            let object = |body: &str| {
                let body = body.trim_end_matches(", \"");
                if body.is_empty() { String::new() } else { format!("\"{body}") }
            };
            let (yfov, znear, at) = camera;
            format!(
                "{{\"asset\": {{\"version\": \"2.0\"}}, \"scene\": 0,\n\
                 \"scenes\": [{{\"nodes\": [0, 1, 2]}}],\n\
                 \"nodes\": [{{\"mesh\": 0{}}}, {{\"camera\": 0, \"translation\": [0, 0, 4]}}, \
                 {{\"extensions\": {{\"KHR_lights_punctual\": {{\"light\": 0}}}}, \"translation\": {at}}}],\n\
                 \"cameras\": [{{\"type\": \"perspective\", \"perspective\": {{\"yfov\": {yfov}, \"znear\": {znear}, \"aspectRatio\": 1.0}}}}],\n\
                 \"extensionsUsed\": [\"KHR_lights_punctual\", \"KHR_materials_emissive_strength\", \"KHR_materials_ior\", \"KHR_materials_transmission\"],\n\
                 \"extensions\": {{\"KHR_lights_punctual\": {{\"lights\": [{light}]}}}},\n\
                 \"meshes\": [{{\"primitives\": [{{{primitive}}}]}}],\n\
                 \"materials\": [{{\"pbrMetallicRoughness\": {{{}}}{}}}],\n\
                 \"accessors\": [{}],\n\
                 \"bufferViews\": [{}],\n\
                 \"buffers\": [{{\"byteLength\": {}, \"uri\": \"data:application/octet-stream;base64,{}\"}}]}}\n",
                if node.is_empty() { String::new() } else { format!(", {}", object(&node)) },
                object(&material),
                if extras.is_empty() { String::new() } else { format!(", {}", object(&extras)) },
                accessors.join(",\n  "),
                views.join(",\n  "),
                buffer.len(),
                base64(&buffer),
            )
        })
}

/// glTF files, as `plsr render model.gltf` reads them.
#[test]
fn gltf_files_end_in_ok_or_a_clean_error() {
    fuzz(
        "gltf_files",
        1500,
        0.05,
        (gltf_text(), mutations()),
        |(text, mutations)| {
            let dir = scene_fixtures();
            let bytes = mutate(&text, &mutations);
            let input = String::from_utf8_lossy(&bytes).into_owned();
            case(&input, || {
                check_scene(dir.path(), "model.gltf", &bytes, &input)
            })
        },
    );
}

// ---------------------------------------------------------------------
// Bracket sets.
// ---------------------------------------------------------------------

/// One bracket: its pixel values, exposure time in the header, and how
/// its file is damaged.
#[derive(Debug, Clone)]
struct Bracket {
    /// Its own size, when it differs from the set's.
    size: Option<(usize, usize)>,
    /// Its own channel count, when it differs from the set's.
    channels: Option<usize>,
    /// `ExposureTime`: the set's i-th time (1/8 s · 4^i), an odd value or
    /// none.
    exposure: Exposure,
    pixels: Vec<u8>,
    damage: Damage,
}

#[derive(Debug, Clone)]
enum Exposure {
    Stepped,
    Odd(f32),
    Missing,
}

#[derive(Debug, Clone)]
enum Damage {
    None,
    Truncated(prop::sample::Index),
    Garbage(Vec<u8>),
    Empty,
}

fn bracket() -> impl Strategy<Value = Bracket> {
    (
        prop::option::weighted(0.03, prop::sample::select(vec![(8usize, 5usize), (1, 1)])),
        prop::option::weighted(0.03, prop::sample::select(vec![1usize, 4])),
        prop_oneof![
            30 => Just(Exposure::Stepped),
            1 => prop::sample::select(vec![0.0f32, -1.0, f32::NAN, f32::INFINITY, 1e-30, 1e30, 0.125])
                .prop_map(Exposure::Odd),
            1 => Just(Exposure::Missing),
        ],
        prop::collection::vec(any::<u8>(), 8 * 5 * 4),
        prop_oneof![
            40 => Just(Damage::None),
            1 => any::<prop::sample::Index>().prop_map(Damage::Truncated),
            1 => prop::collection::vec(any::<u8>(), 0..64).prop_map(Damage::Garbage),
            1 => Just(Damage::Empty),
        ],
    )
        .prop_map(|(size, channels, exposure, pixels, damage)| Bracket {
            size,
            channels,
            exposure,
            pixels,
            damage,
        })
}

/// Merge options as the command line or a C host may give them.
fn merge_options() -> impl Strategy<Value = (MergeOptions, &'static str)> {
    (
        prop::sample::select(vec![
            ResponseMethod::Debevec,
            ResponseMethod::Robertson,
            ResponseMethod::Linear,
            ResponseMethod::Srgb,
        ]),
        prop::option::weighted(
            0.1,
            prop::collection::vec(
                prop::sample::select(vec![0.125f64, 0.5, 2.0, 0.0, -1.0, f64::NAN, 1e300]),
                0..5,
            ),
        ),
        any::<bool>(),
        prop::bool::weighted(0.2),
        prop_oneof![
            20 => Just(10.0f64),
            1 => prop::sample::select(vec![0.0f64, -1.0, f64::NAN, 1e12]),
        ],
        prop::option::weighted(0.1, prop::sample::select(vec![0usize, 1, 3, 1 << 20])),
        prop_oneof![20 => Just("exr"), 2 => Just("hdr"), 1 => Just("png")],
    )
        .prop_map(|(response, exposures, align, half, lambda, samples, ext)| {
            (
                MergeOptions {
                    response,
                    exposures,
                    align,
                    half,
                    lambda,
                    samples,
                    threads: Some(1),
                    ..Default::default()
                },
                ext,
            )
        })
}

/// Bracket sets of every file format, with damaged files and odd headers;
/// a merge that succeeds holds finite, non-negative radiance.
#[test]
fn bracket_sets_end_in_ok_or_a_clean_error() {
    let strategy = (
        prop_oneof![12 => prop::collection::vec(bracket(), 2..5), 1 => prop::collection::vec(bracket(), 0..2)],
        prop::sample::select(vec!["png", "tif", "exr", "jpg", "hdr"]),
        prop_oneof![12 => Just(3usize), 1 => Just(1), 1 => Just(4)],
        merge_options(),
    );
    fuzz(
        "bracket_sets",
        2000,
        0.05,
        strategy,
        |(brackets, format, channels, options)| {
            let (options, out_ext) = options;
            let dir = tempfile::tempdir().unwrap();
            let mut paths = Vec::new();
            for (i, b) in brackets.iter().enumerate() {
                let path = dir.path().join(format!("b{i}.{format}"));
                let (w, h) = b.size.unwrap_or((8, 4));
                let channels = b.channels.unwrap_or(channels);
                let n = w * h * channels;
                let exposure = match b.exposure {
                    Exposure::Stepped => Some(0.125 * 4f32.powi(i as i32)),
                    Exposure::Odd(t) => Some(t),
                    Exposure::Missing => None,
                };
                let attrs: Vec<(String, AttrValue)> = exposure
                    .map(|t| vec![("ExposureTime".to_string(), AttrValue::Float(t))])
                    .unwrap_or_default();
                let written = if matches!(format, "exr" | "hdr") {
                    let data: Vec<f32> = b.pixels[..n].iter().map(|&v| v as f32 / 64.0).collect();
                    write_image(&path, w, h, channels, PixelType::F32, &attrs, &data)
                } else {
                    write_image(&path, w, h, channels, PixelType::U8, &attrs, &b.pixels[..n])
                };
                if written.is_err() {
                    // Formats refuse some channel counts (HDR takes three).
                    std::fs::write(&path, b"").unwrap();
                }
                match &b.damage {
                    Damage::None => {}
                    Damage::Truncated(i) => {
                        let bytes = std::fs::read(&path).unwrap();
                        std::fs::write(&path, &bytes[..i.index(bytes.len().max(1))]).unwrap();
                    }
                    Damage::Garbage(g) => std::fs::write(&path, g).unwrap(),
                    Damage::Empty => std::fs::write(&path, b"").unwrap(),
                }
                paths.push(path);
            }
            // PNG, JPEG and Radiance files carry no exposure time through
            // OpenImageIO: give the times as `--exposures` does.
            let mut options = options;
            if options.exposures.is_none() && matches!(format, "png" | "jpg" | "hdr") {
                options.exposures = Some(
                    (0..brackets.len())
                        .map(|i| 0.125 * 4f64.powi(i as i32))
                        .collect(),
                );
            }
            let output = dir.path().join(format!("pano.{out_ext}"));
            let input = format!(
                "{brackets:?} as {format} with {channels} channels, {options:?} → {out_ext}"
            );
            case(&input, || -> Result<Outcome, TestCaseError> {
                let outcome = match merge(&paths, &output, &options, &|_, _, _| {}) {
                    Err(e) => {
                        let message = e.to_string();
                        if std::env::var_os("PLSR_FUZZ_VERBOSE").is_some() {
                            eprintln!("refused: {message}");
                        }
                        prop_assert!(!message.trim().is_empty());
                        // Either about an input, the output, or the options.
                        let names_a_file = paths
                            .iter()
                            .chain(std::iter::once(&output))
                            .any(|p| message.contains(&*p.file_name().unwrap().to_string_lossy()));
                        prop_assert!(
                            names_a_file
                                || matches!(
                                    e,
                                    plsr_hdr::Error::Base(plsr_base::Error::InvalidArgument(_))
                                ),
                            "the error names no file: {message}\ninput: {input}"
                        );
                        prop_assert!(!output.exists(), "an output was left: {input}");
                        Outcome::Refused
                    }
                    Ok(summary) => {
                        let (_, data) = plsr_hdr::oiio::read_image_f32(&output).unwrap();
                        let bad = data.iter().position(|v| !v.is_finite() || *v < 0.0);
                        prop_assert!(
                            bad.is_none(),
                            "value {bad:?} = {:?} of the panorama\ninput: {input}",
                            bad.map(|i| data[i])
                        );
                        prop_assert_eq!(summary.brackets.len(), paths.len());
                        Outcome::Accepted
                    }
                };
                // No temporary file is ever left behind.
                let left: Vec<PathBuf> = std::fs::read_dir(dir.path())
                    .unwrap()
                    .map(|e| e.unwrap().path())
                    .filter(|p| p.to_string_lossy().contains(".partial"))
                    .collect();
                prop_assert!(left.is_empty(), "{left:?} left by {input}");
                Ok(outcome)
            })
        },
    );
}

// ---------------------------------------------------------------------
// Inputs the generators found, kept as literal cases.
// ---------------------------------------------------------------------

/// A texture index counted back past the start panicked inside tobj
/// (overflow in its index arithmetic); now the line is named.
#[test]
fn found_a_texture_index_before_the_start() {
    let dir = scene_fixtures();
    let sub = tempfile::tempdir_in(dir.path()).unwrap();
    std::fs::write(
        sub.path().join("t.obj"),
        "vt 0 0\nv 0 0 0\nv 0 0 0\nf 1/-3 1 1\n",
    )
    .unwrap();
    std::fs::write(
        sub.path().join("scene.toml"),
        "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nvfov = 40\n\
         resolution = [4, 4]\n[[shapes]]\ntype = \"obj\"\nfile = \"t.obj\"\n",
    )
    .unwrap();
    let e = plsr::scene::file::load(&sub.path().join("scene.toml"))
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("t.obj: line 4") && e.contains("texture coordinate index -3"),
        "{e}"
    );
}

/// `position = [0, -2, 0, 7]` was read as `[0, -2, 0]` (the toml crate
/// drops extra elements of fixed-length arrays), in scene and PLS files.
#[test]
fn found_arrays_longer_than_their_field() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    std::fs::write(
        &scene,
        "[camera]\nposition = [0, -2, 0, 7]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nvfov = 40\n\
         resolution = [4, 4]\n",
    )
    .unwrap();
    let e = plsr::scene::file::load(&scene)
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("camera.position") && e.contains("invalid length 4"),
        "{e}"
    );
    let lights = dir.path().join("lights.toml");
    let text = std::fs::read_to_string("assets/lights/paper.toml")
        .unwrap()
        .replacen(
            "d = [0.0, 0.021, 0.021, 0.0]",
            "d = [0.0, 0.021, 0.021, 0.0, 5]",
            1,
        );
    std::fs::write(&lights, text).unwrap();
    let e = plsr::light::pls::file::load(&lights)
        .expect_err("refused")
        .to_string();
    assert!(e.contains("invalid length 5"), "{e}");
}

/// An `ExposureTime` of 1e-30 s merged into infinite radiance.
#[test]
fn found_an_exposure_time_too_short_for_f32() {
    let dir = tempfile::tempdir().unwrap();
    let mut paths = Vec::new();
    for (i, t) in [1e-30f32, 0.5].iter().enumerate() {
        let path = dir.path().join(format!("b{i}.exr"));
        let attrs = vec![("ExposureTime".to_string(), AttrValue::Float(*t))];
        write_image(&path, 4, 2, 3, PixelType::F32, &attrs, &[0.5f32; 24]).unwrap();
        paths.push(path);
    }
    let output = dir.path().join("pano.exr");
    let e = merge(&paths, &output, &MergeOptions::default(), &|_, _, _| {})
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("b0.exr") && e.contains("exposure time 1.000e-30 s"),
        "{e}"
    );
    assert!(!output.exists());
}

/// JSON scene errors did not name the field.
#[test]
fn found_json_errors_without_a_field() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.json");
    std::fs::write(
        &scene,
        r#"{"camera": {"position": [0, -2, null], "look_at": [0, 0, 0], "up": [0, 0, 1],
            "vfov": 40, "resolution": [4, 4]}}"#,
    )
    .unwrap();
    let e = plsr::scene::file::load(&scene)
        .expect_err("refused")
        .to_string();
    assert!(e.contains("camera.position[2]"), "{e}");
}

/// A thin lens of radius 9.2e18 made camera rays Embree refuses (an
/// assertion abort inside Embree); coordinates are now bounded.
#[test]
fn found_coordinates_beyond_what_embree_traces() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    let camera = "[camera]\ntype = \"thin_lens\"\nposition = [0, -2, 1]\nlook_at = [0, 0, 0]\n\
                  up = [0, 0, 1]\nvfov = 60\nresolution = [3, 3]\n";
    for (extra, field) in [
        (
            "aperture_radius = 9223372036854775807\n",
            "camera.aperture_radius",
        ),
        (
            "aperture_radius = 0.1\n[[shapes]]\ntype = \"sphere\"\nradius = 1e30\n",
            "scene.toml: shapes[0]: mesh `shapes[0] (sphere)`: vertex 0 lands at",
        ),
        (
            "aperture_radius = 0.1\n[[lights]]\ntype = \"point\"\nposition = [0, 0, 1e20]\n\
             intensity = [1, 1, 1]\n",
            "beyond",
        ),
    ] {
        std::fs::write(&scene, format!("{camera}{extra}")).unwrap();
        let Err(e) = Scene::load(&scene) else {
            panic!("{extra}: accepted")
        };
        let e = e.to_string();
        assert!(e.contains(field), "{extra}: {e}");
    }
}

/// `--half` stored radiance above 65504 (the largest half float) as
/// infinity; it is now clamped, with a warning.
#[test]
fn found_radiance_beyond_half_floats() {
    let dir = tempfile::tempdir().unwrap();
    let mut paths = Vec::new();
    // 0.9 in 10 µs and in 12 µs: about 80,000 (relative units).
    for (i, t) in [1e-5f32, 1.2e-5].iter().enumerate() {
        let path = dir.path().join(format!("b{i}.exr"));
        let attrs = vec![("ExposureTime".to_string(), AttrValue::Float(*t))];
        write_image(&path, 4, 2, 3, PixelType::F32, &attrs, &[0.9f32; 24]).unwrap();
        paths.push(path);
    }
    let output = dir.path().join("pano.exr");
    let options = MergeOptions {
        response: ResponseMethod::Linear,
        half: true,
        ..Default::default()
    };
    let summary = merge(&paths, &output, &options, &|_, _, _| {}).unwrap();
    let (_, data) = plsr_hdr::oiio::read_image_f32(&output).unwrap();
    assert!(data.iter().all(|v| *v == 65504.0), "{data:?}");
    assert!(
        summary
            .warnings
            .iter()
            .any(|w| w.contains("24 value(s) above 65504")),
        "{:?}",
        summary.warnings
    );
}
