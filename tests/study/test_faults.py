"""Fault probes of the study engine: what users and disks do to a study.

Damaged and conflicting shards, a second `study run` on the same output, configs that no
run could finish, a full disk in the final write, unreadable configs and records, a busy
dashboard port. Each probe failed before the engine handled it.
"""

from __future__ import annotations

import hashlib
import io
import socket
import sys
import warnings
import zipfile
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import numpy as np
import pytest
import xarray as xr

import tumblemc
from tests.study.test_engine import _to_toml, assert_same_result, tiny
from tumblemc.cli import main
from tumblemc.io import ResultWriteError, StudyStateError, parts_dir, shard_digest
from tumblemc.study.checks import ConfigError
from tumblemc.study.config import load_config
from tumblemc.study.engine import run_study, study_status
from tumblemc.study.lock import StudyLock, StudyLockedError


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("ref") / "tiny.nc"
    run_study(tiny(), out=out, progress=False)
    return out


def interrupted(out: Path, monkeypatch: pytest.MonkeyPatch, **changes: Any) -> list[Path]:
    """Every shard of the tiny study, and no result: the run stops just before the final write."""

    def stop(*a: Any, **k: Any) -> None:
        raise KeyboardInterrupt

    with monkeypatch.context() as m:
        m.setattr("tumblemc.study.engine.write_result", stop)
        with pytest.raises(KeyboardInterrupt):
            run_study(tiny(**changes), out=out, progress=False, batch_size=1)
    assert not out.exists()
    return sorted(parts_dir(out).glob("main-*.npz"))


