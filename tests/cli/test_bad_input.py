"""Bad input is refused before it costs: a generated campaign over study configs, bench files, calibrate arguments and simulate calls.

Every refusal must be one ``ValueError`` line (the CLI: exit status 2 and one ``error:``
line, no traceback) naming the input. Validation-only cases are fast; the accepted
extremes that simulate are in the slow tier, each bounded to 10 s.
"""

from __future__ import annotations

import math
import os
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

from tumblemc.cli import main
from tumblemc.lab import calibrate as C
from tumblemc.lab.benchdata import MAX_BENCH_ROWS
from tumblemc.model.params import NUMERIC_FIELDS, PRESETS, RANGES
from tumblemc.model.plausible import run_notes
from tumblemc.model.run import run_inputs, simulate
from tumblemc.study.checks import ConfigError
from tumblemc.study.config import load_config
from tumblemc.study.distributions import UNCERTAIN_PARAMS

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "studies" / "smoke.toml"
GOOD_TILT = "field_mT,tilt_deg\n" + "".join(f"{b},{t}\n" for b, t in [(3, 0), (5, 0), (7, 52.1), (9, 57.5), (11, 60.6), (13, 62.1)])


def tiny(**changes: Any) -> dict[str, Any]:
    d = tomllib.loads(SMOKE.read_text())
    d.update({"name": "tiny", "incline_deg": [0, 60], "freq_hz": 10, "samples": 3})
    d.update(changes)
    return d


def one_line(msg: str) -> None:
    assert msg and "\n" not in msg and "Traceback" not in msg, msg


# -- study configs -------------------------------------------------------------------------


def _bad_distributions() -> list[tuple[str, dict[str, Any]]]:
    """Four unusable distributions of every uncertain parameter: NaN, huge or implausible draws."""
    out = []
    for p in UNCERTAIN_PARAMS:
        if p in ("axis_yaw_deg", "axis_pitch_deg"):
            continue
        r = RANGES[p]
        top = min(r.hi, r.plausible_hi)
        out += [
            (f"{p} lognormal cv 1e300", {p: {"dist": "lognormal", "cv": 1e300, "mean": top / 2 if math.isfinite(top) else 1.0}}),
            (f"{p} uniform to 1e300", {p: {"dist": "uniform", "low": max(r.lo, 0.0), "high": 1e300}}),
            (f"{p} normal sd 1e300", {p: {"dist": "normal", "sd": 1e300}}),
            (f"{p} truncnormal mean 1e300", {p: {"dist": "truncnormal", "mean": 1e300, "sd": 1.0}}),
        ]
    return out


def _bad_posterior(tmp: Path, name: str, values: dict[str, Any]) -> str:
    f = tmp / f"{name}.nc"
    xr.Dataset({k: ("sample", np.asarray(v, float)) for k, v in values.items()}).to_netcdf(f)
    return str(f)


