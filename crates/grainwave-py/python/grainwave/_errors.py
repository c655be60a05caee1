"""Exceptions for paths that do not exist: each is a ``FileNotFoundError`` (``errno``,
``filename``) and also what the call raised for it before, so that code catching either keeps
working.

* :class:`ConfigFileNotFoundError`: a config file given by path (a :class:`ConfigError`, with
  ``file``, ``message``…);
* :class:`PathNotFoundError`: a checkpoint or output directory (``Simulation.load``,
  ``grainwave.load``, ``resume``, ``load_result``; a ``ValueError``).

``str()`` is the message the module gives (``text``), not ``[Errno 2] …``.
"""

from __future__ import annotations

import errno
import os

from ._native import ConfigError


class _NotFound(FileNotFoundError):
    def __init__(self, *args) -> None:
        # the OSError fields (errno, strerror, filename) are set by OSError's own __init__,
        # which the other base class's would skip
        FileNotFoundError.__init__(self, *args)

    def __str__(self) -> str:
        text = getattr(self, "text", None)
        return text if text else FileNotFoundError.__str__(self)


class ConfigFileNotFoundError(_NotFound, ConfigError):
    """A config file that does not exist: a ``FileNotFoundError`` and a ``ConfigError``."""


class PathNotFoundError(_NotFound, ValueError):
    """A checkpoint, output directory or other path that does not exist: a
    ``FileNotFoundError`` and a ``ValueError``."""


def path_not_found(path, text: str) -> PathNotFoundError:
    """The exception for ``path``, which does not exist, with message ``text``."""
    e = PathNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), os.fspath(path))
    e.text = text
    return e
