"""Every fault one line: workers that die, SIGTERM, a finish cut short, a full or read-only disk, a lost study.json.

Each case checks the message (one line, no traceback, what is kept and what to do), that
no lock or shard folder is left where a rerun can tidy it, and that the rerun gives the
file of the uninterrupted run, variable by variable. ``docs/guide/faults.md`` lists them.
"""

from __future__ import annotations

import errno
import os
import re
import signal
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import xarray as xr

from tests.study.test_engine import _cli, _to_toml, assert_same_result, tiny
from tests.study.test_faults import interrupted
from tumblemc.cli import main
from tumblemc.io import StudyStateError, parts_dir
from tumblemc.study.engine import run_study
from tumblemc.study.tasks import Task, execute_task

LINUX = sys.platform.startswith("linux")  # /proc/self/fd names the file behind a descriptor


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ref") / "tiny.nc"
    run_study(tiny(), out=out, progress=False)
    return out


def _toml(folder: Path, **changes: Any) -> Path:
    p = folder / "tiny.toml"
    p.write_text(_to_toml(tiny(**changes)))
    return p


def _run(toml: Path, out: Path, *extra: str) -> list[str]:
    return ["study", "run", str(toml), "--workers", "0", "--out", str(out), "--no-progress", *extra]


def _lock(out: Path) -> Path:
    return out.with_name(out.name + ".lock")


def _one_line(err: str) -> str:
    assert "Traceback" not in err and err.strip().count("\n") == 0, err
    return err.strip()


def _dies_on_run_2(task: Task) -> Any:
    """A task whose worker process dies whenever it holds run 2 (a crash, an out-of-memory kill)."""
    if 2 in task.run:
        os._exit(1)
    return execute_task(task)


@pytest.mark.slow
def test_workers_that_die_repeatedly_end_in_one_line_and_the_rerun_completes(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import dask

    out, toml = tmp_path / "tiny.nc", _toml(tmp_path)
    monkeypatch.setattr("tumblemc.study.engine.execute_task", _dies_on_run_2)
    with dask.config.set({"distributed.scheduler.allowed-failures": 1}):  # two deaths, not four: seconds
        rc = main(["study", "run", str(toml), "--workers", "1", "--batch-size", "1", "--out", str(out), "--no-progress"])
    line = _one_line(capsys.readouterr().err)
    # dask blames a task the dying worker held, run 2's or one queued beside it, and how many
    # runs finished before the second death depends on scheduling: the words follow both
    assert rc == 1 and re.match(r"error: the workers died 2 times holding the main task of run \d+ \(", line), line
    words = r"; (\d+) finished runs? (?:and (\d+) dt-check runs? )?(?:is|are) kept in (\S+): run the same command again to resume"
    kept = re.search(words, line)
    assert kept is not None and kept[3] == str(parts_dir(out)), line
    assert not _lock(out).exists() and not out.exists()
    assert int(kept[1]) == len(list(parts_dir(out).glob("main-*.npz"))) >= 1, line
    assert int(kept[2] or 0) == len(list(parts_dir(out).glob("check-*.npz"))), line
    monkeypatch.undo()
    assert main(_run(toml, out)) == 0
    assert_same_result(reference, out)
    assert not parts_dir(out).exists() and not _lock(out).exists()


def _terminates_after_run_2(task: Task) -> Any:
    if 2 in task.run:
        os.kill(os.getpid(), signal.SIGTERM)  # delivered to the main thread, which is this one (in-process run)
    return execute_task(task)


@pytest.mark.skipif(sys.platform == "win32", reason="no SIGTERM to send on Windows")
def test_sigterm_ends_like_ctrl_c_in_process(reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: Any) -> None:
    out, toml = tmp_path / "tiny.nc", _toml(tmp_path)

    def sentinel(signum: int, frame: Any) -> None:  # the handler before the command, which it must restore
        raise AssertionError("the command's SIGTERM handler was not installed")

    previous = signal.signal(signal.SIGTERM, sentinel)
    try:
        with monkeypatch.context() as m:
            m.setattr("tumblemc.study.engine.execute_task", _terminates_after_run_2)
            rc = main(_run(toml, out, "--batch-size", "1"))
        restored = signal.getsignal(signal.SIGTERM)
    finally:
        signal.signal(signal.SIGTERM, previous)
    err = capsys.readouterr().err.strip()
    assert rc == 143 and "Traceback" not in err
    want = f"terminated (SIGTERM): 2 finished runs are kept in {parts_dir(out)}; run the same command again to resume"
    assert err.splitlines()[-1] == want
    assert not _lock(out).exists() and not out.exists()
    assert restored is sentinel  # the handler is the command's, not left behind
    assert main(_run(toml, out)) == 0
    assert_same_result(reference, out)


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="no SIGTERM to send on Windows")
def test_sigterm_to_study_run_on_a_local_cluster(tmp_path: Path) -> None:
    """A real SIGTERM to `study run` with worker processes: the lock gone, one message, no semaphore warning; the rerun completes."""
    cfg = tiny(freq_hz=1, samples=4, incline_deg=[0, 30])  # 8 runs of 2 s
    toml = tmp_path / "slow.toml"
    toml.write_text(_to_toml(cfg))
    ref = tmp_path / "ref.nc"
    run_study(cfg, out=ref, progress=False)
    out = tmp_path / "slow.nc"
    proc = _cli(["study", "run", str(toml), "--workers", "1", "--batch-size", "1", "--out", str(out), "--no-progress"])
    deadline = time.time() + 180
    while time.time() < deadline and not list(parts_dir(out).glob("main-*.npz")):
        time.sleep(0.05)
    assert proc.poll() is None, "the study ended before it could be terminated"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert "Traceback" not in err and "leaked" not in err, err
    assert err.strip().splitlines()[-1].startswith("terminated (SIGTERM): ") and "run the same command again to resume" in err
    assert not _lock(out).exists() and not out.exists()
    again = _cli(["study", "run", str(toml), "--workers", "0", "--out", str(out), "--no-progress"])
    _, err = again.communicate(timeout=300)
    assert again.returncode == 0, err
    assert_same_result(ref, out)
    assert not parts_dir(out).exists() and not _lock(out).exists()


