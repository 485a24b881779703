"""numba's settings either work as they should or are refused in one line: uncompiled kernels (the physics would
not move), a cache folder of the user's (kept per version of the package's code), an unusable cache root, and
cache files that cannot be read (dropped and compiled again)."""
import json
import os
import shutil
import subprocess
import sys

import pytest

from paa_mj.provenance import numba_cache_folder, package_digest


def _python(code, **env):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**os.environ, **{k: str(v) for k, v in env.items()}})


def _paa(*args, **env):
    for name in ("NUMBA_CACHE_DIR", "PAA_MJ_NUMBA_CACHE_BASE"):
        os.environ.get(name) and name not in env and env.setdefault(name, os.environ[name])
    return subprocess.run([sys.executable, "-m", "paa_mj.cli", *map(str, args)], capture_output=True, text=True,
                          env={**os.environ, **{k: str(v) for k, v in env.items()}})


@pytest.mark.parametrize("value", ["1", pytest.param("yes", marks=pytest.mark.slow)])  # three processes each
def test_uncompiled_kernels_are_refused_in_one_line(value):
    proc = _paa("simulate", "--t-final", "0.1", "--json", NUMBA_DISABLE_JIT=value)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.strip().splitlines() == [
        f"paa-mj: error: NUMBA_DISABLE_JIT='{value}' is set: paa_mj's physics runs as compiled code only"
        " (uncompiled, MuJoCo would not be stepped); unset it"]
    api = _python("from paa_mj.sim import simulate_mujoco", NUMBA_DISABLE_JIT=value)
    assert api.returncode != 0 and "PaaError: NUMBA_DISABLE_JIT" in api.stderr.strip().splitlines()[-1]
    assert _paa("simulate", "--t-final", "0.01", "--json", NUMBA_DISABLE_JIT="0").returncode == 0


def test_a_cache_folder_of_the_users_gets_one_subfolder_per_version_of_the_code(tmp_path):
    code = "import os, paa_mj; print(os.environ['NUMBA_CACHE_DIR'])"
    proc = _python(code, NUMBA_CACHE_DIR=tmp_path, PAA_MJ_NUMBA_CACHE_BASE="")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == str(tmp_path / package_digest()[:16])
    # a process started from that one keeps the same folder (not a folder inside the folder)
    nested = _python(f"import subprocess, sys; subprocess.run([sys.executable, '-c', {code!r}])",
                     NUMBA_CACHE_DIR=tmp_path, PAA_MJ_NUMBA_CACHE_BASE="")
    assert nested.stdout.strip() == str(tmp_path / package_digest()[:16])


def test_an_unusable_cache_root_falls_back_to_the_temporary_folder():
    proc = _python("import os, paa_mj; print(os.environ['NUMBA_CACHE_DIR'])", PAA_MJ_CACHE="/proc/not-here",
                   NUMBA_CACHE_DIR="", PAA_MJ_NUMBA_CACHE_BASE="")
    assert proc.returncode == 0, proc.stderr
    import tempfile

    assert proc.stdout.strip().startswith(tempfile.gettempdir()) and proc.stdout.strip().endswith(
        package_digest()[:16])


def test_a_small_kernel_s_unreadable_cache_files_are_dropped_and_it_is_compiled_again(tmp_path):
    """The quick form of the next test, in this process (the package's guard on numba's cache is installed): a
    one-line kernel's truncated index and zero-filled data file are removed, and the kernel compiled again."""
    import importlib.util
    from pathlib import Path

    import numba

    source = tmp_path / "tiny_kernel.py"
    source.write_text("from numba import njit\n\n\n@njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n")

    def kernel(module_name):  # the same file as a new module: a new dispatcher, which reads the cache
        spec = importlib.util.spec_from_file_location(module_name, source)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module.twice

    assert kernel("tiny_kernel_first")(1.5) == 3.0
    files = sorted(Path(numba.config.CACHE_DIR).rglob("tiny_kernel.twice-*"))
    try:
        assert {path.suffix for path in files} == {".nbi", ".nbc"}, files
        for path in files:
            path.write_bytes(b"" if path.suffix == ".nbi" else b"\0" * 64)
        again = kernel("tiny_kernel_again")
        assert again(1.5) == 3.0 and again.stats.cache_misses  # compiled again, not loaded
        assert all(path.stat().st_size > 64 for path in files)  # and written anew
    finally:
        for path in files:
            path.unlink(missing_ok=True)