def _bad_configs(tmp: Path) -> list[tuple[str, dict[str, Any]]]:
    fifo = tmp / "fifo.nc"
    os.mkfifo(fifo)
    big = tmp / "big.nc"
    with open(big, "wb") as fh:  # sparse: its size says 1 GiB, nothing is written
        fh.truncate(2**30)
    fine = {"start": -89, "stop": 89, "step": 0.02}  # 8,901 inclines
    cases: list[tuple[str, dict[str, Any]]] = [(n, tiny(uncertain=u)) for n, u in _bad_distributions()]
    cases += [
        ("max_runs 1e12, fine grid", tiny(incline_deg=fine, field_mT=list(range(1, 1001)), samples=1000, execution={"max_runs": 10**12})),
        ("samples 0", tiny(samples=0)),
        ("samples 1e12", tiny(samples=10**12)),
        ("field 1e6 mT", tiny(field_mT=1e6)),
        ("field 2 T", tiny(field_mT=2000)),
        ("freq 0", tiny(freq_hz=0)),
        ("freq 1e9", tiny(freq_hz=1e9)),
        ("periods 1e9", tiny(periods=1e9)),
        ("dt 1 s", tiny(dt=1.0)),
        ("incline 95", tiny(incline_deg=[95])),
        ("seed -1", tiny(seed=-1)),
        ("name with space", tiny(name="a b")),
        ("dist cauchy", tiny(uncertain={"mu": {"dist": "cauchy", "sd": 1}})),
        ("cv nan", tiny(uncertain={"mu": {"dist": "lognormal", "cv": math.nan}})),
        ("posterior /dev/zero", tiny(uncertain={"posterior": "/dev/zero"})),
        ("posterior fifo", tiny(uncertain={"posterior": str(fifo)})),
        ("posterior directory", tiny(uncertain={"posterior": str(tmp)})),
        ("posterior 1 GiB", tiny(uncertain={"posterior": str(big)})),
        ("posterior mass 0", tiny(uncertain={"posterior": _bad_posterior(tmp, "m0", {"mass": [0.0, 0.0, 1.6e-7]})})),
        ("posterior mu nan", tiny(uncertain={"posterior": _bad_posterior(tmp, "nan", {"mu": [0.3, math.nan]})})),
        ("posterior mu 1e300", tiny(uncertain={"posterior": _bad_posterior(tmp, "big", {"mu": [0.3, 1e300]})})),
        ("posterior magnetisation 1e9", tiny(uncertain={"posterior": _bad_posterior(tmp, "mag", {"magnetization": [1e9, 1.5e4]})})),
    ]
    return cases


def test_eighty_malformed_configs_are_one_line_each(tmp_path: Path) -> None:
    cases = _bad_configs(tmp_path)
    assert len(cases) >= 80
    for name, cfg in cases:
        t0 = time.perf_counter()
        with pytest.raises(ConfigError) as err:
            load_config(cfg)
        one_line(str(err.value))
        assert time.perf_counter() - t0 < 10.0, name


@pytest.mark.parametrize(
    "uncertain, words",
    [
        ({"adhesion_C": {"dist": "lognormal", "cv": 1e300}}, ["uncertain.adhesion_C", "finite draws"]),
        ({"mu": {"dist": "uniform", "low": 0.05, "high": 1e300}}, ["uncertain.mu", "[0, 100]", "dry friction"]),
        ({"magnetization": {"dist": "uniform", "low": 1e4, "high": 1e7}}, ["uncertain.magnetization", "1.95e6 A/m"]),
    ],
)
def test_unusable_distributions_name_the_key_and_the_reason(uncertain: dict[str, Any], words: list[str]) -> None:
    with pytest.raises(ConfigError) as err:
        load_config(tiny(uncertain=uncertain))
    for w in words:
        assert w in str(err.value), str(err.value)


def test_a_posterior_is_read_only_from_a_bounded_regular_file(tmp_path: Path) -> None:
    for value, words in (("/dev/zero", "is not a regular file"), (str(tmp_path), "is not a regular file")):
        with pytest.raises(ConfigError, match=words):
            load_config(tiny(uncertain={"posterior": value}))
    fifo = tmp_path / "f.nc"
    os.mkfifo(fifo)
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match="is not a regular file"):
        load_config(tiny(uncertain={"posterior": str(fifo)}))
    assert time.perf_counter() - t0 < 5.0
    zero = _bad_posterior(tmp_path, "zero", {"mass": [1.6e-7, 0.0]})
    with pytest.raises(ConfigError, match=r"mass has 1 of 2 draws outside a number in \[1e-12, 1\] kg, the first 0.0 \(sample 1\)"):
        load_config(tiny(uncertain={"posterior": zero}))


def test_a_huge_grid_is_counted_not_built() -> None:
    """A grid of 8.9 billion runs with max_runs raised: refused by its design table's memory, at once."""
    cfg = tiny(incline_deg={"start": -89, "stop": 89, "step": 0.02}, field_mT=list(range(1, 1001)), samples=1000)
    cfg["execution"] = {"max_runs": 10**12}
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match="design table alone needs about"):
        load_config(cfg)
    assert time.perf_counter() - t0 < 5.0


