"""Headless Chromium for the tests that look at a report as a reader's browser draws it
(Debian's ``chromium``; ``.ci/setup`` installs it).  The flags are those that work on this kind of
machine without a network or a display: no sandbox (root), no GPU, no background networking."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--hide-scrollbars")


def chromium() -> str:
    """The chromium executable; a test that needs it fails (not skips) without it."""
    found = shutil.which("chromium") or shutil.which("chromium-browser")
    assert found, "headless chromium is needed: bash .ci/setup installs it (Debian package chromium)"
    return found


def screenshot(page: Path, png: Path, width: int = 1280, height: int = 1000, after_ms: int = 1000) -> Path:
    """A screenshot of ``page`` at ``width`` x ``height`` px, taken ``after_ms`` of virtual time
    after loading (the page's timers and animation frames run that long)."""
    subprocess.run([chromium(), *FLAGS, f"--window-size={width},{height}", f"--virtual-time-budget={after_ms}",
                    f"--screenshot={png}", page.as_uri()], capture_output=True, text=True, timeout=180, check=True)
    assert png.is_file(), f"chromium wrote no {png}"
    return png


def layout(page: Path, tmp: Path, selectors: dict, width: int = 1280, height: int = 1000) -> dict:
    """{name: [left, top, right, bottom]} in CSS px of the first element each CSS selector finds,
    as the page lays out at ``width`` x ``height`` (None where none is found)."""
    probe = tmp / f"probe_{page.stem}.html"
    script = ("<script>window.addEventListener('load', () => { const out = {};"
              f"const sel = {json.dumps(selectors)};"
              "for (const [k, s] of Object.entries(sel)) { const e = document.querySelector(s);"
              "out[k] = e ? (r => [r.left, r.top, r.right, r.bottom])(e.getBoundingClientRect()) : null; }"
              "document.body.setAttribute('data-layout', JSON.stringify(out)); });</script>")
    probe.write_text(page.read_text(encoding="utf-8").replace("</body>", script + "</body>"), encoding="utf-8")
    done = subprocess.run([chromium(), *FLAGS, f"--window-size={width},{height}", "--virtual-time-budget=2000",
                           "--dump-dom", probe.as_uri()], capture_output=True, text=True, timeout=180)
    m = re.search(r'data-layout="([^"]*)"', done.stdout)
    assert m, done.stderr[-2000:]
    return json.loads(m.group(1).replace("&quot;", '"'))
