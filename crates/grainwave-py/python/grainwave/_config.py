"""Configs as the native functions take them: a file path, or TOML text with a name for errors.

A config may be given as a path (``str`` or ``os.PathLike``), as TOML text (a ``str`` holding a
newline or ``=``), or as a ``dict`` (nested dicts are tables, lists of dicts arrays of tables),
which is written as TOML text (:func:`dumps`) and validated like a file: the errors of a dict
name its keys the same way.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping
from typing import Any, List, Optional, Tuple

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def normalize(config: Any) -> Tuple[Optional[str], str, Optional[str]]:
    """``(path, name, text)``: a path (``name``/``text`` unused) or TOML ``text`` named ``name``."""
    if isinstance(config, Mapping):
        return None, "<dict>", dumps(config)
    if isinstance(config, os.PathLike):
        path = os.fspath(config)
        return path, path, None
    if isinstance(config, str):
        if "\n" in config or "=" in config:
            return None, "<string>", config
        return config, config, None
    raise TypeError(
        f"config: a path, a TOML string or a dict expected, {type(config).__name__} given"
    )


def experiment_of(config: Any) -> Optional[str]:
    """The ``experiment`` key of a config, if it can be read without validating it."""
    if isinstance(config, Mapping):
        e = config.get("experiment")
        return e if isinstance(e, str) else None
    from . import _native

    try:
        data = _native.read_config(*normalize(config))
    except Exception:
        return None
    e = data.get("experiment")
    return e if isinstance(e, str) else None


def _key(k: Any) -> str:
    if not isinstance(k, str):
        raise TypeError(f"config keys are strings: {k!r} ({type(k).__name__}) given")
    return k if _BARE_KEY.match(k) else json.dumps(k, ensure_ascii=False)


def _is_table(v: Any) -> bool:
    return isinstance(v, Mapping)


def _is_table_array(v: Any) -> bool:
    return isinstance(v, (list, tuple)) and len(v) > 0 and all(isinstance(x, Mapping) for x in v)


def _value(v: Any, where: str) -> str:
    # NumPy scalars and arrays: their Python values
    if hasattr(v, "tolist") and not isinstance(v, (str, bytes)):
        v = v.tolist()
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, Mapping):
        inner = ", ".join(f"{_key(k)} = {_value(x, f'{where}.{k}')}" for k, x in v.items())
        return "{" + inner + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x, f"{where}[{i}]") for i, x in enumerate(v)) + "]"
    if v is None:
        raise TypeError(f"config key `{where}`: None has no TOML form (leave the key out for its default)")
    raise TypeError(f"config key `{where}`: a {type(v).__name__} has no TOML form (allowed: bool, int, float, str, list, dict)")


def dumps(config: Mapping) -> str:
    """TOML text of a dict: scalars and lists as ``key = value``, dicts as ``[tables]``, lists of
    dicts as ``[[arrays of tables]]`` (so errors point at a line per key)."""
    lines: List[str] = []

    def emit(table: Mapping, path: List[str]) -> None:
        dotted = ".".join(_key(p) for p in path)
        for k, v in table.items():
            if not (_is_table(v) or _is_table_array(v)):
                where = ".".join(path + [str(k)])
                lines.append(f"{_key(k)} = {_value(v, where)}")
        for k, v in table.items():
            if _is_table(v):
                lines.append("")
                lines.append(f"[{dotted + '.' if dotted else ''}{_key(k)}]")
                emit(v, path + [k])
            elif _is_table_array(v):
                for item in v:
                    lines.append("")
                    lines.append(f"[[{dotted + '.' if dotted else ''}{_key(k)}]]")
                    emit(item, path + [k])

    emit(config, [])
    return "\n".join(lines) + "\n"