def test_the_shipped_studies_still_load() -> None:
    for f in sorted((ROOT / "studies").glob("*.toml")):
        if not f.name.startswith("design"):
            load_config(f)


# -- bench files and calibrate arguments ---------------------------------------------------


def _bench_files(tmp: Path) -> list[tuple[str, Path, str]]:
    """(name, file, words of the message) for malformed bench CSVs."""
    rows = "".join(f"{b},{t}\n" for b, t in [(3, 0), (5, 0), (7, 52.1)])
    texts = {
        "tilt 500": ("field_mT,tilt_deg\n3,0\n5,500\n7,700\n", "line 3: tilt_deg=500 is out of range"),
        "tilt -20": ("field_mT,tilt_deg\n3,-20\n5,0\n", "tilt_deg=-20 is out of range"),
        "negative field": ("field_mT,tilt_deg\n-3,0\n5,10\n", "line 2: field_mT=-3 is out of range"),
        "all-zero field": ("field_mT,tilt_deg\n0,0\n0.0,0\n", "line 3: repeats field_mT=0"),
        "zero fields": ("field_mT,tilt_deg\n0,0\n-0.0,1\n", "gives another tilt_deg"),
        "field 1e308": ("field_mT,tilt_deg\n1e308,0\n5,10\n", "field_mT=1e+308 is out of range"),
        "tilt 1e308": ("field_mT,tilt_deg\n3,1e308\n5,10\n", "tilt_deg=1e+308 is out of range"),
        "field 2 T": ("field_mT,tilt_deg\n2000,10\n5,10\n", "1 T is beyond any coil"),
        "conflicting duplicate": (
            "field_mT,tilt_deg\n" + rows + "5,40\n",
            "line 5: gives another tilt_deg (40, not 0) for field_mT=5 of line 3",
        ),
        "copied row": ("field_mT,tilt_deg\n" + rows + "7,52.1\n", "line 5: repeats field_mT=7 of line 4"),
        "inf": ("field_mT,tilt_deg\n3,inf\n5,0\n", "is not finite"),
        "nan": ("field_mT,tilt_deg\nnan,0\n5,0\n", "is not finite"),
        "text": ("field_mT,tilt_deg\n3,flat\n5,0\n", "is not two numbers"),
        "three columns": ("field_mT,tilt_deg\n3,0,1\n5,0\n", "is not two numbers"),
        "header only": ("field_mT,tilt_deg\n", "0 data row"),
        "bad header": ("B,tilt\n3,0\n5,0\n", "is not a bench test"),
        "empty": ("", "empty"),
        "speed freq 0": ("freq_hz,speed_mm_s\n0,0\n5,1\n", "freq_hz=0 is out of range"),
        "speed 1e308": ("freq_hz,speed_mm_s\n1,1e308\n5,1\n", "speed_mm_s=1e+308 is out of range"),
        "speed freq -1": ("freq_hz,speed_mm_s\n-1,0\n5,1\n", "freq_hz=-1 is out of range"),
        "climbed 2": ("incline_deg,climbed\n10,2\n20,0\n", "climbed=2 is out of range"),
        "too many rows": (
            "field_mT,tilt_deg\n" + "".join(f"{i * 1e-3:.3f},0\n" for i in range(MAX_BENCH_ROWS + 1)),
            "data rows (allowed: at most",
        ),
    }
    out = []
    for name, (text, words) in texts.items():
        f = tmp / (name.replace(" ", "_") + ".csv")
        f.write_text(text, encoding="utf-8")
        out.append((name, f, words))
    latin = tmp / "latin1.csv"
    latin.write_bytes("field_mT,tilt_deg\n# B in mT, tilt in \u00b0\n3,0\n5,0\n".encode("latin-1"))
    out.append(("not UTF-8", latin, "latin1.csv, line 2: not UTF-8 text"))
    fifo = tmp / "fifo.csv"
    os.mkfifo(fifo)
    out.append(("fifo", fifo, "is not a regular file"))
    out.append(("directory", tmp, "is not a regular file"))
    out.append(("/dev/zero", Path("/dev/zero"), "is not a regular file"))
    big = tmp / "big.csv"
    with open(big, "wb") as fh:
        fh.truncate(2**30)
    out.append(("1 GiB", big, "bytes (allowed: at most"))
    return out


