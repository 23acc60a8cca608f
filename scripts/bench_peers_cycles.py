#!/usr/bin/env python3
"""Peer renderer for `plsr bench peers`: Blender's Cycles on the same scenes.

`plsr bench peers` writes each scene twice, in plsr's format and as Mitsuba 3
XML (the meshes as shared OBJ files, the environment as a shared EXR). This
script rebuilds each XML scene in Cycles (through Blender's Python module,
PyPI `bpy`) and is started with a JSON job list:

  {"threads": 2, "scenes": [{"name": "cornell", "xml": ".../cornell.xml",
   "spp": 16, "image": ".../cornell.cycles.f32",
   "denoised_image": ".../cornell.cycles-oidn.f32"}, ...]}

For each scene it builds the Cycles scene (untimed), renders once at the
job's spp (untimed warm-up: BVH, light importance maps, first-use costs), then
renders `--repeats` more times with seeds 1..N WITHOUT denoising and keeps the
fastest; every timed render's image is written, one after the other, as raw
little-endian float32 RGB rows (top row first) to the job's `image` path
(plsr scores each against its reference and averages). If the job has a
`denoised_image`, the same is done again (one untimed warm-up, then N timed
renders with seeds 1..N) with Cycles' built-in OpenImageDenoise on the CPU
(albedo + normal guiding passes, prefilter ACCURATE, quality HIGH: Blender's
defaults), and those images go to `denoised_image`. The time is the wall time
of `bpy.ops.render.render()`: path tracing (plus denoising in the denoised
variant) and Blender's per-render overhead; with persistent data (default,
see below) Cycles keeps the warm-up's BVH and importance maps, so like
Mitsuba's timing it excludes scene construction. Building the Blender scene
and reading the image back are not timed. Progress goes to stderr (Blender's own output
too); the result is one line of JSON on stdout:

  {"blender_version": "4.5.x", "device": "CPU",
   "scenes": [{"name": ..., "seconds": ..., "denoised_seconds": ... or null,
               "width": ..., "height": ...}]}

Exits 2 if `bpy` cannot be imported.

Setup (Debian 12; bpy 4.5 wheels need exactly Python 3.11):

  python3.11 -m venv /work/venvs/bpy
  /work/venvs/bpy/bin/pip install 'bpy==4.5.*'     # pulls numpy 1.26
  /work/venvs/bpy/bin/python scripts/bench_peers_cycles.py JOBS.json

The XML subset read (what plsr writes; anything else is an error):
  * <integrator type="path"> with max_depth;
  * <sensor type="perspective">: fov, fov_axis (x, y, diagonal, smaller,
    larger), to_world (lookat / translate / rotate / scale / matrix),
    hdrfilm width and height, box rfilter, sample_count (unused: the job's
    spp rules);
  * <bsdf>: twosided wrapping diffuse, roughconductor / conductor,
    principled; bare roughdielectric / dielectric (a bare reflecting bsdf
    is made one-sided like Mitsuba's);
  * <shape type="obj"> with filename, face_normals, a <ref> (or an inline
    <bsdf>) and optionally <emitter type="area"> with rgb radiance;
  * <emitter type="envmap"> (filename, scale, to_world) or type="constant".

How the Mitsuba conventions are carried over:
  * Geometry and camera stay in the XML's raw coordinates: OBJs are imported
    with forward_axis='Y', up_axis='Z' (the identity, no Y-up conversion).
    Mitsuba's camera looks down its local +Z with +X to the left; Blender's
    looks down -Z with +X to the right, so camera = to_world * diag(-1,1,-1).
  * Environment: Mitsuba looks a local direction v up at
    u = atan2(v.x, -v.z) / 2pi, v = acos(v.y) / pi (+Y up); Cycles'
    equirectangular lookup of a vector b is u = (pi - atan2(b.y, b.x)) / 2pi,
    v = acos(b.z) / pi from the top (+Z up). They agree for
    b = (v.z, v.x, v.y), a cyclic axis permutation (a proper rotation), so
    the world shader feeds Generated (= ray direction) through a Mapping node
    (type VECTOR) rotating by permutation * inverse(to_world). Bilinear
    lookup ("Linear") as Mitsuba's. Mitsuba puts texel rows at
    theta = pi * row / (H - 1), Cycles at pi * (row + 0.5) / H: at most half
    a texel apart near the poles, none at the horizon.
  * Area emitters are one-sided in Mitsuba (they emit towards the side the
    geometric normal, from the triangle winding, faces): one-sided emission
    via a backfacing mix (Geometry.Backfacing mixes Emission with nothing),
    added to the surface's bsdf (Mitsuba's emitter shape also reflects), and
    the material's emission sampling set to FRONT so Cycles' light sampling
    only picks the emitting side. Emission strength 1 = radiance.
  * Roughness: Mitsuba's GGX alpha = Blender roughness^2, so roughness =
    sqrt(alpha). Conductor: Metallic BSDF, fresnel "Physical Conductor" with
    IOR = eta and Extinction = k, plain GGX (not multiscatter). Dielectric:
    Glass BSDF, plain GGX, IOR = int_ior / ext_ior.
  * Principled: Mitsuba's (and plsr's Mitsuba-mode) principled simply adds
    Burley's diffuse to a GGX specular; Cycles' Principled BSDF couples them
    (the diffuse loses what the specular reflects), which made the blue
    principled sphere 6 % darker than plsr's reference. So the lobes are
    built apart and added: Diffuse BSDF (Lambert; Burley's albedo is within
    2 % of Lambert's at roughness 0.4) with base_color * (1 - metallic), plus
    a Principled BSDF with a BLACK base colour, i.e. its dielectric specular
    layer alone (exact Fresnel at eta, plain GGX, alpha = roughness^2 as
    Mitsuba), mixed by `metallic` with a fully metallic Principled of
    base_color. eta from Mitsuba's specular (eta = 2 / (1 - sqrt(0.08
    specular)) - 1, 1.5 at 0.5), Specular IOR Level 0.5 (neutral), Specular
    Tint white mixed towards the base colour's hue by spec_tint and
    Anisotropic as given (both approximations; 0 in plsr's scenes); sheen,
    clearcoat, spec_trans, flatness are ignored with a warning. Burley's
    retro-reflection shaping is not reproduced (no such closure in Cycles 4).

Fairness settings (all forced here, whatever Blender's defaults):
  * Cycles on the CPU, scene.render.threads_mode FIXED with the job's
    `threads`;
  * samples = spp exactly, adaptive sampling off, path guiding off (plsr and
    Mitsuba have neither); light tree on (Cycles' default light sampling);
  * no clamping (sample_clamp_direct = sample_clamp_indirect = 0), no
    filter glossy, reflective and refractive caustics on: nothing biased;
  * pixel filter BOX, width 1 px, as Mitsuba's box rfilter and plsr;
  * bounces: Mitsuba's max_depth counts path segments (1 = emitters only,
    2 = direct light only), i.e. max_depth - 1 scattering events; Cycles'
    max_bounces counts bounces after the first hit (0 = direct light only,
    Cycles adds one internally), i.e. max_bounces + 1 scattering events. So
    max_bounces = max_depth - 2 (checked: at max_bounces 0 the Cornell
    box's ceiling, lit only indirectly, renders black), and the diffuse, glossy, transmission,
    volume and transparent limits the same (none binds before the total);
  * the seed per render (scene.cycles.seed), no animated seed;
  * colour management Standard / look None / exposure 0 / gamma 1; the image
    is saved as 32-bit float OpenEXR (always linear scene-referred radiance,
    the view transform does not apply) and read back through bpy's image
    API;
  * persistent data ON (`--no-persistent-data` turns it off): without it
    every render() re-syncs the scene and rebuilds the BVH and, above all,
    the environment's importance map (about 1.2 s of the glossy-env scene's
    render() on 2 loaded cores, against 0.06 s for the BVH), which Mitsuba
    builds once at load; with it the untimed warm-up builds them and the
    timed renders only path trace (and denoise). The images are identical
    either way;
  * default tile size (one tile at these sizes), no compositing or
    sequencer; Cycles' default sampling pattern and light threshold (both
    unbiased). Russian roulette is Cycles' own (from the
    second bounce, throughput-based), Mitsuba's starts at depth 5: both
    unbiased.
"""

