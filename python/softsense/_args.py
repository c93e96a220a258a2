"""Argument checks shared by every public call: paths or library objects, and keyword names.

Python's own messages say which keyword was unknown but not which are known, and a path
argument given a dict would otherwise reach the library as its repr; both are checked here,
before the call, with the argument's name in the message.
"""

from __future__ import annotations

import difflib
import functools
import inspect
import os
from typing import Any, Callable, Iterable, Optional, TypeVar, Union

from ._softsense import SoftsenseError

PathLike = Union[str, "os.PathLike[str]"]
F = TypeVar("F", bound=Callable[..., Any])


class MissingPathError(SoftsenseError, FileNotFoundError):
    """An input path that does not exist: a ``FileNotFoundError``, and a
    ``SoftsenseError`` like the library's own errors for unreadable files."""


def check_keywords(where: str, given: Iterable[str], known: Iterable[str]) -> None:
    """A ``TypeError`` listing the ``known`` keywords if one of ``given`` is not one."""
    known = list(known)
    for name in given:
        if name not in known:
            close = difflib.get_close_matches(name, known, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            listed = f"known: {', '.join(known)}" if known else "it takes none"
            raise TypeError(f"{where}() got an unexpected keyword argument {name!r}{hint} ({listed})")


def keywords(f: F) -> F:
    """``f`` with its keyword arguments checked against its signature's names; ``f`` itself
    when it takes ``**params``, which the library checks against its own names."""
    params = inspect.signature(f).parameters.values()
    if any(p.kind == p.VAR_KEYWORD for p in params):
        return f
    known = [
        p.name
        for p in params
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and p.name not in ("self", "cls")
    ]
    where = f.__qualname__.replace(".__init__", "")

    @functools.wraps(f)
    def checked(*args: Any, **kwargs: Any) -> Any:
        check_keywords(where, kwargs, known)
        return f(*args, **kwargs)

    return checked  # type: ignore[return-value]


def path(value: Any, name: str, must_exist: bool = False, objects: tuple = ()) -> str:
    """``value`` as a path string: a ``str`` or ``os.PathLike``, or an instance of one of
    ``objects`` (such as ``Model`` or ``Recording``), which gives the file it was read
    from. With ``must_exist``, a path that does not exist is a :class:`MissingPathError`."""
    if isinstance(value, objects):
        given = value.path
        if given is None:
            raise ValueError(
                f"{name}: this {type(value).__name__} has no file behind it (it was loaded with "
                f"its mesh replaced), and this call reads it from a file: give the path of a "
                f"model file that describes it"
            )
    elif isinstance(value, (str, os.PathLike)):
        given = value
    else:
        kinds = [c.__name__ for c in objects] + ["str", "os.PathLike"]
        raise TypeError(f"{name}: expected {' or '.join(kinds)}, got {type(value).__name__}")
    text = os.fspath(given)
    if not isinstance(text, str):
        raise TypeError(f"{name}: expected a text path, got {type(text).__name__}")
    if must_exist and not os.path.exists(text):
        raise MissingPathError(f"{name}: {text} does not exist")
    return text


def optional_path(value: Any, name: str, must_exist: bool = False) -> Optional[str]:
    return None if value is None else path(value, name, must_exist)