def _bad_arguments(good: Path) -> list[tuple[str, list[str], str]]:
    """(name, calibrate argv after the data file, words of the message)."""
    free = ["--free", "F_elect,offset_deg"]
    return [
        ("--set mu=abc", [*free, "--set", "mu=abc"], "mu='abc' is not a number"),
        ("--set mass=1e-30", [*free, "--set", "mass=1e-30"], "mass=1e-30 is implausible"),
        ("--bounds inf", [*free, "--bounds", "F_elect=0:inf"], "bounds of F_elect = (0, inf) are not finite"),
        ("--bounds nan", [*free, "--bounds", "F_elect=nan:1"], "are not finite"),
        ("--bounds implausible", [*free, "--bounds", "F_elect=0:5"], "leave the plausible range"),
        ("--bounds reversed", [*free, "--bounds", "F_elect=1e-5:1e-6"], "are empty"),
        ("--bounds junk", [*free, "--bounds", "F_elect"], "is not NAME=LO:HI"),
        ("--set on a free parameter", [*free, "--set", "F_elect=1e-6"], "F_elect is both free and fixed"),
        ("--samples 0", [*free, "--samples", "0"], "samples=0 is not allowed"),
        ("--samples 1e8", [*free, "--samples", "100000000"], "samples=100000000 is not allowed"),
        ("--noise-sd negative", [*free, "--noise-sd", "-1"], "noise_sd=-1.0 is not allowed"),
        ("--noise-sd nan", [*free, "--noise-sd", "nan"], "noise_sd=nan is not allowed"),
        ("--noise-sd with Laplace", [*free, "--noise-sd", "1", "--posterior", "laplace"], "noise_sd=1.0 is not allowed"),
        ("--free unknown", ["--free", "mass_kg"], "'mass_kg' is not a numeric Params field"),
        ("--free empty", ["--free", ","], "names no parameter"),
        ("--direction zero", [*free, "--direction", "0,0,0"], "direction=(0.0, 0.0, 0.0) is not allowed"),
    ]


