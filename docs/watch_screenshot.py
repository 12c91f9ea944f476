"""The README's screenshot of the cable animation (docs/watch.png), from a run's report.html.

    .venv/bin/python docs/watch_screenshot.py results/uh60_part2_forward_flight_cable/report.html \
        docs/watch.png --frame 0 --view=-120,30

Renders the page in Debian's headless chromium (``apt-get install chromium``) at 1280 px wide
(tall enough to hold the whole page), then crops the section "Watch the cable": its canvas
is found by its background colour (#fbfbfd, animation.js).  A link ``report.html#frame=0&view=-120,30``
opens the same view in a browser.
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

BACKGROUND = (251, 251, 253)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("report")
    ap.add_argument("png")
    ap.add_argument("--frame", type=int, default=0)
    ap.add_argument("--view", default="", help="yaw,pitch [deg]")
    ap.add_argument("--colour", default="strain", choices=["strain", "damage"])
    ap.add_argument("--height", type=int, default=8000, help="window height [px] (the whole page)")
    args = ap.parse_args()
    url = Path(args.report).resolve().as_uri() + f"#frame={args.frame}" + (f"&view={args.view}" if args.view else "") \
        + f"&colour={args.colour}"
    with tempfile.TemporaryDirectory() as tmp:
        shot = Path(tmp) / "page.png"
        subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
                        "--virtual-time-budget=5000", f"--screenshot={shot}", f"--window-size=1280,{args.height}",
                        url], check=True, capture_output=True)
        im = Image.open(shot).convert("RGB")
    a = np.asarray(im).astype(int)
    rows = np.flatnonzero((np.abs(a - BACKGROUND).sum(axis=2) == 0).sum(axis=1) > 400)
    if not len(rows):
        raise SystemExit("no animation canvas found in the page")
    top, bottom = max(0, rows[0] - 125), min(im.height, rows[-1] + 45)     # heading and caption above, controls below
    im.crop((0, top, im.width, bottom)).save(args.png, optimize=True)
    print(f"{args.png}: {Path(args.png).stat().st_size / 1e3:.0f} kB, {im.width} x {bottom - top} px")


if __name__ == "__main__":
    main()
