"""Open a diagnosis ``report.html`` in headless Chromium: take a screenshot and check that the
page logs no console error and that its embedded figure decodes.

    python docs/scripts/check_report_html.py out/diagnosis/report.html [screenshot.png]

Exit status 0 when the page is clean, 1 when Chromium logged a console error or the figure does
not decode, 2 when Chromium is not installed (``apt-get install chromium``). Prints one line
per finding. Used by ``docs/scripts/make_doc_figures.py`` for the docs' screenshot.
"""
from __future__ import annotations

import base64
import io
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

#: Window of the screenshot [px]: the report's body is 1100 px wide; tall enough for the
#: statement, the tables and the figure.
WINDOW = (1200, 2400)


def chromium() -> str | None:
    """The Chromium executable on the path, or None."""
    for name in ("chromium", "chromium-browser", "google-chrome", "chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def embedded_images_decode(html_text: str) -> list[str]:
    """Problems with the page's embedded PNGs (empty list: every image decodes)."""
    import matplotlib.image as mpimg
    problems = []
    images = re.findall(r'src="data:image/png;base64,([^"]+)"', html_text)
    if not images:
        problems.append("no embedded figure")
    for i, b64 in enumerate(images):
        try:
            img = mpimg.imread(io.BytesIO(base64.b64decode(b64)), format="png")
            if img.shape[0] < 100 or img.shape[1] < 100:
                problems.append(f"figure {i} is only {img.shape[1]} x {img.shape[0]} px")
        except Exception as exc:     # noqa: BLE001 - any decoding failure is the finding
            problems.append(f"figure {i} does not decode: {exc}")
    return problems


def check(report: Path, screenshot: Path | None = None) -> list[str]:
    """Findings (empty: clean). Raises FileNotFoundError without Chromium."""
    exe = chromium()
    if exe is None:
        raise FileNotFoundError("chromium is not installed (apt-get install chromium)")
    findings = embedded_images_decode(report.read_text(encoding="utf-8"))
    with tempfile.TemporaryDirectory() as tmp:
        shot = screenshot or Path(tmp) / "shot.png"
        cmd = [exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
               f"--user-data-dir={tmp}/profile", "--enable-logging=stderr", "--v=0",
               f"--window-size={WINDOW[0]},{WINDOW[1]}", f"--screenshot={shot}",
               report.resolve().as_uri()]
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
        console = [line for line in run.stderr.splitlines() if "CONSOLE" in line]
        findings += [f"console: {line.strip()}" for line in console]
        if run.returncode != 0:
            findings.append(f"chromium exited with {run.returncode}: {run.stderr.strip()[-300:]}")
        elif not Path(shot).is_file() or Path(shot).stat().st_size < 10_000:
            findings.append("no screenshot written")
    return findings


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if not argv:
        print(__doc__.strip().splitlines()[2].strip())
        return 2
    report = Path(argv[0])
    shot = Path(argv[1]) if len(argv) > 1 else None
    try:
        findings = check(report, shot)
    except FileNotFoundError as exc:
        print(f"check_report_html: {exc}")
        return 2
    for f in findings:
        print(f"check_report_html: {f}")
    if not findings:
        print(f"check_report_html: {report}: no console error, figure decodes"
              + (f"; screenshot {shot}" if shot else ""))
    return 1 if findings else 0


if __name__ == "__main__":
    sys.exit(main())