import argparse
import json
import math
import os
import re
import resource
import sys
import tempfile
import time
import xml.etree.ElementTree as ET


def log(msg):
    print(f"cycles: {msg}", file=sys.stderr, flush=True)


# ---------------------------------------------------------------- XML subset

def numbers(text):
    return [float(t) for t in re.split(r"[,\s]+", text.strip()) if t]


def vec3(el, default=0.0):
    """A Mitsuba `x/y/z` or `value` vector attribute set."""
    if el.get("value") is not None:
        v = numbers(el.get("value"))
        return v * 3 if len(v) == 1 else v
    return [float(el.get(k, default)) for k in "xyz"]


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(4)) for j in range(4)]
            for i in range(4)]


def identity():
    return [[float(i == j) for j in range(4)] for i in range(4)]


def normalize(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0]]


def parse_transform(el):
    """A Mitsuba <transform>: each child is applied after the previous ones
    (left-multiplied)."""
    m = identity()
    for c in el:
        if c.tag == "lookat":
            o = numbers(c.get("origin"))
            t = numbers(c.get("target"))
            up = numbers(c.get("up", "0, 1, 0"))
            d = normalize([t[i] - o[i] for i in range(3)])
            left = normalize(cross(up, d))
            new_up = cross(d, left)
            step = [[left[i], new_up[i], d[i], o[i]] for i in range(3)]
            step.append([0.0, 0.0, 0.0, 1.0])
        elif c.tag == "translate":
            v = vec3(c)
            step = identity()
            for i in range(3):
                step[i][3] = v[i]
        elif c.tag == "scale":
            v = vec3(c, default=1.0)
            step = identity()
            for i in range(3):
                step[i][i] = v[i]
        elif c.tag == "rotate":
            axis = normalize(vec3(c))
            a = math.radians(float(c.get("angle")))
            x, y, z = axis
            s, co = math.sin(a), math.cos(a)
            t = 1.0 - co
            step = [[t * x * x + co, t * x * y - s * z, t * x * z + s * y, 0.0],
                    [t * x * y + s * z, t * y * y + co, t * y * z - s * x, 0.0],
                    [t * x * z - s * y, t * y * z + s * x, t * z * z + co, 0.0],
                    [0.0, 0.0, 0.0, 1.0]]
        elif c.tag == "matrix":
            v = numbers(c.get("value"))
            if len(v) == 9:
                step = [v[0:3] + [0.0], v[3:6] + [0.0], v[6:9] + [0.0],
                        [0.0, 0.0, 0.0, 1.0]]
            elif len(v) == 16:
                step = [v[0:4], v[4:8], v[8:12], v[12:16]]
            else:
                raise ValueError(f"matrix with {len(v)} values")
        else:
            raise ValueError(f"unsupported transform element <{c.tag}>")
        m = mat_mul(step, m)
    return m