def _npz(arrays: dict[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def _tiny_hash(**changes: Any) -> str:
    from tumblemc.study.identity import config_hash

    return config_hash(load_config(tiny(**changes)))


def _named(folder: Path, stem: str, data: bytes) -> Path:
    """A shard whose name carries the checksum of ``data`` under the tiny study's config hash (a well-formed shard)."""
    p = folder / f"{stem}-{shard_digest(_tiny_hash(), data)}.npz"
    p.write_bytes(data)
    return p


def _damage(shard: Path, how: str) -> Path:
    """Damage ``shard`` as ``how`` says; returns the file the engine must name."""
    raw = shard.read_bytes()
    if how == "truncated":
        shard.write_bytes(raw[: len(raw) // 2])
        return shard
    if how == "bit_flip":
        b = bytearray(raw)
        b[len(b) // 2] ^= 0x10
        shard.write_bytes(bytes(b))
        return shard
    with np.load(shard) as z:
        cols = {k: z[k] for k in z.files}
    if how == "altered_values":  # a valid npz under the old name: only the checksum tells
        cols["progress_ratio"] = cols["progress_ratio"] + 1.0
        shard.write_bytes(_npz(cols))
        return shard
    stem = shard.stem.rsplit("-", 1)[0]
    if how == "missing_column":  # well formed, checksum right, a column gone
        shard.unlink()
        del cols["climbed"]
        return _named(shard.parent, stem, _npz(cols))
    assert how == "conflicting"  # a second well-formed shard with other values for the same run
    cols["progress_ratio"] = cols["progress_ratio"] + 1.0
    return _named(shard.parent, stem, _npz(cols))


@pytest.mark.parametrize("how", ["truncated", "bit_flip", "altered_values", "missing_column", "conflicting"])
def test_a_damaged_shard_is_named_set_aside_and_recomputed(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], how: str
) -> None:
    out = tmp_path / "tiny.nc"
    shards = interrupted(out, monkeypatch)
    bad = _damage(shards[1], how)
    st = study_status(_toml(tmp_path), out)  # status reports it and moves nothing
    assert bad.name in st["damaged_shards"] and bad.exists()
    capsys.readouterr()
    run_study(tiny(), out=out, progress=False)
    err = capsys.readouterr().err
    assert f"set aside {bad.name}" in err
    assert_same_result(reference, out)
    assert (out.with_name(out.name + ".damaged") / bad.name).exists()
    assert not parts_dir(out).exists()


def _toml(folder: Path, **changes: Any) -> Path:
    p = folder / "tiny.toml"
    p.write_text(_to_toml(tiny(**changes)))
    return p


def test_shards_carry_a_checksum_in_their_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shards = interrupted(tmp_path / "tiny.nc", monkeypatch)
    assert shards
    for s in shards:
        assert s.stem.rsplit("-", 1)[1] == shard_digest(_tiny_hash(), s.read_bytes())
        assert zipfile.is_zipfile(s)


@pytest.mark.skipif(sys.platform == "win32", reason="no flock on Windows: nothing is locked there")
def test_a_second_run_on_the_same_output_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "tiny.nc"
    toml = _toml(tmp_path)
    with StudyLock(out):  # the first run holds the output
        with pytest.raises(StudyLockedError, match="is being written by"):
            run_study(tiny(), out=out, progress=False)
        capsys.readouterr()
        rc = main(["study", "run", str(toml), "--workers", "0", "--out", str(out), "--no-progress"])
        err = capsys.readouterr().err
        assert rc == 2 and err.count("\n") == 1 and "is being written by `tumblemc study run` (pid" in err
        assert not parts_dir(out).exists()  # the refused run touched nothing
    run_study(tiny(), out=out, progress=False)  # released: the next run proceeds
    assert out.exists() and not out.with_name(out.name + ".lock").exists()


@pytest.mark.parametrize(
    ("changes", "key", "words"),
    [
        ({"periods": 1e6}, "periods", "beyond the simulator's 10000 s"),
        ({"dt": 1e-9}, "dt", "steps per run"),
        ({"samples": 1_000_000, "incline_deg": {"start": 0, "stop": 89, "step": 0.1}}, "samples", "runs in all"),
        ({"periods": 2.5, "transient_periods": 1.1, "dt": 3.3e-8}, "transient_periods", "GiB per run"),
    ],
)
def test_configs_no_run_could_finish_are_refused_at_validation(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], changes: dict[str, Any], key: str, words: str
) -> None:
    with pytest.raises(ConfigError, match=words) as e:
        load_config(tiny(**changes))
    assert e.value.key == key and "\n" not in str(e.value)
    toml = tmp_path / "big.toml"
    toml.write_text(_to_toml(tiny(**changes)))
    out = tmp_path / "big.nc"
    rc = main(["study", "run", str(toml), "--workers", "0", "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and key in err
    assert not parts_dir(out).exists() and not out.exists()


def test_the_bounds_are_overridable_in_execution(monkeypatch: pytest.MonkeyPatch) -> None:
    cfg = tiny(dt=1e-9)
    cfg["execution"] = {"max_steps_per_run": 10**10, "max_run_memory_gib": 1e3}
    assert load_config(cfg).dt == 1e-9
    monkeypatch.setattr("tumblemc.study.budget.usable_memory", lambda: 64 * 2**30)  # the machine's memory, fixed
    big = tiny(samples=10_000, incline_deg={"start": 0, "stop": 89, "step": 0.1})  # 8.9 million runs
    big["execution"] = {"max_runs": 10**10}
    assert load_config(big).samples == 10_000
    # raising max_runs does not lift the memory the design table needs (counted before it is built)
    big["samples"] = 1_000_000
    with pytest.raises(ConfigError, match=r"samples=1000000 gives 891,000,000 runs whose design table alone needs about"):
        load_config(big)


def test_a_full_disk_in_the_final_write_is_one_clear_line_and_resumes(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "tiny.nc"
    stale = tmp_path / ".tiny.nc.0123abcd.tmp"  # what a kill -9 in the final write leaves
    stale.write_bytes(b"partial")
    real = xr.Dataset.to_netcdf

    def full(self: xr.Dataset, path: Any = None, *a: Any, **k: Any) -> Any:
        if k.get("group") == "maps":  # the file exists and is half written when the disk fills
            raise RuntimeError("NetCDF: HDF error")
        return real(self, path, *a, **k)

    class Usage:
        free = 1024

    toml = _toml(tmp_path)
    with monkeypatch.context() as m:
        m.setattr(xr.Dataset, "to_netcdf", full)
        m.setattr("tumblemc.io.shutil.disk_usage", lambda p: Usage())
        with pytest.raises(ResultWriteError, match="no space left on the disk"):
            run_study(tiny(), out=out, progress=False)
        rc = main(["study", "run", str(toml), "--workers", "0", "--out", str(out), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "no space left on the disk" in err and "run the same command again" in err
    assert not list(tmp_path.glob(".*.tmp")) and not out.exists() and parts_dir(out).exists()
    run_study(tiny(), out=out, progress=False)
    assert_same_result(reference, out)


def test_unreadable_configs_and_records_name_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    bad = tmp_path / "latin1.toml"
    bad.write_bytes(_to_toml(tiny()).encode() + b'description = "caf\xe9"\n')
    with pytest.raises(ConfigError, match=r"latin1.toml: not UTF-8 text: byte 0xe9 at line \d+, column 19"):
        load_config(bad)
    out = tmp_path / "tiny.nc"
    interrupted(out, monkeypatch)
    (parts_dir(out) / "study.json").write_text("{not json")
    with pytest.raises(StudyStateError, match=r"study.json is damaged .*--fresh"):
        run_study(tiny(), out=out, progress=False)
    with pytest.raises(StudyStateError, match="study.json is damaged"):
        study_status(_toml(tmp_path), out)


def test_status_of_a_changed_config_does_not_count_the_other_configs_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "tiny.nc"
    interrupted(out, monkeypatch)
    st = study_status(_toml(tmp_path, seed=99), out)
    assert st["state"] == "different config" and "done" not in st and "--fresh" in st["message"]
    assert study_status(_toml(tmp_path), out)["state"] == "partial"


@pytest.mark.parametrize("value", ["0.4", b"0.4"])
def test_a_string_for_a_number_is_refused(value: Any) -> None:
    with pytest.raises(ValueError, match="mu=.*is not a number"):
        tumblemc.simulate(mu=value, duration_s=0.01)


def test_study_run_prints_a_header_and_a_success_table(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    toml = _toml(tmp_path)
    rc = main(["study", "run", str(toml), "--workers", "0", "--out", str(tmp_path / "tiny.nc")])
    cap = capsys.readouterr()
    assert rc == 0
    head = cap.err.splitlines()
    want = "study tiny: 6 runs = 2 cells (1 shape x 1 substrate x 2 inclines) x 3 samples"
    assert head[0] == want + ", plus 2 dt-check runs at dt/2 (8 in the progress bar)"
    assert head[2].startswith("  rough estimate") and head[3].startswith(("loading the compiled kernels", "compiling the kernels"))
    assert "P(success) by incline (deg)" in cap.out
    assert "cuboid       aluminum" in cap.out and "climbs to" in cap.out


@pytest.mark.slow
def test_the_local_cluster_starts_with_port_8787_taken() -> None:
    from tumblemc.study.engine import local_client

    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("", 8787))
            s.listen()
        except OSError:  # another process holds it already: the case under test
            pass
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            client = local_client(1)
            try:
                assert urlparse(client.dashboard_link).port != 8787
                assert client.submit(sum, [1, 2]).result() == 3
            finally:
                cluster = client.cluster
                client.close()
                cluster.close()


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="no flock on Windows: nothing is locked there")
def test_a_concurrent_cli_run_is_refused_while_the_first_finishes(tmp_path: Path) -> None:
    import time

    from tests.study.test_engine import _cli

    toml = tmp_path / "slow.toml"
    toml.write_text(_to_toml(tiny(freq_hz=1, samples=4, incline_deg=[0, 30])))  # 8 runs of 2 s
    out = tmp_path / "slow.nc"
    first = _cli(["study", "run", str(toml), "--workers", "0", "--batch-size", "1", "--out", str(out), "--no-progress"])
    deadline = time.time() + 120
    while time.time() < deadline and not list(parts_dir(out).glob("main-*.npz")):
        time.sleep(0.05)
    assert first.poll() is None, "the first run ended before the second could start"
    second = _cli(["study", "run", str(toml), "--workers", "0", "--out", str(out), "--no-progress"])
    _, err2 = second.communicate(timeout=120)
    assert second.returncode == 2 and err2.count("\n") == 1 and "is being written by" in err2, err2
    assert first.poll() is None  # refused while the first is still running
    _, err1 = first.communicate(timeout=300)
    assert first.returncode == 0, err1
    assert study_status(out)["state"] == "complete"


def test_shards_of_earlier_versions_are_set_aside_and_redone(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Shards that cannot prove they belong to this study are named, set aside and redone: the same result.

    The 8-hex tag of the oldest versions, and a checksum of the bytes alone (before the config hash was in it).
    """
    out = tmp_path / "tiny.nc"
    shards = interrupted(out, monkeypatch)
    tagged, unbound = shards[:3], shards[3:5]
    for s in tagged:
        s.rename(s.with_name(s.stem.rsplit("-", 1)[0] + "-0123abcd.npz"))
    for s in unbound:
        s.rename(s.with_name(s.stem.rsplit("-", 1)[0] + f"-{hashlib.sha256(s.read_bytes()).hexdigest()[:16]}.npz"))
    capsys.readouterr()
    run_study(tiny(), out=out, progress=False)
    err = capsys.readouterr().err
    assert_same_result(reference, out)
    assert len(list((out.with_name(out.name + ".damaged")).iterdir())) == 5
    assert err.count("unchecked tag of an earlier version") == 3 and err.count("written by an earlier version") == 2


def test_a_shard_of_another_study_or_outside_the_design_is_set_aside(
    reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A foreign shard and one with runs beyond the design: each named and set aside, the result the uninterrupted one.

    The foreign one is the same-numbered shard of another study (valid checksum there, other runs).
    """
    other = tmp_path / "other" / "tiny.nc"
    foreign = interrupted(other, monkeypatch, seed=999)[2]
    out = tmp_path / "tiny.nc"
    shards = interrupted(out, monkeypatch)
    shards[2].unlink()
    planted = out.with_name(out.name + ".parts") / foreign.name
    planted.write_bytes(foreign.read_bytes())
    with np.load(shards[3]) as z:
        cols = {k: z[k] for k in z.files}
    cols["run"] = cols["run"] + 1000
    outside = _named(shards[3].parent, f"main-{int(cols['run'][0]):09d}-{len(cols['run'])}", _npz(cols))
    capsys.readouterr()
    run_study(tiny(), out=out, progress=False)
    err = capsys.readouterr().err
    assert f"set aside {planted.name} (fails its checksum" in err and "of another study" in err
    assert f"set aside {outside.name} (records runs outside the study's design" in err
    assert_same_result(reference, out)


def test_shards_of_an_older_schema_are_redone_once_new_ones_exist(reference: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Legacy shards lacking a column that came later (the config hash unchanged): set aside and redone, not a dead end."""
    out = tmp_path / "tiny.nc"
    shards = interrupted(out, monkeypatch)
    for i, s in enumerate(shards):
        if i >= 4:
            s.unlink()
            continue
        with np.load(s) as z:
            cols = {k: z[k] for k in z.files if k != "heading_change_deg"}
        s.unlink()
        (s.parent / (s.stem.rsplit("-", 1)[0] + "-0123abcd.npz")).write_bytes(_npz(cols))
    run_study(tiny(), out=out, progress=False)
    assert_same_result(reference, out)
    assert len(list((out.with_name(out.name + ".damaged")).iterdir())) == 4


@pytest.mark.slow
def test_the_dashboard_listens_on_loopback_only() -> None:
    """`study run --dashboard`: the dashboard (logs, call stacks, no login) and the scheduler bind to 127.0.0.1, as the link says."""
    from tumblemc.study.engine import local_client

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Port 8787 is already in use", category=UserWarning)
        client = local_client(1, dashboard=True)
    try:
        bound = [s.getsockname()[0] for s in client.cluster.scheduler.http_server._sockets.values()]
        assert bound and all(h == "127.0.0.1" for h in bound), bound
        assert urlparse(client.dashboard_link).hostname == "127.0.0.1"
        assert urlparse(client.cluster.scheduler.address).hostname == "127.0.0.1"
    finally:
        cluster = client.cluster
        client.close()
        cluster.close()


@pytest.mark.skipif(sys.platform == "win32", reason="no flock on Windows: nothing is locked there")
def test_a_symlinked_lock_is_refused_and_its_target_untouched(tmp_path: Path) -> None:
    target = tmp_path / "precious.txt"
    target.write_text("keep me")
    out = tmp_path / "study.nc"
    out.with_name(out.name + ".lock").symlink_to(target)
    with pytest.raises(StudyLockedError, match="is a symbolic link"):
        with StudyLock(out):
            pass
    assert target.read_text() == "keep me"
    with pytest.raises(StudyLockedError, match="is a symbolic link"):
        run_study(tiny(), out=out, progress=False)
    assert target.read_text() == "keep me" and not out.exists()
