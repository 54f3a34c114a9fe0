"""The plug-in contracts, one per kind, checked where a plug-in is registered.

Each kind of plug-in is a :class:`typing.Protocol`: what the simulator calls on it.
:func:`check` runs at ``register_*`` (:class:`mjx_radar.registry.Registry`) and refuses
an object that cannot keep its contract, in one line naming the plug-in and what is
missing, before anything is traced:

* :class:`PlannerPlugin`: a class (or factory ``env -> planner``) made with the
  environment, with ``init()`` and ``plan(carry, obs, key) -> (action [N, 2], carry)``
  (``record(carry, action)`` optional);
* :class:`TrackerFactory`: ``factory(task, params) -> FilterOps``;
* :class:`AssociatorFactory`: ``factory(task, params) -> associate``, the association of
  unlabelled scans to tracks (``[tracker] association``; it drives the per-target bank
  and the managed track table);
* :class:`SensorPlugin`: a ``MeasurementModel`` subclass made without arguments, or an
  instance of one that carries its own parameters, with ``dim >= 1`` and its five methods;
* :class:`CostTermPlugin`: ``fn(h: Horizon, task, params) -> [H]``, a cost per horizon
  step (``mjx_radar.register_cost_term``, which also takes the scenarios it is for).

A base class's method that only raises (``Planner.plan``, ``MeasurementModel.predict``)
is marked :func:`placeholder`: a subclass that does not override it (``plan``
misspelt) is refused by name. :class:`PluginError` is a plug-in's own failure while
it is called (:mod:`mjx_radar.plugin_errors`).
"""

from __future__ import annotations

import inspect
from typing import Any, Protocol, runtime_checkable

from mjx_radar.io.checks import InputError


class PluginError(InputError):
    """A plug-in broke its contract or raised while it was called (one line; the user's
    own frames, if any, in :attr:`frames`)."""

    frames: str = ""


@runtime_checkable
class PlannerPlugin(Protocol):
    """What the closed loop calls on a planner made for an environment."""

    def init(self) -> Any: ...

    def plan(self, carry: Any, obs: Any, key: Any) -> tuple[Any, Any]: ...


class TrackerFactory(Protocol):
    """``factory(task, params) -> FilterOps`` (:class:`mjx_radar.env.filter_ops.FilterOps`)."""

    def __call__(self, task: Any, params: Any) -> Any: ...


class AssociatorFactory(Protocol):
    """``factory(task, params) -> associate``, with (K tracks, N radars, L returns each)::

        associate(means [K, 6], covs [K, 6, 6], live [K], zs [N, L, dim], valid [N, L],
                  radar_pos [N, 3]) -> (means [K, 6], covs [K, 6, 6], nll [K, N, L])

    the tracks' posterior after every radar's scan and each return's negative
    log-likelihood under each track (``+inf`` outside its gate; the managed track table
    reads its claims and hits from it, :mod:`mjx_radar.estimation.tracks.track_update`).
    Pure JAX, static shapes."""

    def __call__(self, task: Any, params: Any) -> Any: ...


@runtime_checkable
class SensorPlugin(Protocol):
    """A measurement model (:class:`mjx_radar.estimation.sensor.measurement.MeasurementModel`)."""

    name: str
    dim: int

    def predict(self, radar_pos: Any, target_pos: Any) -> Any: ...

    def variance(self, z_hat: Any, params: Any, ccr: Any) -> Any: ...

    def sample(self, key: Any, radar_pos: Any, target_pos: Any, params: Any) -> Any: ...

    def residual(self, a: Any, b: Any) -> Any: ...

    def pair_information(self, dx: Any, dy: Any, dz: Any, params: Any, ccr: Any) -> Any: ...


class CostTermPlugin(Protocol):
    """``fn(h, task, params) -> [H]`` (:class:`mjx_radar.task.costs.Horizon`): pure JAX."""

    def __call__(self, h: Any, task: Any, params: Any) -> Any: ...


#: each kind's methods and how many arguments each takes (after ``self``)
METHODS = {
    "planner": {"init": 0, "plan": 3},
    "sensor": {"predict": 2, "variance": 3, "sample": 4, "residual": 2, "pair_information": 5},
}
#: the kinds registered as ``factory(task, params)`` and what the factory returns
FACTORIES = {"tracker": "FilterOps", "associator": "associate"}
#: names no plug-in may take: ``auto`` means "chosen from the scenario's options"
RESERVED = {"tracker": ("auto",), "planner": ("auto",), "sensor": ("auto",)}


def placeholder(fn):
    """Marks a base class's method that a plug-in must override."""
    fn.__placeholder__ = True
    return fn