def parse_params(el):
    """The typed properties of an element: name -> value."""
    out = {}
    for c in el:
        name = c.get("name")
        if c.tag in ("float", "integer"):
            out[name] = float(c.get("value"))
        elif c.tag == "boolean":
            out[name] = c.get("value").strip().lower() == "true"
        elif c.tag == "string":
            out[name] = c.get("value")
        elif c.tag == "rgb":
            v = numbers(c.get("value"))
            out[name] = v * 3 if len(v) == 1 else v
        elif c.tag == "transform":
            out[name or "to_world"] = parse_transform(c)
        elif c.tag in ("spectrum", "texture"):
            raise ValueError(f"<{c.tag} name={name!r}> is outside the subset")
    return out


def parse_bsdf(el):
    return {"type": el.get("type"), "id": el.get("id"),
            "params": parse_params(el),
            "children": [parse_bsdf(c) for c in el if c.tag == "bsdf"]}


def parse_scene(path):
    root = ET.parse(path).getroot()
    base = os.path.dirname(os.path.abspath(path))
    resolve = lambda f: f if os.path.isabs(f) else os.path.join(base, f)
    scene = {"max_depth": -1, "bsdfs": {}, "shapes": [], "env": None}
    for el in root:
        if el.tag == "integrator":
            if el.get("type") not in ("path",):
                raise ValueError(f"integrator {el.get('type')!r} unsupported")
            scene["max_depth"] = int(parse_params(el).get("max_depth", -1))
        elif el.tag == "sensor":
            if el.get("type") != "perspective":
                raise ValueError(f"sensor {el.get('type')!r} unsupported")
            p = parse_params(el)
            film = el.find("film")
            fp = parse_params(film) if film is not None else {}
            rf = film.find("rfilter") if film is not None else None
            if rf is not None and rf.get("type") != "box":
                log(f"warning: rfilter {rf.get('type')!r}, Cycles uses a 1 px box")
            scene["camera"] = {
                "fov": p.get("fov", 39.3077), "fov_axis": p.get("fov_axis", "x"),
                "to_world": p.get("to_world", identity()),
                "width": int(fp.get("width", 768)), "height": int(fp.get("height", 576))}
        elif el.tag == "bsdf":
            b = parse_bsdf(el)
            scene["bsdfs"][b["id"]] = b
        elif el.tag == "shape":
            if el.get("type") != "obj":
                raise ValueError(f"shape {el.get('type')!r} unsupported")
            p = parse_params(el)
            shape = {"filename": resolve(p["filename"]),
                     "face_normals": p.get("face_normals", False),
                     "bsdf": None, "radiance": None}
            if "to_world" in p and p["to_world"] != identity():
                raise ValueError("shape to_world is outside the subset")
            for c in el:
                if c.tag == "ref":
                    shape["bsdf"] = c.get("id")
                elif c.tag == "bsdf":
                    b = parse_bsdf(c)
                    b["id"] = b["id"] or f"inline{len(scene['shapes'])}"
                    scene["bsdfs"][b["id"]] = b
                    shape["bsdf"] = b["id"]
                elif c.tag == "emitter":
                    if c.get("type") != "area":
                        raise ValueError(f"shape emitter {c.get('type')!r}")
                    shape["radiance"] = parse_params(c)["radiance"]
            scene["shapes"].append(shape)
        elif el.tag == "emitter":
            p = parse_params(el)
            t = el.get("type")
            if t == "envmap":
                scene["env"] = {"type": t, "filename": resolve(p["filename"]),
                                "scale": p.get("scale", 1.0),
                                "to_world": p.get("to_world", identity())}
            elif t == "constant":
                scene["env"] = {"type": t, "radiance": p.get("radiance", [1.0] * 3)}
            else:
                raise ValueError(f"emitter {t!r} unsupported")
        elif el.tag in ("default",):
            raise ValueError("<default> parameters are outside the subset")
    if "camera" not in scene:
        raise ValueError("no sensor")
    return scene


