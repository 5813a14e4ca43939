"""Run the test suite once and record how long it took (paper-figures/test-time.md).

    python workflow/scripts/test_time.py [--out paper-figures]

The README quotes the file, so the time it gives a newcomer is measured, with the
machine's load at the start (other work on the machine slows the tests down).
"""
import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def main(out):
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "auto", "-rf",
                          "-p", "no:cacheprovider"], cwd=ROOT, capture_output=True, text=True)
    minutes = (time.perf_counter() - t0) / 60
    summary = run.stdout.strip().splitlines()[-1] if run.stdout.strip() else ""
    passed = re.search(r"(\d+) passed", summary)
    if run.returncode != 0 or not passed:
        failed = [ln for ln in run.stdout.splitlines() if ln.startswith("FAILED")]
        sys.exit("the tests did not pass, nothing written:\n"
                 + "\n".join(failed + [summary]))
    line = (f"`pytest -n auto` runs {passed.group(1)} tests in {minutes:.0f} minutes on "
            f"{os.cpu_count()} cores (load average {load:.1f} when it started).")
    Path(out, "test-time.md").write_text(line + "\n")
    print(line)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "paper-figures"))
    main(ap.parse_args().out)
