"""Who owns an output folder: each study names itself in it (its command and, for RealAIGym, the protocol), and
another study's results are never overwritten or removed without ``--fresh``."""
from __future__ import annotations

import contextlib
import json
import os
import zipfile

from ..errors import PaaError
from .common import note


#: The file that marks a folder as holding a command's results (``--out``).
RESULT_FILES = {"simulate": "trajectory.npz", "basin": "basin.npz", "robustness": "robustness.npz",
                "compare": "leaderboard.json", "atlas": "atlas.npz", "reproduce": "report.md",
                "peers": "peers.json", "realaigym": "realaigym.json"}
#: The other files each command writes: found without the command's result file beside them, they are
#: somebody else's, and the command refuses to replace them.
ALSO_WRITTEN = {"simulate": ("trajectory.csv", "summary.json"),
                "basin": ("summary.json", "basin.png", "basin.svg"), "robustness": ("summary.json",),
                "compare": ("leaderboard.md", "leaderboard.png", "leaderboard.svg", "kips.npz", "kips_overlaid.png",
                            "kips_overlaid.svg", "kips_side_by_side.mp4"),
                "atlas": ("atlas.json", "atlas_theory.png", "atlas_theory.svg", "atlas_outcome.png",
                          "atlas_outcome.svg"),
                "reproduce": ("results.json",), "peers": ("peers.md", "peers_closed_loop.png", "peers_closed_loop.svg"),
                "realaigym": ("sim_swingup.csv", "robustness_v2.png", "robustness_v2.svg", "global_v3.png",
                              "global_v3.svg")}


#: The folders a study keeps in its --out besides its files: finished chunks, compare's studies per controller.
ALSO_KEPT = {"basin": (".chunks",), "robustness": (".chunks",), "atlas": (".chunks",), "realaigym": (".chunks",),
             "compare": ("studies",)}
#: The file naming the one study that owns a study's --out (``{"command": ..., "study": ...}``, the study being the
#: command with its protocol): written when the study takes the folder, before its first chunk.
MANIFEST = ".paa-mj-study.json"


def folder_owner(out):
    """``(command, study)`` that owns the folder ``out``: its manifest's, else the command whose result file it holds
    (a folder of a command that keeps no manifest, or of an older version), else None."""
    try:
        with open(os.path.join(out, MANIFEST)) as fh:
            owner = json.load(fh)
        return str(owner["command"]), str(owner["study"])
    except (OSError, ValueError, KeyError, TypeError):
        pass
    for command, name in RESULT_FILES.items():  # a file of that name that is not the command's is nobody's
        if _holds_own_result(command, os.path.join(out, name)):
            return command, _legacy_study(command, os.path.join(out, name))
    return None


def _legacy_study(command, path):
    if command != "realaigym":
        return command
    try:
        with open(path) as fh:
            return f"realaigym --protocol {json.load(fh)['protocol']}"
    except (OSError, ValueError, KeyError, TypeError):
        return command


def output_lock(out, command, study=None, fresh=False):
    """The lock on ``--out`` for ``command`` (nothing without ``--out``); ``study``: the command with what makes
    another study of it (``realaigym --protocol robustness-v2``; default the command).

    A folder has one owner (:func:`folder_owner`): a folder owned by another study is refused in one line, or with
    ``fresh`` (the studies' ``--fresh``) that study's files and kept chunks are removed first, said on stderr; files
    of nobody's are never removed. The same study again replaces, or resumes. A study (a command with ``--fresh``)
    names itself in the folder's :data:`MANIFEST` as it starts.
    """
    if out is None:
        return contextlib.nullcontext()
    return _owned(out, command, study or command, fresh)


@contextlib.contextmanager
def _owned(out, command, study, fresh):
    from ..io import OutputLock, write_json

    with OutputLock(out):
        owner = folder_owner(out)
        if owner is not None and owner[1] != study:
            if not fresh:
                raise PaaError(f"{out} holds the results of 'paa-mj {owner[1]}': choose another --out"
                               + (", or give --fresh to replace them" if command in ALSO_KEPT else ""))
            _remove_results(out, owner)
        own = RESULT_FILES[command]
        replaced = [name for name in (own, *ALSO_WRITTEN.get(command, ())) if os.path.lexists(os.path.join(out, name))]
        if replaced and not _holds_own_result(command, os.path.join(out, own)):
            raise PaaError(f"{out} holds {', '.join(replaced)}, not the results of a 'paa-mj {command}' it would"
                           " replace: choose another --out, or move those files")
        if command in ALSO_KEPT:
            write_json(os.path.join(out, MANIFEST), {"command": command, "study": study})
        yield


def _remove_results(out, owner):
    """Remove what the study ``owner`` (command, study) wrote in ``out``: its files and folders, nothing else."""
    import shutil

    command, study = owner
    names = [name for name in (RESULT_FILES.get(command, MANIFEST), *ALSO_WRITTEN.get(command, ()),
                               *ALSO_KEPT.get(command, ()), MANIFEST) if os.path.lexists(os.path.join(out, name))]
    names = list(dict.fromkeys(names))
    for name in names:
        path = os.path.join(out, name)
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        else:
            os.remove(path)
    note(f"--fresh: removed the results of 'paa-mj {study}' from {out} ({', '.join(names)})")


#: What each command's result file holds, by which a file of that name is known to be the command's (a folder
#: without a manifest, of an older version or of a command that keeps none): the arrays of an NPZ, the keys of a JSON
#: object, the report's title. A user's ``report.md`` or ``results.json`` is nobody's: never replaced, never
#: removed by another study's ``--fresh``.
RESULT_SIGNS = {"simulate": ("npz", {"t", "q", "qd", "tau", "meta"}), "basin": ("npz", {"x0", "success"}),
                "robustness": ("npz", {"x0", "success"}), "atlas": ("npz", {"factors_1", "factors_2", "E_r"}),
                "compare": ("json", {"robot", "controllers"}), "peers": ("json", {"paa_mj", "drake"}),
                "realaigym": ("json", {"protocol", "robot", "controller"}),
                "reproduce": ("title", None)}  # report.md's first line: paa_mj.outputs.report.REPORT_TITLE


def _holds_own_result(command, path):
    """Whether ``path`` is ``command``'s result file, by what it holds (:data:`RESULT_SIGNS`), not by its name."""
    if not os.path.isfile(path):
        return False
    kind, sign = RESULT_SIGNS[command]
    try:
        if kind == "npz":
            with zipfile.ZipFile(path) as archive:
                return {f"{name}.npy" for name in sign} <= set(archive.namelist())
        if kind == "json":
            with open(path) as fh:
                data = json.load(fh)
            return isinstance(data, dict) and sign <= set(data)
        from ..outputs.report import REPORT_TITLE

        with open(path, encoding="utf-8") as fh:
            return fh.readline().rstrip("\n") == REPORT_TITLE
    except (OSError, ValueError, zipfile.BadZipFile):
        return False