def test_thirty_malformed_bench_files_and_argument_sets(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    files = _bench_files(tmp_path)
    good = tmp_path / "good.csv"
    good.write_text(GOOD_TILT, encoding="utf-8")
    args = _bad_arguments(good)
    assert len(files) + len(args) >= 30
    cases = [(n, ["calibrate", "static-tilt", str(f), "--free", "F_elect"], w) for n, f, w in files]
    cases += [(n, ["calibrate", "static-tilt", str(good), *a], w) for n, a, w in args]
    for name, argv, words in cases:
        capsys.readouterr()
        t0 = time.perf_counter()
        rc = main([*argv, "--out", str(tmp_path / "out.nc")])
        err = capsys.readouterr().err.strip()
        assert rc == 2, (name, err)
        one_line(err)
        assert err.startswith("error: ") and words in err, (name, err)
        assert time.perf_counter() - t0 < 10.0, name
    assert not (tmp_path / "out.nc").exists()


def test_calibrate_prints_units_and_what_the_diagnostics_mean(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "t.csv"
    from tumblemc.lab import protocols as lab

    fields = np.arange(3.0, 16.0)
    truth = {"F_elect": 2.5e-6, "offset_deg": 22.0, "adhesion_C": 3.0}
    tilt = np.array([lab.cuboid_tilt_balance(b, "paper", **truth) for b in fields]) + np.random.default_rng(1).normal(0, 0.3, fields.size)
    C.write_bench(f, "field_mT", "tilt_deg", fields, np.abs(tilt))
    assert (
        main(["calibrate", "static-tilt", str(f), "--free", "F_elect,offset_deg", "--samples", "300", "--out", str(tmp_path / "c.nc")]) == 0
    )
    out = capsys.readouterr().out
    assert "rms residual " in out and " deg (data minus the fit" in out
    assert "condition number " in out and "(of J^T J, the fit's Jacobian in the sampling scale; dimensionless): " in out
    assert "the simulator at the estimate differs from the closed form by " in out and "of the noise sd" in out
    assert "it does not matter" in out or "it matters" in out


# -- simulate ------------------------------------------------------------------------------


def _bad_simulate_calls() -> list[tuple[str, dict[str, Any]]]:
    out: list[tuple[str, dict[str, Any]]] = []
    for p in NUMERIC_FIELDS:  # 14 fields x 4 values
        r = RANGES[p]
        top = min(r.hi, r.plausible_hi)
        beyond = 1e300 if not math.isfinite(r.hi) else r.hi * 10 + 1
        out += [(f"{p}=nan", {p: math.nan}), (f"{p}=beyond", {p: beyond}), (f"{p}='1'", {p: "1"}), (f"{p}=-1e300", {p: -1e300})]
        if top < r.hi:
            out.append((f"{p} above plausible", {p: top * 10}))
        if r.plausible_lo > r.lo:
            out.append((f"{p} below plausible", {p: r.plausible_lo / 10}))
    out += [
        ("mass 1e-30", {"mass": 1e-30}),
        ("magnetization 1e30", {"magnetization": 1e30}),
        ("omega0 1e9", {"omega0": (1e9, 0.0, 0.0)}),
        ("omega0 nan", {"omega0": (math.nan, 0.0, 0.0)}),
        ("omega0 2-vector", {"omega0": (1.0, 0.0)}),
        ("v0 100 m/s", {"v0": (0.0, 100.0, 0.0)}),
        ("field 1e6 mT", {"field_mT": 1e6}),
        ("field 2 T", {"field_mT": 2000.0}),
        ("field -1", {"field_mT": -1.0}),
        ("freq 1e9", {"freq_hz": 1e9}),
        ("freq -1", {"freq_hz": -1.0}),
        ("solver fast", {"solver": "fast"}),
        ("dt 0", {"dt": 0.0}),
        ("dt 1", {"dt": 1.0}),
        ("duration -1", {"duration_s": -1.0}),
        ("duration 1e9", {"duration_s": 1e9}),
        ("record_every 0", {"record_every": 0}),
        ("strong magnet on a light body", {"mass": 1e-12, "V_m": 1e-6, "magnetization": 2e6}),
        ("lift 10 m", {"lift_m": 10.0}),
        ("torque sideways", {"torque": "sideways"}),
        ("unknown parameter", {"mass_kg": 1.0}),
    ]
    return out


def test_seventy_five_bad_simulate_calls_are_refused_in_one_line() -> None:
    cases = _bad_simulate_calls()
    assert len(cases) >= 75
    for name, kw in cases:
        t0 = time.perf_counter()
        with pytest.raises(ValueError) as err:
            run_inputs(**kw)
        one_line(str(err.value))
        assert time.perf_counter() - t0 < 1.0, name


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--set", "mass=1e-30"], "mass=1e-30 is implausible (allowed: a number in [1e-12, 1] kg;"),
        (["--set", "magnetization=1e30"], "no material saturates above 1.95e6 A/m"),
        (["--field-mT", "5000"], "1 T is beyond any coil"),
        (["--set", "mu=abc"], "mu='abc' is not a number"),
        (["--freq-hz", "-1"], "freq_hz=-1.0 is out of range"),
    ],
)
def test_cli_simulate_refuses_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], words: str) -> None:
    assert main(["simulate", *argv, "--out", str(tmp_path / "r.nc")]) == 2
    err = capsys.readouterr().err.strip()
    one_line(err)
    assert words in err, err
    assert not (tmp_path / "r.nc").exists()


