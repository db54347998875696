"""Value checkers of study configs.

Each returns the checked value or raises one :class:`ConfigError` naming the key path, the
value and what is allowed.
"""

from __future__ import annotations

import difflib
import math
import stat
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.analysis.confseq import CS_METHODS, first_possible_stop
from tumblemc.model.params import describe_interval


class ConfigError(ValueError):
    """One problem in a study config; ``key`` is its dotted path (``uncertain.mu.rel_sd``)."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key


MAX_GRID_VALUES = 10_001
_INF = math.inf


#: the largest config file read (a grid of 10,001 values per axis is a few hundred kB)
MAX_CONFIG_BYTES = 16 * 2**20


def read_limited(path: Path, limit: int, allowed: str, key: str = "", prefix: str = "") -> bytes:
    """The bytes of ``path`` if it is a regular file of at most ``limit`` bytes, else one :class:`ConfigError`.

    A device (``/dev/zero``) would be read until memory runs out and a FIFO would block, so
    the file's kind and size are checked (``stat``, which never blocks) before it is opened.
    ``allowed`` says what the file should be, ``prefix`` starts the message (default: the path).
    """
    head = prefix or f"{path}: "
    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):
            raise ConfigError(key, f"{head}{path} is not a regular file (allowed: {allowed})")
        if st.st_size > limit:
            raise ConfigError(key, f"{head}{path} has {st.st_size:,} bytes (allowed: at most {limit:,}, {allowed})")
        with open(path, "rb") as fh:
            raw = fh.read(limit + 1)
    except OSError as e:
        raise ConfigError(key, f"{head}cannot read {path} ({e.strerror})") from None
    if len(raw) > limit:  # it grew after stat
        raise ConfigError(key, f"{head}{path} has over {limit:,} bytes (allowed: at most that, {allowed})")
    return raw


def read_config_text(path: Path) -> str:
    """A config file's text (UTF-8); a file that is not names itself, the byte and its line and column."""
    raw = read_limited(path, MAX_CONFIG_BYTES, "a TOML study config")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, e.start) + 1
        col = e.start - (raw.rfind(b"\n", 0, e.start) + 1) + 1
        raise ConfigError(
            "", f"{path}: not UTF-8 text: byte 0x{raw[e.start]:02x} at line {line}, column {col} (save the file as UTF-8)"
        ) from None


def config_error(key: str, value: Any, problem: str, allowed: str) -> ConfigError:
    """Build the :class:`ConfigError` ``"<key>=<value> <problem> (allowed: <allowed>)"``."""
    return ConfigError(key, f"{key}={value!r} {problem} (allowed: {allowed})")