# ---------------------------------------------------------------- Blender scene

def rgba(c):
    return (c[0], c[1], c[2], 1.0)


def bsdf_nodes(nt, b):
    """Shader nodes for one Mitsuba bsdf; returns the output socket."""
    nodes, links = nt.nodes, nt.links
    t, p = b["type"], b["params"]
    if t == "twosided":
        # Cycles' surfaces are two-sided already (the shading frame flips).
        if len(b["children"]) != 1:
            raise ValueError("twosided with two different bsdfs is unsupported")
        return bsdf_nodes(nt, b["children"][0])
    if t in ("diffuse",):
        n = nodes.new("ShaderNodeBsdfDiffuse")
        n.inputs["Color"].default_value = rgba(p.get("reflectance", [0.5] * 3))
        n.inputs["Roughness"].default_value = 0.0  # Lambert
        return n.outputs["BSDF"]
    if t in ("roughconductor", "conductor"):
        if p.get("distribution", "beckmann" if t == "roughconductor" else "ggx") != "ggx":
            raise ValueError("roughconductor: only the ggx distribution is supported")
        if "eta" not in p or "k" not in p:
            raise ValueError("conductor: eta and k must be given as rgb")
        n = nodes.new("ShaderNodeBsdfMetallic")
        n.distribution = "GGX"
        n.fresnel_type = "PHYSICAL_CONDUCTOR"
        n.inputs["IOR"].default_value = p["eta"]
        n.inputs["Extinction"].default_value = p["k"]
        alpha = p.get("alpha", 0.1) if t == "roughconductor" else 0.0
        n.inputs["Roughness"].default_value = math.sqrt(alpha)
        sr = p.get("specular_reflectance", [1.0] * 3)
        if any(abs(x - 1.0) > 1e-6 for x in sr):
            log(f"warning: conductor specular_reflectance {sr} ignored")
        return n.outputs["BSDF"]
    if t in ("roughdielectric", "dielectric"):
        if p.get("distribution", "beckmann" if t == "roughdielectric" else "ggx") != "ggx":
            raise ValueError("roughdielectric: only the ggx distribution is supported")
        n = nodes.new("ShaderNodeBsdfGlass")
        n.distribution = "GGX"
        n.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        alpha = p.get("alpha", 0.1) if t == "roughdielectric" else 0.0
        n.inputs["Roughness"].default_value = math.sqrt(alpha)
        n.inputs["IOR"].default_value = p.get("int_ior", 1.5046) / p.get("ext_ior", 1.000277)
        return n.outputs["BSDF"]
    if t == "principled":
        return principled_nodes(nt, p)
    raise ValueError(f"bsdf {t!r} unsupported")


