"""Progress display: the events of a run (dicts with a ``kind``) to a callback, a tqdm bar or
lines on stderr."""

from __future__ import annotations

import sys
import time
from typing import Any, Callable, Dict, Optional, Tuple

Event = Dict[str, Any]


class _Lines:
    """Progress as lines on stderr (when tqdm is not installed), at most one step line per 2 s."""

    def __init__(self) -> None:
        self._last = 0.0

    def __call__(self, ev: Event) -> None:
        kind = ev["kind"]
        if kind == "stage":
            print(f"grainwave: {ev['name']}", file=sys.stderr)
        elif kind == "units":
            print(f"grainwave: {ev['done']}/{ev['total']} units done", file=sys.stderr)
        elif kind == "message":
            print(f"grainwave: {ev['text']}", file=sys.stderr)
        elif kind == "progress" and time.monotonic() - self._last > 2.0:
            self._last = time.monotonic()
            print(f"grainwave:   step {ev['step']}  t {ev['time']:.4e}  KE/grain {ev['kinetic_energy_per_grain']:.2e}  contacts {ev['contacts']}", file=sys.stderr)

    def close(self) -> None:
        pass


class _Tqdm:
    """A bar of units of work (samples, replays…), named after the current stage, and a bar of
    the steps of the current stage, opened at its first step report (a study whose stage only
    counts units — an E1 ensemble — shows no step bar stuck at 0)."""

    def __init__(self, tqdm) -> None:
        self._tqdm = tqdm
        self._steps = None
        self._units = None
        self._stage: Event = {}

    def __call__(self, ev: Event) -> None:
        kind = ev["kind"]
        if kind == "stage":
            if self._steps is not None:
                self._steps.close()
                self._steps = None
            self._stage = ev
            if self._units is not None:
                self._units.set_description(ev["name"], refresh=False)
        elif kind == "progress":
            if self._steps is None:
                # `first_step`: a simulation's run_until/step starts from its current step count
                first = self._stage.get("first_step") or 0
                total = self._stage.get("total_steps")
                self._first = first
                self._steps = self._tqdm(
                    total=None if total is None else total - first,
                    desc=self._stage.get("name", "steps"),
                    unit="step",
                    leave=False,
                    dynamic_ncols=True,
                )
            # update() redraws at most every `mininterval` (0.1 s): step reports can come every step
            self._steps.set_postfix(KE=f"{ev['kinetic_energy_per_grain']:.2e}", contacts=ev["contacts"], refresh=False)
            self._steps.update(ev["step"] - self._first - self._steps.n)
        elif kind == "units":
            if self._units is None:
                self._units = self._tqdm(total=ev["total"], desc=self._stage.get("name", "units"), unit="unit", dynamic_ncols=True)
            self._units.total = ev["total"]
            self._units.update(ev["done"] - self._units.n)
        elif kind == "message":
            self._tqdm.write(f"grainwave: {ev['text']}")

    def close(self) -> None:
        for bar in (self._steps, self._units):
            if bar is not None:
                bar.close()


def make(progress: Any) -> Tuple[Optional[Callable[[Event], None]], Callable[[], None]]:
    """``(callback, close)`` for ``progress``: None/False (nothing), True (a tqdm bar when tqdm
    is installed, else lines on stderr) or a callable receiving each event."""
    if progress is None or progress is False:
        return None, lambda: None
    if progress is True:
        try:
            from tqdm.auto import tqdm
        except ImportError:
            shown = _Lines()
        else:
            shown = _Tqdm(tqdm)
        return shown, shown.close
    if callable(progress):
        return progress, lambda: None
    raise TypeError(f"progress: None, True or a callable expected, {type(progress).__name__} given")
