//! The C ABI from real C and C++ hosts:
//! - a C program calls every function with NULL and invalid arguments;
//! - the C++ host of examples/cpp builds a scene with a PLS light, renders
//!   it, and its image equals the Rust API's render bit for bit;
//! - the C++ host runs clean under valgrind (no leaks, no invalid reads);
//! - `make install` installs what a pkg-config or CMake host needs (the
//!   README's minimal host is built both ways, shared and static, against
//!   an installed prefix), and `make uninstall` removes it again.
//!
//! (The calls a host makes, from Rust: `crates/capi/src/tests/`.)
//!
//! The libraries are those this `cargo test` built: `plsr-capi` is a
//! dev-dependency of this crate, so cargo builds `libplsr.so` and
//! `libplsr.a` (in the tests' profile, with line tables for the install's
//! split debug info) before the tests run; nothing is built twice.

use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

fn root() -> &'static Path {
    Path::new(plsr_testkit::REPO_ROOT)
}

/// A folder holding what `make install` installs from, as cargo's target
/// folder would: `libplsr.so` with its soname link, `libplsr.a` and the
/// `plsr` program, each a link to what this `cargo test` built. Returns it.
fn library() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        // Cargo keeps a dependency's cdylib and staticlib beside this test
        // program, in the profile's deps/ folder.
        let exe = std::env::current_exe().expect("the test's own path");
        let deps = exe.parent().expect("the test's folder");
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("c-abi");
        std::fs::create_dir_all(&dir).unwrap();
        // A host linked against the library asks for its soname (set by
        // crates/capi/build.rs), which `make install` links to the library;
        // here a link beside cargo's file stands in for it.
        let soname = format!("libplsr.so.{}", env!("CARGO_PKG_VERSION_MAJOR"));
        for (name, target) in [
            ("libplsr.so", deps.join("libplsr.so")),
            ("libplsr.a", deps.join("libplsr.a")),
            (soname.as_str(), PathBuf::from("libplsr.so")),
            ("plsr", PathBuf::from(env!("CARGO_BIN_EXE_plsr"))),
        ] {
            if name != soname {
                assert!(target.is_file(), "{} was not built", target.display());
            }
            let link = dir.join(name);
            // Another test process may have made the same link already.
            if std::fs::read_link(&link).ok().as_deref() != Some(target.as_path()) {
                let _ = std::fs::remove_file(&link);
                if let Err(e) = std::os::unix::fs::symlink(&target, &link) {
                    assert_eq!(
                        e.kind(),
                        std::io::ErrorKind::AlreadyExists,
                        "linking {}: {e}",
                        link.display()
                    );
                }
            }
        }
        dir
    })
}

/// Runs `cmd`, which must succeed. `cargo test` puts its own target folders
/// on `LD_LIBRARY_PATH`, which outranks the programs' rpath (a `RUNPATH`):
/// a host would load whatever `libplsr.so` the test profile left there,
/// not the library built above, so the variable is removed.
fn run(cmd: &mut Command) -> std::process::Output {
    cmd.env_remove("LD_LIBRARY_PATH");
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn c_program_checks_every_error_path() {
    let lib = library();
    let dir = tempfile::tempdir().unwrap();
    let exe = dir.path().join("api_errors");
    run(Command::new("cc")
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-Wno-div-by-zero",
            "-o",
        ])
        .arg(&exe)
        .arg(root().join("tests/c/api_errors.c"))
        .arg(format!("-I{}", root().join("include").display()))
        .arg(format!("-L{}", lib.display()))
        .arg("-lplsr")
        .arg("-lm")
        .arg(format!("-Wl,-rpath,{}", lib.display())));
    let out = run(Command::new(&exe).arg(dir.path()));
    assert!(String::from_utf8_lossy(&out.stdout).contains("all C API error checks passed"));
}

/// Builds the C++ host into `dir`.
fn build_host(dir: &Path) -> PathBuf {
    let lib = library();
    run(Command::new("make")
        .arg("-C")
        .arg(root().join("examples/cpp"))
        .arg(format!("PLSR_LIBDIR={}", lib.display()))
        .arg(format!("BUILD_DIR={}", dir.display())));
    dir.join("host")
}

