#!/usr/bin/env python3
"""A generic DDS reader (Pillow) on an export's DDS files: each must decode to the
exported values or be refused -- never read as something else (the DX10 header's
pixel format once said RGB with a bit count, and Pillow read every float texture as
8-bit RGB zeros). Usage: dds_generic_reader.py EXPORT_DIR. Exit 1 on a silent misread."""
import glob
import os
import sys

from PIL import Image

files = sorted(glob.glob(os.path.join(sys.argv[1], "*.dds")))
if not files:
    sys.exit(f"no DDS files in {sys.argv[1]}")
bad = 0
for f in files:
    try:
        with Image.open(f) as im:
            im.load()
            lo_hi = im.getextrema()
    except Exception as e:  # refused: fine, the reader says it cannot decode it
        print(f"{os.path.basename(f)}: refused ({type(e).__name__}: {e})")
        continue
    # Decoded: the exported textures hold no constant-zero channel set, so an
    # all-zero image is a misread.
    flat = [v for band in (lo_hi if isinstance(lo_hi[0], tuple) else [lo_hi]) for v in band]
    if all(v == 0 for v in flat):
        print(f"{os.path.basename(f)}: MISREAD as {im.mode} zeros")
        bad += 1
    else:
        print(f"{os.path.basename(f)}: decoded as {im.mode}, extrema {lo_hi}")
print(f"{len(files)} DDS files: {bad} misread")
sys.exit(1 if bad else 0)