def takes(fn, n: int) -> bool:
    """Whether ``fn`` can be called with ``n`` positional arguments (and ``argument=``,
    for an entry selected as ``name:ARGUMENT``)."""
    extra = {"argument": ""} if getattr(fn, "takes_argument", False) else {}
    try:
        inspect.signature(fn).bind(*range(n), **extra)
    except TypeError:
        return False
    except ValueError:  # no signature (a builtin): assume it can
        return True
    return True


def _check_methods(kind: str, name: str, cls: type) -> None:
    for method, n in METHODS[kind].items():
        fn = inspect.getattr_static(cls, method, None)
        fn = getattr(fn, "__func__", fn)  # staticmethod / classmethod
        if fn is None or not callable(fn) or getattr(fn, "__placeholder__", False):
            missing = [m for m in METHODS[kind] if _missing(cls, m)]
            raise PluginError(
                f"{kind} {name!r}: {cls.__name__} has no {method}() (a {kind} defines "
                f"{', '.join(f'{m}()' for m in METHODS[kind])}; missing: {', '.join(missing)})"
            )
        if not takes(getattr(cls, method), n + 1):
            args = "self" + "".join(", x" for _ in range(n))
            raise PluginError(
                f"{kind} {name!r}: {cls.__name__}.{method}{inspect.signature(fn)} must take "
                f"({args}): {n} argument(s) after self"
            )


def _missing(cls: type, method: str) -> bool:
    fn = inspect.getattr_static(cls, method, None)
    fn = getattr(fn, "__func__", fn)
    return fn is None or not callable(fn) or getattr(fn, "__placeholder__", False)


def check(kind: str, name: str, obj: Any) -> None:
    """Refuses ``obj`` as a ``kind`` plug-in called ``name`` unless it keeps the contract.

    Raises:
        PluginError: one line naming the plug-in and what is missing or wrong.
    """
    what = type(obj).__name__
    if kind == "planner":
        if inspect.isclass(obj):
            _check_methods("planner", name, obj)
            if not takes(obj, 1):
                raise PluginError(
                    f"planner {name!r}: {obj.__name__}{inspect.signature(obj)} must be made "
                    "with the environment: def __init__(self, env)"
                )
        elif inspect.isfunction(obj) or inspect.ismethod(obj):
            if not takes(obj, 1):
                raise PluginError(
                    f"planner {name!r}: the factory {obj.__name__}{inspect.signature(obj)} "
                    "must take the environment: factory(env) -> planner"
                )
        elif not callable(obj) or isinstance(obj, PlannerPlugin):
            raise PluginError(
                f"planner {name!r}: register the class (or a factory env -> planner), "
                f"not an instance of {what}"
            )
    elif kind in FACTORIES:
        if not callable(obj):
            raise PluginError(
                f"{kind} {name!r}: a factory(task, params) -> {FACTORIES[kind]}, not a {what}"
            )
        if not takes(obj, 2):
            raise PluginError(
                f"{kind} {name!r}: the factory {getattr(obj, '__name__', what)}"
                f"{inspect.signature(obj)} must take (task, params)"
            )
    elif kind == "cost term":
        if not takes(obj, 3):
            raise PluginError(
                f"cost term {name!r}: {getattr(obj, '__name__', what)}() must take "
                "(h, task, params)"
            )
    elif kind == "sensor":
        made, label = _made_sensor(name, obj)
        dim = getattr(made, "dim", None)
        if isinstance(dim, bool) or not isinstance(dim, int) or dim < 1:
            raise PluginError(
                f"sensor {name!r}: {label}.dim = {dim!r}: must be an integer >= 1 "
                "(components per measurement)"
            )


def _made_sensor(name: str, obj: Any) -> tuple[Any, str]:
    """``(the sensor made, its name in messages)`` of a registered sensor: a class made
    without arguments, or an instance carrying its own parameters (hashable: the
    compiled programs are keyed on it)."""
    if inspect.isclass(obj):
        _check_methods("sensor", name, obj)
        try:
            return obj(), obj.__name__
        except Exception as err:  # noqa: BLE001 -- the user's class: one line
            raise PluginError(
                f"sensor {name!r}: {obj.__name__}() cannot be made without arguments "
                f"({type(err).__name__}: {err}); or register an instance that carries "
                "its parameters"
            ) from None
    _check_methods("sensor", name, type(obj))
    try:
        hash(obj)
    except TypeError:
        raise PluginError(
            f"sensor {name!r}: the {type(obj).__name__} instance is not hashable; make "
            "the class a frozen dataclass (compiled programs are keyed on the sensor)"
        ) from None
    return obj, type(obj).__name__