/// The host's scene (examples/cpp/host.cpp) through the Rust API.
fn host_scene_in_rust() -> plsr::scene::Scene {
    use plsr::bsdf::Bsdf;
    use plsr::camera::PinholeCamera;
    use plsr::job::RenderJob;
    use plsr::light::pls::{BrightnessMode, Pls, PlsGeometry};
    use plsr::scene::{pls_mesh, Material, Mesh, Scene, SceneDescription};
    let mesh = |id: u32, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, material| {
        Mesh::new(format!("mesh {id}"), positions, triangles, material, id).unwrap()
    };
    let floor = mesh(
        0,
        vec![
            Vec3::new(-2.0, -2.0, 0.0),
            Vec3::new(2.0, -2.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(-2.0, 2.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
        0,
    );
    let corners = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { 0.25 } else { -0.25 },
                if i & 2 != 0 { 0.25 } else { -0.25 },
                if i & 4 != 0 { 0.5 } else { 0.0 },
            )
        })
        .collect();
    let tris = [
        0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6,
        1, 3, 5, 3, 7, 5,
    ];
    let boxm = mesh(
        1,
        corners,
        tris.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
        1,
    );
    let light = Pls {
        name: Some("params".into()),
        n: Vec3::new(0.0, 0.0, -1.0),
        g: PlsGeometry {
            e1: Vec3::new(-0.015, 0.0, 1.2),
            e2: Vec3::new(0.015, 0.0, 1.2),
            alpha1: 0.0,
            alpha2: 1.0,
            d: [0.0, 0.02, 0.02, 0.0],
        },
        a_deg: 30.0,
        penumbra_deg: 0.0,
        c: Vec3::new(1.0, 0.9, 0.7),
        b: 4.0,
    };
    let pls = pls_mesh(&light, BrightnessMode::Intensity, 16, 2, "pls 2".into());
    Scene::build(SceneDescription {
        meshes: vec![floor, boxm, pls],
        materials: vec![
            Material::new("floor", Bsdf::diffuse(Vec3::splat(0.7))),
            Material::new("box", Bsdf::diffuse(Vec3::new(0.2, 0.4, 0.8))),
            Material::new("(pls)", Bsdf::diffuse(Vec3::ZERO)),
        ],
        point_lights: vec![plsr::light::PointLight::isotropic(
            Vec3::new(1.5, -1.5, 2.0),
            Vec3::splat(0.5),
        )],
        directional_lights: Vec::new(),
        environment: None,
        camera: PinholeCamera::look_at(
            Vec3::new(0.0, -3.0, 1.5),
            Vec3::new(0.0, 0.0, 0.2),
            Vec3::Z,
            40.0,
            48,
            32,
        )
        .unwrap()
        .into(),
        film: Default::default(),
        job: RenderJob {
            spp: 8,
            max_depth: 6,
            seed: 42,
            sample_start: 0,
            hide_virtual: false,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    })
    .unwrap()
}

fn read_rgba(path: &Path) -> Vec<u32> {
    std::fs::read(path)
        .unwrap()
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

#[test]
fn cpp_host_image_equals_the_rust_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let host = build_host(dir.path());
    let prefix = dir.path().join("host-out");
    run(Command::new(&host).arg(&prefix).arg("2"));
    assert!(prefix.with_extension("exr").is_file() && prefix.with_extension("png").is_file());
    let from_host = read_rgba(&prefix.with_extension("rgba"));
    let scene = host_scene_in_rust();
    let (film, _) = plsr::render::render(
        &scene,
        &scene.default_job(),
        &Default::default(),
        &|_, _| true,
    )
    .unwrap();
    let from_rust: Vec<u32> = film
        .color
        .iter()
        .zip(&film.alpha)
        .flat_map(|(c, a)| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits(), a.to_bits()])
        .collect();
    assert_eq!(from_host.len(), 48 * 32 * 4);
    assert!(from_rust.iter().any(|&b| b != 0), "the render is black");
    let differ: Vec<usize> = (0..from_rust.len())
        .filter(|&i| from_host[i] != from_rust[i])
        .collect();
    assert!(
        differ.is_empty(),
        "the C++ host's image differs from the Rust render in {} of {} values; the first at \
         pixel {} channel {}: {} against {}",
        differ.len(),
        from_rust.len(),
        differ[0] / 4,
        differ[0] % 4,
        f32::from_bits(from_host[differ[0]]),
        f32::from_bits(from_rust[differ[0]])
    );
}

