//! Compositing's paired render (`render_pair_sums`: the renders with and
//! without the virtual objects in one wavefront, a path traced once until
//! it meets a virtual object) gives both films bit for bit as two renders
//! do: every field of every pixel's sums, for the general integrator and
//! every instruction set of the kernel.

use crate::vectorised::{isas, scene_from, Case};
use plsr::film::FilmSums;
use plsr::integrator::{Isa, RayStats};
use plsr::render::{render_pair_sums, render_sums, RenderOptions};

/// Every field of every pixel's sums, as bit patterns.
fn bits(sums: &FilmSums) -> Vec<u64> {
    let mut out = Vec::new();
    for p in sums.pixels() {
        out.extend(p.sum.to_array().map(f64::to_bits));
        out.extend(p.sum_sq.to_array().map(f64::to_bits));
        out.extend([p.samples as u64, p.hits as u64, p.depth.to_bits()]);
        out.extend(p.normal.to_array().map(|x| x.to_bits() as u64));
        out.extend(p.albedo.to_array().map(|x| x.to_bits() as u64));
        out.extend([p.object_id.to_bits() as u64, p.virtual_hits as u64]);
    }
    out
}

fn options(kernel: Option<Isa>, tile_size: u32) -> RenderOptions {
    RenderOptions {
        threads: Some(2),
        tile_size,
        vectorised: kernel.is_some(),
        isa: kernel,
    }
}

fn assert_equal(what: &str, film: &str, expected: &FilmSums, got: &FilmSums) {
    let (a, b) = (bits(expected), bits(got));
    assert_eq!(a.len(), b.len());
    if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
        panic!(
            "{what}: the film {film} differs at word {i} of {} (pixel {}): {} of them differ",
            a.len(),
            i / 17,
            (0..a.len()).filter(|&i| a[i] != b[i]).count()
        );
    }
}

/// Renders `case` paired with the general integrator and every kernel
/// (and odd tiles), compares both films with two plain renders of the
/// general integrator, and returns the kernel's ray counts.
fn assert_paired_exact(what: &str, case: &Case) -> RayStats {
    let mut job = case.job;
    job.hide_virtual = false;
    let reference = options(None, 16);
    let (with, _) = render_sums(&case.scene, &job, &reference, &|_, _| true).unwrap();
    let hidden = plsr::render::RenderJob {
        hide_virtual: true,
        ..job
    };
    let (without, _) = render_sums(&case.scene, &hidden, &reference, &|_, _| true).unwrap();
    assert_ne!(
        bits(&with),
        bits(&without),
        "{what}: the virtual objects change the image"
    );
    assert!(
        with.pixels().iter().any(|p| p.virtual_hits > 0),
        "{what}: the virtual objects are in view"
    );
    let mut kernel_rays = RayStats::default();
    let runs = std::iter::once((None, 16))
        .chain(isas().into_iter().map(|isa| (Some(isa), 16)))
        .chain([(Some(Isa::best()), 7)]);
    for (kernel, tile_size) in runs {
        let name = format!(
            "{what}, {} with {tile_size}-pixel tiles",
            kernel.map_or("general integrator", |k| k.name())
        );
        let (w, o, stats) =
            render_pair_sums(&case.scene, &job, &options(kernel, tile_size), &|_, _| true).unwrap();
        assert_eq!(stats.vectorised, kernel, "{name}: kernel choice");
        assert_equal(&name, "with the virtual objects", &with, &w);
        assert_equal(&name, "without the virtual objects", &without, &o);
        if kernel.is_some() {
            kernel_rays = stats.rays;
            assert!(stats.rays.forked > 0, "{name}: no path forked");
        }
    }
    kernel_rays
}

const CORNELL: &str =
    "[camera]\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
     vfov = 37\nresolution = [29, 27]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n";

