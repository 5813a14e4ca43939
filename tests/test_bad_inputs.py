"""Every invalid input of the bad-input table raises a clear error naming it."""
import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "workflow" / "scripts"))
import bad_inputs  # noqa: E402

from fracfem.solvers import ConvergenceError  # noqa: E402

# case → (the parameter, named as a word; the offending value; what is allowed),
# three regular expressions that must each occur in the message
EXPECT = {
    "time step τ = 0": (r"\btau=", r"=0\.0\b", r"finite number > 0"),
    "time step τ = −0.1": (r"\btau=", r"=-0\.1\b", r"finite number > 0"),
    "time step τ = NaN": (r"\btau=", r"=nan\b", r"finite number > 0"),
    "final time T = 0": (r"\bT=", r"=0\.0\b", r"finite number > 0"),
    "final time T = inf": (r"\bT=", r"=inf\b", r"finite number > 0"),
    "time grid not increasing [0, 0.5, 0.4]":
        (r"\btimes\b", r"times\[2\] = .*0\.4\b.*times\[1\] = .*0\.5\b", r"strictly increasing"),
    "initial value u0 = NaN": (r"\bu0=", r"=nan\b", r"must be finite"),
    "θ = 1 in Algorithm C": (r"θ \(theta\) =", r"= 1\.0\b", r"open interval \(0, 1\)"),
    "s = 0": (r"\bs=", r"=0\.0\b", r"allowed range \(0\.0, 1\.0\)"),
    "s = 1.2": (r"\bs=", r"=1\.2\b", r"allowed range \(0\.0, 1\.0\)"),
    "s = NaN": (r"\bs=", r"=nan\b", r"allowed range \(0\.0, 1\.0\)"),
    "s = '0.5' (a string)": (r"\bs=", r"='0\.5'", r"must be a number in \(0\.0, 1\.0\)"),
    "thin obstacle with s = 0.5":
        (r"^s \(thin problems", r"\)=0\.5\b", r"allowed range \(0\.5, 1\.0\)"),
    "θ = 1.5 (marking)": (r"θ \(theta\) =", r"= 1\.5\b", r"open interval \(0, 1\)"),
    "θ = 0 (Dörfler)": (r"θ \(theta\) =", r"= 0\.0\b", r"open interval \(0, 1\)"),
    "disk_graded(0.2, grading=9)": (r"^grading\b", r"got 9\.0$", r"\[1\.0, 4\.0\]"),
    "disk_graded(h=0)": (r"^h\b", r"got 0\.0$", r"\[0\.001, 1\.0\]"),
    "disk_uniform(12)": (r"^level\b", r"got 12$", r"integer in \[1, 9\]"),
    "friction bound F = −1": (r"\bF\b", r"min\(F\) = .*-1\.0\b", r">= 0"),
    "friction bound F = NaN": (r"\bF\b", r"non-finite entries", r"finite and >= 0"),
    "obstacle χ = 1 (positive on ∂Ω)": (r"\bχ\b", r"max χ = 1\.0\b", r"<= 0 on the boundary"),
    "paraboloid obstacle with slope < height":
        (r"\bχ\b", r"χ = 1 − 0\.5\|x\|²", r"choose slope >= height"),
    "segment [−0.3, 0.3] not made of coarse edges":
        (r"\bsegment\b", r"\[-0\.3, 0\.3\]", r"not made of coarse mesh edges"),
    "mesh coordinates with NaN": (r"^p\b", r"NaN/inf coordinates at nodes \[2\]", r"NaN/inf"),
    "mesh coordinates of shape (3, Nv)": (r"^p\b", r"shape \(3, 4\)", r"shape \(2, Nv\)"),
    "duplicate nodes": (r"^p\b", r"duplicate nodes: \[3, 4\] at \[1\.0, 1\.0\]", r"merge"),
    "unused node": (r"^p\b", r"\[4\]$", r"unused nodes not referenced by t"),
    "zero-area triangle": (r"^t\b", r"triangle 0 has area 0\.000e\+00", r"zero-area"),
    "triangle index out of range": (r"^t\b", r"t\[:, 0\] = \[0, 1, 7\]", r"outside \[0, 3\]"),
    "load f returning NaN": (r"^f\b", r"non-finite values", r"at quadrature points"),
    "far_thresholds of the wrong length":
        (r"\bfar_thresholds=", r"=\(8\.0, 4\.0\)", r"len\(far_orders\) - 1 = 1 entries"),
    "Uzawa stopped after 2 iterations":
        (r"\biterations = 2\b", r"residual = [0-9.e+-]+", r"tol = 1e-10"),
    "s_values: [1.5]": (r"\['s_values', 0\]", r"\b1\.5\b", r"maximum of 1\b"),
    "example1.grading: 9": (r"\['example1', 'grading'\]", r"\b9\b", r"maximum of 4\b"),
    "unknown key 'sigma'": (r"\bschema\b", r"'sigma' was unexpected", r"Additional properties"),
}


def test_every_case_has_an_expectation():
    missing = [what for _, what, _ in bad_inputs.CASES if what not in EXPECT]
    assert not missing, f"add the expected name, value and range of {missing} to EXPECT"


@pytest.mark.parametrize("param, what, call", bad_inputs.CASES,
                         ids=[c[1] for c in bad_inputs.CASES])
def test_bad_input_raises_naming_the_parameter(param, what, call, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises((ValueError, ConvergenceError)) as err:
        call()
    msg = str(err.value).splitlines()[0]
    for part, pattern in zip(("parameter", "value", "allowed range"), EXPECT[what]):
        assert re.search(pattern, msg), f"{part} {pattern!r} not in {msg!r}"
    assert list(tmp_path.iterdir()) == []          # nothing written