#[test]
fn cpp_host_is_clean_under_valgrind() {
    if Command::new("valgrind").arg("--version").output().is_err() {
        eprintln!("valgrind is not installed: skipped (apt-get install valgrind)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let host = build_host(dir.path());
    let out = Command::new("valgrind")
        .env_remove("LD_LIBRARY_PATH")
        .args([
            "--error-exitcode=42",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite",
            "--show-leak-kinds=definite",
        ])
        .arg(&host)
        .arg(dir.path().join("vg"))
        .arg("1")
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "valgrind found errors:\n{log}");
    assert!(log.contains("ERROR SUMMARY: 0 errors"), "{log}");
}

/// Fails, rather than skips, when a tool the packaging tests need is
/// missing: all of them are in the Makefile's DEB_PACKAGES or DEB_TEST_PACKAGES.
fn require(tool: &str, package: &str) {
    let found = Command::new(tool)
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        found,
        "this test needs `{tool}`, which is not installed: `make test-deps` installs it \
         (Debian package {package}, listed in the Makefile's DEB_PACKAGES or DEB_TEST_PACKAGES)"
    );
}

/// Runs `make TARGET VAR=VALUE…` in the repository, installing what this
/// `cargo test` built (`INSTALL_FROM`: `make install` builds nothing).
fn make(target: &str, vars: &[(&str, &Path)]) {
    let built = library();
    let mut cmd = Command::new("make");
    cmd.arg("-C").arg(root()).arg(target);
    for (name, value) in vars {
        cmd.arg(format!("{name}={}", value.display()));
    }
    cmd.arg(format!("INSTALL_FROM={}", built.display()));
    run(&mut cmd);
}

fn text_of(out: std::process::Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Every file, link and folder under `dir`, relative to it.
fn entries(dir: &Path) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            found.push(p.strip_prefix(dir).unwrap().display().to_string());
            if p.is_dir() && !p.is_symlink() {
                stack.push(p);
            }
        }
    }
    found.sort();
    found
}

/// The README's section "## From C and C++".
fn readme_c_section() -> String {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let start = text
        .find("\n## From C and C++\n")
        .expect("README.md has a section \"## From C and C++\"")
        + 1;
    let rest = &text[start..];
    let end = rest[3..].find("\n## ").map_or(rest.len(), |i| i + 4);
    rest[..end].to_string()
}

/// The contents of the code blocks fenced as ```LANG in `text`.
fn code_blocks(text: &str, lang: &str) -> Vec<String> {
    let fence = format!("```{lang}");
    let mut blocks = Vec::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        if line == fence {
            let mut block = String::new();
            for l in lines.by_ref().take_while(|l| *l != "```") {
                block.push_str(l);
                block.push('\n');
            }
            blocks.push(block);
        }
    }
    blocks
}

#[test]
fn readme_shows_the_minimal_host_as_it_is() {
    let section = readme_c_section();
    for (lang, file) in [
        ("cpp", "examples/minimal/minimal.cpp"),
        ("cmake", "examples/minimal/CMakeLists.txt"),
    ] {
        let want = std::fs::read_to_string(root().join(file)).unwrap();
        assert_eq!(
            code_blocks(&section, lang),
            vec![want],
            "README.md's \"From C and C++\" must show {file} as it is, in one ```{lang} block"
        );
    }
    assert_eq!(
        code_blocks(&section, "sh")
            .iter()
            .filter(|b| b.contains("pkg-config --static"))
            .count(),
        1,
        "README.md's \"From C and C++\" has one ```sh block with the pkg-config builds"
    );
}