const VIRTUAL: &str = "[[shapes]]\ntype = \"sphere\"\ncenter = [300, 120, 250]\nradius = 110\nvirtual = true\n\n\
     [[shapes]]\ntype = \"rectangle\"\nvirtual = true\n\
     transform = { scale = 60, rotate = { axis = [0, 1, 0], angle = 30 }, translate = [150, 300, 200] }\n\n";

const POINT: &str =
    "[[lights]]\ntype = \"point\"\nposition = [278, 500, 100]\nintensity = [90000, 90000, 90000]\n\n";

#[test]
fn a_paired_render_equals_two_renders_bit_for_bit() {
    // The Cornell box with a virtual sphere and panel, lit by a point
    // light: forks at the camera and at every bounce, shadow rays blocked
    // by the box that pass the virtual objects' bounds asked again.
    let text = format!("[render]\nspp = 3\nmax_depth = 4\nseed = 3\n\n{CORNELL}{VIRTUAL}{POINT}");
    let mut case = scene_from("paired", &text);
    let rays = assert_paired_exact("point light", &case);
    assert!(rays.shadow_again > 0, "no shadow ray asked again");
    assert!(
        rays.o_rays * 2 < rays.camera + rays.bounce,
        "the render without the objects traced most rays again: {rays:?}"
    );
    // Direct light only; long paths with early roulette.
    case.job.max_depth = 1;
    assert_paired_exact("max_depth 1", &case);
    case.job.max_depth = 8;
    case.job.rr_depth = 2;
    assert_paired_exact("max_depth 8, roulette from 2", &case);
}

#[test]
fn paired_renders_with_emitters_and_skies_are_bit_identical() {
    // An area light (emission found by bounce rays, MIS), a constant sky
    // through the box's open side, and a virtual glass sphere (refraction,
    // a delta BSDF with no light sample).
    let area = "[[shapes]]\ntype = \"rectangle\"\nemission = [30, 30, 30]\n\
         transform = { scale = 60, rotate = { axis = [1, 0, 0], angle = 90 }, translate = [278, 540, 250] }\n\n";
    let text = format!("[render]\nspp = 2\nmax_depth = 5\nseed = 8\n\n{CORNELL}{VIRTUAL}{area}");
    assert_paired_exact("area light", &scene_from("paired-area", &text));
    let sky = "[environment]\nradiance = [0.4, 0.5, 0.7]\n\n";
    let glass = "[[materials]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5\n\n\
         [[shapes]]\ntype = \"sphere\"\nmaterial = \"glass\"\ncenter = [180, 380, 150]\nradius = 70\nvirtual = true\n\n";
    let text = format!(
        "[render]\nspp = 2\nmax_depth = 6\nseed = 9\n\n{CORNELL}{VIRTUAL}{glass}{sky}{POINT}"
    );
    assert_paired_exact(
        "sky, point light and glass",
        &scene_from("paired-sky", &text),
    );
}

#[test]
fn paired_renders_through_a_fisheye_are_bit_identical() {
    // Pixels without rays: lanes and pixels no longer match one to one.
    let text = format!(
        "[render]\nspp = 2\nmax_depth = 4\n\n[camera]\ntype = \"dual_fisheye\"\nposition = [278, 273, 250]\n\
         look_at = [278, 273, 500]\nup = [0, 1, 0]\nresolution = [40, 20]\n\n\
         [[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n{VIRTUAL}{POINT}"
    );
    assert_paired_exact("dual fisheye", &scene_from("paired-fisheye", &text));
}

#[test]
fn a_paired_render_refuses_a_job_that_hides_the_virtual_objects() {
    let text = format!("[render]\nspp = 1\n\n{CORNELL}{VIRTUAL}{POINT}");
    let case = scene_from("paired-hidden", &text);
    let job = plsr::render::RenderJob {
        hide_virtual: true,
        ..case.job
    };
    let e = render_pair_sums(&case.scene, &job, &options(None, 16), &|_, _| true).unwrap_err();
    assert!(e.to_string().contains("hide_virtual"), "{e}");
}
