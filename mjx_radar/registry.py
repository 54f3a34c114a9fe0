"""One registry style for every plug-in: cost terms, planners, trackers, associators, sensors.

A :class:`Registry` maps names to plug-ins (functions or classes). Built-in entries
are listed when the registry is made; entries registered from scripts are kept apart,
and their *code* (bytecode, closure values and the scalar globals they read, every
method of a class) is part of every compiled-program cache key through
:meth:`Registry.key`, so changing a registered plug-in recompiles and an unchanged
one loads from the cache.

Example:
    >>> PLANNERS = Registry("planner")
    >>> @PLANNERS.register("spiral")
    ... class Spiral: ...
    >>> PLANNERS.names()
    ('spiral',)
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import inspect
import marshal
from collections.abc import Callable
from typing import Any

from mjx_radar import contracts

_SCALARS = (int, float, str, bool, tuple)


def _update_function(h, fn) -> None:
    code = fn.__code__
    h.update(marshal.dumps(code))
    for cell in fn.__closure__ or ():
        try:
            h.update(repr(cell.cell_contents).encode())
        except ValueError:  # an empty cell (a closure over a name not yet bound)
            h.update(b"<empty>")
    for gname in code.co_names:  # scalar globals the code reads (e.g. a weight)
        value = fn.__globals__.get(gname)
        if isinstance(value, _SCALARS):
            h.update(f"{gname}={value!r}".encode())


def code_digest(obj: Any) -> str:
    """A digest of what a plug-in computes: its code, closures and scalar globals.

    Functions hash their bytecode; classes every function in their own and their
    bases' namespaces (``object`` excluded); ``functools.partial`` its function and
    arguments; an instance its class and its attributes' values (a sensor that carries
    its parameters); anything else its ``repr``.
    """
    h = hashlib.sha256()
    if isinstance(obj, functools.partial):
        h.update(code_digest(obj.func).encode())
        h.update(repr((obj.args, sorted(obj.keywords.items()))).encode())
    elif inspect.isclass(obj):
        for klass in obj.__mro__:
            if klass is object:
                continue
            h.update(klass.__qualname__.encode())
            for name, value in sorted(vars(klass).items()):
                fn = getattr(value, "__func__", value)  # staticmethod / classmethod
                if inspect.isfunction(fn):
                    h.update(name.encode())
                    _update_function(h, fn)
                elif isinstance(value, _SCALARS):
                    h.update(f"{name}={value!r}".encode())
    elif inspect.isfunction(obj):
        _update_function(h, obj)
    elif callable(getattr(obj, "code_parts", None)):  # an entry made of user functions
        for part in obj.code_parts():
            h.update(code_digest(part).encode())
    elif hasattr(obj, "__dict__") and not inspect.isroutine(obj):  # an instance: its
        h.update(code_digest(type(obj)).encode())  # class's code and its own values
        h.update(repr(sorted(vars(obj).items())).encode())
    else:
        h.update(repr(obj).encode())
    return h.hexdigest()[:16]


class Registry:
    """Named plug-ins of one kind (``"planner"``, ``"tracker"``, ...).

    Args:
        kind: what the entries are, for messages (``"planner 'x' is not one of ..."``).
        builtins: the entries that ship with the package (never part of :meth:`key`,
            which the package's own code fingerprint covers); an entry may be given as
            ``"module:attribute"``, imported on first use (keeps imports light).
    """

    def __init__(self, kind: str, builtins: dict[str, Any] | None = None):
        self.kind = kind
        self._builtin: dict[str, Any] = dict(builtins or {})
        self._user: dict[str, Any] = {}

    def register(self, name: str, obj: Any = None) -> Any:
        """Adds ``obj`` under ``name`` (replacing a registered one; a built-in: refused).

        Usable as a decorator: ``@REGISTRY.register("name")``. Returns ``obj``.

        Raises:
            ValueError: ``name`` is not a string of letters, digits, ``-`` and ``_``,
                or names a built-in entry.
        """
        if obj is None:
            return lambda o: self.register(name, o)
        if not isinstance(name, str) or not name.replace("-", "_").isidentifier():
            raise ValueError(f"{self.kind} name {name!r}: letters, digits, '-' and '_' only")
        key = name.lower()  # names are case-insensitive, as method names
        if key in self._builtin:
            raise ValueError(f"{self.kind} name {name!r}: a built-in {self.kind}")
        if key in contracts.RESERVED.get(self.kind, ()):
            raise ValueError(f"{self.kind} name {name!r}: reserved (the scenario's own choice)")
        if not callable(obj) and self.kind not in contracts.METHODS:
            raise TypeError(f"{self.kind} {name!r}: a class or function, not {type(obj).__name__}")
        contracts.check(self.kind, name, obj)
        self._user[key] = obj
        return obj

    def unregister(self, name: str) -> None:
        """Removes a registered entry (no error if absent; built-ins stay)."""
        self._user.pop(name.lower() if isinstance(name, str) else name, None)

    def add_builtin(self, name: str, obj: Any) -> None:
        """Lists a built-in entry (package code only)."""
        self._builtin[name] = obj

    def get(self, name: str) -> Any:
        """The entry called ``name``, or ``"name:ARGUMENT"`` for an entry that takes one.

        An entry with a true ``takes_argument`` attribute (e.g. the planner
        ``policy:DIR``, a trained policy read from ``DIR``) is returned as
        ``functools.partial(entry, argument=ARGUMENT)``.

        Raises:
            ValueError: one line naming the known entries (or, for a built-in whose
                optional dependency is missing, the remedy), or an argument given to an
                entry that takes none (or none given to one that needs it).
        """
        if isinstance(name, str) and ":" in name:
            base, _, arg = name.partition(":")
            base = base.lower()
            obj = self._entry(base)
            if not getattr(obj, "takes_argument", False):
                raise ValueError(f"{self.kind} {name!r}: {base!r} takes no ':ARGUMENT'")
            if not arg:
                raise ValueError(f"{self.kind} {name!r}: give {base}:ARGUMENT")
            return functools.partial(obj, argument=arg)
        obj = self._entry(name)
        if getattr(obj, "takes_argument", False):
            arg = getattr(obj, "argument_name", "ARGUMENT")
            raise ValueError(f"{self.kind} {name!r}: give {name}:{arg}")
        return obj

    def _entry(self, name: str) -> Any:
        """The entry called ``name`` itself (one-line ``ValueError`` if unknown)."""
        if isinstance(name, str):
            name = name.lower()  # names are case-insensitive
            if name in self._user:
                return self._user[name]
            if name in self._builtin:
                obj = self._builtin[name]
                if isinstance(obj, str):  # "module:attribute", imported on first use
                    module, attr = obj.split(":")
                    try:
                        loaded = importlib.import_module(module)
                    except ImportError as err:  # an optional dependency: one line
                        raise ValueError(f"{self.kind} {name!r}: {err}") from None
                    obj = self._builtin[name] = getattr(loaded, attr)
                return obj
        raise ValueError(f"{self.kind}: {name!r} is not one of {', '.join(self.names())}")

    def __contains__(self, name) -> bool:
        if isinstance(name, str):
            name = name.partition(":")[0].lower()
        return name in self._user or name in self._builtin

    def names(self) -> tuple[str, ...]:
        """Built-in names, then registered ones, in order of registration."""
        return tuple(self._builtin) + tuple(n for n in self._user if n not in self._builtin)

    def registered(self) -> dict[str, Any]:
        """The entries registered from scripts (a copy)."""
        return dict(self._user)

    def key(self, names: tuple[str, ...] | None = None) -> tuple:
        """``((name, digest), ...)`` of registered entries (all, or those of ``names``
        that are registered), and for each ``"name:ARGUMENT"`` of ``names`` the entry's
        ``argument_digest(ARGUMENT)`` (e.g. a trained policy's files): part of the cache
        key of every program that uses them."""
        items = (
            self._user.items()
            if names is None
            else [(n, self._user[n.lower()]) for n in names if n.lower() in self._user]
        )
        out = tuple((n, code_digest(o)) for n, o in items)
        for n in names or ():  # "name:ARGUMENT": what the argument names (a file's digest)
            if isinstance(n, str) and ":" in n:
                base, _, arg = n.partition(":")
                digest = getattr(self._entry(base.lower()), "argument_digest", None)
                out += ((n, digest(arg) if digest else ""), *self.key((base,)))
        return out


def check_callable(kind: str, name: str, fn: Callable | None) -> None:
    """One-line ``TypeError`` unless ``fn`` is callable (or None)."""
    if fn is not None and not callable(fn):
        raise TypeError(f"{kind} {name!r}: {type(fn).__name__} is not callable")


#: planners by name (:mod:`mjx_radar.planners`): the paper's MPPI, "hold" (radars keep
#: still), and those of :func:`mjx_radar.register_planner`
PLANNERS = Registry(
    "planner",
    {
        "mppi": "mjx_radar.planners.mppi:MPPIPlanner",
        "hold": "mjx_radar.planners.mppi:HoldPlanner",
        "ps": "mjx_radar.planners.zoo:PredictiveSamplingPlanner",
        "cem": "mjx_radar.planners.zoo:CEMPlanner",
        "grad": "mjx_radar.planners.zoo:GradientPlanner",
        "hybrid": "mjx_radar.planners.zoo:HybridPlanner",
        "cmaes": "mjx_radar.planners.evolution:CMAESPlanner",
        "sep-cmaes": "mjx_radar.planners.evolution:SepCMAESPlanner",
        "policy": "mjx_radar.learning.policy:PolicyPlanner",  # policy:DIR (docs/learning.md)
        # the same policy with the keep-out shield at deployment (learning/shield.py)
        "shielded-policy": "mjx_radar.learning.policy:ShieldedPolicyPlanner",
    },
)
#: trackers by name (:mod:`mjx_radar.env.filter_ops`): ``[filter] tracker``
TRACKERS = Registry(
    "tracker",
    {
        "ckf": "mjx_radar.env.filter_ops:joint_ckf",
        "bank": "mjx_radar.env.filter_ops:ckf_bank",
        "imm": "mjx_radar.env.filter_ops:imm_bank",
        "pda": "mjx_radar.env.filter_ops:pda_bank",
        "jpda": "mjx_radar.env.association_ops:jpda_bank",
        "gnn": "mjx_radar.env.association_ops:gnn_bank",
        "mht": "mjx_radar.env.mht_ops:mht_bank",
        "managed": "mjx_radar.env.managed:managed_tracker",
    },
)
#: associators of unlabelled scans by name (:mod:`mjx_radar.env.trackers`): ``[tracker]
#: association``. A built-in entry is the per-target bank that runs it (``factory(task,
#: params) -> FilterOps``); one of :func:`mjx_radar.register_associator` is
#: ``factory(task, params) -> associate`` (:class:`mjx_radar.contracts.AssociatorFactory`),
#: which drives the bank and the managed track table alike
ASSOCIATORS = Registry(
    "associator",
    {
        "pda": "mjx_radar.env.filter_ops:pda_bank",
        "jpda": "mjx_radar.env.association_ops:jpda_bank",
        "gnn": "mjx_radar.env.association_ops:gnn_bank",
        "mht": "mjx_radar.env.mht_ops:mht_bank",
    },
)
#: cost terms of the planner's objective by name (:mod:`mjx_radar.task.costs`): the
#: built-in ones, each in the objective of the scenarios it applies to, then those of
#: :func:`mjx_radar.register_cost_term` in order of registration
COST_TERMS = Registry(
    "cost term",
    {
        name: f"mjx_radar.task.costs:{name}"
        for name in (
            "information",
            "radar_radar",
            "radar_target",
            "obstacle",
            "moving_obstacle",
            "terrain_slope",
            "control_effort",
            "association",
        )
    },
)
#: sensors (measurement models) by name (:mod:`mjx_radar.estimation.sensor.measurement`):
#: ``[measurement] model``
SENSORS = Registry(
    "sensor",
    {
        "range": "mjx_radar.estimation.sensor.measurement:RangeModel",
        "range-azimuth": "mjx_radar.estimation.sensor.measurement:RangeAzimuthModel",
    },
)
