"""Progress lines: fracfem's loggers (adaptive loops, time stepping, solvers), silent
unless configured, and the job log of the workflow (fracfem_workflow.logs)."""
import atexit
import logging
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import fracfem as ff
from fracfem import _progress, adaptive, parabolic, vi
from fracfem.examples import paraboloid_obstacle
from fracfem.krylov import pcg

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "workflow" / "scripts"))

from fracfem_workflow import logs  # noqa: E402
from fracfem_workflow.runs import start  # noqa: E402

S = 0.5
CHI = paraboloid_obstacle(1.0, 4.0)


def messages(records, name, prefix=""):
    return [r for r in records if r.name == name and r.getMessage().startswith(prefix)]


# ----------------------------------------------------------------- adaptive loops


def test_algorithm_b_logs_one_info_line_per_step(caplog):
    with caplog.at_level(logging.INFO, logger="fracfem"):
        recs = adaptive.algorithm_b(lambda m: ff.discretise(m, S, 1.0), ff.disk_uniform(1),
                                    theta=0.5, steps=3, f=1.0)
    lines = messages(caplog.records, "fracfem.adaptive", "Algorithm B step")
    assert len(recs) == 3 and len(lines) == 3
    for rec, line in zip(recs, lines):
        text = line.getMessage()
        assert line.levelno == logging.INFO
        assert f"step {rec.step}: {rec.dofs} DOFs" in text
        assert f"eta {rec.eta:.4e}" in text
        assert re.search(r"\d+\.\d\d s \(elapsed \d+\.\d s\)$", text)
    stop = messages(caplog.records, "fracfem.adaptive", "Algorithm B stops")
    assert [r.getMessage() for r in stop] == ["Algorithm B stops after step 2: steps"]


def test_algorithm_b_obstacle_line_has_the_solver_iterations(caplog):
    with caplog.at_level(logging.INFO, logger="fracfem"):
        recs = adaptive.algorithm_b(
            lambda c: vi.mixed_problem("obstacle", c, S, 1.0, chi=CHI), ff.disk_uniform(1),
            theta=0.5, steps=2, f=1.0, solver="uzawa")
    lines = messages(caplog.records, "fracfem.adaptive", "Algorithm B step")
    assert len(lines) == len(recs) == 2
    for rec, line in zip(recs, lines):
        text = line.getMessage()
        assert rec.info["iterations"] > 1
        assert f"{rec.n_multipliers} multipliers" in text
        assert f"solver iterations: {rec.info['iterations']}," in text
    # a top-level solve inside Algorithm B reports its own summary at INFO
    assert len(messages(caplog.records, "fracfem.solvers", "uzawa (obstacle)")) == 2


def test_algorithm_c_logs_one_info_line_per_iteration(caplog):
    with caplog.at_level(logging.INFO, logger="fracfem"):
        recs = ff.algorithm_c(lambda c: vi.mixed_problem("obstacle", c, S, 0.0, chi=CHI),
                              ff.disk_uniform(1), 2.0, T=0.5, theta=0.5, iterations=2)
    lines = messages(caplog.records, "fracfem.spacetime_adaptive", "Algorithm C iteration")
    assert len(lines) == len(recs) == 2
    for rec, line in zip(recs, lines):
        text = line.getMessage()
        n_steps = sum(sl.n_steps for sl in rec.slabs)
        assert f"iteration {rec.iteration}: {len(rec.slabs)} slabs, {n_steps} time steps" in text
        assert f"{rec.dofs} space-time DOFs, eta {rec.eta:.4e}" in text


def test_algorithm_c_start_line_names_the_cache_budget(caplog):
    """The run's memory depends on the assembled-problem cache: its log says how large."""
    with caplog.at_level(logging.INFO, logger="fracfem"):
        ff.algorithm_c(lambda c: vi.mixed_problem("obstacle", c, S, 0.0, chi=CHI),
                       ff.disk_uniform(1), 2.0, T=0.5, theta=0.5, iterations=1,
                       cache_bytes="1.5G")
    (line,) = messages(caplog.records, "fracfem.spacetime_adaptive", "Algorithm C: at most")
    assert line.getMessage().endswith("assembled problems cached up to 1.50 GiB")


# ----------------------------------------------------------------- solvers


def spd(n=40, seed=1):
    rng = np.random.default_rng(seed)
    G = rng.standard_normal((n, n))
    return G @ G.T + n * np.eye(n), rng.standard_normal(n)