@pytest.mark.slow  # two processes and the engine's step compiled again: about 17 CPU-s
def test_unreadable_cache_files_are_dropped_and_compiled_again(tmp_path):
    """Truncated and zero-filled index and data files of the kernels a run loads: the run gives the same numbers
    as with a sound cache, and the files are written anew."""
    base = tmp_path / "cache"
    shutil.copytree(numba_cache_folder(), base / package_digest()[:16])
    sound = _paa("simulate", "--t-final", "0.2", "--json", NUMBA_CACHE_DIR=base, PAA_MJ_NUMBA_CACHE_BASE=base)
    assert sound.returncode == 0, sound.stderr
    broken = sorted((base / package_digest()[:16]).rglob("step.*"))
    assert broken, "the engine's kernels are cached"
    for k, path in enumerate(broken):
        path.write_bytes(b"" if k % 2 else b"\0" * 64)
    again = _paa("simulate", "--t-final", "0.2", "--json", NUMBA_CACHE_DIR=base, PAA_MJ_NUMBA_CACHE_BASE=base)
    assert again.returncode == 0 and "Error" not in again.stderr, again.stderr
    assert json.loads(again.stdout)["final_state"] == json.loads(sound.stdout)["final_state"]
    assert any(path.exists() and path.stat().st_size > 64 for path in broken)


def test_a_kernel_of_fixed_signature_compiles_at_first_use_once_for_threads_racing_to_it(tmp_path):
    """:func:`paa_mj.jit.lazy_njit`: nothing compiled on import; the first calls, from several threads at once (as the
    engine's threads make them), compile the one signature once and all get their result; then other argument
    types are refused, as ``njit(signature)`` refuses them."""
    import importlib.util
    import threading

    import numpy as np

    source = tmp_path / "tiny_lazy_kernel.py"
    source.write_text("from numba import types\nfrom paa_mj.jit import lazy_njit\n\n\n"
                      "@lazy_njit(types.float64(types.float64[:]), nogil=True)\ndef total(x):\n"
                      "    s = 0.0\n    for v in x:\n        s += v\n    return s\n")
    spec = importlib.util.spec_from_file_location("tiny_lazy_kernel", source)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    assert module.total.signatures == []  # imported, not compiled
    barrier, results, errors = threading.Barrier(4), [], []

    def call(k):
        barrier.wait()
        try:
            results.append(module.total(np.arange(k + 3.0)[::1 + k % 2]))
        except Exception as err:  # noqa: BLE001 - reported below
            errors.append(err)

    threads = [threading.Thread(target=call, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == [] and sorted(results) == [2.0, 3.0, 6.0, 10.0]
    assert len(module.total.signatures) == 1
    with pytest.raises(TypeError):
        module.total(np.arange(3))  # int64: no second signature compiled


def test_a_command_says_once_that_it_compiles_and_nothing_when_it_compiles_nothing(capsys):
    """The line of a fresh install comes with the first compilation, once; a command that compiles nothing (a
    refusal, or kernels loaded from the cache) says nothing of it."""
    from numba import njit

    from paa_mj.cli import _said_when_compiling

    with _said_when_compiling():
        pass
    assert capsys.readouterr().err == ""
    with _said_when_compiling():
        njit(lambda x: x + 1)(1)
        njit(lambda x: x + 2)(1)
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("paa-mj: compiling the kernels this command needs")
    with _said_when_compiling():
        pass
    assert capsys.readouterr().err == ""
