"""Render report.html to PNG pages with headless Chromium, to look at it as a reader would.

    apt-get install chromium            # Debian's package; not a Python dependency
    python -m validation.render_report report/report.html [--out report_pages] [--height 1500]

Writes one full-page screenshot and its slices page_00.png, page_01.png, ... (1300 px wide)
into a folder beside the report's (default ``<report folder>_pages``: a file inside the
report folder would make the next ``mbs-clearance report`` refuse to replace it).
"""

from __future__ import annotations

import shutil
import subprocess
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
    raise ValueError("no Chromium found: install Debian's package (apt-get install chromium)")


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
        print(f"{len(pages)} pages written to {pages[0].parent}")
        return 0

    return run_command(ap.prog, run, args)


if __name__ == "__main__":
    raise SystemExit(main())
