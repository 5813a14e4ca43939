"""Figure 11: Example 4 (ũ₀ = 2), indicators over time for several Algorithm C passes."""
import numpy as np
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, problem_title, save


def step_edges(t, tau):
    """The time steps (t_{k−1}, t_k] as stair edges t_0 < t_1 < … from the end times t_k
    and lengths τ_k of the steps."""
    t, tau = np.asarray(t, dtype=float), np.asarray(tau, dtype=float)
    edges = np.concatenate([[t[0] - tau[0]], t])
    if not np.allclose(edges[:-1], t - tau, rtol=0, atol=1e-9 * max(1.0, abs(t[-1]))):
        raise ValueError("time steps are not contiguous: t_k − τ_k ≠ t_{k−1}")
    return edges


def main(npz, table, png, pdf):
    d = np.load(npz)
    first = pd.read_csv(table).first_contact
    fig, ax = plt.subplots(figsize=(6, 4))
    for it in d["iterations"]:
        t, tau, eta2 = d[f"t_it{it}"], d[f"tau_it{it}"], d[f"eta2_it{it}"]
        # η² per unit time (the step's indicator over its length): comparable across τ.
        # DG(0): each step's value holds on (t_{k−1}, t_k], the first step from t = 0.
        ax.stairs(eta2 / tau, step_edges(t, tau), baseline=None, lw=1,
                  color=f"C{int(it)}", label=f"pass {it}: {len(t)} steps")
    ax.set_yscale("log")
    if np.isfinite(first.iloc[-1]):
        ax.axvline(first.iloc[-1], color="k", ls="--", lw=0.8,
                   label=f"first contact, $t = {first.iloc[-1]:.3f}$")
    ax.set_xlabel("$t$")
    ax.set_ylabel(r"$\eta_k^2/\tau_k$ (sum over the prisms of step $k$)")
    ax.set_title(f"{problem_title('ex4-u2')}: indicators in time (Algorithm C)")
    ax.legend(loc="lower left")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.input.table, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
