"""The design search (``tumblemc design run``): rounds of proposals, staged evaluation, early stops, the recommendation.

1. Round 0 evaluates ``initial`` designs of a Sobol set; every later round ``batch``
   designs proposed by the strategy (:mod:`tumblemc.design.strategies`) from everything
   measured so far.
2. A round's designs are evaluated stage by stage (``stage`` robots each, the same robots
   for every design: common random numbers, :mod:`tumblemc.design.evaluate`). After each
   stage, with one objective of 0/1 values (P(climb)), each design is compared with the
   incumbent (the design with the best estimate on the same robots) robot by robot: on
   the robots where the two differ (the discordant pairs, McNemar's view), the incumbent
   wins each with a probability ``q``, and ``q > 1/2`` exactly when the incumbent's P is
   higher. The beta-binomial confidence sequence of the adaptive studies
   (:func:`tumblemc.analysis.confseq.cs_interval`) on those wins is valid at every stage,
   however often it is looked at; a design is stopped once its lower end exceeds 1/2: it is
   worse than the incumbent at the stated level, whatever its remaining robots do. Pairing
   is what makes this bite: neighbouring designs differ on few robots.
3. Rounds continue while the budget (simulations) allows another round and the
   confirmation.
4. The recommendation is the design the model believes best (:func:`model_best`) among
   those meeting the constraints; it is re-estimated on ``confirm`` fresh robots, and that
   estimate is the one reported. With several objectives the result holds the Pareto set
   of the estimates (no single recommendation).

State lives in ``<out>.parts/``: ``journal.json`` (the config hash and every design
proposed, written before it is simulated) and one ``.npz`` per finished chunk, written
atomically. A search killed at any point (``kill -9`` included) resumes from there: the
stopping decisions and proposals are deterministic functions of the stored results, so
the resumed search is the uninterrupted one.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
from collections.abc import Callable, Iterable, Iterator
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np

from tumblemc.analysis.confseq import cs_interval
from tumblemc.design.config import DesignConfig
from tumblemc.design.evaluate import FRESH, SEARCH, Chunk, Estimate, estimate, execute
from tumblemc.design.strategies import initial, model_best, propose, require
from tumblemc.io import StudyStateError
from tumblemc.study.lock import StudyLock

SCHEME = "tumblemc-design-1"


def config_dict(cfg: DesignConfig) -> dict[str, Any]:
    """The problem as plain data: the TOML text left out, the posterior by its file and sha256 (not its draws)."""
    d = asdict(cfg)
    d.pop("source", None)
    d["posterior"] = cfg.posterior.to_dict() if cfg.posterior is not None else None
    return d


def config_hash(cfg: DesignConfig) -> str:
    """Identity of a design problem: sha256 of :func:`config_dict`'s canonical JSON."""
    return hashlib.sha256(json.dumps([SCHEME, config_dict(cfg)], sort_keys=True, default=str).encode()).hexdigest()[:16]


