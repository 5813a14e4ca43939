"""Figure 11: Example 4 (ũ₀ = 2), indicators over time for several Algorithm C passes."""
import numpy as np
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, save


def main(npz, table, png, pdf):
    d = np.load(npz)
    first = pd.read_csv(table).first_contact
    fig, ax = plt.subplots(figsize=(6, 4))
    for it in d["iterations"]:
        t, tau, eta2 = d[f"t_it{it}"], d[f"tau_it{it}"], d[f"eta2_it{it}"]
        # η² per unit time (the step's indicator over its length): comparable across τ
        ax.semilogy(t, eta2 / tau, drawstyle="steps-pre", lw=1,
                    label=f"pass {it}: {len(t)} steps")
    if np.isfinite(first.iloc[-1]):
        ax.axvline(first.iloc[-1], color="k", ls="--", lw=0.8,
                   label=f"first contact t = {first.iloc[-1]:.3f}")
    ax.set_xlabel("t")
    ax.set_ylabel(r"$\eta_k^2/\tau_k$ (sum over the prisms of step k)")
    ax.set_title(r"Example 4, $\tilde u_0 = 2$: indicators in time (Algorithm C)", fontsize=9)
    ax.legend(fontsize=7)
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.input.table, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
