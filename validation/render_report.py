"""Render report.html to PNG pages with headless Chromium, to look at it as a reader would.

    python -m validation.render_report report/report.html [--out report_pages] [--height 1500]

Two Chromium engines, whichever is there: Debian's ``chromium`` (apt-get install chromium) or
Qt WebEngine, the Chromium that the PyPI wheel PyQt6-WebEngine ships (the ``test`` extra
installs it, so CI has a browser without any system package), run offscreen. `inspect` loads
the report in the browser and reads back what a reader sees: the summary's verdict lines
and, for every image, whether it decoded (natural size > 0).

Writes one full-page screenshot and its slices page_00.png, page_01.png, ... (1300 px wide)
into a folder beside the report's (default ``<report folder>_pages``: a file inside the
report folder would make the next ``mbs-clearance report`` refuse to replace it).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars"]


def find_chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    raise ValueError("no Chromium found: install Debian's package (apt-get install chromium) "
                     "or the test extra (PyQt6-WebEngine)")


def has_qt_webengine() -> bool:
    """True when PyQt6-WebEngine (Qt's Chromium) can be imported."""
    import importlib.util

    try:
        return importlib.util.find_spec("PyQt6.QtWebEngineWidgets") is not None
    except ImportError:
        return False


def has_browser() -> bool:
    """True when `inspect` and `render` have a Chromium to run."""
    return has_qt_webengine() or any(shutil.which(n) for n in ("chromium", "chromium-browser",
                                                               "google-chrome"))


# Runs in a child process (Qt owns its process): load the page offscreen, wait until it has
# loaded, run READ_PAGE in it, optionally grab the whole page as PNG; print JSON.
_QT_CHILD = r"""
import json, sys
from PyQt6.QtCore import QTimer, QUrl
from PyQt6.QtGui import QImage, QPainter
from PyQt6.QtWidgets import QApplication
from PyQt6.QtWebEngineWidgets import QWebEngineView
url, script, shot, width = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
VIEW = 1500
app = QApplication(["report"])
view = QWebEngineView()
view.resize(width, VIEW)
result = {"loaded": False}
tiles = []
def tile(tops, k):
    # scroll to tops[k], let it paint, grab the viewport; then the next
    if k == len(tops):
        image = QImage(width, result["height"], QImage.Format.Format_RGB32)
        painter = QPainter(image)
        for top, pix in tiles:
            painter.drawPixmap(0, top, pix)
        painter.end()
        image.save(shot)
        app.quit()
        return
    view.page().runJavaScript(f"window.scrollTo(0, {tops[k]}); window.scrollY",
                              lambda y: QTimer.singleShot(400, lambda: (
                                  tiles.append((int(y), view.grab())), tile(tops, k + 1))))
def read(data):
    result.update(json.loads(data))
    if shot:
        tile(list(range(0, result["height"], VIEW)), 0)
    else:
        app.quit()
def loaded(ok):
    result["loaded"] = bool(ok)
    QTimer.singleShot(200, lambda: view.page().runJavaScript(script, read))
view.loadFinished.connect(loaded)
view.load(QUrl(url))
view.show()
QTimer.singleShot(240000, app.quit)
app.exec()
print(json.dumps(result))
"""

#: what `inspect` reads from the page (JavaScript; returns JSON text)
READ_PAGE = """JSON.stringify({
  height: document.documentElement.scrollHeight,
  scroll_width: document.documentElement.scrollWidth,
  verdicts: Array.from(document.querySelectorAll('li.verdict')).map(li => ({
    key: li.dataset.key, status: li.dataset.status, text: li.innerText})),
  images: Array.from(document.images).map(i => ({
    alt: i.alt, complete: i.complete, width: i.naturalWidth, height: i.naturalHeight})),
  anchors: Array.from(document.querySelectorAll('a[href^="#"]')).map(a => ({
    href: a.getAttribute('href'),
    found: document.getElementById(a.getAttribute('href').slice(1)) !== null}))
})"""


def _qt(html: Path, shot: Path | None, width: int) -> dict:
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen",
           "QTWEBENGINE_CHROMIUM_FLAGS": "--no-sandbox --disable-gpu --disable-quic "
                                         "--disable-background-networking",
           "QTWEBENGINE_DISABLE_SANDBOX": "1"}
    proc = subprocess.run([sys.executable, "-c", _QT_CHILD, html.as_uri(), READ_PAGE,
                           str(shot or ""), str(width)], capture_output=True, text=True,
                          timeout=300, env=env)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"Qt WebEngine failed (status {proc.returncode}): "
                           f"{proc.stderr.strip()[-500:]}")
    return json.loads(lines[-1])


