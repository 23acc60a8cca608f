#!/usr/bin/env python3
"""Regenerates the demo table of docs/fitting.md from a real run, so that
the table cannot drift from what `plsr fit` does.

Runs the command the doc shows on assets/scenes/fit-room/ (its seed is the
scene's `[render] seed`), reads the guesses (fit-room.toml), the fitted
values (the written scene) and the truth (truth.toml), and replaces what
lies between the markers `<!-- fit-demo-table:begin -->` and
`<!-- fit-demo-table:end -->` in docs/fitting.md (the table and the loss
line) and docs/img/fitting-loss.png (the loss curve). Standard library only (Python 3.11). About seven minutes on two
cores.

    cargo build --release
    python3 scripts/fitting_table.py [--plsr target/release/plsr]
"""

import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ROOM = ROOT / "assets/scenes/fit-room"
DOC = ROOT / "docs/fitting.md"
BEGIN, END = "<!-- fit-demo-table:begin -->", "<!-- fit-demo-table:end -->"
PATTERNS = ["*.base_color", "*.reflectance", "*.roughness", "ball.metallic"]
ROWS = [
    "floor.base_color", "floor.roughness", "back.reflectance", "left.reflectance",
    "right.reflectance", "box.base_color", "box.roughness", "ball.base_color",
    "ball.roughness", "ball.metallic",
]


def value(scene: dict, row: str):
    """The value of `material.field` in a parsed scene file."""
    name, field = row.split(".")
    for m in scene.get("materials", []):
        if m.get("name") == name:
            return m[field]
    raise KeyError(f"no material {name!r} with {field!r}")


def shown(v, digits=None) -> str:
    """A number or an RGB triple as the table writes it."""
    values = v if isinstance(v, list) else [v]
    if digits is None:
        return ", ".join(f"{x:g}" for x in values)
    return ", ".join(f"{x:.{digits}f}" for x in values)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plsr", default=str(ROOT / "target/release/plsr"))
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        fitted_path = Path(tmp) / "fitted.toml"
        cmd = [a.plsr, "fit", str(ROOM / "fit-room.toml"), "-o", str(fitted_path)]
        for p in PATTERNS:
            cmd += ["--param", p]
        run = subprocess.run(cmd, env={**os.environ, "PLSR_PROGRESS": "none"},
                             capture_output=True, text=True)
        if run.returncode != 0:
            sys.stderr.write(run.stderr)
            return 1
        guess = tomllib.loads((ROOM / "fit-room.toml").read_text())
        truth = tomllib.loads((ROOM / "truth.toml").read_text())
        fitted = tomllib.loads(fitted_path.read_text())
        with open(Path(tmp) / "fitted.loss.csv", newline="") as f:
            losses = [float(r[-1]) for r in list(csv.reader(f))[1:]]
        shutil.copyfile(Path(tmp) / "fitted.loss.png", ROOT / "docs/img/fitting-loss.png")
    lines = ["| parameter | guess | fitted | true |", "| --- | --- | --- | --- |"]
    for row in ROWS:
        lines.append(f"| `{row}` | {shown(value(guess, row))} | "
                     f"{shown(value(fitted, row), 3)} | {shown(value(truth, row))} |")
    lines += ["", f"The loss falls from {losses[0]:.1e} to {losses[-1]:.1e} in "
              f"{len(losses) - 1} iterations (`plsr fit` prints the same)."]
    text = DOC.read_text()
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    DOC.write_text(text[:start] + "\n" + "\n".join(lines) + "\n" + text[end:])
    print(f"wrote the table into {DOC.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
