"""The outputs of a run: summary, tables and arrays of its output directory."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path
from typing import Any, Dict, List, Optional

import numpy as np

from ._tables import Columns

# an integer as the tables write one (floats always have a point, an exponent, inf or NaN)
_INTEGER = re.compile(r"^[+-]?[0-9]+$")


def read_table(path: Path) -> Columns:
    """A CSV file with a header row as columns: int64 where every value is an integer (written
    without a point or exponent, e.g. ``seed``, ``grains``), float64 where every value is a
    number (an empty field is NaN), str otherwise (and for a column with no value at all). The
    result is a dict with ``to_pandas()`` and ``records()``."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    if not rows:
        return Columns()
    header, body = rows[0], rows[1:]
    columns = Columns()
    for k, name in enumerate(header):
        raw = [r[k] if k < len(r) else "" for r in body]
        if body and all(x == "" for x in raw):
            # no value at all (e.g. the `failure` column of a run where nothing failed): text
            columns[name] = np.asarray(raw, dtype=str)
            continue
        if body and all(_INTEGER.match(x) for x in raw):
            try:
                columns[name] = np.asarray([int(x) for x in raw], dtype=np.int64)
                continue
            except OverflowError:
                pass  # beyond int64: as floats below
        try:
            values = [float(x) if x != "" else math.nan for x in raw]
            columns[name] = np.asarray(values, dtype=np.float64)
        except ValueError:
            columns[name] = np.asarray(raw, dtype=str)
    return columns


class Result:
    """A finished run (or any output directory): ``summary`` (the report, ``summary.json``, as a
    dict), ``tables`` (every CSV file as a dict of NumPy columns, keyed by its path relative to
    ``out`` without ``.csv``), ``arrays`` (every ``.npz`` file as a dict of arrays), ``out``."""

    def __init__(self, out: Path, summary: Dict[str, Any], lines: Optional[List[str]] = None):
        self.out = Path(out)
        self.summary = summary
        self.lines = list(lines or [])
        self._tables: Optional[Dict[str, Dict[str, np.ndarray]]] = None
        self._arrays: Optional[Dict[str, Dict[str, np.ndarray]]] = None

    @classmethod
    def from_dir(cls, out) -> "Result":
        """The result of the run whose output directory is ``out`` (its ``summary.json``)."""
        out = Path(out)
        path = out / "summary.json"
        if not out.exists():
            from ._errors import path_not_found

            raise path_not_found(out, f"`{out}` does not exist (give the output directory of a finished run)")
        if not path.is_file():
            raise ValueError(f"`{out}` holds no summary.json (not a finished run's output directory)")
        with open(path, encoding="utf-8") as f:
            return cls(out, json.load(f))

    @property
    def files(self) -> List[str]:
        """Every file of the output directory, relative to it."""
        return sorted(str(p.relative_to(self.out)) for p in self.out.rglob("*") if p.is_file() and not p.name.startswith("."))

    @property
    def tables(self) -> Dict[str, Columns]:
        if self._tables is None:
            self._tables = {
                str(p.relative_to(self.out).with_suffix("")): read_table(p) for p in sorted(self.out.rglob("*.csv"))
            }
        return self._tables

    @property
    def arrays(self) -> Dict[str, Dict[str, np.ndarray]]:
        if self._arrays is None:
            out = {}
            for p in sorted(self.out.rglob("*.npz")):
                with np.load(p) as z:
                    out[str(p.relative_to(self.out).with_suffix(""))] = {k: z[k] for k in z.files}
            self._arrays = out
        return self._arrays

    def __repr__(self) -> str:
        what = self.summary.get("experiment", "run") if isinstance(self.summary, dict) else "run"
        return f"<grainwave.Result {what} in {self.out}>"