def principled_nodes(nt, p):
    """Mitsuba's principled (Burley diffuse + GGX specular, simply added):
    Cycles' Principled BSDF couples its layers (the diffuse loses what the
    specular reflects), 5-7 % darker on a blue dielectric. So the lobes are
    built apart and added: a Lambert Diffuse BSDF with base_color *
    (1 - metallic) (Burley's albedo is within 2 % of Lambert's), plus the
    specular alone as a Principled BSDF with a black base colour (its
    dielectric layer: exact Fresnel at eta, plain GGX), mixed by `metallic`
    with a fully metallic Principled of base_color (Schlick-like F82 as
    Mitsuba's Schlick(base_color))."""
    nodes, links = nt.nodes, nt.links
    base = p.get("base_color", [0.5] * 3)
    metallic = p.get("metallic", 0.0)
    rough = p.get("roughness", 0.5)
    eta = p["eta"] if "eta" in p else \
        2.0 / (1.0 - math.sqrt(0.08 * p.get("specular", 0.5))) - 1.0
    tint = p.get("spec_tint", 0.0)
    lum = 0.2126 * base[0] + 0.7152 * base[1] + 0.0722 * base[2]
    hue = [c / lum for c in base] if lum > 0 else [1.0] * 3
    for k in ("sheen", "clearcoat", "spec_trans", "flatness"):
        if p.get(k, 0.0):
            log(f"warning: principled {k}={p[k]} ignored")

    def specular(color, metal):
        n = nodes.new("ShaderNodeBsdfPrincipled")
        n.distribution = "GGX"
        n.inputs["Base Color"].default_value = rgba(color)
        n.inputs["Metallic"].default_value = metal
        n.inputs["Roughness"].default_value = rough
        n.inputs["IOR"].default_value = eta
        n.inputs["Specular IOR Level"].default_value = 0.5
        # Mitsuba blends Schlick(hue * f0) in by spec_tint; Cycles tints f0.
        n.inputs["Specular Tint"].default_value = rgba(
            [(1 - tint) + tint * h for h in hue])
        n.inputs["Anisotropic"].default_value = p.get("anisotropic", 0.0)
        return n.outputs["BSDF"]

    spec = None
    if metallic < 1.0:
        spec = specular([0.0] * 3, 0.0)
    if metallic > 0.0:
        metal = specular(base, 1.0)
        if spec is None:
            spec = metal
        else:
            mix = nodes.new("ShaderNodeMixShader")
            mix.inputs["Fac"].default_value = metallic
            links.new(spec, mix.inputs[1])
            links.new(metal, mix.inputs[2])
            spec = mix.outputs["Shader"]
    if metallic >= 1.0:
        return spec
    diff = nodes.new("ShaderNodeBsdfDiffuse")
    diff.inputs["Color"].default_value = rgba([c * (1.0 - metallic) for c in base])
    diff.inputs["Roughness"].default_value = 0.0
    add = nodes.new("ShaderNodeAddShader")
    links.new(diff.outputs["BSDF"], add.inputs[0])
    links.new(spec, add.inputs[1])
    return add.outputs["Shader"]


