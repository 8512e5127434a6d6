"""Make the figures of the README and the docs site from the tool's own output.

    python docs/scripts/make_doc_figures.py          # writes docs/img/*.png

- ``docs/img/efficiency_S1_S2.png`` and ``docs/img/partial_losses.png``: ``cyclo-fmu paper``
  on the default design (physical profile, the paper profile as the dotted reference);
- ``docs/img/diagnosis.png``: ``cyclo-fmu diagnose`` of the tutorial's recording
  (``cyclo-fmu synth --effect load_independent_loss --seed 3 --mode S1 --size small``);
- ``docs/img/report.png``: the first screen of that diagnosis' ``report.html`` in headless
  Chromium, checked for console errors (``docs/scripts/check_report_html.py``), when Chromium is
  installed.

Every figure is made by the command line a user runs, in a temporary folder, then copied.
"""
from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: Height [px] of the report screenshot kept for the README: statement, effects, what remains
#: and the checks (the figure below them is docs/img/diagnosis.png).
REPORT_TOP_PX = 1200
IMG = ROOT / "docs" / "img"


def cli(*args, cwd):
    """Run ``cyclo-fmu ARGS`` in ``cwd``; stop on failure."""
    cmd = [sys.executable, "-m", "cyclo_fmu.cli", *map(str, args)]
    print("$ cyclo-fmu " + " ".join(map(str, args)))
    subprocess.run(cmd, cwd=cwd, check=True, stdout=subprocess.DEVNULL)


def main() -> int:
    IMG.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        cli("paper", "--out", tmp / "paper", cwd=tmp)
        for name in ("efficiency_S1_S2.png", "partial_losses.png"):
            shutil.copyfile(tmp / "paper" / name, IMG / name)
        cli("synth", "--effect", "load_independent_loss", "--seed", 3, "--mode", "S1",
            "--size", "small", "--out", "rec.csv", "--quiet", cwd=tmp)
        cli("diagnose", "rec.csv", "--mode", "auto", "--out", "diag", cwd=tmp)
        shutil.copyfile(tmp / "diag" / "diagnosis.png", IMG / "diagnosis.png")
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from check_report_html import check
        try:
            findings = check(tmp / "diag" / "report.html", IMG / "report.png")
        except FileNotFoundError as exc:
            print(f"report screenshot skipped: {exc}")
            findings = []
        for f in findings:
            print(f"report.html: {f}")
        if findings:
            return 1
        if (IMG / "report.png").is_file():      # the README shows the report's first screen
            from PIL import Image
            with Image.open(IMG / "report.png") as im:
                im.crop((0, 0, im.width, min(im.height, REPORT_TOP_PX))).save(IMG / "report.png")
    for f in sorted(IMG.glob("*.png")):
        print(f"{f.relative_to(ROOT)}: {f.stat().st_size // 1024} KiB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
