"""The memory available to a process: the node's, and no more than its control group
leaves (a SLURM job with enforced memory, a container). Made-up cgroup trees."""
import pytest

from fracfem import memory

GIB = 2 ** 30


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_cgroup_v2_limit_less_usage_less_reclaimable_cache(tmp_path):
    job = tmp_path / "sys" / "system.slice" / "slurm" / "job_7"
    write(tmp_path / "cgroup", "0::/system.slice/slurm/job_7/step_0\n")
    write(job / "memory.max", f"{16 * GIB}\n")
    write(job / "memory.current", f"{5 * GIB}\n")
    write(job / "memory.stat", f"anon 1\ninactive_file {GIB}\nactive_file 3\n")
    write(job / "step_0" / "memory.max", "max\n")          # the step: no limit of its own
    write(job / "step_0" / "memory.current", f"{4 * GIB}\n")
    got = memory.cgroup_available(tmp_path / "cgroup", tmp_path / "sys")
    assert got == 16 * GIB - (5 * GIB - GIB)


def test_cgroup_v1_takes_the_tightest_group_and_ignores_the_unlimited(tmp_path):
    mem = tmp_path / "sys" / "memory"
    write(tmp_path / "cgroup", "9:cpu,cpuacct:/a\n4:memory:/slurm/uid_0/job_3\n0::/\n")
    write(mem / "memory.limit_in_bytes", "9223372036854771712\n")        # unlimited root
    write(mem / "memory.usage_in_bytes", f"{20 * GIB}\n")
    write(mem / "slurm" / "uid_0" / "memory.limit_in_bytes", f"{64 * GIB}\n")
    write(mem / "slurm" / "uid_0" / "memory.usage_in_bytes", f"{60 * GIB}\n")
    write(mem / "slurm" / "uid_0" / "job_3" / "memory.limit_in_bytes", f"{8 * GIB}\n")
    write(mem / "slurm" / "uid_0" / "job_3" / "memory.usage_in_bytes", f"{2 * GIB}\n")
    write(mem / "slurm" / "uid_0" / "job_3" / "memory.stat",
          f"cache 5\ntotal_inactive_file {GIB // 2}\n")
    got = memory.cgroup_available(tmp_path / "cgroup", tmp_path / "sys")
    assert got == 4 * GIB                   # the user's 64 − 60 GiB, tighter than the job's


def test_a_path_missing_under_the_mount_reads_the_mounts_own_group(tmp_path):
    """A container sees its own group at the mount's root, not under the host's path."""
    write(tmp_path / "cgroup", "4:memory:/docker/abc\n")
    write(tmp_path / "sys" / "memory" / "memory.limit_in_bytes", f"{6 * GIB}\n")
    write(tmp_path / "sys" / "memory" / "memory.usage_in_bytes", f"{GIB}\n")
    write(tmp_path / "sys" / "memory" / "docker" / "memory.limit_in_bytes", "100\n")
    write(tmp_path / "sys" / "memory" / "docker" / "memory.usage_in_bytes", "0\n")
    assert memory.cgroup_available(tmp_path / "cgroup", tmp_path / "sys") == 5 * GIB


def test_no_limit_or_no_cgroup_file_means_none(tmp_path):
    write(tmp_path / "cgroup", "0::/\n")
    write(tmp_path / "sys" / "memory.current", "123\n")      # the root group: no memory.max
    assert memory.cgroup_available(tmp_path / "cgroup", tmp_path / "sys") is None
    assert memory.cgroup_available(tmp_path / "missing", tmp_path / "sys") is None


def test_a_group_over_its_limit_leaves_nothing(tmp_path):
    write(tmp_path / "cgroup", "0::/job\n")
    write(tmp_path / "sys" / "job" / "memory.max", "100\n")
    write(tmp_path / "sys" / "job" / "memory.current", "150\n")
    assert memory.cgroup_available(tmp_path / "cgroup", tmp_path / "sys") == 0


def test_only_unlimited_groups_mean_none(tmp_path):
    mem = tmp_path / "sys" / "memory"
    write(tmp_path / "cgroup", "4:memory:/job\n")
    for group in (mem, mem / "job"):
        write(group / "memory.limit_in_bytes", "9223372036854771712\n")
        write(group / "memory.usage_in_bytes", f"{GIB}\n")
    assert memory.cgroup_available(tmp_path / "cgroup", tmp_path / "sys") is None


def test_unreadable_cgroup_files_limit_nothing(tmp_path):
    write(tmp_path / "cgroup", "0::/job\n")
    (tmp_path / "sys" / "job").mkdir(parents=True)
    (tmp_path / "sys" / "job" / "memory.max").write_bytes(b"\xff\xfe")
    write(tmp_path / "sys" / "job" / "memory.current", "1\n")
    assert memory.cgroup_available(tmp_path / "cgroup", tmp_path / "sys") is None