def test_pcg_logs_a_summary_and_each_iteration(caplog):
    A, b = spd()
    with caplog.at_level(logging.DEBUG, logger="fracfem.krylov"):
        x, info = pcg(A, b, tol=1e-10)
    recs = messages(caplog.records, "fracfem.krylov")
    summary = [r for r in recs if r.levelno == logging.INFO]
    assert len(summary) == 1
    assert summary[0].getMessage().startswith(f"PCG: {info['iterations']} iterations, "
                                              f"relative residual {info['residual']:.2e}")
    per_iteration = [r for r in recs if r.getMessage().startswith("PCG iteration")]
    assert len(per_iteration) == info["iterations"] > 3
    assert all(r.levelno == logging.DEBUG for r in per_iteration)


def test_inner_solves_report_at_debug(caplog):
    A, b = spd()
    with caplog.at_level(logging.DEBUG, logger="fracfem.krylov"):
        with _progress.inner_solves():
            pcg(A, b, tol=1e-10)
        pcg(A, b, tol=1e-10)
    summaries = [r.levelno for r in messages(caplog.records, "fracfem.krylov", "PCG: ")]
    assert summaries == [logging.DEBUG, logging.INFO]


# ----------------------------------------------------------------- time stepping


def heat():
    return ff.discretise(ff.disk_uniform(1), S, 1.0)


def test_time_steps_log_every_step_and_the_last_at_info(caplog, monkeypatch):
    monkeypatch.setattr(parabolic, "STEP_SECONDS", 1e9)     # no step is ever "slow"
    with caplog.at_level(logging.DEBUG, logger="fracfem.parabolic"):
        steps = ff.solve_parabolic(heat(), 0.0, T=0.2, tau=0.05)
    lines = messages(caplog.records, "fracfem.parabolic", "DG(0) step")
    assert len(lines) == len(steps) - 1 == 4
    for k, line in enumerate(lines, start=1):
        assert line.getMessage().startswith(f"DG(0) step {k}/4: t = {steps[k].t:.6g}, "
                                            f"{len(heat().free)} DOFs")
    # fast steps: only the last one at INFO (no line per step on a long run)
    assert [r.levelno for r in lines] == [logging.DEBUG] * 3 + [logging.INFO]


def test_time_steps_at_info_when_the_interval_has_passed(caplog, monkeypatch):
    monkeypatch.setattr(parabolic, "STEP_SECONDS", 0.0)
    with caplog.at_level(logging.INFO, logger="fracfem"):
        ff.solve_parabolic(heat(), 0.0, T=0.2, tau=0.05)
    lines = messages(caplog.records, "fracfem.parabolic", "DG(0) step")
    assert [r.getMessage().split(":")[0] for r in lines] == [f"DG(0) step {k}/4"
                                                             for k in range(1, 5)]


def test_solvers_inside_time_stepping_are_debug(caplog):
    prob = vi.mixed_problem("obstacle", ff.disk_uniform(1), S, 0.0, chi=CHI)
    with caplog.at_level(logging.DEBUG, logger="fracfem"):
        steps = ff.solve_parabolic(prob, 2.0, T=0.2, tau=0.05, solver="pdas")
    pdas = messages(caplog.records, "fracfem.solvers", "pdas (obstacle)")
    assert len(pdas) == len(steps) - 1
    assert all(r.levelno == logging.DEBUG for r in pdas)
    lines = messages(caplog.records, "fracfem.parabolic", "DG(0) step")
    for st, line in zip(steps[1:], lines):
        assert f"solver iterations: {st.info['iterations']}," in line.getMessage()
    factorised = messages(caplog.records, "fracfem.parabolic", "Stepper: factorised")
    assert len(factorised) == 1 and factorised[0].levelno == logging.INFO


# ----------------------------------------------------------------- silent by default


def test_the_package_logger_has_a_null_handler():
    assert any(isinstance(h, logging.NullHandler) for h in logging.getLogger("fracfem").handlers)


@pytest.mark.parametrize("null_handler", [True, False])
def test_unconfigured_library_prints_nothing(null_handler):
    """A fresh interpreter, logging not configured: fracfem prints nothing, not even a
    warning (without the NullHandler Python's last-resort handler would print it)."""
    code = "\n".join([
        "import logging, numpy as np, fracfem",
        "from fracfem.krylov import pcg",
        "" if null_handler else "logging.getLogger('fracfem').handlers.clear()",
        "pcg(np.diag([1.0, 2.0, 3.0]), np.ones(3))",
        "logging.getLogger('fracfem.krylov').warning('a warning nobody asked for')",
    ])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), str(ROOT / "workflow" / "lib"), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout == ""
    if null_handler:
        assert out.stderr == ""
    else:
        assert "a warning nobody asked for" in out.stderr