def _stop(*a: Any, **k: Any) -> None:
    raise KeyboardInterrupt


@pytest.mark.parametrize("meta", ["kept", "lost"])
def test_shards_left_beside_a_complete_file_are_tidied_by_the_rerun(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], meta: str
) -> None:
    """A kill between the final rename and the shard removal: the rerun removes the folder (its runs are in the file)."""
    out, toml = tmp_path / "tiny.nc", _toml(tmp_path)
    with monkeypatch.context() as m:
        m.setattr("tumblemc.study.engine.finish", _stop)
        assert main(_run(toml, out)) == 130
    assert out.exists() and list(parts_dir(out).glob("main-*.npz"))
    if meta == "lost":  # the shards alone prove that they belong
        (parts_dir(out) / "study.json").unlink()
    capsys.readouterr()
    assert main([*_run(toml, out)[:-1]]) == 0
    err = capsys.readouterr().err
    assert f"removed {parts_dir(out)}, left by an interrupted finish: its runs are all in {out}" in err
    assert not parts_dir(out).exists() and not _lock(out).exists()
    assert_same_result(reference, out)


def test_a_shard_folder_of_another_config_beside_a_complete_file_is_left_and_named(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tiny.nc"
    other = tmp_path / "other.nc"
    interrupted(other, monkeypatch, seed=999)
    os.replace(parts_dir(other), parts_dir(out))  # another config's shards beside a complete file of this one
    out.write_bytes(reference.read_bytes())
    capsys.readouterr()
    run_study(tiny(), out=out)
    assert f"left {parts_dir(out)}: it holds runs of another config" in capsys.readouterr().err
    assert (parts_dir(out) / "study.json").exists()


def _fd_under(fd: int, folder: Path) -> bool:
    try:
        return os.readlink(f"/proc/self/fd/{fd}").startswith(str(folder))
    except OSError:
        return False


@pytest.mark.skipif(not LINUX, reason="the injection reads /proc/self/fd")
def test_a_disk_full_from_the_start_is_one_line_and_leaves_nothing(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """ENOSPC on the first byte written (the lock's holder line), as on a full disk: no empty lock, the folder named."""
    out, toml = tmp_path / "tiny.nc", _toml(tmp_path)
    real = os.write

    def full(fd: int, data: Any) -> int:
        if _fd_under(fd, tmp_path):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd, data)

    with monkeypatch.context() as m:
        m.setattr(os, "write", full)
        rc = main(_run(toml, out))
    line = _one_line(capsys.readouterr().err)
    assert rc == 2 and line.startswith(f"error: no space left on the disk of {tmp_path} (")
    assert "to start writing tiny.nc; nothing was changed: free space and run the same command again" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tiny.toml"]  # no lock, no shard folder
    assert main(_run(toml, out)) == 0
    assert_same_result(reference, out)


def test_the_final_write_reports_the_space_free_once_the_partial_file_is_gone(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The netCDF library can keep a failed file open after its unlink (its blocks return when the process ends): they count as free."""
    out = tmp_path / "tiny.nc"
    real = xr.Dataset.to_netcdf
    held: dict[str, int] = {}
    capacity = 76 * 1024

    def full(self: xr.Dataset, path: Any = None, *a: Any, **k: Any) -> Any:
        if k.get("group") == "maps":
            held["bytes"] = Path(path).stat().st_blocks * 512  # still held by the library after the unlink
            raise RuntimeError("NetCDF: HDF error")
        return real(self, path, *a, **k)

    class Usage:  # a disk of 76 KiB free once the partial file is released
        @property
        def free(self) -> int:
            return capacity - held.get("bytes", 0)

    with monkeypatch.context() as m:
        m.setattr(xr.Dataset, "to_netcdf", full)
        m.setattr("tumblemc.io.shutil.disk_usage", lambda p: Usage())
        with pytest.raises(OSError, match=r"no space left on the disk of .* \(76 KiB free\)"):
            run_study(tiny(), out=out, progress=False)
    assert held["bytes"] > 0 and not list(tmp_path.glob(".*.tmp"))


def _read_only_lock(monkeypatch: pytest.MonkeyPatch, folder: Path) -> None:
    """The lock file cannot be created in ``folder``, as on read-only media (EROFS)."""
    real = os.open

    def ro(path: Any, flags: int, *a: Any, **k: Any) -> int:
        if str(path).startswith(str(folder)) and flags & (os.O_CREAT | os.O_WRONLY | os.O_RDWR):
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        return real(path, flags, *a, **k)

    monkeypatch.setattr(os, "open", ro)


def test_a_complete_result_on_read_only_media_is_reported(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out, toml = tmp_path / "tiny.nc", _toml(tmp_path)
    out.write_bytes(reference.read_bytes())
    before = out.stat().st_mtime_ns
    with monkeypatch.context() as m:
        _read_only_lock(m, tmp_path)
        rc = main(_run(toml, out)[:-1])  # with the progress messages
        cap = capsys.readouterr()
        assert rc == 0 and f"{out} is complete (6 runs); nothing to do" in cap.err
        assert f"complete, read-only (nothing written): {out}" in cap.out and "P(success) by incline" in cap.out
        assert run_study(tiny(), out=out, progress=False).runs.sizes["run"] == 6  # the API too
    assert out.stat().st_mtime_ns == before and sorted(p.name for p in tmp_path.iterdir()) == ["tiny.nc", "tiny.toml"]


def test_an_unfinished_study_on_read_only_media_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out, toml = tmp_path / "tiny.nc", _toml(tmp_path)
    interrupted(out, monkeypatch)
    with monkeypatch.context() as m:
        _read_only_lock(m, tmp_path)
        rc = main(_run(toml, out))
    line = _one_line(capsys.readouterr().err)
    assert rc == 2 and line.startswith(f"error: cannot write in {tmp_path} (Read-only file system); nothing was changed")
    assert f"(6 finished runs and 2 dt-check runs are kept in {parts_dir(out)})" in line


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root writes through chmod 555")
def test_a_complete_result_in_a_folder_without_write_permission_is_reported(reference: Path, tmp_path: Path) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    out = ro / "tiny.nc"
    out.write_bytes(reference.read_bytes())
    ro.chmod(0o555)
    try:
        assert main(_run(_toml(tmp_path), out)) == 0
        assert sorted(p.name for p in ro.iterdir()) == ["tiny.nc"]
    finally:
        ro.chmod(0o755)


def test_a_lost_study_json_is_written_again_when_every_shard_belongs(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tiny.nc"
    interrupted(out, monkeypatch)
    (parts_dir(out) / "study.json").unlink()
    capsys.readouterr()
    run_study(tiny(), out=out)
    assert "study.json was missing: written again from the config (every shard carries its hash)" in capsys.readouterr().err
    assert_same_result(reference, out)


def test_a_lost_study_json_with_a_foreign_shard_is_refused_and_nothing_changes(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    foreign = interrupted(tmp_path / "other" / "tiny.nc", monkeypatch, seed=999)[2]
    out, toml = tmp_path / "tiny.nc", _toml(tmp_path)
    interrupted(out, monkeypatch)
    (parts_dir(out) / "study.json").unlink()
    (parts_dir(out) / foreign.name).write_bytes(foreign.read_bytes())
    before = sorted(p.name for p in parts_dir(out).iterdir())
    with pytest.raises(StudyStateError, match=r"has lost its study.json .* 1 of its \d+ shards do not prove they belong"):
        run_study(tiny(), out=out, progress=False)
    capsys.readouterr()
    assert main(_run(toml, out)) == 2
    line = _one_line(capsys.readouterr().err)
    assert foreign.name in line and "--fresh" in line
    assert sorted(p.name for p in parts_dir(out).iterdir()) == before  # nothing set aside, no study.json written
    assert main([*_run(toml, out), "--fresh"]) == 0
    assert_same_result(reference, out)