def test_available_memory_is_the_lesser_of_node_and_cgroup(monkeypatch):
    monkeypatch.setattr(memory, "node_available", lambda: 64 * GIB)
    monkeypatch.setattr(memory, "cgroup_available", lambda: 3 * GIB)
    assert memory.available_memory() == 3 * GIB
    monkeypatch.setattr(memory, "cgroup_available", lambda: 2 ** 50)
    assert memory.available_memory() == 64 * GIB
    monkeypatch.setattr(memory, "cgroup_available", lambda: None)
    assert memory.available_memory() == 64 * GIB


def test_algorithm_c_cache_default_follows_the_cgroup(monkeypatch):
    from fracfem.spacetime_adaptive import _cache_bytes
    monkeypatch.setattr(memory, "node_available", lambda: 64 * GIB)
    monkeypatch.setattr(memory, "cgroup_available", lambda: 8 * GIB)
    assert _cache_bytes(None) == 2 * GIB
    monkeypatch.setattr(memory, "cgroup_available", lambda: 0)     # a group at its limit
    assert _cache_bytes(None) == GIB


def _child_memory_group(name):
    """A new memory control group (v1 or v2) under this process's own, or None where this
    process may not make one (no root, read-only cgroupfs, no memory controller)."""
    import os
    from pathlib import Path
    if os.geteuid() != 0:
        return None
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
    except OSError:
        return None
    for line in lines:
        ident, _, rest = line.partition(":")
        controllers, _, path = rest.partition(":")
        if "memory" in controllers.split(","):
            base, limit = Path("/sys/fs/cgroup/memory"), "memory.limit_in_bytes"
        elif ident == "0" and controllers == "":
            base, limit = Path("/sys/fs/cgroup"), "memory.max"
        else:
            continue
        own = base / path.strip("/")
        if not own.is_dir():     # a container's mount: fracfem reads the mount's root there
            continue
        child = own / name
        try:
            child.mkdir()
        except OSError:
            continue
        if (child / limit).exists() and (child / "cgroup.procs").exists():
            return child, limit
        child.rmdir()
    return None


def test_a_real_memory_cgroup_is_read():
    """The kernel's own files, not a made-up tree: a child process in a new memory group
    limited to 1 GiB sees at most that, and 256 MiB it touches come off it."""
    import os
    import re
    import subprocess
    import sys
    import time
    from pathlib import Path
    own = memory.cgroup_available()
    if own is not None and own < 2 * GIB:
        pytest.skip("this process's own control group leaves less than 2 GiB")
    made = _child_memory_group(f"fracfem-test-{os.getpid()}")
    if made is None:
        pytest.skip("no memory control group can be made here (needs root and cgroupfs)")
    group, limit_name = made
    try:
        try:
            (group / limit_name).write_text(str(GIB))
        except OSError as err:
            pytest.skip(f"the memory limit cannot be set: {err}")
        code = ("import numpy as np\nfrom fracfem import memory\n"
                "a = memory.cgroup_available()\n"
                "x = np.ones(2 ** 28 // 8)\n"
                "b = memory.cgroup_available()\n"
                "print(a, b, memory.available_memory())\n"
                "try:\n"
                "    memory.check_dense(2 * 2 ** 30, what='W', advice='A')\n"
                "except memory.DenseMemoryError as err:\n"
                "    print(err)\n")
        root = str(Path(__file__).resolve().parents[1])
        env = {k: v for k, v in os.environ.items() if k != memory.ENV}
        env["PYTHONPATH"] = os.pathsep.join(filter(None, [root, env.get("PYTHONPATH")]))
        out = subprocess.run(
            ["sh", "-c", 'echo $$ > "$2/cgroup.procs" && exec "$0" -c "$1"',
             sys.executable, code, str(group)], capture_output=True, text=True, timeout=300,
            env=env)
        assert out.returncode == 0, out.stderr
        numbers, _, refused = out.stdout.partition("\n")
        before, after, available = (int(v) for v in numbers.split())
    finally:
        for _ in range(50):          # the kernel may hold an emptied group for a moment
            try:
                group.rmdir()
                break
            except OSError:
                time.sleep(0.1)
    assert GIB - 512 * 2 ** 20 < before <= GIB       # the interpreter and numpy: < 512 MiB
    assert 0.9 * 2 ** 28 < before - after < 1.2 * 2 ** 28
    assert available <= after + 64 * 2 ** 20          # the group's, not the node's
    # the dense paths' guard refuses 2 GiB in the 1 GiB group, wherever the node has room
    got = re.match(r"W needs about 2 GiB, but only ([0-9.e+-]+) GiB are available", refused)
    assert got and float(got.group(1)) <= 1.0, refused