def one_sided(nt, socket):
    """Mix `socket` (front side) with nothing (back side)."""
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    mix = nt.nodes.new("ShaderNodeMixShader")
    nt.links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
    nt.links.new(socket, mix.inputs[1])  # Fac 0 = front face
    return mix.outputs["Shader"]


def make_material(bpy, name, b, radiance):
    mat = bpy.data.materials.new(name)
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    surface = bsdf_nodes(nt, b)
    if b["type"] in ("diffuse", "roughconductor", "conductor", "principled"):
        # A bare reflecting bsdf is black from behind in Mitsuba.
        surface = one_sided(nt, surface)
    if radiance is not None:
        em = nt.nodes.new("ShaderNodeEmission")
        em.inputs["Color"].default_value = rgba(radiance)
        em.inputs["Strength"].default_value = 1.0
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(surface, add.inputs[0])
        nt.links.new(one_sided(nt, em.outputs["Emission"]), add.inputs[1])
        surface = add.outputs["Shader"]
        mat.cycles.emission_sampling = "FRONT"
    else:
        mat.cycles.emission_sampling = "NONE"
    nt.links.new(surface, out.inputs["Surface"])
    return mat


def invert3(m):
    a, b, c = m[0][:3], m[1][:3], m[2][:3]
    det = (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
           + a[2] * (b[0] * c[1] - b[1] * c[0]))
    inv = [[(b[1] * c[2] - b[2] * c[1]) / det, (a[2] * c[1] - a[1] * c[2]) / det,
            (a[1] * b[2] - a[2] * b[1]) / det],
           [(b[2] * c[0] - b[0] * c[2]) / det, (a[0] * c[2] - a[2] * c[0]) / det,
            (a[2] * b[0] - a[0] * b[2]) / det],
           [(b[0] * c[1] - b[1] * c[0]) / det, (a[1] * c[0] - a[0] * c[1]) / det,
            (a[0] * b[1] - a[1] * b[0]) / det]]
    return inv


def make_world(bpy, env):
    from mathutils import Matrix
    world = bpy.data.worlds.new("world")
    world.use_nodes = True
    nt = world.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputWorld")
    bg = nt.nodes.new("ShaderNodeBackground")
    nt.links.new(bg.outputs["Background"], out.inputs["Surface"])
    if env is None:
        bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        bg.inputs["Strength"].default_value = 0.0
        return world
    if env["type"] == "constant":
        bg.inputs["Color"].default_value = rgba(env["radiance"])
        bg.inputs["Strength"].default_value = 1.0
        return world
    img = bpy.data.images.load(env["filename"])
    img.colorspace_settings.name = "Linear Rec.709"
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = img
    tex.projection = "EQUIRECTANGULAR"
    tex.interpolation = "Linear"
    coords = nt.nodes.new("ShaderNodeTexCoord")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.vector_type = "VECTOR"
    # Mitsuba local v = inverse(to_world) d; Cycles must look up b = P v with
    # P: (x, y, z) -> (z, x, y) (see the docstring).
    perm = Matrix(((0, 0, 1), (1, 0, 0), (0, 1, 0)))
    rot = perm @ Matrix(invert3(env["to_world"]))
    euler = rot.normalized().to_euler("XYZ")
    mapping.inputs["Rotation"].default_value = (euler.x, euler.y, euler.z)
    nt.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = env["scale"]
    return world