def test_cli_simulate_refuses_a_run_over_its_wall_budget_and_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r.nc"
    assert main(["simulate", "--duration-s", "1", "--max-wall-s", "0.001", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    one_line(err)
    assert err.startswith("error: max_wall_s=0.001: this run could take") and "20,000 steps of dt=5e-05 s" in err, err
    assert not out.exists()


def test_degenerate_runs_are_valid_and_said() -> None:
    assert run_notes(run_inputs(duration_s=0.01)) == []
    notes = run_notes(run_inputs(duration_s=0.01, field_mT=0.0))
    assert len(notes) == 1 and "the field is off" in notes[0]
    assert "does not turn" in run_notes(run_inputs(duration_s=0.01, freq_hz=0.0))[0]
    assert "the magnetic moment is zero" in run_notes(run_inputs(duration_s=0.01, V_m=0.0))[0]


def test_the_presets_and_a_given_solver_pass() -> None:
    from tumblemc.model.solver_options import SolverOptions

    for p in PRESETS:
        run_inputs(preset=p, duration_s=0.01, solver=SolverOptions())


#: plausible extremes (each alone at a bound of RANGES), with durations that keep the slow tier short
EXTREMES: list[dict[str, Any]] = [
    {"mass": 1e-12, "duration_s": 2e-3},
    {"mass": 1.0},
    {"F_elect": 1.0},
    {"mu": 100.0},
    {"mu": 0.0},
    {"adhesion_C": 1e6},
    {"g": 0.01},
    {"g": 1000.0},
    {"field_mT": 1000.0},
    {"freq_hz": 10_000.0, "duration_s": 2e-3},
    {"omega0": (1e5, 0.0, 0.0), "duration_s": 5e-3},
    {"v0": (0.0, 1.0, 0.0)},
    {"e_t": 1e-3},
    {"e_o": 1e3},
    {"e_r": 1e-9},
    {"magnetization": 2e6},
    {"V_m": 1e-6, "duration_s": 0.02},
]


@pytest.mark.slow
@pytest.mark.parametrize("kw", EXTREMES, ids=lambda kw: ",".join(kw))
def test_accepted_extremes_finish_or_are_refused_within_ten_seconds(kw: dict[str, Any]) -> None:
    kw = {"duration_s": 0.2, **kw}
    t0 = time.perf_counter()
    try:
        ds = simulate(**kw)
    except ValueError as exc:  # refused: one line, at once
        one_line(str(exc))
    else:
        assert ds.sizes["time"] >= 2 and "status" in ds.attrs
    assert time.perf_counter() - t0 < 10.0


#: plausible extremes at their default duration (2 s) and step: up to five million steps;
#: the wall-time guard (tumblemc.model.cost) refuses those that would take long
LONG_EXTREMES: list[dict[str, Any]] = [
    {"mass": 1e-12},  # default step 3.8e-7 s: 5.2 million steps
    {"mass": 1e-12, "dt": 5e-5},  # 40,000 steps of a stiff contact solve, 14-35 ms each
    {"magnetization": 2e6, "field_mT": 1000.0},  # 1.1 million steps
    {"omega0": (1e5, 0.0, 0.0)},  # 680,000 steps, a first step of 0.5 s
    {"V_m": 1e-6},  # 2.4 million steps
]


@pytest.mark.slow
@pytest.mark.parametrize("kw", LONG_EXTREMES, ids=lambda kw: ",".join(kw))
def test_long_extremes_finish_or_are_refused_within_ten_seconds_under_a_small_budget(kw: dict[str, Any]) -> None:
    t0 = time.perf_counter()
    try:
        ds = simulate(**kw, max_wall_s=2.0)
    except ValueError as exc:
        one_line(str(exc))
        assert str(exc).startswith("max_wall_s=2: this run could take"), exc
    else:
        assert ds.attrs["n_steps"] > 20_000
    assert time.perf_counter() - t0 < 10.0


@pytest.mark.slow
@pytest.mark.parametrize("kw", LONG_EXTREMES[:2], ids=lambda kw: ",".join(kw))
def test_the_lightest_robot_is_refused_under_the_default_budget(kw: dict[str, Any]) -> None:
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=r"^max_wall_s=600: this run could take [\d,]+ s of wall time \("):
        simulate(**kw)
    assert time.perf_counter() - t0 < 10.0
