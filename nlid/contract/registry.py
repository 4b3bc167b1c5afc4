"""Discovery of identifier plugins through entry points, with pluggy.

:func:`plugin_manager` builds a fresh manager (no import-time global): it adds
the hook specifications, loads every entry point of the group
``nlid.identifiers`` and validates the hook implementations. Each plugin is
loaded and asked for its identifiers separately, so a plugin that fails to
import, misspells a hook or raises is recorded in :attr:`Registry.failures`
under its entry-point name and never takes the others down; so is a plugin
that loads but implements no hook (it would provide nothing, silently).

Whatever a plugin prints while it is imported or asked for its identifiers
(``print``, warnings, a C library writing to the file descriptors) is kept out
of nlid's own output (``--json`` stays one JSON object) and reported in
:attr:`Registry.notes`, as is an import slower than :data:`SLOW_IMPORT`
seconds; ``nlid methods`` lists both.

:func:`default_registry` caches one registry per process for the CLI and the
library functions; tests build their own with :func:`load_registry`.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.metadata
import io
import os
import sys
import tempfile
import time
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

import pluggy

from ..base.validate import did_you_mean
from ..errors import PASS_THROUGH, InputError, NlidError, PluginError, brief, describe_exception, listing
from . import hookspecs
from .identifier import Option

__all__ = [
    "ENTRY_POINT_GROUP",
    "SLOW_IMPORT",
    "Registry",
    "plugin_manager",
    "load_registry",
    "default_registry",
    "check_contract",
    "captured_output",
]

#: Entry-point group under which identifier plugins register.
ENTRY_POINT_GROUP = "nlid.identifiers"
#: A plugin whose import takes longer than this (s) is named in :attr:`Registry.notes`.
SLOW_IMPORT = 5.0
#: The hooks a plugin can implement (:mod:`nlid.contract.hookspecs`).
HOOKS = ("nlid_identifiers", "nlid_candidates")


@contextlib.contextmanager
def captured_output() -> Iterator[list[str]]:
    """Keep what the body prints off nlid's stdout and stderr; the text is in the list on exit.

    Both the Python streams and the file descriptors 1 and 2 are redirected, so a C library or a
    child process writing to them is caught too. Used around a plugin's import and hook calls.
    """
    found: list[str] = []
    buffer = io.StringIO()
    saved: dict[int, int] = {}
    with tempfile.TemporaryFile() as sink:
        for stream in (sys.stdout, sys.stderr):
            with contextlib.suppress(Exception):
                stream.flush()
        for fd in (1, 2):
            try:
                saved[fd] = os.dup(fd)
                os.dup2(sink.fileno(), fd)
            except OSError:  # no such descriptor (an embedded interpreter): the Python streams still are
                saved.pop(fd, None)
        try:
            with contextlib.redirect_stdout(buffer), contextlib.redirect_stderr(buffer):
                yield found
        finally:
            for fd, keep in saved.items():
                os.dup2(keep, fd)
                os.close(keep)
            sink.seek(0)
            text = buffer.getvalue()[:65536] + sink.read(65536).decode("utf-8", errors="replace")  # a start is enough
            if text.strip():
                found.append(text)


def _printed(text: list[str], when: str) -> str | None:
    """The note for what a plugin printed ``when`` (``"at import"``), ``None`` if nothing."""
    if not text:
        return None
    joined = " ".join(text).strip()
    return f"printed {when} (kept out of nlid's output): {brief(joined, 120)}"


def plugin_manager(
    entry_points: Iterable[importlib.metadata.EntryPoint] | None = None,
    failures: dict[str, str] | None = None,
    notes: dict[str, list[str]] | None = None,
) -> pluggy.PluginManager:
    """A plugin manager with nlid's hooks and the installed plugins registered.

    Parameters
    ----------
    entry_points
        Entry points to load; default: all of group :data:`ENTRY_POINT_GROUP`.
    failures
        Filled with ``{plugin name: error}`` for plugins that could not be
        loaded or validated.
    notes
        Filled with ``{plugin name: [note, ...]}``: what a plugin printed at
        import (kept out of nlid's output), an import slower than
        :data:`SLOW_IMPORT` seconds.
    """
    failures = {} if failures is None else failures
    notes = {} if notes is None else notes
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    if entry_points is None:
        entry_points = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    seen: set[str] = set()
    for ep in entry_points:
        if ep.name in seen:
            continue  # the same distribution visible twice on sys.path
        seen.add(ep.name)
        start = time.perf_counter()
        with captured_output() as printed:
            try:
                plugin = ep.load()
                pm.register(plugin, name=ep.name)
            except PASS_THROUGH:
                raise
            except BaseException as exc:  # noqa: BLE001 - any plugin error (sys.exit too) is reported, not raised
                failures[ep.name] = f"failed to load ({ep.value}): {describe_exception(exc)}"
        seconds = time.perf_counter() - start
        said = _printed(printed, "at import")
        if said:
            notes.setdefault(ep.name, []).append(said)
        if seconds > SLOW_IMPORT:
            notes.setdefault(ep.name, []).append(f"took {seconds:.1f} s to import (every nlid command pays it)")
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
        ``{plugin name: error message}`` for plugins that could not be used
        (including one that loads but implements no hook).
    notes
        ``{plugin name: [note, ...]}`` for plugins that work but should be
        mentioned: what they printed while loading (kept out of nlid's
        output), a slow import.
    """

    identifiers: dict[str, type] = field(default_factory=dict)
    plugins: dict[str, str] = field(default_factory=dict)
    failures: dict[str, str] = field(default_factory=dict)
    notes: dict[str, list[str]] = field(default_factory=dict)

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


def _provides_nothing(pm: pluggy.PluginManager, plugin: object) -> str | None:
    """Why a registered plugin provides nothing (it implements no hook), else ``None``."""
    if pm.get_hookcallers(plugin):
        return None
    unmarked = [h for h in HOOKS if callable(getattr(plugin, h, None))]
    if unmarked:
        return f"provides nothing: {unmarked[0]}() is not marked with @nlid.hookimpl"
    return f"provides nothing: it implements no nlid hook ({', '.join(HOOKS)}; see docs/plugins.md)"


def load_registry(
    pm: pluggy.PluginManager | None = None,
    failures: dict[str, str] | None = None,
    notes: dict[str, list[str]] | None = None,
) -> Registry:
    """Ask every registered plugin for its identifiers.

    Parameters
    ----------
    pm
        Plugin manager; default: :func:`plugin_manager`.
    failures
        Load failures already known (from :func:`plugin_manager`).
    notes
        Load notes already known (from :func:`plugin_manager`).
    """
    failures = dict(failures or {})
    notes = {k: list(v) for k, v in (notes or {}).items()}
    if pm is None:
        pm = plugin_manager(failures=failures, notes=notes)
    reg = Registry(failures=failures, notes=notes)
    for plugin_name, plugin in pm.list_name_plugin():
        why = _provides_nothing(pm, plugin)
        if why is not None and plugin_name not in reg.failures:
            reg.failures[plugin_name] = why
    for impl in reversed(pm.hook.nlid_identifiers.get_hookimpls()):  # registration order
        # Each implementation is called on its own (not through the hook's
        # fan-out) so that one raising plugin cannot hide the others.
        with captured_output() as printed:
            try:
                classes = list(impl.function())
                for cls in classes:
                    check_contract(cls)
            except PASS_THROUGH:
                raise
            except PluginError as exc:
                reg.failures[impl.plugin_name] = f"nlid_identifiers() returned a broken identifier: {exc}"
                classes = None
            except BaseException as exc:  # noqa: BLE001 - reported per plugin, sys.exit too
                reg.failures[impl.plugin_name] = f"nlid_identifiers() {describe_exception(exc)}"
                classes = None
        said = _printed(printed, "in nlid_identifiers()")
        if said:
            reg.notes.setdefault(impl.plugin_name, []).append(said)
        if classes is None:
            continue
        if not classes and not any(c.plugin_name == impl.plugin_name for c in pm.hook.nlid_candidates.get_hookimpls()):
            reg.notes.setdefault(impl.plugin_name, []).append("provides no identifier (nlid_identifiers() is empty)")
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
    notes: dict[str, list[str]] = {}
    return load_registry(plugin_manager(failures=failures, notes=notes), failures, notes)


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
        notes: dict[str, list[str]] = {}
        reg = load_registry(plugin_manager(entry_points=matching[:1], failures=failures, notes=notes), failures, notes)
        if name in reg.identifiers:
            return reg
    return default_registry()


def make_identifier(method: Any, options: Mapping[str, Any] | None = None, registry: Registry | None = None) -> Any:
    """The identifier named ``method``, created with ``options`` (:meth:`Registry.create`); an instance as it is.

    Raises
    ------
    InputError
        ``options`` given with an instance (they belong to its constructor).
    """
    if not isinstance(method, str):
        if options:
            raise InputError("options are given to the identifier's constructor when passing an instance")
        return method
    return (registry or registry_for(method)).create(method, options)
