"""What a study says and tidies when something outside its config stops it.

Every fault ends in one sentence that says what is kept and what to do (no traceback):
the cluster losing the workers that run a task (:class:`StudyAbortedError`), an
interruption (:func:`kept_words`), a finish interrupted between the final file and the
removal of its shards (:func:`tidy_finished`). ``docs/guide/faults.md`` lists every case.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

from tumblemc.io import ShardStore, check_parts_belong, parts_dir, read_study_json
from tumblemc.study.tasks import Task


class StudyAbortedError(RuntimeError):
    """The study stopped before its end for a reason outside its config (its workers died); the finished runs are kept."""


def lost_task(task: Task, err: BaseException) -> StudyAbortedError:
    """The error of a task that the cluster could not run: which runs, and why, in words."""
    runs = f"run {task.run[0]}" if len(task.run) == 1 else f"runs {task.run[0]} to {task.run[-1]}"
    what = f"the {task.kind} task of {runs}"
    if type(err).__name__ == "KilledWorker":
        tries = getattr(err, "allowed_failures", 0) + 1
        why = f"the workers died {tries} times holding {what} (a worker process ended: out of memory, a crash, or killed)"
    else:
        why = f"{what} failed on the cluster ({type(err).__name__}: {err})"
    return StudyAbortedError(why)


def kept_words(path: Path, chash: str) -> str:
    """What an interrupted study of config hash ``chash`` keeps for ``path``: how many runs, where."""
    store = ShardStore(path, "", chash)
    n = {k: len(store.read(k, set_aside=False).get("run", ())) for k in ("main", "check")}
    if not any(n.values()):
        return "no run had finished (nothing to keep)"
    check = f" and {n['check']} dt-check {'run' if n['check'] == 1 else 'runs'}" if n["check"] else ""
    one = n["main"] == 1 and not n["check"]
    return f"{n['main']} finished {'run' if n['main'] == 1 else 'runs'}{check} {'is' if one else 'are'} kept in {store.dir}"


def finish(store: ShardStore, path: Path, say: Any) -> None:
    """After the final file is written: keep the damaged shards beside it (named), remove the shard folder."""
    damaged = store.dir / "damaged"
    if damaged.exists():  # kept for inspection: the shards were replaced by recomputed runs
        keep = path.with_name(path.name + ".damaged")
        shutil.rmtree(keep, ignore_errors=True)
        os.replace(damaged, keep)
        say(f"the damaged shards set aside are in {keep}")
    store.remove()


def tidy_finished(path: Path, chash: str, say: Any) -> None:
    """Remove the shard folder an interrupted finish left beside the complete result ``path`` of ``chash``.

    Only a folder of the same config (its ``study.json``, or, without one, every shard's
    checksum) is removed: the complete file holds every run it holds. One of another
    config is left and named. Nothing is removed where the folder cannot be written.
    """
    folder = parts_dir(path)
    if not folder.exists():
        return
    meta = folder / "study.json"
    try:
        same = str(read_study_json(meta).get("config_hash")) == chash if meta.exists() else _all_prove(folder, chash)
    except ValueError:
        same = False
    if not same:
        say(f"left {folder}: it holds runs of another config, not of {path.name} (remove it by hand if they are not wanted)")
        return
    try:
        finish(ShardStore(path, "", chash), path, say)
    except OSError as e:
        say(f"left {folder}: its runs are all in {path}, but it cannot be removed ({e.strerror}); remove it by hand")
        return
    if folder.exists():
        say(f"left {folder}: its runs are all in {path}, but it cannot be removed; remove it by hand")
    else:
        say(f"removed {folder}, left by an interrupted finish: its runs are all in {path}")


def _all_prove(folder: Path, chash: str) -> bool:
    try:
        check_parts_belong(folder, chash)
    except ValueError:
        return False
    return True


__all__ = ["StudyAbortedError", "finish", "kept_words", "lost_task", "tidy_finished"]
