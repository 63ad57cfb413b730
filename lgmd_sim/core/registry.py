"""Names that stand for classes: a `Registry` maps each name to a class or a
``"module:attr"`` string, imported on first use, so that listing the names stays cheap and
a module loads only when one of its classes is asked for (the models, the controllers, the
reference models).

A registry holds, in this order: the package's own names, those added by `Registry.register`
(a researcher's classes), and those an installed distribution declares in the registry's
entry-point group (read once, on first use). A ``"package.module:Class"`` spec names a
class directly, wherever a name is accepted.
"""

from __future__ import annotations

import contextlib
import dataclasses
import warnings
from collections.abc import Iterator, Mapping
from importlib import import_module, metadata
from pathlib import Path
from typing import Any

__all__ = ["Registry"]

# They separate a detector's parts ("model/preset+front,model"), so no name may hold one.
_SEPARATORS = ":/+, "


def _plain(name: Any) -> bool:
    """Whether `name` can be a registered or entry-point name: a non-empty string without
    any of `_SEPARATORS`."""
    return isinstance(name, str) and bool(name) and not any(c in name for c in _SEPARATORS)


def _is_spec(text: Any) -> bool:
    """Whether `text` reads as "package.module:attr": an absolute dotted module and an
    identifier ("mypkg.looming:Mine/fast" is a spec with a preset, not a spec)."""
    module, colon, attr = text.partition(":") if isinstance(text, str) else ("", "", "")
    return bool(colon and attr.isidentifier()
                and all(part.isidentifier() for part in module.split(".")))


def _import_fault(module: str, exc: BaseException) -> str:
    """Why `module` did not import, in one line: not found (and where Python looks for a
    module of a spec), or what its code raised on import, and where."""
    text = " ".join(str(exc).split())[:300]
    top = module.partition(".")[0]
    if isinstance(exc, ModuleNotFoundError) and exc.name == top:
        return (f"cannot import module {module!r} ({text}): put the folder that holds "
                f"{top}.py or {top}/ on PYTHONPATH (as PYTHONPATH=examples does for "
                "examples/eta_lgmd.py)")
    if isinstance(exc, SystemExit):
        raised = f"called sys.exit({exc.code!r})"
    else:
        raised = f"raised {type(exc).__name__}{': ' + text if text else ''}"
    tb = exc.__traceback__
    while tb is not None and tb.tb_next is not None:
        tb = tb.tb_next
    # where in the user's code; a SyntaxError's text names its file and line already
    at = "" if tb is None or isinstance(exc, SyntaxError) else (
        f" ({Path(tb.tb_frame.f_code.co_filename).name}, line {tb.tb_lineno})")
    return f"cannot import module {module!r}: importing it {raised}{at}"