class DesignStore:
    """The parts folder of a search: the journal of designs and the finished chunks."""

    def __init__(self, out: Path, cfg: DesignConfig) -> None:
        self.dir = out.with_name(out.name + ".parts")
        self.hash = config_hash(cfg)
        self.journal = self.dir / "journal.json"

    def open(self, fresh: bool) -> None:
        """Create the folder (emptied when ``fresh``); refuse the parts of another problem."""
        if fresh and self.dir.exists():
            for f in self.dir.iterdir():
                f.unlink()
        self.dir.mkdir(parents=True, exist_ok=True)
        if self.journal.exists():
            j = json.loads(self.journal.read_text())
            if j.get("config_hash") != self.hash:
                raise StudyStateError(
                    f"{self.dir} holds a search of another design problem (config hash {j.get('config_hash')}, this one {self.hash}); "
                    "give another --out, or --fresh to discard it"
                )

    def designs(self) -> list[dict[str, Any]]:
        """The journal's designs, in the order proposed."""
        return list(json.loads(self.journal.read_text())["designs"]) if self.journal.exists() else []

    def add_designs(self, rows: list[dict[str, Any]]) -> None:
        """Append designs to the journal (atomically, before they are simulated)."""
        j = {"config_hash": self.hash, "designs": self.designs() + rows}
        tmp = self.journal.with_suffix(".tmp")
        tmp.write_text(json.dumps(j))
        os.replace(tmp, self.journal)

    def path(self, key: str) -> Path:
        """The file of chunk ``key``."""
        return self.dir / f"{key}.npz"

    def load(self, key: str) -> dict[str, np.ndarray] | None:
        """Chunk ``key``'s stored result (None: not done, or damaged and removed)."""
        p = self.path(key)
        if not p.exists():
            return None
        try:
            with np.load(p, allow_pickle=False) as z:
                return {k: z[k] for k in z.files}
        except (OSError, ValueError, EOFError):  # a damaged chunk is simulated again
            p.unlink(missing_ok=True)
            return None

    def save(self, key: str, res: dict[str, np.ndarray]) -> None:
        """Store chunk ``key``'s result atomically (written, synced, renamed)."""
        tmp = self.dir / f"{key}.tmp.npz"
        arrays: dict[str, Any] = {k: (v.astype(str) if v.dtype == object else v) for k, v in res.items()}  # no pickles
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, self.path(key))

    def remove(self) -> None:
        """Remove the parts folder (after the result is written)."""
        if self.dir.exists():
            for f in self.dir.iterdir():
                f.unlink()
            self.dir.rmdir()


#: runs chunks and yields each with its result, in any order
Runner = Callable[[list[Chunk]], Iterator[tuple[Chunk, dict[str, np.ndarray]]]]


def _executor(client: Any) -> Runner:
    def serial(chunks: list[Chunk]) -> Iterator[tuple[Chunk, dict[str, np.ndarray]]]:
        for c in chunks:
            yield c, execute(c)

    def distributed(chunks: list[Chunk]) -> Iterator[tuple[Chunk, dict[str, np.ndarray]]]:
        from distributed import as_completed

        futs = {client.submit(execute, c, key=c.key + f"-{id(c)}", retries=3, pure=False): c for c in chunks}
        try:
            for f in as_completed(futs):
                yield futs[f], f.result()
        finally:
            client.cancel([f for f in futs if not f.done()])

    return serial if client is None else distributed


