"""Figures 4, 5 and 10: an obstacle solution (Example 2 uniform / adaptive, Example 4 at
T on its last adaptive mesh) with λ_H and the contact set."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from plotstyle import multiplier_panel, save, solution_figure  # noqa: E402


def main(npz, png, pdf, title="Example 2: $u_h$ ({triangles} triangles)"):
    d, fig, ax2 = solution_figure(npz, title)
    multiplier_panel(fig, ax2, d, "magma")
    ax2.set_title(rf"$\lambda_H$ (contact where $\lambda_H<0$: {int(np.sum(d['lam'] < 0))} "
                  "elements)")
    save(fig, png, pdf)


if __name__ == "__main__":
    title = snakemake.params.get("title")  # noqa: F821  (Figures 5, 10 reuse this script)
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf,  # noqa: F821
         *([title] if title else []))