# ----------------------------------------------------------------- the job log


@pytest.fixture
def job_logging():
    """Undo what log_to and start do to the process (root handler and level, warnings,
    excepthook, numba threads)."""
    import numba

    root = logging.getLogger()
    level, hook, threads = root.level, sys.excepthook, numba.get_num_threads()
    quiet = {name: logging.getLogger(name).level for name in logs.QUIET}
    yield
    numba.set_num_threads(threads)
    for name, lvl in quiet.items():
        logging.getLogger(name).setLevel(lvl)
    for h in [h for h in root.handlers if isinstance(h, logs._JobLog)]:
        root.removeHandler(h)
        h.close()
    root.setLevel(level)
    logging.captureWarnings(False)
    sys.excepthook = hook
    atexit.unregister(logs._finished)
    logs._state.update(start=None, failed=False)


LINE = r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d INFO "


def test_log_to_writes_each_line_before_the_job_ends(tmp_path, job_logging):
    path = tmp_path / "logs" / "job.log"
    handler = logs.log_to(path)
    assert re.search(LINE + r"fracfem_workflow: log of \S+ \(pid \d+\)$",
                     path.read_text(), re.M)
    logging.getLogger("fracfem.adaptive").info("Algorithm B step %d: %d DOFs", 3, 120)
    # the handler is still open: the line is in the file already
    assert re.search(LINE + r"fracfem\.adaptive: Algorithm B step 3: 120 DOFs$",
                     path.read_text(), re.M)
    logging.getLogger("fracfem.krylov").debug("a DEBUG line")
    logging.getLogger("skfem.assembly").info("Assembling 'mass'.")
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.warn("a warning of the job")
    text = path.read_text()
    assert "a DEBUG line" not in text and "Assembling" not in text
    assert re.search(r" WARNING py\.warnings: .*a warning of the job", text)
    assert handler.stream is not None and not handler.stream.closed


def test_log_to_again_replaces_the_file_handler(tmp_path, job_logging):
    first = logs.log_to(tmp_path / "a.log")
    logs.log_to(tmp_path / "b.log")
    logging.getLogger("fracfem").info("only in b")
    assert first not in logging.getLogger().handlers
    assert "only in b" not in (tmp_path / "a.log").read_text()
    assert "only in b" in (tmp_path / "b.log").read_text()


def test_an_uncaught_exception_is_logged(tmp_path, job_logging, capsys):
    path = tmp_path / "job.log"
    logs.log_to(path)
    try:
        raise ValueError("the job failed")
    except ValueError:
        sys.excepthook(*sys.exc_info())
    text = path.read_text()
    assert " ERROR fracfem_workflow: uncaught exception" in text
    assert "ValueError: the job failed" in text
    assert "the job failed" in capsys.readouterr().err      # still reported as before
    logs._finished()
    assert re.search(r" ERROR fracfem_workflow: failed after \d+\.\d s$", path.read_text(),
                     re.M)


def test_a_run_script_writes_library_and_script_lines_to_its_log(tmp_path, job_logging):
    import ex1_adaptive

    log = tmp_path / "logs" / "adaptive_s0.5.log"
    ex1_adaptive.main(0.5, 0.5, 1, 60, 3, {}, tmp_path / "steps.csv", tmp_path / "last.npz",
                      log=str(log), threads=1)
    text = log.read_text()
    steps = re.findall(LINE + r"fracfem\.adaptive: Algorithm B step (\d+): (\d+) DOFs", text,
                       re.M)
    mine = re.findall(LINE + r"workflow\.ex1_adaptive: adaptive step (\d+): (\d+) dofs", text,
                      re.M)
    assert len(steps) >= 2 and steps == mine
    assert re.search(LINE + r"fracfem\.assembly: assembled", text, re.M)
    assert re.search(LINE + r"fracfem_workflow\.io: wrote .*steps\.csv$", text, re.M)


def test_start_logs_to_the_file(tmp_path, job_logging):
    start(tmp_path / "x.log", threads=1)
    logging.getLogger("workflow.x").info("item %d of %d", 1, 2)
    text = (tmp_path / "x.log").read_text()
    assert re.search(LINE + r"fracfem_workflow: numba threads: 1$", text, re.M)
    assert re.search(LINE + r"workflow\.x: item 1 of 2$", text, re.M)
    logs._finished()
    assert re.search(LINE + r"fracfem_workflow: finished after \d+\.\d s$",
                     (tmp_path / "x.log").read_text(), re.M)