def is_number(value: Any) -> bool:
    """Whether ``value`` is a Python or NumPy int or float (a bool is not)."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def check_num(key: str, value: Any, lo: float = -_INF, hi: float = _INF, lo_open: bool = False, hi_open: bool = False) -> float:
    """Check that ``value`` is a finite number from ``lo`` to ``hi`` and return it as a float.

    ``lo_open``/``hi_open`` exclude the bound itself; ``-0.0`` becomes ``0.0``.
    """
    allowed = describe_interval(lo, hi, lo_open, hi_open)
    if not is_number(value):
        raise config_error(key, value, "is not a number", allowed)
    x = float(value)
    ok = math.isfinite(x) and (x > lo if lo_open else x >= lo) and (x < hi if hi_open else x <= hi)
    if not ok:
        raise config_error(key, value, "is out of range", allowed)
    return x + 0.0  # -0.0 -> 0.0: one canonical zero for hashes


def check_int(key: str, value: Any, lo: int, hi: int) -> int:
    """Check that ``value`` is an integer (not a bool) in ``[lo, hi]`` and return it as an int."""
    allowed = f"an integer in [{lo}, {hi}]"
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)):
        raise config_error(key, value, "is not an integer", allowed)
    if not lo <= int(value) <= hi:
        raise config_error(key, value, "is out of range", allowed)
    return int(value)


def check_str(key: str, value: Any, allowed: str = "a string") -> str:
    """Check that ``value`` is a string and return it."""
    if not isinstance(value, str):
        raise config_error(key, value, "is not a string", allowed)
    return value


def check_choice(key: str, value: Any, choices: Sequence[str]) -> str:
    """Check that ``value`` is one of ``choices`` and return it (the error suggests the closest choice)."""
    allowed = "one of " + ", ".join(repr(c) for c in choices)
    if not isinstance(value, str):
        raise config_error(key, value, "is not a string", allowed)
    if value not in choices:
        close = difflib.get_close_matches(value, choices, n=1)
        hint = f" - did you mean {close[0]!r}?" if close else ""
        raise config_error(key, value, f"is not allowed{hint}", allowed)
    return value


def check_table(key: str, value: Any) -> Mapping[str, Any]:
    """Check that ``value`` is a TOML table (a mapping with string keys) and return it."""
    if not isinstance(value, Mapping):
        raise config_error(key, value, "is not a table", "a TOML table / mapping")
    for k in value:
        if not isinstance(k, str):
            raise config_error(f"{key}.{k}", k, "is not a string key", "string keys")
    return value


def join_key(prefix: str, key: str) -> str:
    """Join a dotted key path: ``prefix.key``, or ``key`` if ``prefix`` is empty."""
    return f"{prefix}.{key}" if prefix else key


def check_no_unknown(table: Mapping[str, Any], allowed: Sequence[str], prefix: str, what: str = "key") -> None:
    """Raise a :class:`ConfigError` for the first key of ``table`` not in ``allowed`` (``what`` names the kind of key)."""
    for k in table:
        if k not in allowed:
            close = difflib.get_close_matches(k, allowed, n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            key = join_key(prefix, k)
            raise ConfigError(key, f"{key} is not a known {what} ({hint}allowed: {', '.join(allowed)})")


def check_required(table: Mapping[str, Any], key: str, prefix: str, allowed: str) -> Any:
    """Return ``table[key]``; a :class:`ConfigError` if it is missing or None."""
    if table.get(key) is None:
        path = join_key(prefix, key)
        raise ConfigError(path, f"{path} is missing (required: {allowed})")
    return table[key]


def check_str_list(key: str, value: Any, choices: Sequence[str], what: str) -> tuple[str, ...]:
    """Check that ``value`` is a non-empty list of distinct names from ``choices`` and return it as a tuple."""
    allowed = f"a non-empty list of distinct {what} names ({', '.join(sorted(choices))})"
    if not isinstance(value, (list, tuple)) or not value:
        raise config_error(key, value, "is not a non-empty list", allowed)
    out = tuple(check_choice(f"{key}[{i}]", v, sorted(choices)) for i, v in enumerate(value))
    if len(set(out)) != len(out):
        raise config_error(key, value, "has duplicates", allowed)
    return out


def check_num_list(key: str, value: Any, lo: float, hi: float, lo_open: bool = False) -> tuple[float, ...]:
    """Check a number or a non-empty list of distinct numbers in the range, and return them as a tuple.

    At most ``MAX_GRID_VALUES`` values; each is checked by :func:`check_num`.
    """
    allowed = f"a number or a non-empty list of distinct numbers, each {describe_interval(lo, hi, lo_open)}"
    if is_number(value):
        return (check_num(key, value, lo, hi, lo_open),)
    if not isinstance(value, (list, tuple)) or not value:
        raise config_error(key, value, "is not a number or a non-empty list", allowed)
    if len(value) > MAX_GRID_VALUES:
        raise config_error(key, f"<{len(value)} values>", "is too long", f"at most {MAX_GRID_VALUES} values")
    out = tuple(check_num(f"{key}[{i}]", v, lo, hi, lo_open) for i, v in enumerate(value))
    if len(set(out)) != len(out):
        raise config_error(key, value, "has duplicates", allowed)
    return out


def check_range_table(key: str, value: Mapping[str, Any], lo: float, hi: float) -> tuple[float, ...]:
    """Expand a ``{start, stop, step}`` table into its values, ``start`` to ``stop`` inclusive.

    At most ``MAX_GRID_VALUES`` values, each rounded to 10 decimals.
    """
    check_no_unknown(value, ("start", "stop", "step"), key)
    start = check_num(f"{key}.start", check_required(value, "start", key, describe_interval(lo, hi)), lo, hi)
    stop = check_num(f"{key}.stop", check_required(value, "stop", key, describe_interval(lo, hi)), lo, hi)
    step = check_num(f"{key}.step", check_required(value, "step", key, "a number > 0"), 0.0, _INF, lo_open=True)
    if stop < start:
        raise config_error(f"{key}.stop", value["stop"], "is below start", f"a number >= start = {start:g}")
    n = math.floor((stop - start) / step + 1e-9) + 1
    if n > MAX_GRID_VALUES:
        raise config_error(f"{key}.step", value["step"], f"gives {n} values", f"at most {MAX_GRID_VALUES} values")
    # rounding makes 0.1-steps land on 0.3, not 0.30000000000000004 (cell ids use repr)
    return tuple(round(start + i * step, 10) + 0.0 for i in range(n))


def check_adaptive(mode: str, sampler: str, ci: str, precision: float, samples: int, level: float) -> None:
    """The config keys ``precision`` needs, checked (a :class:`ConfigError` naming the one that is not)."""
    if mode not in ("grid", "threshold"):
        raise ConfigError(
            "precision", f"precision is for mode = 'grid' or 'threshold' studies, not mode = {mode!r} (allowed: leave precision out)"
        )
    if sampler != "mc":
        raise ConfigError(
            "sampler",
            f"sampler={sampler!r} with precision: the stopping rule needs independent runs whose draws do not depend on "
            "how many are drawn (allowed: 'mc')",
        )
    if ci not in CS_METHODS:
        raise ConfigError(
            "ci",
            f"ci={ci!r} with precision: a fixed-n interval does not cover at a data-dependent stop "
            "(allowed: 'confidence-sequence-ends', the default with precision, or 'confidence-sequence')",
        )
    least = first_possible_stop(precision, level, 10**6, CS_METHODS[ci])
    if samples < least:
        raise ConfigError(
            "samples",
            f"samples={samples} with precision={precision:g}: no cell can reach that precision in fewer than {least} runs "
            f"(the narrowest {level:.0%} interval, every run one verdict), so every cell would run to samples "
            f"(allowed: samples >= {least}, or a larger precision)",
        )