def import_obj(bpy, path):
    before = set(bpy.data.objects)
    # forward Y, up Z: Blender's identity, the file's coordinates unchanged.
    bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z",
                          use_split_objects=False, use_split_groups=False)
    return [o for o in bpy.data.objects if o not in before]


def build_scene(bpy, desc, threads, persistent=True):
    from mathutils import Matrix
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for o in list(bpy.data.objects):
        bpy.data.objects.remove(o)

    # materials: shared per bsdf id, own material for each emitter
    mats = {}
    for i, shape in enumerate(desc["shapes"]):
        b = desc["bsdfs"][shape["bsdf"]] if shape["bsdf"] else \
            {"type": "diffuse", "params": {}, "children": [], "id": None}
        if shape["radiance"] is not None:
            mat = make_material(bpy, f"emitter{i}", b, shape["radiance"])
        else:
            key = shape["bsdf"]
            if key not in mats:
                mats[key] = make_material(bpy, str(key), b, None)
            mat = mats[key]
        for o in import_obj(bpy, shape["filename"]):
            mesh = o.data
            mesh.materials.clear()
            mesh.materials.append(mat)
            if shape["face_normals"]:
                if "custom_normal" in mesh.attributes:
                    mesh.attributes.remove(mesh.attributes["custom_normal"])
                mesh.shade_flat()
            else:
                # the file's vertex normals (custom normals) if it has them,
                # else Blender's smooth vertex normals
                mesh.shade_smooth()
                if "sharp_edge" in mesh.attributes and not mesh.has_custom_normals:
                    mesh.attributes.remove(mesh.attributes["sharp_edge"])

    # camera
    cd = desc["camera"]
    cam_data = bpy.data.cameras.new("camera")
    cam = bpy.data.objects.new("camera", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    flip = [[-1.0, 0, 0, 0], [0, 1.0, 0, 0], [0, 0, -1.0, 0], [0, 0, 0, 1.0]]
    cam.matrix_world = Matrix(mat_mul(cd["to_world"], flip))
    w, h = cd["width"], cd["height"]
    axis_len = {"x": w, "y": h, "diagonal": math.hypot(w, h),
                "smaller": min(w, h), "larger": max(w, h)}[cd["fov_axis"]]
    fov_x = 2.0 * math.atan(math.tan(math.radians(cd["fov"]) / 2.0) * w / axis_len)
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.angle_x = fov_x
    cam_data.shift_x = cam_data.shift_y = 0.0
    cam_data.clip_start = 1e-4
    cam_data.clip_end = 1e9

    scene.world = make_world(bpy, desc["env"])

    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y = w, h
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_border = False
    r.film_transparent = False
    r.use_compositing = False
    r.use_sequencer = False
    r.use_persistent_data = persistent
    r.dither_intensity = 0.0
    if threads:
        r.threads_mode = "FIXED"
        r.threads = int(threads)
    img = r.image_settings
    img.file_format = "OPEN_EXR"
    img.color_mode = "RGB"
    img.color_depth = "32"
    img.exr_codec = "NONE"

    vs = scene.view_settings
    scene.display_settings.display_device = "sRGB"
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    vs.use_curve_mapping = False

    c = scene.cycles
    c.device = "CPU"
    c.feature_set = "SUPPORTED"
    c.use_adaptive_sampling = False
    c.use_guiding = False
    c.use_light_tree = True
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.caustics_reflective = True
    c.caustics_refractive = True
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.use_animated_seed = False
    c.time_limit = 0.0
    c.use_layer_samples = "IGNORE"
    md = desc["max_depth"]
    bounces = 1024 if md < 0 else max(0, md - 2)
    c.max_bounces = bounces
    for k in ("diffuse_bounces", "glossy_bounces", "transmission_bounces",
              "volume_bounces", "transparent_max_bounces"):
        setattr(c, k, bounces)
    c.min_light_bounces = 0
    c.min_transparent_bounces = 0
    c.denoiser = "OPENIMAGEDENOISE"
    c.denoising_input_passes = "RGB_ALBEDO_NORMAL"
    c.denoising_prefilter = "ACCURATE"
    c.denoising_quality = "HIGH"
    c.denoising_use_gpu = False
    c.use_denoising = False
    scene.view_layers[0].cycles.use_denoising = True  # the per-layer switch
    return scene


def cpu_seconds():
    ru = resource.getrusage(resource.RUSAGE_SELF)
    return ru.ru_utime + ru.ru_stime


def render(bpy, np, scene, spp, seed, denoise, path):
    """One render; returns (seconds, CPU seconds of all threads, float32
    HxWx3 top row first)."""
    scene.cycles.samples = spp
    scene.cycles.seed = seed
    scene.cycles.use_denoising = denoise
    c = cpu_seconds()
    t = time.perf_counter()
    bpy.ops.render.render()
    seconds = time.perf_counter() - t
    cpu = cpu_seconds() - c
    bpy.data.images["Render Result"].save_render(path, scene=scene)
    im = bpy.data.images.load(path)
    try:
        w, h = im.size
        px = np.empty(w * h * im.channels, dtype=np.float32)
        im.pixels.foreach_get(px)
        # bpy images are stored bottom row first
        rgb = px.reshape(h, w, im.channels)[::-1, :, :3]
    finally:
        bpy.data.images.remove(im)
    return seconds, cpu, np.ascontiguousarray(rgb, dtype="<f4")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("jobs", help="the JSON job list plsr wrote")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--no-persistent-data", action="store_true",
                    help="time Cycles' scene sync (BVH, light importance maps) too")
    args = ap.parse_args()
    with open(args.jobs) as f:
        jobs = json.load(f)

    # Blender prints to stdout (import banner, render progress): route the
    # process' stdout to stderr and keep the real one for the JSON result.
    sys.stdout.flush()
    real_stdout = os.dup(1)
    os.dup2(2, 1)
    try:
        import bpy
        import numpy as np
    except Exception as e:  # noqa: BLE001 - any import failure means "no peer"
        os.dup2(real_stdout, 1)
        print(f"cannot import bpy (Blender as a Python module): {e}", file=sys.stderr)
        sys.exit(2)
    threads = jobs.get("threads")
    version = ".".join(str(v) for v in bpy.app.version)

    results = []
    with tempfile.TemporaryDirectory(prefix="plsr-cycles-") as tmp:
        exr = os.path.join(tmp, "render.exr")
        for job in jobs["scenes"]:
            name, spp = job["name"], int(job["spp"])
            log(f"{name}: building the scene from {job['xml']}")
            scene = build_scene(bpy, parse_scene(job["xml"]), threads,
                                not args.no_persistent_data)
            result = {"name": name, "seconds": None, "denoised_seconds": None,
                      "width": scene.render.resolution_x,
                      "height": scene.render.resolution_y}
            variants = [("seconds", False, job["image"])]
            if job.get("denoised_image"):
                variants.append(("denoised_seconds", True, job["denoised_image"]))
            for key, denoise, out in variants:
                what = "with OIDN" if denoise else "no denoising"
                log(f"{name}: warm-up render at {spp} spp, {what}")
                render(bpy, np, scene, spp, 1000, denoise, exr)
                best = float("inf")
                frames = []
                for r in range(max(1, args.repeats)):
                    seconds, cpu, image = render(bpy, np, scene, spp, r + 1, denoise, exr)
                    # CPU time / threads well below the wall time: other
                    # processes took cores, the timing is not clean.
                    log(f"{name}: seed {r + 1}, {what}: {seconds:.3f} s "
                        f"(CPU {cpu:.2f} s)")
                    best = min(best, seconds)
                    frames.append(image)
                np.concatenate([f.ravel() for f in frames]).tofile(out)
                result[key] = best
            results.append(result)
    sys.stdout.flush()
    os.dup2(real_stdout, 1)
    print(json.dumps({"blender_version": version, "device": "CPU",
                      "scenes": results}), flush=True)


if __name__ == "__main__":
    main()
