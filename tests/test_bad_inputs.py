"""Every invalid input of the bad-input table raises a clear error naming it."""
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "scripts"))
import bad_inputs  # noqa: E402

from fracfem.solvers import ConvergenceError  # noqa: E402

NAMES = {"s": ["s"], "θ": ["θ", "theta"], "grading": ["grading"], "h": ["h "], "level": ["level"],
         "F": ["F"], "χ": ["χ"], "Γ̃": ["edges", "segment"], "p": ["p "], "t": ["t "],
         "f": ["f "], "quadrature": ["far_thresholds"], "maxiter": ["iterations"],
         "config": ["schema"], "τ": ["tau"], "T": ["T="], "times": ["times"], "u0": ["u0"]}


@pytest.mark.parametrize("param, what, call", bad_inputs.CASES,
                         ids=[c[1] for c in bad_inputs.CASES])
def test_bad_input_raises_naming_the_parameter(param, what, call, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises((ValueError, ConvergenceError)) as err:
        call()
    assert any(n in str(err.value) for n in NAMES[param]), str(err.value)
    assert list(tmp_path.iterdir()) == []          # nothing written
