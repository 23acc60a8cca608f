#!/usr/bin/env python3
"""Writes src/scene/mitsuba/conductors.rs: the complex index of refraction
(eta, k) that Mitsuba 3's RGB variants give each of its named conductors
(`<string name="material" value="..."/>`), as Mitsuba computes it from its
spectral data (data/ior/*.spd, shipped with the `mitsuba` package): the
spectrum integrated against the CIE 1931 curves and converted to linear
sRGB, negative components clamped to 0 as Mitsuba clamps them.

Run: python3 scripts/mitsuba_conductors.py > src/scene/mitsuba/conductors.rs
(needs `pip install mitsuba`)."""
import os
import mitsuba as mi

mi.set_variant("scalar_rgb")
mi.set_log_level(mi.LogLevel.Error)
data = os.path.join(os.path.dirname(mi.__file__), "data", "ior")
names = sorted({f.split(".")[0] for f in os.listdir(data) if f.endswith(".spd")})
rows = []
for n in names:
    p = mi.traverse(mi.load_dict({"type": "conductor", "material": n}))
    eta = [float(x) for x in p["eta.value"]]
    k = [float(x) for x in p["k.value"]]
    rows.append((n, eta, k))
v = mi.__version__
print(f"""//! Mitsuba 3's named conductors (`conductor` and `roughconductor`'s
//! `material`), as the complex index of refraction `(eta, k)` its RGB
//! variants use: Mitsuba {v}'s spectral data integrated to linear sRGB by
//! Mitsuba itself. Written by `scripts/mitsuba_conductors.py`; do not edit.

/// `(name, eta, k)` of every named conductor, by name.
pub(super) const CONDUCTORS: [(&str, [f64; 3], [f64; 3]); {len(rows)}] = [""")
fmt = lambda a: "[" + ", ".join(f"{x:.6}" for x in a) + "]"
for n, eta, k in rows:
    print(f'    ("{n}", {fmt(eta)}, {fmt(k)}),')
print("];")