class Search:
    """The state of one search: designs, each design's robots' values per objective, simulations used."""

    def __init__(self, cfg: DesignConfig, store: DesignStore, client: Any = None, bar: Any = None, runner: Runner | None = None) -> None:
        self.cfg = cfg
        self.store = store
        self.run = runner or _executor(client)
        self.bar = bar
        self.designs: list[dict[str, Any]] = store.designs()
        self.values: dict[tuple[int, int, int], np.ndarray] = {}  # (design, task, stream) -> values in robot order
        self.nsim = 0
        self.stopped: dict[int, int] = {}  # design -> robots it was stopped at
        self.chunks: dict[str, tuple[Chunk, dict[str, np.ndarray]]] = {}

    # -- evaluation -----------------------------------------------------------------
    def _x(self, i: int) -> tuple[tuple[str, float], ...]:
        return tuple(sorted(self.designs[i]["x"].items()))

    def evaluate(self, ids: Iterable[int], samples: range, stream: int) -> None:
        """Robots ``samples`` of designs ``ids`` on every objective (stored chunks are read, not simulated)."""
        chunks = [Chunk(i, self._x(i), t, tuple(samples), stream, self.cfg) for i in ids for t in range(len(self.cfg.tasks))]
        todo = []
        for c in chunks:
            r = self.store.load(c.key)
            if r is None:
                todo.append(c)
            else:
                self._take(c, r, fresh=False)
        for c, r in self.run(todo):
            self.store.save(c.key, r)
            self._take(c, r, fresh=True)

    def _take(self, c: Chunk, r: dict[str, np.ndarray], fresh: bool) -> None:
        k = (c.design, c.task, c.stream)
        self.values[k] = np.concatenate([self.values.get(k, np.zeros(0)), r["value"]])
        n = int(r["n_sim"].sum())
        self.nsim += n
        self.chunks[c.key] = (c, r)
        if fresh and self.bar is not None:
            self.bar.update(n)

    def est(self, i: int, t: int, stream: int = SEARCH) -> Estimate:
        """Design ``i``'s estimate on task ``t`` from its robots of ``stream``."""
        return estimate(self.cfg.tasks[t], self.values.get((i, t, stream), np.zeros(0)), self.cfg.level)

    # -- early stopping -------------------------------------------------------------
    def _stop_check(self, active: list[int]) -> list[int]:
        """The active designs not yet decisively worse than the incumbent (paired, anytime-valid; module docstring)."""
        cfg = self.cfg
        obj = cfg.objectives[0]
        if not (cfg.early_stop and len(cfg.objectives) == 1 and obj.binary):
            return active
        sign = 1.0 if obj.goal == "max" else -1.0
        vals = {i: v for i in range(len(self.designs)) if len(v := self.values.get((i, 0, SEARCH), np.zeros(0)))}
        keep = []
        for d in active:
            n = len(vals[d])
            peers = [i for i, v in vals.items() if i != d and len(v) >= n]
            if not peers:
                keep.append(d)
                continue
            b = max(peers, key=lambda i: (sign * float(np.nanmean(vals[i][:n])), -i))  # the incumbent on d's robots
            xb, xd = sign * vals[b][:n], sign * vals[d][:n]
            ok = ~np.isnan(xb) & ~np.isnan(xd)
            wins, discordant = int(np.sum(xb[ok] > xd[ok])), int(np.sum(xb[ok] != xd[ok]))
            lo, _ = cs_interval(wins, discordant, cfg.level)
            if discordant and float(lo) > 0.5:
                self.stopped[d] = n
            else:
                keep.append(d)
        return keep

    def evaluate_round(self, ids: list[int]) -> None:
        """Evaluate designs ``ids`` stage by stage, stopping the decisively worse ones between stages."""
        active = list(ids)
        for s0 in range(0, self.cfg.samples, self.cfg.stage):
            if not active:
                break
            self.evaluate(active, range(s0, s0 + self.cfg.stage), SEARCH)
            if s0 + self.cfg.stage < self.cfg.samples:
                active = self._stop_check(active)

    # -- the model's view -------------------------------------------------------------
    def matrix(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit-box designs, estimates oriented larger-is-better, and their noise variances (designs x objectives)."""
        cfg = self.cfg
        X = np.array([[(d["x"][v.name] - v.lo) / (v.hi - v.lo) for v in cfg.variables] for d in self.designs])
        Y = np.full((len(self.designs), len(cfg.objectives)), np.nan)
        V = np.full_like(Y, np.nan)
        for i in range(len(self.designs)):
            for t, o in enumerate(cfg.objectives):
                e = self.est(i, t)
                if e.n and math.isfinite(e.value):
                    Y[i, t] = e.value if o.goal == "max" else -e.value
                    V[i, t] = e.var
        return X, Y, V

    def feasible(self, stream: int = SEARCH) -> np.ndarray:
        """Designs whose estimates meet every constraint."""
        out = np.ones(len(self.designs), dtype=bool)
        for t, c in enumerate(self.cfg.tasks):
            if c.bound is None:
                continue
            for i in range(len(self.designs)):
                e = self.est(i, t, stream)
                ok = math.isfinite(e.value) and (e.value >= c.bound if c.sense == "min" else e.value <= c.bound)
                out[i] &= ok
        return out

    def cost_per_design(self) -> float:
        """Simulations a fully evaluated design takes (observed; 1 per robot and objective before any)."""
        per_robot = 0.0
        for t in range(len(self.cfg.tasks)):
            sims = [int(r["n_sim"].sum()) for c, r in self.chunks.values() if c.task == t]
            robots = [len(r["n_sim"]) for c, r in self.chunks.values() if c.task == t]
            per_robot += (sum(sims) / sum(robots)) if robots else 1.0
        return per_robot * self.cfg.samples

    def add(self, unit: np.ndarray, round_: int) -> list[int]:
        """Journal the designs at unit-box points ``unit`` as round ``round_``; their ids."""
        cfg = self.cfg
        rows: list[dict[str, Any]] = []
        for u in unit:
            x = {v.name: float(v.lo + float(np.clip(c, 0, 1)) * (v.hi - v.lo)) for v, c in zip(cfg.variables, u, strict=True)}
            rows.append({"id": len(self.designs) + len(rows), "x": x, "round": round_})
        self.store.add_designs(rows)
        self.designs += rows
        return [r["id"] for r in rows]


def search(
    cfg: DesignConfig, out: Path, client: Any = None, fresh: bool = False, progress: bool = True, runner: Runner | None = None
) -> Path:
    """Run (or resume) the design search of ``cfg`` and write ``out`` (netCDF, :mod:`tumblemc.design.result`).

    ``client``: a dask client (None: in this process). ``runner``: replaces the simulator
    (a function of chunks yielding ``(chunk, result)``; the campaign's emulator of a
    precomputed grid of designs, and tests).
    """
    from tumblemc.design.result import write_result
    from tumblemc.study.progress import Progress

    out = Path(out)
    require(cfg.strategy)
    with StudyLock(out):
        store = DesignStore(out, cfg)
        if out.exists() and not fresh and not store.dir.exists():
            import xarray as xr

            with xr.open_datatree(out, engine="netcdf4") as done:
                theirs = done.attrs.get("config_hash")
            if theirs != store.hash:
                raise StudyStateError(f"{out} holds another design problem's result (config hash {theirs}); give another --out, or --fresh")
            if progress:
                print(f"{out} is complete; nothing to do (--fresh to search again)", file=sys.stderr)
            return out
        store.open(fresh)
        bar = Progress(cfg.budget, 0, enabled=progress)
        s = Search(cfg, store, client, bar, runner)
        d = len(cfg.variables)
        confirm_cost = cfg.confirm * len(cfg.tasks) if len(cfg.objectives) == 1 else 0
        if not s.designs:  # as many of the initial designs as the budget allows with the confirmation
            fit = int((cfg.budget - confirm_cost) // s.cost_per_design())
            s.add(initial(d, max(1, min(cfg.initial, fit)), cfg.seed), 0)
        rounds = sorted({int(r["round"]) for r in s.designs})
        for r in rounds:  # replay: stored chunks are read, unfinished ones simulated
            s.evaluate_round([x["id"] for x in s.designs if x["round"] == r])
        r = rounds[-1]
        while True:
            left = cfg.budget - s.nsim - confirm_cost * s.cost_per_design() / (cfg.samples * len(cfg.tasks))
            n_new = min(cfg.batch, int(left // max(s.cost_per_design(), 1.0)))
            if n_new < 1:
                break
            r += 1
            X, Y, V = s.matrix()
            ids = s.add(propose(cfg.strategy, X, Y, V, n_new, cfg.seed * 1009 + r, len(s.designs)), r)
            s.evaluate_round(ids)
        rec, means = None, None
        if len(cfg.objectives) == 1:
            X, Y, V = s.matrix()
            feasible = s.feasible()
            _, means = model_best(X, Y[:, 0], V[:, 0], cfg.seed)
            rec = int(np.argmax(np.where(feasible, means, -np.inf))) if feasible.any() else None
            if rec is not None and cfg.confirm:
                s.evaluate([rec], range(cfg.confirm), FRESH)
        bar.close()
        write_result(out, s, rec, means)
        store.remove()
    if progress:
        print(f"wrote {out} ({len(s.designs)} designs, {s.nsim} simulations)", file=sys.stderr)
    return out


__all__ = ["DesignStore", "Search", "config_dict", "config_hash", "search"]
