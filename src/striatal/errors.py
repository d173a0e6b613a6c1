"""Typed errors. The CLI turns every one of them into one line on stderr and exit code 2."""

from __future__ import annotations

__all__ = [
    "DataFileError",
    "MissingExtraError",
    "ParameterError",
    "StriatalError",
]


class StriatalError(ValueError):
    """Base class: an input or a file that striatal cannot use, with a message a user can act on."""


class ParameterError(StriatalError):
    """A physical, controller, protocol or learner parameter is out of its valid range."""


class DataFileError(StriatalError):
    """A result, history, checkpoint or config file is missing, truncated or does not parse."""


class MissingExtraError(StriatalError, ImportError):
    """An optional part of striatal needs a package that is not installed; names the extra."""
