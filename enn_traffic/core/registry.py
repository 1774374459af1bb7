"""Names bound to code, imported on first use: the tables of world kinds, environments and
experiments (a name missing from a table is an error, never a silent fallback;
docs/design.md, "Architecture"), and the old names of modules that moved."""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import types
import warnings
from collections.abc import Iterator


class Registry:
    """Names bound to objects written ``"package.module:attribute"``, imported on first look-up
    (as gymnasium's entry points are), so that naming SUMO's world does not load SUMO for an
    arena run. An unknown name is a ``KeyError`` that lists the known ones; there is no
    ``get`` with a default, and ``name in table`` imports nothing."""

    def __init__(self, what: str, entries: dict[str, str]):
        self.what = what
        self._entries = dict(entries)

    def __getitem__(self, name: str) -> object:
        if name not in self._entries:
            raise KeyError(f"unknown {self.what} {name!r}; known: {', '.join(self._entries)}")
        module, attribute = self._entries[name].split(":")
        return getattr(importlib.import_module(module), attribute)

    def __contains__(self, name: object) -> bool:
        return name in self._entries

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def target(self, name: str) -> str:
        """Where ``name``'s object lives, ``"package.module:attribute"``, without importing."""
        return self._entries[name]


class MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Old module names that still import, for one release after a module moved: each is a
    module whose attributes are the new module's, found on first use with a
    ``DeprecationWarning`` that names the new place."""

    def __init__(self, moved: dict[str, str | tuple[str, ...]]):
        self.moved = dict(moved)

    def find_spec(self, name: str, path: object = None, target: object = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if name not in self.moved:
            return None
        return importlib.machinery.ModuleSpec(name, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> types.ModuleType:
        return _Moved(spec.name, self.moved[spec.name])

    def exec_module(self, module: types.ModuleType) -> None:
        warnings.warn(f"{module.__name__} is now {module.target}; the old name goes in the next "
                      "release", DeprecationWarning, stacklevel=2)


class _Moved(types.ModuleType):
    """A module that moved: its attributes are those of the module at ``target``, or, where
    it was split, of the first of the modules ``target`` names that has them."""

    def __init__(self, name: str, target: str | tuple[str, ...]):
        super().__init__(name)
        self.targets = (target,) if isinstance(target, str) else tuple(target)
        self.target = " and ".join(self.targets)

    def __getattr__(self, name: str) -> object:
        for target in self.targets:
            module = importlib.import_module(target)
            if hasattr(module, name):
                return getattr(module, name)
        raise AttributeError(f"{self.__name__} (now {self.target}) has no {name!r}")

    def __dir__(self) -> list[str]:
        return sorted({name for target in self.targets
                       for name in dir(importlib.import_module(target))})
