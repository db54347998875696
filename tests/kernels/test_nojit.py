"""The kernels with the JIT off: the same records as compiled, and their line coverage.

``tools/kernel_coverage.py`` runs its short runs with ``NUMBA_DISABLE_JIT=1`` (in a
subprocess: the JIT setting is read at import) and traces the kernel lines they execute.
The interpreter runs the same source in float64 with the same operations in the same order;
only the elementary functions differ (Python's own ``math.hypot``, the C library's in
compiled code), by an ulp now and then, and such an ulp can end a Newton solve at another
iterate within the tolerance. So the records agree to the solver's tolerance (measured: at
most 5e-8 of each variable's largest value over these runs), not bit for bit: a larger difference
means the compiled code does not compute what its source says (fastmath, a contraction, a
Numba bug).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.tooling import load_tool

ROOT = Path(__file__).resolve().parents[2]
DURATION_S = 0.03
#: interpreter and compiled records agree to this fraction of each variable's largest value
REL = 1e-6
#: rounding-level quantities by nature (the Newton residual left at convergence, the
#: penetration left by it, the ledger's balance: a difference of terms 1e10 times larger),
#: compared only for NaN and shape
ROUNDING_LEVEL = ("residual", "penetration", "energy_balance")
#: the solver's counters (an iterate more or less, see above)
COUNTERS = ("newton_iterations", "fallbacks")
#: total line coverage of the kernels by the tool's runs at DURATION_S; a floor (ratchet,
#: 0.65 when written): a change that stops the runs reaching kernel code fails
COVERAGE_FLOOR = 0.6


@pytest.mark.slow
def test_kernels_without_jit_agree_with_the_compiled_kernels_and_cover_the_time_loop(tmp_path: Path) -> None:
    cov_json, rec_npz = tmp_path / "cov.json", tmp_path / "records.npz"
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1", "PYTHONPATH": str(ROOT)}
    tool = ROOT / "tools" / "kernel_coverage.py"
    cmd = [sys.executable, str(tool), "--duration", str(DURATION_S), "--json", str(cov_json), "--records", str(rec_npz)]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stderr[-3000:]
    interpreted = np.load(rec_npz)
    compiled = load_tool("kernel_coverage").records(DURATION_S)
    assert sorted(interpreted.files) == sorted(compiled)
    # a variable's scale over every case (a robot at rest moves 1e-16 m in one of them)
    scales: dict[str, float] = {}
    for key, want in compiled.items():
        var = key.split("/")[1]
        if want.dtype.kind == "f" and np.isfinite(want).any():
            scales[var] = max(scales.get(var, 0.0), float(np.nanmax(np.abs(want))))
    for key, want in compiled.items():
        got = interpreted[key]
        assert got.shape == want.shape, key
        if key.split("/")[1] in COUNTERS:
            continue
        if want.dtype.kind == "f" and key.split("/")[1] in ROUNDING_LEVEL:
            np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=key)
        elif want.dtype.kind == "f" and want.size:
            scale = scales.get(key.split("/")[1], 0.0)
            np.testing.assert_array_equal(np.isnan(got), np.isnan(want), err_msg=key)
            assert np.nanmax(np.abs(got - want), initial=0.0) <= REL * scale, key
        else:
            np.testing.assert_array_equal(got, want, err_msg=key)
    cov = json.loads(cov_json.read_text())
    executed = sum(r["executed"] for r in cov.values())
    lines = sum(r["lines"] for r in cov.values())
    assert executed / lines >= COVERAGE_FLOOR, res.stdout