@dataclasses.dataclass
class Registry:
    """The classes of one kind (`base`), by name.

    Attributes:
        what: the kind of name, for messages ("model").
        base: the class every entry must subclass.
        builtins: the package's own, name -> "module:attr".
        group: the entry-point group installed distributions add theirs to, or None.
        registered: those `register` added, name -> class or "module:attr".
    """

    what: str
    base: type
    builtins: Mapping[str, str]
    group: str | None = None
    registered: dict[str, type | str] = dataclasses.field(default_factory=dict)
    # name -> ("module:attr", distribution) of the entry-point group; None until first read
    _entry_points: dict[str, tuple[str, str]] | None = dataclasses.field(
        default=None, init=False, repr=False)

    def names(self) -> list[str]:
        """Every name: the built-ins, then the registered, then the entry points'."""
        return list({**dict.fromkeys(self.builtins), **dict.fromkeys(self.registered),
                     **dict.fromkeys(self._found())})

    def register(self, name: str, cls: type | str) -> None:
        """Add `cls` (a class, or a "package.module:Class" string imported on first use)
        under `name`; ValueError for a name taken or not a plain name, or a class that is
        not a `base`."""
        if not _plain(name):
            raise ValueError(f"a {self.what} name is a non-empty string without any of "
                             f"{' '.join(repr(c) for c in _SEPARATORS)}, got {name!r}")
        if name in self.names():
            raise ValueError(f"{self.what} name {name!r} is taken ({self.origin(name)})")
        if isinstance(cls, str):
            if not _is_spec(cls):
                raise ValueError(f"{self.what} {name!r}: {cls!r} is not a "
                                 "'package.module:Class' string")
        else:
            self._check(cls, name)
        self.registered[name] = cls

    def get(self, name: str) -> type:
        """The class behind a name or a "package.module:Class" spec; a one-line ValueError
        naming the valid names for another, or what is wrong with a spec."""
        found = self._found()
        if name in self.builtins:
            target: type | str = self.builtins[name]
        elif name in self.registered:
            target = self.registered[name]
        elif name in found:
            target = found[name][0]
        elif _is_spec(name):
            target = name
        else:
            raise ValueError(f"unknown {self.what} {name!r}; available: "
                             f"{', '.join(self.names())} (or a 'package.module:Class' spec)")
        if isinstance(target, str):
            target = self._import(target, name)
        return self._check(target, name)

    def origin(self, name: str) -> str:
        """Where a name comes from: "built-in", "registered", "entry point of DIST", or
        "spec"."""
        if name in self.builtins:
            return "built-in"
        if name in self.registered:
            return "registered"
        found = self._found()
        return f"entry point of {found[name][1]}" if name in found else "spec"

    @contextlib.contextmanager
    def isolated(self) -> Iterator[None]:
        """Within the block, nothing registered and the entry points read afresh; after
        it, the registry as it was (for tests that register or install classes)."""
        saved = self.registered, self._entry_points
        self.registered, self._entry_points = {}, None
        try:
            yield
        finally:
            self.registered, self._entry_points = saved

    def _found(self) -> dict[str, tuple[str, str]]:
        if self._entry_points is None:
            self._entry_points = {}
            for ep in [] if self.group is None else metadata.entry_points(group=self.group):
                dist = ep.dist.name if ep.dist else "?"
                clash = ep.name in self.builtins or ep.name in self.registered
                if clash or not _plain(ep.name):
                    why = "is taken" if clash else f"holds one of {_SEPARATORS!r}"
                    warnings.warn(f"{self.what} entry point {ep.name!r} of {dist} skipped: "
                                  f"the name {why}", stacklevel=2)
                else:
                    self._entry_points[ep.name] = (ep.value, dist)
        return self._entry_points

    def _import(self, spec: str, name: str) -> Any:
        where = name if name == spec else f"{name} = {spec}"
        if not _is_spec(spec):
            raise ValueError(f"{self.what} {where!r}: not a 'package.module:Class' string")
        module, _, attr = spec.partition(":")
        try:
            imported = import_module(module)
        except (Exception, SystemExit) as exc:
            # a module's own fault (a SyntaxError, whatever it raises or exits with on
            # import) is the user's to fix, said in one line as a missing module is
            raise ValueError(f"{self.what} {where!r}: {_import_fault(module, exc)}") from exc
        if not hasattr(imported, attr):
            raise ValueError(f"{self.what} {where!r}: module {module!r} has no {attr!r}")
        return getattr(imported, attr)

    def _check(self, cls: Any, name: str) -> type:
        if not (isinstance(cls, type) and issubclass(cls, self.base)):
            # a class by its name; anything else by its type: a module's or a dict's repr
            # runs to kilobytes
            what = (f"class {cls.__module__}.{cls.__qualname__}" if isinstance(cls, type)
                    else f"a {type(cls).__name__}")
            raise ValueError(f"{self.what} {name!r}: {what} is not a subclass of "
                             f"{self.base.__module__}.{self.base.__qualname__}")
        return cls