/// A small scene for the installed hosts: the Cornell box at 64×64, 4 spp.
fn small_scene(dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(root().join("tests/data/cornell-64.toml")).unwrap();
    let text = text.replace("spp = 64", "spp = 4").replace(
        "file = \"../../assets",
        &format!("file = \"{}/assets", root().display()),
    );
    let path = dir.join("cornell.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs a host built against the installed library on the small scene;
/// returns the EXR it wrote.
fn run_host(host: &Path, scene: &Path, out: &Path) -> Vec<u8> {
    let said = text_of(run(Command::new(host).arg(scene).arg(out)));
    assert!(
        said.contains(&format!("plsr {}: 64x64", env!("CARGO_PKG_VERSION"))),
        "{}: {said}",
        host.display()
    );
    std::fs::read(out).unwrap()
}

fn dynamic_section(elf: &Path) -> String {
    text_of(run(Command::new("readelf").arg("-d").arg(elf)))
}

/// Configures a CMake project that asks for `find_package(plsr REQUEST)`
/// from the package in `plsr_dir`, with no compiler; returns the output,
/// or the error when CMake refuses.
fn cmake_find_plsr(work: &Path, plsr_dir: &Path, request: &str) -> Result<String, String> {
    let src = work.join(format!("find-{request}"));
    std::fs::create_dir_all(&src).unwrap();
    std::fs::write(
        src.join("CMakeLists.txt"),
        format!(
            "cmake_minimum_required(VERSION 3.16)\nproject(find_plsr NONE)\n\
             find_package(plsr {request} REQUIRED)\n\
             get_target_property(lib plsr::plsr IMPORTED_LOCATION)\n\
             get_target_property(inc plsr::plsr INTERFACE_INCLUDE_DIRECTORIES)\n\
             message(STATUS \"plsr ${{plsr_VERSION}}: ${{lib}} ${{inc}}\")\n"
        ),
    )
    .unwrap();
    let out = Command::new("cmake")
        .arg("-S")
        .arg(&src)
        .arg("-B")
        .arg(src.join("build"))
        .arg(format!("-Dplsr_DIR={}", plsr_dir.display()))
        .output()
        .unwrap();
    if out.status.success() {
        Ok(text_of(out))
    } else {
        Err(String::from_utf8_lossy(&out.stderr).into_owned())
    }
}

#[test]
fn make_install_serves_pkg_config_and_cmake_hosts() {
    for (tool, package) in [
        ("cmake", "cmake"),
        ("pkg-config", "pkg-config"),
        ("readelf", "binutils"),
        ("g++", "g++"),
    ] {
        require(tool, package);
    }
    let version = env!("CARGO_PKG_VERSION");
    let soname = format!("libplsr.so.{}", env!("CARGO_PKG_VERSION_MAJOR"));
    let real = format!("libplsr.so.{version}");
    // Debian's multiarch library folder, the harder case for the package
    // files (the default, PREFIX/lib, is in the next test).
    let multiarch = text_of(run(Command::new("gcc").arg("-print-multiarch")));
    let prefix_dir = tempfile::tempdir().unwrap();
    let p = prefix_dir.path();
    let libdir = p.join("lib").join(multiarch.trim());
    make("install", &[("PREFIX", p), ("LIBDIR", &libdir)]);

    for f in [
        real.as_str(),
        "libplsr.a",
        "pkgconfig/plsr.pc",
        "cmake/plsr/plsrConfig.cmake",
        "cmake/plsr/plsrConfigVersion.cmake",
        "plsr/install-manifest.txt",
    ] {
        assert!(libdir.join(f).is_file(), "{f} not installed in LIBDIR");
    }
    for f in ["include/plsr.h", "include/plsr.hpp", "bin/plsr"] {
        assert!(p.join(f).is_file(), "{f} not installed");
    }
    // The soname and the links to the real file.
    let so = libdir.join(&real);
    assert!(
        dynamic_section(&so).contains(&format!("Library soname: [{soname}]")),
        "{real} lacks the soname {soname}"
    );
    assert_eq!(
        std::fs::read_link(libdir.join(&soname)).unwrap(),
        Path::new(&real)
    );
    assert_eq!(
        std::fs::read_link(libdir.join("libplsr.so")).unwrap(),
        Path::new(&soname)
    );
    // Stripped, with the debug info (and the symbol table) in a file of its
    // own that the library names.
    let sections = text_of(run(Command::new("readelf").arg("-S").arg(&so)));
    for absent in [".debug_info", ".symtab"] {
        assert!(
            !sections.contains(absent),
            "the installed {real} has {absent}"
        );
    }
    assert!(
        sections.contains(".gnu_debuglink"),
        "{real} names no debug file"
    );
    let debug = libdir.join(".debug").join(format!("{real}.debug"));
    let debug_sections = text_of(run(Command::new("readelf").arg("-S").arg(&debug)));
    assert!(
        debug_sections.contains(".debug_info"),
        "{}",
        debug.display()
    );
    // The library is only the library: none of the program's crates (clap,
    // indicatif) is linked into it.
    let exported = text_of(run(Command::new("nm").arg("-D").arg(&so)));
    assert!(
        exported.contains("plsr_render"),
        "{real} exports no plsr_render"
    );
    let symbols = text_of(run(Command::new("nm").arg(&debug)));
    assert!(symbols.contains("plsr_render"), "nm lists no plsr symbols");
    for program_crate in ["clap", "indicatif"] {
        assert!(
            !symbols.contains(program_crate),
            "libplsr.so carries {program_crate} symbols"
        );
    }

    // The program runs from the prefix, stripped, with its debug info beside.
    let plsr = p.join("bin/plsr");
    assert!(p.join("bin/.debug/plsr.debug").is_file());
    let said = text_of(run(Command::new(&plsr).arg("--version")));
    assert!(said.contains(version), "plsr --version: {said}");
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let scene = small_scene(w);
    run(Command::new(&plsr)
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(w.join("program.exr")));
    assert!(w.join("program.exr").is_file());

    // pkg-config follows LIBDIR.
    let pkg_config_path = libdir.join("pkgconfig");
    let pkg_config = |args: &[&str]| {
        text_of(run(Command::new("pkg-config")
            .args(args)
            .arg("plsr")
            .env("PKG_CONFIG_PATH", &pkg_config_path)))
    };
    assert_eq!(pkg_config(&["--modversion"]).trim(), version);
    assert_eq!(
        pkg_config(&["--variable=libdir"]).trim(),
        libdir.display().to_string()
    );

    // The README's minimal host, built by the README's pkg-config lines:
    // shared (with an rpath) and static.
    let section = readme_c_section();
    let lines = code_blocks(&section, "sh")
        .into_iter()
        .find(|b| b.contains("pkg-config --static"))
        .expect("README shows the pkg-config builds");
    let build = w.join("pkg-config");
    std::fs::create_dir(&build).unwrap();
    std::fs::copy(
        root().join("examples/minimal/minimal.cpp"),
        build.join("minimal.cpp"),
    )
    .unwrap();
    run(Command::new("bash")
        .arg("-euc")
        .arg(&lines)
        .current_dir(&build)
        .env("PKG_CONFIG_PATH", &pkg_config_path));
    let shared = build.join("minimal");
    let dynamic = dynamic_section(&shared);
    assert!(
        dynamic.contains(&format!("Shared library: [{soname}]")),
        "the shared host does not record {soname}:\n{dynamic}"
    );
    assert!(
        dynamic.contains(&libdir.display().to_string()),
        "the shared host has no rpath to LIBDIR:\n{dynamic}"
    );
    let image = run_host(&shared, &scene, &w.join("shared.exr"));
    let fully_static = build.join("minimal-static");
    let dynamic = dynamic_section(&fully_static);
    assert!(
        !dynamic.contains("libplsr"),
        "the static host still needs libplsr:\n{dynamic}"
    );
    assert_eq!(
        run_host(&fully_static, &scene, &w.join("static.exr")),
        image,
        "the static host's image differs from the shared host's"
    );

    // The same host through CMake's find_package(plsr 0.2), run from its
    // build folder (CMake's build rpath) and after `cmake --install` (the
    // link path kept as rpath).
    let cmake_build = w.join("cmake");
    run(Command::new("cmake")
        .arg("-S")
        .arg(root().join("examples/minimal"))
        .arg("-B")
        .arg(&cmake_build)
        .arg(format!("-DCMAKE_PREFIX_PATH={}", p.display())));
    run(Command::new("cmake").arg("--build").arg(&cmake_build));
    assert_eq!(
        run_host(&cmake_build.join("minimal"), &scene, &w.join("cmake.exr")),
        image
    );
    let host_prefix = w.join("host-prefix");
    run(Command::new("cmake")
        .arg("--install")
        .arg(&cmake_build)
        .arg("--prefix")
        .arg(&host_prefix));
    assert_eq!(
        run_host(
            &host_prefix.join("bin/minimal"),
            &scene,
            &w.join("cmake-installed.exr")
        ),
        image
    );
    // plsr::plsr_static links the archive and what it needs.
    let static_src = w.join("cmake-static");
    std::fs::create_dir(&static_src).unwrap();
    std::fs::write(
        static_src.join("CMakeLists.txt"),
        format!(
            "cmake_minimum_required(VERSION 3.16)\nproject(minimal_static CXX)\n\
             set(CMAKE_CXX_STANDARD 17)\nfind_package(plsr 0.2 REQUIRED)\n\
             add_executable(minimal_static {}/examples/minimal/minimal.cpp)\n\
             target_link_libraries(minimal_static PRIVATE plsr::plsr_static)\n",
            root().display()
        ),
    )
    .unwrap();
    run(Command::new("cmake")
        .arg("-S")
        .arg(&static_src)
        .arg("-B")
        .arg(static_src.join("build"))
        .arg(format!("-DCMAKE_PREFIX_PATH={}", p.display())));
    run(Command::new("cmake")
        .arg("--build")
        .arg(static_src.join("build")));
    let cmake_static = static_src.join("build/minimal_static");
    assert!(!dynamic_section(&cmake_static).contains("libplsr"));
    assert_eq!(
        run_host(&cmake_static, &scene, &w.join("cmake-static.exr")),
        image
    );
    // The version file: 0.2 (the oldest compatible C ABI) up to this
    // version, of the same major version.
    let plsr_dir = libdir.join("cmake/plsr");
    let found = cmake_find_plsr(w, &plsr_dir, "0.2").unwrap_or_else(|e| panic!("{e}"));
    assert!(
        found.contains(&format!(
            "plsr {version}: {} {}",
            so.display(),
            p.join("include").display()
        )),
        "{found}"
    );
    for refused in ["1.0", "0.1", "0.6"] {
        let err = cmake_find_plsr(w, &plsr_dir, refused)
            .map(|out| panic!("find_package(plsr {refused}) accepted {version}:\n{out}"))
            .unwrap_err();
        assert!(
            err.contains(&format!("version: {version}")),
            "find_package(plsr {refused}): {err}"
        );
    }

    // The examples/cpp host's pkg-config mode.
    run(Command::new("make")
        .arg("-C")
        .arg(root().join("examples/cpp"))
        .arg("USE_PKG_CONFIG=1")
        .arg(format!("BUILD_DIR={}", build.display()))
        .env("PKG_CONFIG_PATH", &pkg_config_path));
    run(Command::new(build.join("host"))
        .arg(build.join("out"))
        .arg("1"));

    // make uninstall leaves the prefix as it found it: empty.
    make("uninstall", &[("PREFIX", p), ("LIBDIR", &libdir)]);
    let left = entries(p);
    assert!(left.is_empty(), "make uninstall left {left:?}");
}

#[test]
fn make_install_stages_into_destdir_and_uninstalls_from_it() {
    require("cmake", "cmake");
    let version = env!("CARGO_PKG_VERSION");
    let stage_dir = tempfile::tempdir().unwrap();
    let stage = stage_dir.path();
    let prefix = Path::new("/opt/plsr-test");
    let vars = [("DESTDIR", stage), ("PREFIX", prefix)];
    // Twice: the second install replaces the first, and still knows which
    // folders were made for plsr.
    make("install", &vars);
    make("install", &vars);
    let staged = stage.join("opt/plsr-test");
    let libdir = staged.join("lib"); // the default LIBDIR
    assert!(libdir.join(format!("libplsr.so.{version}")).is_file());
    assert!(staged.join("bin/plsr").is_file());
    // The files speak of the installed system's paths, not the stage's.
    let pc = std::fs::read_to_string(libdir.join("pkgconfig/plsr.pc")).unwrap();
    for line in [
        "prefix=/opt/plsr-test",
        "libdir=${prefix}/lib",
        "includedir=${prefix}/include",
    ] {
        assert!(pc.lines().any(|l| l == line), "plsr.pc lacks {line}:\n{pc}");
    }
    let manifest = std::fs::read_to_string(libdir.join("plsr/install-manifest.txt")).unwrap();
    assert!(
        manifest.lines().all(|l| l[2..].starts_with("/opt")),
        "{manifest}"
    );
    assert!(manifest.contains("d /opt\n"), "{manifest}");
    // The CMake package finds its files relative to itself, wherever the
    // tree is (here: still in the stage).
    let work = tempfile::tempdir().unwrap();
    let found = cmake_find_plsr(work.path(), &libdir.join("cmake/plsr"), "0.2")
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(
        found.contains(&format!(
            "plsr {version}: {}/libplsr.so.{version} {}",
            libdir.display(),
            staged.join("include").display()
        )),
        "{found}"
    );
    make("uninstall", &vars);
    let left = entries(stage);
    assert!(left.is_empty(), "make uninstall left {left:?}");
}
