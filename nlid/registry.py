"""Discovery of identifier plugins through entry points, with pluggy.

:func:`plugin_manager` builds a fresh manager (no import-time global): it adds
the hook specifications, loads every entry point of the group
``nlid.identifiers`` and validates the hook implementations. Each plugin is
loaded and asked for its identifiers separately, so a plugin that fails to
import, misspells a hook or raises is recorded in :attr:`Registry.failures`
under its entry-point name and never takes the others down.

:func:`default_registry` caches one registry per process for the CLI and the
library functions; tests build their own with :func:`load_registry`.
"""

from __future__ import annotations

import functools
import importlib.metadata
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import pluggy

from . import hookspecs
from .errors import PASS_THROUGH, InputError, NlidError, PluginError, brief, describe_exception, listing
from .interface import Option
from .validate import did_you_mean

__all__ = ["ENTRY_POINT_GROUP", "Registry", "plugin_manager", "load_registry", "default_registry", "check_contract"]

#: Entry-point group under which identifier plugins register.
ENTRY_POINT_GROUP = "nlid.identifiers"


def plugin_manager(
    entry_points: Iterable[importlib.metadata.EntryPoint] | None = None,
    failures: dict[str, str] | None = None,
) -> pluggy.PluginManager:
    """A plugin manager with nlid's hooks and the installed plugins registered.

    Parameters
    ----------
    entry_points
        Entry points to load; default: all of group :data:`ENTRY_POINT_GROUP`.
    failures
        Filled with ``{plugin name: error}`` for plugins that could not be
        loaded or validated.
    """
    failures = {} if failures is None else failures
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    if entry_points is None:
        entry_points = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    seen: set[str] = set()
    for ep in entry_points:
        if ep.name in seen:
            continue  # the same distribution visible twice on sys.path
        seen.add(ep.name)
        try:
            plugin = ep.load()
            pm.register(plugin, name=ep.name)
        except PASS_THROUGH:
            raise
        except BaseException as exc:  # noqa: BLE001 - any plugin error (sys.exit too) is reported, not raised
            failures[ep.name] = f"failed to load ({ep.value}): {describe_exception(exc)}"
    while True:
        try:
            pm.check_pending()
            break
        except pluggy.PluginValidationError as exc:
            name = pm.get_name(exc.plugin) or str(exc.plugin)
            failures[name] = f"invalid plugin: {exc}"
            pm.unregister(exc.plugin)
    return pm


def check_contract(cls: Any) -> None:
    """Check the attributes the core relies on; raise PluginError otherwise."""
    if not isinstance(cls, type):
        raise PluginError(f"expected an identifier class, got {cls!r}")
    name = getattr(cls, "name", None)
    if not isinstance(name, str) or not name:
        raise PluginError(f"{cls.__name__} has no 'name'")
    if not callable(getattr(cls, "identify", None)):
        raise PluginError(f"identifier {name!r} has no identify() method")
    options = getattr(cls, "options", ())
    if not all(isinstance(o, Option) for o in options):
        raise PluginError(f"identifier {name!r}: 'options' must be a tuple of nlid.Option")
    if not isinstance(getattr(cls, "needs_mass", False), bool):
        raise PluginError(f"identifier {name!r}: 'needs_mass' must be a bool")


@dataclass
class Registry:
    """The identifiers available in this environment.

    Attributes
    ----------
    identifiers
        ``{name: identifier class}``.
    plugins
        ``{identifier name: plugin (entry-point) name}``.
    failures
        ``{plugin name: error message}`` for plugins that could not be used.
    """

    identifiers: dict[str, type] = field(default_factory=dict)
    plugins: dict[str, str] = field(default_factory=dict)
    failures: dict[str, str] = field(default_factory=dict)

    def names(self) -> list[str]:
        """Sorted identifier names."""
        return sorted(self.identifiers)

    def get(self, name: str) -> type:
        """The identifier class called ``name``.

        Raises
        ------
        PluginError
            If the plugin of that name failed to load.
        InputError
            If no identifier has that name (with a suggestion).
        """
        if name in self.identifiers:
            return self.identifiers[name]
        if name in self.failures:
            raise PluginError(f"identifier plugin {name!r} is installed but unusable: {self.failures[name]}")
        raise InputError(
            f"unknown method {brief(name)}{did_you_mean(name, self.names())}; "
            f"installed: {listing(self.names(), limit=40) or 'none'}"
        )

    def create(self, name: str, options: Mapping[str, Any] | None = None) -> Any:
        """Instantiate an identifier with validated options.

        Raises
        ------
        OptionError
            Bad options (from the identifier's declaration).
        PluginError
            The identifier's constructor failed otherwise (``sys.exit`` too).
        """
        cls = self.get(name)
        try:
            return cls(**dict(options or {}))
        except (NlidError, *PASS_THROUGH):
            raise
        except BaseException as exc:  # noqa: BLE001 - a plugin bug is reported by name
            raise PluginError(
                f"identifier {name!r} (plugin {self.plugins.get(name, '?')!r}) {describe_exception(exc)} when created"
            ) from None


def load_registry(pm: pluggy.PluginManager | None = None, failures: dict[str, str] | None = None) -> Registry:
    """Ask every registered plugin for its identifiers.

    Parameters
    ----------
    pm
        Plugin manager; default: :func:`plugin_manager`.
    failures
        Load failures already known (from :func:`plugin_manager`).
    """
    failures = dict(failures or {})
    if pm is None:
        pm = plugin_manager(failures=failures)
    reg = Registry(failures=failures)
    for impl in reversed(pm.hook.nlid_identifiers.get_hookimpls()):  # registration order
        # Each implementation is called on its own (not through the hook's
        # fan-out) so that one raising plugin cannot hide the others.
        try:
            classes = list(impl.function())
            for cls in classes:
                check_contract(cls)
        except PASS_THROUGH:
            raise
        except PluginError as exc:
            reg.failures[impl.plugin_name] = f"nlid_identifiers() returned a broken identifier: {exc}"
            continue
        except BaseException as exc:  # noqa: BLE001 - reported per plugin, sys.exit too
            reg.failures[impl.plugin_name] = f"nlid_identifiers() {describe_exception(exc)}"
            continue
        for cls in classes:
            if cls.name in reg.identifiers:
                reg.failures[impl.plugin_name] = (
                    f"identifier name {cls.name!r} is already provided by plugin {reg.plugins[cls.name]!r}"
                )
                continue
            reg.identifiers[cls.name] = cls
            reg.plugins[cls.name] = impl.plugin_name
    return reg


@functools.lru_cache(maxsize=1)
def default_registry() -> Registry:
    """The registry of installed plugins, built once per process."""
    failures: dict[str, str] = {}
    return load_registry(plugin_manager(failures=failures), failures)


@functools.lru_cache(maxsize=16)
def registry_for(name: str) -> Registry:
    """A registry that holds identifier ``name``, importing as few plugins as possible.

    Built-in and well-behaved plugins register each identifier under an entry point of the same name, so
    only that entry point is loaded (``nlid identify --method rfs`` does not import pysindy,
    scikit-learn or pandas through the other plugins). When no entry point carries the name, or its
    plugin does not provide it, the full :func:`default_registry` answers (with its suggestions and the
    failures of every plugin).
    """
    matching = [ep for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP) if ep.name == name]
    if matching:
        failures: dict[str, str] = {}
        reg = load_registry(plugin_manager(entry_points=matching[:1], failures=failures), failures)
        if name in reg.identifiers:
            return reg
    return default_registry()
