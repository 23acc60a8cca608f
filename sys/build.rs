//! Build script of the Embree 3 -sys crate.
//!
//! Where Embree is looked for, in order:
//! 1. `EMBREE_DIR`: a prefix with `include/embree3/rtcore.h` and `lib/` (or `lib64/`).
//! 2. pkg-config `embree3` (not shipped by Debian, but by some source builds).
//! 3. Debian's paths: `/usr/include/embree3` and `/usr/lib/<multiarch>`.
//!
//! The header's version must be 3.x; anything else stops the build with a message
//! naming the package to install.

use std::env;
use std::path::{Path, PathBuf};

const INSTALL_HINT: &str =
    "install Debian's package `libembree-dev` (apt-get install libembree-dev) \
     or point EMBREE_DIR at an Embree 3 installation prefix";

struct Found {
    include_dir: PathBuf,
    lib_dirs: Vec<PathBuf>,
}

fn from_embree_dir() -> Option<Found> {
    let dir = PathBuf::from(env::var_os("EMBREE_DIR")?);
    let include_dir = dir.join("include");
    if !include_dir.join("embree3/rtcore.h").is_file() {
        panic!(
            "EMBREE_DIR={} has no include/embree3/rtcore.h; {INSTALL_HINT}",
            dir.display()
        );
    }
    let lib_dirs = ["lib", "lib64"]
        .iter()
        .map(|l| dir.join(l))
        .filter(|p| p.is_dir())
        .collect();
    Some(Found {
        include_dir,
        lib_dirs,
    })
}

fn from_pkg_config() -> Option<Found> {
    let lib = pkg_config::Config::new()
        .atleast_version("3.0")
        .cargo_metadata(false)
        .probe("embree3")
        .ok()?;
    let include_dir = lib
        .include_paths
        .iter()
        .find(|p| p.join("embree3/rtcore.h").is_file())
        .cloned()?;
    Some(Found {
        include_dir,
        lib_dirs: lib.link_paths,
    })
}

fn from_debian_paths() -> Option<Found> {
    let include_dir = PathBuf::from("/usr/include");
    if !include_dir.join("embree3/rtcore.h").is_file() {
        return None;
    }
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let env_abi = env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    let multiarch = format!("/usr/lib/{arch}-{os}-{env_abi}");
    let lib_dirs = [
        multiarch.as_str(),
        "/usr/lib",
        "/usr/lib64",
        "/usr/local/lib",
    ]
    .iter()
    .map(PathBuf::from)
    .filter(|p| p.join("libembree3.so").exists())
    .collect::<Vec<_>>();
    if lib_dirs.is_empty() {
        return None;
    }
    Some(Found {
        include_dir,
        lib_dirs,
    })
}

/// Reads `RTC_VERSION_MAJOR/MINOR/PATCH` from `rtcore_config.h`.
fn header_version(include_dir: &Path) -> (u32, u32, u32) {
    let path = include_dir.join("embree3/rtcore_config.h");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}; {INSTALL_HINT}", path.display()));
    let field = |name: &str| -> u32 {
        text.lines()
            .filter_map(|l| l.trim().strip_prefix("#define "))
            .filter_map(|l| l.strip_prefix(name))
            .find_map(|rest| rest.trim().parse().ok())
            .unwrap_or_else(|| panic!("{} does not define {name}", path.display()))
    };
    (
        field("RTC_VERSION_MAJOR"),
        field("RTC_VERSION_MINOR"),
        field("RTC_VERSION_PATCH"),
    )
}

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");
    println!("cargo:rerun-if-changed=build.rs");

    let found = from_embree_dir()
        .or_else(from_pkg_config)
        .or_else(from_debian_paths)
        .unwrap_or_else(|| panic!("Embree 3 not found; {INSTALL_HINT}"));

    let (major, minor, patch) = header_version(&found.include_dir);
    if major != 3 {
        panic!(
            "found Embree {major}.{minor}.{patch} in {}, but plsr needs Embree 3.x; {INSTALL_HINT}",
            found.include_dir.display()
        );
    }

    for dir in &found.lib_dirs {
        println!("cargo:rustc-link-search=native={}", dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=embree3");
    // Exposed to dependents as DEP_EMBREE3_INCLUDE / DEP_EMBREE3_VERSION.
    println!("cargo:include={}", found.include_dir.display());
    println!("cargo:version={major}.{minor}.{patch}");

    let header = found.include_dir.join("embree3/rtcore.h");
    println!("cargo:rerun-if-changed={}", header.display());
    let bindings = bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", found.include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .layout_tests(false)
        .derive_default(true)
        .generate()
        .unwrap_or_else(|e| {
            panic!(
                "bindgen failed on {}: {e}; is libclang-dev installed?",
                header.display()
            )
        });
    let out = PathBuf::from(env::var("OUT_DIR").unwrap());
    bindings
        .write_to_file(out.join("bindings.rs"))
        .expect("cannot write bindings.rs");
    std::fs::write(
        out.join("version.rs"),
        format!("{}", major * 10000 + minor * 100 + patch),
    )
    .expect("cannot write version.rs");
}
