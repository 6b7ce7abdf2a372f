"""Open a report in headless Chromium (Debian's chromium package) and save a full-page screenshot, to check that every
figure renders and nothing is cut off; also fails if an image in the page cannot be decoded.

    python scripts/screenshot_report.py results/cup/report.html results/cup/report.png
"""

from __future__ import annotations

import argparse
import base64
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path


def broken_images(page: str) -> list[int]:
    """Indices of inline images whose data does not decode to a PNG or GIF."""
    bad = []
    for i, (mime, data) in enumerate(re.findall(r'src="data:image/(png|gif);base64,([^"]+)"', page)):
        head = base64.b64decode(data[:16])
        if not head.startswith(b"\x89PNG" if mime == "png" else b"GIF8"):
            bad.append(i)
    return bad


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("report", type=Path)
    parser.add_argument("screenshot", type=Path)
    parser.add_argument("--width", type=int, default=1280)
    args = parser.parse_args()
    page = args.report.read_text()
    if "http://" in page or "https://" in page.replace("https://json-schema.org", ""):
        print(f"{args.report}: refers to the network; a report must open offline", file=sys.stderr)
        return 1
    bad = broken_images(page)
    if bad:
        print(f"{args.report}: images {bad} do not decode", file=sys.stderr)
        return 1
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        print("chromium not found (apt-get install chromium)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as profile:
        # a tall window: the whole page in one image; Chromium sizes the screenshot to the window
        height = 800 + 400 * page.count("<figure") + 45 * page.count("<tr")
        subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", f"--user-data-dir={profile}",
                        f"--window-size={args.width},{height}", "--hide-scrollbars",
                        f"--screenshot={args.screenshot.resolve()}", args.report.resolve().as_uri()],
                       check=True, capture_output=True, timeout=120)
    print(f"{args.screenshot}: {page.count('<figure')} figures, {len(re.findall('<img', page))} images")
    return 0


if __name__ == "__main__":
    sys.exit(main())
