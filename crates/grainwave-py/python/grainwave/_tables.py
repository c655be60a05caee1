"""Columns of a table (a CSV of a run's output directory, the contact records of a simulation)
as a dict of NumPy arrays, with the flat forms other tools take: :meth:`Columns.records` (a NumPy
structured array) and :meth:`Columns.to_pandas` (a ``pandas.DataFrame``; pandas is optional).

A column of shape (m, k) — a vector per row, e.g. the contact normals — becomes k flat columns
``name_x``, ``name_y`` (, ``name_z``) in both forms; the dict itself keeps it whole.
"""

from __future__ import annotations

from typing import Dict, List, Tuple

import numpy as np

_AXES = "xyz"


class Columns(dict):
    """A dict ``{column name: array}`` whose arrays have one entry per row."""

    def _flat(self) -> List[Tuple[str, np.ndarray]]:
        out: List[Tuple[str, np.ndarray]] = []
        rows = None
        for name, values in self.items():
            a = np.asarray(values)
            if a.ndim == 0:
                raise ValueError(f"column `{name}` is a scalar (allowed: one entry per row)")
            if rows is None:
                rows = a.shape[0]
            elif a.shape[0] != rows:
                raise ValueError(f"column `{name}` has {a.shape[0]} rows, the columns before it {rows} (allowed: the same number of rows)")
            if a.ndim == 1:
                out.append((name, a))
            elif a.ndim == 2:
                for k in range(a.shape[1]):
                    suffix = _AXES[k] if a.shape[1] <= 3 else str(k)
                    out.append((f"{name}_{suffix}", a[:, k]))
            else:
                raise ValueError(f"column `{name}` has shape {a.shape} (allowed: one value or one vector per row)")
        return out

    def records(self) -> np.ndarray:
        """The rows as a NumPy structured array (one field per flat column, dtypes kept)."""
        flat = self._flat()
        rows = flat[0][1].shape[0] if flat else 0
        out = np.empty(rows, dtype=[(name, a.dtype) for name, a in flat])
        for name, a in flat:
            out[name] = a
        return out

    def to_pandas(self):
        """The rows as a ``pandas.DataFrame`` (vector columns split into ``name_x``, ``name_y``…;
        dtypes kept). Needs pandas (``pip install pandas``)."""
        try:
            import pandas as pd
        except ImportError as e:
            raise ImportError("to_pandas() needs pandas, which is not installed (pip install pandas); records() gives the same rows as a NumPy structured array") from e
        return pd.DataFrame(dict(self._flat()))


def columns(d: Dict[str, np.ndarray]) -> Columns:
    """``d`` as :class:`Columns`."""
    return Columns(d)