def inspect(html: str | Path, width: int = 1300) -> dict:
    """Load `html` in Qt WebEngine (Chromium) and return what the page shows: ``verdicts``
    (key, status, text of each summary line), ``images`` (alt, natural width and height:
    0 when the image did not decode), ``anchors`` (each in-page link and whether its target
    exists), ``height`` (px) and ``scroll_width`` (px: above `width` when something overflows
    the page)."""
    html = Path(html).resolve()
    if not html.is_file():
        raise ValueError(f"cannot read report file {str(html)!r}")
    return _qt(html, None, width)


def render(html: str | Path, out: str | Path, width: int = 1300, height: int = 20000,
           page_height: int = 1500) -> list[Path]:
    """Screenshot `html` at width x height and cut it into pages; returns the page files."""
    from PIL import Image

    html = Path(html).resolve()
    if not html.is_file():
        raise ValueError(f"cannot read report file {str(html)!r}")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    full = out / "full.png"
    if not any(shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")) \
            and has_qt_webengine():
        _qt(html, full, width)
    else:
        with tempfile.TemporaryDirectory() as profile:
            subprocess.run([find_chromium(), *FLAGS, f"--user-data-dir={profile}",
                            f"--window-size={width},{height}", f"--screenshot={full}",
                            html.as_uri()], check=True, capture_output=True, timeout=180)
    image = Image.open(full).convert("RGB")
    # drop the blank tail below the content: last pixel row that is not uniform
    pixels = np.asarray(image)
    busy = np.flatnonzero((pixels != pixels[:, :1]).any(axis=(1, 2)))
    bottom = min(image.height, int(busy[-1]) + 40) if busy.size else image.height
    pages = []
    for k, top in enumerate(range(0, bottom, page_height)):
        page = out / f"page_{k:02d}.png"
        image.crop((0, top, width, min(top + page_height, bottom))).save(page)
        pages.append(page)
    return pages


def default_pages_folder(html: Path) -> Path:
    """``<report folder>_pages`` beside the report folder."""
    folder = html.absolute().parent
    return folder.with_name(folder.name + "_pages")


def main(argv=None) -> int:
    from mbs_clearance.cli import Parser, int_at_least, run_command

    ap = Parser(prog="render_report", description=__doc__.splitlines()[0])
    ap.add_argument("html", type=Path)
    ap.add_argument("--out", type=Path,
                    help="folder for the PNG pages (default: <report folder>_pages)")
    ap.add_argument("--height", type=int_at_least(1), default=1500, help="page height in px")
    args = ap.parse_args(argv)

    def run(args) -> int:
        from mbs_clearance._io import check_can_create_in

        out = args.out or default_pages_folder(args.html)
        if out.exists() and not out.is_dir():
            raise ValueError(f"--out {str(out)!r} is a file; expected a folder")
        check_can_create_in(out, "--out", "folder")
        pages = render(args.html, out, page_height=args.height)
        from mbs_clearance.cli import wrote

        wrote(pages[0].parent, f"{len(pages)} pages page_NN.png and full.png")
        return 0

    return run_command(ap.prog, run, args)


if __name__ == "__main__":
    raise SystemExit(main())
